"""Infeasibility as an answer: which constraints conflict, how close each can come, and what
would be needed (docs/optimise.md, "When no design meets the constraints").

* **Feasibility** of a set S of constraints is decided by solving for it: the least total
  squared shortfall ``½ Σ_{j∈S} min(0, g_j)²`` over the box (L-BFGS-B on compiled JAX
  gradients, from the start and from every variable at its upper bound). S is feasible when
  the least shortfall leaves every margin ≥ −tolerance.
* A **minimal conflicting set** (an irreducible infeasible subset: infeasible, but feasible
  without any one of its members) by Chinneck's sensitivity filter, then the deletion filter:
  the constraints met at the least-shortfall point of them all (``phase1``) are dropped at
  once when the violated ones alone are still infeasible (one check); then each remaining
  constraint in turn is dropped and kept out when the rest is still infeasible. Each check of
  a set that stays infeasible runs its minimisations to their end, so the first filter is what
  makes a large study's answer affordable: on the full courtyard (45 constraints, a conflict
  of 2) 45 such checks took 220 s of a 267 s design (studies/design/README.md).
* The **best achievable** value of each member: the criterion maximised (or, for a ceiling,
  minimised) subject to the other members, by the constrained solve — not the value the
  failed solve happened to stop at.
* **What would be needed**: at that best design, the variables held on a bound that push the
  criterion towards its bound (a network at full output: more flux there; an aim at the end of
  its range: a wider range), ranked by how much each moves the criterion.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._constrained import DesignProblem, _g, solve_constrained

__all__ = ["Conflict", "Infeasibility", "find_feasible", "explain_infeasible"]


def _shortfall(problem, x, mask, smooth):
    def f(x):
        g = problem.g(x, smooth)
        return 0.5 * jnp.sum(jnp.where(mask, jnp.minimum(g, 0.0) ** 2, 0.0))

    return jax.value_and_grad(f)(x)


_COMPILED: dict = {}  # the last few problems' structures → their compiled shortfall


def _shortfall_of(problem):
    """``(fn, leaves)``: ``fn(leaves, x, mask, smooth)`` is :func:`_shortfall` of ``problem``,
    its arrays passed as the flat ``leaves``. A feasibility solve calls it hundreds of times;
    through ``eqx.filter_jit`` each call partitioned the whole problem again (its luminaires'
    sources and every constraint: ~700 leaves, 3.7 ms of an 11 ms call on the full courtyard,
    cProfile), here once a solve. Problems of one structure and static values share ``fn``."""
    dynamic, static = eqx.partition(problem, eqx.is_array)
    leaves, dynamic_def = jax.tree_util.tree_flatten(dynamic)
    static_leaves, static_def = jax.tree_util.tree_flatten(static)
    try:
        key = (dynamic_def, static_def, tuple(static_leaves))
        fn = _COMPILED.get(key)
    except TypeError:  # an unhashable static value: compiled for this problem alone
        key, fn = None, None
    if fn is None:
        def flat(leaves, x, mask, smooth):
            return _shortfall(eqx.combine(jax.tree_util.tree_unflatten(dynamic_def, leaves),
                                          static), x, mask, smooth)

        fn = jax.jit(flat)
        if key is not None:
            while len(_COMPILED) >= 4:
                _COMPILED.pop(next(iter(_COMPILED)))
            _COMPILED[key] = fn
    return fn, leaves


def find_feasible(problem: DesignProblem, starts, lo, hi, members, *, smooth: float,
                  tolerance: float) -> tuple[bool, np.ndarray, float]:
    """``(feasible, x, worst margin)`` of the constraints ``members`` (indices), solved for:
    the least squared shortfall over the box from each start."""
    from scipy.optimize import minimize

    m = len(problem.constraints)
    mask = jnp.asarray(np.isin(np.arange(m), list(members)))
    best = (False, np.asarray(starts[0], np.float64), -np.inf)
    shortfall, leaves = _shortfall_of(problem)
    for x0 in starts:
        def fun(x):
            v, g = shortfall(leaves, jnp.asarray(x), mask, jnp.asarray(smooth))
            return float(v), np.asarray(g, np.float64)

        res = minimize(fun, np.clip(x0, lo, hi), jac=True, method="L-BFGS-B",
                       bounds=list(zip(lo, hi, strict=True)),
                       options=dict(maxiter=500, ftol=0.0, gtol=1e-12))
        x = np.clip(res.x, lo, hi)
        g = np.asarray(_g(problem, jnp.asarray(x), smooth))[list(members)]
        worst = float(g.min(initial=np.inf))
        if worst > best[2]:
            best = (worst >= -tolerance, x, worst)
        if best[0]:
            break
    return best


@dataclass
class Conflict:
    """One member of the minimal conflicting set."""

    label: str
    key: str
    relation: str
    bound: float
    best: float  # best achievable value subject to the other members (natural units)
    unit: str
    needed: list[str] = field(default_factory=list)

    def sentence(self) -> str:
        u = f" {self.unit}" if self.unit else ""
        need = f"; would need: {'; '.join(self.needed)}" if self.needed else ""
        return (f"{self.label} {self.relation} {self.bound:.4g}{u}: best achievable "
                f"{self.best:.4g}{u} with the other constraints of this set met{need}")


@dataclass
class Infeasibility:
    """No design of the chosen variables meets the constraints: ``conflict`` is a minimal set
    that cannot be met together (each member's best achievable value solved for)."""

    conflict: list[Conflict]
    phase1_worst: float  # the least worst relative shortfall of all constraints together

    def to_dict(self) -> dict:
        return {"verdict": "infeasible",
                "conflict": [dict(label=c.label, key=c.key, relation=c.relation,
                                  bound=c.bound, best_achievable=c.best, unit=c.unit,
                                  needed=c.needed) for c in self.conflict],
                "sentences": [c.sentence() for c in self.conflict]}


class _Criterion(eqx.Module):
    """The objective "push constraint j towards and past its bound": −sense · value."""

    constraint: eqx.Module

    def __call__(self, light):
        return -self.constraint.sense * self.constraint.value(light, self._smooth)

    _smooth: float | None = eqx.field(static=True, default=None)


def explain_infeasible(problem: DesignProblem, x0, lo, hi, *, smooth: float, tolerance: float,
                       labels: list[str], method: str = "slsqp", max_steps: int = 200,
                       worst: float = np.nan, phase1=None) -> Infeasibility:
    """The minimal conflicting set of ``problem``'s constraints, with each member's best
    achievable value and what would be needed (see the module docstring). ``labels`` name the
    variables (``DesignParameters.labels``); ``phase1``: the least-shortfall point of all the
    constraints (:func:`find_feasible`'s), found again when not given."""
    m = len(problem.constraints)
    starts = [np.asarray(x0, np.float64), np.asarray(hi, np.float64)]

    def feasible(members):
        return find_feasible(problem, starts, lo, hi, members, smooth=smooth,
                             tolerance=tolerance)[0]

    members = list(range(m))
    if phase1 is None:
        phase1 = find_feasible(problem, starts, lo, hi, members, smooth=smooth,
                               tolerance=tolerance)[1]
    g = np.asarray(_g(problem, jnp.asarray(phase1), smooth))
    violated = [i for i in members if g[i] < -tolerance]  # the sensitivity filter
    if violated and len(violated) < m and not feasible(violated):
        members = violated
    for j in list(members):  # the deletion filter
        trial = [i for i in members if i != j]
        if trial and not feasible(trial):
            members = trial
    out = []
    for j in members:
        c = problem.constraints[j]
        others = tuple(problem.constraints[i] for i in members if i != j)
        sub = DesignProblem(problem.model, _Criterion(c, smooth), others,
                            objective_scale=float(c.scale))
        ok, start, _ = find_feasible(sub, starts, lo, hi, range(len(others)), smooth=smooth,
                                     tolerance=tolerance) if others else (True, starts[0], 0.0)
        run = solve_constrained(sub, start, lo, hi, smooth=smooth, method=method,
                                max_steps=max_steps, tolerance=tolerance)
        light = problem.light(jnp.asarray(run.x))
        best = float(c.value(light, None))
        out.append(Conflict(c.label, c.key, c.relation, float(c.bound), best, c.unit,
                            _needed(problem, c, run.x, lo, hi, labels, smooth)))
    return Infeasibility(out, float(worst))


def _needed(problem, c, x, lo, hi, labels, smooth, top: int = 3) -> list[str]:
    """Variables held on a bound that would move ``c`` towards its bound if the bound were
    wider, ranked by ``|∂c/∂x_i|`` × the variable's range."""

    def value(x):
        return c.value(problem.light(x), smooth)

    grad = np.asarray(jax.grad(value)(jnp.asarray(x)), np.float64) * c.sense
    span = np.asarray(hi) - np.asarray(lo)
    at_hi = (np.asarray(hi) - x) <= 1e-6 * np.maximum(span, 1e-300)
    at_lo = (x - np.asarray(lo)) <= 1e-6 * np.maximum(span, 1e-300)
    push = np.where(at_hi & (grad > 0), grad, 0.0) + np.where(at_lo & (grad < 0), -grad, 0.0)
    push = np.where(span > 0, push, 0.0)
    order = [i for i in np.argsort(-push * np.maximum(span, 1e-3)) if push[i] > 0][:top]
    best = float(c.value(problem.light(jnp.asarray(x)), None))
    gap = abs(float(c.bound) - best)
    out = []
    for i in order:
        name = labels[i]
        kind, _, who = name.partition("[")
        who = who.rstrip("]")
        if kind == "dimmers":
            frac = gap / push[i]
            out.append(f"more flux on network {who!r} (at full output; about "
                       f"+{100 * frac:.0f} % of its flux would close the gap alone, to first "
                       "order)")
        elif kind == "level":
            out.append(f"a higher level (more flux) for luminaire {who!r} (at its top level)")
        else:
            comp = "tilt" if kind.startswith("tilt") else "pan"
            end = "upper" if at_hi[i] else "lower"
            per_deg = push[i] * np.pi / 180
            out.append(f"a wider {comp} range for luminaire {who!r} (at the {end} end; "
                       f"{per_deg:.3g}{' ' + c.unit if c.unit else ''} per degree)")
    if not out:
        out.append("no variable held on a bound limits it: the chosen variables cannot reach it "
                   "at any setting (free other variables — aims, levels — or change the "
                   "installation)")
    return out
