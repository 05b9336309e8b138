"""Building the transport operator: form factors for every visible block pair.

Per patch pair, by the centre distance d relative to the larger patch diameter (r = d / diam):

* **far** (r ≥ ``near_ratio``): the reciprocal point-to-point kernel with a second-order
  finite-area correction (:func:`form_factor_far`, :func:`far_g`) times one centroid-to-centroid
  shadow ray;
* **near** (r < ``near_ratio``): Lambert's contour integral from receiver quadrature points to the
  horizon-clipped source triangle (exact in the source), averaged over the receiver's
  sub-triangle centroids (``mid_subdiv``², or ``close_subdiv``² when r < ``close_ratio``:
  neighbours sharing an edge), computed both ways and symmetrised, times the fraction of
  unblocked rays between the two patches' quadrature points — or, where those rays disagree (a
  shadow edge crosses the pair), the light of a ray from each receiver point to each of the
  source's (≤ 4) points, weighed by where the factor lies (:func:`_shadowed_view`).

Why this choice, with numbers, is in ``docs/radiosity.md``.
"""

from __future__ import annotations

import dataclasses
import time
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .. import _executables
from .._jit_cache import to_device
from ..kernels import (
    far_g,
    form_factor_point_front_triangle,
    form_factor_point_triangle,
    rounding_length,
    triangle_spread,
)
from ..parallel import Executor, batches, current_executor, threaded_map
from ._hierarchy import cluster_tree, walk_block_tree
from ._lowrank import Obstacles, aca_block, block_spheres, truncate_block, well_separated
from ._operator import DENSE_PATCHES, Bucket, Info, LowRankBucket, TransportOperator
from ._partition import Partition
from ._patches import Patches, _template

__all__ = ["FormFactorSettings", "build_operator"]


@dataclasses.dataclass(frozen=True)
class FormFactorSettings:
    """Accuracy knobs of :func:`build_operator` (hashable: part of the operator's cache key)."""

    near_ratio: float = 4.0
    """Pairs closer than this many (larger) patch diameters use the analytic contour integral."""
    close_ratio: float = 1.5
    """Pairs closer than this (neighbours) get the dense receiver quadrature."""
    mid_subdiv: int = 2
    """Receiver quadrature for near pairs: centroids of mid_subdiv² sub-triangles."""
    close_subdiv: int = 4
    """Receiver quadrature for neighbours: close_subdiv² points."""
    mid_rays: int = 4
    """Shadow rays per near pair (between quadrature points)."""
    close_rays: int = 16
    """Shadow rays per neighbour pair."""
    symmetrise: bool = True
    """Average A_i F_ij and A_j F_ji for near pairs (exact reciprocity; halves quadrature bias)."""
    max_bytes_per_step: int = 1 << 26
    """Block data per step of a product (chunking of the scan; memory, not accuracy)."""
    lowrank: bool = True
    """Compress well-separated cluster pairs to ``U Vᵀ`` (see ``_lowrank.py``)."""
    hierarchical: bool = True
    """Offer whole clusters of blocks for compression (an H-matrix, ``_hierarchy.py``), not only
    single block pairs: what makes the far field's memory near-linear in patches."""
    lowrank_eta: float = 1.5
    """Well separated: gap between the bounding spheres > eta × the larger radius."""
    lowrank_tol: float = 1e-3
    """Relative Frobenius error of each compressed block."""
    lowrank_max_fraction: float = 0.5
    """Keep a pair dense unless its factors take at most this fraction of the dense block."""
    lowrank_max_rank: int = 128
    """Largest rank tried for one pair; a cluster pair that needs more is split."""
    lowrank_shadowed: bool = True
    """Also compress well-separated pairs that may be shadowed: ACA with a shadow ray for every
    entry it visits, accepted on its exact error over every entry; a leaf pair that fails is
    computed dense and truncated by SVD with its exact error (see ``docs/radiosity.md``)."""


#: Relative margin of the near/far and close/mid choices. A regular mesh puts many pairs exactly
#: at a threshold (centres 4 diameters apart), and at site coordinates their distance carries
#: 10⁻⁹ m of rounding: without a margin the same pair is near at the origin and far at 5·10⁶ m
#: (0.2 % apart in that entry). Ties go to the more accurate (near, close) rule.
_TIE = 1e-7

_LADDER = np.array([8 * round(32 * 2 ** (k / 2) / 8) for k in range(24)])


