"""Design to a standard: the least power (or misfit) that meets every requirement as a hard
constraint, proof when none can, and the price of each requirement (docs/optimise.md).

The requirements are the grids' own limits read as hard constraints — ``target_lux`` as
Ēm ≥ target (EN 12464-1's maintained average is a floor), ``min_lux``, ``max_lux``,
``uniformity_min``, ``max_luminance_cdm2``, a ``target_csv`` map as RMS misfit ≤ 5 % of its
mean — and every ``[[optimise.constraints]]`` entry; ``[optimise] max_luminance_cdm2`` bounds
the brightest patch. The solve is ``_constrained``'s; the design it returns is lit exactly
(superposition, or the study computed at it) and every constraint checked on the exact
criterion.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..errors import ConfigError
from ._augmented import tighten_for_model_error
from ._constrained import (
    DesignProblem,
    exact_values,
    light_report,
    objective_value,
    solve_constrained,
)
from ._constraints import (
    DesignLight,
    GridAverage,
    GridLuminance,
    GridMaximum,
    GridMinimum,
    GridUniformity,
    MapMisfit,
    PatchLuminance,
    PowerModel,
    TotalPower,
    reference,
)
from ._glare_constraint import GLARE_UNITS, GlareConstraint
from ._infeasible import explain_infeasible, find_feasible
from ._leni import leni_objective
from ._objective import Objective
from ._surface_constraint import surface_constraints

__all__ = ["build_constraints", "design_to_standard", "MAP_MISFIT_MAX", "price_step"]

MAP_MISFIT_MAX = 0.05
"""A ``target_csv`` map read as a constraint: RMS misfit at most 5 % of the map's mean (the
least-squares fit's "met")."""

_AGREE = 0.01  # starts whose objective is within 1 % of the best "agree"

TIGHTEN_ROUNDS = 2
"""At most this many re-solves with the short constraints' bounds moved by the light model's
error there (an aims design: the aim model is not the recomputed study)."""

ROUND_STEPS = 50
"""At most this many solver steps a tightening round, each stage of its smoothing (fewer if
``max_steps`` says so): a round starts at the best design, inside a trust region when the model
was re-centred, and corrects it. Measured on the demo's aims design (230 re-aimed luminaires,
alone, benchmarks/RESULTS.md): its second round took 309 SLSQP steps and 1,759 evaluations
(387 s) uncapped with aims held within 1°, to 3,251.5 W; within 0.5°, 179 steps (162 s) at 100
and 100 steps (52 s) at 50, each to 3,254.8 W, met."""

_TIGHTEN_SAFETY = 1.0
"""Each moved bound is moved a further ``_TIGHTEN_SAFETY × tolerance × scale`` to the harder
side: the re-solve meets its bound to within the tolerance, and the model's error moves a
little with the design, so without it the exact value lands just short again."""

_CLASSES = {"avg": GridAverage, "min": GridMinimum, "max": GridMaximum, "u0": GridUniformity,
            "luminance": GridLuminance, "misfit": MapMisfit}
_NAMES = {"avg": "Eavg", "min": "Emin", "max": "Emax", "u0": "U0", "luminance": "luminance",
          "misfit": "target-map misfit", "power": "total power",
          "patch_luminance": "brightest patch luminance", "ugr": "UGR", "gr": "GR",
          "ti": "TI"}
_UNITS = {"avg": "lx", "min": "lx", "max": "lx", "u0": "", "luminance": "cd/m²", "misfit": "",
          "power": "W", "patch_luminance": "cd/m²", **GLARE_UNITS}


def price_step(criterion: str, bound: float, sense: int) -> float:
    """The tightening a price sentence quotes: +0.05 for U0, 10 % of the bound otherwise
    (towards the harder side)."""
    step = 0.05 if criterion == "u0" else 0.1 * abs(bound)
    return sense * step


