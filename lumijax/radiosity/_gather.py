"""Gathering inter-reflected light from the patches onto calculation points.

A calculation point in free space (a workplane, a facade grid) receives from every patch it
sees: ``E_ind(p) = ∫ L(ω) cos θ dω`` with the patches' luminance ``L = B/π``. Sampling the
hemisphere with cosine-weighted directions turns this into a mean: ``E_ind(p) ≈ (1/N) Σ B(hit)``.
The rays are cast once; the result is a fixed sparse linear map ``G`` from patch radiosity to
point illuminance, so gathering for another dimmer setting, another network or inside the
optimiser's gradient is a sparse product, never a ray.

Directions are a stratified (Fibonacci-lattice) cosine-weighted set, turned by a random
rotation per point so that neighbouring points do not share a pattern; the seed is fixed, so
results are reproducible.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import jax
import numpy as np
from jaxtyping import Array, Float, Int

from .. import _executables
from .._jit_cache import to_device
from ._slopes import PatchSlopes

__all__ = ["GatherOperator", "build_gather", "build_sensor_gather"]

#: (patches, links, points) a gather's product is padded up to (:meth:`GatherOperator.__call__`):
#: small.py's rooms fall within it (its cube: 1,728 patches, 100 points, 172,800 links in
#: closed form — every point to every patch — and 132,003 from 4,096 rays a point; its office
#: 4,960 patches: one study above 4,096 runs its own shape).
ROOM_SHAPE = (4096, 1 << 19, 1024)


@dataclass(frozen=True)
class GatherOperator:
    """Sparse map from patch radiosity (lm/m²) to point illuminance (lx): ``E = G @ B``.

    ``weight[k]`` links point ``point[k]`` to patch ``patch[k]``; the weights of one point sum
    to the fraction of its hemisphere covered by patches (1 inside a closed room; less where
    the point sees the sky).
    """

    n_points: int
    n_patches: int
    point: Int[np.ndarray, " links"]
    patch: Int[np.ndarray, " links"]
    weight: Float[np.ndarray, " links"]

    def __call__(self, b: Float[Array, "patches ..."]) -> Float[Array, "points ..."]:
        """Illuminance (lx) at the points from patch radiosity ``b`` (any trailing axes).

        A room-sized product runs on shapes padded up to :data:`ROOM_SHAPE` (4,096 patches,
        2¹⁹ links, 1,024 points; padding links weigh 0 and land on a point past the last), so
        every such study calls the one program the first compiled and stored (~0.1 s of a new
        study's run otherwise). An axis above its size runs as it is: padding there would
        cost copies and work on every call (up to 2× the product, a host copy of ``b``) for
        a compile a large study pays once."""
        from ._solve import _pad_rows

        n, links, n_points = self.n_patches, len(self.patch), self.n_points
        least_rows, least_links, least_points = ROOM_SHAPE
        rows, size = max(n, least_rows), max(links, least_links)
        points = max(n_points + (size > links), least_points)
        traced = isinstance(b, jax.core.Tracer)
        b = _pad_rows(b, n, rows - n) if rows > n else to_device(b)
        weight = np.asarray(self.weight, b.dtype).reshape((-1,) + (1,) * (b.ndim - 1))
        patch, point = self.patch, self.point
        if size > links:
            weight = np.concatenate([weight, np.zeros((size - links,) + weight.shape[1:],
                                                      weight.dtype)])
            patch = np.concatenate([patch, np.zeros(size - links, patch.dtype)])
            point = np.concatenate([point, np.full(size - links, n_points, point.dtype)])
        out = _apply(b, patch, weight, point, points)
        if points == n_points:
            return out
        if traced:  # the slice joins the caller's program
            return out[:n_points]
        return to_device(np.asarray(out)[:n_points])  # an eager slice would compile one

    @property
    def coverage(self) -> Float[np.ndarray, " points"]:
        """Fraction of each point's (cosine-weighted) hemisphere that sees a patch."""
        # float even with no rays (numpy's bincount of empty weights is integer)
        return np.bincount(self.point, weights=self.weight,
                           minlength=self.n_points).astype(np.float64, copy=False)


@_executables.stored("gather_apply", "radiosity/_gather.py", static_argnums=4)
def _apply(b, patch, weight, point, n_points):
    """``E = G @ B`` as one compiled program (its eager ops, each compiled per process, cost
    more than the gather on a small study: docs/radiosity.md, "Caches")."""
    return jax.ops.segment_sum(b[patch] * weight, point, num_segments=n_points)


def _cosine_directions(n: int) -> Float[np.ndarray, "n 3"]:
    """``n`` stratified cosine-weighted directions about +z (Fibonacci lattice on the disk)."""
    k = np.arange(n) + 0.5
    r = np.sqrt(k / n)  # uniform on the unit disk → cosine-weighted after projecting up
    phi = k * np.pi * (3.0 - np.sqrt(5.0))
    x, y = r * np.cos(phi), r * np.sin(phi)
    return np.stack([x, y, np.sqrt(np.maximum(0.0, 1.0 - x * x - y * y))], axis=1)


def _frames(normals: Float[np.ndarray, "p 3"], rng) -> Float[np.ndarray, "p 3 3"]:
    """Orthonormal frames with z along each normal and a random turn about it."""
    n = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    ang = rng.uniform(0, 2 * np.pi, size=len(n))[:, None]
    t, b = np.cos(ang) * t + np.sin(ang) * b, -np.sin(ang) * t + np.cos(ang) * b
    return np.stack([t, b, n], axis=2)  # columns: world = frame @ local


def build_gather(
    points: Float[np.ndarray, "points 3"],
    normals: Float[np.ndarray, "points 3"],
    patches,
    caster,
    *,
    rays: int = 512,
    seed: int = 0,
    chunk: int = 4096,
    slopes: PatchSlopes | None = None,
) -> GatherOperator:
    """Cast ``rays`` cosine-weighted rays from each point and record which patch each hits
    (exactly, by :class:`~lumijax.radiosity.PatchLocator`, where the caster's triangles are
    the ones the patches were cut from; else the hit triangle's nearest patch centroid).

    Parameters
    ----------
    points, normals
        Calculation points (m) and the normals of their measuring planes.
    patches
        :class:`lumijax.radiosity.Patches` of the scene.
    caster
        The scene's :class:`lumijax.scene.RayCaster` (over the same triangles the patches
        subdivide).
    rays
        Rays per point; the statistical error of a smooth field falls like 1/rays for this
        stratified set, about 1 % at 512.
    slopes
        :func:`~lumijax.radiosity.patch_slopes` of ``patches``: each ray reads the patch's
        radiosity linear across it, ``B_i + g_i · (hit − c_i)``, where the patch lies within
        :data:`SLOPE_DISTANCE` of its longest edge from the point, folded into the links
        (which then reach those patches' neighbours, some with negative weights; every
        point's weights still sum to its coverage). None: constant over each patch.
    """
    points = np.asarray(points, np.float64)
    rng = np.random.default_rng(seed)
    local = _cosine_directions(rays)
    src_tri = np.asarray(patches.source_triangle)
    tri_normals = np.zeros((int(src_tri.max()) + 1 if len(src_tri) else 0, 3))
    tri_normals[src_tri] = patches.normal
    rows, cols, carry, offsets = [], [], [], []
    if slopes is not None:  # once, not per chunk: a million patches' edges at LoD 3
        centroid = np.asarray(patches.centroid, np.float64)
        near_reach = SLOPE_DISTANCE * np.asarray(patches.diameter)
    locator = _locator(patches, caster)
    glazed = getattr(caster, "glazing_key", None) is not None
    for s in range(0, len(points), chunk):
        p = points[s : s + chunk]
        frames = _frames(np.asarray(normals[s : s + chunk], np.float64), rng)
        dirs = np.einsum("pij,rj->pri", frames, local).reshape(-1, 3)
        origins = np.repeat(p, rays, axis=0)
        if glazed:  # clear panes pass the ray on, carrying τ(θ) (docs/materials.md)
            tri, dist, carried = caster.first_hit_through(origins, dirs)
            uv = None
        else:  # Embree's barycentric uv: the patch lookup needs no hit point
            tri, dist, uv = caster.first_hit_uv(origins, dirs)
        hit = tri >= 0
        # surfaces are one-sided: a ray meeting a patch's back sees no light (it is still blocked)
        hit[hit] &= np.einsum("ij,ij->i", dirs[hit], tri_normals[tri[hit]]) < 0
        if locator is None:
            patch = patch_of_hits(patches, origins[hit] + dirs[hit] * dist[hit, None], tri[hit])
        else:  # a triangle with no patch (an occluder only) blocks and carries nothing
            if uv is None:
                patch = locator(origins[hit] + dirs[hit] * dist[hit, None], tri[hit])
            else:
                patch = locator(None, tri[hit], uv[hit])
            hit[hit] = patch >= 0
            patch = patch[patch >= 0]
        rows.append(np.repeat(np.arange(s, s + len(p)), rays)[hit])
        cols.append(patch)
        if glazed:
            carry.append(carried[hit])
        if slopes is not None:
            # only where the patch is near: seen from farther than a few of its sizes, a
            # patch is seen evenly and its slope changes the reading to second order only,
            # while every slope read adds links (an open court's rays meet each far patch once)
            offset = origins[hit] + dirs[hit] * dist[hit, None] - centroid[patch]
            far = dist[hit] > near_reach[patch]
            offset[far] = 0.0
            offsets.append(offset)
    point_idx = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    patch_idx = np.concatenate(cols) if cols else np.zeros(0, np.int64)
    # merge repeated (point, patch) links: fewer gathers per product
    key = point_idx.astype(np.int64) * patches.n + patch_idx
    carried_all = np.concatenate(carry) if glazed and carry else None
    if slopes is None:
        uniq, counts = merged_links(key, carried_all)
        weight = counts / rays
    else:
        each = np.ones(len(key)) if carried_all is None else carried_all
        offset = np.concatenate(offsets) * each[:, None] if offsets else np.zeros((0, 3))
        space = len(points) * patches.n
        uniq, sums = _sums_by_key(key, [each, *offset.T], space)
        uniq, weight = _with_slopes(uniq, sums[0] / rays, np.stack(sums[1:], axis=1) / rays,
                                    slopes, space)
    return GatherOperator(
        n_points=len(points),
        n_patches=patches.n,
        point=(uniq // patches.n).astype(np.int32),
        patch=(uniq % patches.n).astype(np.int32),
        weight=weight,
    )


def _with_slopes(key, weight, moment, slopes: PatchSlopes, space: int):
    """Links ``key`` (point · patches + patch) of ``weight`` with each link's first moment
    ``moment`` (Σ over its rays of (hit − centroid) / rays, m) read through the patch's slope:
    ``w B_i + moment · g_i`` with ``g_i = Σ coef B[col]``, merged into one set of links."""
    n = slopes.n_patches
    read = np.flatnonzero(np.any(moment != 0.0, axis=1))  # the links of near patches
    point, patch, moment = key[read] // n, key[read] % n, moment[read]
    count = np.diff(slopes.start)[patch]
    link = np.repeat(np.arange(len(read)), count)
    entry = np.repeat(slopes.start[patch] - (np.cumsum(count) - count), count) + np.arange(
        int(count.sum()))
    extra = np.einsum("ec,ec->e", moment[link], slopes.coef[entry])
    uniq, (total,) = _sums_by_key(np.concatenate([key, point[link] * n + slopes.col[entry]]),
                                  [np.concatenate([weight, extra])], space)
    return uniq, total


#: The distance (over the patch's longest edge) within which a ray reads its patch's slope.
#: The cube of benchmarks/small.py read as well with 4 as with every patch; the LoD-0
#: courtyard's grids with every patch had 2.6× the links and a peak 1.5 GiB higher.
SLOPE_DISTANCE = 8.0

#: Keys (points × patches) up to which links are summed in a dense array, not by sorting.
_DENSE_KEYS = 1 << 22


def _sums_by_key(key, columns: list, space: int):
    """The distinct keys (sorted) and each column's sum over each: by ``np.bincount`` over the
    whole key space where it is small (a room's 100 points × 1,728 patches: no sort), else by
    ``np.unique``."""
    # float even with no links (numpy's bincount of empty weights is integer)
    if space <= _DENSE_KEYS:
        dense = [np.bincount(key, weights=c, minlength=space) for c in columns]
        uniq = np.flatnonzero(np.bincount(key, minlength=space))
        return uniq, [d[uniq].astype(np.float64, copy=False) for d in dense]
    uniq, inverse = np.unique(key, return_inverse=True)
    return uniq, [np.bincount(inverse, weights=c, minlength=len(uniq)).astype(np.float64,
                                                                            copy=False)
                  for c in columns]


def merged_links(key: Int[np.ndarray, " hits"],
                 carried: Float[np.ndarray, " hits"] | None = None):
    """The distinct link keys of a set of hits (sorted) and each one's total: the hits'
    count, or the sum of what they carry (a glazed scene's τ). Counting sorts; summing weights
    needs the inverse, an argsort."""
    if carried is None:
        return np.unique(key, return_counts=True)
    uniq, inverse = np.unique(key, return_inverse=True)
    return uniq, np.bincount(inverse.ravel(), weights=carried, minlength=len(uniq))


_LOCATORS = threading.Lock()
_KEPT_LOCATORS = 4  # meshes of one scene whose lookups a caster keeps


def _locator(patches, caster):
    """The exact patch lookup of ``patches`` in ``caster``'s triangles (:class:`~lumijax.
    radiosity.PatchLocator`), or None where the caster's triangles are not the ones the patches
    were cut from. Made once per caster and patches (1.3 s at 3.4·10⁵ patches) and kept on the
    caster: a study's gathers (the grids' chunks on threads, the observers, a fine level) share
    it."""
    from ._sampled import PatchLocator

    triangles = getattr(caster, "triangles", None)
    src = np.asarray(patches.source_triangle)
    if triangles is None or (len(src) and src.max() >= len(triangles)):
        return None
    with _LOCATORS:  # the other threads wait for this one's, not make their own
        kept = caster.__dict__.setdefault("_patch_locators", {})
        held = kept.get(id(patches))
        if held is None or held[0] is not patches:  # held: the patches too, so ids stay theirs
            while len(kept) >= _KEPT_LOCATORS:  # a session re-meshing one scene: the newest
                kept.pop(next(iter(kept)))
            held = kept[id(patches)] = (patches, PatchLocator(patches, triangles))
        return held[1]


def patch_of_hits(patches, points, tri, *, few: int = 256,
                  budget: int = 1 << 22) -> Int[np.ndarray, " hits"]:
    """The patch of triangle ``tri`` whose centroid is nearest each point (m): where a ray
    that hit triangle ``tri`` at ``points`` lands.

    A triangle's patches are contiguous (``mesh_patches`` keeps them in order): a triangle of
    one patch is a lookup, of up to 64 a padded brute-force search (vectorised over every
    triangle hit), of up to ``few`` a search per triangle hit by one matrix product (``budget``
    distances at a time: a Python loop over those triangles only), and only larger
    ones (a courtyard's ground) a k-d tree. No scipy.spatial (~0.3 s to import) unless such a
    triangle is hit. (The tree alone falls back to a Python loop whenever a big patch's
    centroid is farther than 16 small neighbours' — most hits, on a courtyard.)
    """
    src = np.asarray(patches.source_triangle)
    tri = np.asarray(tri)
    points = np.asarray(points, np.float64)
    lo = np.searchsorted(src, tri, side="left")
    n = np.searchsorted(src, tri, side="right") - lo
    out = lo.astype(np.int64)
    c = patches.centroid
    for top, floor in ((4, 1), (16, 4), (64, 16)):  # pad a bucket to its own largest only
        sel = np.flatnonzero((n > floor) & (n <= min(top, few)))
        for b in range(0, len(sel), budget // top):
            i = sel[b:b + budget // top]
            cand = lo[i, None] + np.arange(int(n[i].max()))[None]
            valid = cand < (lo[i] + n[i])[:, None]
            v = c[np.where(valid, cand, lo[i, None])] - points[i, None]
            d = np.where(valid, np.einsum("hkc,hkc->hk", v, v), np.inf)
            out[i] = cand[np.arange(len(i)), np.argmin(d, axis=1)]
    mid = np.flatnonzero((n > 64) & (n <= few))
    if len(mid):
        order = mid[np.argsort(tri[mid], kind="stable")]
        cut = np.flatnonzero(np.diff(tri[order])) + 1
        for hits in np.split(order, cut):
            own = c[lo[hits[0]]:lo[hits[0]] + n[hits[0]]]
            o = own[0]  # re-centred: |p − c|² from products keeps its digits at site coordinates
            co = own - o
            cc = (co * co).sum(1)
            for s in range(0, len(hits), max(1, budget // len(own))):
                h = hits[s:s + budget // len(own)]
                d = cc[None] - 2.0 * ((points[h] - o) @ co.T)  # |p − c|² − |p|²
                out[h] = lo[h] + np.argmin(d, axis=1)
    many = np.flatnonzero(n > few)
    if len(many):
        from scipy.spatial import cKDTree

        out[many] = _patch_by_tree(cKDTree(c), src, points[many], tri[many])
    return out


def _patch_by_tree(tree, src_tri, hit_points, hit_tri, k: int = 16):
    """:func:`patch_of_hits` by a k-d tree of every patch centroid: the nearest of the ``k``
    nearest centroids cut from the hit triangle, else a search of its own patches."""
    if not len(hit_points):
        return np.zeros(0, np.int64)
    k = min(k, len(src_tri))
    _, idx = tree.query(hit_points, k=k)
    idx = idx.reshape(len(hit_points), k)
    same = src_tri[idx] == hit_tri[:, None]
    first = np.argmax(same, axis=1)
    found = same[np.arange(len(idx)), first]
    out = idx[np.arange(len(idx)), first]
    if not found.all():  # a huge triangle cut into many patches: search its own patches
        lo = np.searchsorted(src_tri, hit_tri, side="left")  # a triangle's patches are contiguous
        hi = np.searchsorted(src_tri, hit_tri, side="right")
        for i in np.flatnonzero(~found):
            d = np.linalg.norm(tree.data[lo[i]:hi[i]] - hit_points[i], axis=1)
            out[i] = lo[i] + int(np.argmin(d))
    return out


def _sphere_directions(n: int) -> Float[np.ndarray, "n 3"]:
    """``n`` stratified uniform directions on the unit sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = k * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def build_sensor_gather(
    points: Float[np.ndarray, "points 3"],
    response,
    patches,
    caster,
    *,
    rays: int = 1024,
    seed: int = 0,
    chunk: int = 2048,
) -> GatherOperator:
    """The gather of sensors that are not planes (cylindrical, semi-cylindrical,
    hemispherical: :class:`lumijax.direct.SensorResponse`), which see the whole sphere.

    ``E = ∫ L(u) R(u) dω`` with ``L = B/π`` is sampled with ``rays`` stratified uniform
    directions per point (turned at random per point): ``E ≈ (4/N) Σ R(u) B(hit)``, so each
    link weighs ``4 R(u)/N``. The weights of a point sum to the fraction of ``∫ R dω = π``
    (divided by π) that meets a patch: 1 in a closed room, as for the planar gather.
    """
    points = np.asarray(points, np.float64)
    rng = np.random.default_rng(seed)
    local = _sphere_directions(rays)
    src_tri = np.asarray(patches.source_triangle)
    tri_normals = np.zeros((int(src_tri.max()) + 1 if len(src_tri) else 0, 3))
    tri_normals[src_tri] = patches.normal
    rows, cols, wts = [], [], []
    for s in range(0, len(points), chunk):
        p = points[s : s + chunk]
        frames = _frames(rng.normal(size=(len(p), 3)) + 1e-9, rng)  # a random turn per point
        dirs = np.einsum("pij,rj->pri", frames, local).reshape(-1, 3)
        receiver = np.repeat(np.arange(s, s + len(p)), rays)
        weight = 4.0 * response.factor(-dirs, receiver) / rays
        live = weight > 0
        origins = np.repeat(p, rays, axis=0)[live]
        dirs, receiver, weight = dirs[live], receiver[live], weight[live]
        tri, dist, carried = caster.first_hit_through(origins, dirs)  # τ(θ) of clear panes
        hit = tri >= 0
        hit[hit] &= np.einsum("ij,ij->i", dirs[hit], tri_normals[tri[hit]]) < 0
        hit_points = origins[hit] + dirs[hit] * dist[hit, None]
        rows.append(receiver[hit])
        cols.append(patch_of_hits(patches, hit_points, tri[hit]))
        wts.append(weight[hit] * carried[hit])
    point_idx = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    patch_idx = np.concatenate(cols) if cols else np.zeros(0, np.int64)
    weight = np.concatenate(wts) if wts else np.zeros(0)
    key = point_idx.astype(np.int64) * patches.n + patch_idx
    uniq, inverse = np.unique(key, return_inverse=True)
    return GatherOperator(
        n_points=len(points),
        n_patches=patches.n,
        point=(uniq // patches.n).astype(np.int32),
        patch=(uniq % patches.n).astype(np.int32),
        weight=np.bincount(inverse.ravel(), weights=weight, minlength=len(uniq)),
    )
