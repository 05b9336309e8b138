"""The (source, receiver) pair set of point-source direct light: built once, by one culling and
one set of shadow rays, and evaluated by one kernel (:func:`lumijax.kernels.pair_light`) for both
the forward light (:func:`lumijax.direct.direct_illuminance`) and the optimiser's aim model
(``lumijax.optimise``).

A pair is a (sub-)source and a receiver that can receive its light: the receiver faces it, lies
in the cone where the distribution is non-zero (widened by how far the optimiser may turn the
aim), in the sub-source's distance band (the 5× rule for large openings), and is not shadowed.
What does not depend on the aim is kept: the unit direction (world frame) and the gain
``scale · cos θ_r / d²`` (1/m², times cd gives lx; the scale holds the sub-source's share, the
multiplier, maintenance factor, level and the LM-63 TILT factor of the start aim).

Culling is exact: a pair is skipped only where its light is exactly zero, and the steps are
ordered by what they cost. Receivers are clustered into tiles (bounding spheres); per source
and tile, a cone–sphere test against the support cone, a band–sphere test for sub-sources and,
for Type C tables, the tile's cone of directions against the table's cells that hold light
(:class:`_Support`: a washer's light is nowhere near round); then, per tile, one dense block
of (sources × points) tests for facing, cone and band; then the kernel, whose zero is the
last test: a shadow ray only for a pair with light (docs/radiosity.md, "Direct light at
scale").
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .. import _executables
from .._jit_cache import size_class, to_device
from ..kernels import pair_light
from ..photometry._distribution import angles_to_direction

__all__ = ["PairSet", "PairChunk", "build_pairs", "pair_chunks", "sub_source_offsets",
           "support_cosine"]

_MAX_SUB = 32  # sub-sources per opening axis: beyond this a bar is closer than 1/6 of its length
_PAIRS_PER_CALL = 1 << 20  # pairs per kernel call: one compiled shape per photometry
_CULL_PAIRS = 1 << 18  # (source, tile) pairs per culling step
_TILE = 256  # receiver points per culling tile
_EXPAND = 1 << 20  # (source, point) pairs tested per dense culling block
_MARGIN_DEG = 0.5  # added to a tile's angular radius: rounding, never a beam's edge
_KEEP_ENTRIES = 1 << 24  # (source, tile) flags held at once: sources a tile-major pass covers


class PairSet(eqx.Module):
    """The fixed pairs of one photometry: ``E = gain · I(Rᵀ w)`` (lx) per pair at any aim.

    Attributes
    ----------
    distribution
        The :class:`lumijax.photometry.CandelaDistribution` (cd) of these sources.
    luminaire
        Per pair, the index of its luminaire in the table of rotations given to :meth:`light`
        (the luminaires the set was built for, in that order).
    receiver
        Per pair, the receiver index.
    direction
        Unit vector source → receiver, world frame.
    gain
        ``scale · cos θ_r / d²`` (m⁻²); blocked pairs are not in the set.
    """

    distribution: object
    luminaire: Int[Array, " pairs"]
    receiver: Int[Array, " pairs"]
    direction: Float[Array, "pairs 3"]
    gain: Float[Array, " pairs"]

    def light(self, rotations: Float[Array, "lum 3 3"]) -> Float[Array, " pairs"]:
        """Direct illuminance (lx) of every pair with world-from-local luminaire
        ``rotations``."""
        return pair_light(self.distribution, rotations[self.luminaire], self.direction,
                          self.gain)

    def light_stored(self, rotations: Float[Array | np.ndarray, "lum 3 3"]
                     ) -> Float[np.ndarray, " pairs"]:
        """:meth:`light` (lx, float64 on the host) by the direct stage's stored kernel, in its
        padded calls: nothing compiles that the forward light has compiled, where an eager
        :meth:`light` compiles each of its operations for each new count of pairs (~0.02-0.06 s
        an operation: seconds for the aim model's pair sets)."""
        dt = self.gain.dtype
        rot_j = _rotation_table(rotations, dt)
        lum, w, gain = (np.asarray(a) for a in (self.luminaire, self.direction, self.gain))
        out = np.empty(len(lum))
        for a in range(0, len(lum), _PAIRS_PER_CALL):
            s = slice(a, a + _PAIRS_PER_CALL)
            out[s] = _stored_light(self.distribution, rot_j, lum[s], w[s], gain[s], dt)
        return out

class PairChunk(NamedTuple):
    """A batch of unshadowed-then-shadowed pairs of one photometry (numpy, float64), with the
    light of each at the start aims (lx); ``direction`` and ``gain`` (what the aim model needs)
    None where :func:`pair_chunks` was asked for the light alone."""

    photometry: str
    luminaire: np.ndarray
    receiver: np.ndarray
    direction: np.ndarray | None
    gain: np.ndarray | None
    light: np.ndarray


@dataclass
class PairStats:
    """What building pairs cost: pairs tested, shadow rays cast, seconds per step."""

    candidate_pairs: int = 0
    shadow_rays: int = 0
    timing_s: dict | None = None


def sub_source_offsets(length_m: float, width_m: float, distance_m: float) -> np.ndarray:
    """Local offsets (m) of the sub-sources a luminous opening is split into for a receiver at
    ``distance_m``: each piece is at most a fifth of that distance long (capped at 32 a side)."""
    def count(size: float) -> int:
        if size <= 0:
            return 1
        if 5.0 * size >= _MAX_SUB * distance_m:  # also distance 0, at any scale
            return _MAX_SUB
        return int(max(1, math.ceil(5.0 * size / distance_m - 1e-9)))

    nl, nw = count(length_m), count(width_m)
    xs = ((np.arange(nl) + 0.5) / nl - 0.5) * length_m
    ys = ((np.arange(nw) + 0.5) / nw - 0.5) * width_m
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)


