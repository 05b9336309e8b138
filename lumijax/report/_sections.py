"""Sections that other layers add to the report (glare, compliance, …).

A :class:`ReportSection` is a titled block of ready HTML. ``_html.section_builders`` lists the
functions that make them; the template draws the ``first`` ones (the compliance verdict) before
the summary, so that the report opens with them, and the others after the built-in sections, in
order.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ReportSection"]


@dataclass(frozen=True)
class ReportSection:
    """One section of ``report.html``: ``id`` (the HTML anchor), ``title``, an optional ``lead``
    line, and ``html``, its body (trusted markup, inserted as it is: escape what you put in).
    ``first``: open the report with it (before the summary)."""

    id: str
    title: str
    html: str
    lead: str = ""
    first: bool = False
