"""Direct illuminance on receiver points from every luminaire, with shadows, per network.

The pipeline per batch of sources: a JAX kernel gives unshadowed illuminance for a block of
(source, point) pairs; only the pairs that receive light get a shadow ray (Embree); the result is
summed into its network. Luminaires with a large luminous opening are split into sub-sources
where a receiver is closer than five times the opening (the usual 5× rule), and area sources are
integrated exactly (Lambert's contour integral per sub-rectangle) with fractional visibility
from four stratified rays per sub-rectangle.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from ._kernels import pair_illuminance, quad_form_factors

__all__ = ["DirectLighting", "direct_illuminance", "sub_source_offsets", "support_cosine"]

_MAX_SUB = 32  # sub-sources per opening axis: beyond this a bar is closer than 1/6 of its length
_PAIRS_PER_CALL = 1 << 20  # pairs per kernel call: one compiled shape per photometry
_CULL_PAIRS = 1 << 18  # (source, tile) pairs per culling step
_TILE = 256  # receiver points per culling tile

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


def sub_source_offsets(length_m: float, width_m: float, distance_m: float) -> np.ndarray:
    """Local offsets (m) of the sub-sources a luminous opening is split into for a receiver at
    ``distance_m``: each piece is at most a fifth of that distance long (capped at 32 a side)."""
    def count(size: float) -> int:
        if size <= 0:
            return 1
        return int(min(_MAX_SUB, max(1, math.ceil(5.0 * size / max(distance_m, 1e-9) - 1e-9))))

    nl, nw = count(length_m), count(width_m)
    xs = ((np.arange(nl) + 0.5) / nl - 0.5) * length_m
    ys = ((np.arange(nw) + 0.5) / nw - 0.5) * width_m
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)


@jax.jit
def _pair_block(distribution, positions, rotations, scales, points, normals, source, receiver):
    return pair_illuminance(distribution, positions, rotations, scales, points, normals,
                            source, receiver)


@jax.jit
def _quad_block(points, normals, quads):
    return quad_form_factors(points, normals, quads)


def support_cosine(distribution) -> float:
    """Cosine of the widest angle from the photometric axis at which ``distribution`` can be
    non-zero: the bilinear interpolant is non-zero up to the neighbours of non-zero samples, and
    a 2° margin covers Type A/B cells whose interior leans further out than their corners."""
    cd = np.asarray(distribution.candela)
    nz = cd > 0
    if not nz.any():
        return 1.0
    grown = nz.copy()
    grown[1:] |= nz[:-1]
    grown[:-1] |= nz[1:]
    grown[:, 1:] |= nz[:, :-1]
    grown[:, :-1] |= nz[:, 1:]
    hh, vv = np.meshgrid(np.asarray(distribution.h_deg), np.asarray(distribution.v_deg),
                         indexing="ij")
    dirs = np.asarray(distribution.direction(hh[grown], vv[grown]))
    widest = np.arccos(np.clip(np.min(-dirs[:, 2]), -1.0, 1.0)) + np.radians(2.0)
    return float(np.cos(widest)) if widest < np.pi else -1.0


def direct_illuminance(
    scene,
    points: Float[np.ndarray, "points 3"],
    normals: Float[np.ndarray, "points 3"],
    *,
    shadows: bool = True,
    progress: Progress | None = None,
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
        Called as ``progress(done, total)`` in units of sources processed.

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
    caster = scene.raycaster if shadows and len(scene.triangles) else None
    batches = _point_source_batches(scene)
    total = sum(len(b[1]) for b in batches) + len(scene.area_sources)
    done = 0
    pts_j, nrm_j = jnp.asarray(points), jnp.asarray(normals)
    tiles = _Tiles.build(points)
    for phot_name, pos, rot, scale, owner, centre, d_lo, d_hi in batches:
        banded = bool(np.any(d_lo > 0) or np.any(np.isfinite(d_hi)))
        dist = scene.photometries[phot_name].distribution
        cos_support = support_cosine(dist)
        axis = -rot[:, :, 2]  # world direction of each source's photometric axis (local −z)
        # one padding source of scale 0 at the end, so padded pairs add nothing
        tables = (jnp.asarray(np.vstack([pos, pos[:1]])),
                  jnp.asarray(np.concatenate([rot, rot[:1]])),
                  jnp.asarray(np.append(scale, 0.0)))
        per_cull = max(1, _CULL_PAIRS // max(len(tiles.radius), 1))
        batch = _SourceBatch(dist, tables, pos, owner)
        pending: list[tuple[np.ndarray, np.ndarray]] = []
        pending_n = 0
        for c0 in range(0, len(pos), per_cull):
            t0 = time.perf_counter()
            sl = slice(c0, c0 + per_cull)
            i, j = _candidates(tiles, points, normals, pos[sl], axis[sl], cos_support,
                               centre[sl] if banded else None, d_lo[sl], d_hi[sl])
            result.timing_s["cull"] += time.perf_counter() - t0
            pending.append(((i + c0).astype(np.int32), j.astype(np.int32)))
            pending_n += len(i)
            result.candidate_pairs += len(i)
            if pending_n >= _PAIRS_PER_CALL or c0 + per_cull >= len(pos):
                src = np.concatenate([p[0] for p in pending])
                rcv = np.concatenate([p[1] for p in pending])
                pending, pending_n = [], 0
                _evaluate_pairs(batch, src, rcv, pts_j, nrm_j, points, caster, out, result)
            done += len(pos[sl])
            if progress is not None:
                progress(done, total)

    for area in scene.area_sources:
        e, rays = _area_illuminance(area, points, normals, caster, result.timing_s)
        out[net_index[area.network]] += e
        result.shadow_rays += rays
        done += 1
        if progress is not None:
            progress(done, total)
    return result


@dataclass(frozen=True)
class _SourceBatch:
    """Sources sharing one distribution: JAX tables (with one scale-0 padding source last),
    world positions (numpy, for shadow rays) and each source's network index."""

    distribution: object
    tables: tuple
    positions: np.ndarray
    network: np.ndarray


