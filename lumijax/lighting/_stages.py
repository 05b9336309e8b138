"""The stages of a study's lighting: each a function of the records before it that returns its
own typed record, with the wall time (s) the stage took.

    Emission ─▶ DirectLight (points) ─▶ Meshed ─▶ Transport ─▶ DirectLight (+ patches)
        ─▶ Sampling ─▶ GatherRays ─▶ Radiosity ─▶ Gathered  ─▶  LightingSolution (assemble)

Light in the records is per emission group (a network and a spectrum: one column of the solve
per sample wavelength); :meth:`Emission.per_network` sums the groups of a network at the end.
``solve_lighting`` (``_pipeline.py``) runs them in this order; a benchmark may run them one by
one to measure each (``benchmarks/courtyard.py``).
"""

from __future__ import annotations

import dataclasses
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import overload

import numpy as np
from jaxtyping import Float

from ..direct import DirectLighting, direct_illuminance
from ..errors import LumijaxWarning
from ..parallel import current_executor, release_freed_memory, threaded_map
from ..radiosity import (
    BrightPatches,
    GatherOperator,
    PartitionSettings,
    Patches,
    SampledGather,
    SampledNoise,
    SampledSettings,
    TransportOperator,
    build_exact_gather,
    build_gather,
    build_operator,
    cached_operator,
    mesh_patches,
    near_light,
    partition,
    patch_slopes,
    refine_patches,
    sampled_noise,
)
from ..radiosity._estimate import (
    bound_operator_memory,
    bound_sampled_memory,
    check_before_meshing,
)
from ..radiosity._final_gather import FineLevel, element_direct, final_gather
from ..scene import AreaSource, Luminaire, Network, Scene
from ..spectral import Spectrum
from ._settings import (
    DEFAULT_MAX_BLOCK,
    SolverSettings,
    accuracy_patch_size,
    auto_patch_size,
    block_size,
    mean_free_path,
    source_distance,
)
from ._solution import Level, LightingSolution, Shot, _needed, shoot
from ._spectral import SpectralSetup, source_spectrum

__all__ = [
    "Emission", "DirectLight", "Meshed", "Transport", "Sampling", "GatherRays", "Radiosity",
    "Gathered", "group_emission", "light_points", "mesh", "bound_sampled", "build_transport",
    "light_patches", "sample_spectra", "cast_gather_rays", "solve", "transport_noise",
    "gather_fine", "assemble", "direct_only",
    "CREATED_WARN", "NOISE_WARN", "POINT_CHUNK", "patch_size_of", "requested_patches",
]

Report = Callable[[int, int], None]

CREATED_WARN = 0.01
"""Fraction of the reflected flux that rows summing above 1 would create, beyond which a
study is warned (the solve corrects it either way)."""

NOISE_WARN = 0.03
"""Own noise of the sampled transport (RMS per patch of the inter-reflected irradiance,
relative; ``radiosity/_noise.py``) beyond which a study is warned: issue 17's 3 %."""

#: Grid points per chunk of direct light and gathering on a large grid: each chunk reports
#: progress (a 10⁷-point grid in ~80 steps), and one chunk's rays and pairs stay in memory.
POINT_CHUNK = 1 << 17


# --- records ----------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Emission:
    """The scene's sources grouped by (network, spectrum).

    Attributes
    ----------
    scene
        The scene with each source's network replaced by its group (``group0``, ``group1``…):
        direct light of this scene comes out per group.
    network, spectra
        Each group's network index (``scene.networks`` order of the study's scene) and spectrum.
    to_network
        ``(networks, groups)`` 0/1 matrix summing groups into networks.
    seconds
        Wall time of the grouping (s).
    """

    scene: Scene
    network: tuple[int, ...]
    spectra: tuple[Spectrum, ...]
    to_network: Float[np.ndarray, "net group"]
    seconds: float = 0.0

    @overload
    def per_network(self, a: np.ndarray) -> np.ndarray: ...

    @overload
    def per_network(self, a: None) -> None: ...

    def per_network(self, a: np.ndarray | None) -> np.ndarray | None:
        """Per-group values (groups on the first axis) summed into networks."""
        return None if a is None else np.tensordot(self.to_network, a, axes=(1, 0))


@dataclass(frozen=True, eq=False)
class DirectLight:
    """Direct illuminance (lx) per emission group at dimmer 1, shadows included.

    Attributes
    ----------
    points
        ``(groups, points)`` on the calculation points.
    patches
        ``(groups, patches)`` on the operator's patches (two levels: the fine patches' flux
        over each element's area); None before :func:`light_patches`.
    fine
        ``(groups, fine)`` on the fine patches of a two-level solve, else None.
    shadow_rays
        Shadow rays cast so far.
    points_s, patches_s
        Wall time (s) of the light on the points and on the patches.
    """

    points: Float[np.ndarray, "group points"]
    patches: Float[np.ndarray, "group patches"] | None = None
    fine: Float[np.ndarray, "group fine"] | None = None
    shadow_rays: int = 0
    points_s: float = 0.0
    patches_s: float = 0.0


