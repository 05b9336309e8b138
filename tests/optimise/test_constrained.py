"""The constrained design solve on synthetic light (no study): against a linear programme and an
exhaustive grid search written here, its prices against re-solves, its aggregation bound, and
the minimal conflicting set of an infeasible problem against a hand-built LP."""

from __future__ import annotations

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import linprog

from lumijax.optimise._constrained import DesignProblem, solve_constrained
from lumijax.optimise._constraints import (
    GridAverage,
    GridMaximum,
    GridMinimum,
    GridUniformity,
    PowerModel,
    soft_max,
    soft_min,
)
from lumijax.optimise._infeasible import explain_infeasible
from lumijax.optimise._models import DimmerLight

jax.config.update("jax_enable_x64", True)

POWER = np.array([30.0, 50.0, 20.0])


def _light(k=3, n=120, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(20, 200, (k, n)) * rng.uniform(0.5, 1, (k, 1))


def _c(cls, bound, start, stop, sense=1, **kw):
    return cls(label=cls.__name__, key="k", unit="", sense=sense, bound=jnp.asarray(bound),
               ref=abs(bound), start=start, stop=stop, **kw)


def _lp(a, power, avg=None, emin=None, u0=None, emax=None):
    """min P·α s.t. the constraints written point by point (linear in α), 0 ≤ α ≤ 1."""
    rows, rhs = [], []
    mean = a.mean(axis=1)
    if avg is not None:
        rows.append(-mean[None])
        rhs.append([-avg])
    if emin is not None:
        rows.append(-a.T)
        rhs.append(np.full(a.shape[1], -emin))
    if u0 is not None:  # E_i ≥ u·Eavg at every point
        rows.append(-(a.T - u0 * mean[None]))
        rhs.append(np.zeros(a.shape[1]))
    if emax is not None:
        rows.append(a.T)
        rhs.append(np.full(a.shape[1], emax))
    res = linprog(power, A_ub=np.vstack(rows), b_ub=np.concatenate(rhs),
                  bounds=[(0, 1)] * a.shape[0], method="highs")
    return res


def test_soft_aggregation_is_conservative_within_its_stated_bound():
    rng = np.random.default_rng(1)
    for n in (2, 10, 1000):
        v = jnp.asarray(rng.uniform(0, 3, n))
        for eps in (1e-1, 1e-3):
            hi, lo = float(soft_max(v, eps)), float(soft_min(v, eps))
            assert float(v.max()) <= hi <= float(v.max()) + eps * (1 + 1e-9)
            assert float(v.min()) - eps * (1 + 1e-9) <= lo <= float(v.min())
    # ties: the bound is reached (N equal values give max + ε exactly)
    assert float(soft_max(jnp.ones(50), 0.01)) == pytest.approx(1.01, rel=1e-12)


def test_least_power_matches_a_linear_programme():
    """Eavg ≥, Emin ≥, U0 ≥ over dimmers: linear per point, so the LP (HiGHS, point by point,
    no aggregation) is the exact optimum. SLSQP on the aggregated constraints meets it within
    the aggregation's ε and finds the same active set."""
    a = _light()
    n = a.shape[1]
    cons = (_c(GridAverage, 220.0, 0, n), _c(GridMinimum, 50.0, 0, n),
            _c(GridUniformity, 0.3, 0, n))
    prob = DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(POWER)),
                         cons, objective_scale=float(POWER.sum()))
    run = solve_constrained(prob, np.ones(3), np.zeros(3), np.ones(3))
    lp = _lp(a, POWER, avg=220.0, emin=50.0, u0=0.3)
    assert lp.status == 0
    assert run.violation <= 1e-6
    assert run.objective == pytest.approx(lp.fun, rel=2e-3)
    # exact check of the returned design, not the solver's own margins
    e = run.x @ a
    assert e.mean() >= 220 * (1 - 1e-6) and e.min() >= 50 * (1 - 1e-6)
    assert e.min() / e.mean() >= 0.3 * (1 - 1e-6)
    # the active constraints: the LP's slacks at zero
    mean = a.mean(axis=1)
    lp_active = [abs(lp.x @ mean - 220) < 1e-6, abs((lp.x @ a).min() - 50) < 1e-6 * 50,
                 abs((lp.x @ a).min() / (lp.x @ mean) - 0.3) < 1e-6]
    assert sum(lp_active) == 2
    assert list(run.active) == lp_active


