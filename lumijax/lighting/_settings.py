"""The ``[solver]`` settings of a study's lighting, and the automatic patch size."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SolverSettings", "auto_patch_size", "mean_free_path", "source_distance",
           "accuracy_patch_size", "AUTO_PATCH_CAP", "PATCH_SIZE_PER_PATH",
           "PATCH_SIZE_PER_SOURCE_DISTANCE", "GATHER_RAYS", "MOST_GATHER_RAYS",
           "GATHER_RAY_BUDGET", "gather_rays_for", "AUTO_FIRST_RAYS"]

#: Most patches the accuracy rule asks for (the fixed default before it; docs/radiosity.md,
#: "Patch count against an accuracy target"): an explicit ``target_patches`` goes beyond.
AUTO_PATCH_CAP = 4_000

#: The rule's constants: at ``accuracy`` = 1 % the patch edge is at most this fraction of the
#: mean free path (calibrated on the closed cube: 1,728 patches) ...
PATCH_SIZE_PER_PATH = 0.19
#: ... and at most this multiple of the nearest lit surface's distance from a luminaire: the
#: direct light on a patch is its centroid's, which misjudges a patch's flux when the patch is
#: wide against the distance to the source (the office's ceiling, lamps 0.2 m below it: its
#: direct flux +8.3 % at h/d = 4.2, −0.7 % at 1.9, +0.03 % at 1.35; docs/radiosity.md).
PATCH_SIZE_PER_SOURCE_DISTANCE = 1.5

_SOURCE_RAYS = 128  # directions from each luminaire (a Fibonacci sphere)
_LIT = 0.05  # a direction counts when its intensity is at least this fraction of the peak

_MFP_RAYS = 4096  # rays of the mean-free-path estimate: its own spread ~1 % (σ/√n of chords)

#: ``rays_per_patch = "auto"``: the rays a patch of the operator, whose measured noise sets the
#: final gather's (the default count: a broadly lit court reads ≈ 7 % there).
AUTO_FIRST_RAYS = 256


@dataclass(frozen=True)
class SolverSettings:
    """How inter-reflection is computed (the config's ``[solver]`` table, docs/config.md).

    ``patch_size`` None means automatic: about ``target_patches`` patches over the scene, or,
    with ``target_patches`` None (the default), the patch edge that ``accuracy`` asks for
    (:func:`accuracy_patch_size`), at most :data:`AUTO_PATCH_CAP` patches.
    """

    indirect: bool = True
    patch_size: float | None = None
    target_patches: int | None = None
    accuracy: float = 0.01  # relative error aimed at when the patch count is automatic
    max_block: int | None = None  # None: by the patch count (:func:`block_size`)
    method: str = "refined"  # a name in lumijax.radiosity.RADIOSITY_SOLVERS
    tolerance: float | None = None
    max_iterations: int = 1000
    gather_rays: int | None = None  # None: :func:`gather_rays_for` the receivers' count
    precision: str = "float32"
    spectral_samples: int = 16
    refine: int = 0  # most levels of adaptive refinement (docs/radiosity.md, "Refinement")
    refine_threshold: float = 0.5
    operator_patches: int | None = None  # two levels: elements for the operator (docs/radiosity.md)
    transport: str = "blocks"  # "sampled": ray-sampled form factors (radiosity/_sampled.py)
    # rays cast from each patch by the sampled transport; "auto": 256, and a final gather of as
    # many as ≈ 3 % noise per patch needs (docs/radiosity.md, "Final gather of the sampled
    # transport")
    rays_per_patch: int | str = 256
    aimed_share: float = 0.25  # of those, aimed at the lit patches (radiosity/_bright.py)
    # rays a patch of the sampled transport's final gather (radiosity/_sampled_gather.py);
    # None: none, or with "auto" rays what ≈ 3 % per patch needs
    final_gather_rays: int | None = None

    @property
    def first_rays(self) -> int:
        """The rays a patch of the sampled transport's first build: ``rays_per_patch``, or
        :data:`AUTO_FIRST_RAYS` where it is ``"auto"`` (whose noise decides the rest)."""
        n = self.rays_per_patch
        if n == "auto":
            return AUTO_FIRST_RAYS
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 16 <= n <= 65536:
            from ..errors import SolveError

            raise SolveError(f"rays_per_patch must be an integer from 16 to 65,536 or \"auto\", "
                             f"not {n!r}", key="solver.rays_per_patch")
        return int(n)

    def gather_rays_for(self, receivers: int) -> int:
        """Rays per receiver of a gather onto ``receivers`` points (:func:`gather_rays_for`)."""
        return gather_rays_for(self.gather_rays, receivers)

    def gathers_exactly(self, points: int, patches: int, view: bool = False) -> bool:
        """Whether the grids' gather is taken in closed form (``radiosity._exact_gather``):
        ``gather_rays`` unset and points × patches within
        :data:`~lumijax.radiosity.EXACT_GATHER_PAIRS`, a quarter of it where the view
        between points and patches must be tested (``view``: 7 rays a far pair, where the
        ray gather casts about one)."""
        from ..radiosity import EXACT_GATHER_PAIRS

        limit = EXACT_GATHER_PAIRS // 4 if view else EXACT_GATHER_PAIRS
        return self.gather_rays is None and points * patches <= limit


#: Rays per receiver of the gather of inter-reflected light when ``[solver] gather_rays`` is
#: not set: at least :data:`GATHER_RAYS`, and up to :data:`MOST_GATHER_RAYS` while the
#: receivers' rays stay within :data:`GATHER_RAY_BUDGET` in all. The gather's noise falls like
#: 1/rays (a stratified set): on the office of benchmarks/small.py (100 points) 512 rays gave
#: 0.88 % RMS against the reference, 4,096 gave 0.35 % (docs/radiosity.md, "Gather rays");
#: a small grid gets the better figure for well under a second of rays, a 10⁴-point one stays
#: at 512.
GATHER_RAYS = 512
MOST_GATHER_RAYS = 4096
GATHER_RAY_BUDGET = 1 << 20


def gather_rays_for(setting: int | None, receivers: int) -> int:
    """``setting`` where given; else the power of two from :data:`GATHER_RAYS` to
    :data:`MOST_GATHER_RAYS` that keeps ``receivers`` × rays within
    :data:`GATHER_RAY_BUDGET`."""
    if setting is not None:
        return int(setting)
    rays = GATHER_RAYS
    while rays < MOST_GATHER_RAYS and 2 * rays * max(receivers, 1) <= GATHER_RAY_BUDGET:
        rays *= 2
    return rays


#: ``[solver] max_block`` when not given: :data:`SMALL_MAX_BLOCK` up to
#: ``radiosity._operator.DENSE_PATCHES`` patches, else :data:`DEFAULT_MAX_BLOCK`.
DEFAULT_MAX_BLOCK = 1024
SMALL_MAX_BLOCK = 384


def block_size(max_block: int | None, n_patches: int) -> int:
    """The partition's largest block for ``n_patches``: ``max_block`` where the study gives
    one. Else 384 patches for a study whose solve applies one dense block
    (``radiosity._operator.DENSE_PATCHES``, 4,096: there the blocks matter to the build
    only), 1,024 above. Smaller blocks let the partition cull more pairs of blocks that cannot
    see each other (a wall's patches among themselves) and keep the build's arrays in cache:
    measured alone, operator builds at 1,024 → 384 (session 20): the cube ρ 0.5 (1,728
    patches) 0.75 → 0.45 s, the furnished room (2,060) 1.23–1.46 → 0.91–0.95 s, the demo
    (3,490, blocks cut by its groups) 5.0–5.3 → 4.8 s. Lux the same to 5·10⁻⁷ in the cube,
    the furnished room and the office; the demo's grid means within 8·10⁻⁵ and single points
    within 0.3 % (5·10⁻⁴ of a grid's largest value): a far pair's one visibility ray starts
    from its lower block's patch, so other blocks cast some from the other end, and a ray
    grazing a column's edge may differ by direction (Embree is float32; not traced further).
    Above, the block structure is the solve's too and 1,024 stays (the 4,960-patch office
    built in 1.6 s against 2.2 s, but its operator grew from 63 to 96 MB)."""
    from ..radiosity._operator import DENSE_PATCHES  # here: this module imports no JAX

    if max_block is not None:
        return int(max_block)
    return SMALL_MAX_BLOCK if n_patches <= DENSE_PATCHES else DEFAULT_MAX_BLOCK


def auto_patch_size(total_area_m2: float, target_patches: int) -> float:
    """Patch edge (m) giving about ``target_patches`` patches. A triangle of longest edge L is
    cut into ⌈L/s⌉² pieces; for the right triangles of rectangles and boxes (L² = 4 × area
    of the square they halve) that is 4·area/s² patches per unit area, hence s = √(4A/N).
    No floor in metres: a 4 mm model wants 0.1 mm patches as a 4 m room wants 0.1 m ones (a
    1 mm floor once gave a 4 µm model a single patch per face)."""
    return float(max(np.sqrt(4.0 * total_area_m2 / max(target_patches, 1)),
                     np.finfo(np.float64).tiny))


def mean_free_path(vertices: np.ndarray, caster, rays: int = _MFP_RAYS,
                   seed: int = 0) -> float | None:
    """Mean length (m) of the chords that light reflected by the scene's surfaces travels to
    the next surface: rays from area-uniform points of the triangles (``(T, 3, 3)``, m), cosine
    distributed about their normals (the one-sided surfaces reflect to that side), through
    ``caster``; rays that leave the scene are not chords. For a closed convex room this is
    Cauchy's 4V/S (2a/3 in a cube of side a). None when no ray hits anything (a lone
    surface: no inter-reflection to resolve). Deterministic (a fixed seed)."""
    v = np.asarray(vertices, np.float64)
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    cross = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    total = float(area.sum())
    if len(v) == 0 or not total > 0:
        return None
    rng = np.random.default_rng(seed)
    tri = rng.choice(len(v), size=rays, p=area / total)
    a, b = rng.random(rays), rng.random(rays)
    fold = a + b > 1.0
    a, b = np.where(fold, 1.0 - a, a), np.where(fold, 1.0 - b, b)
    origin = v[tri, 0] + a[:, None] * e1[tri] + b[:, None] * e2[tri]
    n = cross[tri] / (2.0 * area[tri])[:, None]
    # a cosine-distributed direction about n: a uniform disc point lifted onto the hemisphere
    t = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(n, t)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = np.cross(n, u)
    r, phi = np.sqrt(rng.random(rays)), 2.0 * np.pi * rng.random(rays)
    d = (r * np.cos(phi))[:, None] * u + (r * np.sin(phi))[:, None] * w \
        + np.sqrt(np.clip(1.0 - r * r, 0.0, None))[:, None] * n
    _, dist = caster.first_hit(origin, d)
    hit = np.isfinite(dist)
    return float(dist[hit].mean()) if hit.any() else None


def source_distance(scene) -> float | None:
    """Distance (m) from the luminaires to the nearest plane of a surface they light: from
    each luminaire :data:`_SOURCE_RAYS` directions of a Fibonacci sphere, those where its
    intensity is at least :data:`_LIT` of its peak (a recessed downlight does not light the
    ceiling it sits in), each hit's distance times the cosine at the hit (the distance to the
    hit triangle's plane: what the direct light's variation over that surface scales with).
    The smallest over luminaires; None without luminaires or hits. Area sources are not
    counted (their light is already spread over their size)."""
    import jax.numpy as jnp

    from ..radiosity._gather import _sphere_directions

    lums = scene.luminaires
    if not lums or not len(scene.triangles):
        return None
    w = _sphere_directions(_SOURCE_RAYS)
    cd = np.zeros((len(lums), len(w)))
    by_photometry: dict[str, list[int]] = {}
    for i, lum in enumerate(lums):
        by_photometry.setdefault(lum.photometry, []).append(i)
    for name, idx in by_photometry.items():
        local = np.concatenate([w @ lums[i].rotation for i in idx])
        rows = 1 << max(len(local) - 1, 255).bit_length()  # padded: one shape per size class
        padded = np.zeros((rows, 3))
        padded[:len(local)] = local
        dist = scene.photometries[name].distribution
        table = np.asarray(dist.candela)
        if table.size and np.ptp(table) == 0:  # isotropic: lit everywhere (no kernel to run)
            cd[idx] = float(table.flat[0])
            continue
        cd[idx] = np.asarray(dist.intensity(jnp.asarray(padded)))[:len(local)].reshape(len(idx), -1)
    pos = np.array([lum.position for lum in lums], np.float64)
    tri, t = scene.raycaster.first_hit(np.repeat(pos, len(w), axis=0), np.tile(w, (len(lums), 1)))
    n = scene.triangles.normals[np.maximum(tri, 0)]
    plane = (t * np.abs(np.einsum("rc,rc->r", n, np.tile(w, (len(lums), 1))))).reshape(cd.shape)
    lit = (cd >= _LIT * cd.max(axis=1, keepdims=True)) & (cd > 0) \
        & (tri >= 0).reshape(cd.shape)
    return float(plane[lit].min()) if lit.any() else None


def accuracy_patch_size(total_area_m2: float, free_path_m: float | None,
                        accuracy: float, source_distance_m: float | None = None) -> float:
    """The patch edge (m) the accuracy rule gives (docs/radiosity.md, "Patch count against an
    accuracy target"): ``√(accuracy / 1 %)`` times the smaller of
    :data:`PATCH_SIZE_PER_PATH` × the mean free path and
    :data:`PATCH_SIZE_PER_SOURCE_DISTANCE` × the luminaires' distance to the nearest lit
    surface (piecewise-constant radiosity's error grows like h², h measured against the
    distances over which the light varies), never finer than :data:`AUTO_PATCH_CAP` patches
    over ``total_area_m2`` (m²). Without a free path (nothing inter-reflects) the cap's size."""
    cap = auto_patch_size(total_area_m2, AUTO_PATCH_CAP)
    if free_path_m is None or not np.isfinite(free_path_m) or free_path_m <= 0:
        return cap
    h = PATCH_SIZE_PER_PATH * free_path_m
    if source_distance_m is not None and np.isfinite(source_distance_m):
        h = min(h, PATCH_SIZE_PER_SOURCE_DISTANCE * source_distance_m)
    return float(max(np.sqrt(accuracy / 0.01) * h, cap))
