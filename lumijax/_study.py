"""The study: the Python API that the command line is a thin layer over.

``load_study`` reads and validates a config and builds its scene; ``compute`` lights it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path

import numpy as np

from .config import StudyConfig, load_config
from .design import Design
from .lighting import LightingSolution, SolverSettings, solve_lighting
from .lighting._solution import Level, float64_scope
from .parallel import executor_scope
from .results import GridResult, Results
from .scene import Scene, build_scene

__all__ = ["Study", "load_study", "study_of", "compute", "solver_settings", "check_memory"]


@dataclass(frozen=True, eq=False)
class Study:
    """A validated config and the scene built from it."""

    config: StudyConfig
    scene: Scene
    load_s: float = 0.0  # wall time (s) of load_study: config_s + scene_s
    config_s: float = 0.0  # reading and validating the config
    scene_s: float = 0.0  # building the scene from it (files, geometry, photometry)

    @property
    def name(self) -> str:
        return self.scene.name

    @property
    def design(self) -> Design:
        """The design the study is configured at (dimmers, aims, levels)."""
        return Design.of(self.scene)

    def with_design(self, design: Design) -> Study:
        """The same study at another design (its config text is not rewritten: the config
        stays the one loaded; ``scene`` is placed at ``design``)."""
        return replace(self, scene=self.scene.with_design(design), load_s=0.0, config_s=0.0,
                       scene_s=0.0)

    def summary(self) -> dict:
        """What the study holds: counts, and each photometry's rated and integrated flux (lm)."""
        sc = self.scene
        return {
            "study": sc.name,
            "triangles": len(sc.triangles),
            "luminaires": len(sc.luminaires) + len(sc.area_sources),
            "networks": len(sc.networks),
            "grid_points": int(sum(len(g) for g in sc.grids)),
            "photometry": {
                name: {"rated_lm": p.rated_lm, "integrated_lm": float(p.integrated_lm)}
                for name, p in sc.photometries.items()
            },
        }


def load_study(path: str | Path) -> Study:
    """Load a TOML study config and build its scene.

    Raises :class:`lumijax.LumijaxError` (a ``ConfigError``, ``PhotometryError``,
    ``SpectrumError`` or ``GeometryError``) naming the file and key of any problem.
    """
    t0 = time.perf_counter()
    cfg = load_config(path)
    return study_of(cfg, config_s=time.perf_counter() - t0)


def study_of(cfg: StudyConfig, *, config_s: float = 0.0) -> Study:
    """The study of an already loaded and validated config (``config_s``: the seconds that
    loading took, for ``timing_s``); raises as :func:`load_study` does for the scene."""
    t = time.perf_counter()
    scene = build_scene(cfg)
    scene_s = time.perf_counter() - t
    return Study(cfg, scene, load_s=config_s + scene_s, config_s=config_s, scene_s=scene_s)


def solver_settings(study: Study, **overrides) -> SolverSettings:
    """The study's ``[solver]`` table as :class:`~lumijax.lighting.SolverSettings`."""
    c = study.config.solver
    values = dict(
        indirect=c.indirect, patch_size=c.patch_size, target_patches=c.target_patches,
        accuracy=c.accuracy,
        max_block=c.max_block, method=c.method, tolerance=c.tolerance,
        max_iterations=c.max_iterations, gather_rays=c.gather_rays, precision=c.precision,
        spectral_samples=c.spectral_samples, operator_patches=c.operator_patches,
        refine=c.refine, refine_threshold=c.refine_threshold,
        transport=c.transport, rays_per_patch=c.rays_per_patch, aimed_share=c.aimed_share,
        final_gather_rays=c.final_gather_rays,
    )
    values.update(overrides)
    return SolverSettings(**values)


