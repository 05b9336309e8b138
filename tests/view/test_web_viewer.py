"""``lumijax view --web`` end to end: serve on localhost, drive headless Chromium, move a
slider, see the picture change. Skips without trame, playwright or a Chromium binary."""

from __future__ import annotations

import io
import os
import shutil
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

pytest.importorskip("trame")
pytest.importorskip("trame_vtk")
pytest.importorskip("trame_vuetify")
sync_api = pytest.importorskip("playwright.sync_api")

CHROMIUM = os.environ.get("LUMIJAX_CHROMIUM") or shutil.which("chromium") or shutil.which(
    "chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium binary")

def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _canvas(page) -> np.ndarray:
    from PIL import Image

    png = page.locator("canvas").first.screenshot()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), float)


def test_slider_changes_the_picture(box_room, write_study):
    cfg = write_study(box_room)
    port = _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "lumijax.cli", "view", str(cfg), "--web", "--port", str(port)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True).start()
    try:
        deadline = time.monotonic() + 90
        while not any("App running" in ln for ln in lines):
            assert proc.poll() is None, "".join(lines)
            assert time.monotonic() < deadline, "server did not start:\n" + "".join(lines)
            time.sleep(0.2)
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
            try:
                page = browser.new_page(viewport={"width": 1100, "height": 700})
                page.goto(f"http://127.0.0.1:{port}/", timeout=30_000)
                page.wait_for_selector("canvas", timeout=30_000)
                deadline = time.monotonic() + 30
                before = _canvas(page)
                while before.std() < 5:  # wait for the first streamed picture
                    assert time.monotonic() < deadline, "no picture arrived"
                    time.sleep(0.3)
                    before = _canvas(page)
                # drag network a's slider to its left end (dimmer 0)
                box = page.locator(".slider-dimmer_0 .v-slider-track").bounding_box()
                page.mouse.click(box["x"] + 1, box["y"] + box["height"] / 2)
                deadline = time.monotonic() + 30
                after = _canvas(page)
                while np.abs(after - before).max() < 30:
                    assert time.monotonic() < deadline, "the picture did not change"
                    time.sleep(0.3)
                    after = _canvas(page)
                time.sleep(1.0)
                after = _canvas(page)
                # one of two equal lamps off: the room is darker (the picture is streamed as
                # JPEG, so compare brightness, not exact values)
                assert after.mean() < before.mean() - 3
            finally:
                browser.close()
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)
