"""Build a study's :class:`LightingSolution`: the stages of ``_stages.py`` in order."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from ..scene import Scene
from . import _stages as st
from ._settings import SolverSettings, auto_patch_size
from ._solution import LightingSolution

__all__ = ["SolverSettings", "solve_lighting", "auto_patch_size"]

# the stage helpers callers reach here (lumijax check's memory estimate, tests)
CREATED_WARN = st.CREATED_WARN
_check_before_meshing = st._check_before_meshing
_group_counts = st._group_counts
_two_levels = st._two_levels
patch_size_of = st.patch_size_of
requested_patches = st.requested_patches

_DEFAULT = SolverSettings()


def solve_lighting(
    scene: Scene,
    points: np.ndarray,
    normals: np.ndarray,
    settings: SolverSettings = _DEFAULT,
    *,
    progress: Callable[[str, int, int], None] | None = None,
    cache_dir=None,
) -> LightingSolution:
    """Direct and inter-reflected light of ``scene`` on the given calculation points.

    Parameters
    ----------
    scene
        A :class:`lumijax.scene.Scene`.
    points, normals
        Calculation points (m) and their measuring planes' normals, all grids concatenated.
    settings
        :class:`SolverSettings`.
    progress
        Called as ``progress(stage, done, total)``.
    cache_dir
        Folder of the on-disk operator cache (``.lumijax-cache`` beside the config); ``None``
        builds the operator every time.

    Each stage's wall time is in ``stats["timing_s"]`` (docs/results.md), ``lighting`` the
    whole of it.
    """
    t0 = time.perf_counter()
    report = _reporter(progress)
    emission = st.group_emission(scene)
    direct = st.light_points(emission, points, normals, report("direct light"))
    if not settings.indirect or len(scene.triangles) == 0 or not scene.networks:
        sol = st.direct_only(scene, points, normals, emission, direct)
        return _timed(sol, t0)
    meshed = st.mesh(scene, emission, settings)
    # the sampled transport aims rays where the direct light lies (radiosity/_bright.py), so
    # it comes after that light (its memory bounded before it); the blocks' bound needs their
    # partition, so they come first and refuse before any light is cast
    aimed = settings.transport == "sampled"
    if aimed:
        st.bound_sampled(scene, meshed, settings)
    else:
        transport = st.build_transport(scene, meshed, settings, cache_dir,
                                       report("form factors"))
    direct = st.light_patches(direct, emission, meshed, report("direct light on patches"),
                              report("direct light near luminaires"))
    if aimed:
        transport = st.build_transport(scene, meshed, settings, cache_dir,
                                       report("form factors"), direct=direct)
    sampling = st.sample_spectra(scene, meshed, settings)
    rays = st.cast_gather_rays(points, normals, meshed, scene, settings,
                               report("gathering onto grids"))
    radiosity = st.solve(scene, points, normals, emission, direct, meshed, transport, sampling,
                         rays, settings, report("solving inter-reflections"),
                         report("final gather on patches"))
    noise = st.transport_noise(scene, meshed, transport, radiosity, rays, sampling)
    gathered = st.gather_fine(scene, emission, direct, meshed, sampling, radiosity, settings)
    sol = st.assemble(scene, points, normals, emission, direct, meshed, transport, sampling,
                      rays, radiosity, gathered, settings, noise)
    return _timed(sol, t0)


def _reporter(progress: Callable[[str, int, int], None] | None
              ) -> Callable[[str], st.Report]:
    """``report(stage)``: the ``(done, total)`` callback of one stage."""
    def stage(name: str) -> st.Report:
        def report(done: int, total: int) -> None:
            if progress is not None:
                progress(name, done, total)

        return report

    return stage


def _timed(sol: LightingSolution, t0: float) -> LightingSolution:
    sol.stats["timing_s"]["lighting"] = time.perf_counter() - t0
    return sol
