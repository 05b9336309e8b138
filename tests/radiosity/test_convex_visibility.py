"""A room convex as seen from inside needs no visibility rays (RayCaster.sees_everything): the
operator built without them is the one the rays give, and anything that can occlude (a table,
an L-shaped room, a box seen from outside, glazing) keeps them."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from lumijax.radiosity import build_operator, mesh_patches, partition
from lumijax.scene._raycast import RayCaster

from .conftest import quad


def _box(lo, hi, inward: bool) -> np.ndarray:
    mesh = trimesh.creation.box(bounds=np.array([lo, hi], float))
    if inward:
        mesh.invert()
    return np.asarray(mesh.triangles)


def _with_rays(tri) -> RayCaster:
    """A caster that casts every ray (its convexity answer overridden): the reference."""
    caster = RayCaster(tri)
    caster._sees_everything = False
    return caster


def _operator(tri, caster, size=0.5):
    p = mesh_patches(tri, patch_size=size)
    part = partition(p, 256, occluders=caster)
    return p, part, build_operator(p, part, caster, dtype=np.float64, occluder_triangles=tri)


def test_box_room_skips_the_rays_and_keeps_the_operator():
    tri = _box((0, 0, 0), (2.0, 1.5, 1.2), inward=True)
    caster = RayCaster(tri)
    assert caster.sees_everything
    p, part, op = _operator(tri, caster)
    _, ref_part, ref = _operator(tri, _with_rays(tri))
    assert op.info["visibility_skipped"] and op.info["rays"] == 0
    assert part.stats["occlusion_rays"] == 0
    assert not ref.info["visibility_skipped"] and ref.info["rays"] > 0
    assert ref_part.stats["occlusion_rays"] > 0
    assert np.array_equal(part.pairs, ref_part.pairs)  # nothing was culled by the rays either
    f, f_ref = np.asarray(op.todense()), np.asarray(ref.todense())
    assert f.shape == (p.n, p.n) and f_ref.max() > 0
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-12 * f_ref.max())


def test_box_at_site_coordinates_is_still_convex():
    # 5·10⁶ m north: the planes' rounding must not read as a vertex behind a wall
    tri = _box((0, 0, 0), (4.0, 3.0, 2.5), inward=True) + np.array([3.1e5, 5.2e6, 40.0])
    assert RayCaster(tri).sees_everything


def test_box_with_a_table_casts_the_rays():
    room = _box((0, 0, 0), (2.0, 1.5, 1.2), inward=True)
    table = _box((0.6, 0.5, 0.70), (1.4, 1.0, 0.75), inward=False)
    tri = np.concatenate([room, table])
    caster = RayCaster(tri)
    assert not caster.sees_everything
    _, _, op = _operator(tri, caster)
    assert not op.info["visibility_skipped"] and op.info["rays"] > 0


@pytest.mark.parametrize("case", ["outward box", "L-shaped room", "one-sided floor in a box"])
def test_what_can_occlude_is_not_convex(case):
    if case == "outward box":  # seen from outside: every vertex behind every face
        tri = _box((0, 0, 0), (1, 1, 1), inward=False)
    elif case == "L-shaped room":  # two inward boxes sharing a wall opening: a re-entrant corner
        a = _box((0, 0, 0), (2, 1, 1), inward=True)
        b = _box((0, 1, 0), (1, 2, 1), inward=True)
        tri = np.concatenate([a, b])
    else:  # a floor facing down inside an inward box: the floor's plane has vertices above it
        tri = np.concatenate([_box((0, 0, 0), (1, 1, 1), inward=True),
                              quad((0.2, 0.2, 0.5), (0, 0.6, 0), (0.6, 0, 0))])
    assert not RayCaster(tri).sees_everything


def test_glazed_caster_keeps_its_rays():
    from lumijax.scene._glass import GlazedCaster

    tri = _box((0, 0, 0), (1, 1, 1), inward=True)
    glazed = GlazedCaster(tri, np.where(np.arange(len(tri)) < 2, 0.8, 0.0))
    assert not glazed.sees_everything


def test_points_inside_the_convex_room_see_everything_and_points_outside_do_not():
    """A segment from a point to a wall is unblocked when the point lies in every wall's
    half-space (inside the room, or on its boundary); a point outside sees some walls
    through others. The room at site coordinates keeps its answer."""
    offset = np.array([3.1e5, 5.2e6, 40.0])
    tri = _box((0, 0, 0), (4.0, 3.0, 2.5), inward=True) + offset
    caster = RayCaster(tri)
    inside = np.array([[2.0, 1.5, 0.8], [0.0, 0.0, 0.0], [4.0, 3.0, 2.5]]) + offset
    assert caster.sees_everything_from(inside)
    assert not caster.sees_everything_from(np.array([[2.0, 1.5, 3.0]]) + offset)
    assert not caster.sees_everything_from(np.array([[-0.01, 1.5, 1.0]]) + offset)
    table = _box((0.5, 0.5, 0.7), (1.5, 1.0, 0.75), inward=False) + offset
    assert not RayCaster(np.concatenate([tri, table])).sees_everything_from(inside[:1])