@dataclass(frozen=True)
class _Tiles:
    """Receiver points clustered by median bisection into tiles of at most ``_TILE`` points:
    ``order[offsets[t]:offsets[t+1]]`` are tile t's points; each tile has a bounding sphere."""

    order: np.ndarray
    offsets: np.ndarray
    centre: np.ndarray
    radius: np.ndarray

    @classmethod
    def build(cls, points: np.ndarray) -> _Tiles:
        leaves: list[np.ndarray] = []
        stack = [np.arange(len(points))]
        while stack:
            idx = stack.pop()
            if len(idx) <= _TILE:
                leaves.append(idx)
                continue
            p = points[idx]
            axis = int(np.argmax(np.ptp(p, axis=0)))
            half = np.argsort(p[:, axis], kind="stable")
            mid = len(idx) // 2
            stack += [idx[half[:mid]], idx[half[mid:]]]
        order = np.concatenate(leaves)
        offsets = np.concatenate([[0], np.cumsum([len(x) for x in leaves])])
        centre = np.array([points[x].mean(axis=0) for x in leaves])
        radius = np.array([np.linalg.norm(points[x] - c, axis=1).max()
                           for x, c in zip(leaves, centre, strict=True)])
        return cls(order, offsets, centre, radius)


def _candidates(tiles, pts, nrm, pos, axis, cos_support, centre, d_lo, d_hi):
    """``(source, point)`` pairs that can receive light: the point faces the source, lies in
    the support cone of its beam and (sub-sources) in its distance band.

    Whole tiles are rejected first by a cone–sphere and a band–sphere test, so a narrow spot
    costs little more than the points it lights.
    """
    v = tiles.centre[None, :, :] - pos[:, None, :]  # (src, tiles, 3)
    dist = np.linalg.norm(v, axis=2)
    r = tiles.radius[None, :]
    # angle to the tile centre minus the tile's angular radius must be within the cone
    cos_c = np.einsum("ltk,lk->lt", v, axis) / np.maximum(dist, 1e-300)
    ang = np.arccos(np.clip(cos_c, -1.0, 1.0)) - np.arcsin(np.clip(r / np.maximum(dist, 1e-300),
                                                                   0.0, 1.0))
    keep = (dist <= r) | (ang <= np.arccos(np.clip(cos_support, -1.0, 1.0)) + 1e-9)
    if centre is not None:
        dc = np.linalg.norm(tiles.centre[None, :, :] - centre[:, None, :], axis=2)
        keep &= (dc + r >= d_lo[:, None]) & (dc - r < d_hi[:, None])
    src_out, pt_out = [], []
    for li in np.flatnonzero(keep.any(axis=1)):
        sel = np.flatnonzero(keep[li])
        idx = np.concatenate([tiles.order[tiles.offsets[t]:tiles.offsets[t + 1]] for t in sel])
        d = pts[idx] - pos[li]
        rr = np.sqrt(np.einsum("pk,pk->p", d, d))
        ok = (np.einsum("pk,pk->p", d, nrm[idx]) < 0) & (d @ axis[li] >= cos_support * rr - 1e-9)
        if centre is not None:
            rc = np.linalg.norm(pts[idx] - centre[li], axis=1)
            ok &= (rc >= d_lo[li]) & (rc < d_hi[li])
        hit = idx[ok]
        src_out.append(np.full(len(hit), li, np.int32))
        pt_out.append(hit.astype(np.int32))
    if not src_out:
        return np.zeros(0, np.int32), np.zeros(0, np.int32)
    return np.concatenate(src_out), np.concatenate(pt_out)


