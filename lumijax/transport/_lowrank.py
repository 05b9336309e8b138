"""Low-rank far-field blocks: which block pairs to compress, and ACA to compress them.

A block pair is a candidate when its two blocks are **well separated**: the gap between their
bounding spheres exceeds ``eta`` times the larger radius (and ``near_ratio`` patch diameters,
so every patch pair in it is a far pair of the point kernel). Over such a pair the unoccluded
far kernel ``A_i A_j cosθ_i cosθ_j / (d² (π d² + A_i + A_j))`` is smooth, so the block of
``G = A F`` has rapidly decaying singular values.

Visibility is not smooth, so a candidate is compressed only when nothing can shadow it. With
the occluding triangles at hand this is decided **geometrically and exactly** (conservatively):
every segment between the two blocks lies in the convex hull of their bounding boxes, so if no
triangle penetrates that hull (separating-axis test on the hull's faces and the triangle's
plane; touching, as the blocks' own and coplanar neighbouring triangles do, does not count),
every shadow ray of the pair is clear and every entry's visibility is 1, exactly as the dense
path would compute it. Any penetrating triangle sends the pair to the dense path with its
per-entry rays; that dense block may then be truncated by SVD with an exact error
(:func:`truncate_block`: courtyard bays shadow themselves, so most far pairs land here). When only a ray caster is available (no triangles), ``samples`` random
centroid-to-centroid rays between facing patches must all be clear instead; a partial occluder
covering a fraction f of the pair is then missed with probability (1 − f)^samples (measured:
a 0.5 % shadow slipped through and cost 0.8 % of the pair's norm), which is why the geometric
test is the default.

Compression is adaptive cross approximation with partial pivoting (Bebendorf 2000), computed
from kernel rows and columns only — k rows and k columns for rank k, never the m × n block —
followed by a QR + SVD recompression that truncates to the tolerance. A check on random
entries guards ACA's heuristic stopping rule; when it fails, or the rank would save less than
``1 − max_fraction`` of the dense storage, the pair is stored dense.
"""

from __future__ import annotations

import numpy as np

from ._kernels import far_g

__all__ = ["block_spheres", "separated", "clear_pairs", "unobstructed_pairs", "aca_block",
           "truncate_block"]


def block_spheres(patches, part):
    """Centre (box centre) and radius (farthest vertex) of each block's bounding sphere."""
    centre = 0.5 * (part.lo + part.hi)
    bo = np.repeat(np.arange(part.n_blocks), part.sizes)
    v = patches.vertices[part.members]  # (P, 3, 3)
    dist = np.linalg.norm(v - centre[bo][:, None], axis=-1).max(axis=1)
    radius = np.maximum.reduceat(dist, part.offsets[:-1]) if len(dist) else np.zeros(0)
    return centre, radius


def separated(patches, part, eta: float, near_ratio: float, diam) -> np.ndarray:
    """Mask over ``part.pairs``: well-separated (admissible for low rank) block pairs."""
    if not len(part.pairs) or part.n_blocks == 0:
        return np.zeros(len(part.pairs), bool)
    centre, radius = block_spheres(patches, part)
    dmax = np.maximum.reduceat(diam[part.members], part.offsets[:-1])
    a, b = part.pairs[:, 0], part.pairs[:, 1]
    gap = np.linalg.norm(centre[a] - centre[b], axis=1) - radius[a] - radius[b]
    big = np.maximum(radius[a], radius[b])
    return (a != b) & (gap > eta * big) & (gap > near_ratio * np.maximum(dmax[a], dmax[b]))