@dataclass(frozen=True, eq=False)
class Meshed:
    """The scene's surfaces cut into patches.

    Attributes
    ----------
    patches
        The operator's patches (the elements of a two-level solve).
    fine
        The fine patches that gather from the elements (two levels), else None.
    patch_size_m, element_size_m
        Patch edge (m) of ``fine`` (two levels) or ``patches``, and of the elements (None:
        one level).
    seconds
        Wall time (s): checks, meshing, adaptive refinement and the second level.
    """

    patches: Patches
    fine: Patches | None
    patch_size_m: float
    element_size_m: float | None
    seconds: float


@dataclass(frozen=True, eq=False)
class Transport:
    """The transport operator F of the operator's patches and where it came from.

    Attributes
    ----------
    operator
        The block-sparse :class:`~lumijax.radiosity.TransportOperator`.
    cache_hit
        Whether it was read from the operator cache; None when no cache was asked for.
    bytes_bound
        The up-front bound on its memory (bytes) checked before building.
    bound_s, partition_s, seconds
        Wall time (s) of the memory bound, of the partition (built without a cache; None
        otherwise: the cache partitions on a miss) and of building or loading the operator.
    sampled, bright
        The sampled transport's settings and the patches its aimed rays were aimed at (what
        :func:`transport_noise` casts again); None for the block operator.
    final
        The sampled transport's final gather (``[solver] final_gather_rays``, or what
        ``rays_per_patch = "auto"`` found 3 % per patch needs); None without one.
    """

    operator: TransportOperator
    cache_hit: bool | None
    bytes_bound: int
    bound_s: float
    partition_s: float | None
    seconds: float
    sampled: SampledSettings | None = None
    bright: BrightPatches | None = None
    final: SampledGather | None = None


@dataclass(frozen=True, eq=False)
class Sampling:
    """The spectral set-up of the solve and the patches' luminous reflectance.

    ``seconds``: wall time (s) of segmenting the study's spectra into sample wavelengths.
    """

    spectral: SpectralSetup
    rho: Float[np.ndarray, " patches"]
    seconds: float


@dataclass(frozen=True, eq=False)
class GatherRays:
    """The rays cast from the calculation points: the patches → points gather operator.

    ``seconds``: wall time (s) of casting them; ``rays``: rays per point (0: the gather was
    taken in closed form, ``radiosity.build_exact_gather``).
    """

    gather: GatherOperator
    seconds: float
    rays: int


@dataclass(frozen=True, eq=False)
class Radiosity:
    """The batched radiosity solve of every emission group, and its gather onto the points.

    ``shot`` holds the per-group radiosity and the inter-reflected light on the points;
    ``seconds`` the wall time (s) of solve and gather together (``shot.timing_s`` splits it).
    """

    shot: Shot
    seconds: float

    def stats(self) -> dict:
        """The solve's figures as the solution's stats carry them."""
        res = self.shot.result
        escaped = np.asarray(res.escaped).ravel()
        created = np.asarray(res.stats["created"]).ravel()
        return dict(iterations=int(res.iterations), residual=float(res.residual),
                    escaped_fraction=float(np.max(escaped)) if escaped.size else 0.0,
                    columns_solved=int(res.stats["columns_solved"]),
                    solved_directly=bool(res.stats.get("direct", False)),
                    created_fraction=float(np.max(created)) if created.size else 0.0)


@dataclass(frozen=True, eq=False)
class Gathered:
    """The fine level of a two-level solve, per emission group (None with one level).

    ``seconds``: wall time (s) of the final gather (``fine.timing_s`` splits it).
    """

    fine: FineLevel | None
    seconds: float = 0.0


# --- stages -----------------------------------------------------------------------------------

def group_emission(scene: Scene) -> Emission:
    """Group the sources by (network, spectrum): a group is one column of the solve per sample
    wavelength, and networks sum their groups."""
    t = time.perf_counter()
    net = {n.name: i for i, n in enumerate(scene.networks)}
    index: dict[tuple[int, Spectrum], int] = {}
    group_of = []
    sources: list[Luminaire | AreaSource] = [*scene.luminaires, *scene.area_sources]
    for src in sources:
        key = (net[src.network], source_spectrum(src.spectrum))
        group_of.append(index.setdefault(key, len(index)))
    groups = list(index)
    names = [f"group{i}" for i in range(len(groups))]
    n_lum = len(scene.luminaires)
    grouped = dataclasses.replace(
        scene,
        networks=tuple(Network(n) for n in names),
        luminaires=tuple(dataclasses.replace(lum, network=names[group_of[i]])
                         for i, lum in enumerate(scene.luminaires)),
        area_sources=tuple(dataclasses.replace(a, network=names[group_of[n_lum + i]])
                           for i, a in enumerate(scene.area_sources)),
    )
    to_network = np.zeros((len(scene.networks), len(groups)))
    for gi, (k, _) in enumerate(groups):
        to_network[k, gi] = 1.0
    return Emission(grouped, tuple(k for k, _ in groups), tuple(s for _, s in groups),
                    to_network, seconds=time.perf_counter() - t)