def _bucket(n: int) -> int:
    """Padded call size: powers of 4 from 4096 up, so few shapes are ever compiled."""
    size = 4096
    while size < n:
        size *= 4
    return min(size, _PAIRS_PER_CALL)


def _evaluate_pairs(batch, src, rcv, pts_j, nrm_j, points, caster, out, result) -> None:
    """Illuminance of candidate pairs, shadowed, summed into ``out[network, point]``."""
    n_pts = len(points)
    pad_src = len(batch.positions)
    for c0 in range(0, len(src), _PAIRS_PER_CALL):
        s_idx, r_idx = src[c0:c0 + _PAIRS_PER_CALL], rcv[c0:c0 + _PAIRS_PER_CALL]
        n = len(s_idx)
        pad = _bucket(n) - n
        t0 = time.perf_counter()
        e = np.array(_pair_block(
            batch.distribution, *batch.tables, pts_j, nrm_j,
            jnp.asarray(np.pad(s_idx, (0, pad), constant_values=pad_src)),
            jnp.asarray(np.pad(r_idx, (0, pad))),
        ), dtype=np.float64)[:n]
        t1 = time.perf_counter()
        result.timing_s["kernel"] += t1 - t0
        if caster is not None:
            lit = np.flatnonzero(e > 0)
            if len(lit):
                blocked = caster.occluded(batch.positions[s_idx[lit]], points[r_idx[lit]])
                e[lit[blocked]] = 0.0
                result.shadow_rays += len(lit)
            result.timing_s["shadow_rays"] += time.perf_counter() - t1
        flat = batch.network[s_idx].astype(np.int64) * n_pts + r_idx
        out.reshape(-1)[:] += np.bincount(flat, weights=e, minlength=out.size)


def _bands(size: float) -> list[tuple[int, float, float]]:
    """Subdivision levels of an opening of largest side ``size`` (m): ``(pieces, d_min, d_max)``.

    A receiver at distance d from the centre uses the first power of two n with
    size/n ≤ d/5 (the 5× rule per piece), capped at ``_MAX_SUB``: each receiver pays only for
    the subdivision its own distance needs.
    """
    out, n, hi = [], 1, np.inf
    while True:
        lo = 5.0 * size / n
        if n >= _MAX_SUB:
            out.append((n, 0.0, hi))
            return out
        out.append((n, lo, hi))
        n, hi = 2 * n, lo