def _grids(study):
    out, start = {}, 0
    for i, (gc, g) in enumerate(zip(study.config.grids, study.scene.grids, strict=True)):
        out[g.name] = (i, start, start + len(g), gc)
        start += len(g)
    return out


def build_constraints(study, ocfg, goals, power: PowerModel, *, has_patches: bool,
                      glare=None, params=None, surfaces=None):
    """The hard constraints of a constrained design, with ``criterion`` names (for the price
    steps); a :class:`ConfigError` names the key of a constraint the study cannot compute or
    that contradicts another. ``glare`` (the study's :class:`~lumijax.glare.GlareModel`, None
    without observers) and ``params`` (the flat variables' layout) serve the glare ratings."""
    cfg = study.config
    grids = _grids(study)
    goal_of = {g.name: g for g in goals}
    made = []  # (criterion, constraint)

    def grid_constraint(crit, grid, sense, bound, key):
        i, start, stop, gc = grids[grid]
        cls = _CLASSES[crit]
        extra = {}
        if crit == "luminance":
            if gc.reflectance is None:
                raise ConfigError(f"a luminance constraint on grid {grid!r} needs the grid's "
                                  "'reflectance' (L = ρE/π)", file=cfg.source, key=key)
            extra["rho"] = float(gc.reflectance)
        if crit == "misfit":
            goal = goal_of.get(grid)
            if goal is None or goal.target_kind != "target_csv":
                raise ConfigError(f"a misfit constraint needs a 'target_csv' map on grid "
                                  f"{grid!r}", file=cfg.source, key=key)
            extra["target"] = jnp.asarray(goal.target)
        c = cls(label=f"grid {grid!r}: {_NAMES[crit]}", key=key, unit=_UNITS[crit],
                sense=sense, bound=jnp.asarray(float(bound)), ref=reference(bound),
                start=start, stop=stop, **extra)
        made.append((crit, c))

    for name, (i, _, _, gc) in grids.items():
        k = f"grids[{i}]"
        if gc.target_lux is not None and gc.target_lux > 0:
            grid_constraint("avg", name, 1, gc.target_lux, f"{k}.target_lux")
        if gc.target_csv is not None and ocfg.objective != "misfit":
            grid_constraint("misfit", name, -1, MAP_MISFIT_MAX, f"{k}.target_csv")
        if gc.min_lux is not None and gc.min_lux > 0:
            grid_constraint("min", name, 1, gc.min_lux, f"{k}.min_lux")
        if gc.max_lux is not None:
            grid_constraint("max", name, -1, gc.max_lux, f"{k}.max_lux")
        if gc.uniformity_min is not None:
            grid_constraint("u0", name, 1, gc.uniformity_min, f"{k}.uniformity_min")
        if gc.max_luminance_cdm2 is not None:
            grid_constraint("luminance", name, -1, gc.max_luminance_cdm2,
                            f"{k}.max_luminance_cdm2")
    if ocfg.max_luminance_cdm2 is not None:
        if not has_patches:
            raise ConfigError("a patch luminance limit needs inter-reflection (patches): the "
                              "study computes none", file=cfg.source,
                              key="optimise.max_luminance_cdm2")
        made.append(("patch_luminance", _patch(ocfg.max_luminance_cdm2,
                                               "optimise.max_luminance_cdm2")))
    # the observers' max_luminance_cdm2 limits on named surfaces (lumijax.glare.SeenSurfaces)
    made.extend(("surface_luminance", c) for c in surface_constraints(surfaces,
                                                                       source=cfg.source))
    for j, cc in enumerate(ocfg.constraints):
        key = f"optimise.constraints[{j}]"
        if cc.criterion == "surface_luminance":
            made.extend(("surface_luminance", c) for c in surface_constraints(
                surfaces, observer=cc.observer, surface=cc.surface, bound=cc.max, key=key,
                source=cfg.source))
            continue
        if cc.grid is not None and cc.grid not in grids:
            raise ConfigError(f"no grid named {cc.grid!r}; grids: {', '.join(grids) or 'none'}",
                              file=cfg.source, key=f"{key}.grid")
        if cc.criterion in GLARE_UNITS:
            made.extend((cc.criterion, c) for c in _glare_constraints(cc, key, glare, params,
                                                                     cfg))
            continue
        for side, sense in (("min", 1), ("max", -1)):
            bound = getattr(cc, side)
            if bound is None:
                continue
            if cc.criterion == "power":
                made.append(("power", TotalPower(
                    label="total power", key=f"{key}.{side}", unit="W", sense=sense,
                    bound=jnp.asarray(float(bound)), ref=reference(bound), power=power)))
            elif cc.criterion == "patch_luminance":
                if not has_patches:
                    raise ConfigError("a patch luminance constraint needs inter-reflection "
                                      "(patches): the study computes none", file=cfg.source,
                                      key=f"{key}.criterion")
                made.append(("patch_luminance", _patch(bound, f"{key}.{side}")))
            else:
                grid_constraint(cc.criterion, cc.grid, sense, bound, f"{key}.{side}")
    _contradictions(made, cfg)
    return made