def light_points(emission: Emission, points: np.ndarray, normals: np.ndarray,
                 report: Report) -> DirectLight:
    """Direct light on the calculation points (m; unit normals); above :data:`POINT_CHUNK`
    points in chunks that report ``(points done, points)``, below it as one call reporting
    sources (unchanged results)."""
    t = time.perf_counter()
    d = _direct_in_chunks(emission.scene, points, normals, report)
    _release_after_threads(len(points))
    return DirectLight(points=d.by_network, shadow_rays=d.shadow_rays,
                       points_s=time.perf_counter() - t)


def mesh(scene: Scene, emission: Emission, settings: SolverSettings) -> Meshed:
    """Cut the scene's triangles into patches: refused first if the mesh or its operator could
    not fit (``radiosity._estimate``), refined where the direct light varies (``refine``), and
    split into elements and fine patches when ``operator_patches`` asks for two levels."""
    t = time.perf_counter()
    tri = scene.triangles
    size = patch_size_of(scene, settings)
    _check_before_meshing(scene, tri, size, settings)
    patches = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=size)
    if settings.refine:
        patches = refine_patches(
            patches,
            lambda p: direct_illuminance(emission.scene, p.centroid, p.normal).by_network,
            settings.refine, settings.refine_threshold).patches
    patches, fine = _two_levels(patches, tri, size, settings.operator_patches)
    esize = None
    if fine is not None and settings.operator_patches is not None:
        esize = auto_patch_size(float(tri.areas.sum()), settings.operator_patches)
    return Meshed(patches, fine, size, esize, time.perf_counter() - t)


def build_transport(scene: Scene, meshed: Meshed, settings: SolverSettings,
                    cache_dir=None, report: Report | None = None, *,
                    direct: DirectLight | None = None) -> Transport:
    """The operator of ``meshed.patches``: its memory bounded before any form factor (an
    operator that cannot fit is refused now, naming the settings that would fit, not after
    minutes of building: docs/radiosity.md, "Memory estimate"), then read from ``cache_dir``
    or built (None: built every time). The sampled transport aims a share of its rays at the
    patches ``direct`` lights (:func:`light_patches`; None: cosine-weighted rays only)."""
    t = time.perf_counter()
    tri, caster, patches, fine = scene.triangles, scene.raycaster, meshed.patches, meshed.fine
    dtype = np.float64 if settings.precision == "float64" else np.float32
    if settings.transport == "sampled":
        return _sampled_transport(scene, patches, settings, dtype, cache_dir, t, report, direct)
    max_block = block_size(settings.max_block, patches.n)
    estimate, part = bound_operator_memory(
        patches, max_block=max_block, itemsize=np.dtype(dtype).itemsize,
        caster=caster, triangles=len(tri), two_levels=fine is not None,
        file=scene.source, patch_size=None if fine is not None else meshed.patch_size_m,
        requested=settings.operator_patches if fine is not None else requested_patches(
            float(tri.areas.sum()), meshed.patch_size_m, settings),
        remesh=lambda n: _group_counts(tri, n))
    bound_s = time.perf_counter() - t
    partition_s = None
    hit: bool | None = None
    if cache_dir is not None:
        t = time.perf_counter()
        operator, hit = cached_operator(
            patches, tri.vertices, cache_dir=cache_dir, dtype=dtype, caster=caster,
            partition_settings=PartitionSettings(max_block=max_block),
        )
        hit = bool(hit)
    else:
        t = time.perf_counter()
        if part is None:
            part = partition(patches, max_block=max_block, occluders=caster)
        partition_s = time.perf_counter() - t
        t = time.perf_counter()
        operator = build_operator(patches, part, caster, dtype=dtype,
                                  occluder_triangles=tri.vertices)
    return Transport(operator, hit, int(estimate.stored_bytes), bound_s, partition_s,
                     time.perf_counter() - t)


def bound_sampled(scene: Scene, meshed: Meshed, settings: SolverSettings) -> None:
    """Refuse a sampled transport that cannot fit before any light is cast (it is built after
    the direct light on the patches, where its rays aim: :func:`build_transport`)."""
    _sampled_bound(scene, meshed.patches, settings,
                   np.float64 if settings.precision == "float64" else np.float32)


def _sampled_bound(scene: Scene, patches: Patches, settings: SolverSettings, dtype):
    # the solve's columns too (one batch at least, and every column's result on the host):
    # one group per network and sample wavelength, the fewest the solve can have
    columns = len(scene.networks) * max(settings.spectral_samples, 1)
    return bound_sampled_memory(patches.n, settings.first_rays,
                                itemsize=np.dtype(dtype).itemsize, file=scene.source,
                                columns=columns)


