"""report.pdf: the study name, the date and "page N of M" on every page, pictures kept whole
(each on one page), a table kept on one page; ``lumijax report --pdf``; and the error when
WeasyPrint is missing. Read back with pypdf."""

from __future__ import annotations

import base64
import io
import re
import sys

import numpy as np
import pytest

from lumijax.cli import main
from lumijax.errors import OutputError
from lumijax.report import render_report, report_context

pypdf = pytest.importorskip("pypdf")


@pytest.fixture
def weasy():
    from lumijax.report._pdf import require_pdf

    try:
        return require_pdf()
    except OutputError as e:
        pytest.skip(str(e))


COLOURS = [(200, 30, 30), (30, 160, 60), (40, 60, 200), (230, 180, 20)]


def _png(rgb, size=(160, 120)) -> str:
    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGB", size, rgb).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def test_pdf_pages_carry_name_date_and_number(two_rooms, weasy, tmp_path):
    from lumijax.report._pdf import write_pdf

    study, results = two_rooms
    ctx = report_context(study, results, pictures=False)
    # four pictures, small (WeasyPrint is slow on big ones) but each a figure with a caption
    ctx["views"] = [{"name": f"v{i}", "kind": "realistic", "src": _png(c),
                     "caption": f"picture {i}"} for i, c in enumerate(COLOURS)]
    path = write_pdf(render_report(ctx), tmp_path / "report.pdf")
    reader = pypdf.PdfReader(path)
    n = len(reader.pages)
    assert n >= 3
    texts = [p.extract_text() for p in reader.pages]
    for i, text in enumerate(texts):
        assert "Two rooms" in text, i
        assert f"Generated {ctx['generated']}" in text, i
        assert f"page {i + 1} of {n}" in text, i
    # every figure whole on one page: each picture drawn once, on the page of its caption
    colour = {}  # image object number -> which of COLOURS it is
    for im in reader.pages[0].images:  # the pages share one resource dictionary
        rgb = np.asarray(im.image.convert("RGB"), float).reshape(-1, 3).mean(axis=0)
        colour[im.indirect_reference.idnum] = int(np.argmin(np.abs(rgb - COLOURS).sum(axis=1)))
    drawn = []
    for k, page in enumerate(reader.pages):
        xobjects = page["/Resources"].get("/XObject", {})
        for name in re.findall(rb"/([^\s/\[\]<>()]+)\s+Do", page.get_contents().get_data()):
            ref = xobjects.raw_get("/" + name.decode())  # the reference, not the image
            if ref.idnum in colour:
                drawn.append((colour[ref.idnum], k))
    assert sorted(c for c, _ in drawn) == [0, 1, 2, 3], drawn
    for c, k in drawn:
        assert f"picture {c}" in texts[k]
    # the grids table on one page: its header and both rows together
    grid_pages = [i for i, t in enumerate(texts) if "Illuminance on the calculation grids" in t]
    assert len(grid_pages) == 1
    t = texts[grid_pages[0]]
    assert "Eavg ≥ 50 lx" in t and "Eavg ≥ 500 lx" in t


def test_report_pdf_subcommand(box_room, write_study, weasy, tmp_path):
    cfg = write_study(box_room)
    out = tmp_path / "rep"
    assert main(["report", str(cfg), "--out", str(out), "--no-pictures", "--pdf"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["report.html", "report.pdf"]
    reader = pypdf.PdfReader(out / "report.pdf")
    assert "cli room" in reader.pages[0].extract_text()
    assert "Luminaire schedule" in "".join(p.extract_text() for p in reader.pages)


def test_pdf_without_weasyprint_names_the_extra(box_room, write_study, monkeypatch, capsys,
                                                tmp_path):
    cfg = write_study(box_room)
    monkeypatch.setitem(sys.modules, "weasyprint", None)  # import weasyprint -> ImportError
    assert main(["report", str(cfg), "--out", str(tmp_path / "o"), "--pdf"]) == 1
    err = capsys.readouterr().err
    assert "lumijax[pdf]" in err and "WeasyPrint" in err
    assert not (tmp_path / "o").exists()  # refused before computing anything
