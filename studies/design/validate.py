"""Validation of the constrained design solve (studies/design/README.md).

1. Four networks: the SLSQP optimum against an exhaustive grid search (every dimmer on a 0.02
   grid, 6.8·10⁶ designs, each checked point by point, then a 0.004 grid around its best):
   least power and active constraints.
2. Six networks: SLSQP and trust-constr against the exact linear programme (HiGHS, point by
   point): objective gap, constraint violation, iterations, wall time (contended machine).

Run: ``python studies/design/validate.py`` (writes nothing; prints the tables).
"""

from __future__ import annotations

import itertools
import time

import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import linprog

from lumijax.optimise._constrained import DesignProblem, solve_constrained
from lumijax.optimise._constraints import (
    GridAverage,
    GridMaximum,
    GridMinimum,
    GridUniformity,
    PowerModel,
)
from lumijax.optimise._models import DimmerLight

jax.config.update("jax_enable_x64", True)


def light(k, n, seed):
    rng = np.random.default_rng(seed)
    # each network lights its own part of the grid more (a bay), with a spread of spill
    centre = np.linspace(0, 1, k)[:, None]
    pos = np.linspace(0, 1, n)[None]
    return 300 * np.exp(-((pos - centre) / 0.35) ** 2) * rng.uniform(0.8, 1.2, (k, n)) + 10


def c(cls, bound, n, sense=1):
    return cls(label=cls.__name__, key="k", unit="", sense=sense, bound=jnp.asarray(bound),
               ref=abs(bound), start=0, stop=n)


def grid_search(a, power, avg, emin, emax, step=0.02):
    levels = np.round(np.arange(0, 1 + 1e-9, step), 10)
    k = a.shape[0]
    best, best_x = np.inf, None
    mean = a.mean(axis=1)
    head = np.array(list(itertools.product(levels, repeat=k - 1)))
    for last in levels:
        x = np.c_[head, np.full(len(head), last)]
        ok = x @ mean >= avg
        x = x[ok]
        for chunk in np.array_split(x, max(1, len(x) // 20000)):
            e = chunk @ a
            feas = (e.min(axis=1) >= emin) & (e.max(axis=1) <= emax)
            if feas.any():
                p = chunk[feas] @ power
                j = int(np.argmin(p))
                if p[j] < best:
                    best, best_x = float(p[j]), chunk[feas][j]
    return best, best_x


def refined_search(a, power, avg, emin, emax):
    """The 0.02 grid, then a 0.004 grid within ±0.06 of its best (the optimum of this
    problem is on the feasible set's boundary, so the coarse best is within one step)."""
    best, bx = grid_search(a, power, avg, emin, emax)
    k = a.shape[0]
    fine = np.arange(-0.06, 0.06 + 1e-9, 0.004)
    mean = a.mean(axis=1)
    for d in itertools.product(fine, repeat=k - 1):
        x = np.clip(np.c_[np.tile(bx[:-1] + np.array(d), (len(fine), 1)),
                          bx[-1] + fine], 0, 1)
        x = x[x @ mean >= avg]
        if not len(x):
            continue
        e = x @ a
        feas = (e.min(axis=1) >= emin) & (e.max(axis=1) <= emax)
        if feas.any():
            p = x[feas] @ power
            j = int(np.argmin(p))
            if p[j] < best:
                best, bx = float(p[j]), x[feas][j]
    return best, bx


def main():
    print("## 1. Four networks against an exhaustive grid search (0.02, then 0.004 steps)\n")
    k, n = 4, 200
    a = light(k, n, 1)
    power = np.array([40.0, 55.0, 30.0, 45.0])
    avg, emin, emax = 150.0, 60.0, 260.0
    cons = (c(GridAverage, avg, n), c(GridMinimum, emin, n), c(GridMaximum, emax, n, -1))
    prob = DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(power)),
                         cons, float(power.sum()))
    t = time.perf_counter()
    run = solve_constrained(prob, np.ones(k), np.zeros(k), np.ones(k))
    t_s = time.perf_counter() - t
    t = time.perf_counter()
    best, bx = refined_search(a, power, avg, emin, emax)
    t_g = time.perf_counter() - t
    e_s, e_g = run.x @ a, bx @ a
    res = 0.02 * a.sum(axis=0).max()
    print("| | least power (W) | Eavg | Emin | Emax | active | time (s, contended) |")
    print("|---|---|---|---|---|---|---|")
    print(f"| SLSQP (ε = 10⁻³) | {run.objective:.3f} | {e_s.mean():.2f} | {e_s.min():.2f} | "
          f"{e_s.max():.2f} | {[bool(v) for v in run.active]} | {t_s:.1f} |")
    res = 0.004 * a.sum(axis=0).max()
    grid_active = [bool(abs(e_g.mean() - avg) < res), bool(abs(e_g.min() - emin) < res),
                   bool(abs(e_g.max() - emax) < res)]
    print(f"| grid search | {best:.3f} | {e_g.mean():.2f} | {e_g.min():.2f} | "
          f"{e_g.max():.2f} | {grid_active} | {t_g:.1f} |")
    lp = linprog(power, A_ub=np.vstack([-a.mean(axis=1)[None], -a.T, a.T]),
                 b_ub=np.r_[-avg, np.full(n, -emin), np.full(n, emax)], bounds=[(0, 1)] * k,
                 method="highs")
    print(f"| LP (HiGHS, exact) | {lp.fun:.3f} | | | | | |")
    print(f"\nrelative gap (grid − SLSQP)/grid: {(best - run.objective) / best:.4%}\n")

    print("## 2. Six networks: SLSQP and trust-constr against the linear programme\n")
    k, n = 6, 400
    a = light(k, n, 2)
    power = np.array([40.0, 55.0, 30.0, 45.0, 35.0, 50.0])
    avg, emin, u0 = 160.0, 70.0, 0.5
    mean = a.mean(axis=1)
    lp = linprog(power, A_ub=np.vstack([-mean[None], -a.T, -(a.T - u0 * mean[None])]),
                 b_ub=np.r_[-avg, np.full(n, -emin), np.zeros(n)], bounds=[(0, 1)] * k,
                 method="highs")
    cons = (c(GridAverage, avg, n), c(GridMinimum, emin, n), c(GridUniformity, u0, n))
    prob = DesignProblem(DimmerLight(jnp.asarray(a), None), PowerModel(jnp.asarray(power)),
                         cons, float(power.sum()))
    print("| method | ε | least power (W) | gap to LP | violation (exact) | iterations | "
          "evaluations | time (s, contended) |")
    print("|---|---|---|---|---|---|---|---|")
    for method in ("slsqp", "trust-constr"):
        for eps in (1e-2, 1e-3):
            solve_constrained(prob, np.ones(k), np.zeros(k), np.ones(k), method=method,
                              smooth=eps, max_steps=5)  # compile outside the timing
            t = time.perf_counter()
            r = solve_constrained(prob, np.ones(k), np.zeros(k), np.ones(k), method=method,
                                  smooth=eps)
            dt = time.perf_counter() - t
            e = r.x @ a
            viol = max(0.0, (avg - e.mean()) / avg, (emin - e.min()) / emin,
                       (u0 - e.min() / e.mean()) / u0)
            print(f"| {method} | {eps:g} | {r.objective:.4f} | "
                  f"{(r.objective - lp.fun) / lp.fun:+.4%} | {viol:.2e} | {r.iterations} | "
                  f"{r.evaluations} | {dt:.2f} |")
    print(f"| LP (HiGHS) | — | {lp.fun:.4f} | — | — | — | — | — |")


if __name__ == "__main__":
    main()
