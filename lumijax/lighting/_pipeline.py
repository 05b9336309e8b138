"""Build a study's :class:`LightingSolution`: mesh, operator, direct light, solve, gather."""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..direct import direct_illuminance
from ..errors import LumijaxWarning
from ..radiosity._gather import build_gather
from ._solution import Level, LightingSolution, shoot
from ._spectral import SpectralSetup

__all__ = ["SolverSettings", "solve_lighting", "auto_patch_size"]

CREATED_WARN = 0.01
"""Fraction of the reflected flux that rows summing above 1 would create, beyond which a
study is warned (the solve corrects it either way)."""


@dataclass(frozen=True)
class SolverSettings:
    """How inter-reflection is computed (the config's ``[solver]`` table, docs/config.md).

    ``patch_size`` None means automatic: about ``target_patches`` patches over the scene.
    """

    indirect: bool = True
    patch_size: float | None = None
    target_patches: int = 4_000
    max_block: int = 1024
    method: str = "refined"  # a name in lumijax.radiosity.RADIOSITY_SOLVERS
    tolerance: float | None = None
    max_iterations: int = 1000
    gather_rays: int = 512
    precision: str = "float32"
    spectral_samples: int = 16
    refine: int = 0  # most levels of adaptive refinement (docs/radiosity.md, "Refinement")
    refine_threshold: float = 0.5
    operator_patches: int | None = None  # two levels: elements for the operator (docs/radiosity.md)


