"""Large-scale constrained design: an augmented Lagrangian whose inner problem is scipy's
bound-constrained L-BFGS-B, and the registry of the constrained methods (``[optimise] method``).

SLSQP (``_constrained``) keeps a dense n × n quasi-Newton matrix and solves a dense
least-squares subproblem every step: O(n²) memory and O(n³) work a step in the number of
variables, and it needs the whole m × n Jacobian of the constraints at every iterate. With
dimmers and the aims of thousands of luminaires (tilt and pan each: n > 6,000) neither scales.
A design problem has *few* constraints (tens) and *many* bounded variables, the case the
augmented Lagrangian of Powell, Hestenes and Rockafellar (PHR; Conn, Gould & Toint's LANCELOT,
Birgin & Martínez's ALGENCAN) is made for: the bounds stay exact in the inner solver, the
constraints enter the inner objective

    Φ(x; λ, ρ) = f(x) + (1 / 2ρ) Σ_j [max(0, λ_j − ρ g_j(x))² − λ_j²]

(``g_j ≥ 0`` the margins of ``_constraints``: relative, O(1); f scaled to O(1)), and

    ∇Φ = ∇f − Σ_j max(0, λ_j − ρ g_j) ∇g_j

is *one* reverse pass (VJP) through the light model — the aim model's pair kernels and its
reflection solve — whatever the number of constraints: no Jacobian is ever formed. L-BFGS-B
keeps 2 × 10 vectors of n. After each inner solve ``λ_j ← max(0, λ_j − ρ g_j)`` (the first-order
multiplier update) and ρ grows ×10 when the infeasibility–complementarity measure
``max_j |min(g_j, λ_j/ρ)|`` did not fall below a quarter of its previous value. At the end λ are
the Lagrange multipliers of the margins, the μ of ``_constrained.kkt_multipliers``: the prices
the design reports come from them directly (no NNLS over thousands of active bounds).

The registry :data:`CONSTRAINED_METHODS` maps ``[optimise] method`` to a method object;
``"auto"`` (the default) picks SLSQP up to :data:`AUTO_SLSQP_VARIABLES` free variables and the
augmented Lagrangian above (measurements in docs/optimise.md).
"""

from __future__ import annotations

import abc
import time
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._registry import Registry
from ..config._design_goals import ConstrainedMethod
from ._constrained import _ACTIVE, _COARSE, ConstrainedRun, DesignProblem

__all__ = ["CONSTRAINED_METHODS", "AUTO_SLSQP_VARIABLES", "AbstractConstrainedMethod",
           "AugmentedLagrangian", "MMA", "SLSQP", "TrustConstr", "AutoConstrained",
           "solve_augmented", "resolve_method", "tighten_for_model_error"]

AUTO_SLSQP_VARIABLES = 1000
"""``method = "auto"``: SLSQP up to this many free variables, the augmented Lagrangian above.
SLSQP's step is O(n³) in the variables (its dense least-squares subproblem) and it needs the
m × n Jacobian at every iterate; measured (docs/optimise.md, contended) on a synthetic linear
design of 3 constraints its step took 0.2 s at 250 variables, 0.9 s at 1,000, 6.3 s at 2,000 and
29 s at 6,000, the augmented Lagrangian's 15–95 ms. Where an evaluation of the light is dear
(the demo's aim model, 470 variables) SLSQP's fewer evaluations win: it keeps problems up to
1,000 variables."""


class AbstractConstrainedMethod(eqx.Module):
    """A constrained solver of a :class:`~._constrained.DesignProblem`: ``name`` is its key in
    :data:`CONSTRAINED_METHODS`."""

    name: eqx.AbstractClassVar[str]

    @abc.abstractmethod
    def solve(self, problem: DesignProblem, x0, lo, hi, *, smooth: float, max_steps: int,
              tolerance: float) -> ConstrainedRun:
        """Minimise ``problem.f`` over the box with every margin ``≥ −tolerance``."""


class SLSQP(AbstractConstrainedMethod):
    """scipy's SLSQP on the JAX margins and their Jacobian (``_constrained``)."""

    name: ClassVar[str] = "slsqp"

    def solve(self, problem, x0, lo, hi, *, smooth, max_steps, tolerance):
        from ._constrained import solve_constrained

        return solve_constrained(problem, x0, lo, hi, smooth=smooth, method=self.name,
                                 max_steps=max_steps, tolerance=tolerance)


class TrustConstr(SLSQP):
    """scipy's trust-constr (interior point), kept for comparison (docs/optimise.md)."""

    name: ClassVar[str] = "trust-constr"


class MMA(AbstractConstrainedMethod):
    """Svanberg's globally convergent method of moving asymptotes (``_mma``)."""

    name: ClassVar[str] = "mma"

    def solve(self, problem, x0, lo, hi, *, smooth, max_steps, tolerance):
        from ._mma import solve_mma

        return solve_mma(problem, x0, lo, hi, smooth=smooth, max_steps=max_steps,
                         tolerance=tolerance)


