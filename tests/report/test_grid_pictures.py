"""Every grid kind draws something true: plane grids a map, points along a path a profile (lux
along each leg, the limits drawn), scattered points a plan with their values. Checked by the
pictures' content: colours where the values put them, the limit line where 10 lx lies."""

from __future__ import annotations

import io
import json
import re

import helpers as h
import numpy as np
import pytest

from lumijax.config import parse_config
from lumijax.report import lux_to_rgb
from lumijax.report._gridplots import grid_picture, path_legs, picture_kind
from lumijax.results import GridResult, Results

pytest.importorskip("matplotlib")

ACCENT = np.array([0x1F, 0x4E, 0x79]) / 255
RED = np.array([0xA4, 0x26, 0x2C]) / 255

# the demo's paths-eye: two legs at eye height, horizontal normals (a map would collapse them)
EYE = np.array([[13.2, y, 1.6] for y in (2, 3.84, 5.68, 7.52, 9.36, 11.2)]
               + [[x, 13.2, 1.6] for x in (24.4, 22.56, 20.72, 18.88, 17.04, 15.2)])
EYE_N = np.array([[0, 1, 0]] * 6 + [[-1, 0, 0]] * 6, float)
DESKS = np.array([[1, 1, 0.8], [3, 1.5, 0.8], [2, 4, 0.8], [5, 3, 0.8], [4.5, 0.5, 0.8]])


def _grid(name, points, normals, lux, shape=None) -> GridResult:
    return GridResult(name, np.asarray(points, float), np.asarray(normals, float), ("n",),
                      np.asarray(lux, float)[None], np.ones(1), shape=shape)


def _image(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), float) / 255


def _near(img, rgb, tol=0.06) -> np.ndarray:
    return np.all(np.abs(img - rgb) < tol, axis=-1)


def _lattice(n=5):
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])


def test_every_kind_gets_a_picture_kind():
    up = np.tile([0.0, 0.0, 1.0], (25, 1))
    assert picture_kind(_lattice(), up, (5, 5)) == "map"
    assert picture_kind(_lattice()[:5], up[:5], (1, 5)) == "profile"  # a plane grid of one row
    assert picture_kind(_lattice(), up) == "map"  # points over an area, one normal
    assert picture_kind(EYE, EYE_N) == "profile"
    assert [len(leg) for leg in path_legs(EYE)] == [6, 6]
    assert picture_kind(DESKS, up[:5]) == "plan"  # scattered: no path through them
    assert picture_kind(DESKS[:1], up[:1]) == "plan"
    assert picture_kind(DESKS[:2], up[:2]) == "plan"
    # the same lattice with normals that differ cannot be mapped face-on: not a map
    tilted = up.copy()
    tilted[0] = [1.0, 0.0, 0.0]
    assert picture_kind(_lattice(), tilted) != "map"