def test_least_power_matches_an_exhaustive_grid_search():
    """Three networks, an Eavg floor, an Emin floor and an Emax ceiling: every dimmer triple
    on a 0.005 grid is tried (8·10⁶ designs); the best feasible one is within 1 % of the
    constrained optimum, and the constrained optimum is never below it by more than the
    grid's resolution."""
    a = _light(seed=4)
    n = a.shape[1]
    floor_avg, floor_min, ceil_max = 150.0, 50.0, 300.0
    cons = (_c(GridAverage, floor_avg, 0, n), _c(GridMinimum, floor_min, 0, n),
            _c(GridMaximum, ceil_max, 0, n, sense=-1))
    prob = DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(POWER)),
                         cons, objective_scale=float(POWER.sum()))
    run = solve_constrained(prob, np.ones(3), np.zeros(3), np.ones(3))
    levels = np.linspace(0, 1, 201)
    best = np.inf
    best_x = None
    emin_pts, emax_pts = a.min(axis=1), a.max(axis=1)
    for a0 in levels:  # a grid over two dimmers at a time, vectorised over the third
        g1, g2 = np.meshgrid(levels, levels, indexing="ij")
        x = np.stack([np.full(g1.size, a0), g1.ravel(), g2.ravel()], axis=1)
        # cheap necessary tests first (bounds of min and max), then the exact ones
        ok = (x @ a.mean(axis=1) >= floor_avg) & (x @ emax_pts >= floor_min) & (
            x @ emin_pts <= ceil_max)
        if not ok.any():
            continue
        xs = x[ok]
        e = xs @ a
        feas = (e.min(axis=1) >= floor_min) & (e.max(axis=1) <= ceil_max)
        if feas.any():
            p = xs[feas] @ POWER
            j = int(np.argmin(p))
            if p[j] < best:
                best, best_x = float(p[j]), xs[feas][j]
    assert best_x is not None
    assert run.violation <= 1e-6
    assert abs(run.objective - best) <= 0.01 * best
    # the grid's designs are feasible designs: the optimum cannot be worse than the best one
    assert run.objective <= best * (1 + 1e-3)
    # same active constraints (exact slacks at the grid's best within its resolution)
    e = best_x @ a
    res = 0.005 * a.sum(axis=0).max()
    grid_active = [abs(e.mean() - floor_avg) < res, abs(e.min() - floor_min) < res,
                   abs(e.max() - ceil_max) < res]
    assert list(run.active) == grid_active


@pytest.mark.parametrize("which", [0, 2])
def test_prices_predict_the_cost_of_a_tightened_constraint(which):
    """The KKT price of an active constraint against re-solving with its bound tightened:
    "raising Eavg from 220 to 224.4 lx costs N W" to first order; the re-solve's real cost
    agrees within 5 % (the LP's value function is piecewise linear: exact within a piece)."""
    a = _light()
    n = a.shape[1]
    bounds = [220.0, 50.0, 0.3]
    classes = [GridAverage, GridMinimum, GridUniformity]

    def problem(bs):
        cons = tuple(_c(cls, b, 0, n) for cls, b in zip(classes, bs, strict=True))
        return DesignProblem(DimmerLight(jnp.asarray(a), None),
                             PowerModel(jnp.asarray(POWER)), cons,
                             objective_scale=float(POWER.sum()))

    base = solve_constrained(problem(bounds), np.ones(3), np.zeros(3), np.ones(3))
    assert base.active[which], "the test needs an active constraint"
    step = 0.02 * bounds[which]
    tight = list(bounds)
    tight[which] += step
    again = solve_constrained(problem(tight), base.x, np.zeros(3), np.ones(3))
    real = again.objective - base.objective
    predicted = base.prices[which] * step
    assert real > 0
    assert predicted == pytest.approx(real, rel=0.05)
    # and against the LP solved at both bounds (independent of the solver and its KKT)
    kw = dict(zip(("avg", "emin", "u0"), bounds, strict=True))
    kw_t = dict(zip(("avg", "emin", "u0"), tight, strict=True))
    lp_cost = _lp(a, POWER, **kw_t).fun - _lp(a, POWER, **kw).fun
    assert predicted == pytest.approx(lp_cost, rel=0.05)


