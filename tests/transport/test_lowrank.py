"""Low-rank far-field blocks: accuracy against the dense operator, fallbacks, products, I/O."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from lumijax.mesh import mesh_patches, partition
from lumijax.solve import solve_radiosity
from lumijax.transport import (
    FormFactorSettings,
    LowRankBucket,
    build_operator,
    load_operator,
)
from lumijax.transport._lowrank import aca_block

from .conftest import quad

DENSE = FormFactorSettings(lowrank=False)


def _far_plates(occluder: bool):
    """A 4 × 4 m floor and ceiling 12 m apart (every block pair far), optionally a 1 m plate
    half-way up that shadows some block pairs partly."""
    tri = [quad([0, 0, 0], [4, 0, 0], [0, 4, 0]), quad([0, 0, 12], [0, 4, 0], [4, 0, 0])]
    if occluder:
        tri.append(quad([1.5, 1.5, 6], [1, 0, 0], [0, 1, 0]))
    tri = np.concatenate(tri)
    group = np.arange(len(tri)) // 2
    p = mesh_patches(tri, group=group, patch_size=0.4)
    part = partition(p, 100, occluders=tri)
    return p, part, tri


@pytest.fixture(scope="module", params=[False, True], ids=["clear", "occluded"])
def plates(request):
    p, part, tri = _far_plates(request.param)
    return p, build_operator(p, part, tri), build_operator(p, part, tri, DENSE), request.param


def test_far_blocks_are_compressed_accurately(plates):
    p, op, dense, occluded = plates
    info = op.info
    assert info["lowrank_pairs"] > 0
    assert any(isinstance(b, LowRankBucket) for b in op.buckets)
    if occluded:  # pairs whose sample rays are partly blocked by the plate stay dense
        assert info["lowrank_mixed_visibility"] > 0
    else:
        assert info["lowrank_mixed_visibility"] == 0
    assert op.nbytes < dense.nbytes
    f, fd = op.todense(), dense.todense()
    g = p.area[:, None] * f
    assert np.allclose(g, g.T, rtol=0, atol=1e-12 * np.abs(g).max())  # reciprocity kept exactly
    assert np.linalg.norm(f - fd) <= 1e-3 * np.linalg.norm(fd)
    x = jnp.asarray(np.random.default_rng(0).random((p.n, 3)), jnp.float32)
    for name, ref in (("matmul", fd), ("rmatmul", fd.T)):
        got = np.asarray(getattr(op, name)(x))
        want = ref @ np.asarray(x, np.float64)
        assert np.linalg.norm(got - want) <= 1e-3 * np.linalg.norm(want), name


def test_products_of_low_rank_buckets_match_todense(plates):
    p, op, _, _ = plates
    f = op.todense()
    rng = np.random.default_rng(1)
    x = jnp.asarray(rng.random((p.n, 2)), jnp.float32)
    assert np.allclose(op.matmul(x), f @ np.asarray(x, np.float64), rtol=1e-4, atol=1e-9)
    assert np.allclose(op.rmatmul(x), f.T @ np.asarray(x, np.float64), rtol=1e-4, atol=1e-9)
    # Southwell's single-block shot goes through the low-rank buckets too
    blk = int(np.asarray(op.block_of)[0])
    xb = jnp.where((op.block_of == blk)[:, None], x, 0.0)
    assert np.allclose(op.matmul_from_block(xb, blk), op.matmul(xb), rtol=1e-5, atol=1e-9)


def test_low_rank_operator_survives_save_and_load(plates, tmp_path):
    p, op, _, _ = plates
    op.save(tmp_path / "op.lmjop")
    back = load_operator(tmp_path / "op.lmjop")
    assert [type(b) for b in back.buckets] == [type(b) for b in op.buckets]
    x = jnp.asarray(np.random.default_rng(2).random((p.n, 2)), jnp.float32)
    assert np.array_equal(back.matmul(x), op.matmul(x))


def test_aca_refuses_a_rank_it_cannot_afford():
    rng = np.random.default_rng(0)
    ca = rng.uniform(0, 2, (300, 3)) * [1, 1, 0]
    cb = ca + [0, 0, 10.0]
    na, nb = np.tile([0, 0, 1.0], (300, 1)), np.tile([0, 0, -1.0], (300, 1))
    a = np.full(300, 0.01)
    u, v, st = aca_block(ca, na, a, cb, nb, a, 1e-3, 50)
    d = cb[None] - ca[:, None]
    d2 = (d**2).sum(-1)
    exact = a[0] * a[0] * d[..., 2] ** 2 / (d2 * (np.pi * d2 + 2 * a[0]))
    assert np.linalg.norm(u @ v.T - exact) <= 1e-3 * np.linalg.norm(exact)
    assert 1 <= st["rank"] <= 10
    assert aca_block(ca, na, a, cb, nb, a, 1e-9, 2) is None


def test_furnace_in_a_hall_with_compressed_far_field():
    m = trimesh.creation.box(extents=(20, 20, 8))
    m.invert()
    tri = m.triangles
    p = mesh_patches(tri, patch_size=2.0)
    part = partition(p, 48, occluders=tri)
    op = build_operator(p, part, tri)
    dense = build_operator(p, part, tri, DENSE)
    assert op.info["lowrank_pairs"] > 0.2 * len(part.pairs)
    assert op.nbytes < dense.nbytes
    rho = 0.5
    sol = solve_radiosity(op, jnp.full(p.n, rho), jnp.ones((p.n, 1)))
    # every patch of a closed room with uniform emission and reflectance: M/(1 − ρ)
    assert np.allclose(np.asarray(sol.value), 1 / (1 - rho), rtol=0.015)
    ref = solve_radiosity(dense, jnp.full(p.n, rho), jnp.ones((p.n, 1)))
    assert np.allclose(sol.value, ref.value, rtol=1e-3)


def _ribbed_plates():
    """Floor and ceiling 12 m apart, each 4 × 4 m with its own 1 m ribs (two-sided, same
    group as its plate): far pairs are shadowed by the pair's own geometry, like a bay's
    columns and reveals in a courtyard."""
    tri = []
    for z, up in ((0.0, 1.0), (12.0, -1.0)):
        o, u, v = ([0, 0, z], [4, 0, 0], [0, 4, 0]) if up > 0 else ([0, 0, z], [0, 4, 0], [4, 0, 0])
        plate = [quad(o, u, v)]
        for x in (1.0, 3.0):
            rib = quad([x, 0, z], [0, 4, 0], [0, 0, 1.0 * up])
            plate += [rib, rib[:, ::-1]]  # both faces
        tri.append(np.concatenate(plate))
    group = np.concatenate([np.full(len(t), g) for g, t in enumerate(tri)])
    tri = np.concatenate(tri)
    p = mesh_patches(tri, group=group, patch_size=0.7)
    return p, partition(p, 60, occluders=tri), tri


def test_self_shadowed_far_pairs_are_compressed_with_their_shadows():
    p, part, tri = _ribbed_plates()
    dense = build_operator(p, part, tri, DENSE)
    op = build_operator(p, part, tri)
    info = op.info
    assert info["lowrank_candidates"] > 0
    # the ribs penetrate candidate hulls: the exact hull test alone keeps those pairs dense
    assert info["lowrank_mixed_visibility"] > 0.5 * info["lowrank_candidates"]
    assert info["lowrank_shadowed"] > 0.5 * info["lowrank_mixed_visibility"]
    assert op.nbytes < dense.nbytes
    fd = dense.todense()
    far = np.zeros_like(fd, bool)
    for bk in op.buckets:
        if isinstance(bk, LowRankBucket):
            for r, s in zip(np.asarray(bk.recv_block), np.asarray(bk.src_block), strict=True):
                if r >= 0:
                    far[np.ix_(part.block(r), part.block(s))] = True
    # the compressed pairs really are shadowed: facing entries with no light
    d = p.centroid[None] - p.centroid[:, None]
    facing = (np.einsum("ijk,ik->ij", d, p.normal) > 0) & (np.einsum("ijk,jk->ij", d, p.normal) < 0)
    assert (far & facing & (fd == 0)).sum() > 0.01 * (far & facing).sum()
    x = jnp.asarray(np.random.default_rng(3).random((p.n, 4)), jnp.float32)
    for name, ref in (("matmul", fd), ("rmatmul", fd.T)):
        got = np.asarray(getattr(op, name)(x))
        want = ref @ np.asarray(x, np.float64)
        assert np.linalg.norm(got - want) <= 1e-3 * np.linalg.norm(want), name
    f = op.todense()  # the compressed blocks themselves: truncated to 1e-3 of their norm
    assert np.linalg.norm((f - fd)[far]) <= 1e-3 * np.linalg.norm(fd[far])
