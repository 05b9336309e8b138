"""The constrained solve: minimise an objective (W, or a misfit) over the box of the design's
variables subject to hard constraints, by scipy's SLSQP (default) or trust-constr fed by JAX.

``f`` and the margins ``g`` (one per constraint, ≥ 0 when met; ``_constraints``) are compiled
once with their gradient and Jacobian (reverse mode: a few constraints, up to thousands of
variables). Over the dimmers alone (or any light model but the aim model's) one program gives
everything at a point — f, ∇f, the margins, their Jacobian and the exact criteria
(:func:`_evaluate`) — so SLSQP's function and constraint calls at an iterate share one
evaluation, the start, the KKT multipliers and the model's values at the end cost no other
compilation, and a design compiles two programs in all (this and the exact check of the lit
design, :func:`light_report`), where the demo's design compiled 48 before
(benchmarks/design.py). The aggregation of minima and maxima is solved by continuation: first
at ε = 10⁻² (gentle curvature, a good active set), then from there at the requested ε.

After the solve the Lagrange multipliers are recovered from the KKT conditions at the solution,
independently of the method: ``∇f = Σ μ_j ∇g_j + Σ ν_i (±e_i)`` over the active constraints and
bounds, μ, ν ≥ 0 by non-negative least squares. ``μ_j`` converts to the price of constraint j
in the objective's units per unit of its bound, ``∂f*/∂b_j = μ_j · sense_j / scale_j`` (the
envelope theorem), checked in tests by re-solving at a tightened bound.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._constraints import AbstractConstraint, DesignLight, constraint_margins, constraint_values
from ._models import AimLight

__all__ = ["DesignProblem", "ConstrainedRun", "solve_constrained", "kkt_multipliers",
           "exact_values", "objective_value", "light_report"]

_ACTIVE = 1e-3  # a margin (relative) below which a constraint counts as active
_COARSE = 1e-2  # the first aggregation ε of the continuation


class DesignProblem(eqx.Module):
    """Objective and constraints over the flat variables of a light model.

    ``model(x) -> (e, b, alpha)`` is one of ``_models``' light models; ``objective(light)`` is
    in natural units (W for power) and divided by ``objective_scale`` for the solver.
    """

    model: eqx.Module
    objective: eqx.Module
    constraints: tuple[AbstractConstraint, ...]
    objective_scale: float = eqx.field(static=True, default=1.0)

    def light(self, x) -> DesignLight:
        e, b, alpha = self.model(x)
        return DesignLight(e, b, alpha, x)

    def f(self, x):
        return self.objective(self.light(x)) / self.objective_scale

    def g(self, x, smooth):
        light = self.light(x)
        if not self.constraints:
            return jnp.zeros(0, x.dtype)
        return self.margins(light, smooth)

    def margins(self, light: DesignLight, smooth):
        """Every margin (``AbstractConstraint.margin``), the constraints of a kind evaluated
        together (``_constraints.constraint_margins``)."""
        return constraint_margins(self.constraints, light, smooth)

    def g_and_jac(self, x, smooth):
        """The margins and their Jacobian (constraints × variables). Through an aim model by
        its structured pull-back (``AimLight.linearise``): the constraints' cotangents on the
        light, then one pull-back of them all; through the dimmer model by ``vmap`` of one
        reverse pass (cheap: it is linear)."""
        eye = None
        if isinstance(self.model, AimLight):
            e, b, alpha, pull = self.model.linearise(x)
            g, vjp = jax.vjp(lambda e, b, a, x: self.margins(DesignLight(e, b, a, x), smooth),
                             e, b, alpha, x)
            eye = jnp.eye(g.shape[0], dtype=g.dtype)
            w_e, w_b, w_alpha, w_x = jax.vmap(vjp)(eye)
            return g, w_x + pull_in_chunks(pull, (w_e, w_b, w_alpha), self.model.pull_rows())
        g, vjp = jax.vjp(lambda x: self.g(x, smooth), x)
        eye = jnp.eye(g.shape[0], dtype=g.dtype)
        return g, jax.vmap(lambda w: vjp(w)[0])(eye)

    def values(self, x, smooth=None):
        light = self.light(x)
        return constraint_values(self.constraints, light, smooth) if (
            self.constraints) else jnp.zeros(0)

    @property
    def fused(self) -> bool:
        """Whether :func:`_evaluate` serves every call at a point: all light models but the
        aim model, whose Jacobian costs 2.4 margins (SLSQP's line search asks f and g alone)."""
        return not isinstance(self.model, AimLight)


def pull_in_chunks(pull, rows, size: int):
    """``pull(*rows)`` of cotangent rows (every array's leading axis; None passes through),
    ``size`` rows at a time in sequence (``jax.lax.map``), so that the pull-back's temporaries
    are those of one chunk. ``pull`` is linear: the last chunk is padded with zero rows and the
    padding sliced off."""
    m = next(r.shape[0] for r in rows if r is not None)
    if m <= size:
        return pull(*rows)
    n = -(-m // size)

    def chunked(r):
        pad = jnp.zeros((n * size - m, *r.shape[1:]), r.dtype)
        return jnp.concatenate([r, pad]).reshape(n, size, *r.shape[1:])

    out = jax.lax.map(lambda c: pull(*c), jax.tree.map(chunked, tuple(rows)))
    return out.reshape(n * size, *out.shape[2:])[:m]


@eqx.filter_jit
def _f_grad(problem, x):
    return jax.value_and_grad(problem.f)(x)


@eqx.filter_jit
def _g_traced(problem, x, smooth):
    return problem.g(x, smooth)


@eqx.filter_jit
def _g_jac_traced(problem, x, smooth):
    return _g_and_jac_traced(problem, x, smooth)[1]


def _g_and_jac_body(problem, x, smooth):
    """Margins and their Jacobian from one linearisation, so that SLSQP's ``cons`` and ``jac``
    at a point light it once."""
    if not problem.constraints:
        return jnp.zeros(0, x.dtype), jnp.zeros((0, x.shape[0]), x.dtype)
    return problem.g_and_jac(x, smooth)


_g_and_jac_traced = eqx.filter_jit(_g_and_jac_body)


@eqx.filter_jit
def _values_traced(problem, x):
    return problem.values(x)


@eqx.filter_jit
def _evaluate(problem, x, smooth):
    """``(f, ∇f, g, ∂g/∂x, exact values)`` at ``x`` in one program (``DesignProblem.fused``):
    for the dimmers everything is linear in α before the aggregations, so this graph is small
    and one compilation serves the whole design."""
    f, df = jax.value_and_grad(problem.f)(x)
    g, jac = _g_and_jac_body(problem, x, smooth)
    return f, df, g, jac, problem.values(x)


def _host(x):
    """A host float64 array: ``filter_jit`` takes a NumPy array as a traced argument (a NumPy
    scalar or a Python float would be static: a compilation per value)."""
    return np.asarray(x, np.float64)


# ε is an array (traced), so that the continuation's two ε compile once
def _g(problem, x, smooth):
    if problem.fused:
        return _evaluate(problem, _host(x), _host(smooth))[2]
    return _g_traced(problem, x, jnp.asarray(smooth, jnp.float64))


def _g_jac(problem, x, smooth):
    if problem.fused:
        return _evaluate(problem, _host(x), _host(smooth))[3]
    return _g_jac_traced(problem, x, jnp.asarray(smooth, jnp.float64))


def _value_and_grad(problem, x):
    """``(f, ∇f)`` at ``x`` (f divided by ``objective_scale``)."""
    if problem.fused:
        return _evaluate(problem, _host(x), _host(_COARSE))[:2]
    return _f_grad(problem, jnp.asarray(x))


def exact_values(problem, x):
    """Every constraint's exact value (natural units) at ``x``, compiled."""
    if problem.fused:
        return _evaluate(problem, _host(x), _host(_COARSE))[4]
    return _values_traced(problem, jnp.asarray(x))


def objective_value(problem, x) -> float:
    """The objective at ``x`` in natural units (W for power)."""
    return float(_value_and_grad(problem, x)[0]) * problem.objective_scale


@eqx.filter_jit
def _light_report(constraints, objective, light):
    return constraint_values(constraints, light, None), objective(light)


def light_report(constraints, objective, light: DesignLight) -> tuple[np.ndarray, float]:
    """``(exact values, objective)`` of a lit design's :class:`DesignLight` (natural units),
    in one compiled program: the check of the final design on the exact criteria."""
    if not constraints:
        return np.zeros(0), float(objective(light))
    v, f = _light_report(tuple(constraints), objective, light)
    return np.asarray(v, np.float64), float(f)


class _Margins:
    """``cons``/``jac`` callbacks of one solve: the margins and their Jacobian at the last point
    asked, computed together once (SLSQP asks both at each new iterate); for a fused problem
    with f and ∇f too (``value_and_grad``), all from one call of :func:`_evaluate`."""

    def __init__(self, problem, smooth):
        self.problem, self.smooth = problem, _host(smooth)
        self.key: bytes | None = None
        self.g = self.jac = np.zeros(0)
        self.f, self.df = 0.0, np.zeros(0)

    def _at(self, x):
        x = np.asarray(x, np.float64)
        if self.key != x.tobytes():
            if self.problem.fused:
                f, df, g, jac, _ = _evaluate(self.problem, x, self.smooth)
                self.f, self.df = float(f), np.asarray(df, np.float64)
            else:
                g, jac = _g_and_jac_traced(self.problem, jnp.asarray(x),
                                           jnp.asarray(self.smooth))
            self.g = np.asarray(g, np.float64)
            self.jac = np.asarray(jac, np.float64).reshape(-1, len(x))
            self.key = x.tobytes()

    def value_and_grad(self, x):
        if not self.problem.fused:
            v, g = _f_grad(self.problem, jnp.asarray(x))
            return float(v), np.asarray(g, np.float64)
        self._at(x)
        return self.f, self.df

    def cons(self, x):
        self._at(x)
        return self.g

    def jacobian(self, x):
        self._at(x)
        return self.jac


@dataclass
class ConstrainedRun:
    """Where the constrained solve stopped.

    ``objective`` is in natural units (W); ``violation`` the largest relative shortfall of a
    smoothed constraint (0 when every margin ≥ 0); ``multipliers`` the KKT μ per constraint
    (dimensionless, on the margins) and ``prices`` ``∂f*/∂bound`` in objective units per unit
    of each bound; ``active`` which constraints are active.
    """

    method: str
    x: np.ndarray
    objective: float
    violation: float
    iterations: int
    evaluations: int
    success: bool
    message: str
    history: list[float] = field(default_factory=list)
    multipliers: np.ndarray | None = None
    prices: np.ndarray | None = None
    active: np.ndarray | None = None
    seconds: float = 0.0


def _one_solve(problem, x0, lo, hi, smooth, method, max_steps, tol):
    from scipy.optimize import Bounds, NonlinearConstraint, minimize

    counter = {"n": 0}
    history: list[float] = []
    margins = _Margins(problem, smooth)
    cons, jac = margins.cons, margins.jacobian

    def fun(x):
        counter["n"] += 1
        return margins.value_and_grad(x)

    def callback(*args):
        xk = args[0] if not hasattr(args[0], "x") else args[0].x
        history.append(fun(np.asarray(xk))[0] * problem.objective_scale)

    free = np.asarray(lo) < np.asarray(hi)
    # a pinned variable is a bound with lo == hi; SLSQP takes it, trust-constr needs lo < hi
    lo_s = np.where(free, lo, lo - 1e-12) if method == "trust-constr" else lo
    bounds = Bounds(lo_s, np.where(free, hi, hi + 1e-12) if method == "trust-constr" else hi)
    m = len(problem.constraints)
    if method == "slsqp":
        kw = dict(constraints=[{"type": "ineq", "fun": cons, "jac": jac}] if m else [],
                  options=dict(maxiter=max_steps, ftol=tol * 1e-3))
        res = minimize(fun, x0, jac=True, method="SLSQP", bounds=bounds, callback=callback,
                       **kw)
    else:
        nl = [NonlinearConstraint(cons, 0.0, np.inf, jac=jac)] if m else []
        res = minimize(fun, x0, jac=True, method="trust-constr", bounds=bounds,
                       constraints=nl, callback=callback,
                       options=dict(maxiter=max_steps * 5, gtol=tol * 1e-2,
                                    xtol=tol * 1e-4, verbose=0))
    x = np.clip(np.asarray(res.x, np.float64), lo, hi)
    return x, res, counter["n"], history


def solve_constrained(problem: DesignProblem, x0, lo, hi, *, smooth: float = 1e-3,
                      method: str = "slsqp", max_steps: int = 200,
                      tolerance: float = 1e-3) -> ConstrainedRun:
    """Minimise ``problem.f`` over ``lo ≤ x ≤ hi`` with every margin ``g(x, smooth) ≥ 0``.

    ``tolerance`` is the relative violation accepted (margins ≥ −tolerance). Returns the last
    point (clipped to the box) with its KKT multipliers and prices. ``method``: a name of
    ``_augmented.CONSTRAINED_METHODS`` (``"auto"`` picks by the problem's size).
    """
    if method not in ("slsqp", "trust-constr"):  # "auto", "augmented_lagrangian": _augmented
        from ._augmented import CONSTRAINED_METHODS

        return CONSTRAINED_METHODS[method]().solve(problem, x0, lo, hi, smooth=smooth,
                                                   max_steps=max_steps, tolerance=tolerance)
    t0 = time.perf_counter()
    x = np.clip(np.asarray(x0, np.float64), lo, hi)
    schedule = [smooth] if smooth >= _COARSE else [_COARSE, smooth]
    iterations = evaluations = 0
    history = [objective_value(problem, x)]
    res = None
    for eps in schedule:
        x, res, n, hist = _one_solve(problem, x, lo, hi, eps, method, max_steps, tolerance)
        iterations += int(getattr(res, "nit", 0) or 0)
        evaluations += n
        history += hist
    g = np.asarray(_g(problem, x, smooth), np.float64)
    violation = float(np.max(-g, initial=0.0)) if g.size else 0.0
    violation = max(violation, 0.0)
    mu, prices, active = kkt_multipliers(problem, x, lo, hi, smooth)
    obj = objective_value(problem, x)
    return ConstrainedRun(
        method=method, x=x, objective=obj, violation=violation, iterations=iterations,
        evaluations=evaluations, success=bool(res.success) and violation <= tolerance,
        message=str(res.message), history=history + [obj], multipliers=mu, prices=prices,
        active=active, seconds=time.perf_counter() - t0)


def kkt_multipliers(problem: DesignProblem, x, lo, hi, smooth, *, active_tol: float = _ACTIVE):
    """``(μ, prices, active)`` at ``x``: non-negative multipliers of the active constraints
    and bounds that best satisfy ``∇f = Σ μ_j ∇g_j + Σ ν_i (±e_i)`` (NNLS), and the price of
    each constraint ``∂f*/∂b_j = μ_j · sense_j · objective_scale / scale_j`` (objective units
    per unit of the bound; 0 for an inactive constraint)."""
    from scipy.optimize import nnls

    x = np.asarray(x, np.float64)
    m = len(problem.constraints)
    if problem.fused:  # one call: ∇f, g and J at x
        _, grad, g, jac, _ = _evaluate(problem, x, _host(smooth))
    else:
        _, grad = _f_grad(problem, jnp.asarray(x))
        if m:
            g, jac = _g_and_jac_traced(problem, jnp.asarray(x), jnp.asarray(smooth, jnp.float64))
    grad = np.asarray(grad, np.float64)
    if m == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0, bool)
    g = np.asarray(g, np.float64)
    jac = np.asarray(jac, np.float64).reshape(m, -1)
    active = g <= active_tol
    span = np.maximum(np.asarray(hi) - np.asarray(lo), 1e-300)
    at_lo = (x - lo) <= 1e-6 * span
    at_hi = (hi - x) <= 1e-6 * span
    cols = [jac[active].T]
    n = len(x)
    eye = np.eye(n)
    cols += [eye[:, at_lo], -eye[:, at_hi]]
    a = np.concatenate(cols, axis=1)
    mu = np.zeros(m)
    if a.shape[1]:
        sol, _ = nnls(a, grad, maxiter=50 * a.shape[1] + 100)
        mu[active] = sol[:int(active.sum())]
    scales = np.array([c.scale for c in problem.constraints])
    senses = np.array([c.sense for c in problem.constraints], np.float64)
    prices = mu * senses * problem.objective_scale / scales
    return mu, prices, active & (mu > 1e-9)