def check_memory(study: Study):
    """The up-front memory check of ``lumijax check``: mesh the scene as ``compute`` will and
    bound its operator's memory (``lumijax.radiosity._estimate``) without building it.

    Returns the :class:`~lumijax.radiosity._estimate.OperatorEstimate`, or ``None`` when the
    study has no inter-reflection to build. Raises :class:`~lumijax.errors.SolveError` naming
    the ``[solver]`` settings that would fit when it exceeds the available memory. Adaptive
    refinement (``refine``) adds patches after direct light, so it is bounded here unrefined.
    """
    from .lighting._pipeline import (
        _check_before_meshing,
        _group_counts,
        _two_levels,
        patch_size_of,
        requested_patches,
    )
    from .lighting._settings import block_size
    from .radiosity import mesh_patches
    from .radiosity._estimate import bound_operator_memory

    settings = solver_settings(study)
    tri = study.scene.triangles
    if not settings.indirect or len(tri) == 0 or not study.scene.networks:
        return None
    size = patch_size_of(study.scene, settings)
    _check_before_meshing(study.scene, tri, size, settings)
    patches = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=size)
    patches, fine = _two_levels(patches, tri, size, settings.operator_patches)
    itemsize = 8 if settings.precision == "float64" else 4
    if settings.transport == "sampled":
        from .radiosity._estimate import bound_sampled_memory

        return bound_sampled_memory(patches.n, settings.first_rays, itemsize=itemsize,
                                    file=study.config.source)
    estimate, _ = bound_operator_memory(
        patches, max_block=block_size(settings.max_block, patches.n), itemsize=itemsize,
        caster=study.scene.raycaster,
        triangles=len(tri), two_levels=fine is not None, file=study.config.source,
        patch_size=None if fine is not None else size,
        requested=settings.operator_patches if fine is not None else requested_patches(
            float(tri.areas.sum()), size, settings),
        remesh=lambda n: _group_counts(tri, n))
    return estimate


def compute(
    study: Study,
    *,
    shadows: bool = True,
    indirect: bool | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    cache_dir: str | Path | None = None,
    design: Design | None = None,
    scheduler=None,
) -> Results:
    """Light the study: direct and inter-reflected illuminance on every grid, per network.

    Parameters
    ----------
    design
        Light the study at this :class:`~lumijax.design.Design` instead of its config's
        (``study.with_design``: no config text is written or parsed).
    shadows
        Cast shadow rays (default). ``False`` ignores every obstruction and inter-reflection:
        the luminaires' photometry alone.
    indirect
        Override the config's ``[solver] indirect``.
    progress
        Called as ``progress(stage, done, total)``.
    cache_dir
        Where to keep the transport operator between runs; default ``.lumijax-cache`` beside
        the config (when ``[solver] cache`` is true).
    scheduler
        Run the parallel stages (direct light, the transport build, the final gather) on a
        Dask cluster: its address (``tcp://HOST:8786``), a ``distributed.Client`` or a
        :class:`~lumijax.parallel.Executor` (docs/parallel.md). None: in this process.
        Results equal the local run's.
    """
    recompute = partial(_at_design, study, shadows=shadows, indirect=indirect,
                        cache_dir=cache_dir)
    if design is not None:
        study = study.with_design(design)
    sc = study.scene
    t0 = time.perf_counter()
    grids = sc.grids
    if grids:
        points = np.concatenate([g.points for g in grids])
        normals = np.concatenate([g.normals for g in grids])
    else:
        points = normals = np.zeros((0, 3))
    overrides = {} if indirect is None else {"indirect": indirect}
    if not shadows:
        overrides["indirect"] = False
    settings = solver_settings(study, **overrides)
    if not study.config.solver.cache:
        cache_dir = None
    elif cache_dir is None and study.config.source is not None:
        cache_dir = study.config.source.parent / ".lumijax-cache"
    # a float64 study is solved in JAX's x64 mode, not by flipping it for the whole process
    with float64_scope(settings.precision == "float64"), executor_scope(scheduler):
        if shadows:
            lighting = solve_lighting(sc, points, normals, settings, progress=progress,
                                      cache_dir=cache_dir)
        else:
            lighting = _unshadowed(sc, points, normals, progress)
    total = lighting.point_total
    names = sc.network_names
    design = Design.of(sc)
    dimmers = design.dimmers
    out: dict[str, GridResult] = {}
    start = 0
    for g in grids:
        sl = slice(start, start + len(g))
        start += len(g)
        out[g.name] = GridResult(
            name=g.name, points=g.points, normals=g.normals, networks=names,
            by_network_lux=total[:, sl], dimmers=dimmers, shape=g.shape,
            target_lux=g.target_lux, direct_by_network_lux=lighting.point_direct[:, sl],
            xyz_by_network=None if lighting.point_xyz is None else lighting.point_xyz[:, :, sl],
        )
    if any(g.kind == "sensor" for g in study.config.grids):  # docs/compliance.md
        out = _sensor_results(study, lighting, out, shadows)
    flux = sc.network_flux_lm()
    networks = {
        n.name: {
            "dimmer": float(d),
            "luminaires": [lum.name for lum in sc.luminaires if lum.network == n.name]
            + [a.name for a in sc.area_sources if a.network == n.name],
            "flux_lm": flux[n.name],
        }
        for n, d in zip(sc.networks, design.dimmers, strict=True)
    }
    timing = {"load": study.load_s, "config": study.config_s, "scene": study.scene_s,
              **lighting.stats.get("timing_s", {}), "total": time.perf_counter() - t0}
    counts = {k: v for k, v in lighting.stats.items()
              if isinstance(v, int) and not isinstance(v, bool)
              and k not in ("gather_rays", "final_gather_rays")}
    counts["grid_points"] = int(len(points))
    solver = {k: v for k, v in lighting.stats.items()
              if k in ("patch_size_m", "iterations", "residual", "escaped_fraction",
                       "operator_cache_hit", "spectral_samples", "columns_solved",
                       "solved_directly", "sampled_noise", "final_gather_rays",
                       "gather_rays")}
    if lighting.spectral is not None and lighting.spectral.sampling is not None:
        solver["wavelengths_nm"] = [float(w) for w in lighting.spectral.sampling.wavelengths_nm]
    glare = _glare(study, lighting, out, design, shadows=shadows,
                   rays=settings.gather_rays_for(len(study.config.observers))
                   ) if study.config.observers else None
    results = Results(
        study=sc.name, grids=out, networks=networks, timing_s=timing, counts=counts,
        solver=solver, lighting=lighting, design=design, recompute=recompute, glare=glare,
    )
    if study.config.compliance is None:
        return results
    from .compliance import evaluate_compliance

    return replace(results, compliance=evaluate_compliance(study, results))