def support_cosine(distribution, threshold: float = 0.0) -> float:
    """Cosine of the widest angle from the photometric axis at which ``distribution`` can exceed
    ``threshold`` × its peak (default: be non-zero at all): the bilinear interpolant reaches the
    neighbours of such samples, and a 2° margin covers Type A/B cells whose interior leans
    further out than their corners."""
    cd = np.asarray(distribution.candela)
    nz = cd > threshold * cd.max()
    if not nz.any():
        return 1.0
    grown = nz.copy()
    grown[1:] |= nz[:-1]
    grown[:-1] |= nz[1:]
    grown[:, 1:] |= nz[:, :-1]
    grown[:, :-1] |= nz[:, 1:]
    hh, vv = np.meshgrid(np.asarray(distribution.h_deg), np.asarray(distribution.v_deg),
                         indexing="ij")
    # in numpy, float64: a compiled program here cost one compile per table shape, and the 2°
    # margin dwarfs the float32 kernel's rounding
    dirs = angles_to_direction(distribution.photometric_type, np.radians(hh[grown]),
                               np.radians(vv[grown]), xp=np)
    widest = np.arccos(np.clip(np.min(-dirs[:, 2]), -1.0, 1.0)) + np.radians(2.0)
    return float(np.cos(widest)) if widest < np.pi else -1.0


def bands(size: float) -> list[tuple[int, float, float]]:
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


class _PointSources(NamedTuple):
    """Point sources (or sub-sources) of one photometry, one row each: positions (m), the
    luminaire (index into the selection), scales (candela multipliers incl. the sub-source's
    share), and the luminaire's centre (m) and the band of distance to it (m) where the row
    applies."""

    photometry: str
    position: np.ndarray
    luminaire: np.ndarray
    scale: np.ndarray
    centre: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


def _point_sources(scene, selection: Sequence[int]) -> list[_PointSources]:
    """Point sources of the luminaires ``selection`` grouped by photometry."""
    groups: dict[str, dict[str, list]] = {}
    for v, li in enumerate(selection):
        lum = scene.luminaires[li]
        phot = scene.photometries[lum.photometry]
        rot = lum.rotation
        length, width = phot.opening.length_m, phot.opening.width_m
        size = max(length, width)
        # bands are on the distance to the opening, ≥ distance to its centre − half-diagonal
        half = 0.5 * float(np.hypot(length, width))
        bnds = [(n, lo + half if lo > 0 else 0.0, hi + half) for n, lo, hi in bands(size)] \
            if size > 0 else [(1, 0.0, np.inf)]
        g = groups.setdefault(lum.photometry, {f: [] for f in _PointSources._fields[1:]})
        for n, lo, hi in bnds:
            offsets = np.zeros((1, 3)) if n == 1 else sub_source_offsets(
                length, width, 5.0 * size / n)
            m = len(offsets)
            g["position"].append(lum.position + offsets @ rot.T)
            g["luminaire"].append(np.full(m, v))
            g["scale"].append(np.full(m, lum.scale / m))
            g["centre"].append(np.broadcast_to(lum.position, (m, 3)))
            g["lo"].append(np.full(m, lo))
            g["hi"].append(np.full(m, hi))
    return [_PointSources(name, **{f: np.concatenate(a) for f, a in arrays.items()})
            for name, arrays in groups.items()]


@dataclass(frozen=True)
class Tiles:
    """Receiver points clustered by median bisection into tiles of at most ``_TILE`` points:
    ``order[offsets[t]:offsets[t+1]]`` are tile t's points; each tile has a bounding sphere."""

    order: np.ndarray
    offsets: np.ndarray
    centre: np.ndarray
    radius: np.ndarray

    @classmethod
    def build(cls, points: np.ndarray) -> Tiles:
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


