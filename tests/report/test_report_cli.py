"""The report and view subcommands, the report step of ``run``, and ``[cameras]`` errors."""

from __future__ import annotations

import sys

import pytest

from lumijax.cli import main
from lumijax.config import parse_config
from lumijax.errors import ConfigError

CAMERAS = """
[cameras.inside]
position = [3.5, 0.5, 2.0]
target = [1, 2.5, 0.5]
fov_deg = 70
size = [320, 200]
[cameras.plan]
position = [2, 1.5, 8]
target = [2, 1.5, 0]
up = [0, 1, 0]
kind = "falsecolour"
quantity = "illuminance"
scale = "linear"
levels = [10, 20]
size = [320, 200]
"""


def test_run_writes_the_report_unless_told_not_to(box_room, write_study, tmp_path, capsys):
    cfg = write_study(box_room + CAMERAS)
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out)]) == 0
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "cli room" in page and "floor" in page
    assert "“inside”" in page and "“plan”" in page  # both configured cameras
    assert "report:" in capsys.readouterr().out
    out2 = tmp_path / "out2"
    assert main(["run", str(cfg), "--out", str(out2), "--no-report"]) == 0
    assert (out2 / "results.json").exists() and not (out2 / "report.html").exists()


def test_report_subcommand(box_room, write_study, tmp_path):
    cfg = write_study(box_room + CAMERAS)
    out = tmp_path / "rep"
    assert main(["report", str(cfg), "--out", str(out), "--no-pictures"]) == 0
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "floor" in page and "<img" not in page
    assert [p.name for p in out.iterdir()] == ["report.html"]  # atomic: no leftovers


def test_view_web_names_the_extra_when_trame_is_missing(box_room, write_study, monkeypatch, capsys):
    cfg = write_study(box_room + CAMERAS)
    monkeypatch.setitem(sys.modules, "trame", None)  # import trame -> ImportError
    assert main(["view", str(cfg), "--web"]) == 1
    err = capsys.readouterr().err
    assert "lumijax[view]" in err and "trame" in err


def test_view_without_a_display_points_to_web(box_room, write_study, monkeypatch, capsys):
    cfg = write_study(box_room + CAMERAS)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(cfg)]) == 1
    assert "lumijax view --web" in capsys.readouterr().err


def test_view_unknown_camera(box_room, write_study, capsys):
    cfg = write_study(box_room + CAMERAS)
    pytest.importorskip("pyvista")
    assert main(["view", str(cfg), "--camera", "nope"]) == 1
    assert "cameras: inside, plan" in capsys.readouterr().err


@pytest.mark.parametrize("camera, message", [
    ("position = [1, 1, 1]\ntarget = [1, 1, 1]", "no direction to look"),
    ("position = [1, 1, 5]\ntarget = [1, 1, 0]", "not parallel"),
    ("position = [0, 0, 0]\ntarget = [1, 0, 0]\nfov_deg = 180", "less than 180"),
    ("position = [0, 0, 0]\ntarget = [1, 0, 0]\nkind = \"photo\"", "'realistic'"),
])
def test_camera_config_errors(camera, message):
    with pytest.raises(ConfigError, match=message) as e:
        parse_config(f"[cameras.c1]\n{camera}\n")
    assert e.value.key.startswith("cameras.c1")
