"""A patch's direct irradiance as its mean over the patch where a luminaire is near.

The radiosity a patch reflects is ρ times its *mean* irradiance. The centroid's value is that
mean to second order in size / distance, but under a lamp hung close to a surface the field
falls like 1/d² across the patch and the centroid misjudges the flux: the office of
``benchmarks/small.py`` (lamps 0.2 m under the ceiling, 4,960 patches) read its point
illuminance −0.27 % low on average from that alone (docs/radiosity.md, "Direct light on a
patch near a luminaire"). So for each luminaire, a patch near it takes that luminaire's light as the mean over
n × n congruent pieces (midpoint grid, equal areas, so equal weights), n the least for which a
piece's longest edge is at most :func:`piece_per_distance` times the patch's clearance from
*that* luminaire, at most :data:`MOST_PER_EDGE`. Every other (luminaire, patch) pair keeps the
centroid's value.

The centroid rule errs by about ``(edge / clearance)² / 4`` of the patch's light under a point
source at normal incidence (the 1/r² field's curvature: ``E ≈ E₀(1 − 1.5 ρ²/D²)`` averaged over
a square of side h is ``E₀(1 − h²/4D²)``), and it errs the same way on every patch facing the
source squarely — high where the field peaks, low where it flattens out towards a wall's edges;
over a surface the total flux comes out too high, and under lamps hung near a ceiling too low
(the centroids just outside the pieces' reach). A study of up to :data:`SMALL_STUDY_PATCHES`
patches pays little for the pieces and takes :data:`SMALL_PIECE_PER_DISTANCE`; a larger one,
where every halving of the ratio quadruples the pairs, :data:`PIECE_PER_DISTANCE`.

The pieces of a pair depend on that luminaire's position and the patch only, never on the
other luminaires: a luminaire's light on the patches is the same in any scene that holds it
(to rounding), so a study of some of the luminaires gives their share of the whole, and
replacing a luminaire takes out what it put in (:meth:`~lumijax.lighting.LightingSolution.replace_luminaire`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from jaxtyping import Float, Int

from ..parallel import threaded_map
from ._patches import Patches, subdivide_triangles

__all__ = ["PIECE_PER_DISTANCE", "SMALL_PIECE_PER_DISTANCE", "SMALL_STUDY_PATCHES", "MOST_PER_EDGE",
           "piece_per_distance", "NearSamples", "near_samples", "near_light"]

#: A piece's longest edge over its patch's clearance from the luminaire (m / m). The centroid
#: rule's flux error on the office's ceiling was +0.03 % at 1.35, −0.7 % at 1.9 and +8.3 % at
#: 4.2 (docs/radiosity.md): 0.5 leaves it far below the solve's other errors, for a large
#: study (one patch's light off by at most ≈ 6 %, and by far less on the whole).
PIECE_PER_DISTANCE = 0.5
#: The ratio for a study of at most :data:`SMALL_STUDY_PATCHES` patches: one patch's
#: light off by at most ≈ 1 %. The closed 4 m cube of ``benchmarks/small.py`` (1,728 patches of
#: 0.33 m, 1.7 m from its lamp: ratio 0.28) read its floor +0.05 % (ρ 0.5) to +0.09 % (ρ 0.8) too
#: bright on average from the centroid rule alone (docs/radiosity.md).
SMALL_PIECE_PER_DISTANCE = 0.2
#: The most patches a study may have to take :data:`SMALL_PIECE_PER_DISTANCE`. The office of
#: ``benchmarks/small.py`` (4,960 patches, lamps 0.2 m under its ceiling) took 0.5 when the
#: limit was the dense solve's 4,096: in that closed room its patches held 0.091 % too little
#: of the lamps' flux, and its points read 0.086 % RMS (mean −0.086 %) from the converged
#: reference; at 0.2, −0.005 % and 0.016 %, its patches' direct light 0.28 s in-process
#: (docs/radiosity.md). Not higher: the courtyard of 8 bays a facade (7,264 patches, 620
#: luminaires under its cornices) would make 9.6 M samples at 0.2 against 2.9 M at 0.5, and its
#: aim model holds them all; what the pieces cost follows the luminaires near surfaces, not
#: the patches alone (a budget of samples per study is the better rule, not built).
SMALL_STUDY_PATCHES = 6_144
#: At most this many pieces along an edge (n² samples a pair): a luminaire touching a surface
#: would otherwise ask for unbounded n.
MOST_PER_EDGE = 4

_PARTS = 4  # parts of the samples lit on threads, at least
_PART_SAMPLES = 1 << 21  # samples of a part, at most
#: Patches × luminaires above which the patches near a luminaire are found by a k-d tree.
_BRUTE_FORCE_PAIRS = 4_000_000


@dataclasses.dataclass(frozen=True)
class NearSamples:
    """The (luminaire, patch) pairs whose light is a mean over pieces, and their samples.

    Attributes
    ----------
    luminaire, patch, per_edge
        ``(pairs,)`` each pair's luminaire and patch, and n (its n² pieces), n ≥ 2.
    owner
        ``(samples,)`` the pair of each sample: a pair's n² pieces' centroids, then its
        patch's centroid.
    weight
        ``(samples,)`` 1/n² for a piece, −1 for the centroid: ``Σ weight · E`` over a pair's
        samples is what the pieces' mean adds to the centroid's value.
    points, normals
        ``(samples, 3)`` m and unit normals.
    """

    luminaire: Int[np.ndarray, " pairs"]
    patch: Int[np.ndarray, " pairs"]
    per_edge: Int[np.ndarray, " pairs"]
    owner: Int[np.ndarray, " samples"]
    weight: Float[np.ndarray, " samples"]
    points: Float[np.ndarray, "samples 3"]
    normals: Float[np.ndarray, "samples 3"]


def near_samples(patches: Patches,
                 sources: Float[np.ndarray, "sources 3"]) -> NearSamples:
    """The pairs of luminaires at ``sources`` (m) and ``patches`` whose light needs more than
    the centroid (module docstring), with their samples."""
    sources = np.asarray(sources, np.float64).reshape(-1, 3)
    return _samples(patches, *_near_pairs(patches, sources))


def _samples(patches: Patches, lum, pat, n) -> NearSamples:
    """The samples of the pairs ``(lum, pat, n)`` (:class:`NearSamples`)."""
    count = n * n + 1
    owner = np.repeat(np.arange(len(lum)), count)
    first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    points = np.empty((int(count.sum()), 3), np.float64)
    weight = np.empty(len(points), np.float64)
    vertices = np.asarray(patches.vertices, np.float64)
    for k in np.unique(n):
        which = np.flatnonzero(n == k)
        pieces = subdivide_triangles(vertices[pat[which]], int(k)).mean(axis=2)
        at = (first[which, None] + np.arange(k * k)).ravel()
        points[at] = pieces.reshape(-1, 3)
        weight[at] = 1.0 / (k * k)
    centre = first + n * n
    points[centre] = np.asarray(patches.centroid, np.float64)[pat]
    weight[centre] = -1.0
    normals = np.asarray(patches.normal, np.float64)[pat[owner]]
    return NearSamples(lum, pat, n, owner, weight, points, normals)


def piece_per_distance(n_patches: int) -> float:
    """A piece's longest edge over its clearance from the luminaire (m / m) on a mesh of
    ``n_patches``: :data:`SMALL_PIECE_PER_DISTANCE` up to :data:`SMALL_STUDY_PATCHES`
    patches, :data:`PIECE_PER_DISTANCE` above. Every caller of one study passes the same
    patches, so its direct light, its replaced luminaires and its aim model agree."""
    return SMALL_PIECE_PER_DISTANCE if n_patches <= SMALL_STUDY_PATCHES else PIECE_PER_DISTANCE


def _near_pairs(patches: Patches, sources):
    """``(luminaire, patch, n)`` of the pairs with n ≥ 2."""
    empty = np.zeros(0, np.int64)
    if not len(sources) or not patches.n:
        return empty, empty, empty
    ratio = piece_per_distance(patches.n)
    vertices = np.asarray(patches.vertices, np.float64)
    centroid = np.asarray(patches.centroid, np.float64)
    size = np.linalg.norm(vertices - np.roll(vertices, 1, axis=1), axis=2).max(axis=1)
    reach = np.linalg.norm(vertices - centroid[:, None], axis=2).max(axis=1)
    # n ≥ 2 needs size > ratio · (distance − reach)
    radius = float((size / ratio + reach).max())
    lum, pat = _within(sources, centroid, radius)
    if not len(lum):
        return empty, empty, empty
    clearance = np.linalg.norm(centroid[pat] - sources[lum], axis=1) - reach[pat]
    with np.errstate(divide="ignore", invalid="ignore"):
        want = np.where(clearance > 0, np.ceil(size[pat] / (ratio * clearance)),
                        MOST_PER_EDGE)
    n = np.clip(np.nan_to_num(want, nan=MOST_PER_EDGE), 1, MOST_PER_EDGE).astype(np.int64)
    keep = n >= 2
    order = np.lexsort((pat[keep], lum[keep]))
    return lum[keep][order], pat[keep][order], n[keep][order]


def _within(sources, points, radius: float):
    """``(source, point)`` index pairs closer than ``radius`` (m): by comparing every pair (in
    chunks) in a small scene, where importing scipy.spatial (0.4 s) would cost more than the
    search; by a k-d tree of the points in a large one."""
    if len(sources) * len(points) > _BRUTE_FORCE_PAIRS:
        from scipy.spatial import cKDTree

        near = cKDTree(points).query_ball_point(sources, radius)
        return (np.repeat(np.arange(len(sources)), [len(p) for p in near]),
                np.concatenate([np.asarray(p, np.int64) for p in near]))
    lum, pat = [], []
    step = max(1, _BRUTE_FORCE_PAIRS // (16 * len(sources)))
    for a in range(0, len(points), step):
        d = points[a:a + step, None] - sources[None]
        p, s = np.nonzero(np.einsum("psk,psk->ps", d, d) < radius * radius)
        lum.append(s)
        pat.append(p + a)
    lum_, pat_ = np.concatenate(lum), np.concatenate(pat)
    order = np.lexsort((pat_, lum_))
    return lum_[order], pat_[order]


def near_light(scene, patches: Patches, *, progress=None
               ) -> tuple[Float[np.ndarray, "net patches"], int]:
    """What the near pairs' means add to ``scene``'s centroid light on ``patches`` (lx per
    network at dimmer 1), and the shadow rays it cast: every sample lit by its own pair's
    luminaire alone (:class:`NearSamples`; :func:`lumijax.direct._pairs.pair_chunks` with an
    owner per receiver), in parts of whole pairs. ``progress(done, total)`` counts samples."""
    from ..direct._pairs import PairStats, pair_chunks

    net_index = {n.name: k for k, n in enumerate(scene.networks)}
    network = np.array([net_index[lum.network] for lum in scene.luminaires], np.int64)
    out = np.zeros((len(scene.networks), patches.n))
    positions = np.array([lum.position for lum in scene.luminaires],
                         np.float64).reshape(-1, 3)
    lum, pat, n = _near_pairs(patches, positions)
    if not len(lum):
        return out, 0
    caster = scene.raycaster if len(scene.triangles) else None
    # parts of whole pairs, each made and lit on its own, on threads (Embree and NumPy's loops
    # release the GIL): the memory is a few parts' at any scale (the LoD-0 courtyard has
    # 1.4·10⁶ pairs, 1.2·10⁷ samples)
    ends = np.cumsum(n * n + 1)
    size = min(_PART_SAMPLES, -(-int(ends[-1]) // _PARTS))
    cuts = np.unique(np.searchsorted(ends, np.arange(size, int(ends[-1]), size), "right"))
    spans = [slice(a, b) for a, b in zip([0, *cuts], [*cuts, len(lum)], strict=True) if b > a]

    def lit(span):
        near = _samples(patches, lum[span], pat[span], n[span])
        # only the part's own luminaires: their sources, not the scene's thousands, are made
        # and sorted for each part
        selection, owner = np.unique(near.luminaire[near.owner], return_inverse=True)
        patch = near.patch[near.owner]
        part = np.zeros_like(out)
        stats = PairStats(timing_s={})
        for c in pair_chunks(scene, near.points, near.normals, selection=selection.tolist(),
                             caster=caster, stats=stats, owner=owner, geometry=False):
            flat = network[selection[c.luminaire]] * patches.n + patch[c.receiver]
            part.reshape(-1)[:] += np.bincount(flat, weights=c.light * near.weight[c.receiver],
                                               minlength=out.size)
        return part, stats.shadow_rays

    rays, done = 0, 0
    if progress is not None:
        progress(0, int(ends[-1]))
    for span, (part, r) in zip(spans, threaded_map(lit, spans), strict=True):
        out += part
        rays += r
        done = int(ends[span.stop - 1])
        if progress is not None:
            progress(done, int(ends[-1]))
    return out, rays