def test_an_infeasible_problem_names_a_minimal_conflicting_set():
    """Two grids lit by the same networks: Eavg ≥ 150 lx on grid A and Emax ≤ 60 lx on grid B
    cannot hold together (A's light comes with B's); a third, unrelated floor on grid C is
    met. The conflict is {A's Eavg, B's Emax}; A's best achievable Eavg with B's ceiling met
    is the LP max of Eavg_A subject to E_B ≤ 60 at every point (solved here independently)."""
    rng = np.random.default_rng(7)
    k, n = 3, 40
    a = rng.uniform(50, 200, (k, 3 * n))
    cons = (_c(GridAverage, 150.0, 0, n), _c(GridMaximum, 60.0, n, 2 * n, sense=-1),
            _c(GridAverage, 20.0, 2 * n, 3 * n))
    prob = DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(POWER)),
                         cons, objective_scale=float(POWER.sum()))
    lo, hi = np.zeros(k), np.ones(k)
    run = solve_constrained(prob, np.ones(k), lo, hi)
    assert run.violation > 1e-2
    inf = explain_infeasible(prob, np.ones(k), lo, hi, smooth=1e-3, tolerance=1e-3,
                             labels=[f"dimmers[n{i}]" for i in range(k)])
    assert sorted(c.label for c in inf.conflict) == ["GridAverage", "GridMaximum"]
    lp = linprog(-a[:, :n].mean(axis=1), A_ub=a[:, n:2 * n].T, b_ub=np.full(n, 60.0),
                 bounds=[(0, 1)] * k, method="highs")
    avg = next(c for c in inf.conflict if c.label == "GridAverage")
    # the soft maximum is conservative by ≤ 0.1 %: the best achievable is at most that lower
    assert avg.best == pytest.approx(-lp.fun, rel=3e-3)
    assert avg.best < 150
    # B's ceiling, with A's floor met, is best at the LP min of max E_B s.t. mean E_A ≥ 150
    # (max over points by an epigraph variable t)
    c_lp = np.r_[np.zeros(k), 1.0]
    a_ub = np.vstack([np.c_[a[:, n:2 * n].T, -np.ones(n)],
                      np.r_[-a[:, :n].mean(axis=1), 0.0][None]])
    b_ub = np.r_[np.zeros(n), -150.0]
    lp2 = linprog(c_lp, A_ub=a_ub, b_ub=b_ub, bounds=[(0, 1)] * k + [(0, None)],
                  method="highs")
    emax = next(c for c in inf.conflict if c.label == "GridMaximum")
    if lp2.status == 0:
        assert emax.best == pytest.approx(lp2.fun, rel=3e-3)
    else:  # A's floor alone is out of reach: B's best is with A as high as it can go
        assert emax.best > 60
    assert all(c.needed for c in inf.conflict)