def _point_source_batches(scene):
    """Point sources grouped by photometry: positions, rotations, scales, network index, and
    the centre and distance band in which each source (or sub-source) applies."""
    net_index = {n.name: k for k, n in enumerate(scene.networks)}
    groups: dict[str, list] = {}
    for lum in scene.luminaires:
        phot = scene.photometries[lum.photometry]
        rot = lum.rotation
        length, width = phot.opening.length_m, phot.opening.width_m
        size = max(length, width)
        # bands are on the distance to the opening, ≥ distance to its centre − half-diagonal
        half = 0.5 * float(np.hypot(length, width))
        bands = [(n, lo + half if lo > 0 else 0.0, hi + half) for n, lo, hi in _bands(size)] \
            if size > 0 else [(1, 0.0, np.inf)]
        g = groups.setdefault(lum.photometry, [[] for _ in range(7)])
        for n, lo, hi in bands:
            offsets = np.zeros((1, 3)) if n == 1 else sub_source_offsets(
                length, width, 5.0 * size / n)
            m = len(offsets)
            g[0].append(lum.position + offsets @ rot.T)
            g[1].append(np.broadcast_to(rot, (m, 3, 3)))
            g[2].append(np.full(m, lum.scale / m))
            g[3].append(np.full(m, net_index[lum.network]))
            g[4].append(np.broadcast_to(lum.position, (m, 3)))
            g[5].append(np.full(m, lo))
            g[6].append(np.full(m, hi))
    return [(name, *(np.concatenate(a) for a in arrays)) for name, arrays in groups.items()]


def _area_illuminance(area, points, normals, caster, timing):
    """Illuminance from one Lambertian rectangle: M·Σ_s F_s·V_s over its sub-rectangles.

    Unshadowed, the sum is exact for any subdivision (Lambert's contour integral per piece);
    the subdivision only sets how finely shadows are resolved, so each receiver gets the
    pieces its distance needs (the 5× rule, in distance bands).
    """
    rel = points - area.origin
    uu, vv = area.u @ area.u, area.v @ area.v
    s = np.clip(rel @ area.u / uu, 0, 1)
    t = np.clip(rel @ area.v / vv, 0, 1)
    dist = np.linalg.norm(area.origin + s[:, None] * area.u + t[:, None] * area.v - points, axis=1)
    size = float(np.sqrt(max(uu, vv)))
    out = np.zeros(len(points))
    rays = 0
    for n, lo, hi in _bands(size):
        sel = np.flatnonzero((dist >= lo) & (dist < hi))
        if not len(sel):
            continue
        nu = max(1, math.ceil(n * np.sqrt(uu) / size - 1e-9))
        nv = max(1, math.ceil(n * np.sqrt(vv) / size - 1e-9))
        e, r = _area_band(area, nu, nv, points[sel], normals[sel], caster, timing)
        out[sel] = e
        rays += r
    return out, rays


def _area_band(area, nu, nv, points, normals, caster, timing):
    a, b = np.meshgrid(np.arange(nu) / nu, np.arange(nv) / nv, indexing="ij")
    a, b = a.ravel(), b.ravel()
    du, dv = area.u / nu, area.v / nv
    base = area.origin + a[:, None] * area.u + b[:, None] * area.v
    quads = np.stack([base, base + du, base + du + dv, base + dv], axis=1)
    # 2 x 2 stratified visibility samples per sub-rectangle: fractional visibility, so a shadow
    # edge across a sub-rectangle is resolved rather than decided by its centre alone
    offs = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]])
    samples = base[:, None, :] + offs[None, :, 0, None] * du + offs[None, :, 1, None] * dv
    out = np.zeros(len(points))
    rays = 0
    chunk = max(1, _PAIRS_PER_CALL // len(quads))
    for p0 in range(0, len(points), chunk):
        sl = slice(p0, p0 + chunk)
        t0 = time.perf_counter()
        f = np.array(_quad_block(jnp.asarray(points[sl]), jnp.asarray(normals[sl]),
                                 jnp.asarray(quads)), dtype=np.float64)
        t1 = time.perf_counter()
        timing["kernel"] += t1 - t0
        if caster is not None:
            i, j = np.nonzero(f > 0)
            if len(i):
                k = len(offs)
                blocked = caster.occluded(
                    np.repeat(points[sl][i], k, axis=0), samples[j].reshape(-1, 3)
                ).reshape(-1, k)
                f[i, j] *= 1.0 - blocked.mean(axis=1)
                rays += len(i) * k
            timing["shadow_rays"] += time.perf_counter() - t1
        out[sl] = area.exitance * f.sum(axis=1)
    return out, rays
