"""The gather in closed form (radiosity/_exact_gather.py): a small grid's factors patch by
patch, without rays.

Checked against what the code does not compute: the view factor from a point to a square in
closed form (a differential area parallel to a rectangle, above its corner), a linear
radiosity summed on a 1 cm grid written here, half a square hidden by a plate (half the
factor, by symmetry), and a closed box, which a point inside sees whole (factors sum to 1)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from lumijax.lighting import SolverSettings
from lumijax.radiosity import (
    EXACT_GATHER_PAIRS,
    build_exact_gather,
    build_gather,
    mesh_patches,
    patch_slopes,
)
from lumijax.scene import RayCaster

# a 2 × 2 m square in the plane z = 0 facing up, cut along x = 0 (two halves of two triangles)
HALVES = np.array([[[-1, -1, 0], [0, -1, 0], [0, 1, 0]], [[-1, -1, 0], [0, 1, 0], [-1, 1, 0]],
                   [[0, -1, 0], [1, -1, 0], [1, 1, 0]], [[0, -1, 0], [1, 1, 0], [0, 1, 0]]],
                  np.float64)
DOWN = np.array([[0.0, 0.0, -1.0]])


def _corner_factor(a: float, b: float, h: float) -> float:
    """View factor from a differential area at height h above a corner of an a × b rectangle,
    parallel to it (the standard closed form)."""
    x, y = a / h, b / h
    return (x / np.sqrt(1 + x * x) * np.arctan(y / np.sqrt(1 + x * x))
            + y / np.sqrt(1 + y * y) * np.arctan(x / np.sqrt(1 + y * y))) / (2 * np.pi)


def _read(gather, b, n_points):
    return np.bincount(gather.point, weights=gather.weight * b[gather.patch], minlength=n_points)


@pytest.mark.parametrize("h", [0.05, 0.3, 1.0, 4.0])
def test_a_point_over_a_square_gets_its_view_factor(h):
    """Near (sub-triangles, the contour integral) and far (the 7-point rule) patches alike:
    the factor to the square within 10⁻⁵ of the closed form, from 5 cm to 4 m."""
    patches = mesh_patches(HALVES, patch_size=0.25)
    caster = RayCaster(HALVES)
    points = np.array([[0.0, 0.0, h], [0.5, 0.5, h]])
    g = build_exact_gather(points, np.repeat(DOWN, 2, axis=0), patches, caster)
    want = np.array([4 * _corner_factor(1, 1, h),
                     _corner_factor(1.5, 1.5, h) + 2 * _corner_factor(1.5, 0.5, h)
                     + _corner_factor(0.5, 0.5, h)])
    np.testing.assert_allclose(g.coverage, want, rtol=1e-5)


def test_a_linear_radiosity_is_read_linearly():
    """B rising linearly across the square, points 0.1–0.4 m above it: read through the
    patches' slopes, the gather matches a 1 cm midpoint sum of ∫ B cos θ cos θ' / (π r²) dA
    to 0.01 % (a constant B per patch misses it by up to 0.11 %); the ray gather at 4,096
    rays a point is further off than the closed form."""
    patches = mesh_patches(HALVES, patch_size=0.25)
    caster = RayCaster(HALVES)
    points = np.array([[x, y, z] for x in (-0.55, 0.1, 0.62) for y in (-0.3, 0.45)
                       for z in (0.1, 0.4)])
    normals = np.repeat(DOWN, len(points), axis=0)
    b = 10.0 + 6.0 * patches.centroid[:, 0] - 3.0 * patches.centroid[:, 1]
    s = 0.01
    gx, gy = np.meshgrid(np.arange(-1 + s / 2, 1, s), np.arange(-1 + s / 2, 1, s))
    gx, gy = gx.ravel(), gy.ravel()
    bb = 10.0 + 6.0 * gx - 3.0 * gy
    want = np.array([np.sum(bb * p[2] ** 2 / (np.pi * ((gx - p[0]) ** 2 + (gy - p[1]) ** 2
                                                        + p[2] ** 2) ** 2)) * s * s
                     for p in points])
    slopes = patch_slopes(patches)
    linear = _read(build_exact_gather(points, normals, patches, caster, slopes=slopes), b,
                   len(points))
    constant = _read(build_exact_gather(points, normals, patches, caster), b, len(points))
    rays = _read(build_gather(points, normals, patches, caster, rays=4096, slopes=slopes), b,
                 len(points))
    assert np.abs(linear / want - 1).max() < 1e-4
    assert np.abs(constant / want - 1).max() > 10 * np.abs(linear / want - 1).max()
    assert np.abs(rays / want - 1).max() > np.abs(linear / want - 1).max()


def test_a_plate_hides_half_the_square():
    """A plate over the half x < 0, between the point and the square, its edge under the
    point: the point sees the other half only, half the square's factor; without the plate,
    the whole."""
    plate = np.array([[[-3, -3, 0.5], [0, 3, 0.5], [0, -3, 0.5]],
                      [[-3, -3, 0.5], [-3, 3, 0.5], [0, 3, 0.5]]], np.float64)
    patches = mesh_patches(HALVES, patch_size=0.25)
    point = np.array([[0.0, 0.0, 1.0]])
    blocked = build_exact_gather(point, DOWN, patches, RayCaster(np.concatenate([HALVES, plate])))
    clear = build_exact_gather(point, DOWN, patches, RayCaster(HALVES))
    whole = 4 * _corner_factor(1, 1, 1.0)
    np.testing.assert_allclose(clear.coverage, [whole], rtol=1e-5)
    np.testing.assert_allclose(blocked.coverage, [whole / 2], rtol=1e-5)
    assert np.all(patches.centroid[blocked.patch, 0] > 0)


def test_a_point_in_a_closed_box_sees_all_of_it_and_nothing_behind(monkeypatch):
    """Inside a closed box (inward faces) a point's factors sum to 1; a point on the floor
    facing down, or outside the box, sees nothing. The facing test run a point at a time
    finds the same links (a consistency check of its passes)."""
    box = trimesh.creation.box(extents=(3.0, 2.0, 2.5))
    box.apply_translation([1.5, 1.0, 1.25])
    tri = np.ascontiguousarray(box.triangles[:, ::-1])  # inward
    patches = mesh_patches(tri, patch_size=0.4)
    caster = RayCaster(tri)
    points = np.array([[1.5, 1.0, 0.8], [0.2, 0.3, 0.05], [2.9, 1.9, 2.4], [1.0, 1.0, 0.0],
                       [5.0, 1.0, 1.0]])
    normals = np.array([[0, 0, 1.0], [1.0, 0, 0], [-0.6, -0.6, -0.52915], [0, 0, -1.0],
                        [-1.0, 0, 0]])
    g = build_exact_gather(points, normals, patches, caster)
    np.testing.assert_allclose(g.coverage[:3], 1.0, atol=2e-4)
    np.testing.assert_allclose(g.coverage[3:], 0.0, atol=1e-12)
    import lumijax.radiosity._exact_gather as eg

    monkeypatch.setattr(eg, "_FACING_CHUNK", patches.n)
    one = build_exact_gather(points, normals, patches, caster)
    np.testing.assert_array_equal(one.point, g.point)
    np.testing.assert_array_equal(one.patch, g.patch)
    np.testing.assert_allclose(one.weight, g.weight, rtol=1e-12)


def test_the_solver_gathers_small_grids_exactly_unless_rays_are_asked_for():
    s = SolverSettings()
    assert s.gathers_exactly(100, 1728)
    assert not s.gathers_exactly(EXACT_GATHER_PAIRS // 1000 + 1, 1000)
    assert not SolverSettings(gather_rays=512).gathers_exactly(100, 1728)
    # a scene that can hide patches from the points: a quarter of the pairs
    assert s.gathers_exactly(100, EXACT_GATHER_PAIRS // 400, view=True)
    assert not s.gathers_exactly(100, EXACT_GATHER_PAIRS // 400 + 1, view=True)
