"""The solve in column batches (radiosity ``_solve``, "Column batches"): every batch size gives
the unbatched answer, the batch comes from the memory budget, and gradients pass through it.
References are dense float64 solves written here with numpy."""

from __future__ import annotations

import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.errors import SolveError
from lumijax.radiosity import solve_radiosity
from lumijax.radiosity._estimate import (
    SOLVE_SHARE,
    bound_sampled_memory,
    sampled_rays_that_fit,
    solve_column_bytes,
    solve_memory_bytes,
)
from lumijax.radiosity._solvers import Refined

from .conftest import facing_squares

pytestmark = pytest.mark.skipif(not jax.config.read("jax_enable_x64"),
                                reason="the batch comparisons are in float64")


@pytest.fixture(scope="module")
def pair():
    """Two facing squares (``conftest.facing_squares``) and their dense F."""
    p, op = facing_squares()
    return p, op, np.asarray(op.todense(), np.float64)


def columns(n, shape=(3, 5), seed=0):
    """Per-column reflectance ``(P, 1, W)`` and distinct right-hand sides ``(P, S, W)``."""
    rng = np.random.default_rng(seed)
    rho = rng.uniform(0.2, 0.9, (n, 1, shape[1]))
    b0 = rho * rng.uniform(10.0, 100.0, (n,) + shape)
    return rho, b0


def dense(f, rho, b0):
    return np.linalg.solve(np.eye(len(rho)) - rho[:, None] * f, b0)


def solve(op, rho, b0, **kw):
    return solve_radiosity(op, jnp.asarray(rho), jnp.asarray(b0), correct_rows=False, **kw)


# the default iterating (its direct solve of a small room takes no batches: tests/radiosity/test_lu.py)
@pytest.mark.parametrize("solver", ["bicgstab", Refined(direct=False)], ids=["bicgstab", "refined"])
def test_every_batch_size_gives_the_unbatched_solve(pair, solver):
    p, op, f = pair
    rho, b0 = columns(p.n)
    whole = solve(op, rho, b0, solver=solver, rtol=1e-11, column_batch=15)
    ref = np.stack([np.stack([dense(f, rho[:, 0, w], b0[:, s, w]) for w in range(5)], -1)
                    for s in range(3)], 1)
    np.testing.assert_allclose(np.asarray(whole.value), ref, rtol=1e-9, atol=1e-9)
    for batch in (1, 4, 7, 15, 40):  # 4: batches of 4, the last padded; 7: three equal of 5
        seen = []
        got = solve(op, rho, b0, solver=solver, rtol=1e-11, column_batch=batch,
                    progress=lambda done, total, seen=seen: seen.append((done, total)))
        assert got.value.shape == b0.shape and got.escaped.shape == (3, 5)
        np.testing.assert_allclose(np.asarray(got.value), np.asarray(whole.value), rtol=1e-12,
                                   atol=0)
        np.testing.assert_allclose(np.asarray(got.escaped), np.asarray(whole.escaped),
                                   rtol=1e-12)
        np.testing.assert_allclose(np.asarray(got.stats["created"]),
                                   np.asarray(whole.stats["created"]), rtol=0, atol=1e-15)
        assert float(got.residual) <= 1e-11
        batches = -(-15 // min(batch, 15))
        assert [d for d, _ in seen] == ([15] if batches == 1 else
                                        [min((k + 1) * -(-15 // batches), 15)
                                         for k in range(batches)])


def test_batches_keep_the_distinct_columns(pair):
    p, op, f = pair
    rho, b0 = columns(p.n, (2, 4))
    rho[:, :, 3] = rho[:, :, 1]
    b0[:, :, 3] = b0[:, :, 1]  # wavelength 3 is a copy of 1: 6 distinct columns of 8
    got = solve(op, rho, b0, rtol=1e-11, column_batch=4)
    assert got.stats["columns_solved"] == 6
    for s in range(2):
        for w in range(4):
            np.testing.assert_allclose(np.asarray(got.value)[:, s, w],
                                       dense(f, rho[:, 0, w], b0[:, s, w]), rtol=1e-9)


def test_the_batch_comes_from_the_memory_budget(pair, monkeypatch):
    p, op, _ = pair
    rho, b0 = columns(p.n)
    per = solve_column_bytes(p.n, 8)
    results = 15 * p.n * 16
    # room for 4 columns in the solve's share: 15 columns in 4 batches (4, 4, 4, 3 → 4 × 4)
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(int((4.5 * per) / SOLVE_SHARE)))
    seen = []
    iterating = Refined(direct=False)  # a direct solve of a small room takes no batches
    got = solve(op, rho, b0, rtol=1e-11, progress=lambda d, t: seen.append(d), solver=iterating)
    assert seen == [4, 8, 12, 15]
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(10**12))
    seen.clear()
    whole = solve(op, rho, b0, rtol=1e-11, progress=lambda d, t: seen.append(d),
                  solver=iterating)
    assert seen == [15]
    np.testing.assert_allclose(np.asarray(got.value), np.asarray(whole.value), rtol=1e-12)
    # not even one column and the results fit: refused before the solve, naming what helps
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(per + results - 1))
    with pytest.raises(SolveError, match="patch_size"):
        solve(op, rho, b0, rtol=1e-11)
    with pytest.raises(SolveError, match="column_batch"):
        solve(op, rho, b0, column_batch=0)


