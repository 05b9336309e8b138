"""The command line: outputs, the results.json contract, clean errors, nothing half-written."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from lumijax.cli import main


def test_run_writes_the_documented_contract(box_room, write_study, tmp_path, capsys):
    cfg = write_study(box_room)
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "floor" in printed and "U0" in printed
    res = json.loads((out / "results.json").read_text())
    assert res["study"] == "cli room"
    assert isinstance(res["lumijax_version"], str)
    g = res["grids"]["floor"]
    assert set(g) >= {"points", "normals", "illuminance_lux", "by_network_lux", "stats"}
    assert set(g["stats"]) == {"avg", "min", "max", "u0", "ud"}
    lux = np.array(g["illuminance_lux"])
    a, b = np.array(g["by_network_lux"]["a"]), np.array(g["by_network_lux"]["b"])
    np.testing.assert_allclose(lux, 0.5 * a + 1.0 * b, rtol=1e-12)
    # independent closed form for network b's single isotropic source
    p = np.array(g["points"]) - [3, 1.5, 2.5]
    np.testing.assert_allclose(b, 2000 / (4 * np.pi) * -p[:, 2] / np.linalg.norm(p, axis=1) ** 3,
                               rtol=1e-6)
    assert res["networks"]["a"] == {"dimmer": 0.5, "luminaires": ["A1"],
                                    "flux_lm": pytest.approx(2000, rel=1e-4)}
    assert {"load", "direct_points", "total"} <= set(res["timing_s"])
    with open(out / "grids" / "floor.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["x", "y", "z", "lux"] and len(rows) == 48
    np.testing.assert_allclose([float(r["lux"]) for r in rows], lux, rtol=1e-5)
    png = out / "images" / "floor.png"
    assert png.stat().st_size > 10_000
    assert not [p for p in out.rglob("*") if p.name.startswith(".")]  # no staging leftovers


def test_check_json_summary(box_room, write_study, capsys):
    assert main(["check", str(write_study(box_room)), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary == {
        "triangles": 12, "luminaires": 2, "networks": 2, "grid_points": 48,
        "photometry": {"iso": {"rated_lm": pytest.approx(2000),
                               "integrated_lm": pytest.approx(2000, rel=1e-4)}},
    }


def test_bad_config_is_one_line_without_traceback(box_room, write_study, tmp_path, capsys):
    cfg = write_study(box_room.replace("dimmer = 0.5", "dimmer = 2"))
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"lumijax: error: {cfg}:12: networks.a.dimmer:")
    assert "Traceback" not in err and err.count("\n") == 1
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("stage", ["map", "report"])
def test_failure_while_writing_leaves_previous_results_untouched(box_room, write_study, tmp_path,
                                                                  monkeypatch, stage):
    """A failure drawing a map (results staged half-way) or writing the report (every other
    file staged) leaves the previous set, byte for byte, and no staging folder."""
    cfg = write_study(box_room)
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out), "--no-images", "--no-report"]) == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}

    import lumijax.report
    import lumijax.report._falsecolour as falsecolour  # a lazy package: import it by name
    from lumijax.errors import OutputError

    def broken(*args, **kwargs):
        if stage == "map":
            raise OSError("disk full")
        raise OutputError("disk full", file=out / "report.html")

    if stage == "map":
        monkeypatch.setattr(falsecolour, "falsecolour_map", broken)
    else:
        monkeypatch.setattr(lumijax.report, "write_report", broken)
    cfg2 = write_study(box_room.replace("dimmer = 0.5", "dimmer = 0.1"), "other.toml")
    assert main(["run", str(cfg2), "--out", str(out)]) == 1
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    # no staging folder left beside out (the study's cache folder holds the first run's stored
    # solution, for dimmer-only reruns)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".lumijax-cache", "other.toml", "out",
                                                          "study.toml"]


def test_installed_entry_point_runs_as_a_process(box_room, write_study, tmp_path):
    cfg = write_study(box_room.replace("flux_lm = 2000", "flux_lm = -5"))
    proc = subprocess.run([sys.executable, "-m", "lumijax.cli", "check", str(cfg)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    assert "photometry.iso.flux_lm" in proc.stderr and "Traceback" not in proc.stderr


def test_demo_runs_the_bundled_study(tmp_path):
    # README's first command as a user runs it: its own process, in JAX's default float32 (not
    # the suite's x64), with its report
    out = tmp_path / "demo"
    proc = subprocess.run([sys.executable, "-m", "lumijax.cli", "demo", "--out", str(out),
                           "--timings"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert "Traceback" not in proc.stderr
    res = json.loads((out / "results.json").read_text())
    # the courtyard corner: two facades (S, E), per facade and kind a network, plus two
    assert set(res["grids"]) == {"S-wall", "S-columns", "E-wall", "E-columns", "court",
                                 "paths-eye"}
    assert set(res["networks"]) == {f"{f}-{k}" for f in "SE"
                                    for k in ("wash", "attic", "columns", "windows")} | {
                                        "floods", "paths"}
    for name in res["grids"]:
        assert (out / "images" / f"{name}.png").stat().st_size > 10_000
        assert res["grids"][name]["stats"]["avg"] > 0
    assert "S-wall" in proc.stdout and "where the time went" in proc.stdout
    # the demo designs to a standard: least power under the grids' limits and a GR ceiling of
    # 50 per visitor (EN 12464-2 Table 5.1.1); each visitor's worst GR is recomputed here from
    # CIE 112 with the entry's own veiling and environment luminances, and is within it
    con = res["optimisation"]["constrained"]
    assert con["verdict"] == "met" and con["objective_end"] < con["objective_start"]
    for name, obs in res["glare"].items():
        gr = max(27 + 24 * math.log10(d["veiling_cdm2"] / (0.035 * d["environment_cdm2"]) ** 0.9)
                 for d in obs["directions"] if d["veiling_cdm2"] > 0)
        assert obs["worst"]["gr"]["value"] == pytest.approx(gr, abs=1e-3), name
        assert gr <= 50 * (1 + 1e-3), name
    report = (out / "report.html").read_text(encoding="utf-8")
    assert all(name in report for name in [*res["grids"], *res["glare"]])


def test_a_one_point_grid_has_its_numbers_and_a_plan_not_a_blank_map(box_room, write_study,
                                                                      tmp_path):
    # A single point has no area to map: it is drawn as a plan of its point with its value
    # (docs/report.md, "Grid pictures"), never as an empty iso-lux map.
    import matplotlib.image as mpimg

    cfg = write_study(box_room + '[[grids]]\nname = "spot"\nkind = "points"\npoints = [[2, 1.5, 0.8]]\n')
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out)]) == 0
    assert (out / "grids" / "spot.csv").exists()
    assert (out / "images" / "floor.png").exists()
    picture = mpimg.imread(out / "images" / "spot.png")[..., :3]
    assert picture.std() > 0.05  # drawn, not one colour