class AugmentedLagrangian(AbstractConstrainedMethod):
    """The PHR augmented Lagrangian with L-BFGS-B inner solves (the module docstring)."""

    name: ClassVar[str] = "augmented_lagrangian"

    def solve(self, problem, x0, lo, hi, *, smooth, max_steps, tolerance):
        return solve_augmented(problem, x0, lo, hi, smooth=smooth, max_steps=max_steps,
                               tolerance=tolerance)


def resolve_method(name: str, n_free: int) -> str:
    """The method ``name`` stands for on a problem of ``n_free`` free variables (``"auto"``:
    by :data:`AUTO_SLSQP_VARIABLES`; any other name is itself)."""
    if name != "auto":
        return name
    return "slsqp" if n_free <= AUTO_SLSQP_VARIABLES else "augmented_lagrangian"


class AutoConstrained(AbstractConstrainedMethod):
    """SLSQP on small problems, the augmented Lagrangian on large ones (:func:`resolve_method`)."""

    name: ClassVar[str] = "auto"

    def solve(self, problem, x0, lo, hi, *, smooth, max_steps, tolerance):
        n_free = int(np.sum(np.asarray(lo) < np.asarray(hi)))
        method = CONSTRAINED_METHODS[resolve_method(self.name, n_free)]()
        return method.solve(problem, x0, lo, hi, smooth=smooth, max_steps=max_steps,
                            tolerance=tolerance)


#: ``optimise.method`` name -> constrained method class.
CONSTRAINED_METHODS: Registry[type[AbstractConstrainedMethod]] = Registry(
    "optimise.method", ConstrainedMethod,
    {cls.name: cls for cls in (AutoConstrained, SLSQP, TrustConstr, AugmentedLagrangian, MMA)})


# --- the augmented Lagrangian -------------------------------------------------------------

_GROW = 10.0      # ρ's growth when the infeasibility did not fall enough
_SHRINK = 0.25    # ... "enough": below this fraction of the previous outer step's
# first penalty (margins and f are O(1)); 1 took 112 evaluations on the facade against 196,
# but stopped 7.5e-5 short of the LP problem's Eavg floor (10: 1e-10)
_RHO0 = 10.0
_RHO_MAX = 1e8
_OUTER = 30       # outer steps per smoothing level at most
_MEMORY = 10      # L-BFGS-B's pairs of correction vectors
_GTOL0 = 1e-3     # the first inner solve's projected-gradient tolerance (f is O(1)) ...
_GTOL = 1e-6      # ... tightened ×0.1 an outer step down to this
_COARSE_SLACK = 10.0  # at the first ε, stop at 10 × the tolerance: only the active set matters


def _phr(problem: DesignProblem, x, lam, rho, smooth):
    """``(Φ, (f, g))``: the PHR augmented Lagrangian, the objective and the margins, from one
    lighting of ``x`` (f and g share it)."""
    light = problem.light(x)
    f = problem.objective(light) / problem.objective_scale
    g = problem.margins(light, smooth)
    shifted = jnp.maximum(0.0, lam - rho * g)
    return f + (jnp.sum(shifted * shifted) - jnp.sum(lam * lam)) / (2.0 * rho), (f, g)


@eqx.filter_jit
def _phr_value_and_grad(problem, x, lam, rho, smooth):
    """Φ and ∇Φ (one reverse pass through the light model), with f and g at ``x``."""
    return jax.value_and_grad(_phr, argnums=1, has_aux=True)(problem, x, lam, rho, smooth)


@eqx.filter_jit
def _f_and_g(problem, x, smooth):
    light = problem.light(x)
    return problem.objective(light) / problem.objective_scale, problem.margins(light, smooth)


def _measure(g, lam, rho) -> float:
    """ALGENCAN's infeasibility–complementarity measure ``max_j |min(g_j, λ_j/ρ)|``."""
    return float(np.max(np.abs(np.minimum(g, lam / rho)), initial=0.0))