def _pad(n: int | np.integer) -> int:
    """Padded block size: next rung of a √2 ladder (≤ 41 % padding per side)."""
    return int(_LADDER[np.searchsorted(_LADDER, n)])


_RANKS = np.array([4, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512, 768, 1024, 1536])


def _pad_rank(r: int | np.integer) -> int:
    return int(_RANKS[np.searchsorted(_RANKS, r)]) if r <= _RANKS[-1] else int(r)


def _chunking(n: int, per_pair: int, max_bytes: int) -> tuple[int, int]:
    """(pairs per scan step, total padded pairs) for n pairs of per_pair bytes each."""
    chunk = int(max(1, min(n, max_bytes // per_pair)))
    steps = -(-n // chunk)
    chunk = -(-n // steps)
    return chunk, steps * chunk


def _far_field(patches, part, s: FormFactorSettings, caster, triangles, diam, counters, spread,
               dtype):
    """Walk the block tree: ``(far, near, dense)``.

    ``far``: ``(receivers, sources, U, V)`` low-rank leaves; ``near``: block pairs ``(a, b)``,
    ``a ≤ b``, to store dense; ``dense``: those of them whose block was already computed (a
    shadowed leaf pair whose SVD rank was over the cap), by pair.
    """
    t0 = time.perf_counter()
    visible = np.zeros((part.n_blocks,) * 2, bool)
    visible[part.pairs[:, 0], part.pairs[:, 1]] = True
    visible |= visible.T
    for key in ("lowrank_candidates", "lowrank_mixed", "lowrank_rank_cap", "lowrank_shadowed"):
        counters[key] = 0
    dense: dict[tuple[int, int], np.ndarray] = {}
    if not s.lowrank or part.n_blocks == 0:
        return [], [tuple(map(int, p)) for p in part.pairs], dense
    obstacles = Obstacles(triangles) if triangles is not None else None
    centre, radius = block_spheres(patches, part)
    dmax = np.maximum.reduceat(diam[part.members], part.offsets[:-1])
    root = cluster_tree(part, centre, radius, dmax)

    def admissible(a, b):
        return (s.hierarchical or (a.leaf and b.leaf)) and well_separated(
            a, b, s.lowrank_eta, s.near_ratio)

    def compress(a, b):
        counters["lowrank_candidates"] += 1
        ia, ib = a.patches, b.patches
        m, n = len(ia), len(ib)
        cap = min(s.lowrank_max_rank, int(s.lowrank_max_fraction * m * n / (m + n)))
        clear = caster is None or (obstacles is not None and obstacles.clear(a.lo, a.hi, b.lo, b.hi))
        if not clear:
            counters["lowrank_mixed"] += 1
            if not s.lowrank_shadowed:
                return None
        res = aca_block(
            patches.centroid[ia], patches.normal[ia], patches.area[ia],
            patches.centroid[ib], patches.normal[ib], patches.area[ib],
            s.lowrank_tol, cap, seed=m * 7919 + n, sa=spread[ia], sb=spread[ib],
            caster=None if clear else caster, counters=counters,
        )
        if res is not None:
            return res[:2]
        if not clear and a.leaf and b.leaf:
            g = _pair_block(patches, ia, ib, False, s, caster, counters, diam, spread)
            res = truncate_block(g, s.lowrank_tol, cap)
            if res is not None:
                counters["lowrank_shadowed"] += 1
                return res
            # kept for the near field in the storage dtype (no float64 copy of every failure)
            ka, kb = int(a.blocks[0]), int(b.blocks[0])
            dense[(ka, kb) if ka <= kb else (kb, ka)] = (g if ka <= kb else g.T).astype(dtype)
        counters["lowrank_rank_cap"] += 1
        return None

    far, near = walk_block_tree(root, visible, admissible, compress)
    counters["lowrank_pairs"] = len(far)
    counters["lowrank_cluster_pairs"] = sum(not (a.leaf and b.leaf) for a, b, _ in far)
    counters["lowrank_block_pairs"] = sum(int(visible[np.ix_(a.blocks, b.blocks)].sum())
                                          for a, b, _ in far)
    counters["lowrank_ranks"] = [uv[0].shape[1] for _, _, uv in far]
    counters["lowrank_time"] = time.perf_counter() - t0
    return [(a.patches, b.patches, *uv) for a, b, uv in far], sorted(near), dense


#: Receiver points per kernel call: one shape, so one trace and one compilation (or one read of
#: JAX's persistent cache) in any process, whatever the patch count. Three shapes (32,768,
#: 4,096, 1,024) cost a cold cube0.8 run 0.3-0.4 s each of tracing and cache reading for
#: 0.06 s of work apiece; 4,096 points run as fast per point as 32,768 (0.004 s vs 0.059 s,
#: contended) and pad at most 4,095 points per call of _contour_start.
_BATCH = 4096


def _contour_kernel(q, n, tri):
    """Point→triangle factors for (M,) receiver points q, normals n and triangles tri."""
    return form_factor_point_triangle(q, n, tri)


def _front_kernel(q, n, tri):
    """:func:`_contour_kernel` for triangles wholly in front of their receivers: unclipped."""
    return form_factor_point_front_triangle(q, n, tri)


def _kernels(quick: bool) -> tuple:
    """The contour kernels ``(clipped, unclipped)`` as stored programs. ``quick``: compiled
    quickly (:func:`lumijax._executables.quick_to_compile`), for a small build (at most
    :data:`~._operator.DENSE_PATCHES` patches: the studies whose solve is one dense block,
    and whose blocks are small), which compiles them once and calls them a few times (the
    cube's first run: 0.43 s of its compiling); a large one calls them for minutes and keeps
    XLA's faster code (~9 %)."""
    options = (lambda *args: _executables.quick_to_compile()) if quick else None
    return tuple(_executables.stored(name, "radiosity/_build.py", "kernels/", options=options)(fn)
                 for name, fn in (("contour_flat", _contour_kernel),
                                  ("contour_front", _front_kernel)))


_CONTOUR = _kernels(quick=False)
_CONTOUR_QUICK = _kernels(quick=True)

#: A vertex counts as wholly in front of a receiver's plane (the unclipped kernel) beyond this
#: fraction of the pair's size: far past float32's rounding of the kernel's relative
#: coordinates (≈ 10⁻⁷ of a few sizes), so the clipped kernel would not clip it either.
_WHOLE = 1e-5


def _quad_points(vertices: np.ndarray, nsub: int) -> np.ndarray:
    """Sub-triangle centroids (N, nsub², 3): an equal-weight rule on each triangle."""
    w = _template(nsub).mean(axis=1)  # (Q, 2) barycentric (w1, w2) of the centroids
    v0 = vertices[:, None, 0]
    return v0 + w[None, :, 0:1] * (vertices[:, None, 1] - v0) + w[None, :, 1:2] * (
        vertices[:, None, 2] - v0
    )


def _contour_start(q, n, tri, kernels, whole=None):
    """Dispatch the factors of each pair's receiver points q (N, Q, 3) to tri (N, 3, 3): the
    kernel calls run while the caller works on (JAX's asynchronous dispatch); finish with
    :func:`_contour_mean`. ``kernels``: ``(clipped, unclipped)``; ``whole`` (N,): the pairs
    whose triangle lies wholly in front of the receiver's plane, which the unclipped kernel
    takes (docs/radiosity.md, "The near field's two kernels"); None: every pair clipped."""
    if whole is None or not whole.any():
        return _dispatch(q, n, tri, kernels[0])
    if whole.all():
        return _dispatch(q, n, tri, kernels[1])
    return _Split([(rows, _dispatch(q[rows], n[rows], tri[rows], k))
                   for rows, k in ((np.flatnonzero(whole), kernels[1]),
                                   (np.flatnonzero(~whole), kernels[0]))], len(q))


class _Split(NamedTuple):
    """Pairs dispatched to both kernels: each part's rows of the pairs and its calls."""

    parts: list
    npair: int


def _dispatch(q, n, tri, kernel):
    npair, nq = q.shape[:2]
    # Relative coordinates (float64 on the host) so that float32 in the kernel keeps precision;
    # rounded to the kernel's dtype here, before the repeats (JAX would round each batch the
    # same way, after copying twice the bytes)
    ft = jax.dtypes.canonicalize_dtype(np.float64)
    origin = q.mean(axis=1, keepdims=True)
    qf = (q - origin).reshape(-1, 3).astype(ft)
    tf = np.repeat((tri - origin).astype(ft), nq, axis=0)
    nf = np.repeat(n.astype(ft), nq, axis=0)
    calls = []
    for s in range(0, len(qf), _BATCH):
        m = min(_BATCH, len(qf) - s)
        if m == _BATCH:  # a full batch: no padded copy
            calls.append(kernel(qf[s : s + m], nf[s : s + m], tf[s : s + m]))
        else:
            qp, tp, npd = (np.zeros((_BATCH, 3), ft), np.zeros((_BATCH, 3, 3), ft),
                           np.zeros((_BATCH, 3), ft))
            qp[:m], tp[:m], npd[:m] = qf[s : s + m], tf[s : s + m], nf[s : s + m]
            calls.append(kernel(qp, npd, tp))
    return calls, npair, nq


def _contour_values(started) -> np.ndarray:
    """Each pair's receiver points' factors (pairs, points) that :func:`_contour_start`
    dispatched."""
    if isinstance(started, _Split):
        points = started.parts[0][1][2]  # each part is (rows, (calls, pairs, points))
        out = np.empty((started.npair, points))
        for rows, part in started.parts:
            out[rows] = _contour_values(part)
        return out
    calls, npair, nq = started
    out = np.empty(npair * nq)
    for k, c in enumerate(calls):
        part = out[k * _BATCH : (k + 1) * _BATCH]
        part[:] = np.asarray(c)[: len(part)]
    return out.reshape(npair, nq)


def _contour_mean(started) -> np.ndarray:
    """Mean over each pair's receiver points of the factors :func:`_contour_start` dispatched."""
    return _contour_values(started).mean(axis=1)


def _visibility(caster, qi, qj, rays: int) -> np.ndarray:
    """Light carried by each of ``rays`` rays between quadrature points of pairs (N, Q, 3) ×
    (N, Q, 3), (N, rays): 0 blocked, 1 clear, τ(θ) through clear glass (docs/materials.md)."""
    n, q = qi.shape[:2]
    k = np.arange(rays)
    a, b = k % q, (k * 7 + 3 * (k // q) + 1) % q  # a fixed scramble pairing points of i and j
    o = qi[:, a].reshape(-1, 3)
    t = qj[:, b].reshape(-1, 3)
    return caster.pair_transmission(o, t).reshape(n, rays)


def _shadowed_view(p: Patches, i, j, qi, sj, f_ij, caster, counters) -> np.ndarray:
    """The light a near pair that a shadow edge crosses passes, weighed where its form factor
    is (pairs,): from each receiver point (``qi``, (pairs, m, 3)) a ray to each source point
    (``sj``, (pairs, k, 3)), each ray weighed by the point-to-point kernel
    ``cos θ_i cos θ_j / r²`` (the share of the factor its part of the source holds), the
    receiver points by their exact factors to the whole source (``f_ij``, (pairs, m), from the
    contour integral).

    Why: the plain fraction of clear rays assumes the blocked part of the source is as bright
    in the kernel as the rest. Where a column meets a cornice the blocked part is the source's
    far side, and a wall patch under the cornice read 21 % low against a fine quadrature
    (docs/radiosity.md, "Shadowed near pairs")."""
    n, m, k = len(i), qi.shape[1], sj.shape[1]
    a = np.repeat(qi, k, axis=1).reshape(-1, 3)
    b = np.tile(sj, (1, m, 1)).reshape(-1, 3)
    t0 = time.perf_counter()
    view = caster.pair_transmission(a, b).reshape(n, m, k)
    counters["ray_time"] += time.perf_counter() - t0
    counters["rays"] += n * m * k
    r = (b - a).reshape(n, m, k, 3)
    cos_i = np.maximum(np.einsum("nabc,nc->nab", r, p.normal[i]), 0.0)
    cos_j = np.maximum(-np.einsum("nabc,nc->nab", r, p.normal[j]), 0.0)
    r2 = np.einsum("nabc,nabc->nab", r, r)
    w = cos_i * cos_j / np.maximum(r2 * r2, 1e-300)  # cos_i, cos_j carry a factor r each

    def weighed(x, weight, axis):
        """Mean of x weighed along ``axis``; the plain mean where no weight."""
        total = weight.sum(axis=axis)
        return np.where(total > 0, (weight * x).sum(axis=axis) / np.where(total > 0, total, 1),
                        x.mean(axis=axis))

    return weighed(weighed(view, w, 2), np.maximum(f_ij, 0.0), 1)


def _near_pairs_start(p: Patches, ia, ib, li, lj, s: FormFactorSettings, caster, counters,
                      diam, whole=None, cut=None):
    """``A_i F_ij`` (m²) for the near pairs ``ia[li]``, ``ib[lj]`` of two blocks by the
    contour integral and receiver quadrature, its kernel calls dispatched now: returns the
    function that waits for them and gives it (the caller computes the far field meanwhile).
    ``diam``: every patch's diameter; ``whole``: per pair, whether j lies wholly in front of
    i's plane and i of j's (:func:`_contour_start`), or None; ``cut``: per pair, whether i's
    plane cuts j and j's plane cuts i (corners on both sides), or None."""
    i, j = ia[li], ib[lj]
    g = np.zeros(len(i))
    if not len(i):
        return lambda: g
    d = np.linalg.norm(p.centroid[j] - p.centroid[i], axis=1)
    r = d / np.maximum(diam[i], diam[j])
    close = r < s.close_ratio * (1 + _TIE)
    parts = []
    kernels = _CONTOUR_QUICK if p.n <= DENSE_PATCHES else _CONTOUR
    for sel, nsub, rays in ((close, s.close_subdiv, s.close_rays), (~close, s.mid_subdiv, s.mid_rays)):
        ii, jj = i[sel], j[sel]
        if not len(ii):
            continue
        # each block's quadrature points once, not once per pair (a patch has hundreds of
        # near partners): the same points, so the same factors bit for bit
        qi = _quad_points(p.vertices[ia], nsub)[li[sel]]
        qj = _quad_points(p.vertices[ib], nsub)[lj[sel]]
        w_ij, w_ji = (None, None) if whole is None else (whole[0][sel], whole[1][sel])
        f_ij = _contour_start(qi, p.normal[ii], p.vertices[jj], kernels, w_ij)
        f_ji = (_contour_start(qj, p.normal[jj], p.vertices[ii], kernels, w_ji)
                if s.symmetrise else None)
        c_ij, c_ji = (None, None) if cut is None else (cut[0][sel], cut[1][sel])
        parts.append((sel, ii, jj, qi, qj, nsub, rays, f_ij, f_ji, c_ij, c_ji))

    def finish() -> np.ndarray:
        for sel, ii, jj, qi, qj, nsub, rays, f_ij, f_ji, c_ij, c_ji in parts:
            v_ij = _contour_values(f_ij)
            gg = p.area[ii] * v_ij.mean(axis=1)
            if f_ji is not None:
                g_ji = p.area[jj] * _contour_mean(f_ji)
                both = 0.5 * (gg + g_ji)
                if c_ij is not None:
                    # a receiver that the source's plane cuts averages a step over its points
                    # (lit on one side, nothing on the other): take the other way alone, exact
                    # in it (docs/radiosity.md, "Shadowed near pairs")
                    both = np.where(c_ij & ~c_ji, gg, np.where(c_ji & ~c_ij, g_ji, both))
                gg = both
            if caster is not None:
                t0 = time.perf_counter()
                carried = _visibility(caster, qi, qj, rays)
                counters["ray_time"] += time.perf_counter() - t0
                counters["rays"] += len(ii) * rays
                view = carried.mean(axis=1)
                # rays that disagree: a shadow edge crosses the pair
                shadowed = np.flatnonzero(carried.min(axis=1) < carried.max(axis=1))
                if len(shadowed):
                    counters["shadowed_near_pairs"] += len(shadowed)
                    # the source's points at most the mid quadrature's (4): a ray from each
                    # receiver point to each, 16 or 64 a pair, not 256
                    sj = _quad_points(p.vertices[jj[shadowed]], min(nsub, s.mid_subdiv))
                    view[shadowed] = _shadowed_view(p, ii[shadowed], jj[shadowed], qi[shadowed],
                                                    sj, v_ij[shadowed], caster, counters)
                gg = gg * view
            g[sel] = gg
        return g

    return finish


def _pair_block(p: Patches, ia, ib, diagonal, s: FormFactorSettings, caster, counters, diam,
                spread):
    """Dense ``G = A F`` block (float64) for receivers ia and sources ib."""
    ci, ni, ai = p.centroid[ia], p.normal[ia], p.area[ia]
    cj, nj, aj = p.centroid[ib], p.normal[ib], p.area[ib]
    # Pair geometry by matrix products, not a (m, n, 3) difference array (a third of the
    # block's time went to it): re-centred on the receivers (site coordinates keep their
    # digits), |c_j − c_i|² = |c_j|² + |c_i|² − 2 c_i·c_j loses ~ε·(block size / d)² of d²,
    # 10⁻¹⁴ for a block of 1,024 patches, far below the near/far tie margin (_TIE).
    o = ci.mean(axis=0)
    ci0, cj0 = ci - o, cj - o
    cross = ci0 @ cj0.T
    d2 = np.maximum((ci0 * ci0).sum(1)[:, None] + (cj0 * cj0).sum(1)[None] - 2.0 * cross, 0.0)
    cos_i = ni @ cj0.T - (ni * ci0).sum(1)[:, None]  # n_i·(c_j − c_i) = cos θ_i × |d|
    cos_j = ci0 @ nj.T - (nj * cj0).sum(1)[None]  # −n_j·(c_j − c_i)
    size = np.maximum(diam[ia][:, None], diam[ib][None])
    near = d2 < (s.near_ratio * size) ** 2 * (1 + 2 * _TIE)
    # j > i: each unordered pair of a diagonal block once (np.tri, not triu of a block of ones:
    # one comparison pass instead of two)
    upper = ~np.tri(d2.shape[0], d2.shape[1], 0, dtype=np.bool_) if diagonal else True
    # Near pairs first, their kernel calls left running while the far field is computed here:
    # any vertex of each in front of the other's plane (partly-facing neighbours count; the
    # contour integral clips exactly).
    ni_i, nj_j = np.nonzero(near & upper)
    near_done = None
    if len(ni_i):
        vi, vj = p.vertices[ia[ni_i]], p.vertices[ib[nj_j]]
        # in front by more than the rounding of the coordinates: a floor vertex on the wall's
        # plane is not "in front" of it because the room sits at 10⁷ m
        tol = np.maximum(1e-9 * size[ni_i, nj_j], max(rounding_length(vi), rounding_length(vj)))
        ahead_j = np.einsum("nkc,nc->nk", vj - ci[ni_i, None], ni[ni_i])  # j's corners, i's side
        ahead_i = np.einsum("nkc,nc->nk", vi - cj[nj_j, None], nj[nj_j])
        keep = (ahead_i > tol[:, None]).any(1) & (ahead_j > tol[:, None]).any(1)
        clear = np.maximum(tol, _WHOLE * size[ni_i, nj_j])[:, None]
        whole = ((ahead_j > clear).all(1)[keep], (ahead_i > clear).all(1)[keep])
        cut = (((ahead_j < -clear).any(1) & (ahead_j > clear).any(1))[keep],
               ((ahead_i < -clear).any(1) & (ahead_i > clear).any(1))[keep])
        ni_i, nj_j = ni_i[keep], nj_j[keep]
        counters["near_pairs"] += len(ni_i)
        near_done = _near_pairs_start(p, ia, ib, ni_i, nj_j, s, caster, counters, diam, whole,
                                      cut)
    far = ~near & (cos_i > 0) & (cos_j > 0) & upper
    # the far kernel (form_factor_far) in float64 numpy (host side) on the far pairs only, by
    # flat index: the same operations on the same numbers as on the whole block, without the
    # half of a diagonal block below its diagonal, the near pairs and the pairs facing away
    # (far_g was half the block's host time, computed on every entry)
    flat = np.flatnonzero(far)
    fi, fj = np.divmod(flat, far.shape[1])
    sa, sb = spread[ia], spread[ib]
    g = np.zeros(far.shape)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        g.flat[flat] = far_g(cos_i.flat[flat], cos_j.flat[flat], (ni @ nj.T).flat[flat],
                             d2.flat[flat], ai[fi], aj[fj], sa[fi], sb[fj])
    if caster is not None and len(flat):
        t0 = time.perf_counter()
        carried = caster.pair_transmission(ci[fi], cj[fj])  # 0, 1, or τ(θ) through glass
        counters["ray_time"] += time.perf_counter() - t0
        counters["rays"] += len(fi)
        g.flat[flat] *= carried
    if near_done is not None:
        g[ni_i, nj_j] = near_done()
    if diagonal:
        g = g + g.T
    return g


def _near_task(pairs, *, patches, part, settings, caster, diam, spread):
    """One batch of near-field pairs on any process: their dense blocks and ray counts."""
    counters = dict(rays=0, ray_time=0.0, near_pairs=0, shadowed_near_pairs=0)
    blocks = [_pair_block(patches, part.block(a), part.block(b), a == b, settings, caster,
                          counters, diam, spread) for a, b in pairs]
    return blocks, counters


def _near_blocks(executor, pairs, computed, patches, part, s, caster, counters, diam, spread):
    """Each pair's dense block (float64), in ``pairs`` order (the blocks already computed by
    the far field first): here on threads, a block a task (the contour kernels, Embree and
    NumPy's loops release the GIL; each block is what it would be alone, so the operator is
    the same bit for bit), or in batches on a cluster's workers, each consumed before the
    next is fetched."""
    ex = current_executor() if executor is None else executor
    todo = [p for p in pairs if p not in computed]
    shared = dict(patches=patches, part=part, settings=s, caster=caster, diam=diam,
                  spread=spread)
    if ex.distributed and todo:
        results = ex.map(_near_task, [[todo[i] for i in r] for r in batches(len(todo),
                                                                              ex.parts())],
                         shared=shared)
    else:
        results = threaded_map(lambda pair: _near_task([pair], **shared), todo)
    pending: list = []
    for a, b in pairs:
        g = computed.pop((a, b), None)
        if g is None:
            if not pending:
                pending, got = next(results)
                pending.reverse()
                for key, v in got.items():
                    counters[key] += v
            g = pending.pop()
        yield g


def build_operator(
    patches: Patches,
    part: Partition,
    occluders=None,
    settings: FormFactorSettings | None = None,
    *,
    dtype=np.float32,
    occluder_triangles=None,
    executor: Executor | None = None,
) -> TransportOperator:
    """Compute the form factors of every visible block pair into a :class:`TransportOperator`.

    Parameters
    ----------
    patches, part
        From :func:`~lumijax.radiosity.mesh_patches` and :func:`~lumijax.radiosity.partition`.
    occluders
        Scene triangles ``(T, 3, 3)`` (or a ``RayCaster``) for shadow rays; ``None``: no
        occlusion (convex scenes, tests).
    settings
        Accuracy knobs, :class:`FormFactorSettings` (defaults meet the documented accuracy).
    dtype
        Storage of the blocks: float32 (default; BLAS speed, half the memory) or float64.
    occluder_triangles
        The triangles of ``occluders`` when that is a prebuilt ``RayCaster``: they let the
        low-rank far field prove a block pair unshadowed geometrically instead of by sampling.
    executor
        Where the near-field blocks are computed (:mod:`lumijax.parallel`); default
        :func:`~lumijax.parallel.current_executor`: threads here unless a cluster was given.
        The far-field walk stays here (it decides which pairs are near).
    """
    from ..scene._raycast import RayCaster

    s = settings or FormFactorSettings()
    caster = occluders
    if occluders is not None and not isinstance(occluders, RayCaster):
        occluder_triangles = np.asarray(occluders, np.float64)
        caster = RayCaster(occluders)
    t_start = time.perf_counter()
    counters = dict(rays=0, ray_time=0.0, near_pairs=0, shadowed_near_pairs=0)
    if caster is not None and caster.sees_everything:
        # a convex room seen from inside (a plain box): no segment between its surfaces can
        # be blocked, so the rays would all come back clear (RayCaster.sees_everything)
        caster, counters["skipped_visibility"] = None, 1
    diam = patches.diameter
    spread = triangle_spread(patches.vertices)
    sizes = part.sizes
    npatch = patches.n
    far, near, computed = _far_field(patches, part, s, caster, occluder_triangles, diam,
                                     counters, spread, dtype)
    # Bucket every pair by its padded shape, and preallocate (no second copy).
    keys: dict = {}
    lr_keys: dict = {}
    for k, (ia, ib, uu, _) in enumerate(far):
        r = uu.shape[1]
        if r:  # r = 0: the pair exchanges nothing (no facing patches)
            lr_keys.setdefault((_pad(len(ia)), _pad(len(ib)), _pad_rank(r)), []).append(k)
    for a, b in near:
        keys.setdefault((_pad(sizes[a]), _pad(sizes[b]), bool(a == b)), []).append((a, b))
    buckets = []
    nnz = 0
    lr_entries = 0
    block_of = part.block_of
    for (sa, sb, r), ks in sorted(lr_keys.items()):
        chunk, total = _chunking(len(ks), (sa + sb) * r * np.dtype(dtype).itemsize,
                                 s.max_bytes_per_step)
        u = np.zeros((total, sa, r), dtype)
        v = np.zeros((total, sb, r), dtype)
        recv = np.full((total, sa), npatch, np.int32)
        src = np.full((total, sb), npatch, np.int32)
        rblk = np.full(total, -1, np.int32)
        sblk = np.full(total, -1, np.int32)
        for slot, k in enumerate(ks):
            ia, ib, uu, vv = far[k]
            u[slot, : len(ia), : uu.shape[1]] = uu
            v[slot, : len(ib), : vv.shape[1]] = vv
            recv[slot, : len(ia)], src[slot, : len(ib)] = ia, ib
            # a cluster spanning several blocks has no single block: -1 (see LowRankBucket)
            one_a, one_b = np.unique(block_of[ia]), np.unique(block_of[ib])
            rblk[slot] = one_a[0] if len(one_a) == 1 else -1
            sblk[slot] = one_b[0] if len(one_b) == 1 else -1
            lr_entries += 2 * len(ia) * len(ib)
        buckets.append(LowRankBucket(*(jnp.asarray(x) for x in (u, v, recv, src, rblk, sblk)),
                                     chunk=chunk))
    near_blocks = _near_blocks(executor, [p for _, ks in sorted(keys.items()) for p in ks],
                               computed, patches, part, s, caster, counters, diam, spread)
    for (sa, sb, diagonal), ks in sorted(keys.items()):
        n = len(ks)
        per_pair = sa * sb * np.dtype(dtype).itemsize
        chunk, total = _chunking(n, per_pair, s.max_bytes_per_step)
        blocks = np.zeros((total, sa, sb), dtype)
        recv = np.full((total, sa), npatch, np.int32)
        src = np.full((total, sb), npatch, np.int32)
        rblk = np.full(total, -1, np.int32)
        sblk = np.full(total, -1, np.int32)
        for slot, (a, b) in enumerate(ks):
            rblk[slot], sblk[slot] = a, b
            ia, ib = part.block(a), part.block(b)
            g = next(near_blocks)
            nnz += int(np.count_nonzero(g)) * (1 if diagonal else 2)
            blocks[slot, : len(ia), : len(ib)] = g
            recv[slot, : len(ia)] = ia
            src[slot, : len(ib)] = ib
        buckets.append(
            Bucket(
                *(to_device(x) for x in (blocks, recv, src, rblk, sblk)), diagonal=diagonal,
                chunk=chunk,
            )
        )
    info = Info(
        patches=npatch,
        blocks=part.n_blocks,
        visible_pairs=int(len(part.pairs)),
        nonzeros=nnz,
        rays=counters["rays"],
        ray_time_s=counters["ray_time"],
        near_pairs=counters["near_pairs"],
        shadowed_near_pairs=counters["shadowed_near_pairs"],
        visibility_skipped=bool(counters.get("skipped_visibility", 0)),
        lowrank_candidates=counters.get("lowrank_candidates", 0),
        lowrank_pairs=counters.get("lowrank_pairs", 0),
        lowrank_cluster_pairs=counters.get("lowrank_cluster_pairs", 0),
        lowrank_block_pairs=counters.get("lowrank_block_pairs", 0),
        lowrank_mixed_visibility=counters.get("lowrank_mixed", 0),
        lowrank_rank_cap=counters.get("lowrank_rank_cap", 0),
        lowrank_rank_mean=float(np.mean(counters["lowrank_ranks"])) if counters.get("lowrank_ranks") else 0.0,
        lowrank_rank_max=int(np.max(counters["lowrank_ranks"])) if counters.get("lowrank_ranks") else 0,
        lowrank_entries=lr_entries,
        lowrank_time_s=counters.get("lowrank_time", 0.0),
        lowrank_shadowed=counters.get("lowrank_shadowed", 0),
        build_time_s=time.perf_counter() - t_start,
        settings=dataclasses.asdict(s),
    )
    # to_device: numpy's cast and a transfer, no eager kernel per shape and process
    area = to_device(patches.area, np.float64 if jax.config.jax_enable_x64 else None)
    block_of = to_device(part.block_of, np.int32)
    return TransportOperator(tuple(buckets), area, block_of, npatch, part.n_blocks, info)