def _sampled_transport(scene: Scene, patches: Patches, settings: SolverSettings, dtype,
                       cache_dir, t0: float, report: Report | None = None,
                       direct: DirectLight | None = None) -> Transport:
    """``[solver] transport = "sampled"``: rays from every patch (radiosity/_sampled.py), a
    share aimed at the patches ``direct`` lights (each group's flux, ``_bright.py``), its
    memory bounded first (every ray a link), then cached like the block operator."""
    from ..radiosity import SampledSettings, bright_patches, build_sampled, cached_sampled_operator

    estimate = _sampled_bound(scene, patches, settings, dtype)
    bound_s = time.perf_counter() - t0
    t = time.perf_counter()
    ss = SampledSettings(rays_per_patch=settings.first_rays, aimed_share=settings.aimed_share)
    bright = (None if direct is None or direct.patches is None or settings.aimed_share == 0
              else bright_patches(direct.patches * patches.area, patches))

    def build(ss):
        if cache_dir is None:
            return build_sampled(patches, scene.triangles.vertices, ss, caster=scene.raycaster,
                                 dtype=dtype, progress=report, bright=bright), None
        operator, hit = cached_sampled_operator(patches, scene.triangles.vertices, ss,
                                                cache_dir=cache_dir, dtype=dtype,
                                                caster=scene.raycaster, progress=report,
                                                bright=bright)
        return operator, bool(hit)

    operator, hit = build(ss)
    final = settings.final_gather_rays
    if (final is None and settings.rays_per_patch == "auto" and direct is not None
            and direct.patches is not None):
        rays = _rays_for_noise(scene, patches, settings, operator, ss, bright, direct, dtype)
        final = rays if rays > ss.rays_per_patch else None
    # the final gather's rows: a seed of their own, independent of the rows the radiosity was
    # solved with (SampledGather.of)
    gather = None if final is None else SampledGather.of(ss, int(final), bright)
    return Transport(operator, hit, int(estimate.stored_bytes), bound_s, None,
                     time.perf_counter() - t, sampled=ss, bright=bright, final=gather)


def _rays_for_noise(scene: Scene, patches: Patches, settings: SolverSettings, operator, ss,
                    bright, direct: DirectLight, dtype) -> int:
    """``rays_per_patch = "auto"``: the final gather's rays a patch for 0.9 × :data:`NOISE_WARN`
    noise per patch, from the first build's (:func:`~lumijax.radiosity.sampled_noise` for a
    one-column solve: every group's direct light at full output, luminous), at most
    :data:`AUTO_MOST_RAYS` (the gather's rays are streamed, so memory does not bound them;
    its time grows like them). The noise falls about as rays^-1/2 (docs/radiosity.md)."""
    import jax.numpy as jnp

    from ..radiosity import solve_radiosity

    rho = _luminous_rho(scene, patches)
    b0 = rho * np.asarray(direct.patches, np.float64).sum(axis=0)
    b = solve_radiosity(operator, jnp.asarray(rho, dtype), jnp.asarray(b0[:, None], dtype)).value
    noise = sampled_noise(operator, patches, ss, np.asarray(b, np.float64)[:, 0],
                          caster=scene.raycaster, bright=bright)
    # aimed a tenth below the warning, so that the final gather's own sample lands under it
    want = _rays_for(ss.rays_per_patch, noise.rms, 0.9 * NOISE_WARN)
    return int(min(want, AUTO_MOST_RAYS))


#: Most rays a patch ``rays_per_patch = "auto"`` gives the final gather: 16 × the first
#: build's 256, ≈ 4 times less noise (beyond it a scene's noise says its patches are too
#: coarse for its light, and the warning says what 3 % would take).
AUTO_MOST_RAYS = 4096


def _links_per_ray(operator, n_patches: int) -> float:
    """The share of a sampled operator's rays that became a link (rays into the sky store
    nothing, a patch's repeated hits on one patch one link), with a twentieth to spare: an
    upper bound for the same scene at more rays a patch, where more hits merge
    (``bound_sampled_memory``)."""
    rays = int(operator.info["settings"]["rays_per_patch"]) * max(int(n_patches), 1)
    return min(1.0, 1.05 * int(operator.info["links"]) / max(rays, 1))


def _luminous_rho(scene: Scene, patches: Patches) -> Float[np.ndarray, " patches"]:
    """Each patch's luminous reflectance (its material's)."""
    return np.array([m.luminous_reflectance for m in scene.materials])[patches.material]


def _rays_for(rays: int, noise: float, target: float) -> int:
    """The rays a patch for ``target`` noise, given ``noise`` at ``rays``, rounded up to 64:
    the noise falls about as rays^-1/2 (docs/radiosity.md, "Noise, measured")."""
    return int(64 * np.ceil(rays * (noise / target) ** 2 / 64))