def _glare_constraints(cc, key, glare, params, cfg):
    """One :class:`GlareConstraint` per observer named (every observer when none is)."""
    name = _NAMES[cc.criterion]
    if glare is None or not glare.observers:
        raise ConfigError(f"a {name} constraint needs an observer: the study has no "
                          "[[observers]]", file=cfg.source, key=f"{key}.criterion")
    if cc.observer is not None and cc.observer not in glare.observers:
        raise ConfigError(f"no observer named {cc.observer!r}; observers: "
                          f"{', '.join(glare.observers)}", file=cfg.source,
                          key=f"{key}.observer")
    if cc.criterion == "ti":
        rated = [o for o, road in zip(glare.observers, glare.has_road, strict=True) if road]
        if cc.observer is not None and cc.observer not in rated:
            raise ConfigError(f"observer {cc.observer!r} has no road (road_grid or "
                              "road_luminance_cdm2): its TI is not rated", file=cfg.source,
                              key=f"{key}.observer")
    else:
        rated = list(glare.observers)
    names = rated if cc.observer is None else [cc.observer]
    if not names:
        raise ConfigError("no observer has a road (road_grid or road_luminance_cdm2): TI is "
                          "not rated", file=cfg.source, key=f"{key}.criterion")
    view_obs = np.asarray(glare.view_observer)
    # dimmers only: rate by superposition at the start's aims and levels (exact, ~0.3 ms)
    superposed = None if params is None or params.aims or params.levels else glare.at_aims(
        params.start)
    out = []
    for obs in names:
        i = glare.observers.index(obs)
        out.append(GlareConstraint(
            label=f"observer {obs!r}: {name}", key=f"{key}.max",
            unit=GLARE_UNITS[cc.criterion], sense=-1, bound=jnp.asarray(float(cc.max)),
            model=glare, params=params, rating=cc.criterion, observer=i,
            views=tuple(int(v) for v in np.flatnonzero(view_obs == i)),
            ref=reference(cc.max), superposed=superposed))
    return out


def _at_results(c, after):
    """A glare constraint checked on the glare of the final results (their background lit at
    the final aims, when the design re-aims: the solver's model keeps the start's). Rated by
    superposition (only the dimmers were free) it keeps it: the final results' glare is the
    start's model at other dimmers, which the superposition rates exactly (``Glare.at`` does
    the same), and the exact check then compiles nothing the solve did not."""
    if isinstance(c, GlareConstraint) and after.glare is not None:
        if c.superposed is None or not after.design.only_dimmers_differ(c.params.start):
            c = dataclasses.replace(c, superposed=None)  # the final check: the full model
        return eqx.tree_at(lambda g: g.model, c, after.glare.model)
    return c