def auto_patch_size(total_area_m2: float, target_patches: int) -> float:
    """Patch edge (m) giving about ``target_patches`` patches. A triangle of longest edge L is
    cut into ⌈L/s⌉² pieces; for the right triangles of rectangles and boxes (L² = 4 × area
    of the square they halve) that is 4·area/s² patches per unit area, hence s = √(4A/N).
    No floor in metres: a 4 mm model wants 0.1 mm patches as a 4 m room wants 0.1 m ones (a
    1 mm floor once gave a 4 µm model a single patch per face)."""
    return float(max(np.sqrt(4.0 * total_area_m2 / max(target_patches, 1)),
                     np.finfo(np.float64).tiny))


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
    from ..radiosity import (
        PartitionSettings,
        build_operator,
        cached_operator,
        mesh_patches,
        partition,
    )

    timing: dict[str, float] = {}
    stats: dict = {}

    def stage(name: str):
        def report(done: int, total: int) -> None:
            if progress is not None:
                progress(name, done, total)

        return report

    # Sources grouped by (network, spectrum): a group is one column of the solve per sample
    # wavelength; networks sum their groups.
    group_of, groups = _emission_groups(scene)
    gscene = _grouped_scene(scene, group_of, len(groups))
    k = len(scene.networks)
    to_net = np.zeros((k, len(groups)))
    for gi, (net, _) in enumerate(groups):
        to_net[net, gi] = 1.0

    def per_network(a):
        return None if a is None else np.tensordot(to_net, a, axes=(1, 0))

    t = time.perf_counter()
    direct_pts = _direct_in_chunks(gscene, points, normals, stage("direct light"))
    timing["direct_points"] = time.perf_counter() - t
    stats["shadow_rays"] = direct_pts.shadow_rays
    point_direct = per_network(direct_pts.by_network)
    tri = scene.triangles
    if not settings.indirect or len(tri) == 0 or k == 0:
        zeros = np.zeros((k, 0))
        return LightingSolution(
            scene=scene, points=points, normals=normals, patches=None, transport=None,
            gather=None, spectral=None, rho=None, patch_direct=zeros, radiosity=zeros,
            radiosity_xyz=None, point_direct=point_direct,
            point_indirect=np.zeros_like(point_direct), point_xyz=None,
            stats={**stats, "timing_s": timing},
        )

    t = time.perf_counter()
    size = settings.patch_size or auto_patch_size(float(tri.areas.sum()), settings.target_patches)
    _check_before_meshing(scene, tri, size, settings)
    patches = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=size)
    if settings.refine:
        from ..radiosity import refine_patches

        patches = refine_patches(
            patches, lambda p: direct_illuminance(gscene, p.centroid, p.normal).by_network,
            settings.refine, settings.refine_threshold).patches
    caster = scene.raycaster
    patches, fine = _two_levels(patches, tri, size, settings.operator_patches)
    timing["mesh"] = time.perf_counter() - t
    stats.update(patches=patches.n, patch_size_m=size)
    if fine is not None:
        stats.update(fine_patches=fine.n,
                     element_size_m=auto_patch_size(float(tri.areas.sum()),
                                                    settings.operator_patches))

    t = time.perf_counter()
    dtype = np.float64 if settings.precision == "float64" else np.float32
    # before any form factor: an operator that cannot fit is refused now, naming the settings
    # that would fit, not after minutes of building (docs/radiosity.md, "Memory estimate")
    from ..radiosity._estimate import bound_operator_memory

    estimate, part = bound_operator_memory(
        patches, max_block=settings.max_block, itemsize=np.dtype(dtype).itemsize,
        caster=caster, triangles=len(tri), two_levels=fine is not None,
        file=scene.source, patch_size=None if fine is not None else size,
        requested=settings.operator_patches if fine is not None else (
            None if settings.patch_size else settings.target_patches),
        remesh=lambda n: _group_counts(tri, n))
    stats["operator_bytes_bound"] = int(estimate.stored_bytes)
    if cache_dir is not None:
        transport, hit = cached_operator(
            patches, tri.vertices, cache_dir=cache_dir, dtype=dtype, caster=caster,
            partition_settings=PartitionSettings(max_block=settings.max_block),
        )
        stats["operator_cache_hit"] = bool(hit)
    else:
        if part is None:
            part = partition(patches, max_block=settings.max_block, occluders=caster)
        timing["partition"] = time.perf_counter() - t
        t = time.perf_counter()
        transport = build_operator(patches, part, caster, dtype=dtype,
                                   occluder_triangles=tri.vertices)
    timing["operator"] = time.perf_counter() - t
    stats["operator_bytes"] = int(transport.nbytes)

    t = time.perf_counter()
    if fine is None:
        direct_patch = direct_illuminance(gscene, patches.centroid, patches.normal,
                                          progress=stage("direct light on patches"))
    else:  # exact on the fine patches; the elements get their area means (flux conserved)
        from ..radiosity._final_gather import element_direct

        direct_fine, direct_patch = element_direct(gscene, fine, patches,
                                                   progress=stage("direct light on patches"))
    timing["direct_patches"] = time.perf_counter() - t
    stats["shadow_rays"] += direct_patch.shadow_rays

    rho = np.array([m.luminous_reflectance for m in scene.materials])[patches.material]
    t = time.perf_counter()
    spectral = SpectralSetup.build(scene, patches.material, settings.spectral_samples)
    timing["spectral_sampling"] = time.perf_counter() - t
    stats["spectral_samples"] = spectral.n
    t = time.perf_counter()
    gather = _gather_in_chunks(points, normals, patches, caster, settings.gather_rays,
                               stage("gathering onto grids"))
    timing["gather_rays"] = time.perf_counter() - t

    k = len(scene.networks)
    blank = LightingSolution(
        scene=scene, points=points, normals=normals, patches=patches, transport=transport,
        gather=gather, spectral=spectral, rho=rho, patch_direct=np.zeros((k, patches.n)),
        radiosity=np.zeros((k, patches.n)), radiosity_xyz=None,
        point_direct=point_direct, point_indirect=np.zeros_like(point_direct),
        point_xyz=None, solve_method=settings.method, solve_tolerance=settings.tolerance,
        solve_max_steps=settings.max_iterations,
    )
    t = time.perf_counter()
    shot = shoot(blank, direct_patch.by_network, [g[1] for g in groups],
                 direct_pts.by_network)
    timing["solve_and_gather"] = time.perf_counter() - t
    timing.update(shot.timing_s)
    fine_level = None
    if fine is not None:
        from ..radiosity._final_gather import final_gather

        t = time.perf_counter()
        lvl = final_gather(fine, patches, caster, spectral, [g[1] for g in groups],
                           shot.value, direct_fine.by_network, rays=settings.gather_rays)
        timing["final_gather"] = time.perf_counter() - t
        timing.update(lvl.timing_s)
        fine_level = Level(patches=fine, gather=lvl.gather, rho=lvl.rho,
                           patch_direct=per_network(lvl.direct),
                           patch_indirect=per_network(lvl.indirect),
                           radiosity=per_network(lvl.radiosity),
                           radiosity_xyz=per_network(lvl.radiosity_xyz))
    res = shot.result
    escaped = np.asarray(res.escaped).ravel()
    stats.update(iterations=int(res.iterations), residual=float(res.residual),
                 escaped_fraction=float(np.max(escaped)) if escaped.size else 0.0,
                 columns_solved=int(res.stats["columns_solved"]))
    created = np.asarray(res.stats["created"]).ravel()
    stats["created_fraction"] = float(np.max(created)) if created.size else 0.0
    if stats["created_fraction"] > CREATED_WARN:
        warnings.warn(
            f"form-factor rows sum to up to {float(res.stats['row_max']):.3f} (above 1: "
            f"{100 * stats['created_fraction']:.1f} % of the reflected flux would be created, "
            "not reflected); corrected by rescaling those patches' outgoing light "
            "(docs/radiosity.md, \"Row sums\"). Usually coincident surfaces (see any warning "
            "naming them) or patches too coarse where surfaces meet: lower [solver] "
            "patch_size or raise [solver] target_patches",
            LumijaxWarning, stacklevel=2,
        )
    if len(points) and float(np.min(gather.coverage)) < 0.999 and stats["escaped_fraction"] > 0.01:
        warnings.warn(
            f"the scene is open: up to {100 * stats['escaped_fraction']:.0f} % of the reflected "
            "light leaves it (to the sky) — fine outdoors, a modelling gap indoors",
            LumijaxWarning, stacklevel=2,
        )
    coarse = dataclasses.replace(
        blank.coarse, patch_direct=per_network(direct_patch.by_network),
        radiosity=per_network(shot.radiosity), radiosity_xyz=per_network(shot.radiosity_xyz))
    return dataclasses.replace(
        blank, coarse=coarse, fine=fine_level,
        point_indirect=per_network(shot.point_indirect), point_xyz=per_network(shot.point_xyz),
        stats={**stats, "timing_s": timing},
    )