def test_profile_draws_the_values_and_the_limit_where_they_are():
    cfg = parse_config('[[grids]]\nname = "eye"\nkind = "points"\nmax_lux = 10\n'
                       'points = [[0, 0, 0]]\n').grids[0]
    lux = np.concatenate([np.linspace(0.0, 20.0, 6), np.full(6, 5.0)])
    pic = grid_picture(_grid("eye", EYE, EYE_N, lux), cfg, title="eye", size=(900, 600))
    assert pic.kind == "profile"
    img = _image(pic.png)
    h, w = img.shape[:2]
    line = _near(img, ACCENT)
    red = _near(img, RED, 0.08)
    left, right = line[:, : w // 2], line[:, w // 2:]
    assert left.sum() > 200 and right.sum() > 200  # one panel per leg, each with its curve
    # leg 1 runs linearly from 0 to 20 lx: 10 lx (the limit) is half way up its curve
    rows = np.flatnonzero(left.any(axis=1))
    legend = rows < 0.1 * h  # the legend's sample line, above the panels
    rows = rows[~legend]
    mid = (rows.min() + rows.max()) / 2
    red_rows = np.flatnonzero(red[:, : w // 2].sum(axis=1) > 0.25 * w / 2)
    assert red_rows.size, "the max_lux line is drawn"
    assert abs(red_rows.mean() - mid) < 4
    # leg 2 is at 5 lx everywhere: its curve is flat, below the limit line
    r2 = np.flatnonzero(right.sum(axis=1) > 40)
    assert r2.size and r2.min() > red_rows.max()
    # the points above the limit are marked red, above the line; leg 2's are not (the legend,
    # above the panels, is left out)
    off_line = ~np.isin(np.arange(h), np.arange(red_rows.min() - 2, red_rows.max() + 3))
    marks = red & off_line[:, None]
    marks[: int(0.1 * h)] = False
    assert marks[: red_rows.min(), : w // 2].sum() > 30
    assert marks[:, w // 2:].sum() < 10


def test_plan_colours_each_point_by_its_lux():
    lux = np.array([120.0, 340.0, 80.0, 500.0, 260.0])
    grid = _grid("desks", DESKS, np.tile([0.0, 0.0, 1.0], (5, 1)), lux)
    pic = grid_picture(grid, None, title="desks", size=(800, 600),
                       luminaires=[((2.0, 2.0, 2.8), (0.0, 0.0, -1.0))])
    assert pic.kind == "plan"
    img = _image(pic.png)
    centres = []
    for value in lux:
        hit = _near(img, lux_to_rgb(value, lux.min(), lux.max()), 0.03)
        hit[:, int(0.84 * img.shape[1]):] = False  # not the colour bar
        assert hit.sum() > 30, value
        centres.append(np.argwhere(hit).mean(axis=0))
    centres = np.array(centres)
    # where they are: x to the right, y up, as in the plan
    assert np.array_equal(np.argsort(centres[:, 1]), np.argsort(DESKS[:, 0]))
    assert np.array_equal(np.argsort(-centres[:, 0]), np.argsort(DESKS[:, 1]))


KINDS_STUDY = h.study_text(
    h.table("study", name="kinds"), h.material("wall", 0.5), h.photometry("iso", "isotropic", 1000),
    h.network("a"), h.box([0, 0, 0], [6, 4, 3], name="room"),
    h.lamp("L1", [3, 2, 2.5], "a"),
    h.plane_grid("plane", [0, 0, 0.8], [6, 0, 0], [0, 4, 0], 6, 4),
    h.point_grid("points", [[1, 1, 0.8], [4, 3, 0.8], [2, 3.5, 0.8]]),
    h.table("[[grids]]", name="sensor", kind="sensor", sensor="cylindrical",
            points=[[x, 1, 1.2] for x in range(1, 6)]),
    h.table("[[grids]]", name="area", kind="area", origin=[0, 0, 0.8], u=[6, 0, 0],
            v=[0, 4, 0]),
    h.table("[[grids]]", name="surface", kind="surface", geometry="room", spacing=1.5))


def test_every_grid_kind_the_config_accepts_is_drawn(write_study):
    import typing

    from lumijax import load_study
    from lumijax.config._schema import Grid

    study = load_study(write_study(KINDS_STUDY))
    kinds = {typing.get_args(m.model_fields["kind"].annotation)[0]
             for m in typing.get_args(typing.get_args(Grid)[0])}
    assert kinds == {g.kind for g in study.config.grids}, "a grid kind is missing here"
    grids = {}
    for g in study.scene.grids:
        lux = 10.0 + g.points[:, 0] + 2.0 * g.points[:, 1]  # any field that varies
        grids[g.name] = _grid(g.name, g.points, g.normals, lux, g.shape)
        pic = grid_picture(grids[g.name], None, title=g.name, size=(600, 420))
        img = _image(pic.png)
        coloured = np.ptp(img, axis=-1) > 0.15  # viridis or the profile's blue, not text
        assert coloured.mean() > 0.003, (g.name, pic.kind)  # a blank one: its legend only
    # the grids that are not mapped list their values, point by point, in the report
    from lumijax.report import render_report, report_context

    results = Results("kinds", grids, {"n": {"dimmer": 1.0, "flux_lm": 1.0, "luminaires": []}})
    page = render_report(report_context(study, results, pictures=False))
    body = page.split('<section id="values">', 1)[1].split("</section>", 1)[0]
    listed = re.findall(r"<h3>(.*?)</h3>", body)
    assert set(listed) == {n for n, g in grids.items()
                           if picture_kind(g.points, g.normals, g.shape) != "map"}
    assert "points" in listed and "sensor" in listed and "plane" not in listed
    sensor = body.split("<h3>sensor</h3>", 1)[1].split("</table>", 1)[0]
    cells = re.findall(r"<td[^>]*>([^<]*)</td>", sensor)
    for x in range(1, 6):  # the sensors at x = 1 … 5 m, y = 1 m: 10 + x + 2y lx
        assert f"{x:.3g}, 1, 1.2" in cells and f"{12 + x:.3g}" in cells, x


def test_results_folder_draws_a_path_grid(tmp_path):
    from lumijax.report import write_results

    lux = np.linspace(1.0, 12.0, 12)
    results = Results("paths", {"eye": _grid("eye", EYE, EYE_N, lux)},
                      {"n": {"dimmer": 1.0, "flux_lm": 1000.0, "luminaires": ["L"]}})
    paths = write_results(results, tmp_path / "out")
    img = _image(paths["images/eye.png"].read_bytes())
    assert _near(img, ACCENT).sum() > 400  # the profile's curve: not an empty map
    data = json.loads(paths["results.json"].read_text())
    assert data["grids"]["eye"]["illuminance_lux"] == pytest.approx(lux)