class _Support:
    """Where a Type C distribution can exceed ``threshold`` × its peak, as cells of its table:
    a summed-area table of the cells any of whose four corners does, grown by one cell on
    every side (the bilinear interpolant is zero on a cell whose corners all are, and the
    growth absorbs a direction that lands one cell over by rounding). :meth:`may_light` then
    answers for a whole cone of directions at once, exactly in rejecting: far tighter than the
    support cone for a distribution whose light is not round (a washer's 110° × 24° beam
    reaches γ 172° along the bar but only 58° towards the wall).
    """

    def __init__(self, distribution, threshold: float = 0.0) -> None:
        cd = np.asarray(distribution.candela, np.float64)
        self.h = np.asarray(distribution.h_deg, np.float64)
        self.v = np.asarray(distribution.v_deg, np.float64)
        hot = cd > threshold * cd.max() if cd.max() > 0 else np.zeros(cd.shape, bool)
        cell = hot[:-1, :-1] | hot[1:, :-1] | hot[:-1, 1:] | hot[1:, 1:]
        grown = cell.copy()
        grown[1:] |= cell[:-1]
        grown[:-1] |= cell[1:]
        grown[0] |= cell[-1]  # C wraps: the first and last cells are neighbours
        grown[-1] |= cell[0]
        g2 = grown.copy()
        g2[:, 1:] |= grown[:, :-1]
        g2[:, :-1] |= grown[:, 1:]
        self.sat = np.zeros((g2.shape[0] + 1, g2.shape[1] + 1), np.int64)
        self.sat[1:, 1:] = np.cumsum(np.cumsum(g2, axis=0), axis=1)

    @classmethod
    def of(cls, distribution, threshold: float = 0.0) -> _Support | None:
        """The support of a Type C table over the whole C circle (0–360°); ``None`` for
        other types, whose tiles keep the support cone alone."""
        h = np.asarray(distribution.h_deg)
        if distribution.photometric_type != "C" or h[0] != 0.0 or h[-1] != 360.0:
            return None
        return cls(distribution, threshold)

    def _count(self, i0, i1, j0, j1):
        """Hot cells in rows i0..i1 and columns j0..j1 (inclusive; 0 where empty)."""
        s = self.sat
        n = s[i1 + 1, j1 + 1] - s[i0, j1 + 1] - s[i1 + 1, j0] + s[i0, j0]
        return np.where((i1 >= i0) & (j1 >= j0), n, 0)

    def _cells(self, grid, lo, hi):
        """Inclusive cell range of ``grid`` that the angles ``[lo, hi]`` (deg) touch."""
        last = len(grid) - 2
        return (np.clip(np.searchsorted(grid, lo, "right") - 1, 0, last),
                np.clip(np.searchsorted(grid, hi, "left") - 1, 0, last))

    def may_light(self, local, half_deg):
        """Per row: can a direction within ``half_deg`` (deg) of the unit vector ``local``
        (luminaire frame) get light? ``False`` is exact: every such direction's intensity is 0
        (at most the threshold)."""
        x, y, z = local.T
        gamma = np.degrees(np.arctan2(np.hypot(x, y), -z))
        c = np.mod(np.degrees(np.arctan2(y, x)), 360.0)
        g_lo, g_hi = gamma - half_deg, gamma + half_deg
        pole = (g_lo <= 0.0) | (g_hi >= 180.0)
        # azimuth half-width of a cap that holds no pole: asin(sin α / sin γ)
        sg = np.sin(np.radians(np.clip(gamma, 1e-9, 180.0 - 1e-9)))
        ratio = np.sin(np.radians(np.minimum(half_deg, 90.0))) / sg
        dc = np.where(pole | (ratio >= 1.0) | (half_deg >= 90.0), 180.0,
                      np.degrees(np.arcsin(np.clip(ratio, 0.0, 1.0))))
        j0, j1 = self._cells(self.v, np.maximum(g_lo, self.v[0]), np.minimum(g_hi, self.v[-1]))
        j1 = np.where((g_hi < self.v[0]) | (g_lo > self.v[-1]), j0 - 1, j1)  # off the table
        h0, h1 = self.h[0], self.h[-1]
        span = h1 - h0
        full = dc >= 180.0
        lo = np.where(full, h0, c - dc)
        hi = np.where(full, h1, c + dc)
        n = np.zeros(len(local), np.int64)
        for shift in (-span, 0.0, span):  # the C range and its wrapped images
            a, b = np.maximum(lo + shift, h0), np.minimum(hi + shift, h1)
            i0, i1 = self._cells(self.h, a, b)
            n += self._count(i0, np.where(b >= a, i1, i0 - 1), j0, j1)
        return n > 0


