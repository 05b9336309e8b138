"""The report's compliance section: the verdict per standard, first in the report
(docs/compliance.md): per criterion the maintained value, the initial value, the limit, pass or
fail and the margin, and the criteria not computed with why."""

from __future__ import annotations

import html

from .._study import Study
from ..results import Results
from ._sections import ReportSection

__all__ = ["compliance_sections"]


def _f(v, unit: str = "") -> str:
    if v is None:
        return "—"
    s = f"{v:,.0f}" if abs(v) >= 100 else f"{v:.3g}"
    return f"{s} {unit}".strip()


def compliance_sections(study: Study, results: Results, pictures: bool) -> list[ReportSection]:
    """One section opening the report, when the study has ``[compliance]``."""
    comp = results.compliance
    if comp is None:
        return []
    rows = []
    for r in comp.rows:
        lim = "—" if r["limit"] is None else (
            ("≥ " if r["sense"] == "min" else "≤ ") + _f(r["limit"], r["unit"]))
        status = r["status"]
        colour = {"pass": "#1a7f37", "fail": "#c0392b"}.get(status, "#666")
        crit = r["quantity"] + (f" ({r['when']})" if r["when"] else "")
        cells = [r["standard"], r["area"], crit, _f(r["value"], r["unit"]),
                 _f(r["initial"], r["unit"]), lim, _f(r["margin"], r["unit"]),
                 r["source"] or "", r["note"] or ""]
        tds = "".join(f"<td>{html.escape(str(c))}</td>" for c in cells)
        rows.append(f'<tr>{tds}<td style="color:{colour};font-weight:600">'
                    f"{html.escape(status)}</td></tr>")
    head = "".join(f"<th>{h}</th>" for h in ("standard", "area", "criterion", "maintained",
                                             "initial", "limit", "margin", "from", "note",
                                             "result"))
    mf = ", ".join(f"{html.escape(n)} {m:.3f}" for n, m in
                   comp.to_dict()["maintenance_factor"].items())
    verdict = ("compliant: every computed criterion passes" if comp.compliant else
               "not compliant: " + ", ".join(
                   html.escape(f"{r['area']}.{r['quantity']}") for r in comp.rows
                   if r["passed"] is False) + " fail")
    body = (f'<p style="font-size:1.15em;font-weight:600">{verdict}</p>'
            f"<p>maintenance factors (CIE 97:2005) per network: {mf}</p>"
            f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>")
    return [ReportSection(
        id="compliance", title="Compliance",
        lead="The verdict per standard at the design's dimmers: maintained values (MF × initial) "
             "judged, initial values beside them; docs/compliance.md says how each quantity is "
             "computed and which table rows are transcribed.",
        html=body, first=True)]
