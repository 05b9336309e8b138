"""The standards' grids: the EN 12464-1 spacing rule, area grids with a border and a cut-out,
surface grids that cover their geometry, and sensor grids at another grid's points."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import material, study_text, table

from lumijax.config import parse_config
from lumijax.errors import ConfigError
from lumijax.scene import build_scene
from lumijax.scene._standard_grids import area_counts, en12464_spacing

ROOM = study_text(
    material("w", 0.4), material("dark", 0.1),
    table("[[geometry]]", name="room", kind="box", min=[0, 0, 0], max=[6, 4, 3],
          normals="inward", material="w"),
    table("[[geometry]]", name="panel", kind="rectangle", origin=[1, 3.9, 0.5], u=[2, 0, 0],
          v=[0, 0, 1.5], material="dark"),
)


def _scene(grids: str):
    return build_scene(parse_config(ROOM + grids))


@pytest.mark.parametrize(("d", "p"), [(1.0, 0.2), (10.0, 1.0), (100.0, 5.0), (0.1, 0.04)])
def test_spacing_rule_at_powers_of_ten(d, p):
    """p = 0.2·5^log10(d): at d = 10ⁿ it is 0.2·5ⁿ m exactly (5^n by hand)."""
    assert en12464_spacing(d) == pytest.approx(p, rel=1e-12)


def test_spacing_rule_worked_examples_and_cap():
    # a 6 m × 4 m office: d = 6 m, p = 0.2 × 5^0.778 = 0.700 m; 9 × 6 points
    assert en12464_spacing(6.0) == pytest.approx(0.2 * math.exp(math.log(5) * math.log10(6)))
    assert en12464_spacing(6.0) == pytest.approx(0.7000, abs=5e-4)
    assert area_counts(6.0, 4.0)[:2] == (9, 6)
    # a 0.6 m × 0.4 m desk task area: p = 0.2 × 5^(−0.222) = 0.1399 m: 5 × 3 points
    assert area_counts(0.6, 0.4)[:2] == (5, 3)
    # ratio ≥ 2: d is the shorter side (20 × 5 m corridor: d = 5 m, p = 0.617 m)
    n_long, n_short, p = area_counts(20.0, 5.0)
    assert p == pytest.approx(0.2 * 5 ** math.log10(5.0))
    assert (n_long, n_short) == (math.ceil(20 / p), math.ceil(5 / p))
    # the cap: 10 m from d = 10^(log 50 / log 5) ≈ 269 m up
    assert en12464_spacing(1000.0) == 10.0
    assert en12464_spacing(250.0) < 10.0


def test_area_grid_border_and_cut_out():
    sc = _scene("""
[[grids]]
name = "task"
kind = "area"
origin = [2, 1, 0.8]
u = [2, 0, 0]
v = [0, 2, 0]
[[grids]]
name = "band"
kind = "area"
origin = [1.5, 0.5, 0.8]
u = [3, 0, 0]
v = [0, 3, 0]
exclude = "task"
[[grids]]
name = "room_floor"
kind = "area"
origin = [0, 0, 0.0]
u = [6, 0, 0]
v = [0, 4, 0]
border_m = 0.5
""")
    task, band, floor = (sc.grid(n) for n in ("task", "band", "room_floor"))
    p = en12464_spacing(2.0)  # 0.2·5^0.301 = 0.324 m: 7 cells a side
    assert task.shape == (7, 7) and len(task) == 49
    np.testing.assert_allclose(task.points[0], [2 + 1 / 7, 1 + 1 / 7, 0.8])
    assert 2 / 7 <= p
    # the band: a 3 × 3 m grid (p = 0.2·5^0.477 = 0.43 m: 7 × 7) less the points in the task
    rel = band.points - [2, 1, 0.8]
    assert not np.any((rel[:, 0] > 0) & (rel[:, 0] < 2) & (rel[:, 1] > 0) & (rel[:, 1] < 2))
    full = 7 * 7
    inside = sum(1 for i in range(7) for j in range(7)
                 if 0.5 < 1.5 + (i + .5) * 3 / 7 - 1.5 < 2.5 and 0.5 < (j + .5) * 3 / 7 < 2.5)
    assert len(band) == full - inside and band.shape is None
    # the border: 5 × 3 m inside, d = 5: p = 0.2 × 5^0.699 = 0.617 m, 9 × 5 points from 0.5 m
    assert floor.shape == (9, 5)
    assert floor.points[:, 0].min() == pytest.approx(0.5 + 5 / 9 / 2)
    assert np.all(floor.normals == [0, 0, 1])


def test_surface_grid_covers_its_geometry():
    sc = _scene("""
