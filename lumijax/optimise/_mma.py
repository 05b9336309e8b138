"""Constrained design in few light-model evaluations: Svanberg's globally convergent method of
moving asymptotes (GCMMA; K. Svanberg, "A class of globally convergent optimization methods
based on conservative convex separable approximations", SIAM J. Optim. 12, 2002, and "MMA and
GCMMA – two methods for nonlinear optimization", KTH 2007), the method structural optimisation
uses for the same shape of problem: many bounded variables (dimmers and thousands of aims),
few constraints (tens), each evaluation of the functions dear (here: a pass through the aim
model's pairs and its reflection solve).

Each outer step evaluates, once, the objective ``f₀``, its gradient, the constraints
``f_i = −g_i ≤ 0`` (the margins of ``_constraints``, relative, O(1)) and their Jacobian (the aim
model's structured pull-back, ``AimLight.linearise``: 2.4 margins on the demo). From them it
builds, for every function, a *convex separable* approximation

    f̃_i(x) = r_i + Σ_j p_ij / (U_j − x_j) + q_ij / (x_j − L_j),
    p_ij = (U_j − x_j)² (1.001 (∂_j f_i)⁺ + 0.001 (∂_j f_i)⁻ + ρ_i / Δ_j),
    q_ij = (x_j − L_j)² (0.001 (∂_j f_i)⁺ + 1.001 (∂_j f_i)⁻ + ρ_i / Δ_j)

(Δ_j the variable's range), exact in value and gradient at the point, whose curvature is set by
the moving asymptotes ``L < x < U``, per variable: they close in on a variable that oscillates
(×0.7) and open out on one that moves steadily (×1.2). The subproblem — minimise f̃₀ subject to
f̃_i ≤ 0 within move limits, with an elastic slack ``y_i`` (penalty ``c y + ½ y²``) so it is
always feasible — is separable, so its Lagrangian dual is a concave function of the m
multipliers only: for given λ each variable's minimiser is closed form, and the dual is
maximised by L-BFGS-B over m numbers, with no light-model evaluation. A candidate is accepted
when every approximation was conservative there (``f̃_i ≥ f_i``); else the offending ρ_i grow
and the subproblem is solved again (GCMMA's inner step: one evaluation of the light, no
gradient). That makes it globally convergent; in practice on these problems most candidates
are accepted at once.

Where the augmented Lagrangian (``_augmented``) needs hundreds of inner L-BFGS-B steps a
multiplier estimate (each a forward and reverse pass), a GCMMA step costs one margins-and-
Jacobian evaluation: on the facade and the courtyards the evaluations drop by an order of
magnitude (docs/optimise.md, "choice of method"). The final dual λ are the Lagrange
multipliers of the margins, so the prices come from them as the augmented Lagrangian's do.
The ε continuation is SLSQP's (ε = 10⁻² first, stopped at 10 × the tolerance, then ε), the
asymptotes and multipliers carried over.
"""

from __future__ import annotations

import time

import jax.numpy as jnp
import numpy as np

from ._constrained import (
    _ACTIVE,
    _COARSE,
    ConstrainedRun,
    DesignProblem,
    _evaluate,
    _f_grad,
    _g_and_jac_traced,
    _g_traced,
    _host,
)

__all__ = ["solve_mma"]

_ASYINIT = 0.5    # the first asymptotes at ± half the range from the point
_ASYINCR = 1.2    # opened out where a variable keeps its direction ...
_ASYDECR = 0.7    # ... closed in where it oscillates (Svanberg 2007's values)
_ALBEFA = 0.1     # the move limit stays a tenth of the way from the point to an asymptote
_MOVE = 0.5       # and within half the range
_RAA0 = 1e-5      # GCMMA's least curvature parameter ρ_i
_ELASTIC = 1e3    # c_i of the elastic slack: well above any multiplier of an O(1) problem
_INNER = 0        # GCMMA inner steps (ρ raised) per outer step at most: 0 is plain MMA
_CONSERVATIVE = 1e-6  # f − f̃ accepted (relative): the margins' own scale is O(1)
_COARSE_SLACK = 10.0  # at the first ε, stop at 10 × the tolerance (as _augmented)
_KKT_STOP = 1e-4  # the projected gradient of the Lagrangian (× each range) that ends a level
# ... with the margins within this fraction of the tolerance. The prices are read from the
# KKT conditions at the last point, so it must be nearly feasible and stationary: at 0.1 the
# facade's aims design stopped with its U0 margin 5·10⁻⁵ short, where the soft minimum's
# Jacobian in the aims is steep and still moving, and the U0 price came out 6 % off SLSQP's
# (5.2 % off a re-solve); at 0.01, 2 more evaluations (29) and 0.04 % (test_mma)
_FEAS_STOP = 0.01