def _tile_keep(tiles, pos, axis, cos_support, centre, d_lo, d_hi, support=None, rotation=None,
               fixed=None, grow: float = 0.0):
    """``(sources, tiles)``: may the tile hold a point that receives the source's light?

    A cone–sphere test (angle to the tile's centre minus its angular radius within the support
    cone), for sub-sources a band–sphere test, and with ``support`` (a :class:`_Support`; rows
    ``fixed``, i.e. not re-aimed, with world-from-local ``rotation``) the tile's cone of
    directions against the table's cells with light. Exact in rejecting: a rejected tile's
    every point fails the per-pair tests of :func:`_tile_pairs` or gets no light at all.
    ``grow`` (m) widens every tile's sphere: the tests then hold for any source within that
    distance of ``pos`` (a luminaire's sub-sources, tested once at its centre). Also returns
    the distances source → tile centre (m)."""
    v = tiles.centre[None, :, :] - pos[:, None, :]  # (src, tiles, 3)
    dist = np.linalg.norm(v, axis=2)
    r = tiles.radius[None, :] + grow
    # angle to the tile centre minus the tile's angular radius must be within the cone
    cos_c = np.einsum("ltk,lk->lt", v, axis) / np.maximum(dist, 1e-300)
    ang = np.arccos(np.clip(cos_c, -1.0, 1.0)) - np.arcsin(np.clip(r / np.maximum(dist, 1e-300),
                                                                   0.0, 1.0))
    half = np.arccos(np.clip(cos_support, -1.0, 1.0))[:, None]
    keep = (dist <= r) | (ang <= half + 1e-9)
    if centre is not None:
        dc = np.linalg.norm(tiles.centre[None, :, :] - centre[:, None, :], axis=2)
        keep &= (dc + r >= d_lo[:, None]) & (dc - r < d_hi[:, None])
    if support is not None:
        # the tile's cone of directions against the table's cells where light can be
        li, ti = np.nonzero(keep & (dist > r) & fixed[:, None])
        if len(li):
            dd = dist[li, ti]
            local = np.einsum("kij,ki->kj", rotation[li], v[li, ti] / dd[:, None])
            half = np.degrees(np.arcsin(np.minimum((tiles.radius[ti] + grow) / dd, 1.0)))
            keep[li, ti] = support.may_light(local, half + _MARGIN_DEG)
    return keep, dist


def _banded_keep(tiles, batch, c0, c1, axis, cos_src, support, rotation, fixed, per_cull):
    """:func:`_tile_keep` of sub-source rows ``c0:c1``: the cone and support tests once per
    luminaire, at its centre with every tile grown by the farthest sub-source's offset (the
    sub-sources of a 0.8 m bar are 63 rows, one per piece of each distance band), then per row
    only its band against the distance from the luminaire's centre."""
    lum = batch.luminaire[c0:c1]
    _, first, inv = np.unique(lum, return_index=True, return_inverse=True)
    first = c0 + first
    grow = float(np.max(np.linalg.norm(batch.position[c0:c1] - batch.centre[c0:c1], axis=1)))
    parts = [_tile_keep(tiles, batch.centre[s], axis[s], cos_src[s], None, None, None, support,
                        rotation[s], fixed[s], grow)
             for s in (first[k:k + per_cull] for k in range(0, len(first), per_cull))]
    keep_l = np.concatenate([q[0] for q in parts])
    dist_l = np.concatenate([q[1] for q in parts])
    del parts
    r = tiles.radius[None, :]
    keep = np.empty((c1 - c0, len(tiles.radius)), bool)
    for k in range(0, c1 - c0, per_cull):  # per row: the band (the same test as per source)
        i = inv[k:k + per_cull]
        dc = dist_l[i]
        keep[k:k + per_cull] = keep_l[i] & (dc + r >= batch.lo[c0 + k:c0 + k + per_cull, None]) \
            & (dc - r < batch.hi[c0 + k:c0 + k + per_cull, None])
    return keep


def _tile_pairs(t, rows, tiles, pts, nrm, batch, axis, cos_support, banded, response):
    """The pairs of sources ``rows`` (indices into ``batch``) and tile ``t``'s points that can
    receive light: the point faces the source, lies in the support cone of its beam
    (``cos_support`` per source) and (sub-sources) in its distance band; with their geometry
    (:func:`_geometry`). ``pts``/``nrm`` are in tile order, so a tile is one slice.

    Point sources' tests run on one dense ``(sources, tile points)`` block, coordinate by
    coordinate (broadcast arithmetic: no per-pair gather, no BLAS call, whose threads only
    contend on a busy machine); sub-sources' on the pairs in each row's band
    (:func:`_banded_pairs`). The offsets and band distances are the same float64 operations
    as on gathered pairs, so the pairs kept and their geometry are too.
    """
    a, b = tiles.offsets[t], tiles.offsets[t + 1]
    p, n = pts[a:b].T, nrm[a:b]  # (3, points)
    if banded:
        si, pi, off = _banded_pairs(rows, p, nrm[a:b], batch, axis, cos_support,
                                    response is None)
    else:
        s = batch.position[rows][:, :, None]  # (rows, 3, 1)
        d = p[0] - s[:, 0], p[1] - s[:, 1], p[2] - s[:, 2]  # receiver − source
        ax = axis[rows][:, :, None]
        ok = _kept(d, (ax[:, 0], ax[:, 1], ax[:, 2]), cos_support[rows][:, None],
                   None if response is not None else (n[:, 0], n[:, 1], n[:, 2]))
        f = np.flatnonzero(ok)  # one flat index for the three gathers
        si, pi = np.divmod(f, ok.shape[1])
        off = np.stack([c.reshape(-1)[f] for c in d], axis=1)
    src = rows[si]
    rcv = tiles.order[a + pi]
    if response is not None:  # a sensor's own response decides which side it reads
        rk = np.sqrt(np.einsum("pk,pk->p", off, off))
        f = response.factor(off / np.maximum(rk, np.finfo(np.float64).tiny)[:, None], rcv) > 0
        src, rcv, off, pi = src[f], rcv[f], off[f], pi[f]
    return src, rcv, *_geometry(off, n[pi], batch.scale[src], response, rcv)


