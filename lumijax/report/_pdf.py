"""``report.pdf``: the report's own HTML laid out on A4 pages by WeasyPrint.

The page furniture comes from the template's print style sheet (``@page``): the study name at
the top left of every page, the date it was made at the top right, "page N of M" at the bottom;
tables, figures and sections are kept whole where they fit on a page, and a table that runs on
repeats its header. WeasyPrint is the optional extra ``lumijax[pdf]`` and needs the Pango
library of the system (Debian: ``apt-get install libpango-1.0-0 libpangoft2-1.0-0``).
"""

from __future__ import annotations

from pathlib import Path

from .._atomic import atomic_path
from ..errors import OutputError

__all__ = ["require_pdf", "write_pdf"]


def require_pdf():
    """The ``weasyprint`` module, or an :class:`OutputError` saying what to install."""
    try:
        import weasyprint
    except ImportError:
        raise OutputError("a PDF report needs WeasyPrint: pip install 'lumijax[pdf]'",
                          key="--pdf") from None
    except OSError as e:  # the package is there, the system's Pango is not
        raise OutputError(f"WeasyPrint cannot load the Pango library ({e}): install it "
                          "(Debian: apt-get install libpango-1.0-0 libpangoft2-1.0-0)",
                          key="--pdf") from None
    return weasyprint


def write_pdf(html: str, path: str | Path) -> Path:
    """Lay out the report's ``html`` (self-contained: nothing is fetched) on pages and write
    the PDF to ``path`` atomically; return the path."""
    weasyprint = require_pdf()
    path = Path(path)
    if not path.parent.is_dir():
        raise OutputError("folder does not exist", file=path.parent)
    from weasyprint.urls import URLFetcher

    # data URIs only: the report holds every picture inline, and its PDF never reaches out
    doc = weasyprint.HTML(string=html, url_fetcher=URLFetcher(allowed_protocols=("data",)))
    with atomic_path(path, what="report", suffix=".pdf") as tmp:
        doc.write_pdf(str(tmp))
    return path