def solve_augmented(problem: DesignProblem, x0, lo, hi, *, smooth: float = 1e-3,
                    max_steps: int = 200, tolerance: float = 1e-3,
                    lam0=None) -> ConstrainedRun:
    """Minimise ``problem.f`` over ``lo ≤ x ≤ hi`` subject to ``g(x, smooth) ≥ 0`` by the PHR
    augmented Lagrangian (the module docstring), with the same ε continuation as SLSQP
    (``_constrained.solve_constrained``: ε = 10⁻² first, then ``smooth``).

    ``max_steps`` bounds the L-BFGS-B iterations of each inner solve; ``tolerance`` is the
    accepted relative violation (margins ≥ −tolerance) and, with complementarity, the outer
    stopping test. ``iterations`` counts every inner L-BFGS-B step, ``evaluations`` every Φ
    and ∇Φ evaluation. The multipliers are the final λ; prices ``λ_j · sense_j ·
    objective_scale / scale_j`` as in :func:`~._constrained.kkt_multipliers`.
    """
    from scipy.optimize import minimize

    t0 = time.perf_counter()
    lo_np, hi_np = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    x = np.clip(np.asarray(x0, np.float64), lo_np, hi_np)
    m = len(problem.constraints)
    bounds = list(zip(lo_np, hi_np, strict=True))
    lam = np.zeros(m) if lam0 is None else np.maximum(np.asarray(lam0, np.float64), 0.0)
    rho = _RHO0
    iterations = evaluations = 0
    f0, _ = _f_and_g(problem, jnp.asarray(x), jnp.asarray(smooth, jnp.float64))
    history = [float(f0) * problem.objective_scale]
    message, converged = "", False
    schedule = [smooth] if smooth >= _COARSE else [_COARSE, smooth]
    gtol = _GTOL0  # the inner tolerance on the projected gradient tightens with the steps
    outer: list[tuple[int, int]] = []  # (inner steps, evaluations) of each inner solve
    for level, eps in enumerate(schedule):
        eps_j = jnp.asarray(eps, jnp.float64)
        prev = np.inf
        final = level == len(schedule) - 1
        accept = tolerance if final else _COARSE_SLACK * tolerance
        for _ in range(_OUTER):
            lam_j, rho_j = jnp.asarray(lam), jnp.asarray(rho, jnp.float64)

            def fun(xk, lam_j=lam_j, rho_j=rho_j, eps_j=eps_j):
                nonlocal evaluations
                evaluations += 1
                (v, _), grad = _phr_value_and_grad(problem, jnp.asarray(xk), lam_j, rho_j,
                                                   eps_j)
                return float(v), np.asarray(grad, np.float64)

            res = minimize(fun, x, jac=True, method="L-BFGS-B", bounds=bounds,
                           options=dict(maxiter=max_steps, maxfun=4 * max_steps, gtol=gtol,
                                        ftol=1e-12, maxcor=_MEMORY))
            x = np.clip(np.asarray(res.x, np.float64), lo_np, hi_np)
            iterations += int(res.nit)
            outer.append((int(res.nit), int(res.nfev)))
            f, g = _f_and_g(problem, jnp.asarray(x), eps_j)
            g = np.asarray(g, np.float64)
            history.append(float(f) * problem.objective_scale)
            lam = np.maximum(0.0, lam - rho * g)
            measure = _measure(g, lam, rho)
            violation = float(np.max(-g, initial=0.0))
            message = str(res.message)
            done = violation <= accept and measure <= accept
            if done and (not final or gtol <= _GTOL * 1.0001):
                converged = final
                break
            if measure > _SHRINK * prev:
                rho = min(rho * _GROW, _RHO_MAX)
            prev = measure
            gtol = max(gtol * 0.1, _GTOL)
    # where the evaluations went: outer steps × inner L-BFGS-B steps (docs/optimise.md)
    message += (f"; {len(outer)} outer steps, inner steps {[o[0] for o in outer]}, "
                f"evaluations {[o[1] for o in outer]}")
    x_j = jnp.asarray(x)
    f, g = _f_and_g(problem, x_j, jnp.asarray(smooth, jnp.float64))
    g = np.asarray(g, np.float64)
    violation = max(float(np.max(-g, initial=0.0)), 0.0)
    scales = np.array([c.scale for c in problem.constraints])
    senses = np.array([c.sense for c in problem.constraints], np.float64)
    prices = lam * senses * problem.objective_scale / scales if m else np.zeros(0)
    active = (g <= _ACTIVE) & (lam > 1e-9) if m else np.zeros(0, bool)
    obj = float(f) * problem.objective_scale
    return ConstrainedRun(
        method=AugmentedLagrangian.name, x=x, objective=obj, violation=violation,
        iterations=iterations, evaluations=evaluations,
        success=converged and violation <= tolerance, message=message,
        history=history + [obj], multipliers=lam, prices=prices, active=active,
        seconds=time.perf_counter() - t0)


# --- a shortfall after the exact recompute ------------------------------------------------

def tighten_for_model_error(problem: DesignProblem, achieved, modelled,
                            tolerance: float) -> tuple[DesignProblem, list[int]]:
    """The problem with each constraint the exact recompute found short (relative margin below
    ``−tolerance``) moved by the light model's error there: ``bound' = bound − (achieved −
    model)`` (natural units, either sense), so that the model meeting ``bound'`` is the exact
    criterion meeting ``bound`` to first order in the error. ``achieved`` are the exact
    values at the design, ``modelled`` the model's (``exact_values``). Returns the problem and
    the indices moved (none: the problem itself)."""
    moved, cons = [], list(problem.constraints)
    for j, (c, v, vm) in enumerate(zip(cons, achieved, modelled, strict=True)):
        margin = c.sense * (float(v) - float(c.bound)) / c.scale
        if margin < -tolerance:
            cons[j] = c.with_bound(float(c.bound) - (float(v) - float(vm)))
            moved.append(j)
    if not moved:
        return problem, []
    return eqx.tree_at(lambda p: p.constraints, problem, tuple(cons)), moved