def _banded_pairs(rows, p, tile_nrm, batch, axis, cos_support, planes: bool):
    """:func:`_tile_pairs`'s tests for sub-source ``rows`` and one tile's points ``p``
    (``(3, points)``; normals ``(points, 3)``): the distance band first, once per
    luminaire (its rows share a centre), then the cone and facing tests on the pairs in a row's
    band only (a bar's 63 rows each hold a small part of a tile: 28 % of the dense block's
    pairs were kept on the courtyard). The same float64 operations as the dense block, in the
    same order: the same pairs. Returns the rows' and points' indices and the offsets."""
    _, first, inv = np.unique(batch.luminaire[rows], return_index=True, return_inverse=True)
    cen = batch.centre[rows[first]][:, :, None]
    cx, cy, cz = p[0] - cen[:, 0], p[1] - cen[:, 1], p[2] - cen[:, 2]
    rc = np.sqrt(cx * cx + cy * cy + cz * cz)[inv]  # = _kept's band distance, per row
    si, pi = np.nonzero((rc >= batch.lo[rows][:, None]) & (rc < batch.hi[rows][:, None]))
    src = rows[si]
    # coordinate by coordinate, each a contiguous gather (a (pairs, 3) array's transpose
    # made every operation a strided one)
    pos = batch.position
    d = tuple(p[k][pi] - pos[src, k] for k in range(3))
    k = np.flatnonzero(_kept(d, tuple(axis[src, k] for k in range(3)), cos_support[src],
                             tuple(tile_nrm[pi, k] for k in range(3)) if planes else None))
    return si[k], pi[k], np.stack([c[k] for c in d], axis=1)


def _kept(d, axis, cos_support, normal):
    """Which (source, receiver) pairs can receive light, from broadcastable components (x, y,
    z) of the offsets ``d`` (receiver − source, m), the beam ``axis`` and its support cosine;
    ``normal``: the receiver must face the source (None: a sensor, which decides itself).
    The same float64 operations whichever shape the pairs come in (a sub-source's distance
    band is tested before, by :func:`_banded_pairs` and :func:`_owned_pairs`)."""
    dx, dy, dz = d
    rr = np.sqrt(dx * dx + dy * dy + dz * dz)
    # the cone's margin is relative to the distance: 1e-9 m would be a wide margin in a
    # 1 µm model and nothing at all at site coordinates
    ok = dx * axis[0] + dy * axis[1] + dz * axis[2] >= (cos_support - 1e-9) * rr
    if normal is not None:
        ok &= dx * normal[0] + dy * normal[1] + dz * normal[2] < 0
    return ok


