"""Lambertian area sources against the configuration-factor catalogue (shared/reference §1, §2, §7).

E = M · F_{dA→A} with exitance M = Φ/A: the check values below come from the catalogue, not from
lumijax.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

import lumijax
from lumijax import load_study

# these tests check direct light against closed forms: inter-reflection off
compute = partial(lumijax.compute, indirect=False)

FLUX = 5000.0


def _study(write_study, origin, u, v, points, normals, extra=""):
    return write_study(f"""
        [[luminaires]]
        name = "panel"
        kind = "area"
        origin = {[float(x) for x in origin]}
        u = {[float(x) for x in u]}
        v = {[float(x) for x in v]}
        flux_lm = {FLUX}
        network = "n"
        [[grids]]
        name = "g"
        kind = "points"
        points = {[[float(x) for x in p] for p in points]}
        normals = {[[float(x) for x in n] for n in normals]}
        {extra}
    """)


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
    extra = """
        [materials.m]
        reflectance = 0.3
        [[geometry]]
        kind = "rectangle"
        origin = [-1, -1, 0.5]
        u = [1, 0, 0]
        v = [0, 2, 0]
        material = "m"
    """
    path = _study(write_study, (-0.5, -0.5, 1.0), (0, 1, 0), (1, 0, 0), [(0, 0, 0)],
                  [(0, 0, 1)], extra)
    res = compute(load_study(path))["g"].illuminance_lux[0]
    full = compute(load_study(path), shadows=False)["g"].illuminance_lux[0]
    # the strip covers x < 0 at z = 0.5: from (0,0,0) it hides exactly the panel's x < 0 half
    np.testing.assert_allclose(res / full, 0.5, atol=0.06)