[[grids]]
name = "panel_s"
kind = "surface"
geometry = "panel"
offset_m = 0.02
spacing = 0.4
""")
    from lumijax.scene._standard_grids import surface_samples

    g = sc.grid("panel_s")
    s = surface_samples(sc.triangles, 1, 0.02, 0.4)
    assert s.area_m2.sum() == pytest.approx(2 * 1.5)  # the panel's area, by hand
    n = np.cross([2, 0, 0], [0, 0, 1.5])
    n = n / np.linalg.norm(n)
    np.testing.assert_allclose(g.normals, np.broadcast_to(n, g.normals.shape), atol=1e-12)
    # every point 2 cm in front of the panel's plane, inside its rectangle
    np.testing.assert_allclose((g.points - [1, 3.9, 0.5]) @ n, 0.02, atol=1e-12)
    assert g.points[:, 0].min() > 1 and g.points[:, 0].max() < 3
    assert g.points[:, 2].min() > 0.5 and g.points[:, 2].max() < 2.0
    assert np.all(sc.materials[s.material[0]].name == "dark")
    # pieces about 0.4 m: the panel's triangles (longest edge 2.5 m) are cut 7 times a side
    assert len(g) == 2 * 7 * 7


def test_sensor_grid_at_another_grid():
    sc = _scene("""
[[grids]]
name = "task"
kind = "area"
origin = [2, 1, 0.8]
u = [2, 0, 0]
v = [0, 2, 0]
[[grids]]
name = "ez"
kind = "sensor"
sensor = "cylindrical"
at_grid = "task"
offset_m = [0, 0, 0.4]
""")
    np.testing.assert_allclose(sc.grid("ez").points, sc.grid("task").points + [0, 0, 0.4])


@pytest.mark.parametrize(("grids", "key", "words"), [
    ('[[grids]]\nname = "s"\nkind = "surface"\ngeometry = "nowhere"\n', "grids[0].geometry",
     "no geometry named 'nowhere'"),
    ('[[grids]]\nname = "a"\nkind = "area"\norigin = [0, 0, 0]\nu = [1, 0, 0]\n'
     'v = [0, 1, 0]\nborder_m = 0.5\n', "grids[0].border_m", "no points"),
    ('[[grids]]\nname = "a"\nkind = "area"\norigin = [0, 0, 0]\nu = [1, 0, 0]\n'
     'v = [2, 0, 0]\n', "grids[0]", "no area"),
    ('[[grids]]\nname = "c"\nkind = "sensor"\nsensor = "cylindrical"\nat_grid = "x"\n',
     "grids[0].at_grid", "unknown grid 'x'"),
    ('[[grids]]\nname = "c"\nkind = "sensor"\nsensor = "semicylindrical"\n'
     'points = [[0, 0, 1]]\n', "grids[0].sensor", "needs 'facing'"),
    ('[[grids]]\nname = "a"\nkind = "area"\norigin = [0, 0, 0]\nu = [1, 0, 0]\n'
     'v = [0, 1, 0]\nexclude = "a2"\n', "grids[0].exclude", "unknown grid 'a2'"),
])
def test_bad_grids_name_the_key(grids, key, words):
    with pytest.raises(ConfigError) as e:
        build_scene(parse_config(ROOM + grids))
    assert e.value.key == key and words in e.value.message


def test_surface_grid_on_a_geometry_without_area():
    """The config refuses degenerate boxes and meshes itself; a geometry left without
    triangles (all of them degenerate pieces) is refused by the grid, naming the key."""
    import dataclasses

    from lumijax.scene._standard_grids import build_grids

    cfg = parse_config(ROOM + '[[grids]]\nname = "s"\nkind = "surface"\ngeometry = "panel"\n')
    tri = build_scene(cfg).triangles
    none_on_panel = dataclasses.replace(tri, item=np.zeros_like(tri.item))
    with pytest.raises(ConfigError) as e:
        build_grids(cfg, none_on_panel, lambda g: None, None, None)
    assert e.value.key == "grids[0].geometry" and "has no area" in e.value.message
