"""The aim model's structured Jacobian (``AimLight.linearise``: per-pair forward tangents, one
transposed LU solve for every constraint) against plain reverse-mode autodiff of the forward
model (``jax.jacrev`` of the margins), and its dense LU reflection against the study's Krylov
solve, at aims away from the start (where the inter-reflected change is not zero)."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.lighting._solution import float64_scope
from lumijax.optimise import _optimise
from lumijax.optimise._constrained import DesignProblem, _g_and_jac_traced
from lumijax.optimise._constraints import GridAverage, GridMinimum, GridUniformity
from lumijax.optimise._standard import _power_model


def _jacobian_constraints(c, stats):
    return (c(GridAverage, 30.0), c(GridMinimum, 5.0), c(GridUniformity, 0.2),
            c(GridAverage, 80.0, sense=-1))


def _problem(study, results, variables, cons_of=_jacobian_constraints):
    """The facade's design problem over ``variables`` (aims ±8°), its constraints made by
    ``cons_of(c, stats of the 'wall' grid)`` with ``c(cls, bound, sense)`` over that grid."""
    ocfg = _optimise._settings(study, dict(objective="power", variables=variables,
                                           tilt_range_deg=(-8.0, 8.0),
                                           pan_range_deg=(-8.0, 8.0)))
    setup = _optimise._setup(study, results, ocfg)
    n = len(study.scene.grids[0])

    def c(cls, bound, sense=1):
        return cls(label=cls.__name__, key="k", unit="", sense=sense, bound=jnp.asarray(bound),
                   ref=abs(bound), start=0, stop=n)

    cons = cons_of(c, results.grids["wall"].stats)
    return (DesignProblem(setup.model, _power_model(setup, study.scene), cons,
                          objective_scale=80.0), setup.params)


@pytest.mark.parametrize("variables", [["dimmers", "aims", "levels"]])
def test_structured_jacobian_equals_reverse_mode(facade_results, variables):
    study, results = facade_results
    with float64_scope():
        problem, params = _problem(study, results, variables)
        assert problem.model.lu is not None  # the facade's 200 patches: the dense path
        rng = np.random.default_rng(3)
        lo, hi = np.asarray(params.lower), np.asarray(params.upper)
        x = jnp.asarray(lo + (hi - lo) * rng.uniform(size=lo.shape))
        smooth = jnp.asarray(1e-2)
        g, jac = _g_and_jac_traced(problem, x, smooth)
        # the reference compiled as one program: run op by op, its ~200 primitives each
        # compiled on their own take twice as long (the same reverse-mode arithmetic)
        ref = eqx.filter_jit(lambda p, x, s: jax.jacrev(p.g)(x, s))(problem, x, smooth)
        g_ref = eqx.filter_jit(lambda p, x, s: p.g(x, s))(problem, x, smooth)
        np.testing.assert_allclose(np.asarray(g), np.asarray(g_ref), rtol=1e-12, atol=1e-12)
        scale = float(jnp.max(jnp.abs(ref)))
        assert scale > 0
        np.testing.assert_allclose(np.asarray(jac), np.asarray(ref), rtol=1e-7,
                                   atol=1e-9 * scale)
        # the aims really move the constraints (the test would pass trivially otherwise)
        k = len(study.scene.networks)
        assert float(jnp.max(jnp.abs(jac[:, k:]))) > 1e-3 * scale


def test_dense_reflection_equals_the_krylov_solve(facade_results):
    study, results = facade_results
    with float64_scope():
        problem, params = _problem(study, results, ["dimmers", "aims"])
        model = problem.model
        krylov = eqx.tree_at(lambda m: m.lu, model, None, is_leaf=lambda v: v is None)
        x0 = np.asarray(params.x0)
        x = jnp.asarray(np.clip(x0 + 0.1, params.lower, params.upper))
        e1, b1, _ = model(x)
        e2, b2, _ = krylov(x)
        e0, b0, _ = model(jnp.asarray(x0))
        moved = float(jnp.max(jnp.abs(b1 - b0)))
        assert moved > 1e-3 * float(jnp.max(b1))  # the change of inter-reflection is real
        np.testing.assert_allclose(np.asarray(b1), np.asarray(b2), rtol=0,
                                   atol=1e-6 * float(jnp.max(b1)))
        np.testing.assert_allclose(np.asarray(e1), np.asarray(e2), rtol=0,
                                   atol=1e-6 * float(jnp.max(e1)))


def test_the_krylov_branch_gives_the_dense_jacobian(facade_results):
    """Above ``DENSE_PATCHES`` the aim model pulls the constraints' float64 rows back through
    the study's Krylov solve (a float32 operator here): the same Jacobian as the dense LU's.
    (The pull-back once failed on the cotangent's dtype: float64 rows against the solve's
    float32 output; only the 8-bay courtyard, 7,264 patches, took that branch.) The facade is
    float64; its form factors are cast to float32 for the Krylov branch, as a float32 study's
    are stored."""
    study, results = facade_results
    with float64_scope():
        # the variables of the reverse-mode test above: its dense program serves here as well
        problem, params = _problem(study, results, ["dimmers", "aims", "levels"])
        krylov = eqx.tree_at(lambda p: p.model.lu, problem, None, is_leaf=lambda v: v is None)

        def f32(a):
            return a.astype(jnp.float32) if eqx.is_inexact_array(a) else a

        krylov = eqx.tree_at(lambda p: p.model.transport.buckets, krylov,
                             jax.tree.map(f32, krylov.model.transport.buckets))
        assert problem.model.lu is not None and krylov.model.lu is None
        x = jnp.asarray(np.clip(np.asarray(params.x0) + 0.05, params.lower, params.upper))
        smooth = jnp.asarray(1e-2)
        g1, j1 = _g_and_jac_traced(problem, x, smooth)
        g2, j2 = _g_and_jac_traced(krylov, x, smooth)
        scale = float(jnp.max(jnp.abs(j1)))
        # float32 form factors and the Krylov solve's tolerance: agreement to ~1e-4, not 1e-12
        np.testing.assert_allclose(np.asarray(g2), np.asarray(g1), rtol=3e-4, atol=1e-5)
        np.testing.assert_allclose(np.asarray(j2), np.asarray(j1), rtol=0, atol=1e-4 * scale)


def test_the_pull_back_in_chunks_is_the_pull_back_at_once(facade_results):
    """Constraints' rows pulled back a few at a time (``pull_in_chunks``, what keeps a large
    study's Jacobian within memory) give the rows pulled back all at once, for chunk sizes
    that divide the rows, leave a padded last chunk, or hold them all; a budget too small for
    one row still pulls back one at a time."""
    from lumijax.optimise._constrained import pull_in_chunks

    study, results = facade_results
    with float64_scope():
        problem, params = _problem(study, results, ["dimmers", "aims", "levels"])
        model = problem.model
        x = jnp.asarray(np.clip(np.asarray(params.x0) + 0.05, params.lower, params.upper))
        sizes = (1, 2, 3, 5, 8)

        # one program: the linearisation, its pull-back at once and in chunks of each size
        # (run op by op and compiled a size at a time, they take nearly twice as long)
        @eqx.filter_jit
        def pulled(model, x, rows):
            pull = model.linearise(x)[3]
            return pull(*rows), [pull_in_chunks(pull, rows, size) for size in sizes]

        shapes = jax.eval_shape(lambda x: model.linearise(x)[:3], x)
        rng = np.random.default_rng(11)
        rows = tuple(None if a is None else jnp.asarray(rng.normal(size=(5, *a.shape)))
                     for a in shapes)
        full, chunked = pulled(model, x, rows)
        full = np.asarray(full)
        assert full.shape == (5, x.shape[0]) and np.abs(full).max() > 0
        for got in chunked:
            np.testing.assert_allclose(np.asarray(got), full, rtol=1e-12,
                                       atol=1e-12 * np.abs(full).max())
        assert model.pull_rows(budget_bytes=1) == 1
        assert model.pull_rows(budget_bytes=1 << 40) > 5
