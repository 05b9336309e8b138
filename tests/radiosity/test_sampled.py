"""Ray-sampled transport (``[solver] transport = "sampled"``) against closed forms, the block
operator's exact kernels, finite differences and its own file format."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import trimesh
from helpers import central_difference

from lumijax.errors import SolveError
from lumijax.radiosity import (
    OperatorFileError,
    PatchLocator,
    SampledSettings,
    build_operator,
    build_sampled,
    load_operator,
    mesh_patches,
    partition,
    save_operator,
    solve_radiosity,
)
from lumijax.radiosity._estimate import bound_sampled_memory

from .conftest import opposed_rectangles, quad

SECRET = b"a test secret of thirty-two chars"


def _surface_factor(t1, t2, patch_size, rays):
    """Area-weighted sampled F from surface 1 to 2 (the rays see both surfaces, nothing else)."""
    tri = np.concatenate([t1, t2])
    grp = np.r_[np.zeros(len(t1), int), np.ones(len(t2), int)]
    p = mesh_patches(tri, group=grp, patch_size=patch_size)
    op = build_sampled(p, tri, SampledSettings(rays_per_patch=rays))
    f = op.todense()
    m1, m2 = p.group == 0, p.group == 1
    return (p.area[m1, None] * f[np.ix_(m1, m2)]).sum() / p.area[m1].sum(), op


# Howell's catalogue values (/work/shared/reference/form-factors.md §8), as in test_form_factors
@pytest.mark.parametrize(("abc", "ref"), [((1, 1, 1), 0.1998248957),
                                          ((2, 3, 1.5), 0.3416939135)])
def test_parallel_rectangles(abc, ref):
    a, b, c = abc
    f12, _ = _surface_factor(quad([0, 0, 0], [a, 0, 0], [0, b, 0]),
                             quad([0, 0, c], [0, b, 0], [a, 0, 0]), 0.25, 512)
    # ~10⁴–10⁵ stratified rays in all: a binomial 1σ of F would be ≤ 0.4 %; 1 % is > 2σ
    assert f12 == pytest.approx(ref, rel=0.01)


@pytest.mark.parametrize(("lwh", "ref"), [((1, 1, 1), 0.2000437761), ((2, 1, 3), 0.3081402930),
                                          ((3, 2, 0.5), 0.0974350960)])
def test_perpendicular_rectangles_with_common_edge(lwh, ref):
    ln, w, h = lwh
    f12, _ = _surface_factor(quad([0, 0, 0], [w, 0, 0], [0, ln, 0]),
                             quad([0, 0, 0], [0, ln, 0], [0, 0, h]), 0.25, 512)
    assert f12 == pytest.approx(ref, rel=0.015)


def test_rows_never_exceed_one_and_close_in_a_box():
    m = trimesh.creation.box(extents=(1.0, 2.0, 1.5))
    m.invert()
    p = mesh_patches(m.triangles, patch_size=0.3)
    op = build_sampled(p, m.triangles, SampledSettings(rays_per_patch=256))
    rows = np.asarray(op.row_sums())
    assert rows.max() <= 1 + 1e-6  # N rays, at most N hits
    # every ray from inside a closed box hits its inside: only rays leaving at a seam are lost
    assert rows.min() > 0.99 and rows.mean() > 0.999
    # the hits are unbiased: area-weighted floor → ceiling factor of the 1 × 2 box, 1.5 high
    f = op.todense()
    floor, ceil = p.normal[:, 2] > 0.5, p.normal[:, 2] < -0.5
    f_fc = (p.area[floor, None] * f[np.ix_(floor, ceil)]).sum() / p.area[floor].sum()
    ref = opposed_rectangles(1.0 / 1.5, 2.0 / 1.5)
    assert f_fc == pytest.approx(ref, rel=0.02)


def test_locator_finds_the_patch_holding_a_point():
    # a regular triangle (grid), a sliver (bisected) and one below the patch size (whole)
    tri = np.array([[[0, 0, 0], [2, 0, 0], [0, 2, 0]],
                    [[0, 0, 1], [6, 0, 1], [6, 0.4, 1]],
                    [[5, 5, 5], [5.1, 5, 5], [5, 5.1, 5]]], float)
    p = mesh_patches(tri, patch_size=0.5)
    loc = PatchLocator(p, tri)
    assert loc.grid[0] and loc.bisected[1]
    rng = np.random.default_rng(3)
    u = rng.random((p.n, 40, 2))
    u = np.where(u.sum(-1, keepdims=True) > 1, 1 - u, u)  # uniform in each patch
    v = p.vertices
    pts = v[:, None, 0] + u[..., :1] * (v[:, None, 1] - v[:, None, 0]) + u[..., 1:] * (
        v[:, None, 2] - v[:, None, 0])
    own = np.repeat(np.arange(p.n), 40)
    src = np.asarray(p.source_triangle)[own]
    got = loc(pts.reshape(-1, 3), src)
    assert np.array_equal(got, own)
    # and from the barycentrics in the source triangle alone (what Embree returns)
    t = tri[src]
    e = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]], axis=2)  # (k, 3, 2)
    bary = np.linalg.solve(np.einsum("kij,kil->kjl", e, e),
                           np.einsum("kij,ki->kj", e, pts.reshape(-1, 3) - t[:, 0])[..., None])[..., 0]
    assert np.array_equal(loc(None, src, bary), own)


@pytest.mark.parametrize("sliver_share", [0.03, 0.3, 1.0])
def test_front_hits_find_the_patch_of_every_front_hit(sliver_share):
    # what the sampled build asks of the locator: Embree's (triangle, u, v) of a hit on a grid,
    # a sliver (the bisection tree) or a whole triangle; misses and back faces carry nothing
    tri = np.array([[[0, 0, 0], [2, 0, 0], [0, 2, 0]],
                    [[0, 0, 1], [6, 0, 1], [6, 0.4, 1]],
                    [[5, 5, 5], [5.1, 5, 5], [5, 5.1, 5]]], float)
    p = mesh_patches(tri, patch_size=0.5)
    loc = PatchLocator(p, tri)
    src = np.asarray(p.source_triangle)
    rng = np.random.default_rng(5)
    k = 5000
    on_sliver = rng.random(k) < sliver_share
    own = np.where(on_sliver, rng.choice(np.flatnonzero(src == 1), k),
                   rng.choice(np.flatnonzero(src != 1), k))
    u = rng.random((k, 2))
    u = np.where(u.sum(1, keepdims=True) > 1, 1 - u, u)
    v = p.vertices[own]
    pts = v[:, 0] + u[:, :1] * (v[:, 1] - v[:, 0]) + u[:, 1:] * (v[:, 2] - v[:, 0])
    t = tri[src[own]]
    e = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]], axis=2)
    bary = np.linalg.solve(np.einsum("kij,kil->kjl", e, e),
                           np.einsum("kij,ki->kj", e, pts - t[:, 0])[..., None])[..., 0]
    front = np.zeros((3, 3), np.float32)
    front[src] = p.normal
    hit_tri = src[own].astype(np.int32)
    dirs = -front[hit_tri] * np.where(rng.random(k) < 0.9, 1.0, -1.0)[:, None]  # 10 % backs
    hit_tri[rng.random(k) < 0.1] = -1  # and 10 % misses
    want = np.where((hit_tri >= 0) & (np.einsum("ij,ij->i", dirs, front[hit_tri]) < 0), own, -1)
    got = loc.front_hits(hit_tri, bary.astype(np.float32), dirs.astype(np.float32), front)
    assert np.array_equal(got, want)
    assert 0 < (want[on_sliver] >= 0).sum() and (want >= 0).sum() > 0.7 * k


def test_meshes_of_one_size_class_share_one_compiled_lookup():
    # the locator's tables are padded to their size class and the tree's height is traced, so
    # a second mesh of the same triangles (other patches, another bisection tree) runs the
    # program the first one compiled — and still finds every patch from its own centroid
    from lumijax.radiosity._sampled import _front_hits

    tri = np.array([[[0, 0, 0], [2, 0, 0], [0, 2, 0]],
                    [[0, 0, 1], [6, 0, 1], [6, 0.4, 1]],
                    [[5, 5, 5], [5.1, 5, 5], [5, 5.1, 5]]], float)
    compiled, heights = [], []
    for size in (0.6, 0.3):  # 57 and 219 patches, trees 5 and 7 cuts deep, one size class
        p = mesh_patches(tri, patch_size=size)
        loc = PatchLocator(p, tri)
        src = np.asarray(p.source_triangle)
        t = tri[src]
        e = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]], axis=2)
        bary = np.linalg.solve(np.einsum("kij,kil->kjl", e, e),
                               np.einsum("kij,ki->kj", e, p.centroid - t[:, 0])[..., None])[..., 0]
        front = np.zeros((3, 3), np.float32)
        front[src] = p.normal
        got = loc.front_hits(src.astype(np.int32), bary.astype(np.float32),
                             -front[src], front, at_least=4096)
        assert np.array_equal(got, np.arange(p.n))
        compiled.append(_front_hits._cache_size())
        heights.append(loc.height)
    assert heights[0] != heights[1]
    assert compiled[1] == compiled[0]


def _furnished_triangles():
    """A 4 × 3 × 2.8 m room with a desk and a partition: shadows, near pairs, open edges."""
    m = trimesh.creation.box(extents=(4.0, 3.0, 2.8))
    m.invert()
    desk = trimesh.creation.box(extents=(1.2, 0.8, 0.05))
    desk.apply_translation([0.5, 0.3, -0.65])
    wall = trimesh.creation.box(extents=(0.05, 1.5, 1.4))
    wall.apply_translation([-0.8, -0.4, -0.7])
    return np.concatenate([m.triangles, desk.triangles, wall.triangles])


@pytest.fixture(scope="module")
def furnished():
    tri = _furnished_triangles()
    p = mesh_patches(tri, patch_size=0.35)
    dense = build_operator(p, partition(p, 512, occluders=tri), tri)
    sampled = build_sampled(p, tri, SampledSettings(rays_per_patch=512))
    return p, tri, dense, sampled


@pytest.fixture(scope="module")
def small_furnished():
    """The same room at 0.6 m patches (the derivative and file checks need no accuracy)."""
    tri = _furnished_triangles()
    p = mesh_patches(tri, patch_size=0.6)
    return p, tri, None, build_sampled(p, tri, SampledSettings(rays_per_patch=64))


def test_solve_matches_the_block_operator(furnished):
    p, _, dense, sampled = furnished
    # a downlight's direct light: 1 / d² from (1, 0.5, 1.2) on every upward face, cos-weighted
    d = np.array([1.0, 0.5, 1.2]) - p.centroid
    r2 = np.sum(d * d, axis=1)
    cos = np.clip(np.einsum("ij,ij->i", d, p.normal) / np.sqrt(r2), 0, None)
    e_dir = 300.0 * cos * np.clip(-d[:, 2] / np.sqrt(r2), 0, None) / r2
    rho = np.where(p.normal[:, 2] > 0.5, 0.3, 0.7)
    b0 = jnp.asarray((rho * e_dir)[:, None], jnp.float32)  # float32: the studies' precision
    ind = []
    for op in (dense, sampled):
        b = solve_radiosity(op, jnp.asarray(rho, jnp.float32), b0).value
        ind.append(np.asarray(op.matmul(b))[:, 0])  # inter-reflected irradiance, lx
    e_d, e_s = ind
    a = p.area
    mean = np.sum(a * (e_s - e_d)) / np.sum(a * e_d)
    # RMS per patch relative to the field's, as tests/lighting/test_final_gather.py defines it
    rms = np.sqrt(np.sum(a * (e_s - e_d) ** 2) / np.sum(a * e_d**2))
    print(f"sampled vs block operator: mean {mean:+.4f}, RMS {rms:.4f}")
    # unbiased: measured +0.33 % at 512 rays on this 0.35 m mesh (within ±0.3 % over seeds
    # and 256…4,096 rays at 0.25 m); the per-patch noise is measured 10.8 % RMS here and falls
    # as rays^(−1/2) (docs/radiosity.md, "Sampled transport"): a bias or a mislaid hit would
    # show in either bound
    assert abs(mean) < 0.01
    assert rms < 0.14


def test_gradient_through_the_sampled_solve(small_furnished):
    p, _, _, op = small_furnished
    rng = np.random.default_rng(0)
    e_dir = rng.random(p.n) * 100

    def total(rho):  # flux that the surfaces exchange, a smooth function of ρ
        b = solve_radiosity(op, rho, jnp.asarray(rho * e_dir)[:, None], rtol=1e-11).value
        return jnp.sum(jnp.asarray(p.area) * b[:, 0])

    import jax

    rho0 = jnp.asarray(np.full(p.n, 0.5))
    g = np.asarray(jax.grad(total)(rho0))
    idx = [0, p.n // 3, p.n - 1]
    fd = central_difference(total, rho0, h=1e-5, indices=idx)
    assert np.allclose(g[idx], fd, rtol=1e-5)


def test_operator_file_round_trip_and_a_bad_index(small_furnished, tmp_path):
    p, _, _, op = small_furnished
    path = save_operator(tmp_path / "op.lmjop", op, secret=SECRET)
    back = load_operator(path, secret=SECRET)
    x = jnp.asarray(np.random.default_rng(1).random((p.n, 3)))
    assert np.array_equal(np.asarray(back.matmul(x)), np.asarray(op.matmul(x)))
    assert np.array_equal(np.asarray(back.rmatmul(x)), np.asarray(op.rmatmul(x)))
    assert back.info["transport"] == "sampled"
    # a receiver index past the padding patch, written and correctly signed: refused
    bk = op.buckets[0]
    bad = eqx.tree_at(lambda b: b.base, bk, bk.base.at[-1].set(p.n + 5 - int(bk.recv[-1])))
    forged = eqx.tree_at(lambda o: o.buckets, op, (bad,))
    save_operator(tmp_path / "bad.lmjop", forged, secret=SECRET)
    with pytest.raises(OperatorFileError, match="patch index outside"):
        load_operator(tmp_path / "bad.lmjop", secret=SECRET)


def test_transpose_is_the_transpose(small_furnished):
    p, _, _, op = small_furnished
    f = op.todense()
    x = np.random.default_rng(2).random((p.n, 2))
    assert np.allclose(np.asarray(op.rmatmul(jnp.asarray(x))), f.T @ x, rtol=1e-5, atol=1e-8)
    assert np.allclose(np.asarray(op.matmul(jnp.asarray(x))), f @ x, rtol=1e-5, atol=1e-8)


def test_memory_bound_refuses_and_names_the_setting():
    est = bound_sampled_memory(10_000, 256, available=1 << 30)
    assert est.stored_bytes == 8 * 10_000 * 256  # int32 sender, uint16 receiver, float16
    with pytest.raises(SolveError, match=r"rays_per_patch ≤ 120\b"):  # 0.9 GiB / 8 MB a ray
        bound_sampled_memory(1_000_000, 256, available=1 << 30)


def _room(transport: str, rays: int = 1024, **solver) -> str:
    import helpers as h

    return h.study_text(
        h.material("wall", 0.7), h.material("floor", 0.3),
        h.photometry("iso", "isotropic", 3000), h.photometry("down", "lambertian", 2000),
        h.network("a", 0.3), h.network("b", 0.9),
        h.box([0, 0, 0], [4, 3, 2.5]), h.rectangle([0.5, 0.5, 0.01], [3, 0, 0], [0, 2, 0], "floor"),
        h.lamp("A1", [1, 1.5, 2.0], "a"), h.lamp("B1", [3, 1.0, 2.4], "b", "down"),
        h.plane_grid("wp", [0.2, 0.2, 0.8], [3.6, 0, 0], [0, 2.6, 0], nu=6, nv=5),
        h.table("solver", patch_size=0.5, spectral_samples=0, transport=transport,
                rays_per_patch=rays, **solver))


def test_a_study_with_the_sampled_transport(write_study):
    import lumijax
    from lumijax import load_study

    blocks = lumijax.compute(load_study(write_study(_room("blocks"), "a.toml"))).lighting
    # cosine rays only: a study that aims rays at its lit patches draws a new sample when a
    # luminaire moves (test_bright.py), so replace_luminaire and a new solve agree to noise
    study = load_study(write_study(_room("sampled", aimed_share=0.0), "b.toml"))
    sol = lumijax.compute(study).lighting
    assert sol.transport.info["transport"] == "sampled"
    np.testing.assert_array_equal(sol.point_direct, blocks.point_direct)
    # grid points gather from many patches, so the per-patch noise averages out
    ind_s, ind_b = sol.point_indirect, blocks.point_indirect
    assert np.abs(ind_s / ind_b - 1).max() < 0.03, np.abs(ind_s / ind_b - 1).max()
    # exact superposition and the incremental change still hold on the fixed sampled F
    import dataclasses

    from lumijax.lighting import solve_lighting

    moved = dataclasses.replace(study.scene.luminaires[1], position=np.array([2.0, 1.5, 2.3]))
    fast = sol.replace_luminaire(1, moved)
    full = solve_lighting(fast.scene, sol.points, sol.normals,
                          lumijax._study.solver_settings(study))
    np.testing.assert_allclose(fast.point_total, full.point_total, rtol=1e-4, atol=1e-6)


def test_an_unknown_transport_names_the_key(write_study):
    from lumijax import load_study
    from lumijax.errors import ConfigError

    with pytest.raises(ConfigError, match="transport"):
        load_study(write_study(_room("rays")))


def test_a_narrow_product_runs_padded_and_gives_the_same_bits(small_furnished, monkeypatch):
    # 25…63 columns run zero-padded to 64 on the CPU (XLA:CPU's faster rows: _operator's
    # _WIDE_ROWS); the zero columns touch no real column's sums
    from lumijax.radiosity import _operator

    _, _, _, op = small_furnished
    (bucket,) = op.buckets
    x = np.random.default_rng(3).uniform(0, 50, (op.n_patches + 1, 40)).astype(np.float32)
    x[-1] = 0  # the padding patch

    def product(transpose):  # a new trace every call: the constant is read when tracing
        return np.asarray(jax.jit(lambda xe: bucket.apply(xe, jnp.zeros_like(xe),
                                                          transpose=transpose))(jnp.asarray(x)))

    padded = [product(t) for t in (False, True)]
    jaxpr = str(jax.make_jaxpr(lambda xe: bucket.apply(xe, jnp.zeros_like(xe)))(x))
    assert f"f32[{op.n_patches + 1},64]" in jaxpr  # it did run on 64 columns
    monkeypatch.setattr(_operator, "_WIDE_ROWS", 0)  # padding off
    for t, got in zip((False, True), padded, strict=True):
        np.testing.assert_array_equal(got, product(t))
    assert np.abs(padded[0]).max() > 1.0


@pytest.mark.skipif(jax.default_backend() != "cpu", reason="another device holds its own copy")
def test_the_links_are_held_once(small_furnished, tmp_path):
    """The host arrays the links are written into (and an operator file is read into) are
    adopted by JAX, not copied: at 10⁶ patches a copy would be another 7–12 GB at the peak."""
    from lumijax._jit_cache import host_empty, to_device

    a = host_empty(1000, np.int32)
    a[:] = 7
    assert to_device(a).unsafe_buffer_pointer() == a.ctypes.data
    # a plain numpy array (16-byte aligned) is copied: the alignment is what JAX needs
    plain = np.empty(1003, np.int32)[1:]
    assert to_device(plain).unsafe_buffer_pointer() != plain.ctypes.data
    p, _, _, op = small_furnished
    back = load_operator(save_operator(tmp_path / "op.lmjop", op, secret=SECRET), secret=SECRET)
    (w, r, s) = (x.unsafe_buffer_pointer() for x in (back.buckets[0].weight,
                                                     back.buckets[0].recv, back.buckets[0].src))
    # one read buffer: the arrays lie at their offsets in it, in the file's order
    assert w < r < s and s - w < 3 * back.buckets[0].weight.nbytes + 256


def test_the_share_of_rays_kept_as_links_only_falls_with_more_rays(small_furnished):
    """What ``rays_per_patch = "auto"`` bounds its second build by: the first build's links a
    ray (rays into the sky store nothing, repeated hits merge) bound those at more rays."""
    from lumijax.lighting._stages import _links_per_ray

    p, tri, _, op64 = small_furnished
    shares = [_links_per_ray(op64, p.n)]
    for rays in (256, 1024):
        op = build_sampled(p, tri, SampledSettings(rays_per_patch=rays))
        shares.append(_links_per_ray(op, p.n))
        assert 0 < op.info["links"] <= p.n * rays
    assert shares[0] > shares[1] > shares[2]  # a closed room: every ray hits, many merge
    # the bound scales by the share, and names the rays that fit by it too
    full = bound_sampled_memory(10_000, 256, available=1 << 30)
    half = bound_sampled_memory(10_000, 256, available=1 << 30, links_per_ray=0.5)
    assert half.stored_bytes == full.stored_bytes // 2
    with pytest.raises(SolveError, match=r"rays_per_patch ≤ 241\b"):  # 0.9 GiB / 4 MB a ray
        bound_sampled_memory(1_000_000, 300, available=1 << 30, links_per_ray=0.5)
