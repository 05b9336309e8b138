"""The report's glare section: per observer the worst UGR, GR and TI, the luminaires that
contribute most, and a fisheye map of the sources its eye rates (docs/glare.md)."""

from __future__ import annotations

import base64
import html
import io

import numpy as np

from .._study import Study
from ..results import Results
from ._sections import ReportSection

__all__ = ["glare_sections", "fisheye_png"]


def _f(v, spec=".1f") -> str:
    return "—" if v is None else format(v, spec)


def glare_sections(study: Study, results: Results, pictures: bool) -> list[ReportSection]:
    """One section, when the study has ``[[observers]]``."""
    glare = results.glare
    if glare is None:
        return []
    data = glare.to_dict()
    rows = []
    for name, d in data.items():
        w = d["worst"]
        top = ", ".join(f"{html.escape(t['name'])} {100 * t['share']:.0f} %"
                        for t in d["top_luminaires"]["gr"][:3]) or "—"
        cells = [html.escape(name), str(len(d["directions"])),
                 _f((w["ugr"] or {}).get("value")), _f((w["gr"] or {}).get("value")),
                 _f((w["gr"] or {}).get("azimuth_deg"), "g"), _f((w["ti"] or {}).get("value")),
                 top]
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    head = "".join(f"<th>{h}</th>" for h in ("observer", "directions", "UGR", "GR",
                                             "worst GR at (deg)", "TI (%)",
                                             "largest veiling shares (GR)"))
    body = f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
    if pictures:
        figs = []
        for i, name in enumerate(data):
            views = glare.views_of(i)
            w = data[name]["worst"]
            j = (w["gr"] or w["ugr"] or {"direction": 0})["direction"]
            png = fisheye_png(glare, int(views[j]), title=_title(name, data[name]["directions"][j]))
            uri = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
            figs.append(f'<figure><img src="{uri}" alt="sources seen by {html.escape(name)}">'
                        f"<figcaption>{html.escape(name)}: the sources its eye rates in its "
                        "worst direction, angular fisheye (centre: the line of sight)"
                        "</figcaption></figure>")
        body += "".join(figs)
    return [ReportSection(
        id="glare", title="Glare",
        lead="UGR (CIE 117), GR (CIE 112 / EN 12464-2) and TI (CIE 140) per observer, worst "
             "over its directions; docs/glare.md says how each is computed.",
        html=body)]


def _title(name: str, d: dict) -> str:
    parts = [f"{name}, azimuth {d['azimuth_deg']:g}°"]
    for key, label in (("ugr", "UGR"), ("gr", "GR"), ("ti_percent", "TI %")):
        if d.get(key) is not None:
            parts.append(f"{label} {d[key]:.1f}")
    return " · ".join(parts)


def fisheye_png(glare, view: int, *, title: str = "", size_in: float = 4.5) -> bytes:
    """An angular fisheye (radius ∝ angle off the line of sight, 90° at the rim) of the
    sources view ``view`` rates: each a disc of the area of its solid angle's apparent size
    (at least a few points), coloured by log luminance (cd/m²)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    f = np.asarray(glare.model.view_direction[view], np.float64)
    right = np.cross(f, [0.0, 0.0, 1.0])
    right /= max(np.linalg.norm(right), 1e-12)
    up = np.cross(right, f)
    src = [s for s in glare.seen_sources(view) if np.linalg.norm(s["direction"]) > 0]
    fig, ax = plt.subplots(figsize=(size_in, size_in), dpi=100)
    ax.add_patch(plt.Circle((0, 0), 90, fill=False, color="0.6"))
    for r in (30, 60):
        ax.add_patch(plt.Circle((0, 0), r, fill=False, color="0.85", lw=0.6))
    if src:
        d = np.array([s["direction"] for s in src])
        theta = np.degrees(np.arccos(np.clip(d @ f, -1, 1)))
        phi = np.arctan2(d @ up, d @ right)
        lum = np.array([s["luminance_cdm2"] for s in src])
        radius = np.degrees(np.sqrt(np.array([s["solid_angle_sr"] for s in src]) / np.pi))
        sc = ax.scatter(theta * np.cos(phi), theta * np.sin(phi),
                        s=np.maximum((2.0 * radius) ** 2 * 3.0, 6.0), c=np.log10(lum),
                        cmap="inferno", edgecolors="0.3", linewidths=0.3)
        fig.colorbar(sc, ax=ax, shrink=0.7, label="log10 luminance (cd/m²)")
    ax.set_xlim(-95, 95)
    ax.set_ylim(-95, 95)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()
