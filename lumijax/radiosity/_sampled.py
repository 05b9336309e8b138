"""Ray-sampled form factors (stochastic radiosity, Neumann; Bekaert): ``[solver] transport =
"sampled"``.

Each patch i casts N rays (``rays_per_patch``) from stratified points on its surface in
stratified cosine-weighted directions; a ray whose first hit is the front of patch j is one
hit, and ``F_ij ≈ hits(i → j) / N``. This is an unbiased estimate of the area-averaged form
factor with exact visibility (a column's shadow, a recess, a back face all come from the ray
itself), and it needs memory for the links only: at most N per patch, usually far fewer after
duplicates are merged, O(P·N) where the block operator of an open scene is O(P²).

Given where the direct light lies (``bright=``), a share of each patch's rays is aimed at the
lit patches instead and every sample weighs its multiple-importance weight, not 1/N
(``_bright.py``): still unbiased for any radiosity, far less noisy where the first bounce comes
from pools of light (a room at 256 rays: 15 % → 1.5 % RMS per patch).

The sampled F is fixed once cast (fixed seed), so the radiosity system stays linear and its
implicit derivative is the one of the block operator: the links are a :class:`SampledBucket`
of a :class:`TransportOperator` (``G = A F``, stored directed since the two estimates of a
pair differ), and the solve, the cache, ``replace_luminaire`` and the optimiser see the same
object. With cosine rays only, rows never sum above 1 (N rays, at most N hits), and a closed
room's rows sum to exactly 1 minus the rays that met a back face; aimed rays make each row an
unbiased estimate of Σ_j F_ij that may pass 1 by its noise, which the solve's row correction
takes back to 1 (docs/radiosity.md, "Row sums").

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

from .. import _executables
from .._jit_cache import size_class, to_device
from ..errors import GeometryError, SolveError
from ._bright import BrightPatches, aimed_rays, aimed_samples, balance_weight
from ._gather import _cosine_directions, _frames, merged_links
from ._links import LinkPacker
from ._operator import Info, SampledBucket, TransportOperator
from ._patches import Patches

__all__ = ["SampledSettings", "PatchLocator", "sample_batch", "build_sampled", "front_normals"]

#: Hits per call of the gather's patch lookup (:meth:`PatchLocator.__call__`): one compiled
#: shape; a call takes ~1 ms, a shape more ~0.25 s to compile in a new study's first run.
_LOOKUP_ROWS = 1 << 16

_R2 = 1.32471795724474602596  # plastic number: the R2 low-discrepancy sequence's generator


@dataclass(frozen=True)
class SampledSettings:
    """Knobs of :func:`build_sampled` (hashable: part of the operator's cache key)."""

    rays_per_patch: int = 256
    """Rays cast from each patch; the per-patch noise of a bounce falls like N^(-1/2) or
    faster (stratified), the memory grows at most like N."""
    seed: int = 0
    """Seed of the per-patch rotations and shifts of the stratified pattern."""
    aimed_share: float = 0.25
    """Share of each patch's rays aimed at bright patches when :func:`build_sampled` is given
    a proposal (``bright=``; ``_bright.py``); none without one. In the furnished room at 256
    rays 0.25 took the inter-reflected light's noise per patch from 14.6 % to 1.5 % RMS
    (docs/radiosity.md, "Aimed rays"); a larger share spends more rays on pools a patch may
    not see, and the cosine rays must be left to cover every direction."""
    batch: int = 2048
    """Patches per batch (one Embree query of batch × rays rays). Part of the key: a batch's
    random turns are drawn from (seed, first patch of the batch). 2048 × 256 rays keeps a
    batch's arrays in the last-level cache's reach: the 1.9·10⁵-patch courtyard built in
    13.0 s against 15.2 s with 8192 (2 threads, benchmarks/RESULTS.md)."""

    def __post_init__(self) -> None:
        if not 0.0 <= self.aimed_share <= 0.9:
            raise SolveError(f"aimed_share must lie in [0, 0.9] (the rest of a patch's rays stay "
                             f"cosine-weighted, covering every direction), not {self.aimed_share!r}")


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
        self.leaf_patch, self.n_internal, self.height = np.full(1, -1, np.int64), 0, 0
        if len(cand):
            self._tree(cand, src, index)
        # how each triangle is cut, one gather a lookup: 0 no patch, 1 one patch, 2 the grid,
        # 3 bisected, 4 neither (the nearest patch centroid)
        self.kind = np.select([self.count == 0, self.count == 1, self.grid, self.bisected],
                              [0, 1, 2, 3], 4).astype(np.int8)

    def _tree(self, cand, src, index) -> None:
        p = self.patches
        code = np.concatenate(list(_halves(  # NumPy's loops release the GIL: two at once
            lambda sl: self._replay(p.centroid[cand[sl]], src[cand[sl]],
                                    target=p.vertices[cand[sl]]), len(cand))))
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
        cut = np.concatenate(list(_halves(lambda sl: self._node_cuts(nt[sl], nc[sl]),
                                          len(nt))))
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
        # descent takes the same steps for every point (_patch_of), none compacted.
        n_int, n_leaf = len(node_key), len(leaf_key)
        absorbing = np.arange(n_int, n_int + n_leaf + 1)
        child = np.where(child == -2, n_int + n_leaf, child)
        self.leaf_patch = np.concatenate([leaf_patch, [-1]]).astype(np.int64)
        self.n_internal = n_int
        # float32 as Embree's (u, v): the side test is no sharper than its input
        self.cut = np.concatenate([cut, np.tile([1.0, 0.0, 0.0], (n_leaf + 1, 1))]).astype(
            np.float32).T.copy()
        self.child = np.concatenate([child, np.stack([absorbing, absorbing], 1)]).ravel()
        self.height = int(np.floor(np.log2(lc)).max())  # steps from a root to its deepest leaf
        roots = nc == 1
        self.root[nt[roots]] = np.flatnonzero(roots)
        self.bisected = good & (self.root >= 0)

    def _node_cuts(self, nt, nc):
        """Each node's cut (c0, c1, c2) in the barycentrics of its triangle ``nt``: its
        prefix ``nc`` replayed from the root."""
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
        return np.stack([np.einsum("ij,ij->i", t0[:, 0] - m, w),
                         np.einsum("ij,ij->i", t0[:, 1] - t0[:, 0], w),
                         np.einsum("ij,ij->i", t0[:, 2] - t0[:, 0], w)], axis=1)

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

    def tables(self) -> dict:
        """The lookup's arrays on the default device (made once; :func:`_patch_of`).

        Each is padded to its size class (:func:`~lumijax.radiosity._solve.patch_bucket`: at
        most an eighth more above 4,096 rows), the triangles' with "no patch" rows, the
        nodes' and leaves' with rows no root reaches: the compiled lookup depends on the
        shapes only, so meshes of about the same size — a room remeshed a little finer, a
        new room like the last — share one program instead of compiling their own (~0.2-0.3 s
        each)."""
        from ._solve import patch_bucket

        t = self.__dict__.get("_tables")
        if t is None:
            last = max(len(self.leaf_patch) - 1, 0)  # the "none" node: any point stays, finds −1
            rows = patch_bucket(max(len(self.kind), 1))

            def per_triangle(a, fill):
                return jnp.asarray(_padded(np.asarray(a, np.int32), rows, fill))

            node = self._packed()
            t = self._tables = dict(
                kind=per_triangle(self.kind, 0), first=per_triangle(self.first, 0),
                n=per_triangle(self.n, 0),
                root=per_triangle(np.where(self.root >= 0, self.root, self.n_internal + last),
                                  self.n_internal + last),
                node=jnp.asarray(_padded(node, patch_bucket(len(node)), 0.0)),
                leaf=jnp.asarray(_padded(self.leaf_patch.astype(np.int32),
                                         patch_bucket(len(self.leaf_patch)), -1)),
                n_internal=jnp.asarray(self.n_internal, jnp.int32),
                height=jnp.asarray(self.height, jnp.int32))
        return t

    def _packed(self) -> np.ndarray:
        """One row of 8 float32 a node, half a cache line: its cut (c0, c1, c2) and, as the
        bits of int32, its two children; a descent step then costs one memory access, not
        five (at 1.6·10⁶ patches the tree no longer fits in the cache)."""
        cut = self.cut if self.cut.size else np.array([[1.0], [0.0], [0.0]], np.float32)
        child = (self.child if self.child.size else np.zeros(2)).reshape(-1, 2)
        rows = np.zeros((cut.shape[1], 8), np.float32)
        rows[:, :3] = cut.T
        rows[:, 3:5] = child.astype(np.int32).view(np.float32)
        return rows

    def __getstate__(self):  # device arrays stay where they were made (a worker makes its own)
        return {k: v for k, v in self.__dict__.items() if k != "_tables"}

    def __call__(self, points: Float[np.ndarray, "k 3"] | None,
                 tri: Int[np.ndarray, " k"],
                 uv: Float[np.ndarray, "k 2"] | None = None) -> Int[np.ndarray, " k"]:
        """The patch holding each point of triangle ``tri`` (−1: a triangle with no patch).

        The points are given as positions (m), or as barycentric ``uv`` in their triangle (a
        ray caster's :meth:`~lumijax.scene.RayCaster.first_hit_uv`), or both."""
        tri = np.asarray(tri, np.int64)
        k = len(tri)
        if uv is None:
            uv = self._uv(points, tri) if k else np.zeros((0, 2))
        # in calls of one size, whatever the query's: the compiled lookup then depends on the
        # mesh's size class alone, and a new study's gather finds it stored
        t, w = tri.astype(np.int32), np.asarray(uv, np.float32)
        parts = [np.asarray(_lookup(_padded(t[a:a + _LOOKUP_ROWS], _LOOKUP_ROWS, -1),
                                    _padded(w[a:a + _LOOKUP_ROWS], _LOOKUP_ROWS, 0.0),
                                    self.tables()))[:min(_LOOKUP_ROWS, k - a)]
                 for a in range(0, k, _LOOKUP_ROWS)]
        out = np.concatenate(parts).astype(np.int64) if parts else np.zeros(0, np.int64)
        return self._resolve(out, points, tri, uv)

    def front_hits(self, tri: Int[np.ndarray, " k"], uv: Float[np.ndarray, "k 2"],
                   dirs: Float[np.ndarray, "k 3"], front: Float[np.ndarray, "tri 3"],
                   at_least: int = 0) -> Int[np.ndarray, " k"]:
        """The patch each ray of a :meth:`~lumijax.scene.RayCaster.first_hit_local` query hit
        (triangle ``tri``, −1 none; its ``uv``; the rays' ``dirs``), −1 where it met no patch
        or the back of one (``front``: each triangle's front normal). The query is padded to
        a power of two of at least ``at_least`` rays (one compiled shape for every batch)."""
        k = len(tri)
        size = size_class(max(k, at_least), 1024)
        t = _padded(np.asarray(tri, np.int32), size, -1)
        w = _padded(np.asarray(uv, np.float32), size, 0.0)
        d = _padded(np.asarray(dirs, np.float32), size, 0.0)
        front = np.asarray(front, np.float32)
        if len(front) < len(self.tables()["kind"]):  # build_sampled makes it this long
            front = _padded(front, len(self.tables()["kind"]), 0.0)
        out = np.asarray(_front_hits(t, w, d, front, self.tables()))[:k]
        return self._resolve(out.astype(np.int64), None, np.asarray(tri, np.int64), uv)

    def _resolve(self, out, points, tri, uv):
        """The hits :func:`_patch_of` leaves at −2 (no grid or tree fits their triangle) by
        the nearest patch centroid of their triangle."""
        from ._gather import patch_of_hits

        miss = np.flatnonzero(out == -2)
        if len(miss):
            pts = points[miss] if points is not None else self._point(tri[miss], uv[miss])
            out[miss] = patch_of_hits(self.patches, pts, tri[miss])
        return out

    def _point(self, tri, uv):
        t = self.triangles[tri]
        uv = np.asarray(uv, np.float64)
        return t[:, 0] + uv[:, :1] * (t[:, 1] - t[:, 0]) + uv[:, 1:] * (t[:, 2] - t[:, 0])


def _padded(a: np.ndarray, size: int, fill) -> np.ndarray:
    """``a`` grown to ``size`` rows of ``fill`` (``a`` itself when it has them: no copy)."""
    if len(a) == size:
        return a
    out = np.full((size, *a.shape[1:]), fill, a.dtype)
    out[:len(a)] = a
    return out


def _halves(fn, n: int):
    """``fn(slice)`` of the two halves of ``range(n)``, on two threads (one if n is small)."""
    from ..parallel import threaded_map

    cut = n // 2
    spans = [slice(0, cut), slice(cut, n)] if n >= 4096 else [slice(0, n)]
    return threaded_map(fn, spans, threads=min(2, len(spans)))


def _patch_of(tri, uv, tables):
    """The patch holding each hit (triangle ``tri``, −1 none; barycentric ``uv``, float32):
    −1 where none, −2 where only the nearest centroid can tell (:meth:`PatchLocator._resolve`).

    Every hit takes every branch (one patch, the grid of n², ``tables["height"]`` steps down
    the bisection tree), fused in one XLA loop: 3× the NumPy version, whose compactions and
    scattered writes cost more than the arithmetic. The height is a traced value, not a
    static one, so that one compiled program serves every mesh whose tables fall in the same
    size class (:meth:`PatchLocator.tables`)."""
    t = jnp.maximum(tri, 0)
    u, v = uv[:, 0], uv[:, 1]
    kind, first, n = tables["kind"][t], tables["first"][t], tables["n"][t]
    nf = n.astype(jnp.float32)
    un, vn = u * nf, v * nf
    a = jnp.clip(jnp.floor(un), 0, nf - 1)
    b = jnp.clip(jnp.floor(vn), 0, nf - 1 - a)
    down = (un - a + vn - b > 1.0) & (a + b <= nf - 2)
    a, b = a.astype(jnp.int32), b.astype(jnp.int32)
    grid = first + 2 * a * n - a * a + 2 * b + down.astype(jnp.int32)
    table = tables["node"]

    def step(_, node):
        row = table[node]
        second = row[:, 0] + row[:, 1] * u + row[:, 2] * v < 0
        child = jax.lax.bitcast_convert_type(row[:, 3:5], jnp.int32)
        return jnp.where(second, child[:, 1], child[:, 0])

    node = jax.lax.fori_loop(0, tables["height"], step, tables["root"][t])
    leaf = tables["leaf"][node - tables["n_internal"]]
    found = jnp.select([kind == 1, kind == 2, kind == 3], [first, grid, jnp.where(
        leaf >= 0, leaf, -2)], jnp.where(kind == 4, -2, -1))
    return jnp.where(tri >= 0, found, -1)


@_executables.stored("patch_lookup", "radiosity/_sampled.py")
def _lookup(tri, uv, tables):
    # kept across processes: a small study's gather calls it once, where tracing and lowering
    # would be most of its cost
    return _patch_of(tri, uv, tables)


@jax.jit
def _front_hits(tri, uv, dirs, front, tables):
    """:func:`_patch_of` of the hits on a front face; −1 for a miss or a back face (a ray
    meeting a back face is blocked: surfaces are one-sided)."""
    facing = jnp.einsum("ij,ij->i", dirs, front[jnp.maximum(tri, 0)]) < 0
    return jnp.where(facing, _patch_of(tri, uv, tables), -1)


def _rays(vertices, frames, local, shift, lift: float, centre, nudge: float, size: int = 0):
    """The rays of a batch in a ray caster's own terms (float32, :meth:`~lumijax.scene.
    RayCaster.first_hit_local`): ``(starts, directions)``, each ``(p · rays, 3)``; made for
    at least ``size`` patches (a short last batch is padded, so every batch of a build, and
    of any other study with the same batch and rays, runs one compiled kernel).

    The directions are ``frame @ local`` (unit, cosine-weighted about each patch's normal, the
    frame's z column); the starts are ``rays`` stratified points on each patch — the R2
    sequence shifted per patch, folded into the triangle (uniform in area) — lifted ``lift``
    (m) along the normal, re-centred on ``centre`` and nudged ``nudge`` (m) along the ray.
    The per-patch terms are re-centred in float64 here, the per-ray ones made in one fused
    XLA loop in float32 (the precision Embree takes them in): 3× NumPy's passes."""
    v0 = np.asarray(vertices[:, 0], np.float64)
    base = (v0 + lift * frames[:, :, 2] - centre).astype(np.float32)
    edges = (np.asarray(vertices[:, 1:], np.float64) - v0[:, None]).astype(np.float32)
    k = np.arange(len(local)) + 0.5
    seq = np.stack([k / _R2, k / _R2**2], axis=1) % 1.0  # R2 in float64: k/R2 grows with k
    p, grow = len(base), max(size - len(base), 0)
    frames, shift = np.asarray(frames, np.float32), np.asarray(shift, np.float32)
    if grow:
        base, edges, frames, shift = (np.concatenate([a, np.zeros((grow, *a.shape[1:]),
                                                                  a.dtype)])
                                      for a in (base, edges, frames, shift))
    starts, dirs = _ray_kernel(base, edges, frames, np.asarray(local, np.float32),
                               seq.astype(np.float32), shift, np.float32(nudge))
    n = p * len(local)  # views of the kernel's buffers (Embree reads them in place)
    return np.asarray(starts)[:n], np.asarray(dirs)[:n]


@jax.jit
def _ray_kernel(base, edges, frames, local, seq, shift, nudge):
    u, v = seq[:, 0] + shift[:, :1], seq[:, 1] + shift[:, 1:]
    u, v = jnp.where(u >= 1.0, u - 1.0, u), jnp.where(v >= 1.0, v - 1.0, v)
    fold = u + v > 1.0
    u, v = jnp.where(fold, 1.0 - u, u), jnp.where(fold, 1.0 - v, v)
    dirs = jnp.einsum("pck,rk->prc", frames, local)
    starts = (base[:, None] + u[..., None] * edges[:, None, 0] + v[..., None] * edges[:, None, 1]
              + nudge * dirs)
    return starts.reshape(-1, 3), dirs.reshape(-1, 3)


def sample_batch(
    patches: Patches,
    caster,
    start: int,
    stop: int,
    settings: SampledSettings,
    locator: PatchLocator,
    front: Float[np.ndarray, "tri 3"],
    bright: BrightPatches | None = None,
) -> tuple[Int[np.ndarray, " k"], Int[np.ndarray, " k"], Float[np.ndarray, " k"], dict]:
    """The links of patches ``start..stop``: ``(recv, src, weight, counts)``.

    ``weight = A_i · hits / N`` (m², float32), sorted by receiver then sender, duplicates
    merged; ``counts`` has ``rays`` and ``ray_s`` (time in Embree). ``front``: each triangle's
    front normal (a ray meeting a back face is blocked and carries nothing: surfaces are
    one-sided). With clear glass (a :class:`~lumijax.scene.GlazedCaster`) a ray passes every
    pane it meets and its hit behind counts τ(θ) of each pane crossed, not 1 (module
    docstring). With ``bright`` a share of the rays is aimed at bright patches and every hit
    weighs its balance-heuristic weight, not 1/N (``_bright.py``). Depends only on its
    arguments, so batches can run anywhere in any order.
    """
    n_aim = aimed_rays(settings.rays_per_patch, settings.aimed_share, bright)
    n_rays = settings.rays_per_patch - n_aim
    rng = np.random.default_rng((settings.seed, start))
    frames = _frames(np.asarray(patches.normal[start:stop], np.float64), rng)
    # a fixed shuffle pairs the spatial and the directional strata without correlation
    local = _cosine_directions(n_rays)[np.random.default_rng(settings.seed).permutation(n_rays)]
    centre, nudge = np.asarray(caster.origin, np.float64), float(caster.epsilon)
    o, dirs = _rays(patches.vertices[start:stop], frames, local,
                    rng.uniform(size=(stop - start, 2)), 10.0 * nudge, centre, nudge,
                    size=settings.batch)
    glazed = getattr(caster, "glazing_key", None) is not None
    t = time.perf_counter()
    hit, j, dist, carried = _front_patches(caster, locator, front, o, dirs, centre, glazed,
                                           at_least=settings.batch * n_rays)
    ray_s = time.perf_counter() - t
    recv = hit // n_rays + start
    rays = len(o)
    if bright is None:  # every hit 1/N (τ of the panes it crossed with clear glass)
        uniq, counts = merged_links(recv * patches.n + j, carried)
        r = (uniq // patches.n).astype(np.int32)
        weight = (patches.area[r] * counts / n_rays).astype(np.float32)
        return r, (uniq % patches.n).astype(np.int32), weight, dict(rays=rays, ray_s=ray_s)
    w = balance_weight(local[hit % n_rays, 2], -np.einsum("ij,ij->i", dirs[hit], patches.normal[j]),
                       dist, n_rays, n_aim, bright.density[j])
    ar, asrc, x, u, d, ci, cj = aimed_samples(patches, start, stop, n_aim, bright,
                                              np.random.default_rng((settings.seed, start, 1)),
                                              10.0 * nudge)
    t = time.perf_counter()
    if glazed:  # the first hit beyond the panes, as the cosine rays see it (a pane's own patch
        # is never reached: the cosine rays pass it too)
        seen, k, _, through = _front_patches(caster, locator, front,
                                             (x - centre + nudge * u).astype(np.float32),
                                             u.astype(np.float32), centre, True,
                                             at_least=settings.batch * n_aim)
        reached = k == asrc[seen]  # the aimed point itself, not what stands before it
        seen = seen[reached]
        w = w * carried
    else:  # only whether the segment to the aimed point is clear: Embree's occlusion query,
        # which stops at the point or the first blocker and needs no patch lookup
        seen = np.flatnonzero(~caster.occluded_along(x, u, d))
    ray_s += time.perf_counter() - t
    rays += len(x)
    wa = balance_weight(ci[seen], cj[seen], d[seen], n_rays, n_aim, bright.density[asrc[seen]])
    if glazed:
        wa = wa * through[reached]
    key = np.concatenate([recv * patches.n + j, ar[seen] * patches.n + asrc[seen]])
    uniq, sums = merged_links(key, np.concatenate([w, wa]))
    r = (uniq // patches.n).astype(np.int32)
    weight = (patches.area[r] * sums).astype(np.float32)
    return r, (uniq % patches.n).astype(np.int32), weight, dict(rays=rays, ray_s=ray_s)


def _front_patches(caster, locator, front, o, dirs, centre, glazed: bool, at_least: int):
    """The rays ``(o, dirs)`` (a caster's own terms: float32, re-centred, nudged) that meet the
    front of a patch: ``(ray, patch, distance, carried)`` — carried τ of the panes crossed
    with clear glass, else None."""
    if glazed:  # clear panes pass the ray on to what lies behind, carrying τ(θ) of each
        o, dirs = o + centre, dirs.astype(np.float64)  # in the caster's public terms
        tri, dist, carried = caster.first_hit_through(o, dirs)
        # the hit point from the distance (the passes through panes lose Embree's uv)
        hit = np.flatnonzero(tri >= 0)
        hit = hit[np.einsum("ij,ij->i", dirs[hit], front[tri[hit]]) < 0]
        j = locator(o[hit] + dist[hit, None] * dirs[hit], tri[hit])
        keep = j >= 0
        hit, j = hit[keep], j[keep]
        return hit, j, np.asarray(dist[hit], np.float64), carried[hit]
    tri, dist, uv = caster.first_hit_local(o, dirs)
    j = locator.front_hits(tri, uv, dirs, front, at_least=at_least)
    hit = np.flatnonzero(j >= 0)
    return hit, j[hit], np.asarray(dist[hit], np.float64), None


def front_normals(patches: Patches, caster, locator: PatchLocator) -> Float[np.ndarray, "tri 3"]:
    """Each triangle's front normal, as :func:`sample_batch` takes them: float32 like the rays'
    directions and as long as the lookup's padded tables (no copy a batch)."""
    front = np.zeros((max(caster.n_triangles, len(locator.tables()["kind"])), 3), np.float32)
    front[np.asarray(patches.source_triangle)] = patches.normal
    return front


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
    bright: BrightPatches | None = None,
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
        The operator's precision: float32 stores each weight in float16 under a scale a
        patch, float64 in float64 (``_links.py``).
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
    bright
        Where the direct light lies (:func:`~lumijax.radiosity.bright_patches`): a share
        ``settings.aimed_share`` of each patch's rays is aimed there and every sample weighs
        its multiple-importance weight (``_bright.py``); None: cosine-weighted rays only.
    """
    from ..scene._raycast import RayCaster

    s = settings or SampledSettings()
    triangles = np.asarray(triangles, np.float64)
    caster = RayCaster(triangles) if caster is None else caster
    t0 = time.perf_counter()
    locator = PatchLocator(patches, triangles)
    front = front_normals(patches, caster, locator)
    spans = [(a, min(a + s.batch, patches.n)) for a in range(0, patches.n, s.batch)]

    def one(a, b):
        return sample_batch(patches, caster, a, b, s, locator, front, bright)

    from ..parallel import current_executor, threaded_map

    ex = current_executor()
    if batches is not None:
        parts = batches(one, spans)
    elif ex.distributed and len(spans) > 1:
        parts = ex.map(_batch_task, spans, shared=dict(
            patches=patches, caster=caster, settings=s, locator=locator, front=front,
            bright=bright))
    else:  # here: Embree and NumPy release the GIL, so batches overlap on threads
        parts = threaded_map(lambda span: one(*span), spans, threads)
    from ._estimate import available_memory_bytes
    from ._links import link_bytes

    # The links are written in their stored form as the batches arrive, while the next ones
    # trace (no serial tail of copies: at 1.9·10⁵ patches that tail was 0.9–3.8 s, mostly
    # first touches of fresh memory, ~3 ms a MiB on this project's VM), into arrays reserved
    # for every ray a link or what memory holds where that is less (``auto`` bounds its
    # build by the links a ray measured). A cosine ray's hit weighs A_i / (cosine rays): with
    # that unit the stored values are whole hit counts.
    cosine = s.rays_per_patch - aimed_rays(s.rays_per_patch, s.aimed_share, bright)
    most = min(patches.n * s.rays_per_patch,
               available_memory_bytes() // link_bytes(np.dtype(dtype).itemsize))
    links = LinkPacker(most, patches.n, dtype,
                       unit=np.asarray(patches.area, np.float64) / max(cosine, 1))
    rays, ray_s = 0, 0.0
    for (_, b), (r, c, w, counts) in zip(spans, parts, strict=True):
        links.add(r, c, w)
        rays, ray_s = rays + int(counts["rays"]), ray_s + float(counts["ray_s"])
        if progress is not None:
            progress(b, patches.n)
    n = links.links
    *arrays, chunk = links.packed()
    bucket = SampledBucket(*(to_device(a) for a in arrays), chunk=chunk)
    build_s = time.perf_counter() - t0
    info = Info(patches=patches.n, blocks=1, transport="sampled", links=n,
                links_per_patch=n / max(patches.n, 1), rays=rays, ray_time_s=ray_s,
                build_time_s=build_s, rays_per_s=rays / build_s if build_s > 0 else 0.0,
                settings=dataclasses.asdict(s) | {"aimed_rays": aimed_rays(
                    s.rays_per_patch, s.aimed_share, bright)})
    area = jnp.asarray(patches.area, dtype=jnp.float64 if jax.config.jax_enable_x64 else None)
    return TransportOperator((bucket,), area, jnp.zeros(patches.n, jnp.int32), patches.n, 1,
                             info)


def _batch_task(span, *, patches, caster, settings, locator, front, bright=None):
    """One batch of :func:`build_sampled` on a cluster's worker."""
    return sample_batch(patches, caster, span[0], span[1], settings, locator, front, bright)
