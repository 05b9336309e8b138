"""Low-rank far-field blocks: accuracy against the dense operator, fallbacks, products, I/O."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from lumijax.radiosity import (
    FormFactorSettings,
    LowRankBucket,
    build_operator,
    load_operator,
    mesh_patches,
    partition,
    save_operator,
    solve_radiosity,
)
from lumijax.radiosity._lowrank import aca_block

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
    save_operator(tmp_path / "op.lmjop", op)
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
    assert op.info["lowrank_block_pairs"] > 0.2 * len(part.pairs)
    assert op.nbytes < dense.nbytes
    rho = 0.5
    sol = solve_radiosity(op, jnp.full(p.n, rho), jnp.ones((p.n, 1)))
    # every patch of a closed room with uniform emission and reflectance: M/(1 − ρ)
    assert np.allclose(np.asarray(sol.value), 1 / (1 - rho), rtol=0.015)
    # against the dense operator's answer, solved by LAPACK in float64 (not a second compiled
    # solve) with the row correction written out (docs/radiosity.md, "Row sums"): the room is
    # closed, so every patch's outgoing light is normalised, F_ij → F_ij / s_j
    fd = dense.todense()
    rows = fd.sum(axis=1)
    assert np.all(np.abs(rows - 1) <= 0.02)  # closed: what the solve's correction assumes
    ref = np.linalg.solve(np.eye(p.n) - rho * fd / rows[None, :], np.ones((p.n, 1)))
    assert np.allclose(sol.value, ref, rtol=1e-3)


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


@pytest.fixture(scope="module")
def ribbed():
    """The ribbed plates with their dense operator and the one-level operator that keeps
    shadowed far pairs dense: the same for both parametrisations below, so built once."""
    p, part, tri = _ribbed_plates()
    dense = build_operator(p, part, tri, DENSE)
    flat = build_operator(p, part, tri, FormFactorSettings(hierarchical=False, lowrank_shadowed=False))
    return p, part, tri, dense, flat


@pytest.mark.parametrize("hierarchical", [True, False], ids=["clusters", "blocks"])
def test_self_shadowed_far_pairs_are_compressed_with_their_shadows(hierarchical, ribbed):
    p, part, tri, dense, flat = ribbed
    op = build_operator(p, part, tri, FormFactorSettings(hierarchical=hierarchical))
    info = op.info
    # the ribs penetrate the candidates' hulls: the exact hull test cannot prove them clear
    assert flat.info["lowrank_mixed_visibility"] > 0.5 * flat.info["lowrank_candidates"]
    assert flat.info["lowrank_pairs"] < 0.1 * flat.info["lowrank_candidates"]
    # ... yet nearly every well-separated block pair ends up low rank, shadows and all
    assert info["lowrank_mixed_visibility"] > 0
    assert info["lowrank_block_pairs"] >= 0.9 * flat.info["lowrank_candidates"]
    assert (info["lowrank_cluster_pairs"] > 0) == hierarchical
    assert op.nbytes < dense.nbytes
    fd = dense.todense()
    far = np.zeros_like(fd, bool)
    for bk in op.buckets:
        if isinstance(bk, LowRankBucket):
            for r, s in zip(np.asarray(bk.recv), np.asarray(bk.src), strict=True):
                far[np.ix_(r[r < p.n], s[s < p.n])] = True
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


def _plates_far_apart(patch_size: float):
    """Two 4 × 4 m plates facing each other 12 m apart: every patch pair is far."""
    tri = np.concatenate([quad([0, 0, 0], [4, 0, 0], [0, 4, 0]),
                          quad([0, 0, 12], [0, 4, 0], [4, 0, 0])])
    p = mesh_patches(tri, group=np.arange(len(tri)) // 2, patch_size=patch_size)
    return p, partition(p, 64, occluders=tri), tri


def test_cluster_pairs_make_far_field_memory_near_linear():
    """Blocks of 64 patches: one level of block pairs grows as P², clusters as ~P."""
    sizes, flat, hier = [], [], []
    # 256, 900, 3,364 patches: flat growth 1.85, clusters 1.10 then 1.05, ratio 0.079 (at
    # 900 ... 12,996 patches: 1.97, 1.05 / 1.03, 0.022, but the flat 13k-patch build took 35 s)
    for h in (0.8, 0.4, 0.2):
        p, part, tri = _plates_far_apart(h)
        sizes.append(p.n)
        flat.append(build_operator(p, part, tri, FormFactorSettings(hierarchical=False)).nbytes)
        op = build_operator(p, part, tri)
        assert op.info["lowrank_block_pairs"] == len(part.pairs)  # all of it low rank
        assert op.info["rays"] == 0  # proven clear: no shadow ray
        hier.append(op.nbytes)
    growth = np.log(np.array(hier[1:]) / hier[:-1]) / np.log(np.array(sizes[1:]) / sizes[:-1])
    flat_growth = np.log(flat[-1] / flat[-2]) / np.log(sizes[-1] / sizes[-2])
    assert flat_growth > 1.6, flat_growth  # one level: quadratic in patches (up to padding)
    assert growth[-1] < 1.3, growth  # clusters: near-linear
    assert hier[-1] < 0.25 * flat[-1]


def test_exact_check_rejects_a_factorisation_that_misses_a_shadow():
    """Factors of the unshadowed kernel are wrong for a floor and ceiling with a plate between
    them; the exact pass over every entry (not a sample) measures how wrong."""
    from lumijax.radiosity._lowrank import exact_block_rows, exact_error
    from lumijax.scene._raycast import RayCaster

    p, part, tri = _far_plates(True)
    ia, ib = np.flatnonzero(p.centroid[:, 2] < 1), np.flatnonzero(p.centroid[:, 2] > 11)
    caster = RayCaster(tri)
    counters = dict(rays=0)
    args = (p.centroid[ia], p.normal[ia], p.area[ia], p.area[ia] / (4 * np.pi),
            p.centroid[ib], p.normal[ib], p.area[ib], p.area[ib] / (4 * np.pi))
    u, v, _ = aca_block(*args[:3], *args[4:7], 1e-3, 50, sa=args[3], sb=args[7])  # no shadow
    err, ref = exact_error(u, v, *args, caster, counters)
    assert counters["rays"] > 0.4 * len(ia) * len(ib)  # every facing entry's ray was cast
    assert err > 1e-2 * ref  # the plate's shadow: the unshadowed factors are far off
    err0, _ = exact_error(u, v, *args, None, dict(rays=0))
    assert err0 < 1e-3 * ref  # ... and right for the unshadowed block
    # the shadowed block's true rank at 1e-3 (numpy's SVD of every entry) is near full: below
    # it, ACA with shadow rays must refuse rather than return factors that miss the shadow
    g = exact_block_rows(*args, caster, dict(rays=0))
    sv = np.linalg.svd(g, compute_uv=False)
    rank = int(np.flatnonzero(np.sqrt(np.cumsum((sv**2)[::-1]))[::-1] <= 1e-3 * np.linalg.norm(sv))[0])
    assert rank > 200
    assert aca_block(*args[:3], *args[4:7], 1e-3, 100, sa=args[3], sb=args[7], caster=caster,
                     counters=counters) is None
    u, v, st = aca_block(*args[:3], *args[4:7], 1e-3, len(ia), sa=args[3], sb=args[7],
                         caster=caster, counters=counters)
    assert st["check_error"] <= 1e-3
    assert np.linalg.norm(u @ v.T - g) <= 1e-3 * np.linalg.norm(g)


def test_one_dense_block_holds_every_bucket(plates):
    # radiosity._operator.densified: low-rank and dense buckets, both directions, into one G
    from lumijax.radiosity._operator import densified

    p, op, _, _ = plates
    one = densified(op, p.n + 40)  # 40 padding patches: no form factors
    assert len(one.buckets) == 1 and one.n_patches == p.n + 40
    f = one.todense()
    np.testing.assert_allclose(f[: p.n, : p.n], op.todense(), rtol=1e-6,
                               atol=1e-7 * np.abs(f).max())
    assert not f[p.n:].any() and not f[:, p.n:].any()
    assert densified(op, p.n - 1) is None  # fewer patches than it has: refused
    assert densified(op, p.n + 40) is one  # kept while op lives: the solve's, for the product
    seen = []  # inside a trace the buckets stay (a block would enter as a literal constant)
    jax.jit(lambda x: (seen.append(densified(op, p.n)), x)[1])(1.0)
    assert seen == [None]