def test_a_conflict_among_many_satisfied_constraints_takes_few_checks(monkeypatch):
    """The conflict {A's Eavg ≥ 150, B's Emax ≤ 60} among ten floors met at any design with
    the networks on: the sensitivity filter keeps only what the least-shortfall point violates,
    so the set is found with a handful of feasibility solves (the deletion filter alone: one a
    constraint), and it is the hand-built LP's irreducible infeasible subset."""
    from lumijax.optimise import _infeasible

    rng = np.random.default_rng(7)
    k, n = 3, 40
    a = rng.uniform(50, 200, (k, 12 * n))
    cons = (_c(GridAverage, 150.0, 0, n), _c(GridMaximum, 60.0, n, 2 * n, sense=-1),
            *(_c(GridAverage, 5.0, g * n, (g + 1) * n) for g in range(2, 12)))
    prob = DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(POWER)),
                         cons, objective_scale=float(POWER.sum()))
    lo, hi = np.zeros(k), np.ones(k)
    calls = []
    real = _infeasible.find_feasible

    def counted(*args, **kw):
        calls.append(list(args[4]))
        return real(*args, **kw)

    monkeypatch.setattr(_infeasible, "find_feasible", counted)
    inf = explain_infeasible(prob, np.ones(k), lo, hi, smooth=1e-3, tolerance=1e-3,
                             labels=[f"dimmers[n{i}]" for i in range(k)])
    assert sorted(c.label for c in inf.conflict) == ["GridAverage", "GridMaximum"]
    assert {c.bound for c in inf.conflict} == {150.0, 60.0}
    # the phase-1 point, the violated pair at once, a check without each of the pair, and one
    # for each member's best achievable value: 6 (the deletion filter over all: 12 + 2)
    assert len(calls) <= 6
    # independently: HiGHS finds the pair infeasible and each of its members feasible alone
    mean = a.reshape(k, 12, n).mean(axis=2)
    rows = [-mean[:, 0], *(a[:, n:2 * n].T), *(-mean[:, g] for g in range(2, 12))]
    rhs = [-150.0, *np.full(n, 60.0), *np.full(10, -5.0)]
    status = linprog(np.zeros(k), A_ub=np.array(rows), b_ub=np.array(rhs),
                     bounds=[(0, 1)] * k, method="highs").status
    assert status == 2
    for drop in (slice(0, 1), slice(1, n + 1)):
        keep = np.ones(len(rows), bool)
        keep[drop] = False
        assert linprog(np.zeros(k), A_ub=np.array(rows)[keep], b_ub=np.array(rhs)[keep],
                       bounds=[(0, 1)] * k, method="highs").status == 0


def test_feasibility_of_problems_sharing_one_compiled_shortfall():
    """Problems of one structure share the compiled shortfall (their arrays passed each call):
    each is still judged on its own bounds and light, and a problem whose static values differ
    (another reference level) is not mistaken for one seen before."""
    from lumijax.optimise._infeasible import _COMPILED, find_feasible

    rng = np.random.default_rng(7)
    k, n = 3, 40
    a = rng.uniform(50, 200, (k, 2 * n))
    lo, hi = np.zeros(k), np.ones(k)

    def feasible(avg_floor, ref=100.0):  # the bound is an array, the reference level static
        c = GridAverage(label="GridAverage", key="k", unit="", sense=1,
                        bound=jnp.asarray(avg_floor), ref=ref, start=0, stop=n)
        prob = DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(POWER)),
                             (c, _c(GridMaximum, 60.0, n, 2 * n, sense=-1)),
                             objective_scale=float(POWER.sum()))
        return find_feasible(prob, [np.ones(k), hi], lo, hi, [0, 1], smooth=1e-3,
                             tolerance=1e-3)[0]

    # the LP's answer for each floor, independently
    best = -linprog(-a[:, :n].mean(axis=1), A_ub=a[:, n:].T, b_ub=np.full(n, 60.0),
                    bounds=[(0, 1)] * k, method="highs").fun
    _COMPILED.clear()
    assert feasible(0.5 * best) and not feasible(1.5 * best) and feasible(0.9 * best)
    assert len(_COMPILED) == 1  # one structure, one compiled shortfall
    assert not feasible(1.5 * best, ref=1.0) and feasible(0.5 * best, ref=1.0)
    assert len(_COMPILED) == 2


def test_exhaustive_small_grid_search_is_itself_sound():
    """The grid search above is an independent method only if it finds the LP's optimum on a
    problem where the LP is exact: checked once on two networks."""
    a = _light(k=2, seed=9)
    p = POWER[:2]
    lp = _lp(a, p, avg=150.0)
    levels = np.linspace(0, 1, 1001)
    x = np.array(list(itertools.product(levels, levels)))
    ok = x @ a.mean(axis=1) >= 150.0
    assert (x[ok] @ p).min() == pytest.approx(lp.fun, rel=5e-3)