def _owned_pairs(batch, owner, pts, nrm, axis, cos_support):
    """Each receiver's pairs with the rows of its ``owner`` luminaire in ``batch`` whose
    distance band holds it, kept as :func:`_tile_pairs` keeps them, in parts of at most about
    :data:`_EXPAND` pairs."""
    # the rows' groups: one luminaire's sub-sources of one band, contiguous once sorted
    order = np.lexsort((batch.lo, batch.luminaire))
    lum, lo, hi = batch.luminaire[order], batch.lo[order], batch.hi[order]
    new = np.flatnonzero(np.r_[True, (lum[1:] != lum[:-1]) | (lo[1:] != lo[:-1])])
    g_lum, g_lo, g_hi = lum[new], lo[new], hi[new]
    g_rows = np.diff(np.r_[new, len(order)])
    first = np.searchsorted(g_lum, owner, "left")
    groups = np.searchsorted(g_lum, owner, "right") - first
    # the band of each receiver: the last of its owner's groups starting at or before it
    d = pts - batch.centre[order[new[np.minimum(first, len(new) - 1)]]]
    rc = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    band = np.full(len(owner), -1)
    for k in range(int(groups.max(initial=0))):
        g = np.minimum(first + k, len(new) - 1)
        band = np.where((k < groups) & (g_lo[g] <= rc), g, band)
    ok = band >= 0
    ok[ok] &= rc[ok] < g_hi[band[ok]]
    receivers = np.flatnonzero(ok)
    count = g_rows[band[receivers]]
    row0 = new[band[receivers]]
    ends = np.cumsum(count)
    r0 = 0
    while r0 < len(receivers):
        r1 = max(int(np.searchsorted(ends, (ends[r0 - 1] if r0 else 0) + _EXPAND, "right")),
                 r0 + 1)
        rcv = np.repeat(receivers[r0:r1], count[r0:r1])
        start = np.repeat(np.cumsum(np.r_[0, count[r0:r1 - 1]]), count[r0:r1])
        src = order[np.repeat(row0[r0:r1], count[r0:r1]) + np.arange(len(rcv)) - start]
        # coordinate by coordinate, each a contiguous gather (as _banded_pairs); the band was
        # chosen above by the same float64 operations: no second test of it
        d = tuple(pts[rcv, k] - batch.position[src, k] for k in range(3))
        keep = np.flatnonzero(_kept(d, tuple(axis[src, k] for k in range(3)), cos_support[src],
                                    tuple(nrm[rcv, k] for k in range(3))))
        src, rcv = src[keep], rcv[keep]
        yield src, rcv, *_geometry(np.stack([c[keep] for c in d], axis=1), nrm[rcv],
                                   batch.scale[src])
        r0 = r1


def _bucket(n: int) -> int:
    """Padded call size: 65,536 pairs, or :data:`_PAIRS_PER_CALL` above that, so a run compiles
    at most two shapes. Measured on the demo (session 19; first calls, their executables loaded
    from the cache): a 262,144-pair call took 44 ms and a 1,048,576-pair one 92 ms, while each
    shape more cost 0.26–0.39 s of compiling in a first run (powers of 4 had made three)."""
    return 1 << 16 if n <= 1 << 16 else _PAIRS_PER_CALL


def _quick_for_small_calls(distribution, rotations, luminaire, direction, gain):
    """A 65,536-pair call (a small study's direct light, or a large one's last call) compiles
    quickly (:func:`lumijax._executables.quick_to_compile`: ~10-25 % slower code); the
    1,048,576-pair calls that carry a large study keep XLA's defaults."""
    return _executables.quick_to_compile() if len(luminaire) <= 1 << 16 else None


@_executables.stored("light_block", "direct/_pairs.py", "kernels/", "photometry/",
                     options=_quick_for_small_calls)
def _light_block(distribution, rotations, luminaire, direction, gain):
    return pair_light(distribution, rotations[luminaire], direction, gain)


def _rotation_table(rotations, dtype=None):
    """Luminaire rotations on the device, padded with identities to a power of two so that
    selections of other sizes reuse the compiled kernel (numpy → device without an eager
    kernel: ``_jit_cache.to_device``; ``dtype`` None: JAX's canonical float)."""
    rot = np.asarray(rotations, np.float64).reshape(-1, 3, 3)
    pad = np.broadcast_to(np.eye(3), (size_class(len(rot)) - len(rot), 3, 3))
    return to_device(np.concatenate([rot, pad]), dtype)


def _stored_light(dist, rot_j, lum, w, gain, dtype=None) -> np.ndarray:
    """The light (lx, float64) of at most :data:`_PAIRS_PER_CALL` pairs by the stored kernel
    :func:`_light_block`, padded to its shape bucket; ``dtype`` None: JAX's canonical float."""
    n = len(lum)
    pad = _bucket(n) - n
    w_p = np.zeros((n + pad, 3), np.float64 if dtype is None else dtype)
    w_p[:n], w_p[n:, 2] = w, -1.0  # padding: straight down, gain 0
    # the padded table (CandelaDistribution.kernel): one compiled kernel for every photometry
    # of a type and shape bucket
    return np.array(_light_block(dist.kernel, rot_j, to_device(np.pad(lum, (0, pad)), np.int32),
                                 to_device(w_p), to_device(np.pad(gain, (0, pad)), dtype)),
                    dtype=np.float64)[:n]


def _geometry(offsets: np.ndarray, normals: np.ndarray, scale: np.ndarray, response=None,
              receiver=None):
    """Unit directions, gains ``scale · cos θ_r / d²`` (m⁻²) and distances d (m, the shadow
    rays' lengths) from offsets receiver − source (m), in float64 on the host: the kernel then
    never sees a coordinate, only a direction, so the light does not depend on where the model
    sits. The guard on d² is float64's smallest normal number, not a length (a fixed 1e-12 m²
    once clamped every pair of a µm model)."""
    r2 = np.maximum(np.einsum("ij,ij->i", offsets, offsets), np.finfo(np.float64).tiny)
    d = np.sqrt(r2)
    w = offsets / d[:, None]
    # a sensor (cylindrical, ...) reads its own response where a plane reads the cosine
    cos_r = np.maximum(-np.einsum("ij,ij->i", w, normals), 0.0) if response is None else (
        response.factor(w, receiver))
    return w, scale * cos_r / r2, d


