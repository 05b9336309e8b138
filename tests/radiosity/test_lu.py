"""A small room's solve outside a trace is one LU factorisation on the host (radiosity/_lu.py):
the dense system's answer by numpy, the figures the iterative solve gives, and no program
compiled; the iterative solve where the work or the tolerance says so, and inside a trace."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.radiosity import Refined, _lu, _solve, solve_radiosity

from .conftest import facing_squares

pytestmark = pytest.mark.skipif(not jax.config.read("jax_enable_x64"),
                                reason="the comparisons are in float64")


@pytest.fixture
def compiled(monkeypatch):
    """The solvers the compiled (iterative) solve ran, in order."""
    seen, real = [], _solve._solve_compiled

    def spy(*args, **kw):
        seen.append(args[3])
        return real(*args, **kw)

    monkeypatch.setattr(_solve, "_solve_compiled", spy)
    return seen


@pytest.fixture(scope="module")
def open_pair():
    """Two facing squares (``conftest.facing_squares``): light escapes between them."""
    return facing_squares()


def test_a_closed_room_is_solved_directly_to_the_dense_answer(cube_room, compiled):
    p, _, op = cube_room
    f = np.asarray(op.todense(), np.float64)
    rows = f.sum(axis=1)
    b0 = np.random.default_rng(0).uniform(0.0, 100.0, (p.n, 3))
    sol = solve_radiosity(op, jnp.full(p.n, 0.9), jnp.asarray(b0), rtol=1e-11)
    assert compiled == []  # nothing iterated, so nothing compiled
    assert sol.stats["direct"] and int(sol.iterations) == 0 and bool(sol.stats["closed"])
    # a closed box's outgoing light normalised (F_ij → F_ij / s_j), then numpy's dense solve
    ref = np.linalg.solve(np.eye(p.n) - 0.9 * f / rows[None, :], b0)
    np.testing.assert_allclose(np.asarray(sol.value), ref, rtol=1e-10)
    assert float(sol.residual) <= 1e-11
    assert float(np.max(np.asarray(sol.escaped))) < 1e-9
    assert float(sol.stats["row_max"]) == pytest.approx(rows.max(), rel=1e-12)


@pytest.mark.parametrize("correct_rows", [True, False])
def test_the_direct_figures_are_the_iterative_ones(open_pair, compiled, correct_rows):
    # per-wavelength reflectance (one factorisation per distinct column) in an open scene:
    # the radiosity, the escaped and created light and the flags as the iterative solve's
    p, op = open_pair
    rng = np.random.default_rng(1)
    rho = rng.uniform(0.2, 0.9, (p.n, 1, 4))
    rho[:, :, 3] = rho[:, :, 1]  # one reflectance for two wavelengths: three factorisations
    b0 = rho * rng.uniform(10.0, 100.0, (p.n, 2, 4))
    kw = dict(rtol=1e-11, correct_rows=correct_rows)
    direct = solve_radiosity(op, jnp.asarray(rho), jnp.asarray(b0), **kw)
    assert compiled == [] and direct.stats["direct"]
    iterative = solve_radiosity(op, jnp.asarray(rho), jnp.asarray(b0),
                                solver=Refined(direct=False), **kw)
    assert len(compiled) >= 1 and not iterative.stats["direct"]
    np.testing.assert_allclose(np.asarray(direct.value), np.asarray(iterative.value),
                               rtol=1e-9)
    escaped = np.asarray(direct.escaped)
    assert escaped.shape == (2, 4) and 0.2 < escaped.min() < 1.0  # open: light leaves
    # by hand from the dense F: the flux A|B| leaving each patch times what its row misses
    # (rows above 1 cut to 1 with the correction, as the solve used them)
    rows = np.asarray(op.todense(), np.float64).sum(axis=1)
    used = np.minimum(rows, 1.0) if correct_rows else rows
    flux = np.asarray(p.area)[:, None, None] * np.abs(np.asarray(direct.value))
    want = (flux * np.clip(1.0 - used, 0.0, None)[:, None, None]).sum(0) / flux.sum(0)
    np.testing.assert_allclose(escaped, want, rtol=1e-9)
    np.testing.assert_allclose(escaped, np.asarray(iterative.escaped), rtol=1e-9)
    np.testing.assert_allclose(np.asarray(direct.stats["created"]),
                               np.asarray(iterative.stats["created"]), atol=1e-12)
    assert float(direct.stats["row_max"]) == pytest.approx(
        float(iterative.stats["row_max"]), rel=1e-12)
    assert bool(direct.stats["closed"]) == bool(iterative.stats["closed"]) is False
    assert direct.stats["columns_solved"] == iterative.stats["columns_solved"] == 8


def test_one_factorisation_per_distinct_reflectance(monkeypatch, open_pair):
    p, op = open_pair
    rng = np.random.default_rng(2)
    grey = np.full((p.n, 3), 0.5)
    first, inverse = _lu.direct_groups(grey, None)
    assert len(first) == 1 and list(inverse) == [0, 0, 0]
    spectral = rng.uniform(0.2, 0.8, (p.n, 3))
    spectral[:, 2] = spectral[:, 0]
    tau = np.zeros_like(spectral)
    tau[:, 2] = 0.1  # equal reflectance, different transmittance: not one system
    assert len(_lu.direct_groups(spectral, None)[0]) == 2
    assert len(_lu.direct_groups(spectral, tau)[0]) == 3
    factored = []
    real = np.linalg.solve
    monkeypatch.setattr(np.linalg, "solve", lambda a, b: factored.append(b.shape) or real(a, b))
    b0 = rng.uniform(1.0, 10.0, (p.n, 6))
    sol = solve_radiosity(op, jnp.full(p.n, 0.6), jnp.asarray(b0), rtol=1e-11)  # grey
    assert sol.stats["direct"] and factored == [(p.n, 6)]  # one LU, every column at once


def test_more_work_than_the_limit_iterates(open_pair, compiled, monkeypatch):
    p, op = open_pair
    b0 = jnp.asarray(np.random.default_rng(3).uniform(1.0, 10.0, (p.n, 2)))
    monkeypatch.setattr(_lu, "DIRECT_WORK", p.n**3 - 1)
    real = _lu.direct_groups
    # too large for one factorisation: refused before its columns are grouped (a copy of
    # every column, gigabytes at the courtyard's 10⁶ patches × 288 columns)
    monkeypatch.setattr(_lu, "direct_groups", lambda *a: pytest.fail("columns grouped"))
    sol = solve_radiosity(op, jnp.full(p.n, 0.6), b0, rtol=1e-11)
    assert not sol.stats["direct"] and len(compiled) >= 1
    monkeypatch.setattr(_lu, "direct_groups", real)
    monkeypatch.setattr(_lu, "DIRECT_WORK", p.n**3)
    compiled.clear()
    sol = solve_radiosity(op, jnp.full(p.n, 0.6), b0, rtol=1e-11)
    assert sol.stats["direct"] and compiled == []


def test_a_direct_solve_short_of_the_tolerance_hands_over_to_the_iterative_one(
        open_pair, compiled, monkeypatch):
    p, op = open_pair
    b0 = jnp.asarray(np.random.default_rng(4).uniform(1.0, 10.0, (p.n, 2)))
    real = _lu.direct_solve

    def off(*args):  # as if LAPACK had lost the digits (a near-singular system)
        b, residual, *rest = real(*args)
        return (b * 1.01, 1e-2, *rest)

    monkeypatch.setattr(_lu, "direct_solve", off)
    sol = solve_radiosity(op, jnp.full(p.n, 0.6), b0, rtol=1e-11)
    assert not sol.stats["direct"] and len(compiled) >= 1
    assert float(sol.residual) <= 1e-11  # the iterative solve's own answer, not the bad one


def test_other_methods_and_traced_solves_iterate(open_pair, compiled):
    p, op = open_pair
    rho = jnp.full(p.n, 0.6)
    b0 = jnp.asarray(np.random.default_rng(5).uniform(1.0, 10.0, (p.n, 2)))
    for method in ("bicgstab", Refined(direct=False)):  # a method, or the default told not to
        assert not solve_radiosity(op, rho, b0, solver=method, rtol=1e-9).stats["direct"]
    compiled.clear()
    direct = solve_radiosity(op, rho, b0, rtol=1e-11).value
    assert compiled == []
    # inside grad (and so jit): the implicit-differentiated Krylov solve, as before
    traced = []

    def total(r):
        value = solve_radiosity(op, r, b0, rtol=1e-11).value
        traced.append(isinstance(value, jax.core.Tracer))
        return value.sum(), value

    (_, value), g = jax.value_and_grad(total, has_aux=True)(rho)
    assert traced == [True] and len(compiled) >= 1  # the iterative program, traced
    np.testing.assert_allclose(np.asarray(value), np.asarray(direct), rtol=1e-9)
    assert np.all(np.isfinite(np.asarray(g))) and float(jnp.sum(g)) > 0


def test_the_patch_product_on_the_host_is_the_compiled_one(cube_room):
    # lighting/_solution.py: F'b of a small operator by numpy on the direct solve's matrix
    import dataclasses

    from lumijax.lighting._solution import _corrected_matmul, _corrected_matmul_kernel
    from lumijax.radiosity._operator import Info

    p, _, op = cube_room
    b = np.random.default_rng(6).uniform(0.0, 50.0, (p.n, 3))
    host = _corrected_matmul(op, jnp.asarray(b))
    assert isinstance(host, np.ndarray)
    kernel = np.asarray(_corrected_matmul_kernel(dataclasses.replace(op, info=Info()),
                                                 jnp.asarray(b)))
    np.testing.assert_allclose(host, kernel, rtol=1e-10)
