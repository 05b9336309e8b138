"""Meshing, partitioning and operator persistence."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from lumijax.errors import GeometryError
from lumijax.radiosity import (
    build_operator,
    load_operator,
    mesh_patches,
    operator_key,
    partition,
    save_operator,
)

from .conftest import quad


def test_subdivision_keeps_area_normal_and_size():
    tri = quad([0, 0, 0], [2, 0, 0], [0, 1, 0])
    p = mesh_patches(tri, material=np.array([3, 3]), group=np.array([7, 7]), patch_size=0.3)
    assert p.area.sum() == pytest.approx(2.0)
    assert np.allclose(p.normal, [0, 0, 1])
    n = np.cross(p.vertices[:, 1] - p.vertices[:, 0], p.vertices[:, 2] - p.vertices[:, 0])
    assert np.all(n[:, 2] > 0)  # every patch keeps the parent's front face
    assert p.diameter.max() <= 0.3 + 1e-12
    assert set(p.material) == {3} and set(p.group) == {7}
    assert set(p.source_triangle) == {0, 1}


def test_slivers_are_bisected_not_gridded():
    """A 6 × 0.2 m band at 1 m patches: the n² grid would give 2 × 7² = 98 needles; halving
    along the longest edge stops at pieces shorter than 1 m or below 1/8 m²."""
    tri = quad([0, 0, 0], [6, 0, 0], [0, 0.2, 0])
    p = mesh_patches(tri, patch_size=1.0)
    assert p.area.sum() == pytest.approx(1.2)
    n = np.cross(p.vertices[:, 1] - p.vertices[:, 0], p.vertices[:, 2] - p.vertices[:, 0])
    assert np.all(n[:, 2] > 0)
    assert np.all((p.diameter <= 1.0 + 1e-12) | (p.area <= 1 / 8))
    assert np.all(p.area > 1 / 16)  # never cut below half the stopping area
    assert 2 * 6 <= p.n <= 2 * 12  # at least one per metre, about two per metre per triangle


@pytest.mark.parametrize("bad", ["nan", "zero"])
def test_degenerate_triangles_are_named(bad):
    tri = np.concatenate([quad([0, 0, 0], [1, 0, 0], [0, 1, 0]), np.zeros((1, 3, 3))])
    tri[2] = [[0, 0, 0], [1, 1, 1], [2, 2, 2]]  # collinear: zero area
    if bad == "nan":
        tri[2, 1, 0] = np.nan
    with pytest.raises(GeometryError, match="triangle 2"):
        mesh_patches(tri)


def _two_rooms():
    rooms = []
    for dx in (0.0, 3.2):  # two 3 m rooms, 0.2 m apart: walls between them block all light
        m = trimesh.creation.box(extents=(3, 3, 2.5))
        m.apply_translation([dx, 0, 0])
        m.invert()
        rooms.append(m.triangles)
    tri = np.concatenate(rooms)
    group = np.repeat([0, 1], [len(r) for r in rooms])
    return tri, group


def test_partition_keeps_groups_apart_and_culls_hidden_pairs():
    tri, group = _two_rooms()
    p = mesh_patches(tri, group=group, patch_size=0.5)
    part = partition(p, 100, occluders=tri)
    for b in range(part.n_blocks):
        assert len(set(p.group[part.block(b)])) == 1
    assert 50 <= part.sizes.min() and part.sizes.max() <= 100
    groups = part.block_group[part.pairs]
    assert np.all(groups[:, 0] == groups[:, 1])  # nothing crosses the walls
    assert part.stats["culled_occluded"] > 0
    # Without occluders the facing test alone keeps some cross-room pairs (ceiling ↔ floor).
    assert len(partition(p, 100).pairs) > len(part.pairs)


def test_facing_test_culls_back_to_back_and_flat_blocks():
    up = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])  # faces +z
    down = quad([0, 0, -1], [0, 1, 0], [1, 0, 0])  # below it, faces −z: they never meet
    tri = np.concatenate([up, down])
    p = mesh_patches(tri, group=np.array([0, 0, 1, 1]), patch_size=0.25)
    part = partition(p, 1000)
    # three candidates (two flat blocks with themselves, one pair): all face away
    assert part.stats["candidate_pairs"] == 3 and part.stats["culled_facing"] == 3
    assert len(part.pairs) == 0


def test_save_load_roundtrip_and_key(tmp_path):
    tri, group = _two_rooms()
    p = mesh_patches(tri, group=group, patch_size=1.5)
    op = build_operator(p, partition(p, 64, occluders=tri), tri)
    save_operator(tmp_path / "op.npz", op)
    back = load_operator(tmp_path / "op.npz")
    x = jnp.asarray(np.random.default_rng(0).random((p.n, 3)))
    assert np.allclose(back.matmul(x), op.matmul(x))
    assert back.info["rays"] == op.info["rays"]
    k = operator_key(tri, group, patch_size=1.5)
    assert k == operator_key(tri.copy(), group.copy(), patch_size=1.5)
    assert k != operator_key(tri, group, patch_size=0.5)
    assert k != operator_key(tri, group[::-1].copy(), patch_size=1.5)
