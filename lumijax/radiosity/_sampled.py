"""Ray-sampled form factors (stochastic radiosity, Neumann; Bekaert): ``[solver] transport =
"sampled"``.

Each patch i casts N rays (``rays_per_patch``) from stratified points on its surface in
stratified cosine-weighted directions; a ray whose first hit is the front of patch j is one
hit, and ``F_ij ≈ hits(i → j) / N``. This is an unbiased estimate of the area-averaged form
factor with exact visibility (a column's shadow, a recess, a back face all come from the ray
itself), and it needs memory for the links only: at most N per patch, usually far fewer after
duplicates are merged, O(P·N) where the block operator of an open scene is O(P²).

The sampled F is fixed once cast (fixed seed), so the radiosity system stays linear and its
implicit derivative is the one of the block operator: the links are a :class:`SampledBucket`
of a :class:`TransportOperator` (``G = A F``, stored directed since the two estimates of a
pair differ), and the solve, the cache, ``replace_luminaire`` and the optimiser see the same
object. Rows never sum above 1 (N rays, at most N hits), and a closed room's rows sum to
exactly 1 minus the rays that met a back face.

**Clear glass** (``kind = "clear"``, a :class:`~lumijax.scene.GlazedCaster`): a ray passes a
pane as a gather ray does (``first_hit_through``) and its hit behind weighs τ(θ) of every
pane crossed, θ the ray's own incidence, so ``F_ij ≈ Σ_hits Π τ(θ) / N``: the exact angle of
each ray, where the block operator samples it with one or a few visibility rays per pair. The
pane itself is not hit, so its own diffuse reflection (``reflectance``, which should be 0 or
near it for clear glass: docs/materials.md) is not seen, and the rows still sum to at most 1.

The work is cut into batches of patches (:func:`sample_batch`: a batch in, three link arrays
out, independent of every other batch): :func:`build_sampled` maps them over the current
executor (one task a batch on a Dask cluster, on threads here) and assembles the operator.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float, Int

from ..errors import GeometryError
from ._gather import _cosine_directions, _frames
from ._operator import Info, SampledBucket, TransportOperator
from ._patches import Patches

__all__ = ["SampledSettings", "PatchLocator", "sample_batch", "build_sampled", "sampled_bytes",
           "LINK_BYTES"]

#: Stored bytes per link: int32 receiver, int32 sender, float32 weight.
LINK_BYTES = 12

#: Links per step of a product's scan: 2¹⁶ links × 144 columns × 4 bytes ≈ 38 MiB gathered.
_STEP = 1 << 16

_R2 = 1.32471795724474602596  # plastic number: the R2 low-discrepancy sequence's generator


@dataclass(frozen=True)
class SampledSettings:
    """Knobs of :func:`build_sampled` (hashable: part of the operator's cache key)."""

    rays_per_patch: int = 256
    """Rays cast from each patch; the per-patch noise of a bounce falls like N^(-1/2) or
    faster (stratified), the memory grows at most like N."""
    seed: int = 0
    """Seed of the per-patch rotations and shifts of the stratified pattern."""
    batch: int = 2048
    """Patches per batch (one Embree query of batch × rays rays). Part of the key: a batch's
    random turns are drawn from (seed, first patch of the batch). 2048 × 256 rays keeps a
    batch's arrays in the last-level cache's reach: the 1.9·10⁵-patch courtyard built in
    13.0 s against 15.2 s with 8192 (2 threads, benchmarks/RESULTS.md)."""


class PatchLocator:
    """Which patch of a hit triangle holds a hit point, exactly.

    ``mesh_patches`` cuts a triangle either by its regular barycentric grid (n² congruent
    sub-triangles in the template's order: looked up from the point's barycentric coordinates)
    or, a sliver, by repeated bisection of the longest edge (looked up by replaying the cuts on
    the point: one side test per level). Each triangle's patches are checked at construction
    to be found by their own centroids; a triangle that fails both (a refined mesh) falls back
    to the nearest patch centroid of that triangle, as the two-level gather does. A triangle
    with no patch (an occluder only) holds none: −1.
    """

    _DEPTH = 24  # most bisection levels replayed (a piece of 2⁻²⁴ of its triangle)

    def __init__(self, patches: Patches, triangles: Float[np.ndarray, "tri 3 3"]) -> None:
        tri = np.asarray(triangles, np.float64)
        n_triangles = len(tri)
        src = np.asarray(patches.source_triangle, np.int64)
        if len(src) and np.any(np.diff(src) < 0):
            raise GeometryError("patches must be grouped by source triangle (as mesh_patches "
                                "makes them) for the sampled transport")
        if len(src) and (src.min() < 0 or src.max() >= n_triangles):
            raise GeometryError(f"patch source triangles outside 0..{n_triangles - 1}: the "
                                "patches were not cut from the ray caster's triangles")
        self.patches, self.triangles = patches, tri
        self.count = np.bincount(src, minlength=n_triangles)
        self.first = np.concatenate([[0], np.cumsum(self.count)[:-1]]).astype(np.int64)
        n = np.rint(np.sqrt(self.count)).astype(np.int64)
        self.n = n
        v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        self.v0 = v0
        # dual basis: barycentric (u, v) of a point d = p − v0 are d·a1, d·a2
        g11, g12, g22 = (np.einsum("ij,ij->i", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
        det = g11 * g22 - g12**2
        det = np.where(det > 0, det, 1.0)
        self.a1 = (g22[:, None] * e1 - g12[:, None] * e2) / det[:, None]
        self.a2 = (g11[:, None] * e2 - g12[:, None] * e1) / det[:, None]
        index = np.arange(len(src))
        self.grid = (self.count > 0) & (n * n == self.count)
        ok = np.ones(n_triangles, bool)
        np.logical_and.at(ok, src, self._grid_lookup(patches.centroid, src) == index)
        self.grid &= ok
        # the others: replay the bisection on each patch's centroid until the piece is it,
        # then keep the cuts as a tree (node: the cut's midpoint and the normal of its line in
        # the plane; children: node ids ≥ 0, or −1 − patch)
        cand = np.flatnonzero(~self.grid[src] & (self.count[src] > 1))
        self.bisected = np.zeros(n_triangles, bool)
        self.root = np.full(n_triangles, -1, np.int64)
        self.cut = np.zeros((3, 0), np.float32)  # per node (c0, c1, c2): _tree
        self.child = np.zeros(0, np.int64)  # child[2 node + side]: one flat gather a level
        self.leaf_patch, self.n_internal = np.zeros(0, np.int64), 0
        self.tree_height = np.zeros(n_triangles, np.int64)
        if len(cand):
            self._tree(cand, src, index)
        # how each triangle is cut, one gather a lookup: 0 no patch, 1 one patch, 2 the grid,
        # 3 bisected, 4 neither (the nearest patch centroid)
        self.kind = np.select([self.count == 0, self.count == 1, self.grid, self.bisected],
                              [0, 1, 2, 3], 4).astype(np.int8)

    def _tree(self, cand, src, index) -> None:
        p = self.patches
        code = self._replay(p.centroid[cand], src[cand], target=p.vertices[cand])
        t = src[cand]
        good = np.ones(len(self.count), bool)
        np.logical_and.at(good, t, code > 0)
        shift = self._DEPTH + 1
        leaf_key = t << shift | np.maximum(code, 0)
        order = np.argsort(leaf_key, kind="stable")
        leaf_key, leaf_patch = leaf_key[order], index[cand][order]
        good[t[order][np.flatnonzero(np.diff(leaf_key) == 0)]] = False
        ok = good[t[order]] & (leaf_key & ((1 << shift) - 1) > 0)
        leaf_key, leaf_patch = leaf_key[ok], leaf_patch[ok]
        lt, lc = leaf_key >> shift, leaf_key & ((1 << shift) - 1)
        # every proper prefix of a leaf's code is an internal node
        nodes = []
        c = lc >> 1
        while np.any(c > 0):
            nodes.append(lt[c > 0] << shift | c[c > 0])
            c = c >> 1
        if not nodes:
            return
        node_key = np.unique(np.concatenate(nodes))
        nt, nc = node_key >> shift, node_key & ((1 << shift) - 1)
        # the cut of each node: replay its prefix from the root
        depth = np.floor(np.log2(nc)).astype(np.int64)
        cur = self.triangles[nt].copy()
        for level in range(int(depth.max()) + 1):
            r, m = self._cut(cur)
            go = depth > level
            bit = (nc >> np.maximum(depth - level - 1, 0)) & 1
            nxt = np.where(bit[:, None, None] == 1, np.stack([m, r[:, 1], r[:, 2]], 1),
                           np.stack([r[:, 0], m, r[:, 2]], 1))
            cur = np.where(go[:, None, None], nxt, cur)
        r, m = self._cut(cur)
        nrm = np.cross(r[:, 1] - r[:, 0], r[:, 2] - r[:, 0])
        w = np.cross(nrm, r[:, 2] - m)  # (p − m)·w < 0: the second half, as in _replay
        # p = v0 + u e1 + v e2 is affine in (u, v), so the side is too: c0 + c1 u + c2 v; the
        # descent then reads Embree's barycentrics directly, never a 3-D point
        t0 = self.triangles[nt]
        cut = np.stack([np.einsum("ij,ij->i", t0[:, 0] - m, w),
                        np.einsum("ij,ij->i", t0[:, 1] - t0[:, 0], w),
                        np.einsum("ij,ij->i", t0[:, 2] - t0[:, 0], w)], axis=1)
        child = np.empty((len(node_key), 2), np.int64)
        for side in (0, 1):
            k = nt << shift | (2 * nc + side)
            pi = np.minimum(np.searchsorted(node_key, k), len(node_key) - 1)
            pl = np.minimum(np.searchsorted(leaf_key, k), len(leaf_key) - 1)
            # a leaf child: the node after the internal ones that stands for its leaf; −2: none
            child[:, side] = np.where(node_key[pi] == k, pi,
                                      np.where(leaf_key[pl] == k, len(node_key) + pl, -2))
        # Every leaf is also a node, one that keeps a point where it is (cut (1, 0, 0): the
        # first side; both children itself), and one more stands for a missing child: the
        # descent takes a step for every point at every level, without compacting the points
        # still going (2x faster), and drops those of shallower trees only now and then.
        n_int, n_leaf = len(node_key), len(leaf_key)
        absorbing = np.arange(n_int, n_int + n_leaf + 1)
        child = np.where(child == -2, n_int + n_leaf, child)
        self.leaf_patch = np.concatenate([leaf_patch, [-1]]).astype(np.int64)
        self.n_internal = n_int
        # float32 as Embree's (u, v): the side test is no sharper than its input
        self.cut = np.concatenate([cut, np.tile([1.0, 0.0, 0.0], (n_leaf + 1, 1))]).astype(
            np.float32).T.copy()
        self.child = np.concatenate([child, np.stack([absorbing, absorbing], 1)]).ravel()
        self.tree_height = np.zeros(len(self.count), np.int64)  # steps root → deepest leaf
        np.maximum.at(self.tree_height, lt, np.floor(np.log2(lc)).astype(np.int64))
        roots = nc == 1
        self.root[nt[roots]] = np.flatnonzero(roots)
        self.bisected = good & (self.root >= 0)

    @staticmethod
    def _cut(cur):
        """The cut of bisect_triangles: the longest edge's midpoint to the opposite vertex;
        returns the piece's vertices rotated to (r0, r1, r2), r0 → r1 the cut edge, and m."""
        e = np.linalg.norm(np.roll(cur, -1, axis=1) - cur, axis=-1)
        j = e.argmax(axis=1)
        r = np.take_along_axis(cur, ((np.arange(3) + j[:, None]) % 3)[:, :, None], axis=1)
        return r, 0.5 * (r[:, 0] + r[:, 1])

    def _uv(self, points, tri):
        d = points - self.v0[tri]
        return np.stack([np.einsum("ij,ij->i", d, self.a1[tri]),
                         np.einsum("ij,ij->i", d, self.a2[tri])], axis=1)

    def _grid_lookup(self, points, tri, uv=None):
        uv = self._uv(points, tri) if uv is None else uv
        n = self.n[tri]
        u, v = uv[:, 0] * n, uv[:, 1] * n
        a = np.clip(np.floor(u), 0, n - 1).astype(np.int64)
        b = np.clip(np.floor(v), 0, n - 1 - a).astype(np.int64)
        down = (u - a + v - b > 1.0) & (a + b <= n - 2)
        return self.first[tri] + 2 * a * n - a * a + 2 * b + down

    def _replay(self, points, tri, target):
        """The bisection code (a leading 1, then one bit per cut: 1 for the half holding r1)
        of the piece holding each point, replayed until the piece equals ``target``; −1 when
        none is reached within ``_DEPTH`` cuts."""
        cur = self.triangles[tri].copy()
        code = np.ones(len(tri), np.int64)
        out = np.full(len(tri), -1, np.int64)
        live = np.arange(len(tri))
        scale = np.abs(cur).max(axis=(1, 2)) + 1.0
        for _ in range(self._DEPTH + 1):
            done = np.abs(cur - target[live]).max(axis=(1, 2)) <= 1e-9 * scale[live]
            out[live[done]] = code[done]
            live, cur, code = live[~done], cur[~done], code[~done]
            if not len(live):
                break
            r, m = self._cut(cur)
            nrm = np.cross(r[:, 1] - r[:, 0], r[:, 2] - r[:, 0])
            second = np.einsum("ij,ij->i", np.cross(r[:, 2] - m, points[live] - m), nrm) < 0
            cur = np.where(second[:, None, None], np.stack([m, r[:, 1], r[:, 2]], 1),
                           np.stack([r[:, 0], m, r[:, 2]], 1))
            code = 2 * code + second
        return out

    def _descend(self, uv, tri) -> np.ndarray:
        """The patch of a bisected triangle holding each point (barycentric ``uv`` in its
        triangle): down the tree of cuts, a leaf keeping what reaches it."""
        node = self.root[tri]
        u, v = np.asarray(uv[:, 0], np.float32), np.asarray(uv[:, 1], np.float32)
        height = self.tree_height[tri]
        c0, c1, c2 = self.cut
        done, live = node.copy(), np.arange(len(tri))
        for level in range(int(height.max(initial=0))):
            if level % 4 == 3:  # every fourth level, drop the points whose trees end above it
                go = height > level
                if not go.all():
                    done[live] = node
                    live, node, u, v, height = live[go], node[go], u[go], v[go], height[go]
            second = c0[node] + c1[node] * u + c2[node] * v < 0
            node = self.child[2 * node + second]
        done[live] = node
        return self.leaf_patch[done - self.n_internal]

    def __call__(self, points: Float[np.ndarray, "k 3"] | None,
                 tri: Int[np.ndarray, " k"],
                 uv: Float[np.ndarray, "k 2"] | None = None) -> Int[np.ndarray, " k"]:
        """The patch holding each point of triangle ``tri`` (−1: a triangle with no patch).

        The points are given as positions (m), or as barycentric ``uv`` in their triangle (a
        ray caster's :meth:`~lumijax.scene.RayCaster.first_hit_uv`), or both."""
        from ._gather import patch_of_hits

        out = np.full(len(tri), -1, np.int64)
        kind = self.kind[tri]
        one = np.flatnonzero(kind == 1)
        out[one] = self.first[tri[one]]
        g = np.flatnonzero(kind == 2)
        out[g] = self._grid_lookup(None if points is None else points[g], tri[g],
                                   None if uv is None else uv[g])
        b = np.flatnonzero(kind == 3)
        if len(b):
            out[b] = self._descend(self._uv(points[b], tri[b]) if uv is None else uv[b], tri[b])
        miss = np.flatnonzero((kind == 4) | ((kind == 3) & (out < 0)))
        if len(miss):
            pts = points[miss] if points is not None else self._point(tri[miss], uv[miss])
            out[miss] = patch_of_hits(self.patches, pts, tri[miss])
        return out

    def _point(self, tri, uv):
        t = self.triangles[tri]
        uv = np.asarray(uv, np.float64)
        return t[:, 0] + uv[:, :1] * (t[:, 1] - t[:, 0]) + uv[:, 1:] * (t[:, 2] - t[:, 0])


def _origins(vertices, rays: int, shift, lift=None) -> Float[np.ndarray, "p rays 3"]:
    """``rays`` stratified points on each triangle: the R2 sequence shifted per patch, folded
    into the triangle (uniform in area), each moved by its patch's ``lift`` (m, a 3-vector).

    One coordinate at a time, in place: a batched ``(p, rays, 2) @ (p, 2, 3)`` product loops
    over p in small matrix calls and took 2.6× as long."""
    k = np.arange(rays) + 0.5
    u = k / _R2 + shift[:, :1]
    v = k / _R2**2 + shift[:, 1:]
    u -= np.floor(u)  # the fractional part: float % is several times slower
    v -= np.floor(v)
    fold = u + v > 1.0
    np.subtract(1.0, u, out=u, where=fold)
    np.subtract(1.0, v, out=v, where=fold)
    base = vertices[:, 0] if lift is None else vertices[:, 0] + lift
    e1, e2 = vertices[:, 1] - vertices[:, 0], vertices[:, 2] - vertices[:, 0]
    out = np.empty((len(vertices), rays, 3))
    for c in range(3):
        x = out[:, :, c]
        np.multiply(u, e1[:, c, None], out=x)
        x += v * e2[:, c, None]
        x += base[:, c, None]
    return out


def sample_batch(
    patches: Patches,
    caster,
    start: int,
    stop: int,
    settings: SampledSettings,
    locator: PatchLocator,
    front: Float[np.ndarray, "tri 3"],
) -> tuple[Int[np.ndarray, " k"], Int[np.ndarray, " k"], Float[np.ndarray, " k"], dict]:
    """The links of patches ``start..stop``: ``(recv, src, weight, counts)``.

    ``weight = A_i · hits / N`` (m², float32), sorted by receiver then sender, duplicates
    merged; ``counts`` has ``rays`` and ``ray_s`` (time in Embree). ``front``: each triangle's
    front normal (a ray meeting a back face is blocked and carries nothing: surfaces are
    one-sided). With clear glass (a :class:`~lumijax.scene.GlazedCaster`) a ray passes every
    pane it meets and its hit behind counts τ(θ) of each pane crossed, not 1 (module
    docstring). Depends only on its arguments, so batches can run anywhere in any order.
    """
    n_rays = settings.rays_per_patch
    idx = np.arange(start, stop)
    rng = np.random.default_rng((settings.seed, start))
    normal = np.asarray(patches.normal[start:stop], np.float64)
    frames = _frames(normal, rng)
    # a fixed shuffle pairs the spatial and the directional strata without correlation
    local = _cosine_directions(n_rays)[np.random.default_rng(settings.seed).permutation(n_rays)]
    dirs = np.matmul(local[None], frames.transpose(0, 2, 1)).reshape(-1, 3)  # frame @ local
    o = _origins(patches.vertices[start:stop], n_rays, rng.uniform(size=(len(idx), 2)),
                 lift=10.0 * float(caster.epsilon) * normal).reshape(-1, 3)
    t = time.perf_counter()
    glazed = getattr(caster, "glazing_key", None) is not None
    if glazed:  # clear panes pass the ray on to what lies behind, carrying τ(θ) of each
        tri, dist, carried = caster.first_hit_through(o, dirs)
        uv = None
    else:
        tri, _, uv = caster.first_hit_uv(o, dirs)
    ray_s = time.perf_counter() - t
    hit = np.flatnonzero(tri >= 0)
    th = tri[hit]
    hit = hit[np.einsum("ij,ij->i", dirs[hit], front[th]) < 0]
    th = tri[hit]
    recv = hit // n_rays + start
    if glazed:  # the hit point from the distance (the passes through panes lose Embree's uv)
        j = locator(o[hit] + dist[hit, None] * dirs[hit], th)
    else:
        j = locator(None, th, uv[hit])
    keep = j >= 0
    key = recv[keep] * patches.n + j[keep]
    if glazed:
        uniq, inverse = np.unique(key, return_inverse=True)
        counts = np.bincount(inverse.ravel(), weights=carried[hit][keep], minlength=len(uniq))
    else:
        uniq, counts = np.unique(key, return_counts=True)
    r = (uniq // patches.n).astype(np.int32)
    weight = (patches.area[r] * counts / n_rays).astype(np.float32)
    return r, (uniq % patches.n).astype(np.int32), weight, dict(rays=len(o), ray_s=ray_s)


def build_sampled(
    patches: Patches,
    triangles: Float[np.ndarray, "tri 3 3"],
    settings: SampledSettings | None = None,
    *,
    caster=None,
    dtype=np.float32,
    progress: Callable[[int, int], None] | None = None,
    batches: Callable | None = None,
    threads: int | None = None,
) -> TransportOperator:
    """The ray-sampled transport operator of ``patches`` (module docstring).

    Parameters
    ----------
    patches
        From :func:`~lumijax.radiosity.mesh_patches`, cut from ``triangles``.
    triangles
        The scene's triangles ``(T, 3, 3)``, m: every one occludes, and a hit is mapped to the
        patch of its triangle that holds it (:class:`PatchLocator`).
    caster
        A :class:`~lumijax.scene.RayCaster` of ``triangles`` already built (else one is).
    settings
        :class:`SampledSettings`.
    dtype
        Storage of the weights (float32 or float64).
    progress
        Called with (patches done, patches) after every batch.
    batches
        Optional runner ``batches(fn, [(start, stop), ...]) -> [result, ...]`` for the batch
        function ``fn(start, stop)``; default: the current executor
        (:func:`~lumijax.parallel.current_executor`): on a Dask cluster every batch is a task
        (the patches, locator and caster sent once per worker, the Embree scene built once
        there), here they run on ``threads`` threads (default: every CPU this process may
        use; :func:`~lumijax.parallel.threaded_map`). The links are the same either way, bit
        for bit: a batch depends only on its own span and the seed.
    threads
        Batches traced at once here (1: one after another).
    """
    from ..scene._raycast import RayCaster

    s = settings or SampledSettings()
    triangles = np.asarray(triangles, np.float64)
    caster = RayCaster(triangles) if caster is None else caster
    t0 = time.perf_counter()
    front = np.zeros((max(caster.n_triangles, 1), 3))
    front[np.asarray(patches.source_triangle)] = patches.normal
    locator = PatchLocator(patches, triangles)
    spans = [(a, min(a + s.batch, patches.n)) for a in range(0, patches.n, s.batch)]

    def one(a, b):
        return sample_batch(patches, caster, a, b, s, locator, front)

    from ..parallel import current_executor, threaded_map

    ex = current_executor()
    if batches is not None:
        parts = list(batches(one, spans))
    elif ex.distributed and len(spans) > 1:
        parts = []
        for (_, b), part in zip(spans, ex.map(_batch_task, spans, shared=dict(
                patches=patches, caster=caster, settings=s, locator=locator, front=front)),
                                strict=True):
            parts.append(part)
            if progress is not None:
                progress(b, patches.n)
    else:  # here: Embree and NumPy release the GIL, so batches overlap on threads
        parts = []
        for (_, b), part in zip(spans, threaded_map(lambda span: one(*span), spans, threads),
                                strict=True):
            parts.append(part)
            if progress is not None:
                progress(b, patches.n)
    n = int(sum(len(p[0]) for p in parts))
    chunk = max(1, min(_STEP, n))
    total = -(-max(n, 1) // chunk) * chunk
    recv = np.full(total, patches.n, np.int32)  # padding: the zero patch, weight 0
    src = np.full(total, patches.n, np.int32)
    weight = np.zeros(total, dtype)
    k = 0
    for r, c, w, _ in parts:
        recv[k:k + len(r)], src[k:k + len(r)], weight[k:k + len(r)] = r, c, w
        k += len(r)
    rays = int(sum(p[3]["rays"] for p in parts))
    ray_s = float(sum(p[3]["ray_s"] for p in parts))
    del parts
    bucket = SampledBucket(jnp.asarray(weight), jnp.asarray(recv), jnp.asarray(src),
                           chunk=chunk)
    build_s = time.perf_counter() - t0
    info = Info(patches=patches.n, blocks=1, transport="sampled", links=n,
                links_per_patch=n / max(patches.n, 1), rays=rays, ray_time_s=ray_s,
                build_time_s=build_s, rays_per_s=rays / build_s if build_s > 0 else 0.0,
                settings=dataclasses.asdict(s))
    area = jnp.asarray(patches.area, dtype=jnp.float64 if jax.config.jax_enable_x64 else None)
    return TransportOperator((bucket,), area, jnp.zeros(patches.n, jnp.int32), patches.n, 1,
                             info)


def _batch_task(span, *, patches, caster, settings, locator, front):
    """One batch of :func:`build_sampled` on a cluster's worker."""
    return sample_batch(patches, caster, span[0], span[1], settings, locator, front)


def sampled_bytes(n_patches: int, rays_per_patch: int) -> int:
    """Upper bound of the stored links (bytes): every ray a distinct link."""
    return int(LINK_BYTES * n_patches * rays_per_patch)
