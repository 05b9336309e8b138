"""Low-rank far-field blocks: which cluster pairs may be compressed, and how.

A pair of clusters (or leaf blocks, see ``_hierarchy.py``) is a candidate when it is **well
separated**: the gap between the bounding spheres exceeds ``eta`` times the larger radius (and
``near_ratio`` patch diameters, so every patch pair in it is a far pair of the point kernel).
Over such a pair the unoccluded far kernel ``A_i A_j cosθ_i cosθ_j / (d² (π d² + A_i + A_j))``
is smooth, so the block of ``G = A F`` has rapidly decaying singular values.

Visibility is not smooth, so how a candidate is compressed depends on what can shadow it:

* **Proven clear** (:meth:`Obstacles.clear`): every segment between the two lies in the convex
  hull of their bounding boxes, so if no triangle penetrates that hull (separating-axis test;
  touching, as their own and coplanar neighbouring triangles do, does not count) every shadow
  ray of the pair is clear, exactly as the dense path would find. Then ACA runs on the kernel
  alone, no ray is cast, and random entries check ACA's heuristic stopping rule (the kernel is
  smooth, so they can).
* **Possibly shadowed**: ACA visits entries with their shadow rays, and the result is accepted
  only when its error over **every** entry of the block (:func:`exact_error`: far kernel ×
  centroid ray, streamed by rows) is within the tolerance. Sampled checks cannot bound a sharp
  shadow (measured: a 1 m plate between two far plates slipped past 1,024 random entries and
  left a 3.4e-3 error); the exact pass can, at the dense path's cost in rays but not in memory.
  A leaf block pair that fails is computed dense and truncated by SVD (:func:`truncate_block`),
  also with an exact error.

Compression is adaptive cross approximation with partial pivoting (Bebendorf 2000), computed
from rows and columns only — k rows and k columns for rank k, never the m × n block — followed
by a QR + SVD recompression that truncates to the tolerance. When the rank would exceed the
cap, or the check fails, the caller splits the pair (``_hierarchy.py``) or stores it dense.
"""

from __future__ import annotations

import numpy as np

from ..kernels import far_g, length_tolerance

__all__ = ["Obstacles", "aca_block", "block_spheres", "exact_error", "truncate_block",
           "well_separated"]


def block_spheres(patches, part):
    """Centre (box centre) and radius (farthest vertex) of each block's bounding sphere."""
    centre = 0.5 * (part.lo + part.hi)
    bo = np.repeat(np.arange(part.n_blocks), part.sizes)
    v = patches.vertices[part.members]  # (P, 3, 3)
    dist = np.linalg.norm(v - centre[bo][:, None], axis=-1).max(axis=1)
    radius = np.maximum.reduceat(dist, part.offsets[:-1]) if len(dist) else np.zeros(0)
    return centre, radius


def well_separated(s, t, eta: float, near_ratio: float) -> bool:
    """Admissible for low rank: two clusters (or blocks) whose bounding spheres' gap exceeds
    ``eta`` × the larger radius and ``near_ratio`` × the largest patch diameter in them."""
    gap = float(np.linalg.norm(s.centre - t.centre)) - s.radius - t.radius
    # a relative margin, so that a pair exactly at the threshold (a regular mesh) is decided
    # the same way wherever the model sits (its rounding is ~1e-16 of the coordinates)
    gap *= 1 - 1e-7
    return gap > eta * max(s.radius, t.radius) and gap > near_ratio * max(s.max_diameter,
                                                                           t.max_diameter)


def _box_corners(lo, hi):
    k = np.array([[i, j, m] for i in (0, 1) for j in (0, 1) for m in (0, 1)], float)
    return lo + k * (hi - lo)