def transport_noise(scene: Scene, meshed: Meshed, transport: Transport, radiosity: Radiosity,
                    rays: GatherRays | None = None,
                    sampling: Sampling | None = None) -> SampledNoise | None:
    """The sampled transport's own noise per patch for the solved radiosity (every group at
    full output, luminous; :func:`~lumijax.radiosity.sampled_noise`: 4,096 patches' rays cast
    again with another seed) — of its final gather's rows where it has one — and, given the
    gather and the patches' reflectance, the grid points' to first order, with a warning above
    :data:`NOISE_WARN` that names the rays a patch for 3 %; None for the block operator."""
    if transport.sampled is None:
        return None
    b = np.asarray(radiosity.shot.radiosity, np.float64).sum(axis=0)
    final = None if transport.final is None else transport.final.settings
    noise = sampled_noise(transport.operator, meshed.patches, transport.sampled, b,
                          caster=scene.raycaster, bright=transport.bright,
                          gather=None if rays is None else rays.gather,
                          rho=None if sampling is None else sampling.rho, final=final)
    if noise.rms > NOISE_WARN:
        from ..radiosity._estimate import sampled_rays_that_fit

        n = noise.rays_per_patch
        enough = _rays_for(n, noise.rms, NOISE_WARN)
        fit = sampled_rays_that_fit(
            meshed.patches.n, itemsize=np.dtype(transport.operator.buckets[0].dtype).itemsize,
            columns=len(scene.networks) * max(1 if sampling is None else sampling.spectral.n, 1),
            links_per_ray=_links_per_ray(transport.operator, meshed.patches.n))
        if final is None and enough <= fit:
            fix = f"[solver] rays_per_patch = {enough} would bring it to ≈ 3 %"
        elif enough <= 65536:  # the final gather's rays are streamed: time, not memory
            fix = (f"[solver] final_gather_rays = {enough} would bring it to ≈ 3 % (rays "
                   "cast once more and never stored: they take time, not memory)")
        else:
            fix = (f"≈ 3 % would take ≈ {enough:,} rays a patch, more than 65,536: a "
                   "smaller [solver] patch_size (more, smaller patches, each seeing a "
                   "smoother light)")
        what = "final gather" if final is not None else "sampled transport"
        points = ("" if noise.points_rms is None else
                  f" (≈ {100 * noise.points_rms:.1f} % at the grid points)")
        warnings.warn(
            f"the {what}'s own noise is ≈ {100 * noise.rms:.1f} % RMS per patch of "
            f"the inter-reflected light at {n} rays a patch (estimated by casting "
            f"{noise.patches:,} patches' rays again): the light on each patch (patches.vtp, "
            f"the surface maps) carries it, the grid points, which gather from many patches, "
            f"far less{points}; {fix}",
            LumijaxWarning, stacklevel=3,
        )
    return noise


def light_patches(direct: DirectLight, emission: Emission, meshed: Meshed,
                  report: Report, near_report: Report | None = None) -> DirectLight:
    """``direct`` with the direct light on the patches, each luminaire's light on a patch near
    it the mean over the patch (:func:`~lumijax.radiosity.near_light`): on the operator's
    patches (one level), or on the fine patches with the elements getting their area means
    (two levels: the flux the solve reflects is the fine one). ``near_report`` is told the
    near samples lit (one level)."""
    t = time.perf_counter()
    fine = None
    if meshed.fine is None:
        # in chunks of patches: the progress counts patches (equal work), not photometries
        patch = _direct_in_chunks(emission.scene, meshed.patches.centroid,
                                  meshed.patches.normal, report)
        near, rays = near_light(emission.scene, meshed.patches, progress=near_report)
        patch = dataclasses.replace(patch, by_network=patch.by_network + near,
                                    shadow_rays=patch.shadow_rays + rays)
    else:
        d_fine, patch = element_direct(emission.scene, meshed.fine, meshed.patches,
                                       progress=report)
        fine = d_fine.by_network
    _release_after_threads((meshed.fine or meshed.patches).n)
    return dataclasses.replace(direct, patches=patch.by_network, fine=fine,
                               shadow_rays=direct.shadow_rays + patch.shadow_rays,
                               patches_s=time.perf_counter() - t)


def sample_spectra(scene: Scene, meshed: Meshed, settings: SolverSettings) -> Sampling:
    """The sample wavelengths of the solve (``spectral_samples``; 0 photometric) and the
    reflectances of the operator's patches."""
    rho = _luminous_rho(scene, meshed.patches)
    t = time.perf_counter()
    spectral = SpectralSetup.build(scene, meshed.patches.material, settings.spectral_samples)
    return Sampling(spectral, rho, time.perf_counter() - t)


