"""``lumijax.optimise``: fit dimmers, aims and levels of a computed study to its grids' goals."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ConfigError, LumijaxError, OutputError
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

    ``results`` are the study's results at the optimised design (their ``optimisation`` is this
    object); ``before``/``after`` hold each grid's statistics at the config's and at the
    optimised design; ``targets`` one entry per goal with what was wanted and achieved.
    """

    solver: str
    variables: tuple[str, ...]
    iterations: int
    converged: bool
    objective_history: list[float]
    dimmers: dict[str, float]
    aims: dict[str, dict[str, float]]
    levels: dict[str, float]
    before: dict[str, dict[str, float]]
    after: dict[str, dict[str, float]]
    targets: list[dict[str, Any]]
    unmet: list[str]
    seconds: float = 0.0
    config: Any = field(default=None, repr=False)
    results: Any = field(default=None, repr=False)

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
        return out

    def config_text(self, base_dir: str | Path | None = None) -> str:
        """The optimised study as TOML, file paths relative to ``base_dir``."""
        from ._toml import optimised_toml

        return optimised_toml(
            self.config, dimmers=self.dimmers, aims=self.aims, levels=self.levels,
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
    if not goals and ocfg.max_luminance_cdm2 is None and ocfg.energy_weight == 0:
        raise ConfigError("nothing to optimise: no grid has a target or a limit",
                          file=cfg.source, key="optimise")
    jax.config.update("jax_enable_x64", True)  # the fit runs in float64 (docs/optimise.md)
    names = sc.network_names
    k = len(names)
    flux = sc.network_flux_lm()
    power = np.array([
        cfg.networks[n].power_w if n in cfg.networks and cfg.networks[n].power_w is not None
        else flux[n] / LUMENS_PER_WATT for n in names])
    objective = Objective.build(goals, power, energy_weight=ocfg.energy_weight,
                                constraint_weight=ocfg.constraint_weight,
                                patch_max_luminance=ocfg.max_luminance_cdm2)

    lo = [ocfg.dimmer_min] * k
    hi = [1.0] * k
    x0 = list(np.clip(sc.dimmers, ocfg.dimmer_min, 1.0))
    aims_on, levels_on = "aims" in ocfg.variables, "levels" in ocfg.variables
    variable: list[int] = []
    if aims_on or levels_on:
        spans = []
        for i, lum in enumerate(sc.luminaires):
            (t_lo, t_hi), (p_lo, p_hi) = _aim_range(cfg, cfg.luminaires[lum.config_index], ocfg)
            moving = aims_on and (t_lo != t_hi or p_lo != p_hi or t_lo != 0 or p_lo != 0)
            if moving or levels_on:
                variable.append(i)
                spans.append((t_lo, t_hi, p_lo, p_hi) if aims_on else (0, 0, 0, 0))
        spans = np.radians(np.array(spans, np.float64).reshape(-1, 4))
        model = build_aim_light(
            lighting, variable, np.abs(spans[:, :2]).max(axis=1, initial=0.0),
            np.abs(spans[:, 2:]).max(axis=1, initial=0.0), aims=aims_on, levels=levels_on,
            indirect=ocfg.indirect,
        )
        if aims_on:
            t0r, p0r = np.asarray(model.tilt0), np.asarray(model.pan0)
            x0 += list(t0r) + list(p0r)
            lo += list(t0r + spans[:, 0]) + list(p0r + spans[:, 2])
            hi += list(t0r + spans[:, 1]) + list(p0r + spans[:, 3])
        if levels_on:
            x0 += [1.0] * len(variable)
            lo += [ocfg.dimmer_min] * len(variable)
            hi += [1.0] * len(variable)
    else:
        rad = None if lighting.patches is None or not lighting.radiosity.size else (
            jnp.asarray(lighting.radiosity, jnp.float64))
        model = DimmerLight(jnp.asarray(lighting.point_total, jnp.float64), rad)
    if "dimmers" not in ocfg.variables:
        lo[:k] = hi[:k] = x0[:k]

    solver = "lbfgsb" if ocfg.solver == "auto" else ocfg.solver
    run = minimise(_residuals, (model, objective), np.array(x0), np.array(lo), np.array(hi),
                   solver=solver, max_steps=ocfg.max_steps, tolerance=ocfg.tolerance)
    x = run.x
    dimmers = {n: float(x[i]) for i, n in enumerate(names)}
    aims: dict[str, dict[str, float]] = {}
    levels: dict[str, float] = {}
    if variable:
        v = len(variable)
        j = k
        for m, i in enumerate(variable):
            lum = sc.luminaires[i]
            if aims_on:
                aims[lum.name] = {"tilt": float(np.degrees(x[j + m])),
                                  "pan": float(np.degrees(x[j + v + m])), "spin": lum.spin}
            if levels_on:
                levels[lum.name] = float(x[j + (2 * v if aims_on else 0) + m])

    opt = Optimisation(
        solver=solver, variables=tuple(ocfg.variables), iterations=run.iterations,
        converged=run.converged, objective_history=run.history, dimmers=dimmers, aims=aims,
        levels=levels, before={n: g.stats for n, g in results.grids.items()}, after={},
        targets=[], unmet=[], config=cfg,
    )
    after = _final_results(study, results, opt, cache_dir)
    assessed, unmet = _assess(goals, after, ocfg, dimmers)
    opt = dataclasses.replace(
        opt, after={n: g.stats for n, g in after.grids.items()}, targets=assessed, unmet=unmet,
        seconds=time.perf_counter() - t0,
    )
    final = dataclasses.replace(after, optimisation=opt)
    object.__setattr__(opt, "results", final)
    return opt


def _residuals(x, args):
    model, objective = args
    e, b, alpha = model(x)
    return objective.residuals(e, b, alpha)


def _final_results(study, results, opt: Optimisation, cache_dir):
    """The results at the optimised design: by superposition for dimmers alone, otherwise a
    full re-computation of the optimised config (exact; the operator comes from the cache)."""
    names = study.scene.network_names
    alpha = np.array([opt.dimmers[n] for n in names])
    if not opt.aims and not opt.levels:
        grids = {n: dataclasses.replace(g, dimmers=alpha) for n, g in results.grids.items()}
        networks = {n: {**v, "dimmer": opt.dimmers[n]} for n, v in results.networks.items()}
        lighting = results.lighting
        if lighting is not None:
            scene = dataclasses.replace(lighting.scene, networks=tuple(
                dataclasses.replace(nw, dimmer=opt.dimmers[nw.name])
                for nw in lighting.scene.networks))
            lighting = dataclasses.replace(lighting, scene=scene)
        return dataclasses.replace(results, grids=grids, networks=networks, lighting=lighting)
    from .._study import Study, compute
    from ..config import parse_config
    from ..scene import build_scene

    cfg = study.config
    text = opt.config_text(None if cfg.source is None else cfg.source.parent)
    new_cfg = parse_config(text, source=cfg.source)
    new = Study(new_cfg, build_scene(new_cfg))
    return compute(new, cache_dir=cache_dir)


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
    if ocfg.max_luminance_cdm2 is not None and lighting is not None and lighting.radiosity.size:
        alpha = np.array([dimmers[n] for n in lighting.scene.network_names])
        lmax = float(np.max(alpha @ lighting.radiosity)) / np.pi
        add("patches", "max_luminance_cdm2", ocfg.max_luminance_cdm2, lmax,
            lmax <= ocfg.max_luminance_cdm2 * (1 + _MET),
            f"surfaces: wanted luminance ≤ {ocfg.max_luminance_cdm2:.4g} cd/m², brightest patch "
            f"{lmax:.4g} cd/m² (over by {100 * (lmax / ocfg.max_luminance_cdm2 - 1):.0f} %)")
    return out, unmet