def _patch(bound, key):
    return PatchLuminance(label="brightest patch luminance", key=key, unit="cd/m²", sense=-1,
                          bound=jnp.asarray(float(bound)), ref=reference(bound))


def _contradictions(made, cfg):
    """Bounds no design can meet together on one grid: a floor on the points (Emin) or on the
    average above a ceiling on the points (Emax) or on the average."""
    by_grid: dict = {}
    for crit, c in made:
        if crit in ("avg", "min", "max"):
            by_grid.setdefault(c.label.rpartition(":")[0], []).append((crit, c))
    for grid, cs in by_grid.items():
        floors = [(c, float(c.bound)) for crit, c in cs if c.sense > 0]
        ceilings = [(c, float(c.bound)) for crit, c in cs if c.sense < 0]
        kind = {id(c): crit for crit, c in cs}
        for f, fb in floors:
            for c, cb in ceilings:
                # Emin ≤ Eavg ≤ Emax: a floor on Emin or Eavg above a ceiling on Eavg or Emax
                # conflicts; Eavg ≥ a does not conflict with Emin ≤ … (no such ceiling here)
                if kind[id(f)] == "min" or kind[id(c)] == "max" or kind[id(f)] == kind[id(c)]:
                    if fb > cb:
                        raise ConfigError(
                            f"{grid}: {f.label.rpartition(': ')[2]} ≥ {fb:g} ({f.key}) is above "
                            f"{c.label.rpartition(': ')[2]} ≤ {cb:g} ({c.key}): no design can "
                            "meet both", file=cfg.source, key=f.key)


class _Misfit(eqx.Module):
    """The least-squares fit's target terms as the objective (dimensionless)."""

    objective: Objective

    def __call__(self, light: DesignLight):
        return self.objective.value(light.e, light.b, light.alpha)


def _power_model(setup, sc) -> PowerModel:
    p = jnp.asarray(setup.power, jnp.float64)
    if not setup.levels:
        return PowerModel(p)
    flux = sc.network_flux_lm()
    net_index = {n: k for k, n in enumerate(sc.network_names)}
    lum_net, lum_p = [], []
    for i in setup.variable:
        lum = sc.luminaires[i]
        k = net_index[lum.network]
        share = sc.photometries[lum.photometry].integrated_lm * lum.scale
        lum_net.append(k)
        lum_p.append(setup.power[k] * share / flux[lum.network] if flux[lum.network] > 0
                     else 0.0)
    v = len(setup.variable)
    k = len(sc.networks)
    return PowerModel(p, jnp.asarray(lum_net, jnp.int32), jnp.asarray(lum_p, jnp.float64),
                      k + (2 * v if setup.aims else 0))


def exact_light(study, results, params) -> DesignLight:
    """The light of exact results (grid illuminance, patch radiosity at the dimmers), as host
    float64 arrays (the compiled check reads them as arguments; ``jnp.asarray`` of each would
    compile a copy kernel)."""
    e = np.concatenate([results.grids[g.name].illuminance_lux for g in study.scene.grids])
    alpha = np.asarray(results.design.dimmers, np.float64)
    lighting = results.lighting
    b = None
    if lighting is not None and lighting.coarse.patches is not None and lighting.coarse.radiosity.size:
        b = alpha @ np.asarray(lighting.coarse.radiosity, np.float64)
    return DesignLight(np.asarray(e, np.float64), b, alpha,
                       np.asarray(params.flatten(results.design), np.float64))


def _starts(params, n, seed):
    lo, hi = np.asarray(params.lower), np.asarray(params.upper)
    rng = np.random.default_rng(seed)
    out = [np.asarray(params.x0, np.float64)]
    for _ in range(n - 1):
        out.append(lo + (hi - lo) * rng.uniform(size=lo.shape))
    return out


