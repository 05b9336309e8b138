"""report.html: every grid's numbers and verdicts, per-network flux and power, self-contained,
the optimisation section exactly when there was one."""

from __future__ import annotations

import base64
import dataclasses
import html as htmlmod
import re
import shutil
import subprocess

import numpy as np
import pytest

from lumijax.report import grid_criteria, report_context, write_report


def _rows(page: str, section: str) -> dict[str, list[str]]:
    """Table rows of a section: first cell text -> the other cells' text."""
    body = re.split(f'<section id="{section}"[^>]*>', page, maxsplit=1)[1].split(
        "</section>", 1)[0]
    out = {}
    for row in re.findall(r"<tr>(.*?)</tr>", body, flags=re.S):
        cells = [htmlmod.unescape(re.sub(r"<[^>]+>", " ", c)).split()
                 for c in re.findall(r"<td[^>]*>(.*?)</td>", row, flags=re.S)]
        if cells:
            out[" ".join(cells[0])] = [" ".join(c) for c in cells[1:]]
    return out


def _num(text: str) -> float:
    return float(text.replace(",", ""))


def test_report_has_every_grids_numbers_and_verdict(two_rooms, tmp_path):
    study, results = two_rooms
    path = write_report(study, results, tmp_path / "report.html", pictures=False)
    page = path.read_text(encoding="utf-8")
    rows = _rows(page, "grids")
    assert set(rows) == set(results.grids)
    for name, g in results.grids.items():
        cells = rows[name]
        lux = g.illuminance_lux  # independent of the report: the statistics from the raw lux
        assert int(cells[0].replace(",", "")) == len(lux)
        for text, value in zip(cells[1:4], (lux.mean(), lux.min(), lux.max()), strict=True):
            assert _num(text) == pytest.approx(value, rel=5e-3, abs=5e-3)
        assert _num(cells[4]) == pytest.approx(lux.min() / lux.mean(), abs=0.006)
        assert _num(cells[5]) == pytest.approx(lux.min() / lux.max(), abs=0.006)
        target = g.target_lux
        assert cells[6] == f"Eavg ≥ {target:g} lx"
        assert cells[7] == ("met" if lux.mean() >= target else "not met")
    # the two floors: 1000 lm in a 3 x 3 m room cannot give 500 lx at dimmer 0.5
    assert rows["floor_right"][7] == "not met"


def test_networks_flux_and_power(two_rooms, tmp_path):
    study, results = two_rooms
    page = write_report(study, results, tmp_path / "r.html", pictures=False).read_text()
    rows = _rows(page, "networks")
    # 1000 lm isotropic lamp per network; dimmers 1.0 and 0.5
    assert rows["left"][1:5] == ["1", "100 %", "1,000", "1,000"]
    assert rows["right"][1:5] == ["1", "50 %", "1,000", "500"]
    assert "Power" not in page.split('id="networks"')[1].split("</section>")[0]
    # with power_w in the config, power at the dimmer appears (linear in the dimmer)
    nets = {k: v.model_copy(update={"power_w": 20.0}) if k == "right" else v
            for k, v in study.config.networks.items()}
    cfg = study.config.model_copy(update={"networks": nets})
    page = write_report(dataclasses.replace(study, config=cfg), results, tmp_path / "p.html",
                        pictures=False).read_text()
    rows = _rows(page, "networks")
    assert rows["right"][5:7] == ["20", "10"]
    assert rows["left"][5:7] == ["—", "—"]


def test_grid_criteria_closed_form():
    class G:
        target_lux, min_lux, max_lux, uniformity_min = 100.0, 40.0, 300.0, 0.5

    stats = {"avg": 120.0, "min": 50.0, "max": 310.0, "u0": 50 / 120, "ud": 50 / 310}
    got = {c["key"]: c["met"] for c in grid_criteria(G, stats)}
    assert got == {"target_lux": True, "min_lux": True, "max_lux": False,
                   "uniformity_min": False}
    assert grid_criteria(None, stats) == []