#: Grid points per chunk of direct light and gathering on a large grid: each chunk reports
#: progress (a 10⁷-point grid in ~80 steps), and one chunk's rays and pairs stay in memory.
POINT_CHUNK = 1 << 17


def _direct_in_chunks(scene, points, normals, report):
    """Direct light on the grid points; above :data:`POINT_CHUNK` points in chunks that report
    ``(points done, points)``, below it as one call reporting sources (unchanged results)."""
    n = len(points)
    if n <= POINT_CHUNK:
        return direct_illuminance(scene, points, normals, progress=report)
    parts = []
    report(0, n)
    for s in range(0, n, POINT_CHUNK):
        parts.append(direct_illuminance(scene, points[s:s + POINT_CHUNK],
                                        normals[s:s + POINT_CHUNK]))
        report(min(s + POINT_CHUNK, n), n)
    timing = {}
    for d in parts:
        for key, v in d.timing_s.items():
            timing[key] = timing.get(key, 0.0) + v
    return dataclasses.replace(
        parts[0], by_network=np.concatenate([d.by_network for d in parts], axis=1),
        shadow_rays=sum(d.shadow_rays for d in parts),
        candidate_pairs=sum(d.candidate_pairs for d in parts), timing_s=timing)


def _gather_in_chunks(points, normals, patches, caster, rays, report):
    """The grid points' gather; above :data:`POINT_CHUNK` points in chunks (a seed per
    chunk: the same statistics, not the same rays) that report ``(points done, points)``."""
    n = len(points)
    if n <= POINT_CHUNK:
        return build_gather(points, normals, patches, caster, rays=rays)
    parts = []
    report(0, n)
    for i, s in enumerate(range(0, n, POINT_CHUNK)):
        g = build_gather(points[s:s + POINT_CHUNK], normals[s:s + POINT_CHUNK], patches, caster,
                         rays=rays, seed=i)
        parts.append(dataclasses.replace(g, point=g.point + np.int32(s)))
        report(min(s + POINT_CHUNK, n), n)
    return dataclasses.replace(
        parts[0], n_points=n, point=np.concatenate([g.point for g in parts]),
        patch=np.concatenate([g.patch for g in parts]),
        weight=np.concatenate([g.weight for g in parts]))


def _check_before_meshing(scene, tri, size: float, settings) -> None:
    """The mesh and a hopeless operator refused before meshing (``_estimate``)."""
    from ..radiosity._estimate import check_before_meshing

    esize = None
    if settings.operator_patches is not None:
        esize = auto_patch_size(float(tri.areas.sum()), settings.operator_patches)
        esize = esize if esize > size else None
    check_before_meshing(tri.vertices, tri.group, size, element_size=esize,
                         itemsize=8 if settings.precision == "float64" else 4,
                         max_block=settings.max_block, file=scene.source)


def _group_counts(tri, target_patches: int) -> np.ndarray:
    """Patches per group of the mesh made for ``target_patches`` (the memory check's way to
    try a setting without building anything on it)."""
    from ..radiosity import mesh_patches

    size = auto_patch_size(float(tri.areas.sum()), target_patches)
    return np.unique(mesh_patches(tri.vertices, tri.material, tri.group, patch_size=size).group,
                     return_counts=True)[1]


def _two_levels(patches, tri, size: float, operator_patches: int | None):
    """``(elements, fine)``: the operator's elements and the fine patches that gather from them
    (``fine`` None: one level, when not asked for or when the elements would not be coarser)."""
    if operator_patches is None:
        return patches, None
    from ..radiosity import mesh_patches

    esize = auto_patch_size(float(tri.areas.sum()), operator_patches)
    if esize <= size:
        return patches, None
    elements = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=esize)
    if elements.n >= patches.n:
        return patches, None
    return elements, patches


def _emission_groups(scene):
    """Group index of every luminaire and area source, and the (network, spectrum) groups."""
    from ._spectral import source_spectrum

    net = {n.name: i for i, n in enumerate(scene.networks)}
    index: dict = {}
    group_of = []
    for src in (*scene.luminaires, *scene.area_sources):
        key = (net[src.network], source_spectrum(src.spectrum))
        group_of.append(index.setdefault(key, len(index)))
    return group_of, list(index)


def _grouped_scene(scene, group_of, n_groups):
    """The scene with each source's network replaced by its emission group."""
    from ..scene import Network

    names = [f"group{i}" for i in range(n_groups)]
    n_lum = len(scene.luminaires)
    return dataclasses.replace(
        scene,
        networks=tuple(Network(n) for n in names),
        luminaires=tuple(dataclasses.replace(lum, network=names[group_of[i]])
                         for i, lum in enumerate(scene.luminaires)),
        area_sources=tuple(dataclasses.replace(a, network=names[group_of[n_lum + i]])
                           for i, a in enumerate(scene.area_sources)),
    )