class _Evaluator:
    """f₀ = f, ∇f, the margins g and their Jacobian at a point (the solver's sign: f_i = −g_i),
    counting light-model evaluations: one per point lit (with or without the pull-back)."""

    def __init__(self, problem: DesignProblem):
        self.problem = problem
        self.evaluations = 0
        self.checks = 0  # of which values only (no pull-back)
        self.m = len(problem.constraints)

    def full(self, x, eps):
        """``(f, ∇f, g, ∂g/∂x)`` at ``x`` (numpy float64)."""
        p = self.problem
        self.evaluations += 1
        if p.fused:
            f, df, g, jac, _ = _evaluate(p, _host(x), _host(eps))
        else:
            f, df = _f_grad(p, jnp.asarray(x))
            if self.m:
                g, jac = _g_and_jac_traced(p, jnp.asarray(x), jnp.asarray(eps, jnp.float64))
            else:
                g, jac = np.zeros(0), np.zeros((0, len(x)))
        return (float(f), np.asarray(df, np.float64), np.asarray(g, np.float64),
                np.asarray(jac, np.float64).reshape(self.m, len(x)))

    def values(self, x, eps):
        """``(f, g)`` at ``x`` without derivatives (GCMMA's conservativity check)."""
        p = self.problem
        self.evaluations += 1
        self.checks += 1
        if p.fused:
            f, _, g, _, _ = _evaluate(p, _host(x), _host(eps))
            return float(f), np.asarray(g, np.float64)
        f, _ = _f_grad(p, jnp.asarray(x))
        g = (_g_traced(p, jnp.asarray(x), jnp.asarray(eps, jnp.float64)) if self.m
             else np.zeros(0))
        return float(f), np.asarray(g, np.float64)


def _approximation(x, low, upp, df, span, raa):
    """``(p, q, r)`` of the convex separable approximations of every function (rows: f₀ and
    the constraints ``f_i``) at ``x``, exact in value (r set by the caller) and gradient."""
    pos, neg = np.maximum(df, 0.0), np.maximum(-df, 0.0)
    reg = raa[:, None] / span[None, :]
    ux2 = (upp - x) ** 2
    xl2 = (x - low) ** 2
    p = ux2[None, :] * (1.001 * pos + 0.001 * neg + reg)
    q = xl2[None, :] * (0.001 * pos + 1.001 * neg + reg)
    return p, q


def _approx_values(p, q, r, x, low, upp):
    return r + p @ (1.0 / (upp - x)) + q @ (1.0 / (x - low))


def _subproblem(p, q, r, low, upp, alpha, beta, lam0):
    """Solve ``min f̃₀ + Σ c y + ½ y²  s.t.  f̃_i − y_i ≤ 0, α ≤ x ≤ β, y ≥ 0`` by its dual
    (concave in λ ≥ 0, m numbers): ``(x, λ)``."""
    from scipy.optimize import minimize

    m = p.shape[0] - 1

    def x_of(lam):
        pj = p[0] + lam @ p[1:]
        qj = q[0] + lam @ q[1:]
        sp, sq = np.sqrt(pj), np.sqrt(qj)
        x = (sp * low + sq * upp) / np.maximum(sp + sq, 1e-300)
        return np.clip(x, alpha, beta)

    def negdual(lam):
        x = x_of(lam)
        fx = _approx_values(p, q, r, x, low, upp)
        y = np.maximum(lam - _ELASTIC, 0.0)
        w = fx[0] + lam @ fx[1:] + np.sum(_ELASTIC * y + 0.5 * y * y) - lam @ y
        return -w, -(fx[1:] - y)

    if m == 0:
        return x_of(np.zeros(0)), np.zeros(0)
    # SLSQP on the m multipliers (dense m × m: tens): scipy's L-BFGS-B took 25 ms a step on
    # this 3-variable dual (measured, contended), SLSQP 1 ms for the whole solve
    res = minimize(negdual, np.maximum(lam0, 0.0), jac=True, method="SLSQP",
                   bounds=[(0.0, None)] * m, options=dict(maxiter=500, ftol=1e-15))
    lam = np.maximum(res.x, 0.0)
    return x_of(lam), lam


