"""report.html in a real browser (headless Chromium through Playwright): every picture loads
and is drawn at a size, and no text box overlaps a picture or one picture another, on a wide
and a narrow window. Skips without Playwright or a Chromium binary (``LUMIJAX_CHROMIUM``)."""

from __future__ import annotations

import base64
import io
import os
import shutil

import pytest

from lumijax.report import render_report, report_context

sync_api = pytest.importorskip("playwright.sync_api")
CHROMIUM = os.environ.get("LUMIJAX_CHROMIUM") or shutil.which("chromium") or shutil.which(
    "chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium binary")

TEXT = "h1, h2, h3, p, figcaption, th, td, li, .card, .note"
BOXES = """(sel) => Array.from(document.querySelectorAll(sel)).map(e => {
  const r = e.getBoundingClientRect();
  return {x0: r.left, y0: r.top + window.scrollY, x1: r.right, y1: r.bottom + window.scrollY,
          ok: e.tagName !== 'IMG' || (e.complete && e.naturalWidth > 0),
          what: e.tagName + ' ' + (e.getAttribute('alt') || e.textContent.slice(0, 40))};
})"""


def _png(size, rgb) -> str:
    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGB", size, rgb).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def _overlap(a, b) -> float:
    w = min(a["x1"], b["x1"]) - max(a["x0"], b["x0"])
    h = min(a["y1"], b["y1"]) - max(a["y0"], b["y0"])
    return max(w, 0.0) * max(h, 0.0)


def test_no_text_box_overlaps_a_picture(two_rooms, tmp_path):
    study, results = two_rooms
    ctx = report_context(study, results, pictures=False)
    # pictures of three shapes: a wide panorama, a tall view, a square plot
    ctx["views"] = [{"name": f"v{i}", "kind": "realistic", "src": _png(size, (90, 60 + 60 * i, 40)),
                     "caption": f"picture {i} " * 12}
                    for i, size in enumerate([(1600, 400), (400, 900), (600, 600)])]
    for g in ctx["grids"]:
        g["picture"] = {"kind": "map", "src": _png((1200, 820), (40, 120, 90)),
                        "caption": f"{g['name']}: a map."}
    path = tmp_path / "report.html"
    path.write_text(render_report(ctx), encoding="utf-8")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        try:
            for width in (1280, 700):
                page = browser.new_page(viewport={"width": width, "height": 900})
                page.goto(path.as_uri())
                page.wait_for_load_state("load")
                imgs = page.evaluate(BOXES, "img")
                texts = page.evaluate(BOXES, TEXT)
                assert len(imgs) == 3 + len(ctx["grids"])  # views and grid pictures
                for im in imgs:
                    assert im["ok"], im["what"]
                    assert im["x1"] - im["x0"] > 50 and im["y1"] - im["y0"] > 50, im
                    assert im["x1"] <= width + 0.5, im  # inside the window: no sideways scroll
                for a in imgs:
                    for t in texts:
                        assert _overlap(a, t) < 1.0, (width, a["what"], t["what"])
                    for b in imgs:
                        assert a is b or _overlap(a, b) < 1.0, (width, a["what"], b["what"])
                page.close()
        finally:
            browser.close()
