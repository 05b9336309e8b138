"""The compiled solve sees the patch axis padded to a bucket (radiosity/_solve.py): padding
changes no number, and two rooms of different patch counts share one compiled shape."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.radiosity import Refined, solve_radiosity
from lumijax.radiosity._solve import _solve, patch_bucket


def test_bucket_ladder():
    # by hand: multiples of 256 up to 4,096, then steps of 2^(ceil(log2 n) - 4)
    assert [patch_bucket(n) for n in (1, 300, 344, 1024, 1025, 4332, 16385, 100_000)] == \
        [256, 512, 512, 1024, 1280, 4608, 18432, 106496]
    for n in (1, 777, 5000, 33_333, 250_000):
        assert n <= patch_bucket(n) < n + max(n / 8, 256)


@pytest.mark.parametrize("rho", [0.9])
def test_padded_solve_against_dense_numpy(cube_room, rho):
    p, _, op = cube_room
    assert patch_bucket(p.n) > p.n  # the padding is exercised
    f = op.todense()
    rows = f.sum(axis=1)
    rng = np.random.default_rng(0)
    b0 = rng.uniform(0.0, 100.0, (p.n, 3))
    sol = solve_radiosity(op, jnp.full(p.n, rho), jnp.asarray(b0), rtol=1e-11,
                          solver=sol_solver())
    # independent: a closed box's outgoing light is normalised (F_ij -> F_ij / s_j, s the row
    # sums), then a dense solve of (I - rho F') B = B0
    assert bool(sol.stats["closed"])  # padding rows (row sum 0) do not spoil the closed test
    c = 1.0 / rows
    ref = np.linalg.solve(np.eye(p.n) - rho * f * c[None, :], b0)
    np.testing.assert_allclose(np.asarray(sol.value), ref, rtol=1e-9)
    assert float(np.max(np.asarray(sol.escaped))) < 1e-9
    # unpadded, the same compiled body gives the same numbers
    unpadded = _solve(op, jnp.full(p.n, rho), jnp.asarray(b0), sol_solver(), 1e-11, 1000, True)
    np.testing.assert_allclose(np.asarray(sol.value), np.asarray(unpadded[0]), rtol=1e-12)


def sol_solver():
    return Refined(direct=False)  # the padded program (a small room's direct solve pads nothing)


def test_small_solves_compile_unoptimised_and_large_ones_optimised():
    # radiosity/_solve.py, "Small solves": by the operator's bytes and b0's values; the demo
    # (31 MB, 3,584 × 60) compiles unoptimised, a 10 k-patch cube (231 MB, 1 column) optimised
    from types import SimpleNamespace

    from lumijax.radiosity._solve import (
        SMALL_OPERATOR_BYTES,
        SMALL_SOLVE,
        compiler_options,
        small_solve_options,
    )

    def op(mb):
        return SimpleNamespace(nbytes=int(mb * 1e6))

    assert SMALL_SOLVE == 262_144 and SMALL_OPERATOR_BYTES == 134_217_728
    assert compiler_options(op(13), np.zeros((1280, 3))) is small_solve_options()
    assert compiler_options(op(31), np.zeros((3584, 60))) is small_solve_options()
    assert compiler_options(op(63), np.zeros((5120, 4))) is small_solve_options()
    assert compiler_options(op(231), np.zeros((10_240, 1))) is None  # the operator decides
    assert compiler_options(op(31), np.zeros((3584, 60, 2))) is None  # the columns decide
    assert compiler_options(op(1), np.zeros((106_496, 1))) is small_solve_options()


def test_a_small_solve_asks_for_the_unoptimised_program_and_a_traced_one_does_not(
        cube_room, monkeypatch):
    # the options must reach the compiled call (the stored export's, the suite's cache being
    # on), and never a solve inside the caller's trace, where XLA refuses them
    import jax

    from lumijax import _executables
    from lumijax.radiosity._solve import small_solve_options

    p, _, op = cube_room
    asked, real = [], _executables.call

    def spy(*args, **kw):
        asked.append(kw.get("compiler_options"))
        return real(*args, **kw)

    monkeypatch.setattr(_executables, "call", spy)
    # the solve of test_padded_solve_against_dense_numpy (ρ, shape and tolerance): its compiled
    # program is reused; which options are asked for does not depend on the numbers
    rho = jnp.full(p.n, 0.9)
    b0 = jnp.asarray(np.random.default_rng(0).uniform(0.0, 100.0, (p.n, 3)))
    plain = solve_radiosity(op, rho, b0, rtol=1e-11, solver=sol_solver())
    assert asked == [small_solve_options()]
    traced = jax.jit(lambda r: solve_radiosity(op, r, b0, rtol=1e-11).value)(rho)
    assert asked[1:] in ([], [None])  # a traced call is not for the cache, nor for the options
    np.testing.assert_allclose(np.asarray(traced), np.asarray(plain.value), rtol=1e-12)


def test_the_small_programs_options_compile_and_an_unknown_option_is_left_out(monkeypatch):
    # lumijax._executables.unoptimised: the legacy fusion emitters only where XLA knows the
    # switch (an unknown option fails the compile: XLA is retiring that path)
    import jax

    from lumijax import _executables

    opts = _executables.unoptimised()
    assert opts["xla_backend_optimization_level"] == 0
    x = np.linspace(0.0, 1.0, 7, dtype=np.float32)
    got = jax.jit(lambda v: jnp.cumsum(v * v), compiler_options=opts)(x)
    np.testing.assert_allclose(np.asarray(got), np.cumsum(x * x), rtol=1e-6)
    quick = _executables.quick_to_compile()
    if quick is not None:  # this XLA has the switch: only it, LLVM's passes kept
        assert quick == {_executables.LEGACY_EMITTERS: False}
        assert opts == {**_executables.UNOPTIMISED, **quick}
    monkeypatch.setattr(_executables, "LEGACY_EMITTERS", "xla_cpu_no_such_option_here")
    assert _executables.unoptimised() == _executables.UNOPTIMISED
    assert _executables.quick_to_compile() is None
