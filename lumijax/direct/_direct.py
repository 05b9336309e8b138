"""Direct illuminance on receiver points from every luminaire, with shadows, per network.

Point sources go through the pair set (``_pairs.py``, shared with the optimiser's aim model):
per batch, the culled (source, point) pairs get the one kernel and shadow rays where lit, and
are summed into their network and forgotten. Luminaires with a large luminous opening are split into sub-sources
where a receiver is closer than five times the opening (the usual 5× rule). Area sources are
integrated exactly (Lambert's contour integral over the whole rectangle); shadows are looked
for only where a scene triangle penetrates the receiver's view pyramid of the rectangle, by an
adaptive quadtree down to the 5× rule's pieces, each finest piece still in doubt getting four
stratified rays (fractional visibility).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from ..kernels import form_factor_point_triangle, length_tolerance
from ..parallel import Executor, LocalExecutor, batches, current_executor
from ._pairs import PairStats, Tiles, bands, pair_chunks, sub_source_offsets, support_cosine

__all__ = ["DirectLighting", "direct_illuminance", "sub_source_offsets", "support_cosine"]

Progress = Callable[[int, int], None]


@dataclass
class DirectLighting:
    """Direct illuminance per network on a set of receiver points, at dimmer 1.

    Attributes
    ----------
    by_network
        ``(networks, points)`` lux, network order as in ``scene.networks``.
    shadow_rays
        Number of shadow rays cast.
    candidate_pairs
        (source, point) pairs inside a beam and facing it: the pairs evaluated.
    timing_s
        Seconds spent in the kernels and in ray casting.
    """

    by_network: Float[np.ndarray, "net points"]
    shadow_rays: int = 0
    candidate_pairs: int = 0
    timing_s: dict[str, float] = field(default_factory=dict)


def direct_illuminance(
    scene,
    points: Float[np.ndarray, "points 3"],
    normals: Float[np.ndarray, "points 3"],
    *,
    shadows: bool = True,
    progress: Progress | None = None,
    response=None,
    executor: Executor | None = None,
) -> DirectLighting:
    """Direct illuminance (lx) at ``points`` on planes of ``normals``, per network at dimmer 1.

    Parameters
    ----------
    scene
        A :class:`lumijax.scene.Scene`.
    points, normals
        Receiver positions (m) and unit normals.
    shadows
        Cast shadow rays against all of the scene's triangles (default). ``False`` gives the
        unobstructed illuminance, useful to check a design's photometry alone.
    progress
        Called as ``progress(done, total)`` in luminaires (those with a batch of pairs
        done) and area sources done.
    response
        A :class:`lumijax.direct.SensorResponse`: the points are sensors (cylindrical,
        semi-cylindrical, hemispherical) of point sources; area sources are then not included
        (``lumijax.compliance`` adds them).
    executor
        Where batches of sources are lit (:mod:`lumijax.parallel`; default
        :func:`~lumijax.parallel.current_executor`): on a cluster each batch of luminaires is
        one task and the networks' sums are added here.

    Notes
    -----
    Only pairs that can receive light are evaluated: a receiver must face the source and lie
    inside the cone where the source's distribution is non-zero (:func:`support_cosine`). The
    culling is exact: a skipped pair's illuminance is zero.
    """
    points = np.ascontiguousarray(points, np.float64)
    normals = np.asarray(normals, np.float64)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    n_pts = len(points)
    net_index = {n.name: k for k, n in enumerate(scene.networks)}
    out = np.zeros((len(scene.networks), n_pts))
    result = DirectLighting(out, timing_s={"cull": 0.0, "kernel": 0.0, "shadow_rays": 0.0})
    if n_pts == 0:
        return result
    ex = current_executor() if executor is None else executor
    if ex.distributed and len(scene.luminaires) + len(scene.area_sources) > 1:
        return _mapped(ex, scene, points, normals, shadows, response, progress, result)
    caster = scene.raycaster if shadows and len(scene.triangles) else None
    network = np.array([net_index[lum.network] for lum in scene.luminaires], np.int64)
    stats = PairStats(timing_s=result.timing_s)
    # progress in luminaires lit (each chunk's), not photometries: a courtyard's photometries
    # range from 24 to 1,500 luminaires, and a bar counting them promised 6 s with 0.2 s left
    total = len(scene.luminaires) + len(scene.area_sources)
    lit = np.zeros(len(scene.luminaires), bool)
    for c in pair_chunks(scene, points, normals, caster=caster, stats=stats, response=response,
                         geometry=False):
        flat = network[c.luminaire] * n_pts + c.receiver
        out.reshape(-1)[:] += np.bincount(flat, weights=c.light, minlength=out.size)
        if progress is not None:
            lit[c.luminaire] = True
            progress(int(lit.sum()), total)
    result.candidate_pairs, result.shadow_rays = stats.candidate_pairs, stats.shadow_rays
    done = len(scene.luminaires)
    if progress is not None and done:
        progress(done, total)
    for area in (scene.area_sources if response is None else ()):
        e, rays = _area_illuminance(area, points, normals, caster, result.timing_s,
                                    scene.triangles.vertices if caster is not None else None)
        out[net_index[area.network]] += e
        result.shadow_rays += rays
        done += 1
        if progress is not None:
            progress(done, total)
    return result


def _mapped(ex: Executor, scene, points, normals, shadows, response, progress,
            result: DirectLighting) -> DirectLighting:
    """``direct_illuminance`` with the sources cut into batches, one task each, summed here
    (reports ``(batches done, batches)``)."""
    parts = batches(len(scene.luminaires) + len(scene.area_sources), ex.parts())
    done = ex.map(_direct_task, parts, shared=dict(scene=scene, points=points, normals=normals,
                                                   shadows=shadows, response=response))
    for k, d in enumerate(done):
        result.by_network += d.by_network
        result.shadow_rays += d.shadow_rays
        result.candidate_pairs += d.candidate_pairs
        for key, v in d.timing_s.items():
            result.timing_s[key] = result.timing_s.get(key, 0.0) + v
        if progress is not None:
            progress(k + 1, len(parts))
    return result


def _direct_task(batch: range, *, scene, points, normals, shadows, response) -> DirectLighting:
    """The light of sources ``batch`` (luminaires, then area sources) on any process: the same
    scene with only those sources, sharing its ray caster (built once per worker)."""
    n = len(scene.luminaires)
    lum = [i for i in batch if i < n]
    part = dataclasses.replace(
        scene, luminaires=tuple(scene.luminaires[i] for i in lum),
        area_sources=tuple(scene.area_sources[i - n] for i in batch if i >= n),
        levels=None if scene.levels is None else scene.levels[lum],
        rated_scales=None if scene.rated_scales is None else scene.rated_scales[lum])
    if shadows and len(scene.triangles):
        part.__dict__["raycaster"] = scene.raycaster
    return direct_illuminance(part, points, normals, shadows=shadows, response=response,
                              executor=LocalExecutor())


def _area_illuminance(area, points, normals, caster, timing, triangles=None):
    """Illuminance from one Lambertian rectangle: M·(F − Σ_s F_s·(1 − V_s)).

    F, the unshadowed factor of the whole rectangle, is exact (Lambert's contour integral).
    Shadows are then looked for only where they can be: a receiver whose pyramid (apex the
    receiver, base the rectangle) no scene triangle penetrates sees all of it, exactly, with no
    ray at all. Otherwise the rectangle is split as a quadtree, per receiver, over the pieces
    its distance needs (the 5× rule, :func:`bands`): a piece whose own pyramid is clear is
    fully visible and needs nothing; only the finest pieces that still meet an occluder get
    the four stratified rays and subtract their hidden fraction. The answer is that of
    casting four rays to every finest piece (the former method), at a cost that scales with
    the shadow's edge instead of the rectangle's area.
    """
    quad = np.stack([area.origin, area.origin + area.u, area.origin + area.u + area.v,
                     area.origin + area.v])
    t0 = time.perf_counter()
    f = _quad_pairs(points, normals, np.broadcast_to(quad, (len(points), 4, 3)))
    timing["kernel"] += time.perf_counter() - t0
    out = area.exitance * f
    lit = np.flatnonzero(f > 0)
    if caster is None or not len(lit):
        return out, 0
    tri = None if triangles is None else np.asarray(triangles, np.float64)
    pts = points[lit]
    rel = pts - area.origin
    uu, vv = area.u @ area.u, area.v @ area.v
    s = np.clip(rel @ area.u / uu, 0, 1)
    t = np.clip(rel @ area.v / vv, 0, 1)
    dist = np.linalg.norm(area.origin + s[:, None] * area.u + t[:, None] * area.v - pts, axis=1)
    size = float(np.sqrt(max(uu, vv)))
    nu = np.ones(len(lit), np.int64)
    nv = np.ones(len(lit), np.int64)
    for n, lo, hi in bands(size):
        sel = (dist >= lo) & (dist < hi)
        nu[sel] = max(1, math.ceil(n * np.sqrt(uu) / size - 1e-9))
        nv[sel] = max(1, math.ceil(n * np.sqrt(vv) / size - 1e-9))
    t0 = time.perf_counter()
    tol = None
    if tri is not None and len(tri):
        # touching within this is not penetrating: relative to the scene, never under the
        # rounding of its coordinates (length_tolerance), so any unit and any site position
        tol = length_tolerance(np.concatenate([tri.reshape(-1, 3), quad, pts]), 1e-6)
    node_r, pair_node, pair_tri, unknown = _occluder_candidates(pts, normals[lit], quad, tri,
                                                                caster, tol)
    timing["visibility_test"] = timing.get("visibility_test", 0.0) + time.perf_counter() - t0
    hidden = np.zeros(len(lit))
    rays = 0
    # receivers whose candidate list is too long to test: every finest piece gets rays
    for r0 in range(0, len(unknown), _AREA_CHUNK):
        r = unknown[r0:r0 + _AREA_CHUNK]
        rr, ii, jj = _leaves(np.stack([r, 0 * r, nu[r], 0 * r, nv[r]], axis=1))
        rays += _shade_leaves(area, pts, normals[lit], rr, ii, jj, nu[rr], nv[rr], caster,
                              timing, hidden)
    # the quadtree, one level at a time, on the receivers with a penetrating triangle
    order = np.argsort(node_r, kind="stable")
    node_r = node_r[order]
    remap = np.empty_like(order)
    remap[order] = np.arange(len(order))
    pair_node = remap[pair_node]
    for c0 in range(0, len(node_r), _AREA_CHUNK):
        sel_pairs = (pair_node >= c0) & (pair_node < c0 + _AREA_CHUNK)
        r = node_r[c0:c0 + _AREA_CHUNK]
        nodes = np.stack([r, np.zeros_like(r), nu[r], np.zeros_like(r), nv[r]], axis=1)
        rays += _descend(area, pts, normals[lit], nodes, pair_node[sel_pairs] - c0,
                         pair_tri[sel_pairs], tri, nu, nv, caster, timing, hidden, tol)
    out[lit] = np.maximum(out[lit] - area.exitance * hidden, 0.0)
    return out, rays


_AREA_CHUNK = 2048  # receivers per quadtree pass: bounds the (piece, triangle) pair arrays
_MAX_CANDIDATES = 4096  # triangles per receiver tile beyond which pieces get rays untested


def _corners(area, i0, i1, j0, j1, nu, nv):
    """World corners (N, 4, 3) of pieces [i0, i1) × [j0, j1) of an nu × nv grid."""
    a0, a1 = (i0 / nu)[:, None], (i1 / nu)[:, None]
    b0, b1 = (j0 / nv)[:, None], (j1 / nv)[:, None]
    o, u, v = area.origin, area.u, area.v
    return np.stack([o + a0 * u + b0 * v, o + a1 * u + b0 * v, o + a1 * u + b1 * v,
                     o + a0 * u + b1 * v], axis=1)


def _descend(area, pts, nrm, nodes, pair_node, pair_tri, tri, nu, nv, caster, timing, hidden,
             tol):
    """Walk the quadtree of ``nodes`` (rows: receiver, i0, i1, j0, j1), each penetrated by the
    triangles of its (pair_node, pair_tri) rows; add hidden factors into ``hidden``.

    Per level: a node that one triangle covers entirely is hidden exactly (its factor is
    subtracted); a node of at most ``_SHADE_DIRECT`` pieces gets rays on every piece (cheaper
    than testing its children); the rest are split and their children tested.
    """
    rays = 0
    while len(nodes):
        r, i0, i1, j0, j1 = nodes.T
        t0 = time.perf_counter()
        quads = _corners(area, i0, i1, j0, j1, nu[r], nv[r])
        cov = _covers(pts[r], quads, pair_node, tri[pair_tri], tol)
        covered = np.zeros(len(nodes), bool)
        covered[pair_node[cov]] = True
        timing["visibility_test"] += time.perf_counter() - t0
        if covered.any():
            c = np.flatnonzero(covered)
            t0 = time.perf_counter()
            f = _quad_pairs(pts[r[c]], nrm[r[c]], quads[c])
            hidden += np.bincount(r[c], weights=f, minlength=len(hidden))
            timing["kernel"] += time.perf_counter() - t0
        small = ~covered & ((i1 - i0) * (j1 - j0) <= _SHADE_DIRECT)
        if small.any():
            rr, ii, jj = _leaves(nodes[small])
            rays += _shade_leaves(area, pts, nrm, rr, ii, jj, nu[rr], nv[rr], caster, timing,
                                  hidden)
        split = ~covered & ~small
        # split 2 × 2 (1 × 2 or 2 × 1 along a side already one piece wide)
        im, jm = i0 + (i1 - i0 + 1) // 2, j0 + (j1 - j0 + 1) // 2
        kids = np.stack([
            np.stack([r, i0, im, j0, jm], 1), np.stack([r, im, i1, j0, jm], 1),
            np.stack([r, i0, im, jm, j1], 1), np.stack([r, im, i1, jm, j1], 1)], axis=1)
        ok = (kids[:, :, 2] > kids[:, :, 1]) & (kids[:, :, 4] > kids[:, :, 3]) & split[:, None]
        new_index = np.full(ok.shape, -1)
        new_index[ok] = np.arange(int(ok.sum()))
        kids = kids[ok]
        pn = (4 * pair_node[:, None] + np.arange(4)[None]).ravel()
        pt = np.repeat(pair_tri, 4)
        keep = ok.ravel()[pn]
        pn, pt = new_index.ravel()[pn[keep]], pt[keep]
        if not len(kids):
            break
        t0 = time.perf_counter()
        kr = kids[:, 0]
        hit = _pyramid_hits(pts[kr], nrm[kr], _corners(area, *kids[:, 1:].T, nu[kr], nv[kr]),
                            pn, tri[pt], tol)
        timing["visibility_test"] += time.perf_counter() - t0
        pn, pt = pn[hit], pt[hit]
        alive = np.zeros(len(kids), bool)
        alive[pn] = True
        renum = np.cumsum(alive) - 1
        nodes, pair_node, pair_tri = kids[alive], renum[pn], pt
    return rays


_SHADE_DIRECT = 4  # pieces: a node this small gets rays on each rather than another level


def _leaves(nodes):
    """(receiver, i, j) of every finest piece of ``nodes`` (rows: receiver, i0, i1, j0, j1)."""
    r, i0, i1, j0, j1 = nodes.T
    w = j1 - j0
    counts = (i1 - i0) * w
    k = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    ww = np.repeat(w, counts)
    return np.repeat(r, counts), np.repeat(i0, counts) + k // ww, np.repeat(j0, counts) + k % ww


def _covers(apex, quads, node, tris, tol):
    """Per (node, triangle) row: does the triangle hide the node's whole pyramid?

    It does when all four edges apex → base corner cross the triangle's plane strictly between
    their ends and inside the triangle: the pyramid's section by that plane is the convex hull
    of the four crossings, so it lies inside the (convex) triangle and every segment from the
    apex to the base crosses it.
    """
    if not len(node):
        return np.zeros(0, bool)
    a = apex[node]
    c = quads[node]  # (P, 4, 3)
    t = tris
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    nn = np.linalg.norm(n, axis=1)
    n = n / np.where(nn > 0, nn, 1.0)[:, None]
    off = np.einsum("pc,pc->p", t[:, 0], n)
    da = np.einsum("pc,pc->p", a, n) - off
    dc = np.einsum("pkc,pc->pk", c, n) - off[:, None]
    crosses = ((da[:, None] > tol) & (dc < -tol)) | ((da[:, None] < -tol) & (dc > tol))
    ok = crosses.all(axis=1) & (nn > 0)
    s = da[:, None] / np.where(crosses, da[:, None] - dc, 1.0)
    x = a[:, None] + s[..., None] * (c - a[:, None])  # (P, 4, 3) crossings
    for k in range(3):
        e = t[:, (k + 1) % 3] - t[:, k]
        side = np.einsum("pkc,pc->pk", np.cross(e[:, None], x - t[:, None, k]), n)
        ok &= (side >= 0).all(axis=1)
    return ok


def _shade_leaves(area, pts, nrm, r, i0, j0, nu, nv, caster, timing, hidden):
    """Four stratified shadow rays per finest piece; add F_piece × blocked fraction (a ray
    through clear glass counts as blocked by 1 − τ(θ))."""
    if not len(r):
        return 0
    quads = _corners(area, i0, i0 + 1, j0, j0 + 1, nu, nv)
    du, dv = quads[:, 1] - quads[:, 0], quads[:, 3] - quads[:, 0]
    offs = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]])
    samples = quads[:, None, 0] + offs[None, :, 0, None] * du[:, None] \
        + offs[None, :, 1, None] * dv[:, None]
    t0 = time.perf_counter()
    k = len(offs)
    blocked = 1.0 - caster.transmission(np.repeat(pts[r], k, axis=0), samples.reshape(-1, 3))
    frac = blocked.reshape(-1, k).mean(axis=1)
    t1 = time.perf_counter()
    timing["shadow_rays"] += t1 - t0
    some = np.flatnonzero(frac > 0)
    if len(some):
        f = _quad_pairs(pts[r[some]], nrm[r[some]], quads[some])
        hidden += np.bincount(r[some], weights=f * frac[some], minlength=len(hidden))
    timing["kernel"] += time.perf_counter() - t1
    return len(r) * k


def _occluder_candidates(pts, nrm, quad, tri, caster, tol):
    """Receivers (indices into ``pts``) whose pyramid to ``quad`` a scene triangle penetrates,
    as (receiver per node, pair node, pair triangle) with one root node per such receiver,
    plus the receivers with too many nearby triangles to test (``unknown``).

    Triangles are first kept per tile of receivers by a bounding-box overlap with the tile and
    the rectangle, then tested exactly (separating axes) per receiver.
    """
    empty = np.zeros(0, np.int64)
    if tri is None or not len(tri):
        if caster is None or caster.n_triangles == 0:
            return empty, empty, empty, empty
        return empty, empty, empty, np.arange(len(pts))  # no triangles to test: rays only
    tlo, thi = tri.min(axis=1), tri.max(axis=1)
    tiles = Tiles.build(pts)
    qlo, qhi = quad.min(0), quad.max(0)
    pn, pt, unknown = [], [], []
    for t in range(len(tiles.radius)):
        idx = tiles.order[tiles.offsets[t]:tiles.offsets[t + 1]]
        lo = np.minimum(pts[idx].min(0), qlo)
        hi = np.maximum(pts[idx].max(0), qhi)
        cand = np.flatnonzero(((tlo < hi - tol) & (thi > lo + tol)).all(axis=1))
        if not len(cand):
            continue
        if len(cand) > _MAX_CANDIDATES:
            unknown.append(idx)
            continue
        for c0 in range(0, len(cand), max(1, (1 << 20) // len(idx))):
            cc = cand[c0:c0 + max(1, (1 << 20) // len(idx))]
            rr = np.repeat(idx, len(cc))
            tt = np.tile(cc, len(idx))
            hit = _pyramid_hits(pts[idx], nrm[idx], np.broadcast_to(quad, (len(idx), 4, 3)),
                                np.repeat(np.arange(len(idx)), len(cc)), tri[tt], tol)
            pn.append(rr[hit])
            pt.append(tt[hit])
    if pn:
        rr, tt = np.concatenate(pn), np.concatenate(pt)
        node_r, pair_node = np.unique(rr, return_inverse=True)
        return node_r, pair_node, tt, (np.concatenate(unknown) if unknown else empty)
    return empty, empty, empty, (np.concatenate(unknown) if unknown else empty)


def _pyramid_hits(apex, normal, quads, node, tris, tol):
    """Per (node, triangle) row: does triangle ``tris[k]`` penetrate the pyramid of node
    ``node[k]`` (apex ``apex``, base ``quads``, both per node)?

    Separating axes: the base's normal, the four side faces' normals and the triangle's normal
    (edge × edge axes skipped, which can only report a penetration that is not there, so
    "no" is exact). Touching — the receiver's own surface, a coplanar neighbour, the surface
    an emitter lies on — is not penetrating. The node's axes and extents are computed once per
    node, so a pair costs a few dozen flops. A triangle on or behind the receiver's plane
    (``normal``) cannot block light reaching the receiver's front face, so it does not count
    either (the far side of the object the receiver lies on).
    """
    if not len(node):
        return np.zeros(0, bool)
    rel = tris - apex[node][:, None]
    front = np.einsum("pkc,pc->pk", rel, normal[node]).max(axis=1) > tol
    node, t = node[front], tris[front]
    b = quads - apex[:, None]
    axes = np.stack([np.cross(b[:, 1] - b[:, 0], b[:, 3] - b[:, 0])]
                    + [np.cross(b[:, k], b[:, (k + 1) % 4]) for k in range(4)], axis=1)
    norm = np.linalg.norm(axes, axis=2)  # (M, 5)
    scale = np.abs(b).max(axis=(1, 2))
    good = norm > 1e-12 * np.maximum(scale, 1e-300)[:, None] ** 2
    axes = axes / np.where(good, norm, 1.0)[..., None]
    pyr = np.concatenate([apex[:, None], quads], axis=1)  # (M, 5 vertices, 3)
    proj = np.einsum("mvc,mac->mva", pyr, axes)  # (M, 5 vertices, 5 axes)
    pmin, pmax = proj.min(axis=1), proj.max(axis=1)
    ax = axes[node]  # (P, 5, 3)
    tp = (t[:, :, None, 0] * ax[:, None, :, 0] + t[:, :, None, 1] * ax[:, None, :, 1]
          + t[:, :, None, 2] * ax[:, None, :, 2])  # (P, 3, 5)
    sep = (pmax[node] <= tp.min(axis=1) + tol) | (tp.max(axis=1) <= pmin[node] + tol)
    hit = ~(sep & good[node]).any(axis=1)
    tn = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    tnn = np.linalg.norm(tn, axis=1)
    tgood = tnn > 0
    tn = tn / np.where(tgood, tnn, 1.0)[:, None]
    off = np.einsum("pc,pc->p", t[:, 0], tn)
    pv = pyr[node]
    pp = pv[:, :, 0] * tn[:, None, 0] + pv[:, :, 1] * tn[:, None, 1] + pv[:, :, 2] * tn[:, None, 2]
    tsep = (pp.max(axis=1) <= off + tol) | (off <= pp.min(axis=1) + tol)
    out = np.zeros(len(front), bool)
    out[front] = hit & ~(tsep & tgood)
    return out


def _quad_pairs(points, normals, quads) -> np.ndarray:
    """Exact unshadowed form factor from each point to its own quad (rows matched), computed
    on coordinates relative to the point (float64 on the host, then the kernel)."""
    n = len(points)
    out = np.empty(n)
    rel = np.asarray(quads, np.float64) - np.asarray(points, np.float64)[:, None]
    nrm = np.asarray(normals, np.float64)
    for c0 in range(0, n, 1 << 16):
        m = min(1 << 16, n - c0)
        size = 4096 if m <= 4096 else 1 << 16  # two compiled shapes
        q = np.zeros((size, 4, 3))
        nn = np.zeros((size, 3))
        nn[:, 2] = 1.0
        q[:m], nn[:m] = rel[c0:c0 + m], nrm[c0:c0 + m]
        out[c0:c0 + m] = np.asarray(_quad_pair_block(jnp.asarray(q), jnp.asarray(nn)))[:m]
    return out


@jax.jit
def _quad_pair_block(rel_quads, normals):
    tris = jnp.stack([rel_quads[:, jnp.array([0, 1, 2])], rel_quads[:, jnp.array([0, 2, 3])]],
                     axis=1)
    f = form_factor_point_triangle(jnp.zeros_like(normals)[:, None], normals[:, None], tris)
    return jnp.sum(f, axis=-1)