def clear_pairs(patches, part, pairs, caster, samples: int, min_facing: int, seed: int = 0):
    """Per pair of ``pairs`` (indices into ``part.pairs``): all sampled facing rays clear.

    Returns ``(clear, rays cast)``. With no caster, every pair with a facing sample is clear.
    """
    rng = np.random.default_rng(seed)
    size = part.sizes
    ok = np.zeros(len(pairs), bool)
    rays = 0
    step = max(1, (1 << 20) // samples)
    for s in range(0, len(pairs), step):
        pk = pairs[s : s + step]
        a = np.repeat(part.pairs[pk, 0], samples)
        b = np.repeat(part.pairs[pk, 1], samples)
        i = part.members[part.offsets[a] + rng.integers(0, size[a])]
        j = part.members[part.offsets[b] + rng.integers(0, size[b])]
        ci, cj = patches.centroid[i], patches.centroid[j]
        d = cj - ci
        facing = (np.einsum("ij,ij->i", d, patches.normal[i]) > 0) & (
            np.einsum("ij,ij->i", d, patches.normal[j]) < 0
        )
        blocked = np.zeros(len(i), bool)
        if caster is not None and facing.any():
            blocked[facing] = caster.occluded(ci[facing], cj[facing])
            rays += int(facing.sum())
        n_facing = facing.reshape(-1, samples).sum(1)
        any_blocked = blocked.reshape(-1, samples).any(1)
        need = min_facing if caster is not None else 1
        ok[s : s + step] = (n_facing >= need) & ~any_blocked
    return ok, rays


def _box_corners(lo, hi):
    k = np.array([[i, j, m] for i in (0, 1) for j in (0, 1) for m in (0, 1)], float)
    return lo + k * (hi - lo)


def unobstructed_pairs(part, pairs, triangles) -> np.ndarray:
    """Per pair of ``pairs``: no triangle penetrates the convex hull of the two blocks' boxes.

    Separating axes: the hull's face normals and the triangle's normal (edge × edge axes are
    skipped, which can only report an intersection that is not there: conservative).
    """
    from scipy.spatial import ConvexHull, QhullError

    tri = np.asarray(triangles, np.float64)
    ok = np.zeros(len(pairs), bool)
    if not len(tri):
        ok[:] = True
        return ok
    pts = tri.reshape(-1, 3)
    tol = 1e-6 * max(float(np.max(pts.max(0) - pts.min(0))), 1.0)
    tlo, thi = tri.min(axis=1), tri.max(axis=1)
    tn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    tn /= np.maximum(np.linalg.norm(tn, axis=1, keepdims=True), 1e-300)
    toff = -np.einsum("ij,ij->i", tn, tri[:, 0])
    for q, k in enumerate(pairs):
        a, b = part.pairs[k]
        corners = np.concatenate([_box_corners(part.lo[a], part.hi[a]),
                                  _box_corners(part.lo[b], part.hi[b])])
        lo, hi = corners.min(0), corners.max(0)
        near = np.flatnonzero(((tlo < hi - tol) & (thi > lo + tol)).all(axis=1))
        if not len(near):
            ok[q] = True
            continue
        try:
            eq = ConvexHull(corners).equations  # (F, 4): n·x + d ≤ 0 inside
        except QhullError:
            continue  # degenerate hull: keep the pair dense
        v = tri[near]  # (t, 3, 3)
        face = np.einsum("tkc,fc->tkf", v, eq[:, :3]) + eq[:, 3]
        sep = (face.min(axis=1) >= -tol).any(axis=1)  # the whole triangle outside some face
        side = corners @ tn[near].T + toff[near]  # (16, t): hull on one side of the triangle
        sep |= (side.min(axis=0) >= -tol) | (side.max(axis=0) <= tol)
        ok[q] = bool(sep.all())
    return ok


def _kernel(c, n, a, s, C, N, A, S):
    """``A_i F_ij`` of the far kernel (float64), one patch (c, n, a, spread s) against arrays."""
    d = C - c
    d2 = np.einsum("ij,ij->i", d, d)
    ci = d @ n
    cj = -np.einsum("ij,ij->i", d, N)
    ok = (ci > 0) & (cj > 0)
    g = far_g(np.where(ok, ci, 1.0), np.where(ok, cj, 1.0), N @ n, d2, a, A, s, S)
    return np.where(ok, g, 0.0)


def aca_block(ca, na, aa, cb, nb, ab, tol: float, max_rank: int, checks: int = 256, seed=0,
              sa=None, sb=None):
    """Low-rank ``U Vᵀ ≈ G`` of the far block (receivers a, sources b), or ``None``.

    ``sa, sb``: the patches' spreads for the far kernel's correction (``far_g``; default:
    disks of the same area).

    ``None`` when the rank needed exceeds ``max_rank`` or the random-entry check fails.
    Returns ``(U, V, stats)`` with U (m, r), V (n, r) float64; r = 0 for a block that is zero
    (no facing patch pair found).
    """
    m, n = len(ca), len(cb)
    sa = aa / (4 * np.pi) if sa is None else sa
    sb = ab / (4 * np.pi) if sb is None else sb
    rng = np.random.default_rng(seed)
    cap = max(1, min(max_rank, m, n))
    U = np.zeros((m, cap))
    V = np.zeros((n, cap))
    used = np.zeros(m, bool)
    # start from the receiver nearest to the source block's centre
    i = int(np.argmin(np.linalg.norm(ca - cb.mean(0), axis=1)))
    k, norm2, scale, misses, converged = 0, 0.0, 0.0, 0, False
    stop = 0.5 * tol
    while True:
        used[i] = True
        row = _kernel(ca[i], na[i], aa[i], sa[i], cb, nb, ab, sb) - V[:, :k] @ U[i, :k]
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
        u = _kernel(cb[j], nb[j], ab[j], sb[j], ca, na, aa, sa) - U[:, :k] @ V[j, :k]
        norm2 += 2.0 * float((U[:, :k].T @ u) @ (V[:, :k].T @ v)) + float(u @ u) * float(v @ v)
        U[:, k], V[:, k] = u, v
        k += 1
        if np.sqrt(float(u @ u) * float(v @ v)) <= stop * np.sqrt(max(norm2, 0.0)):
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
    U, V = U[:, :k], V[:, :k]
    if k:
        # recompression: G ≈ Qu (Ru Rvᵀ) Qvᵀ, truncated SVD of the small core
        qu, ru = np.linalg.qr(U)
        qv, rv = np.linalg.qr(V)
        w, s, zt = np.linalg.svd(ru @ rv.T)
        tail = np.sqrt(np.cumsum((s**2)[::-1]))[::-1]  # tail[r] = ‖s[r:]‖
        below = np.flatnonzero(tail <= stop * tail[0])
        keep = (int(below[0]) if len(below) else len(s)) if tail[0] > 0 else 0
        U = qu @ (w[:, :keep] * s[:keep])
        V = qv @ zt[:keep].T
    # check on random entries (the ACA stopping rule is a heuristic)
    ii = rng.integers(0, m, checks)
    jj = rng.integers(0, n, checks)
    d = cb[jj] - ca[ii]
    d2 = np.einsum("ij,ij->i", d, d)
    cos_i = np.einsum("ij,ij->i", d, na[ii])
    cos_j = -np.einsum("ij,ij->i", d, nb[jj])
    ok = (cos_i > 0) & (cos_j > 0)
    exact = far_g(np.where(ok, cos_i, 1.0), np.where(ok, cos_j, 1.0),
                  np.einsum("ij,ij->i", na[ii], nb[jj]), d2, aa[ii], ab[jj], sa[ii], sb[jj])
    exact = np.where(ok, exact, 0.0)
    approx = np.einsum("ir,ir->i", U[ii], V[jj])
    err = np.sqrt(m * n * np.mean((approx - exact) ** 2))
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