class Obstacles:
    """The scene's triangles, prepared for :meth:`clear` (separating-axis tests)."""

    def __init__(self, triangles):
        tri = np.asarray(triangles, np.float64).reshape(-1, 3, 3)
        self.tri = tri
        pts = tri.reshape(-1, 3)
        # relative to the scene and above its coordinates' rounding: any unit, any site
        self.tol = length_tolerance(pts, 1e-6)
        self.lo, self.hi = tri.min(axis=1), tri.max(axis=1)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        self.normal = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        self.offset = -np.einsum("ij,ij->i", self.normal, tri[:, 0])

    def clear(self, lo_a, hi_a, lo_b, hi_b) -> bool:
        """No triangle penetrates the convex hull of the two boxes, so every segment between
        them is unblocked.

        Separating axes: the hull's face normals and the triangle's normal (edge × edge axes
        are skipped, which can only report an intersection that is not there: conservative).
        """
        from scipy.spatial import ConvexHull, QhullError

        corners = np.concatenate([_box_corners(lo_a, hi_a), _box_corners(lo_b, hi_b)])
        lo, hi, tol = corners.min(0), corners.max(0), self.tol
        near = np.flatnonzero(((self.lo < hi - tol) & (self.hi > lo + tol)).all(axis=1))
        if not len(near):
            return True
        try:
            eq = ConvexHull(corners).equations  # (F, 4): n·x + d ≤ 0 inside
        except QhullError:
            return False  # degenerate hull: not proven clear
        face = np.einsum("tkc,fc->tkf", self.tri[near], eq[:, :3]) + eq[:, 3]
        sep = (face.min(axis=1) >= -tol).any(axis=1)  # the whole triangle outside some face
        side = corners @ self.normal[near].T + self.offset[near]  # hull on one side of it
        sep |= (side.min(axis=0) >= -tol) | (side.max(axis=0) <= tol)
        return bool(sep.all())


def _kernel(c, n, a, s, C, N, A, S, caster=None, reverse=False, counters=None):
    """``A_i F_ij`` of the far kernel (float64), one patch (c, n, a, spread s) against arrays.

    With ``caster``, each facing entry is multiplied by its centroid-to-centroid shadow ray,
    exactly as the dense path does; ``reverse`` casts from the array's patches to the one patch
    (columns of a receiver-by-source block keep the dense path's ray direction).
    """
    d = C - c
    d2 = np.einsum("ij,ij->i", d, d)
    ci = d @ n
    cj = -np.einsum("ij,ij->i", d, N)
    ok = (ci > 0) & (cj > 0)
    g = far_g(np.where(ok, ci, 1.0), np.where(ok, cj, 1.0), N @ n, d2, a, A, s, S)
    g = np.where(ok, g, 0.0)
    if caster is not None and ok.any():
        idx = np.flatnonzero(ok)
        one = np.broadcast_to(c, (len(idx), 3))
        # ×0 blocked, ×τ(θ) through clear glass (docs/materials.md), ×1 clear
        g[idx] *= (caster.pair_transmission(C[idx], one) if reverse
                    else caster.pair_transmission(one, C[idx]))
        counters["rays"] += len(idx)
    return g


def exact_block_rows(ca, na, aa, sa, cb, nb, ab, sb, caster, counters):
    """Rows of the far block ``G`` (receivers a, sources b), every entry with its shadow ray."""
    d = cb[None] - ca[:, None]
    d2 = np.einsum("ijk,ijk->ij", d, d)
    cos_i = np.einsum("ijk,ik->ij", d, na)
    cos_j = -np.einsum("ijk,jk->ij", d, nb)
    fi, fj = np.nonzero((cos_i > 0) & (cos_j > 0))
    g = np.zeros(d2.shape)
    g[fi, fj] = far_g(cos_i[fi, fj], cos_j[fi, fj], np.einsum("nk,nk->n", na[fi], nb[fj]),
                      d2[fi, fj], aa[fi], ab[fj], sa[fi], sb[fj])
    if caster is not None and len(fi):
        g[fi, fj] *= caster.pair_transmission(ca[fi], cb[fj])
        counters["rays"] += len(fi)
    return g