def cast_gather_rays(points: np.ndarray, normals: np.ndarray, meshed: Meshed, scene: Scene,
                     settings: SolverSettings, report: Report) -> GatherRays:
    """The gather of inter-reflected light onto the calculation points: in closed form for a
    small grid of a small study (``SolverSettings.gathers_exactly``), else ``gather_rays``
    rays each, above :data:`POINT_CHUNK` points in chunks (a seed per chunk: the same
    statistics, not the same rays) that report ``(points done, points)``."""
    t = time.perf_counter()
    patches = meshed.patches
    n, m = len(points), patches.n
    # the view test only for a grid small enough to be gathered so at all
    if settings.gathers_exactly(n, m) and settings.gathers_exactly(
            n, m, view=not scene.raycaster.sees_everything_from(points)):
        gather = build_exact_gather(points, normals, patches, scene.raycaster,
                                    slopes=patch_slopes(patches))
        return GatherRays(gather, time.perf_counter() - t, 0)
    rays = settings.gather_rays_for(len(points))
    gather = _gather_in_chunks(points, normals, patches, scene.raycaster, rays, report)
    return GatherRays(gather, time.perf_counter() - t, rays)


def solve(scene: Scene, points: np.ndarray, normals: np.ndarray, emission: Emission,
          direct: DirectLight, meshed: Meshed, transport: Transport, sampling: Sampling,
          rays: GatherRays, settings: SolverSettings, report: Report | None = None,
          gather_report: Report | None = None) -> Radiosity:
    """One batched solve ``(I − ρ(λ)F) B = ρ(λ) E s(λ)`` of every group and sample wavelength,
    gathered onto the points (:func:`~lumijax.lighting._solution.shoot`); ``report`` is told
    the columns solved (groups × wavelengths) after each batch, ``gather_report`` the patches
    of a sampled transport's final gather (``transport.final``)."""
    k, n = len(scene.networks), meshed.patches.n
    point_direct = emission.per_network(direct.points)
    unlit = LightingSolution(
        scene=scene, points=points, normals=normals,
        coarse=Level(patches=meshed.patches, gather=rays.gather, rho=sampling.rho,
                     patch_direct=np.zeros((k, n)), radiosity=np.zeros((k, n))),
        transport=transport.operator, spectral=sampling.spectral, point_direct=point_direct,
        point_indirect=np.zeros_like(point_direct), point_xyz=None,
        solve_method=settings.method, solve_tolerance=settings.tolerance,
        solve_max_steps=settings.max_iterations, final_gather=transport.final,
    )
    t = time.perf_counter()
    shot = shoot(unlit, direct.patches, list(emission.spectra), direct.points, progress=report,
                 gather_progress=gather_report)
    return Radiosity(shot, time.perf_counter() - t)


def gather_fine(scene: Scene, emission: Emission, direct: DirectLight, meshed: Meshed,
                sampling: Sampling, radiosity: Radiosity, settings: SolverSettings) -> Gathered:
    """Two levels: the elements' radiosity gathered onto the fine patches and reflected there
    (``radiosity._final_gather``); one level: nothing to do."""
    if meshed.fine is None:
        return Gathered(None)
    t = time.perf_counter()
    fine = final_gather(meshed.fine, meshed.patches, scene.raycaster, sampling.spectral,
                        list(emission.spectra), _needed(radiosity.shot.value),
                        _needed(direct.fine), rays=settings.gather_rays_for(meshed.fine.n))
    return Gathered(fine, time.perf_counter() - t)


def assemble(scene: Scene, points: np.ndarray, normals: np.ndarray, emission: Emission,
             direct: DirectLight, meshed: Meshed, transport: Transport, sampling: Sampling,
             rays: GatherRays, radiosity: Radiosity, gathered: Gathered,
             settings: SolverSettings, noise: SampledNoise | None = None) -> LightingSolution:
    """The :class:`LightingSolution` of the records: groups summed into networks, the stats
    and the stages' times (``stats["timing_s"]``, docs/results.md), and the warnings a
    solve can give (rows creating light, an open scene)."""
    per = emission.per_network
    shot, fine = radiosity.shot, gathered.fine
    solve_stats = radiosity.stats()
    _warn(shot, solve_stats, rays.gather, len(points))
    stats: dict = {"shadow_rays": direct.shadow_rays, "patches": meshed.patches.n,
                   "patch_size_m": meshed.patch_size_m,
                   "gather_rays": rays.rays}
    if meshed.fine is not None:
        stats.update(fine_patches=meshed.fine.n, element_size_m=meshed.element_size_m)
    stats["operator_bytes_bound"] = transport.bytes_bound
    if transport.cache_hit is not None:
        stats["operator_cache_hit"] = transport.cache_hit
    if transport.final is not None:
        stats["final_gather_rays"] = transport.final.rays_per_patch
    stats.update(operator_bytes=int(transport.operator.nbytes),
                 spectral_samples=sampling.spectral.n, **solve_stats)
    if noise is not None:
        stats["sampled_noise"] = dict(rms=noise.rms, mean=noise.mean, patches=noise.patches,
                                      rays_per_patch=noise.rays_per_patch,
                                      points_rms=noise.points_rms)
    timing = {"emission": emission.seconds, "direct_points": direct.points_s,
              "mesh": meshed.seconds, "memory_bound": transport.bound_s}
    if transport.partition_s is not None:
        timing["partition"] = transport.partition_s
    timing.update(operator=transport.seconds, direct_patches=direct.patches_s,
                  spectral_sampling=sampling.seconds, gather_rays=rays.seconds,
                  solve_and_gather=radiosity.seconds, **shot.timing_s)
    if noise is not None:
        timing["sampled_noise"] = noise.seconds
    fine_level = None
    if fine is not None:
        timing["final_gather"] = gathered.seconds
        timing.update(fine.timing_s)
        fine_level = Level(patches=meshed.fine, gather=fine.gather, rho=fine.rho,
                           patch_direct=per(fine.direct), patch_indirect=per(fine.indirect),
                           radiosity=per(fine.radiosity), radiosity_xyz=per(fine.radiosity_xyz))
    coarse = Level(patches=meshed.patches, gather=rays.gather, rho=sampling.rho,
                   patch_direct=per(_needed(direct.patches)), radiosity=per(shot.radiosity),
                   radiosity_xyz=per(shot.radiosity_xyz), patch_indirect=per(shot.patch_indirect))
    point_direct = per(direct.points)
    return LightingSolution(
        scene=scene, points=points, normals=normals, coarse=coarse, fine=fine_level,
        transport=transport.operator, spectral=sampling.spectral, point_direct=point_direct,
        point_indirect=per(shot.point_indirect), point_xyz=per(shot.point_xyz),
        solve_method=settings.method, solve_tolerance=settings.tolerance,
        solve_max_steps=settings.max_iterations, stats={**stats, "timing_s": timing},
        final_gather=transport.final,
    )


