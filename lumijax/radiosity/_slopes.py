"""Each patch's radiosity slope across its plane, as a fixed linear map of the radiosities.

The solve gives one radiosity per patch, its mean. A calculation point close to a wall sees the
wall's patches nearly edge on and close up: which part of a patch it sees matters, and a
constant B over the patch is then wrong to first order in its size (the gather's error in the
cube of ``benchmarks/small.py`` sits at the points 0.2 m from its walls). The gather therefore
reads ``B(y) = B_i + g_i · (y − c_i)`` at a ray's hit ``y`` on patch ``i``: linear across the
patch, with the patch's own mean kept (``g_i · (y − c_i)`` averages to 0 over the patch, so the
flux each patch sends is unchanged, and a point that sees the whole patch evenly reads its
mean as before).

``g_i`` is the least-squares gradient of the neighbours' means — the patches of the same
material in the same plane whose centroids lie within :data:`REACH` of ``i``'s longest edge
(its edge neighbours on a regular mesh) — over ``g`` in the plane:
``g_i = argmin Σ_j (B_j − B_i − g · (c_j − c_i))²``. That is linear in B, ``g_i = Σ_j w_ij
(B_j − B_i)`` with weights of the geometry alone, so the gather stays one fixed sparse map,
every network superposes exactly, and gradients flow as before. A patch with fewer than two neighbours spanning the plane keeps a constant B. No
limiter: a limiter would make the map depend on B (docs/radiosity.md, "The gather's linear
radiosity").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Float, Int

from ._patches import Patches

__all__ = ["REACH", "PatchSlopes", "patch_slopes"]

#: The neighbours' reach, over the patch's longest edge (m / m): the edge neighbours of a
#: regular mesh of right triangles (centroids 0.33 and 0.53 of it apart), not the vertex
#: neighbours. The whole ring (1.0) fitted the cube of benchmarks/small.py no better
#: (0.0286 % against 0.0306 % RMS at ρ 0.5) for three times the gather's links to expand.
REACH = 0.6

#: Patches × patches above which the neighbours are found by a k-d tree (below, by comparing
#: every pair in chunks: importing scipy.spatial costs a small study more than the search).
_BRUTE_FORCE_PAIRS = 16_000_000
#: Least eigenvalue of a patch's normal equations over its largest, below which the
#: neighbours do not span the plane (collinear) and the patch keeps a constant B.
_SPAN = 1e-3


@dataclass(frozen=True)
class PatchSlopes:
    """``g = Σ coef · B[col]`` summed per ``row``: each patch's radiosity gradient (per m) in
    its plane, for radiosities B of any unit (rows sorted; ``start[i]:start[i + 1]`` are
    patch ``i``'s entries, its own among them).
    """

    n_patches: int
    start: Int[np.ndarray, " patches_plus_1"]
    col: Int[np.ndarray, " entries"]
    coef: Float[np.ndarray, "entries 3"]

    def __call__(self, b: Float[np.ndarray, " patches"]) -> Float[np.ndarray, "patches 3"]:
        """The gradients of radiosities ``b`` (patches,)."""
        row = np.repeat(np.arange(self.n_patches), np.diff(self.start))
        terms = self.coef * np.asarray(b, np.float64)[self.col, None]
        return np.stack([np.bincount(row, weights=terms[:, k], minlength=self.n_patches)
                         for k in range(3)], axis=1)


def patch_slopes(patches: Patches) -> PatchSlopes:
    """The least-squares slope map of ``patches`` (module docstring)."""
    n = patches.n
    centroid = np.asarray(patches.centroid, np.float64)
    normal = np.asarray(patches.normal, np.float64)
    reach = REACH * np.asarray(patches.diameter, np.float64)
    i, j = _neighbours(centroid, reach, normal, np.asarray(patches.material))
    # the plane's basis per patch: offsets as 2-D coordinates, normal equations 2 × 2
    t1 = np.cross(normal, np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(normal, t1)
    d = centroid[j] - centroid[i]
    u, v = np.einsum("pc,pc->p", d, t1[i]), np.einsum("pc,pc->p", d, t2[i])
    muu, muv, mvv = (np.bincount(i, weights=w, minlength=n) for w in (u * u, u * v, v * v))
    det = muu * mvv - muv * muv
    trace = muu + mvv
    # the least eigenvalue against the largest: ≈ det / trace² for a well-spread set
    spans = det > _SPAN * trace * trace
    det = np.where(spans, det, 1.0)
    # w_ij = M⁻¹ (u, v): the weight of B_j − B_i in g_i, back in 3-D
    a = np.where(spans[i], (mvv[i] * u - muv[i] * v) / det[i], 0.0)
    b = np.where(spans[i], (muu[i] * v - muv[i] * u) / det[i], 0.0)
    w = a[:, None] * t1[i] + b[:, None] * t2[i]
    own = np.stack([-np.bincount(i, weights=w[:, k], minlength=n) for k in range(3)], axis=1)
    rows = np.concatenate([i, np.arange(n)])
    col = np.concatenate([j, np.arange(n)])
    order = np.lexsort((col, rows))  # by row, then column: the same map however found
    col = col[order]
    coef = np.concatenate([w, own])[order]
    keep = np.any(coef != 0.0, axis=1)
    rows, col, coef = rows[order][keep], col[keep], coef[keep]
    start = np.searchsorted(rows, np.arange(n + 1))
    return PatchSlopes(n, start.astype(np.int64), col.astype(np.int64), coef)


def _neighbours(centroid, reach, normal, material):
    """``(i, j)``: j ≠ i of i's material in i's plane with its centroid within ``reach[i]``.

    Candidates first, as the pairs within the largest reach of points ``(c, s n)`` in six
    dimensions: with ``s`` ten reaches, patches whose normals differ (a wall and the floor
    at their shared edge) are ten reaches apart, so the candidates are nearly all coplanar
    (a small study: every pair's squared distance by one matrix product, chunked; a large
    one: a k-d tree)."""
    n = len(centroid)
    if not n:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    radius = float(reach.max())
    x = np.concatenate([centroid - centroid.mean(axis=0), 10.0 * radius * normal], axis=1)
    if n * n > _BRUTE_FORCE_PAIRS:
        from scipy.spatial import cKDTree

        pairs = cKDTree(x).query_pairs(radius, output_type="ndarray")
        i = np.concatenate([pairs[:, 0], pairs[:, 1]])
        j = np.concatenate([pairs[:, 1], pairs[:, 0]])
    else:
        sq = np.einsum("pc,pc->p", x, x)
        # |a − b|² = |a|² + |b|² − 2 a·b, loose by its rounding (the exact test follows)
        bound = radius * radius * (1 + 1e-6) + 1e-9 * float(sq.max())
        parts_i, parts_j = [], []
        step = max(1, _BRUTE_FORCE_PAIRS // (4 * n))
        for s in range(0, n, step):
            d2 = x[s:s + step] @ (-2.0 * x.T)  # in place after: one block, not three
            d2 += sq[s:s + step, None]
            d2 += sq[None]
            a, b = np.nonzero(d2 <= bound)
            parts_i.append(a + s)
            parts_j.append(b)
        i, j = np.concatenate(parts_i), np.concatenate(parts_j)
    d = centroid[j] - centroid[i]
    dist = np.linalg.norm(d, axis=1)
    # same plane: parallel normals and the offset in the plane (to the coordinates' rounding,
    # relative to the patch: a room at 10⁷ m keeps its digits in the differences)
    flat = np.abs(np.einsum("pc,pc->p", d, normal[i])) <= 1e-6 * reach[i]
    # the reach with a margin for rounding: a regular mesh can put a neighbour at exactly
    # REACH of the longest edge, which must count alike at every scale and position
    keep = ((i != j) & (dist <= reach[i] * (1 + 1e-7)) & (material[i] == material[j])
            & (np.einsum("pc,pc->p", normal[i], normal[j]) > 1.0 - 1e-9) & flat)
    return i[keep].astype(np.int64), j[keep].astype(np.int64)