def pair_chunks(scene, points, normals, *, selection: Sequence[int] | None = None,
                widen=None, threshold: float = 0.0, caster=None,
                stats: PairStats | None = None, response=None,
                owner: np.ndarray | None = None, geometry: bool = True
                ) -> Iterator[PairChunk]:
    """The pairs of the luminaires ``selection`` (indices into ``scene.luminaires``, default
    all) and receivers ``points``/``normals`` (m, unit), in batches of at most about 10⁶.

    ``widen`` (radians per selected luminaire) widens each support cone by the largest aim
    change, for a pair set that stays valid when the aim turns; then every candidate pair gets
    a shadow ray, otherwise only those lit at the start aims. ``threshold`` drops pairs where
    the distribution cannot exceed that fraction of its peak (:func:`support_cosine`).
    ``caster`` is a ray caster (``None``: no shadows). Batches are yielded, not kept: the
    forward light sums and forgets them, the aim model keeps the few it needs. ``response``
    (a :class:`lumijax.direct.SensorResponse`) makes the receivers sensors (cylindrical, ...)
    instead of planes of ``normals``. ``owner`` (``(points,)`` indices into ``selection``)
    pairs each receiver with that one luminaire only, planes only (``radiosity.near_light``'s
    samples). ``geometry`` False: the chunks carry the light alone (no directions and gains,
    which only the aim model reads).
    """
    sel = list(range(len(scene.luminaires))) if selection is None else list(selection)
    stats = PairStats(timing_s={}) if stats is None else stats
    timing = stats.timing_s if stats.timing_s is not None else {}
    for k in ("cull", "kernel", "shadow_rays"):
        timing.setdefault(k, 0.0)
    if not len(points) or not sel:
        return
    if owner is not None and response is not None:
        raise ValueError("pair_chunks: receivers with an owner are planes (response=None)")
    rot_all = np.array([scene.luminaires[i].rotation for i in sel]).reshape(-1, 3, 3)
    # numpy → device without an eager kernel (_jit_cache.to_device), padded with identities to
    # a power of two so that selections of other sizes reuse the compiled kernel
    rot_j = _rotation_table(rot_all)
    widen = np.zeros(len(sel)) if widen is None else np.asarray(widen, np.float64)
    # tile order: a tile is a slice (receivers with an owner are paired directly, no tiles)
    tiles = Tiles.build(points) if owner is None else None
    pts_t, nrm_t = (points, normals) if tiles is None else (points[tiles.order],
                                                           normals[tiles.order])
    n_tiles = 1 if tiles is None else max(len(tiles.radius), 1)
    widened = bool(np.any(widen > 0))

    for batch in _point_sources(scene, sel):
        dist = scene.photometries[batch.photometry].distribution
        half = np.arccos(np.clip(support_cosine(dist, threshold), -1.0, 1.0))
        cos_src = np.cos(np.minimum(half + widen[batch.luminaire], np.pi))
        axis = -rot_all[batch.luminaire, :, 2]  # photometric axis (local −z) of each row
        banded = bool(np.any(batch.lo > 0) or np.any(np.isfinite(batch.hi)))
        support = _Support.of(dist, threshold)
        rotation = rot_all[batch.luminaire]
        fixed = widen[batch.luminaire] <= 0  # a row the optimiser may turn keeps its cone
        per_cull = max(1, _CULL_PAIRS // n_tiles)
        per_keep = max(per_cull, _KEEP_ENTRIES // n_tiles)
        pending: list[tuple[np.ndarray, ...]] = []
        pending_n = 0
        n_src = len(batch.position)
        if owner is not None:  # each receiver its own luminaire's: no tiles to cull
            t0 = time.perf_counter()
            for part in _owned_pairs(batch, owner, points, normals, axis, cos_src):
                pending.append(part)
                pending_n += len(part[0])
                stats.candidate_pairs += len(part[0])
            timing["cull"] += time.perf_counter() - t0
            yield from _flush(pending, batch, dist, rot_j, caster, widened, stats,
                              timing, geometry)
            continue
        for c0 in range(0, n_src, per_keep):
            t0 = time.perf_counter()
            # which tiles each source row may light, then tile by tile the pairs of the rows
            # that keep it: a tile's points are one slice, every source in a block its row
            c1 = min(c0 + per_keep, n_src)
            keep = (_banded_keep(tiles, batch, c0, c1, axis, cos_src, support, rotation, fixed,
                                 per_cull) if banded else np.concatenate([
                _tile_keep(tiles, batch.position[s], axis[s], cos_src[s], None, None, None,
                           support, rotation[s], fixed[s])[0]
                for s in (slice(k, min(k + per_cull, c1)) for k in range(c0, c1, per_cull))]))
            timing["cull"] += time.perf_counter() - t0
            for t in np.flatnonzero(keep.any(axis=0)):
                rows = c0 + np.flatnonzero(keep[:, t])
                step = max(1, _EXPAND // max(int(tiles.offsets[t + 1] - tiles.offsets[t]), 1))
                for r0 in range(0, len(rows), step):
                    t0 = time.perf_counter()
                    part = _tile_pairs(t, rows[r0:r0 + step], tiles, pts_t, nrm_t, batch, axis,
                                       cos_src, banded, response)
                    timing["cull"] += time.perf_counter() - t0
                    pending.append(part)
                    pending_n += len(part[0])
                    stats.candidate_pairs += len(part[0])
                    if pending_n >= _PAIRS_PER_CALL:
                        yield from _flush(pending, batch, dist, rot_j, caster, widened,
                                          stats, timing, geometry)
                        pending, pending_n = [], 0
        yield from _flush(pending, batch, dist, rot_j, caster, widened, stats, timing,
                          geometry)


def _flush(pending, batch, dist, rot_j, caster, all_rays, stats, timing, geometry):
    """The chunks (at most ``_PAIRS_PER_CALL`` pairs each) of the pending candidate pairs."""
    if not pending:
        return
    src, rcv, w, gain, length = (np.concatenate([p[k] for p in pending]) for k in range(5))
    for p0 in range(0, len(src), _PAIRS_PER_CALL):
        s = slice(p0, p0 + _PAIRS_PER_CALL)
        yield _chunk(batch, dist, src[s].astype(np.int64), rcv[s].astype(np.int64), w[s],
                     gain[s], length[s], rot_j, caster, all_rays, stats, timing, geometry)


def _chunk(batch, dist, s_idx, r_idx, w, gain, length, rot_j, caster, all_rays, stats,
           timing, geometry) -> PairChunk:
    """Start light and shadow rays of one batch of candidate pairs (directions ``w``, gains
    and distances from :func:`_geometry`: the rays need no second look at the points)."""
    t0 = time.perf_counter()
    lum = batch.luminaire[s_idx]
    n = len(s_idx)
    e = _stored_light(dist, rot_j, lum, w, gain)
    t1 = time.perf_counter()
    timing["kernel"] += t1 - t0
    keep = np.ones(n, bool)
    if caster is not None:
        test = np.arange(n) if all_rays else np.flatnonzero(e > 0)
        if len(test):
            # 0 blocked, 1 clear, τ(θ) through clear glass (docs/materials.md)
            through = caster.transmission_along(batch.position[s_idx[test]], w[test],
                                                length[test])
            keep[test[through <= 0]] = False
            glazed = test[(through > 0) & (through < 1)]
            if len(glazed):
                factor = through[(through > 0) & (through < 1)]
                gain, e = gain.copy(), e.copy()
                gain[glazed] *= factor
                e[glazed] *= factor
            stats.shadow_rays += len(test)
        timing["shadow_rays"] += time.perf_counter() - t1
    if not all_rays:
        keep &= e > 0  # unlit at the start and never turned: nothing to keep
    k = np.flatnonzero(keep)
    return PairChunk(batch.photometry, lum[k], r_idx[k], w[k] if geometry else None,
                     gain[k] if geometry else None, e[k])


def build_pairs(scene, points, normals, selection: Sequence[int], *, widen=None,
                threshold: float = 0.0, shadows: bool = True, dtype=np.float64,
                owner: np.ndarray | None = None) -> tuple[tuple[PairSet, ...], PairStats]:
    """The pair sets (one per photometry) of the luminaires ``selection``, kept: what the aim
    model needs. Same culling and rays as the forward light (:func:`pair_chunks`, whose
    ``owner`` it passes on)."""
    caster = scene.raycaster if shadows and len(scene.triangles) else None
    stats = PairStats(timing_s={})
    points = np.ascontiguousarray(points, np.float64)
    normals = np.asarray(normals, np.float64)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    by: dict[str, list[PairChunk]] = {}
    for c in pair_chunks(scene, points, normals, selection=selection, widen=widen,
                         threshold=threshold, caster=caster, stats=stats, owner=owner):
        by.setdefault(c.photometry, []).append(c)
    out = []
    for name, chunks in by.items():
        cat = [np.concatenate([getattr(c, f) for c in chunks]) for f in PairChunk._fields[1:5]]
        out.append(PairSet(scene.photometries[name].distribution,
                           jnp.asarray(cat[0], jnp.int32), jnp.asarray(cat[1], jnp.int32),
                           jnp.asarray(cat[2].astype(dtype)), jnp.asarray(cat[3].astype(dtype))))
    return tuple(out), stats