def exact_error(U, V, ca, na, aa, sa, cb, nb, ab, sb, caster, counters, max_bytes=1 << 26):
    """``(‖G − U Vᵀ‖_F, ‖G‖_F)`` over every entry of the far block, streamed by rows.

    Each entry is the dense path's (far kernel × its centroid ray), so the error is exact, not
    estimated, at the dense path's cost in rays, but in O(chunk × n) memory.
    """
    rows = max(1, max_bytes // (8 * 8 * max(len(cb), 1)))
    err2 = ref2 = 0.0
    for s in range(0, len(ca), rows):
        sl = slice(s, s + rows)
        g = exact_block_rows(ca[sl], na[sl], aa[sl], sa[sl], cb, nb, ab, sb, caster, counters)
        err2 += float(np.sum((g - U[sl] @ V.T) ** 2))
        ref2 += float(np.sum(g * g))
    return np.sqrt(err2), np.sqrt(ref2)


def _entries(ii, jj, ca, na, aa, sa, cb, nb, ab, sb, caster, counters):
    """Entries ``G[ii, jj]`` of the far block, with their shadow rays when ``caster``."""
    d = cb[jj] - ca[ii]
    d2 = np.einsum("ij,ij->i", d, d)
    cos_i = np.einsum("ij,ij->i", d, na[ii])
    cos_j = -np.einsum("ij,ij->i", d, nb[jj])
    ok = (cos_i > 0) & (cos_j > 0)
    g = far_g(np.where(ok, cos_i, 1.0), np.where(ok, cos_j, 1.0),
              np.einsum("ij,ij->i", na[ii], nb[jj]), d2, aa[ii], ab[jj], sa[ii], sb[jj])
    g = np.where(ok, g, 0.0)
    if caster is not None and ok.any():
        idx = np.flatnonzero(ok)
        g[idx] *= caster.pair_transmission(ca[ii[idx]], cb[jj[idx]])
        counters["rays"] += len(idx)
    return g


def aca_block(ca, na, aa, cb, nb, ab, tol: float, max_rank: int, checks: int = 256, seed=0,
              sa=None, sb=None, caster=None, counters=None, restarts: int = 4):
    """Low-rank ``U Vᵀ ≈ G`` of the far block (receivers a, sources b), or ``None``.

    ``sa, sb``: the patches' spreads for the far kernel's correction (``far_g``; default:
    disks of the same area).

    ACA's stopping rule is a heuristic: it sees only the rows and columns it pivoted on, and on
    symmetric geometry (two plates' x and y modes share a singular value) it stops with a mode
    missed. So ``checks`` random entries are compared with the factors, and while they are off
    by more than ``tol``, ACA goes on from the row of the worst one (up to ``restarts`` times).

    Without ``caster`` the block is the unoccluded kernel (a pair proven clear), which is
    smooth, and passing the random entries (within 3 tol) accepts it. With ``caster`` (a pair
    that may be shadowed) every entry visited gets its shadow ray, and the result is accepted
    only if its error over **every** entry (:func:`exact_error`) is within ``tol``: a sharp
    shadow that the pivots and the random entries both miss cannot slip through.

    ``None`` when the rank needed exceeds ``max_rank`` or the checks fail.
    Returns ``(U, V, stats)`` with U (m, r), V (n, r) float64; r = 0 for a block that is zero
    (no facing patch pair found).
    """
    m, n = len(ca), len(cb)
    sa = aa / (4 * np.pi) if sa is None else sa
    sb = ab / (4 * np.pi) if sb is None else sb
    side_a, side_b = (ca, na, aa, sa), (cb, nb, ab, sb)
    counters = counters if counters is not None else dict(rays=0)
    rng = np.random.default_rng(seed)
    # ACA's crosses overshoot the rank the recompression keeps: room for them, then the cap
    cap = max(1, min(max_rank + max(2, max_rank // 2), m, n))
    U = np.zeros((m, cap))
    V = np.zeros((n, cap))
    used = np.zeros(m, bool)
    ii, jj = rng.integers(0, m, checks), rng.integers(0, n, checks)
    exact = _entries(ii, jj, *side_a, *side_b, caster, counters)
    # start from the receiver nearest to the source block's centre
    i = int(np.argmin(np.linalg.norm(ca - cb.mean(0), axis=1)))
    k, norm2, scale = 0, 0.0, 0.0
    stop = 0.5 * tol
    for _ in range(restarts + 1):
        misses, quiet, converged = 0, 0, False
        while True:
            used[i] = True
            row = _kernel(ca[i], na[i], aa[i], sa[i], *side_b, caster, False, counters)
            row -= V[:, :k] @ U[i, :k]
            j = int(np.argmax(np.abs(row)))
            piv = row[j]
            if abs(piv) <= 1e-12 * scale or piv == 0.0:
                misses += 1
                free = np.flatnonzero(~used)
                if misses > 16 or not len(free):
                    converged = True  # many zero residual rows in a row: nothing left to find
                    break
                i = int(rng.choice(free))
                continue
            if k == cap:
                break  # a further rank-1 term is needed and there is no room: not compressible
            misses = 0
            scale = max(scale, abs(piv))
            v = row / piv
            u = _kernel(cb[j], nb[j], ab[j], sb[j], *side_a, caster, True, counters)
            u -= U[:, :k] @ V[j, :k]
            norm2 += 2.0 * float((U[:, :k].T @ u) @ (V[:, :k].T @ v)) + float(u @ u) * float(v @ v)
            U[:, k], V[:, k] = u, v
            k += 1
            quiet = quiet + 1 if np.sqrt(float(u @ u) * float(v @ v)) <= stop * np.sqrt(
                max(norm2, 0.0)) else 0
            if quiet >= 2:
                converged = True
                break
            ua = np.abs(u)
            ua[used] = -1.0
            i = int(np.argmax(ua))
            if ua[i] < 0:
                converged = True  # every row used: exact
                break
        if not converged:
            return None
        miss = np.abs(np.einsum("ir,ir->i", U[ii, :k], V[jj, :k]) - exact)
        err = np.sqrt(m * n * np.mean(miss**2))
        ref = np.sqrt(max(norm2, m * n * np.mean(exact**2)))
        if err <= tol * ref or used.all():
            break
        i = int(ii[np.argmax(np.where(used[ii], -1.0, miss))])  # go on from the worst row
        if used[i]:
            break
    if caster is not None and err > 3.0 * tol * ref:
        return None  # clearly off already: spare the exact pass its m × n rays
    U, V = U[:, :k], V[:, :k]
    if k:
        # recompression: G ≈ Qu (Ru Rvᵀ) Qvᵀ, truncated SVD of the small core
        qu, ru = np.linalg.qr(U)
        qv, rv = np.linalg.qr(V)
        w, s, zt = np.linalg.svd(ru @ rv.T)
        tail = np.sqrt(np.cumsum((s**2)[::-1]))[::-1]  # tail[r] = ‖s[r:]‖
        below = np.flatnonzero(tail <= stop * tail[0])
        keep = (int(below[0]) if len(below) else len(s)) if tail[0] > 0 else 0
        if keep > max_rank:
            return None
        U = qu @ (w[:, :keep] * s[:keep])
        V = qv @ zt[:keep].T
    if caster is not None:
        err, ref = exact_error(U, V, *side_a, *side_b, caster, counters)
        if err > tol * ref:
            return None
    else:
        err = np.sqrt(m * n * np.mean((np.einsum("ir,ir->i", U[ii], V[jj]) - exact) ** 2))
        ref = np.sqrt(max(norm2, m * n * np.mean(exact**2)))
        if err > 3.0 * tol * ref:
            return None
    return U, V, dict(rank=U.shape[1], aca_rank=k, check_error=float(err / ref) if ref else 0.0)


def truncate_block(g, tol: float, max_rank: int):
    """``(U, V)`` with ``‖G − U Vᵀ‖_F ≤ tol ‖G‖_F`` exactly (truncated SVD), or ``None``.

    For a possibly shadowed far pair whose dense block (every entry with its shadow ray) is at
    hand: the error is not estimated but exact, so nothing about the shadows is sampled.
    ``None`` when the rank needed exceeds ``max_rank``.
    """
    w, sv, zt = np.linalg.svd(g, full_matrices=False)
    tail = np.sqrt(np.cumsum((sv**2)[::-1]))[::-1]  # tail[r] = ‖s[r:]‖ = error at rank r
    if not len(sv) or tail[0] == 0:
        return np.zeros((g.shape[0], 0)), np.zeros((g.shape[1], 0))
    below = np.flatnonzero(tail <= tol * tail[0])
    r = int(below[0]) if len(below) else len(sv)
    if r > max_rank:
        return None
    return w[:, :r] * sv[:r], zt[:r].T
