"""The augmented-Lagrangian constrained method (``optimise._augmented``) against SLSQP and an
independent linear programme (HiGHS, point by point) on small problems: the same optimum within
1 %, the same active constraints, the same prices; its gradient (one reverse pass) against the
contraction of the structured Jacobian; the registry and the automatic choice by size."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.errors import ConfigError
from lumijax.lighting._solution import float64_scope
from lumijax.optimise._augmented import (
    AUTO_SLSQP_VARIABLES,
    CONSTRAINED_METHODS,
    _phr_value_and_grad,
    resolve_method,
    tighten_for_model_error,
)
from lumijax.optimise._constrained import (
    DesignProblem,
    _f_grad,
    _g_and_jac_traced,
    exact_values,
    solve_constrained,
)
from lumijax.optimise._constraints import (
    GridAverage,
    GridMinimum,
    GridUniformity,
    PowerModel,
)
from lumijax.optimise._models import DimmerLight

from .test_aim_jacobian import _problem
from .test_constrained import POWER, _c, _light, _lp

jax.config.update("jax_enable_x64", True)


def _dimmer_problem(cons, a):
    return DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(POWER)),
                         cons, objective_scale=float(POWER.sum()))


def three_dimmer_problem():
    """test_constrained's three networks with Eavg ≥ 220, Emin ≥ 50, U0 ≥ 0.3 (every method's
    first check): the light matrix and the problem."""
    a = _light()
    n = a.shape[1]
    return a, _dimmer_problem((_c(GridAverage, 220.0, 0, n), _c(GridMinimum, 50.0, 0, n),
                               _c(GridUniformity, 0.3, 0, n)), a)


def meets_the_lp_and_slsqp(method: str, *, violation: float, rel: float):
    """``method`` on :func:`three_dimmer_problem` checked against HiGHS's LP (the exact optimum
    and active set) and SLSQP (the KKT prices); ``violation`` and ``rel`` are the method's own
    tolerances (margins; objective vs SLSQP). Returns its result."""
    a, prob = three_dimmer_problem()
    res = solve_constrained(prob, np.ones(3), np.zeros(3), np.ones(3), method=method)
    sq = solve_constrained(prob, np.ones(3), np.zeros(3), np.ones(3), method="slsqp")
    lp = _lp(a, POWER, avg=220.0, emin=50.0, u0=0.3)
    assert res.method == method and res.success
    assert res.violation <= violation
    assert res.objective == pytest.approx(lp.fun, rel=2e-3)
    assert res.objective == pytest.approx(sq.objective, rel=rel)
    e = res.x @ a  # the design itself, not the solver's margins
    assert e.mean() >= 220 * (1 - violation) and e.min() >= 50 * (1 - violation)
    assert e.min() / e.mean() >= 0.3 * (1 - violation)
    mean = a.mean(axis=1)
    lp_active = [abs(lp.x @ mean - 220) < 1e-6, abs((lp.x @ a).min() - 50) < 1e-6 * 50,
                 abs((lp.x @ a).min() / (lp.x @ mean) - 0.3) < 1e-6]
    assert list(res.active) == lp_active == list(sq.active)
    # the prices are the KKT multipliers SLSQP's NNLS recovers
    np.testing.assert_allclose(res.prices, sq.prices, rtol=0.02, atol=1e-9)
    return res


def test_augmented_lagrangian_meets_the_lp_and_slsqp():
    """Eavg ≥, Emin ≥, U0 ≥ over three dimmers (linear per point: the LP is the exact optimum,
    test_constrained's problem): the augmented Lagrangian's least power is the LP's within the
    aggregation's ε, its active set the LP's, its multipliers SLSQP's KKT multipliers."""
    met = meets_the_lp_and_slsqp("augmented_lagrangian", violation=1e-6, rel=1e-3)
    assert met.evaluations > 0


def test_augmented_lagrangian_price_predicts_a_resolve():
    """The final multiplier of the active Eavg floor prices a 2 % tightening: the LP solved at
    both bounds (independent of the method) costs what it predicts within 5 % (the envelope
    theorem; SLSQP's prices are checked the same way in test_constrained)."""
    a = _light()
    n = a.shape[1]

    def solve(avg):
        prob = _dimmer_problem((_c(GridAverage, avg, 0, n), _c(GridMinimum, 50.0, 0, n),
                                _c(GridUniformity, 0.3, 0, n)), a)
        return solve_constrained(prob, np.ones(3), np.zeros(3), np.ones(3),
                                 method="augmented_lagrangian")

    base = solve(220.0)
    assert base.active[0] and base.prices[0] > 0
    predicted = base.prices[0] * 4.4
    lp_cost = (_lp(a, POWER, avg=224.4, emin=50.0, u0=0.3).fun
               - _lp(a, POWER, avg=220.0, emin=50.0, u0=0.3).fun)
    assert lp_cost > 0
    assert predicted == pytest.approx(lp_cost, rel=0.05)
    assert solve(224.4).objective - base.objective == pytest.approx(lp_cost, rel=0.05)


def test_augmented_lagrangian_reports_an_infeasible_problem():
    """An Eavg floor above what every dimmer at full output gives: the method returns (no
    success) with the shortfall as its violation, for the design layer's infeasibility proof."""
    a = _light()
    n = a.shape[1]
    full = float(a.sum(axis=0).mean())
    prob = _dimmer_problem((_c(GridAverage, 1.2 * full, 0, n),), a)
    run = solve_constrained(prob, np.full(3, 0.5), np.zeros(3), np.ones(3),
                            method="augmented_lagrangian")
    assert not run.success
    assert run.violation == pytest.approx(1 - 1 / 1.2, rel=1e-3)
    np.testing.assert_allclose(run.x, 1.0, atol=1e-6)


def test_registry_and_the_automatic_choice():
    assert set(CONSTRAINED_METHODS) == {"auto", "slsqp", "trust-constr", "augmented_lagrangian",
                                        "mma"}
    assert resolve_method("auto", AUTO_SLSQP_VARIABLES) == "slsqp"
    assert resolve_method("auto", AUTO_SLSQP_VARIABLES + 1) == "augmented_lagrangian"
    assert resolve_method("slsqp", 10**6) == "slsqp"
    with pytest.raises(ConfigError, match="augmented_lagrangian") as err:
        CONSTRAINED_METHODS["lancelot"]
    assert err.value.key == "optimise.method"
    # "auto" on a small problem is SLSQP, and says so
    a = _light()
    n = a.shape[1]
    prob = _dimmer_problem((_c(GridAverage, 220.0, 0, n),), a)
    run = solve_constrained(prob, np.ones(3), np.zeros(3), np.ones(3), method="auto")
    assert run.method == "slsqp"


def _aim_problem(study, results, cons_of):
    return _problem(study, results, ["dimmers", "aims"], cons_of)


def _AIM_CONSTRAINTS(c, s):
    return c(GridAverage, 0.6 * s["avg"]), c(GridUniformity, 0.8 * s["u0"])


@pytest.mark.slow  # three constrained solves through the aim model: ~25 s contended, compiles
def test_augmented_lagrangian_matches_slsqp_with_aims(facade_results):
    """Dimmers + the four spots' aims (±8°) on the optimiser tests' facade, Eavg ≥ 60 % and
    U0 ≥ 80 % of the start's: non-convex, but from the same start the augmented Lagrangian,
    SLSQP and the method of moving asymptotes reach the same least power (measured: equal to
    2e-7), the same active constraints and prices (MMA's within 1 % of SLSQP's converged to
    10⁻⁶: measured 0.16 %; the U0 price moved 6 % when MMA's last level waited for the margins
    within 10⁻⁴ only); MMA in at most 45 evaluations (measured 29, SLSQP 51, the augmented Lagrangian
    196: the regression bound of ``_mma``'s purpose). The prices against re-solves at tightened
    bounds: ``test_mma``."""
    study, results = facade_results
    with float64_scope():
        prob, params = _aim_problem(study, results, _AIM_CONSTRAINTS)
        lo, hi = np.asarray(params.lower), np.asarray(params.upper)
        x0 = np.asarray(params.x0)
        al = solve_constrained(prob, x0, lo, hi, method="augmented_lagrangian")
        sq = solve_constrained(prob, x0, lo, hi, method="slsqp")
        mm = solve_constrained(prob, x0, lo, hi, method="mma")
        assert al.success and sq.success and mm.success
        start = float(_f_grad(prob, jnp.asarray(x0))[0]) * 80.0
        assert al.objective < 0.8 * start  # the aims and dimmers really moved
        assert al.objective == pytest.approx(sq.objective, rel=0.01)
        assert mm.objective == pytest.approx(sq.objective, rel=1e-4)
        assert list(al.active) == list(sq.active) == list(mm.active) == [True, True]
        np.testing.assert_allclose(al.prices, sq.prices, rtol=0.05)
        # MMA's prices against SLSQP's converged ones: at its default tolerance (margins within
        # 10⁻³) SLSQP stops where its KKT fit of the U0 price is 1.4 % off (5.837 W against
        # 5.758 W at 10⁻⁶; MMA 5.767 W, its KKT test at 1.3·10⁻⁵), measured since the gather
        # finds each ray's patch exactly
        tight = solve_constrained(prob, x0, lo, hi, method="slsqp", tolerance=1e-6)
        np.testing.assert_allclose(mm.prices, tight.prices, rtol=0.01)
        assert mm.evaluations <= 45
        # the design meets the constraints on the model's exact (unsmoothed) criteria
        for run in (al, mm):
            light = prob.light(jnp.asarray(run.x))
            for con in prob.constraints:
                assert float(con.margin(light, None)) >= -1e-3


def test_one_reverse_pass_equals_the_jacobian_contraction(facade_results):
    """∇Φ by one reverse pass through the aim model (pair kernels, LU reflection) against
    ∇f − Σ max(0, λ − ρg) ∇g with ∇g the rows of the structured Jacobian
    (``AimLight.linearise``, itself checked against ``jax.jacrev``), at aims away from the
    start where the inter-reflected change is not zero."""
    study, results = facade_results
    with float64_scope():
        # the previous test's constraints: the same compiled programs serve both
        prob, params = _aim_problem(study, results, _AIM_CONSTRAINTS)
        rng = np.random.default_rng(5)
        lo, hi = np.asarray(params.lower), np.asarray(params.upper)
        x = jnp.asarray(lo + (hi - lo) * rng.uniform(size=lo.shape))
        lam = jnp.asarray([5.0, 5.0])  # large enough that both enter ∇Φ (λ − ρg > 0)
        # float64, not weakly typed: the arguments the solver passes, so that its programs,
        # compiled by the previous test, are not compiled again for another signature
        rho, eps = jnp.asarray(1.0, jnp.float64), jnp.asarray(1e-2, jnp.float64)
        (phi, (f, g)), grad = _phr_value_and_grad(prob, x, lam, rho, eps)
        g_ref, jac = _g_and_jac_traced(prob, x, eps)
        _, grad_f = _f_grad(prob, x)
        shifted = jnp.maximum(0.0, lam - rho * g_ref)
        assert int(jnp.sum(shifted > 0)) == 2
        ref = grad_f - shifted @ jac
        np.testing.assert_allclose(np.asarray(g), np.asarray(g_ref), rtol=1e-12, atol=1e-12)
        scale = float(jnp.max(jnp.abs(ref)))
        np.testing.assert_allclose(np.asarray(grad), np.asarray(ref), rtol=1e-7,
                                   atol=1e-9 * scale)
        k = len(study.scene.networks)
        assert float(jnp.max(jnp.abs(grad[k:]))) > 1e-3 * scale  # the aims' part is real
        want = f + (jnp.sum(shifted**2) - jnp.sum(lam**2)) / (2 * rho)
        assert float(phi) == pytest.approx(float(want), rel=1e-12)


def test_a_shortfall_of_the_model_is_closed_by_tightening():
    """The solver's light model 4 % off the true light on one network (as the aim model is off
    the recomputed study): the design it finds misses the true Eavg floor; the bounds moved by
    the model's error there and solved again meet the true constraint."""
    a = _light()
    n = a.shape[1]
    true = a.copy()
    true[1] *= 0.96  # what an exact recompute would light
    cons = (_c(GridAverage, 220.0, 0, n), _c(GridMinimum, 50.0, 0, n))
    model = _dimmer_problem(cons, a)
    exact = _dimmer_problem(cons, true)
    run = solve_constrained(model, np.ones(3), np.zeros(3), np.ones(3),
                            method="augmented_lagrangian")
    achieved = np.asarray(exact_values(exact, run.x))
    modelled = np.asarray(exact_values(model, run.x))
    assert achieved[0] < 220.0 * (1 - 1e-3)  # the model's design is short in truth
    tight, moved = tighten_for_model_error(model, achieved, modelled, 1e-3)
    assert moved == [0]
    assert float(tight.constraints[0].bound) == pytest.approx(220.0 + modelled[0] - achieved[0])
    again = solve_constrained(tight, run.x, np.zeros(3), np.ones(3),
                              method="augmented_lagrangian")
    met = np.asarray(exact_values(exact, again.x))
    assert met[0] >= 220.0 * (1 - 1e-3) and met[1] >= 50.0 * (1 - 1e-3)
    # nothing short: nothing moves
    assert tighten_for_model_error(exact, met, met, 1e-3)[1] == []