def test_gradient_through_a_batched_solve(pair):
    """d(Σ w·B)/dρ for ρ shared by 6 columns: batched (at most 4: two of 3) equals unbatched, and
    both equal the adjoint formula Σ_c (F B_c) ⊙ λ_c, λ_c = (I − ρF)⁻ᵀ w_c, in numpy."""
    p, op, f = pair
    rng = np.random.default_rng(1)
    rho0 = rng.uniform(0.2, 0.8, p.n)
    b0 = rng.uniform(1.0, 10.0, (p.n, 6))
    w = rng.uniform(0.0, 1.0, (p.n, 6))

    def loss(batch):
        def fn(rho):
            b = solve_radiosity(op, rho, jnp.asarray(b0), correct_rows=False, rtol=1e-12,
                                column_batch=batch, solver="bicgstab").value
            return jnp.sum(jnp.asarray(w) * b)
        return jax.grad(fn)(jnp.asarray(rho0))

    g_whole, g_batched = np.asarray(loss(6)), np.asarray(loss(4))
    a = np.eye(p.n) - rho0[:, None] * f
    b = np.linalg.solve(a, b0)
    lam = np.linalg.solve(a.T, w)
    ref = np.sum((f @ b) * lam, axis=1)
    np.testing.assert_allclose(g_whole, ref, rtol=1e-9)
    np.testing.assert_allclose(g_batched, g_whole, rtol=1e-12, atol=1e-14)


def test_the_sampled_bound_counts_the_solve():
    """1,080,114 patches × 256 rays: 2.21 GB of links (8 B each: radiosity/_links.py), held
    once (JAX adopts the host arrays); with 288 columns the solve's one-column batch (24 × 4 B × 1,179,648 padded patches) and
    the results (12 B a patch and column) come on top of the stored links: 6.06 GB."""
    links = 8 * 1_080_114 * 256
    solve = 24 * 4 * 1_179_648 + 288 * 1_080_114 * 12
    assert solve_memory_bytes(1_080_114, 288, 1, 4) == solve
    est = bound_sampled_memory(1_080_114, 256, available=1 << 40, columns=288)
    assert est.stored_bytes == links and est.peak_bytes == links + solve
    assert bound_sampled_memory(1_080_114, 256, available=1 << 40).peak_bytes == links
    # what fits for the operator alone is refused once the solve is counted
    with pytest.raises(SolveError, match="rays_per_patch") as err:
        bound_sampled_memory(1_080_114, 256, available=links + solve - 1, columns=288)
    assert "288 columns" in str(err.value)
    rays = int(re.search(r"rays_per_patch ≤ ([\d,]+)", str(err.value))[1].replace(",", ""))
    assert 150 < rays < 256  # (0.9 × available − solve) / 8 B a patch: ≈ 186; it fits
    bound_sampled_memory(1_080_114, rays, available=links + solve - 1, columns=288)
    bound_sampled_memory(1_080_114, 256, available=links + solve - 1)


def test_the_rays_that_fit_leave_the_solve_its_batches():
    """The LoD-3 courtyard in a 16 GiB budget, 288 columns, 0.55 links a ray: the links get
    what is left of 90 % once the solve's batches (half the budget) and its results (12 B a
    patch and column, 3.73 GB) are set aside — (0.4 × 16 GiB − 3.73 GB) / 4.75 MB a ray = 660
    rays. Counting one column a batch only (what the bound accepts at all) let them take the
    batches' memory too: 2,444 rays, and 17.8 GiB held at ≈ 1,850 (benchmarks/RESULTS.md)."""
    kw = dict(available=16 * 2**30, columns=288, links_per_ray=0.55)
    assert sampled_rays_that_fit(1_080_114, **kw) == 660
    assert sampled_rays_that_fit(1_080_114, least=True, **kw) == 2_444
    assert sampled_rays_that_fit(1_080_114, available=2**30, columns=288) == 0  # none at all