def _glare(study: Study, lighting, grids, design, *, shadows: bool, rays: int):
    """The observers' glare (``lumijax.glare``): what each eye sees of the luminaires, with
    the lit solution's background; None without ``[[observers]]``."""
    from .glare import Glare, build_glare_model, build_observers

    observers = build_observers(study.config, study.scene)
    model = build_glare_model(
        study.scene, observers, lighting if shadows else None, rays=rays,
        grid_lux={n: g.by_network_lux for n, g in grids.items()}, shadows=shadows,
        source=study.config.source)
    surfaces, radiosity = None, None
    names = [g.name for g in study.config.geometry]
    if shadows and lighting is not None and lighting.coarse.patches is not None and any(names):
        from .glare import build_seen_surfaces

        limits = [(oc.name, s, v) for oc in study.config.observers
                  for s, v in (oc.max_luminance_cdm2 or {}).items()]
        surfaces = build_seen_surfaces(study.scene, observers, lighting.coarse.patches, names,
                                       limits=limits)
        radiosity = np.asarray(lighting.coarse.radiosity, np.float64)
    elif any(oc.max_luminance_cdm2 for oc in study.config.observers):
        import warnings

        from .errors import LumijaxWarning

        i = next(i for i, oc in enumerate(study.config.observers) if oc.max_luminance_cdm2)
        warnings.warn(f"observers[{i}].max_luminance_cdm2: surface luminance needs the "
                      "radiosity patches (inter-reflection on) and shadows; not evaluated",
                      LumijaxWarning, stacklevel=3)
    return Glare(model, design, observers, surfaces=surfaces, radiosity=radiosity)


def _sensor_results(study: Study, lighting, grids: dict, shadows: bool) -> dict:
    """The sensor grids' results with their sensors' response (cylindrical, ...): direct and
    inter-reflected light computed again by ``lumijax.compliance`` (no XYZ for them)."""
    from .compliance import sensor_grids

    sensors = sensor_grids(study, lighting, shadows=shadows)
    return {n: g if n not in sensors else replace(
        g, by_network_lux=np.asarray(sensors[n].by_network, np.float64),
        direct_by_network_lux=np.asarray(sensors[n].direct, np.float64), xyz_by_network=None)
        for n, g in grids.items()}


def _at_design(study: Study, design: Design, *, shadows, indirect, cache_dir,
               override_cache_dir=None) -> Results:
    """``compute`` again with the options the results were computed with, at ``design``
    (what ``Results.at`` calls when the design re-aims or re-levels a luminaire)."""
    return compute(study, shadows=shadows, indirect=indirect, design=design,
                   cache_dir=cache_dir if override_cache_dir is None else override_cache_dir)


def _unshadowed(scene, points, normals, progress) -> LightingSolution:
    """Direct light with no obstruction at all (``shadows=False``)."""
    from .direct import direct_illuminance

    report = None if progress is None else (lambda d, t: progress("direct light", d, t))
    d = direct_illuminance(scene, points, normals, shadows=False, progress=report)
    return LightingSolution(
        scene=scene, points=points, normals=normals, coarse=Level.unlit(len(scene.networks)),
        transport=None, spectral=None, point_direct=d.by_network,
        point_indirect=np.zeros_like(d.by_network), point_xyz=None,
        stats={"shadow_rays": 0, "shadows": False},
    )