def _kkt_free(df, jac, g, x, free, xmin, xmax, span, lam):
    """The multipliers of the active margins from the KKT conditions over the variables off
    their bounds, ``∇f = Σ μ_j ∇g_j`` there, μ ≥ 0 (non-negative least squares: m columns,
    where ``kkt_multipliers`` adds a column per bound, thousands with aims); the subproblem's
    λ where no variable is free or no constraint active."""
    from scipy.optimize import nnls

    xf = x[free]
    off = (xf > xmin + 1e-6 * span) & (xf < xmax - 1e-6 * span)
    active = g <= _ACTIVE
    if not off.any() or not active.any():
        return lam
    a = jac[active][:, free][:, off].T
    mu = np.zeros_like(lam)
    mu[active], _ = nnls(a, df[free][off], maxiter=50 * a.shape[1] + 100)
    return mu


def solve_mma(problem: DesignProblem, x0, lo, hi, *, smooth: float = 1e-3,
              max_steps: int = 200, tolerance: float = 1e-3, lam0=None,
              inner: int | None = None) -> ConstrainedRun:
    """Minimise ``problem.f`` over ``lo ≤ x ≤ hi`` subject to ``g(x, smooth) ≥ 0`` by GCMMA
    (the module docstring), with the ε continuation of the other methods.

    ``max_steps`` bounds the outer steps of each ε level; ``tolerance`` the accepted relative
    violation (margins ≥ −tolerance). A level ends when the design is feasible within
    :data:`_FEAS_STOP` × the tolerance (the last level; the coarse ε's within 10 × the
    tolerance) and either the projected gradient of the Lagrangian (times each variable's
    range) is below :data:`_KKT_STOP` or three steps in a row moved the objective by less than
    10⁻³ × the tolerance, relative (SLSQP's ``ftol``). ``iterations`` counts outer
    steps, ``evaluations`` every point lit (an outer step's margins-and-Jacobian, and each
    GCMMA inner check). ``inner``: GCMMA's conservativity checks per outer step at most
    (default :data:`_INNER` = 0, plain MMA: on the facade 31 evaluations against GCMMA's 64,
    the same optimum; docs/optimise.md). Multipliers: the KKT conditions over the variables
    off their bounds (:func:`_kkt_free`), else the last subproblem's λ."""
    n_inner = _INNER if inner is None else int(inner)
    t0 = time.perf_counter()
    lo_np, hi_np = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    x = np.clip(np.asarray(x0, np.float64), lo_np, hi_np)
    free = lo_np < hi_np
    span = np.where(free, hi_np - lo_np, 1.0)[free]
    xmin, xmax = lo_np[free], hi_np[free]
    m = len(problem.constraints)
    ev = _Evaluator(problem)
    lam = np.zeros(m) if lam0 is None else np.maximum(np.asarray(lam0, np.float64), 0.0)
    schedule = [smooth] if smooth >= _COARSE else [_COARSE, smooth]
    iterations = 0
    history: list[float] = []
    converged, message = False, ""
    low = upp = None
    xs: list[np.ndarray] = []  # the last two points' free parts, for the asymptotes
    g = np.zeros(m)
    for level, eps in enumerate(schedule):
        final = level == len(schedule) - 1
        accept = _FEAS_STOP * tolerance if final else _COARSE_SLACK * tolerance
        f, df, g, jac = ev.full(x, eps)
        if not history:
            history.append(f * problem.objective_scale)
        raa = np.full(m + 1, _RAA0)
        small = 0
        for step in range(max_steps):
            xf = x[free]
            grads = np.vstack([df[None, free], -jac[:, free]])
            vals = np.concatenate([[f], -g])
            # GCMMA's curvature parameters, from the gradients' size over the box
            raa = np.maximum(0.1 * raa, np.maximum(
                0.1 * np.mean(np.abs(grads) * span, axis=1), _RAA0)) if step == 0 else \
                np.maximum(0.1 * raa, _RAA0)
            # the moving asymptotes
            if len(xs) < 2 or low is None:
                low, upp = xf - _ASYINIT * span, xf + _ASYINIT * span
            else:
                sign = (xf - xs[-1]) * (xs[-1] - xs[-2])
                gamma = np.where(sign > 0, _ASYINCR, np.where(sign < 0, _ASYDECR, 1.0))
                low = xf - gamma * (xs[-1] - low)
                upp = xf + gamma * (upp - xs[-1])
                low = np.clip(low, xf - 10 * span, xf - 0.01 * span)
                upp = np.clip(upp, xf + 0.01 * span, xf + 10 * span)
            alpha = np.maximum.reduce([xmin, low + _ALBEFA * (xf - low), xf - _MOVE * span])
            beta = np.minimum.reduce([xmax, upp - _ALBEFA * (upp - xf), xf + _MOVE * span])
            for _inner in range(n_inner + 1):
                p, q = _approximation(xf, low, upp, grads, span, raa)
                r = vals - p @ (1.0 / (upp - xf)) - q @ (1.0 / (xf - low))
                x_new_f, lam_new = _subproblem(p, q, r, low, upp, alpha, beta, lam)
                x_new = x.copy()
                x_new[free] = x_new_f
                if _inner == n_inner:
                    break
                f_new, g_new = ev.values(x_new, eps)
                approx = _approx_values(p, q, r, x_new_f, low, upp)
                true = np.concatenate([[f_new], -g_new])
                # conservative within rounding of the functions' own scale
                short = true - approx > _CONSERVATIVE * (1.0 + np.abs(true))
                if not short.any():
                    break
                d = np.sum((upp - low) * (x_new_f - xf) ** 2
                           / ((upp - x_new_f) * (x_new_f - low) * span))
                delta = (true - approx) / max(d, 1e-300)
                raa = np.where(short, np.minimum(1.1 * (raa + delta), 10 * raa), raa)
            xs = (xs + [xf])[-2:]
            lam = lam_new
            f_old = f
            x_old = x
            x = x_new
            iterations += 1
            f, df, g, jac = ev.full(x, eps)
            history.append(f * problem.objective_scale)
            violation = float(np.max(-g, initial=0.0))
            # the projected gradient of the Lagrangian, f₀ + λ·(−g), times each range
            grad_l = (df - lam @ jac)[free]
            at_lo = x[free] <= xmin + 1e-9 * span
            at_hi = x[free] >= xmax - 1e-9 * span
            proj = np.where(at_lo, np.minimum(grad_l, 0.0),
                            np.where(at_hi, np.maximum(grad_l, 0.0), grad_l))
            kkt = float(np.max(np.abs(proj) * span, initial=0.0))
            moved = float(np.max(np.abs(x - x_old)[free] / span, initial=0.0))
            # SLSQP's test (its ftol = 10⁻³ × the tolerance), held for three steps
            small = small + 1 if abs(f - f_old) <= 1e-3 * tolerance * max(abs(f), 1.0) else 0
            if violation <= accept and (kkt <= _KKT_STOP or small >= 3):
                converged = final
                message = f"kkt {kkt:.1e}, step {moved:.1e}"
                break
        else:
            message = f"{max_steps} steps at ε = {eps:g}"
    message += (f"; {ev.evaluations - ev.checks} evaluations with the Jacobian, {ev.checks} "
                "conservativity checks (values only)")
    violation = max(float(np.max(-g, initial=0.0)), 0.0)
    if m:
        lam = _kkt_free(df, jac, g, x, free, xmin, xmax, span, lam)
    scales = np.array([c.scale for c in problem.constraints])
    senses = np.array([c.sense for c in problem.constraints], np.float64)
    prices = lam * senses * problem.objective_scale / scales if m else np.zeros(0)
    active = (g <= _ACTIVE) & (lam > 1e-9) if m else np.zeros(0, bool)
    obj = f * problem.objective_scale
    return ConstrainedRun(
        method="mma", x=x, objective=obj, violation=violation, iterations=iterations,
        evaluations=ev.evaluations, success=converged and violation <= tolerance,
        message=message, history=history, multipliers=lam, prices=prices, active=active,
        seconds=time.perf_counter() - t0)
