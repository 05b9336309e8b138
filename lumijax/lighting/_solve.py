"""Build a study's :class:`LightingSolution`: mesh, operator, direct light, solve, gather."""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from ..direct import direct_illuminance
from ..errors import LumijaxWarning
from ._gather import build_gather
from ._solution import LightingSolution, _solve_columns

__all__ = ["SolverSettings", "solve_lighting", "auto_patch_size"]


@dataclass(frozen=True)
class SolverSettings:
    """How inter-reflection is computed (the config's ``[solver]`` table, docs/config.md).

    ``patch_size`` None means automatic: about ``target_patches`` patches over the scene.
    """

    indirect: bool = True
    patch_size: float | None = None
    target_patches: int = 4_000
    max_block: int = 1024
    method: str = "bicgstab"
    tolerance: float | None = None
    max_iterations: int = 1000
    gather_rays: int = 512
    precision: str = "float32"


def auto_patch_size(total_area_m2: float, target_patches: int) -> float:
    """Patch edge (m) giving about ``target_patches`` patches. A triangle of longest edge L is
    cut into ⌈L/s⌉² pieces; for the right triangles of rectangles and boxes (L² = 4 × area
    of the square they halve) that is 4·area/s² patches per unit area, hence s = √(4A/N)."""
    return float(max(np.sqrt(4.0 * total_area_m2 / max(target_patches, 1)), 1e-3))


def solve_lighting(
    scene,
    points: np.ndarray,
    normals: np.ndarray,
    settings: SolverSettings = SolverSettings(),
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
    """
    from ..mesh import PartitionSettings, mesh_patches, partition
    from ..transport import build_operator, cached_operator

    timing: dict[str, float] = {}
    stats: dict = {}

    def stage(name: str):
        def report(done: int, total: int) -> None:
            if progress is not None:
                progress(name, done, total)

        return report

    t = time.perf_counter()
    direct_pts = direct_illuminance(scene, points, normals, progress=stage("direct light"))
    timing["direct_points"] = time.perf_counter() - t
    stats["shadow_rays"] = direct_pts.shadow_rays
    k = len(scene.networks)
    tri = scene.triangles
    if not settings.indirect or len(tri) == 0 or k == 0:
        zeros = np.zeros((k, 0))
        return LightingSolution(
            scene=scene, points=points, normals=normals, patches=None, transport=None,
            gather=None, rho=None, patch_direct=zeros, radiosity=zeros,
            point_direct=direct_pts.by_network, point_indirect=np.zeros_like(direct_pts.by_network),
            stats={**stats, "timing_s": timing},
        )

    t = time.perf_counter()
    size = settings.patch_size or auto_patch_size(float(tri.areas.sum()), settings.target_patches)
    patches = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=size)
    caster = scene.raycaster
    timing["mesh"] = time.perf_counter() - t
    stats.update(patches=patches.n, patch_size_m=size)

    t = time.perf_counter()
    dtype = np.float64 if settings.precision == "float64" else np.float32
    if cache_dir is not None:
        transport, hit = cached_operator(
            patches, tri.vertices, cache_dir=cache_dir, dtype=dtype, caster=caster,
            partition_settings=PartitionSettings(max_block=settings.max_block),
        )
        stats["operator_cache_hit"] = bool(hit)
    else:
        part = partition(patches, max_block=settings.max_block, occluders=caster)
        transport = build_operator(patches, part, caster, dtype=dtype)
    timing["operator"] = time.perf_counter() - t
    stats["operator_bytes"] = int(transport.nbytes)

    t = time.perf_counter()
    direct_patch = direct_illuminance(scene, patches.centroid, patches.normal,
                                      progress=stage("direct light on patches"))
    timing["direct_patches"] = time.perf_counter() - t
    stats["shadow_rays"] += direct_patch.shadow_rays

    rho = np.array([m.luminous_reflectance for m in scene.materials])[patches.material]
    t = time.perf_counter()
    gather = build_gather(points, normals, patches, caster, rays=settings.gather_rays)
    timing["gather_rays"] = time.perf_counter() - t

    sol = LightingSolution(
        scene=scene, points=points, normals=normals, patches=patches, transport=transport,
        gather=gather, rho=rho, patch_direct=direct_patch.by_network,
        radiosity=np.zeros_like(direct_patch.by_network), point_direct=direct_pts.by_network,
        point_indirect=np.zeros_like(direct_pts.by_network), solve_method=settings.method,
        solve_tolerance=settings.tolerance, solve_max_steps=settings.max_iterations,
    )
    t = time.perf_counter()
    radiosity, res = _solve_columns(sol, direct_patch.by_network)
    timing["solve"] = time.perf_counter() - t
    escaped = np.asarray(res.escaped)
    stats.update(iterations=int(res.iterations), residual=float(res.residual),
                 escaped_fraction=[float(x) for x in np.atleast_1d(escaped)])
    t = time.perf_counter()
    indirect = np.asarray(gather(jnp.asarray(radiosity.T)), np.float64).T
    timing["gather"] = time.perf_counter() - t
    if len(points) and float(np.min(gather.coverage)) < 0.999 and float(np.max(escaped)) > 0.01:
        warnings.warn(
            f"the scene is open: up to {100 * float(np.max(escaped)):.0f} % of the reflected "
            "light leaves it (to the sky) — fine outdoors, a modelling gap indoors",
            LumijaxWarning, stacklevel=2,
        )
    return LightingSolution(
        scene=scene, points=points, normals=normals, patches=patches, transport=transport,
        gather=gather, rho=rho, patch_direct=direct_patch.by_network, radiosity=radiosity,
        point_direct=direct_pts.by_network, point_indirect=indirect,
        solve_method=settings.method, solve_tolerance=settings.tolerance,
        solve_max_steps=settings.max_iterations, stats={**stats, "timing_s": timing},
    )