def design_to_standard(study, results, ocfg, setup, goals, *, cache_dir=None, t0=None):
    """The constrained design (``[optimise] objective`` set): see the module docstring.
    Returns an :class:`~lumijax.optimise.Optimisation` whose ``constrained`` holds the
    verdict, the constraints before and after, the prices and, if infeasible, the conflict."""
    from ._optimise import Optimisation

    t0 = time.perf_counter() if t0 is None else t0
    cfg, sc = study.config, study.scene
    params, model = setup.params, setup.model
    lo, hi = np.asarray(params.lower), np.asarray(params.upper)
    if not np.any(params.free):
        raise ConfigError("every variable's range is empty (lower = upper): nothing can move "
                          "(dimmer_min = 1, or aim ranges of [0, 0])", file=cfg.source,
                          key="optimise.variables")
    lighting = results.lighting
    has_patches = lighting.coarse.patches is not None and lighting.coarse.radiosity.size > 0
    power = _power_model(setup, sc)
    made = build_constraints(study, ocfg, goals, power, has_patches=has_patches,
                             glare=None if results.glare is None else results.glare.model,
                             params=params,
                             surfaces=None if results.glare is None else results.glare.surfaces)
    constraints = tuple(c for _, c in made)
    if ocfg.objective in ("power", "leni"):
        if not constraints:
            raise ConfigError(f"a least-{ocfg.objective} design needs a requirement: with "
                              "none, every network off is the answer (give a grid limit or "
                              "[[optimise.constraints]])", file=cfg.source,
                              key="optimise.objective")
        objective, unit = power, "W"
        scale = float(np.sum(setup.power)) or 1.0
        if ocfg.objective == "leni":
            objective, unit = leni_objective(study, ocfg.variables), "kWh/(m²·a)"
            # the LENI of every network at full output: the solver sees O(1) values
            scale = float(objective(DesignLight(jnp.zeros(0), None,
                                                jnp.ones(len(setup.power)),
                                                jnp.zeros(0)))) or 1.0
    else:
        targets = [g for g in goals if g.target is not None and g.weight > 0]
        if not targets:
            raise ConfigError("objective = \"misfit\" needs a grid with 'target_csv' or "
                              "'target_lux'", file=cfg.source, key="optimise.objective")
        objective, unit = _Misfit(Objective.build(targets, setup.power).only("target")), ""
        scale = 1.0
    problem = DesignProblem(model, objective, constraints, objective_scale=scale)
    x_start = np.asarray(params.x0, np.float64)
    start_values = np.asarray(exact_values(problem, x_start), np.float64)
    start_objective = objective_value(problem, x_start)
    tol, eps = ocfg.constraint_tolerance, ocfg.smoothing

    runs = []
    for x0 in _starts(params, ocfg.starts, ocfg.seed):
        run = solve_constrained(problem, x0, lo, hi, smooth=eps, method=ocfg.method,
                                max_steps=ocfg.max_steps, tolerance=tol)
        if run.violation > tol:  # a local stall is not proof: look for a feasible point
            ok, xf, _ = find_feasible(problem, [run.x, x0, hi], lo, hi,
                                      range(len(constraints)), smooth=eps, tolerance=tol)
            if ok:
                run = solve_constrained(problem, xf, lo, hi, smooth=eps, method=ocfg.method,
                                        max_steps=ocfg.max_steps, tolerance=tol)
        runs.append(run)
    feasible = [r for r in runs if r.violation <= tol]
    infeasibility = None
    if feasible:
        best = min(feasible, key=lambda r: r.objective)
        agreed = sum(abs(r.objective - best.objective) <= _AGREE * max(abs(best.objective),
                                                                        1e-12) for r in feasible)
        x_best = best.x
    else:
        ok, x_best, worst = find_feasible(problem, [r.x for r in runs] + [hi], lo, hi,
                                          range(len(constraints)), smooth=eps, tolerance=tol)
        best, agreed = min(runs, key=lambda r: r.violation), 0
        infeasibility = explain_infeasible(problem, params.x0, lo, hi, smooth=eps,
                                           tolerance=tol, labels=list(params.labels),
                                           method=ocfg.method, max_steps=ocfg.max_steps,
                                           worst=worst, phase1=x_best)
    def lit(x):
        """The design at ``x`` lit exactly, the solver's model there and the exact criteria."""
        design = params.unflatten(np.asarray(x, np.float64))
        if results.design.only_dimmers_differ(design):
            after = results.at(design)
        else:
            from .._study import compute

            after = compute(study, design=design, cache_dir=cache_dir)
        light = exact_light(study, after, params)
        # what the solver's light model says at the design (exact criteria): against the exact
        # re-computation it measures the model's error (aim model; glare background at start)
        modelled = np.asarray(exact_values(problem, np.asarray(x, np.float64)), np.float64)
        # every exact criterion of the lit design, and its objective, in one compiled program
        checked = tuple(_at_results(c, after) for _, c in made)
        achieved, objective_end = light_report(checked, objective, light)
        return design, after, modelled, checked, np.asarray(achieved, np.float64), objective_end

    def worst_short(achieved):
        return max([0.0] + [-float(c.sense * (v - float(c.bound)) / c.scale)
                            for c, v in zip(constraints, achieved, strict=True)])

    design, after, modelled, checked, achieved, objective_end = lit(x_best)
    # an aims design: the aim model is not the recomputed study; a constraint short after the
    # exact recompute has its bound moved by the model's error there and the design solved
    # again from the best point (dimmers only, the superposition is exact: never entered)
    rounds: list[dict] = []
    shortfall = worst_short(achieved)
    first_shortfall = shortfall
    state = (best, x_best, design, after, modelled, checked, achieved, objective_end)
    first, moved_all = best, set[int]()
    while (infeasibility is None and shortfall > tol and len(rounds) < TIGHTEN_ROUNDS
           and not results.design.only_dimmers_differ(design)):
        # the model made exact again where it is first order (the light near a re-aimed
        # luminaire: AimLight.recentred), so the bounds move by its other errors only
        model = problem.model.recentred(x_best)
        box = (lo, hi)
        if model is not problem.model:
            problem = eqx.tree_at(lambda p: p.model, problem, model)
            modelled = np.asarray(exact_values(problem, np.asarray(x_best, np.float64)),
                                  np.float64)
            # ... within a trust region about the centre: the round's solve would otherwise
            # lean on the first-order error wherever it flatters the design
            box = model.trust_region(x_best, lo, hi)
        _, moved = tighten_for_model_error(problem, achieved, modelled, tol)
        moved_all |= set(moved)
        cons = list(constraints)
        for j in moved_all:  # every bound moved so far, by the error at the current design
            c = constraints[j]
            cons[j] = c.with_bound(float(c.bound) - (float(achieved[j]) - float(modelled[j]))
                                   + c.sense * _TIGHTEN_SAFETY * tol * c.scale)
        tightened = eqx.tree_at(lambda p: p.constraints, problem, tuple(cons))
        run = solve_constrained(tightened, np.asarray(x_best, np.float64), *box, smooth=eps,
                                method=ocfg.method, max_steps=min(ocfg.max_steps, ROUND_STEPS),
                                tolerance=tol)
        record: dict[str, Any] = {"moved": [constraints[j].key for j in sorted(moved_all)],
                                  "bounds": [float(cons[j].bound) for j in sorted(moved_all)],
                                  "iterations": int(run.iterations),
                                  "evaluations": int(run.evaluations),
                                  "violation": float(run.violation)}
        rounds.append(record)
        if run.violation > tol:  # the tightened model cannot be met: keep the design so far
            record["worst_shortfall"] = None
            break
        x_best = run.x
        design, after, modelled, checked, achieved, objective_end = lit(x_best)
        record["worst_shortfall"] = worst_short(achieved)
        record["objective"] = float(objective_end)
        if record["worst_shortfall"] < shortfall:
            shortfall = record["worst_shortfall"]
            state = (run, x_best, design, after, modelled, checked, achieved, objective_end)
    best, x_best, design, after, modelled, checked, achieved, objective_end = state
    # the work done: the first solve and every tightening round together
    iterations = int(first.iterations) + sum(r["iterations"] for r in rounds)
    evaluations = int(first.evaluations) + sum(r["evaluations"] for r in rounds)
    table, unmet = [], []
    for (crit, _), c, v, v0, vm, price, act in zip(made, checked, achieved, start_values,
                                                   modelled, best.prices, best.active,
                                                   strict=True):
        v = float(v)
        margin = float(c.sense * (v - float(c.bound)) / c.scale)
        met = margin >= -tol
        row = dict(label=c.label, key=c.key, criterion=crit, relation=c.relation,
                   bound=float(c.bound), unit=c.unit, start=float(v0), achieved=v,
                   model=float(vm), margin=margin, met=bool(met),
                   active=bool(act) and infeasibility is None)
        if infeasibility is None and act:
            step = price_step(crit, float(c.bound), c.sense)
            row["price_per_unit"] = float(price)
            row["price_step"] = float(step)
            row["price"] = float(price * step)
            row["price_sentence"] = _price_sentence(c, crit, step, price * step, unit)
        table.append(row)
        if not met:
            u = f" {c.unit}" if c.unit else ""
            unmet.append(f"{c.label}: wanted {c.relation} {float(c.bound):.4g}{u}, "
                         f"achieved {v:.4g}{u} ({c.key})")
    if infeasibility is not None:
        verdict = "infeasible"
    else:
        verdict = "met" if not unmet else "not met exactly"
    constrained = {
        "verdict": verdict, "objective": ocfg.objective, "unit": unit,
        "objective_start": start_objective,
        "objective_end": objective_end,
        "method": best.method, "smoothing": eps, "tolerance": tol,
        "violation": float(best.violation), "iterations": iterations,
        "evaluations": evaluations,
        "starts": {"count": len(runs), "feasible": len(feasible), "agreed": int(agreed),
                   "objectives": [float(r.objective) for r in runs]},
        "constraints": table,
        "prices": [r["price_sentence"] for r in table if "price_sentence" in r],
        "tightening_rounds": rounds,
        "shortfall_first": float(first_shortfall),
    }
    if infeasibility is not None:
        constrained["infeasibility"] = infeasibility.to_dict()
        unmet = [f"infeasible: {s}" for s in infeasibility.to_dict()["sentences"]] + unmet
    opt = Optimisation(
        solver=f"constrained ({best.method})", variables=tuple(ocfg.variables),
        iterations=iterations, converged=bool(best.success),
        objective_history=[float(v) for v in best.history], design=design,
        start=params.start, aimed=tuple(setup.names) if setup.aims else (),
        levelled=tuple(setup.names) if setup.levels else (),
        before={n: g.stats for n, g in results.grids.items()},
        after={n: g.stats for n, g in after.grids.items()},
        targets=[dict(grid=r["label"], kind=r["criterion"], wanted=r["bound"],
                      achieved=r["achieved"], met=r["met"]) for r in table],
        unmet=unmet, config=cfg, constrained=constrained,
        seconds=time.perf_counter() - t0)
    final = dataclasses.replace(after, optimisation=opt)
    object.__setattr__(opt, "results", final)
    return opt


def _price_sentence(c, crit, step, cost, unit) -> str:
    b = float(c.bound)
    name = c.label
    verb = "raising" if step > 0 else "lowering"
    u = f" {c.unit}" if c.unit else ""
    fmt = ".2f" if crit == "u0" else ".4g"
    cost_u = f" {unit}" if unit else ""
    return (f"{verb} {name} from {b:{fmt}}{u} to {b + step:{fmt}}{u} costs "
            f"{cost:.3g}{cost_u} (first order, from the Lagrange multiplier)")
