"""Lambertian area sources against the configuration-factor catalogue (shared/reference §1, §2, §7).

E = M · F_{dA→A} with exitance M = Φ/A: the check values below come from the catalogue, not from
lumijax.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from helpers import area_lamp, box, material, point_grid, rectangle, study_text

import lumijax
from lumijax import load_study

# these tests check direct light against closed forms: inter-reflection off
compute = partial(lumijax.compute, indirect=False)

FLUX = 5000.0


def _study(write_study, origin, u, v, points, normals, extra=""):
    return write_study(study_text(
        area_lamp("panel", [float(x) for x in origin], [float(x) for x in u],
                  [float(x) for x in v], FLUX),
        point_grid("g", [[float(x) for x in p] for p in points],
                   [[float(x) for x in n] for n in normals]), extra))


@pytest.mark.parametrize(
    "a,b,c,F",
    [(1, 1, 1, 0.1385316060), (2, 1, 1, 0.1673750099), (1, 2, 3, 0.0522678088),
     (2, 3, 1.5, 0.1880837353), (0.5, 0.5, 2, 0.0183694087)],
)
def test_point_under_corner_of_parallel_rectangle(write_study, a, b, c, F):
    # The panel faces down (u × v = −z) at height c above a receiver below its corner.
    path = _study(write_study, (0, 0, c), (0, b, 0), (a, 0, 0), [(0, 0, 0)], [(0, 0, 1)])
    e = compute(load_study(path))["g"].illuminance_lux[0]
    np.testing.assert_allclose(e, FLUX / (a * b) * F, rtol=1e-6)


@pytest.mark.parametrize(
    "a,b,c,F", [(1, 1, 1, 0.0557341970), (2, 1, 0.7, 0.1296166926), (3, 4, 2, 0.1022961062)]
)
def test_point_facing_perpendicular_rectangle(write_study, a, b, c, F):
    # Receiver at the origin facing +z; the emitting wall is in the plane x = c, facing −x,
    # spanning 0 ≤ y ≤ b and 0 ≤ z ≤ a (catalogue §2).
    path = _study(write_study, (c, 0, 0), (0, 0, a), (0, b, 0), [(0, 0, 0)], [(0, 0, 1)])
    e = compute(load_study(path))["g"].illuminance_lux[0]
    np.testing.assert_allclose(e, FLUX / (a * b) * F, rtol=1e-6)


def test_wall_below_the_horizon_adds_nothing(write_study):
    # The same wall extended below the receiver's plane: only the part above counts (§2 again).
    path = _study(write_study, (1, 0, -1), (0, 0, 2), (0, 1, 0), [(0, 0, 0)], [(0, 0, 1)])
    e = compute(load_study(path))["g"].illuminance_lux[0]
    np.testing.assert_allclose(e, FLUX / 2 * 0.0557341970, rtol=1e-6)


def test_tilted_receiver_and_parallelogram(write_study):
    # Catalogue §7: tilted parallelogram seen by a tilted receiver, F = 0.2096227883.
    n = np.array([0.3, 0.2, 1.0])
    n /= np.linalg.norm(n)
    o, u, v = np.array([0.5, -1, 1]), np.array([1.5, 1, 0.5]), np.array([-0.5, 4, 0.2])
    # orient the emitter to face the receiver
    if np.dot(np.cross(u, v), -o) < 0:
        u, v = v, u
    path = _study(write_study, o, u, v, [(0, 0, 0)], [tuple(n)])
    e = compute(load_study(path))["g"].illuminance_lux[0]
    area = np.linalg.norm(np.cross(u, v))
    np.testing.assert_allclose(e, FLUX / area * 0.2096227883, rtol=1e-6)


def test_back_of_panel_emits_nothing(write_study):
    path = _study(write_study, (0, 0, 1), (1, 0, 0), (0, 1, 0), [(0.5, 0.5, 0)], [(0, 0, 1)])
    assert compute(load_study(path))["g"].illuminance_lux[0] == 0.0


def test_blocker_casts_partial_shadow(write_study):
    """A thin opaque strip under half the panel roughly halves the light at a point below."""
    extra = material("m", 0.3) + rectangle([-1, -1, 0.5], [1, 0, 0], [0, 2, 0], "m")
    path = _study(write_study, (-0.5, -0.5, 1.0), (0, 1, 0), (1, 0, 0), [(0, 0, 0)],
                  [(0, 0, 1)], extra)
    res = compute(load_study(path))["g"].illuminance_lux[0]
    full = compute(load_study(path), shadows=False)["g"].illuminance_lux[0]
    # the strip covers x < 0 at z = 0.5: from (0,0,0) it hides exactly the panel's x < 0 half
    np.testing.assert_allclose(res / full, 0.5, atol=0.06)


def _corner_factor(a, b, c):
    """Catalogue §1: point under a corner of a parallel a × b rectangle at height c."""
    x, y = a / c, b / c
    return (x / np.sqrt(1 + x * x) * np.arctan(y / np.sqrt(1 + x * x))
            + y / np.sqrt(1 + y * y) * np.arctan(x / np.sqrt(1 + y * y))) / (2 * np.pi)


def test_occluder_hiding_one_quadrant_exactly(write_study):
    """A 0.5 m square at half height hides exactly one quadrant of a 2 × 2 m panel 2 m above
    the receiver: E = M · 3 · F_corner(1, 1, 2). Its shadow edge lies on the panel's pieces,
    so the adaptive subdivision must give the closed form to rounding."""
    extra = material("m", 0.3) + rectangle([0, 0, 1], [0.5, 0, 0], [0, 0.5, 0], "m")
    path = _study(write_study, (-1, -1, 2), (0, 2, 0), (2, 0, 0), [(0, 0, 0)], [(0, 0, 1)],
                  extra)
    e = compute(load_study(path))["g"].illuminance_lux[0]
    np.testing.assert_allclose(e, FLUX / 4 * 3 * _corner_factor(1, 1, 2), rtol=1e-9)


def test_unobstructed_panel_needs_no_ray(write_study):
    """Receivers on a floor under a ceiling panel 1 mm below the ceiling: nothing penetrates
    their view of the panel, so the light is the exact contour integral and no ray is cast."""
    from lumijax.direct import direct_illuminance

    extra = material("m", 0.3) + box([-2, -2, 0], [2, 2, 2], "m")
    pts = [(x, y, 0.0) for x in (-1.9, -0.3, 0.0, 1.2) for y in (-1.0, 0.4, 1.9)]
    path = _study(write_study, (-2, -2, 1.999), (0, 4, 0), (4, 0, 0), pts, [(0, 0, 1)] * 12,
                  extra)
    scene = load_study(path).scene
    d = direct_illuminance(scene, np.array(pts), np.tile([0.0, 0, 1], (12, 1)))
    assert d.shadow_rays == 0
    x, y = np.array(pts)[:, 0], np.array(pts)[:, 1]
    c = 1.999
    # four rectangles meeting under the receiver
    f = sum(_corner_factor(a, b, c) for a in (2 - x, 2 + x) for b in (2 - y, 2 + y))
    np.testing.assert_allclose(d.by_network[0], FLUX / 16 * f, rtol=1e-9)
