"""Progress from within a solve batch (``radiosity._progress``): the fraction a solver reports is
the log residual's, it changes no bit of the answer, and it reaches the caller's bar."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.radiosity import _progress, _solve, solve_radiosity
from lumijax.radiosity._solvers import Jacobi, Refined


def test_the_fraction_is_the_log_residual_of_a_furnace():
    # A closed cube of uniform ρ lit uniformly: Jacobi's k-th change is ρ^k (every row of F
    # sums to 1, to the row correction's rounding), so the residual has come f = k·log ρ/log tol
    # of the way after step k, and with the final residual's one product still due the batch
    # is k / (k/f + 1) done: even steps, the evenness a time-left estimate relies on.
    import trimesh

    from .conftest import room

    p, _, op = room(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), 0.5)
    rho, tol = 0.5, 1e-4
    seen = []
    with _progress.listening(seen.append) as listens:
        assert listens
        sol = solve_radiosity(op, jnp.full(p.n, rho, jnp.float32),
                              jnp.full((p.n, 1), 3.0, jnp.float32), solver=Jacobi().reporting(),
                              rtol=tol)
    steps = int(sol.iterations)
    assert steps == math.ceil(math.log(tol) / math.log(rho))  # 14: 0.5¹⁴ < 1e-4 < 0.5¹³
    f = [min(k * math.log(rho) / math.log(tol), 1.0) for k in range(1, steps + 1)]
    want = [k / (k / fk + 1) for k, fk in zip(range(1, steps + 1), f, strict=True)]
    np.testing.assert_allclose(seen, want, atol=2e-3)
    assert np.ptp(np.diff(seen[:-1])) < 2e-3  # equal steps up to the last
    assert seen[-1] == pytest.approx(steps / (steps + 1))


def test_the_fraction_at_the_edges():
    assert _progress.converged_fraction(1.0, 1e-4) == 0.0
    assert _progress.converged_fraction(1e-2, 1e-4) == pytest.approx(0.5)
    assert _progress.converged_fraction(1e-9, 1e-4) == 1.0
    assert _progress.converged_fraction(0.0, 1e-4) == 1.0
    assert _progress.converged_fraction(float("nan"), 1e-4) == 0.0
    assert _progress.converged_fraction(3.0, 1e-4) == 0.0  # a residual that grew: no progress
    # two steps halfway there: four in all, and one more step's work due after them
    assert _progress.batch_fraction(1e-2, 1e-4, 2, 1.0) == pytest.approx(2 / 5)
    assert _progress.batch_fraction(1e-5, 1e-4, 4, 1.0) == pytest.approx(4 / 5)
    assert _progress.batch_fraction(1.0, 1e-4, 3, 1.0) == 0.0


def test_one_listener_at_a_time():
    outer, inner = [], []
    with _progress.listening(outer.append) as first:
        with _progress.listening(inner.append) as second:
            _progress._tell(np.float32(1e-2), np.float32(1e-4), np.int32(2), np.float32(0))
            _progress._tell(np.float32(2e-2), np.float32(1e-4), np.int32(3), np.float32(0))
    _progress._tell(np.float32(1e-3), np.float32(1e-4), np.int32(3), np.float32(0))  # dropped
    assert (first, second) == (True, False)
    assert outer == [pytest.approx(0.5)] and inner == []  # and never back


@pytest.mark.parametrize("method", [Refined(direct=False), "southwell", "gmres"],
                         ids=["refined", "southwell", "gmres"])
def test_a_large_batch_reports_within_and_keeps_its_bits(cube_room, monkeypatch, method):
    p, _, op = cube_room
    rng = np.random.default_rng(1)
    rho = jnp.asarray(rng.uniform(0.3, 0.8, p.n), jnp.float32)
    b0 = jnp.asarray(rng.uniform(1.0, 100.0, (p.n, 6)), jnp.float32)  # six distinct columns
    seen = []
    quiet = solve_radiosity(op, rho, b0, solver=method, column_batch=3,
                            progress=lambda d, t: seen.append((d, t)))
    assert seen == [(3, 6), (6, 6)]  # a small solve: a report at the end of each batch
    monkeypatch.setattr(_solve, "REPORTED_SOLVE", 1)
    seen.clear()
    told = solve_radiosity(op, rho, b0, solver=method, column_batch=3,
                           progress=lambda d, t: seen.append((d, t)))
    np.testing.assert_array_equal(np.asarray(told.value), np.asarray(quiet.value))
    done = [d for d, _ in seen]
    assert {t for _, t in seen} == {6} and done == sorted(done) and done[-1] == 6
    assert 3 in done  # the first batch's end
    within = [d for d in done if d not in (3, 6)]
    if method == "gmres":  # lineax's own loop: reports at the batches' ends only
        assert within == []
    else:
        assert len(within) >= 2  # steps of each batch of three columns (1, 2 and 4, 5)