OPT = {
    "solver": "levenberg_marquardt", "variables": ["dimmers"], "iterations": 7,
    "converged": True, "objective_history": [100.0, 20.0, 3.0, 0.8, 0.5],
    "dimmers": {"left": 0.25, "right": 1.0}, "aims": {"L1": {"tilt": 5.0, "pan": -3.0,
                                                               "spin": 0.0}},
    "before": {"floor_left": {"avg": 61.0, "min": 30.0, "max": 90.0, "u0": 0.49, "ud": 0.33}},
    "after": {"floor_left": {"avg": 50.2, "min": 25.0, "max": 70.0, "u0": 0.5, "ud": 0.36}},
    "targets": [{"grid": "floor_left", "kind": "avg", "wanted": 50.0, "achieved": 50.2,
                 "met": True},
                {"grid": "floor_right", "kind": "avg", "wanted": 500.0, "achieved": 230.0,
                 "met": False}],
    "unmet": ["floor_right: Eavg 230 lx < 500 lx"],
}


class _Opt:
    def to_dict(self):
        return OPT


def test_optimisation_section_only_after_an_optimisation(two_rooms, tmp_path):
    study, results = two_rooms
    plain = write_report(study, results, tmp_path / "a.html", pictures=False).read_text()
    assert 'id="optimisation"' not in plain
    optimised = dataclasses.replace(results)
    object.__setattr__(optimised, "optimisation", _Opt())
    page = write_report(study, optimised, tmp_path / "b.html", pictures=False).read_text()
    assert 'id="optimisation"' in page
    sec = page.split('id="optimisation"')[1].split("</section>")[0]
    assert "levenberg_marquardt" in sec and "converged" in sec
    rows = _rows(page, "optimisation")
    assert rows["Eavg"][:2] == ["61", "50.2"]
    assert rows["left"][:2] == ["1", "0.25"]  # dimmer before (config) and after
    assert rows["L1"] == ["5", "-3", "0"]
    assert "<li>floor_right: Eavg 230 lx &lt; 500 lx</li>" in sec
    # the convergence plot is there, as an inline PNG
    assert re.search(r'<img src="data:image/png;base64,[^"]+" alt="objective per iteration"', sec)


def test_self_contained_with_pictures(two_rooms, tmp_path):
    study, results = two_rooms
    ctx = report_context(study, results)
    # overview camera: a realistic and a false-colour view; one map per grid; one polar plot
    assert [v["kind"] for v in ctx["views"]] == ["realistic", "falsecolour"]
    assert all(g["map"] for g in ctx["grids"])
    assert sum(ctx["timings"].values()) < 15.0
    # each network alone: closed rooms side by side along x, seen from the south-west, so the
    # left network's picture is bright on its left and dark on its right, and the other way
    from io import BytesIO

    from PIL import Image

    halves = {}
    for n in ctx["network_pages"]:
        img = np.asarray(Image.open(BytesIO(base64.b64decode(
            n["picture"]["src"].split(",", 1)[1]))).convert("L"), float)
        halves[n["name"]] = img[:, : img.shape[1] // 2].mean(), img[:, img.shape[1] // 2:].mean()
    assert halves["left"][0] > halves["left"][1] + 5
    assert halves["right"][1] > halves["right"][0] + 5
    page = write_report(study, results, tmp_path / "report.html").read_text()
    srcs = re.findall(r'<img src="([^"]+)"', page)
    assert len(srcs) == 2 + 2 + 1 + 2  # views, maps, polar diagram, each network alone
    for src in srcs:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    assert not re.search(r'(src|href)="(https?:)?//', page)  # nothing fetched from outside
    assert "<link" not in page and "<script" not in page


def _chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(_chromium() is None, reason="headless Chromium is not installed")
def test_report_renders_in_chromium(two_rooms, tmp_path):
    from PIL import Image

    study, results = two_rooms
    path = write_report(study, results, tmp_path / "report.html")
    shot = tmp_path / "shot.png"
    subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                    "--hide-scrollbars", f"--screenshot={shot}", "--window-size=1280,2400",
                    path.as_uri()], check=True, timeout=60, capture_output=True)
    img = np.asarray(Image.open(shot).convert("RGB"), float)
    assert img.shape == (2400, 1280, 3)
    # the header band in the report's accent blue (#1f4e79), the page below it light
    np.testing.assert_allclose(img[20, 640], [0x1F, 0x4E, 0x79], atol=3)
    assert img[400:, :60].mean() > 230
    # the realistic view's dark night background appears further down
    dark = np.all(img < 40, axis=-1).mean(axis=1)
    assert dark.max() > 0.3
