"""``lumijax.optimise``: fit dimmers, aims and levels of a computed study to its grids' goals."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jax.numpy as jnp
import numpy as np

from ..design import Design, traverse
from ..errors import ConfigError, LumijaxError, OutputError
from ..lighting._solution import float64_scope
from ..results import CRITERIA_SLACK, grid_stats
from ._models import DimmerLight, build_aim_light
from ._objective import Objective
from ._solvers import minimise
from ._targets import grid_goals

__all__ = ["Optimisation", "optimise", "LUMENS_PER_WATT"]

LUMENS_PER_WATT = 100.0
"""Efficacy assumed for a network without ``power_w`` (its power ∝ its flux)."""

_MET = CRITERIA_SLACK  # slack on a limit or an average target before it counts as not met
_MET_MAP = 0.05  # relative RMS deviation of a target map counted as met


@dataclass(frozen=True, eq=False)
class Optimisation:
    """The outcome of :func:`optimise` (``results.json``'s ``"optimisation"``, docs/results.md).

    ``design`` is the optimised :class:`~lumijax.design.Design` (``start`` the one the fit
    started from) and ``results`` the study's results at it, ``results.design`` (their
    ``optimisation`` is this object); ``aimed``/``levelled`` name the luminaires whose aims and
    levels were variables. ``dimmers``, ``aims`` and ``levels`` are read from ``design``.
    ``before``/``after`` hold each grid's statistics at the start and at the optimised
    design; ``targets`` one entry per goal with what was wanted and achieved.
    """

    solver: str
    variables: tuple[str, ...]
    iterations: int
    converged: bool
    objective_history: list[float]
    design: Design
    start: Design
    aimed: tuple[str, ...]
    levelled: tuple[str, ...]
    before: dict[str, dict[str, float]]
    after: dict[str, dict[str, float]]
    targets: list[dict[str, Any]]
    unmet: list[str]
    seconds: float = 0.0
    config: Any = field(default=None, repr=False)
    #: A constrained design's record (``[optimise] objective``): verdict ("met",
    #: "not met exactly", "infeasible"), objective before/after, each constraint's bound,
    #: start and exact achieved value, activity and price, the starts, and the conflict when
    #: infeasible (docs/optimise.md); None for the least-squares fit.
    constrained: dict[str, Any] | None = None
    results: Any = field(default=None, repr=False)

    @property
    def dimmers(self) -> dict[str, float]:
        """``{network: dimmer}`` of the optimised design."""
        return self.design.dimmer_of()

    @property
    def aims(self) -> dict[str, dict[str, float]]:
        """``{luminaire: {"tilt", "pan", "spin"}}`` (degrees, group frame) of the luminaires
        whose aims were variables."""
        return {n: self.design.aim_of(n) for n in self.aimed}

    @property
    def levels(self) -> dict[str, float]:
        """``{luminaire: level}`` (a factor on its config multiplier) of the luminaires whose
        levels were variables."""
        return {n: self.design.level_of(n) for n in self.levelled}

    def to_dict(self) -> dict[str, Any]:
        out = {
            "solver": self.solver, "variables": list(self.variables),
            "iterations": self.iterations, "converged": self.converged,
            "objective_history": [float(v) for v in self.objective_history],
            "dimmers": self.dimmers, "aims": self.aims, "before": self.before,
            "after": self.after, "targets": self.targets, "unmet": self.unmet,
            "seconds": self.seconds,
        }
        if self.levels:
            out["levels"] = self.levels
        if self.constrained is not None:
            out["constrained"] = self.constrained
        return out

    def config_text(self, base_dir: str | Path | None = None) -> str:
        """The optimised study as TOML, file paths relative to ``base_dir``."""
        from ._toml import optimised_toml

        return optimised_toml(
            self.config, self.design, aimed=self.aimed, levelled=self.levelled,
            base_dir=None if base_dir is None else Path(base_dir).resolve(),
            note=f"optimised by lumijax ({self.solver}, {self.iterations} steps); goals "
                 f"{'all met' if not self.unmet else 'not all met: ' + '; '.join(self.unmet)}",
        )

    def write_config(self, path: str | Path) -> Path:
        """Write the optimised study as a TOML file the designer can open and keep working on
        (atomically; relative file paths re-anchored at the new file's folder)."""
        from .._atomic import atomic_write_text

        path = Path(path)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise OutputError(f"cannot create folder: {e.strerror}", file=path.parent) from None
        atomic_write_text(path, self.config_text(path.parent))
        return path


def _settings(study, overrides):
    from ..config._schema import OptimiseConfig

    base = study.config.optimise
    data = {} if base is None else base.model_dump(exclude_unset=True)
    data.update(overrides)
    try:
        return OptimiseConfig.model_validate(data)
    except Exception as e:  # pydantic ValidationError: name the key as the config does
        errs = getattr(e, "errors", None)
        if errs is None:
            raise
        err = errs(include_url=False)[0]
        key = "optimise." + ".".join(str(p) for p in err["loc"])
        raise ConfigError(err["msg"].removeprefix("Value error, "),
                          file=study.config.source, key=key) from None


def _aim_range(cfg, lum_cfg, ocfg):
    """(tilt range, pan range) in degrees, relative: luminaire, then its groups, then
    ``[optimise]``."""
    ranges = [lum_cfg.aim_range_deg]
    g = lum_cfg.group
    while g is not None:
        ranges.append(cfg.groups[g].aim_range_deg)
        g = cfg.groups[g].parent
    out = []
    for comp, default in (("tilt", ocfg.tilt_range_deg), ("pan", ocfg.pan_range_deg)):
        value = next((getattr(r, comp) for r in ranges if r is not None
                      and getattr(r, comp) is not None), default)
        out.append(tuple(value))
    return out


@float64_scope()  # the fit runs in float64 (docs/optimise.md), x64 mode for its duration only
def optimise(study, results, *, cache_dir: str | Path | None = None, **overrides) -> Optimisation:
    """Fit the study's dimmers (and aims, levels) to its grids' goals.

    Parameters
    ----------
    study, results
        A :class:`lumijax.Study` and its :func:`lumijax.compute` results (with the lighting
        solution).
    cache_dir
        Operator cache for the exact re-computation after an aim or level fit.
    **overrides
        Any ``[optimise]`` key (``variables``, ``solver``, ``max_steps``, …), over the config's.

    Returns
    -------
    Optimisation
        With ``.results`` at the optimised design. Goals that could not be met are listed in
        ``unmet`` ("wanted X, best achievable Y"); the best design found is returned anyway.
    """
    t0 = time.perf_counter()
    ocfg = _settings(study, overrides)
    cfg, sc = study.config, study.scene
    lighting = results.lighting
    if lighting is None:
        raise LumijaxError("the results hold no lighting solution: optimise needs the "
                           "results of lumijax.compute")
    goals = grid_goals(study)
    if (not goals and ocfg.max_luminance_cdm2 is None and ocfg.energy_weight == 0
            and ocfg.objective is None):
        raise ConfigError("nothing to optimise: no grid has a target or a limit",
                          file=cfg.source, key="optimise")
    setup = _setup(study, results, ocfg)
    if ocfg.objective is not None:  # a constrained design (docs/optimise.md)
        from ._standard import design_to_standard

        return design_to_standard(study, results, ocfg, setup, goals, cache_dir=cache_dir,
                                  t0=t0)
    params, model, variable = setup.params, setup.model, setup.variable
    aims_on, levels_on = setup.aims, setup.levels
    objective = Objective.build(goals, setup.power, energy_weight=ocfg.energy_weight,
                                constraint_weight=ocfg.constraint_weight,
                                patch_max_luminance=ocfg.max_luminance_cdm2)

    solver = "lbfgsb" if ocfg.solver == "auto" else ocfg.solver
    run = minimise(_residuals, (model, objective), params.x0, params.lower, params.upper,
                   solver=solver, max_steps=ocfg.max_steps, tolerance=ocfg.tolerance)
    design = params.unflatten(np.asarray(run.x, np.float64))
    names_of = [sc.luminaires[i].name for i in variable]
    opt = Optimisation(
        solver=solver, variables=tuple(ocfg.variables), iterations=run.iterations,
        converged=run.converged, objective_history=run.history, design=design,
        start=params.start,
        aimed=tuple(names_of) if aims_on else (), levelled=tuple(names_of) if levels_on else (),
        before={n: g.stats for n, g in results.grids.items()}, after={},
        targets=[], unmet=[], config=cfg,
    )
    # exact: superposition where only dimmers moved, else the study computed at the design
    # (scene.with_design, the operator from the cache); no config text is written or parsed
    if results.design.only_dimmers_differ(design):
        after = results.at(design)
    else:
        from .._study import compute

        after = compute(study, design=design, cache_dir=cache_dir)
    assessed, unmet = _assess(goals, after, ocfg, opt.dimmers)
    opt = dataclasses.replace(
        opt, after={n: g.stats for n, g in after.grids.items()}, targets=assessed, unmet=unmet,
        seconds=time.perf_counter() - t0,
    )
    final = dataclasses.replace(after, optimisation=opt)
    object.__setattr__(opt, "results", final)
    return opt


@dataclass(frozen=True)
class _Setup:
    """What both fits share: the variables' layout and bounds, the light model, the power."""

    params: Any
    model: Any
    variable: list[int]
    names: list[str]
    aims: bool
    levels: bool
    power: np.ndarray
    ranges: list = field(default_factory=list)  # per variable luminaire, degrees, relative


def _setup(study, results, ocfg) -> _Setup:
    """The variables (``traverse``), the light model at them and each network's power (W)."""
    cfg, sc = study.config, study.scene
    lighting = results.lighting
    names = sc.network_names
    flux = sc.network_flux_lm()
    power = np.array([
        cfg.networks[n].power_w if n in cfg.networks and cfg.networks[n].power_w is not None
        else flux[n] / LUMENS_PER_WATT for n in names])

    # the fit starts at the study's dimmers, and at the aims and levels the light was computed
    # at (where the aim model is exact)
    start = results.design.replace(dimmers=study.design.dimmers)
    aims_on, levels_on = "aims" in ocfg.variables, "levels" in ocfg.variables
    variable: list[int] = []
    ranges = []
    if aims_on or levels_on:
        for i, lum in enumerate(sc.luminaires):
            (t_lo, t_hi), (p_lo, p_hi) = _aim_range(cfg, cfg.luminaires[lum.config_index], ocfg)
            moving = aims_on and (t_lo != t_hi or p_lo != p_hi or t_lo != 0 or p_lo != 0)
            if moving or levels_on:
                variable.append(i)
                ranges.append(((t_lo, t_hi), (p_lo, p_hi)) if aims_on else ((0, 0), (0, 0)))
        if not variable:  # the aim model of no luminaire is an empty, singular solve
            raise ConfigError(
                "'aims'/'levels' need a photometric luminaire free to move: the study has none"
                if not sc.luminaires else "every aim range is zero: no luminaire can turn",
                file=cfg.source, key="optimise.variables")
    params = traverse(start, ocfg.variables, luminaires=variable,
                      dimmer_bounds=(ocfg.dimmer_min, 1.0), aim_bounds_deg=ranges,
                      level_bounds=(ocfg.dimmer_min, 1.0))
    if aims_on or levels_on:
        spans = np.radians(np.array(ranges, np.float64).reshape(-1, 4))
        model = build_aim_light(
            lighting, variable, np.abs(spans[:, :2]).max(axis=1, initial=0.0),
            np.abs(spans[:, 2:]).max(axis=1, initial=0.0), aims=aims_on, levels=levels_on,
            indirect=ocfg.indirect,
        )
    else:
        rad = None if lighting.coarse.patches is None or not lighting.coarse.radiosity.size else (
            jnp.asarray(lighting.coarse.radiosity, jnp.float64))
        model = DimmerLight(jnp.asarray(lighting.point_total, jnp.float64), rad)

    return _Setup(params, model, variable, [sc.luminaires[i].name for i in variable],
                  aims_on, levels_on, power, ranges)


def _residuals(x, args):
    model, objective = args
    e, b, alpha = model(x)
    return objective.residuals(e, b, alpha)


def _assess(goals, results, ocfg, dimmers) -> tuple[list[dict], list[str]]:
    """Each goal: wanted, achieved, met; and a sentence for each one not met."""
    out, unmet = [], []
    full = all(v >= 1.0 - 1e-6 for v in dimmers.values())

    def add(grid, kind, wanted, achieved, met, sentence):
        out.append({"grid": grid, "kind": kind, "wanted": float(wanted),
                    "achieved": float(achieved), "met": bool(met)})
        if not met:
            unmet.append(sentence)

    for g in goals:
        lux = results.grids[g.name].illuminance_lux
        s = grid_stats(lux)
        q = f"grid {g.name!r}"
        if g.target is not None and g.target_kind == "target_lux":
            want = float(g.target[0])
            gap = (s["avg"] - want) / want if want > 0 else 0.0
            why = " (every network at full output: the fittings cannot give more)" if (
                gap < 0 and full) else ""
            add(g.name, "target_lux", want, s["avg"], abs(gap) <= _MET,
                f"{q}: wanted {want:.4g} lx, achieved an average of {s['avg']:.4g} lx "
                f"({'short' if gap < 0 else 'over'} by {100 * abs(gap):.0f} %){why}")
        elif g.target is not None:
            ref = max(float(np.mean(g.target)), 1e-12)
            rms = float(np.sqrt(np.mean((lux - g.target) ** 2))) / ref
            add(g.name, "target_csv", 0.0, rms, rms <= _MET_MAP,
                f"{q}: the target map (mean {ref:.4g} lx) is met only to an RMS deviation of "
                f"{100 * rms:.0f} % (mean achieved {s['avg']:.4g} lx)")
        if g.min_lux is not None:
            add(g.name, "min_lux", g.min_lux, s["min"], s["min"] >= g.min_lux * (1 - _MET),
                f"{q}: wanted Emin ≥ {g.min_lux:.4g} lx, best achievable {s['min']:.4g} lx "
                f"(short by {100 * (1 - s['min'] / g.min_lux):.0f} %)")
        if g.uniformity_min is not None:
            add(g.name, "uniformity_min", g.uniformity_min, s["u0"],
                s["u0"] >= g.uniformity_min * (1 - _MET),
                f"{q}: wanted U0 ≥ {g.uniformity_min:.3g}, best achievable {s['u0']:.3g}")
        if g.max_lux is not None:
            add(g.name, "max_lux", g.max_lux, s["max"], s["max"] <= g.max_lux * (1 + _MET),
                f"{q}: wanted Emax ≤ {g.max_lux:.4g} lx, best achievable {s['max']:.4g} lx "
                f"(over by {100 * (s['max'] / g.max_lux - 1):.0f} %)")
        if g.max_luminance_cdm2 is not None:
            lmax = g.rho * s["max"] / np.pi
            add(g.name, "max_luminance_cdm2", g.max_luminance_cdm2, lmax,
                lmax <= g.max_luminance_cdm2 * (1 + _MET),
                f"{q}: wanted luminance ≤ {g.max_luminance_cdm2:.4g} cd/m², best achievable "
                f"{lmax:.4g} cd/m² (over by {100 * (lmax / g.max_luminance_cdm2 - 1):.0f} %)")
    lighting = results.lighting
    if ocfg.max_luminance_cdm2 is not None and lighting is not None and lighting.coarse.radiosity.size:
        alpha = np.asarray(results.design.dimmers)
        lmax = float(np.max(alpha @ lighting.coarse.radiosity)) / np.pi
        add("patches", "max_luminance_cdm2", ocfg.max_luminance_cdm2, lmax,
            lmax <= ocfg.max_luminance_cdm2 * (1 + _MET),
            f"surfaces: wanted luminance ≤ {ocfg.max_luminance_cdm2:.4g} cd/m², brightest patch "
            f"{lmax:.4g} cd/m² (over by {100 * (lmax / ocfg.max_luminance_cdm2 - 1):.0f} %)")
    return out, unmet