def direct_only(scene: Scene, points: np.ndarray, normals: np.ndarray, emission: Emission,
                direct: DirectLight) -> LightingSolution:
    """The solution without inter-reflection (off, or no surfaces, or no networks)."""
    point_direct = emission.per_network(direct.points)
    return LightingSolution(
        scene=scene, points=points, normals=normals, coarse=Level.unlit(len(scene.networks)),
        transport=None, spectral=None, point_direct=point_direct,
        point_indirect=np.zeros_like(point_direct), point_xyz=None,
        stats={"shadow_rays": direct.shadow_rays,
               "timing_s": {"emission": emission.seconds, "direct_points": direct.points_s}},
    )


# --- helpers ----------------------------------------------------------------------------------

def _warn(shot: Shot, stats: dict, gather: GatherOperator, n_points: int) -> None:
    # stacklevel 4: the warning points at the caller of solve_lighting
    if stats["created_fraction"] > CREATED_WARN:
        warnings.warn(
            f"form-factor rows sum to up to {float(shot.result.stats['row_max']):.3f} (above 1: "
            f"{100 * stats['created_fraction']:.1f} % of the reflected flux would be created, "
            "not reflected); corrected by rescaling those patches' outgoing light "
            "(docs/radiosity.md, \"Row sums\"). Usually coincident surfaces (see any warning "
            "naming them) or patches too coarse where surfaces meet: lower [solver] "
            "patch_size or raise [solver] target_patches",
            LumijaxWarning, stacklevel=4,
        )
    if n_points and float(np.min(gather.coverage)) < 0.999 and stats["escaped_fraction"] > 0.01:
        warnings.warn(
            f"the scene is open: up to {100 * stats['escaped_fraction']:.0f} % of the reflected "
            "light leaves it (to the sky) — fine outdoors, a modelling gap indoors",
            LumijaxWarning, stacklevel=4,
        )


def _in_chunks(n: int, fn: Callable[[slice, Callable[[float], None]], object],
               report: Report) -> list:
    """``fn(span, tell)`` of each :data:`POINT_CHUNK` of ``range(n)``, in order, reporting
    points done.

    The chunks run on threads (Embree's queries and NumPy's loops release the GIL; each chunk's
    result is what it would be alone, so the parts are bit for bit the sequential ones), unless
    the stages run on a cluster: there the calls inside batch their own work, and a thread
    would not see the cluster (the executor is a context variable). ``tell(fraction)`` is how
    far a chunk has come; the report counts every chunk's points by its fraction, so chunks in
    flight together move the bar as they go, not in one jump when the first of them ends."""
    spans = [slice(s, min(s + POINT_CHUNK, n)) for s in range(0, n, POINT_CHUNK)]
    threads = 1 if current_executor().distributed else None
    share = np.zeros(len(spans))
    size = np.array([sp.stop - sp.start for sp in spans], np.float64)
    lock = threading.Lock()

    def tell(k: int, fraction: float) -> None:
        with lock:  # the threads report here; the sum only grows
            share[k] = max(share[k], min(float(fraction), 1.0))
            report(int(round(float(share @ size))), n)

    def run(k: int):
        part = fn(spans[k], lambda fraction: tell(k, fraction))
        tell(k, 1.0)
        return part

    report(0, n)
    return list(threaded_map(run, range(len(spans)), threads))


def _release_after_threads(receivers: int) -> None:
    """What the direct light's threads freed, back to the system before the next stage
    allocates (:func:`~lumijax.parallel.release_freed_memory`): only where the receivers came
    in chunks on threads. A small study's direct light runs on the main thread, whose freed
    memory the next stage reuses, and pages handed back cost this VM 3-9 ms a MiB to fault in
    again (benchmarks/RESULTS.md, "Session 27")."""
    if receivers > POINT_CHUNK:
        release_freed_memory()


def _direct_in_chunks(scene: Scene, points, normals, report: Report) -> DirectLighting:
    n = len(points)
    if n <= POINT_CHUNK:
        return direct_illuminance(scene, points, normals, progress=report)
    if len(scene.triangles):
        scene.raycaster  # built once here, not by two threads at once  # noqa: B018
    parts = _in_chunks(n, lambda sl, tell: direct_illuminance(
        scene, points[sl], normals[sl], progress=lambda done, total: tell(done / total)), report)
    timing: dict[str, float] = {}
    for d in parts:
        for key, v in d.timing_s.items():
            timing[key] = timing.get(key, 0.0) + v
    return dataclasses.replace(
        parts[0], by_network=np.concatenate([d.by_network for d in parts], axis=1),
        shadow_rays=sum(d.shadow_rays for d in parts),
        candidate_pairs=sum(d.candidate_pairs for d in parts), timing_s=timing)


def _gather_in_chunks(points, normals, patches: Patches, caster, rays: int,
                      report: Report) -> GatherOperator:
    n = len(points)
    # each ray reads its patch's radiosity linear across it (radiosity/_slopes.py)
    slopes = patch_slopes(patches)
    if n <= POINT_CHUNK:
        return build_gather(points, normals, patches, caster, rays=rays, slopes=slopes)

    def chunk(sl, tell):  # a seed per chunk: the same statistics, whatever the chunk count
        g = build_gather(points[sl], normals[sl], patches, caster, rays=rays,
                         seed=sl.start // POINT_CHUNK, slopes=slopes)
        return dataclasses.replace(g, point=g.point + np.int32(sl.start))

    parts = _in_chunks(n, chunk, report)
    return dataclasses.replace(
        parts[0], n_points=n, point=np.concatenate([g.point for g in parts]),
        patch=np.concatenate([g.patch for g in parts]),
        weight=np.concatenate([g.weight for g in parts]))


def patch_size_of(scene: Scene, settings: SolverSettings) -> float:
    """The patch edge (m) a study's surfaces are cut at: ``patch_size`` when set, else about
    ``target_patches`` patches when set (both exactly as before the accuracy rule), else the
    edge that ``accuracy`` asks for from the scene's mean free path (docs/radiosity.md,
    "Patch count against an accuracy target")."""
    if settings.patch_size:
        return settings.patch_size
    area = float(scene.triangles.areas.sum())
    if settings.target_patches is not None:
        return auto_patch_size(area, settings.target_patches)
    return accuracy_patch_size(area, mean_free_path(scene.triangles.vertices, scene.raycaster),
                               settings.accuracy, source_distance(scene))


def requested_patches(total_area_m2: float, size: float, settings: SolverSettings) -> int | None:
    """The ``target_patches`` a memory refusal scales (``_estimate.check_operator_memory``):
    the study's own, the count the accuracy rule's edge amounts to, or None with an explicit
    ``patch_size``."""
    if settings.patch_size:
        return None
    if settings.target_patches is not None:
        return settings.target_patches
    return max(10, round(4.0 * total_area_m2 / size**2))


def _check_before_meshing(scene: Scene, tri, size: float, settings: SolverSettings) -> None:
    """The mesh and a hopeless operator refused before meshing (``_estimate``)."""
    esize = None
    if settings.operator_patches is not None:
        esize = auto_patch_size(float(tri.areas.sum()), settings.operator_patches)
        esize = esize if esize > size else None
    check_before_meshing(tri.vertices, tri.group, size, element_size=esize,
                         itemsize=8 if settings.precision == "float64" else 4,
                         max_block=settings.max_block or DEFAULT_MAX_BLOCK, file=scene.source,
                         dense=settings.transport != "sampled")


def _group_counts(tri, target_patches: int) -> np.ndarray:
    """Patches per group of the mesh made for ``target_patches`` (the memory check's way to
    try a setting without building anything on it)."""
    size = auto_patch_size(float(tri.areas.sum()), target_patches)
    return np.unique(mesh_patches(tri.vertices, tri.material, tri.group, patch_size=size).group,
                     return_counts=True)[1]


def _two_levels(patches: Patches, tri, size: float,
                operator_patches: int | None) -> tuple[Patches, Patches | None]:
    """``(elements, fine)``: the operator's elements and the fine patches that gather from them
    (``fine`` None: one level, when not asked for or when the elements would not be coarser)."""
    if operator_patches is None:
        return patches, None
    esize = auto_patch_size(float(tri.areas.sum()), operator_patches)
    if esize <= size:
        return patches, None
    elements = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=esize)
    if elements.n >= patches.n:
        return patches, None
    return elements, patches
