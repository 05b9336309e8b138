"""The candela distribution: a gridded intensity table on the full sphere, evaluated by direction.

Angles are stored in degrees (as in the files); kernels work in radians internally only where a
trigonometric function needs them. Directions are in the luminaire frame of
``docs/conventions.md``: the photometric axis (γ = 0) is ``−z_l``, C0 is ``+x_l``, C90 is ``+y_l``.
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._jit_cache import size_class, to_device

__all__ = ["CandelaDistribution"]

_TYPES = ("C", "B", "A")
_LUT_SIZE = (1 << 16) + 1  # the most entries a cell lookup table has (_cell_lut)
_KERNELS: dict[tuple, tuple] = {}  # CandelaDistribution.kernel's tables, by their arrays' ids
_KERNELS_KEPT = 64  # ~0.8 MB each (the lookup tables at full size): at most ~50 MB kept


def _is_concrete(*xs) -> bool:
    return not any(isinstance(x, jax.core.Tracer) for x in xs)


def _trapezoid_weights(x, xp=jnp):
    """Node weights of the trapezoid rule on the ascending grid ``x`` (same unit as ``x``)."""
    dx = xp.diff(x)
    w = xp.zeros_like(x)
    if xp is np:
        w[:-1] += 0.5 * dx
        w[1:] += 0.5 * dx
        return w
    return w.at[:-1].add(0.5 * dx).at[1:].add(0.5 * dx)


def _linear_weights(x, kind: str, xp=jnp):
    """Node weights ``w`` with ``Σ w_i f_i = ∫ f(x) k(x) dx`` exactly for the piecewise-linear ``f``.

    ``x`` is in radians, ascending; ``k`` is ``sin`` (polar angle from the pole, Type C) or ``cos``
    (latitude from the equator, Types A and B). Integrating ``(b − x) k(x)`` and ``(x − a) k(x)``
    over each segment in closed form makes the flux exact for the interpolant that ``intensity``
    evaluates, so a table's flux does not depend on how finely it happens to be sampled.
    """
    a, b = x[:-1], x[1:]
    h = b - a
    if kind == "sin":
        s = (xp.sin(b) - xp.sin(a)) / h
        wa = xp.cos(a) - s
        wb = s - xp.cos(b)
    else:
        c = (xp.cos(a) - xp.cos(b)) / h
        wa = c - xp.sin(a)
        wb = xp.sin(b) - c
    w = xp.zeros_like(x)
    if xp is np:
        w[:-1] += wa
        w[1:] += wb
        return w
    return w.at[:-1].add(wa).at[1:].add(wb)


def flux_weights(photometric_type: str, h_deg, v_deg, xp=jnp):
    """Weights ``W[h, v]`` (sr) such that the flux of the bilinear interpolant is ``Σ W · I``."""
    h = xp.asarray(h_deg) * (math.pi / 180.0)
    v = xp.asarray(v_deg) * (math.pi / 180.0)
    if photometric_type == "C":  # rows: azimuth C (trapezoid), columns: polar γ (sin weight)
        return _trapezoid_weights(h, xp)[:, None] * _linear_weights(v, "sin", xp)[None, :]
    if photometric_type == "B":  # rows: latitude H (cos weight), columns: azimuth V
        return _linear_weights(h, "cos", xp)[:, None] * _trapezoid_weights(v, xp)[None, :]
    # Type A: rows: azimuth H, columns: latitude V (cos weight)
    return _trapezoid_weights(h, xp)[:, None] * _linear_weights(v, "cos", xp)[None, :]


def _tie_poles_impl(photometric_type: str, h, v, cd, xp):
    """Make the table single-valued where its angles are degenerate, keeping the flux unchanged.

    At a pole of the angle system (Type C: γ = 0 and 180; Type B: H = ±90; Type A: V = ±90) every
    azimuth names the same direction, so all samples there are replaced by their trapezoid-weighted
    mean over the azimuth; for Type C the C = 0 and C = 360 planes are the same plane and are tied
    too. Without this the interpolant jumps at the poles and its gradient is meaningless there.
    The weighted mean preserves the trapezoid-in-azimuth integral, hence the flux.
    """

    def put(a, idx, val):
        if xp is np:
            a = a.copy()
            a[idx] = val
            return a
        return a.at[idx].set(val)

    if photometric_type == "C":
        seam = 0.5 * (cd[0] + cd[-1])
        cd = put(put(cd, 0, seam), -1, seam)
    if photometric_type == "B":
        w = _trapezoid_weights(v, xp)
        w = w / xp.sum(w)
        for i, pole in ((0, -90.0), (-1, 90.0)):
            avg = xp.sum(w * cd[i, :])
            cd = put(cd, (i, slice(None)), xp.where(h[i] == pole, avg, cd[i, :]))
        return cd
    w = _trapezoid_weights(h, xp)
    w = w / xp.sum(w)
    poles = ((0, 0.0), (-1, 180.0)) if photometric_type == "C" else ((0, -90.0), (-1, 90.0))
    for j, pole in poles:
        avg = xp.sum(w * cd[:, j])
        cd = put(cd, (slice(None), j), xp.where(v[j] == pole, avg, cd[:, j]))
    return cd


def _validate(photometric_type: str, h: np.ndarray, v: np.ndarray, cd: np.ndarray) -> None:
    if h.ndim != 1 or v.ndim != 1 or cd.shape != (h.shape[0], v.shape[0]):
        raise ValueError(
            f"candela must have shape (len(h_deg), len(v_deg)) = ({h.shape[0]}, {v.shape[0]}), "
            f"got {cd.shape}"
        )
    if h.shape[0] < 2 or v.shape[0] < 2:
        raise ValueError("a distribution needs at least two angles on each axis (expand first)")
    if np.any(np.diff(h) <= 0) or np.any(np.diff(v) <= 0):
        raise ValueError("h_deg and v_deg must be strictly ascending")
    if photometric_type == "C" and (h[0] != 0.0 or h[-1] != 360.0):
        raise ValueError("Type C h_deg must run from 0 to 360 inclusive")


#: Cephes' ``atanf`` (S. L. Moshier): atan(u) = u + u³ P(u²) on |u| ≤ tan(π/8), ~1 ulp in
#: float32. P's coefficients, highest power first.
_ATAN_P = (8.05374449538e-2, -1.38776856032e-1, 1.99777106478e-1, -3.33329491539e-1)


def _atan2(y, x):
    """``atan2(y, x)`` (radians). In float32 as plain arithmetic (octant reduction and Cephes'
    polynomial): XLA's CPU backend computes ``atan2`` one element at a time, 21 ms a million
    against 1 ms, and the photometry kernel takes two per pair; within 2.8·10⁻⁷ rad of the
    exact value where XLA's own is within 2.5·10⁻⁷ (tested). Float64 keeps ``jnp.arctan2``.
    Signed zeros as ``atan2``'s: ``(±0, −0) → ±π``."""
    dt = jnp.result_type(y, x)
    if dt != jnp.float32:
        return jnp.arctan2(y, x)
    ax, ay = jnp.abs(x), jnp.abs(y)
    hi = jnp.maximum(ax, ay)
    t = jnp.minimum(ax, ay) / jnp.where(hi > 0, hi, jnp.ones((), dt))  # in [0, 1]
    big = t > np.float32(0.41421356237309503)  # tan(π/8)
    u = jnp.where(big, (t - 1) / (t + 1), t)
    z = u * u
    poly = jnp.zeros((), dt)
    for c in _ATAN_P:
        poly = poly * z + np.float32(c)
    a = poly * z * u + u
    a = jnp.where(big, a + np.float32(np.pi / 4), a)
    a = jnp.where(ay > ax, np.float32(np.pi / 2) - a, a)
    a = jnp.where(jnp.signbit(x), np.float32(np.pi) - a, a)
    return jnp.where(jnp.signbit(y), -a, a)


def _safe_hypot_atan2(p, q):
    """``(sqrt(p² + q²), atan2(p, q))`` with finite gradients where ``p = q = 0``.

    The double-where trick: the degenerate inputs are replaced *before* the singular operations,
    so no NaN or inf is ever formed, not even in the branch that ``where`` discards (JAX would
    otherwise multiply it by a zero cotangent and still produce NaN).
    """
    r2 = p * p + q * q
    tiny = jnp.sqrt(jnp.finfo(r2.dtype).tiny)
    degenerate = r2 <= tiny
    r = jnp.where(degenerate, 0.0, jnp.sqrt(jnp.where(degenerate, 1.0, r2)))
    az = _atan2(jnp.where(degenerate, 0.0, p), jnp.where(degenerate, 1.0, q))
    return r, az


def _grid_coords(photometric_type: str, d):
    """Map local unit directions to the table's (row, column) angles in degrees."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    deg = 180.0 / math.pi
    if photometric_type == "C":
        r, c = _safe_hypot_atan2(y, x)
        gamma = _atan2(r, -z)
        return jnp.mod(c * deg, 360.0), gamma * deg
    if photometric_type == "B":  # d = (cos H sin V, sin H, −cos H cos V)
        r, vv = _safe_hypot_atan2(x, -z)
        return _atan2(y, r) * deg, vv * deg
    # Type A: d = (sin V, cos V sin H, −cos V cos H)
    r, hh = _safe_hypot_atan2(y, -z)
    return hh * deg, _atan2(x, r) * deg


def _fraction(x, g0, g1):
    """``(x − g0) / (g1 − g0)``, 0 where the cell has collapsed (knots equal after rounding).

    Angles strictly ascending in float64 can round to equal float32 values when a table holds
    clustered angles; a zero-width cell then contributes its left value instead of a NaN.
    """
    w = g1 - g0
    ok = w > 0
    return jnp.where(ok, (x - g0) / jnp.where(ok, w, jnp.ones((), w.dtype)), jnp.zeros((), w.dtype))


def _locate(grid, x):
    """Cell index and fractional position of ``x`` on an ascending, possibly non-uniform grid."""
    n = grid.shape[0]
    i = jnp.clip(jnp.searchsorted(grid, x, side="right") - 1, 0, n - 2)
    return i, _fraction(x, grid[i], grid[i + 1])


def _cell_lut(grid: np.ndarray) -> tuple[np.ndarray, int]:
    """A uniform-bin lookup table of cells for an ascending, non-uniform grid.

    ``lut[k]`` is the cell holding the left edge of bin ``k`` (``bins + 1`` entries, the last one
    for the right end). The cell of ``x`` in bin ``k`` then lies in ``lut[k − 1] … lut[k + 2]``
    (one bin of slack on each side covers a bin index rounded either way), and a bisection of
    that bracket finds it. Returns the table and the number of bisection steps,
    ``⌈log2(widest bracket + 1)⌉``: 1–2 for the usual, nearly uniform grids (one gather and a
    couple of comparisons instead of a full binary search, the dominant cost of a lookup when
    evaluated 10⁸ times), and never more than ``⌈log2 n⌉`` — so the compiled kernel's size is
    bounded by the table's shape, however the angles cluster.
    """
    n = len(grid)
    span = float(grid[-1] - grid[0])
    bins = int(np.clip(np.ceil(2.0 * span / np.min(np.diff(grid))), 64, _LUT_SIZE - 1))
    edges = grid[0] + np.arange(bins + 1) * (span / bins)
    edges[-1] = grid[-1]
    lut = np.clip(np.searchsorted(grid, edges, side="right") - 1, 0, n - 2).astype(np.int32)
    lo = lut[np.maximum(np.arange(bins) - 1, 0)]
    hi = lut[np.minimum(np.arange(bins) + 2, bins)]
    width = int(np.max(hi - lo))
    steps = int(np.ceil(np.log2(width + 1))) if width > 0 else 0
    return lut, steps


def _locate_lut(grid, lut, steps: int, x, lo_end=None, hi_end=None, bins=None):
    """As :func:`_locate`, through a :func:`_cell_lut` table (same cells, exactly).

    ``lo_end``, ``hi_end`` and ``bins`` are the grid's true ends and the table's true bin count
    when ``grid`` and ``lut`` are padded (:class:`KernelTable`); by default the arrays' own."""
    bins = lut.shape[0] - 1 if bins is None else bins
    g0 = grid[0] if lo_end is None else lo_end
    g1 = grid[-1] if hi_end is None else hi_end
    scale = bins / (g1 - g0)
    k = jnp.clip(jnp.floor((x - g0) * scale).astype(jnp.int32), 0, bins - 1)
    lo = lut[jnp.maximum(k - 1, 0)]
    hi = lut[jnp.minimum(k + 2, bins)]
    # Bisection of [lo, hi] for the last knot ≤ x: a fixed number of steps (≤ ⌈log2 n⌉; extra
    # steps, as a padded table's bucket adds, leave lo where it is).
    for _ in range(steps):
        mid = (lo + hi + 1) // 2
        up = grid[mid] <= x
        lo = jnp.where(up, mid, lo)
        hi = jnp.where(up, hi, mid - 1)
    i = lo
    return i, _fraction(x, grid[i], grid[i + 1])


def _bilinear(photometric_type, cd, i, s, j, t, a, b, h_ends, v_ends, dtype):
    c00 = cd[i, j]
    c01 = cd[i, j + 1]
    c10 = cd[i + 1, j]
    c11 = cd[i + 1, j + 1]
    val = (1 - s) * ((1 - t) * c00 + t * c01) + s * ((1 - t) * c10 + t * c11)
    inside = (b >= v_ends[0]) & (b <= v_ends[1])
    if photometric_type != "C":
        inside = inside & (a >= h_ends[0]) & (a <= h_ends[1])
    return jnp.where(inside, val, jnp.zeros((), dtype))


@functools.partial(jax.jit, static_argnums=(0, 6, 7))
def _intensity(photometric_type: str, h_deg, v_deg, candela, d, luts=None, h_steps=0, v_steps=0):
    # The distribution's own arrays (traced, or a caller's jit): the lookup tables, or a binary
    # search when it was built under a trace. Inside a caller's jit this is simply inlined.
    dtype = d.dtype
    h = h_deg.astype(dtype)
    v = v_deg.astype(dtype)
    a, b = _grid_coords(photometric_type, d)
    if luts is None:
        i, s = _locate(h, a)
        j, t = _locate(v, b)
    else:
        i, s = _locate_lut(h, luts[0], h_steps, a)
        j, t = _locate_lut(v, luts[1], v_steps, b)
    return _bilinear(photometric_type, candela.astype(dtype), i, s, j, t, a, b,
                     (h[0], h[-1]), (v[0], v[-1]), dtype)


def _pad_grid(g: np.ndarray, size: int) -> np.ndarray:
    """``g`` continued upwards by unit steps to ``size`` knots (never read: see KernelTable)."""
    return np.concatenate([g, g[-1] + np.arange(1, size - len(g) + 1, dtype=g.dtype)])


class KernelTable(eqx.Module):
    """A distribution's table padded to shared shape buckets, for the lookup kernel.

    Every array is padded to a power-of-two length (≥ 128 horizontal, ≥ 512 vertical angles;
    the lookup tables to their largest size, 65,537 entries) and the true ends and bin counts
    travel as arrays, so one compiled kernel serves every photometry of a type and bucket: the
    demo's five IES files compiled five direct-light kernels, now one or two. The padding is never read: the lookup tables hold cells of the true
    grid only (``≤ n − 2``) and the bisection stays inside them, so the value is the unpadded
    table's to float32 rounding: on 20,000 random directions the bundled tables' values are
    unchanged bit for bit, and 5 of 19 shared test files differ in 1–2 values by 1 ulp
    (``tests/photometry/test_lookup.py`` compares every file with a plain binary search).
    """

    photometric_type: str = eqx.field(static=True)
    steps: tuple[int, int] = eqx.field(static=True)
    h: Float[Array, " hp"]
    v: Float[Array, " vp"]
    cd: Float[Array, "hp vp"]
    lut_h: Array
    lut_v: Array
    ends: Float[Array, "4"]  # h first, h last, v first, v last (deg)
    bins: Array  # true bin counts of lut_h, lut_v (int32)

    @classmethod
    def of(cls, photometric_type: str, h: np.ndarray, v: np.ndarray, cd: np.ndarray,
           dtype) -> KernelTable:
        """From the stored angles and table (as float64); ``dtype`` is their dtype."""
        (hl, hs), (vl, vs) = _cell_lut(h), _cell_lut(v)
        nh, nv = size_class(len(h), 128), size_class(len(v), 512)
        cd_p = np.zeros((nh, nv))
        cd_p[:len(h), :len(v)] = cd

        def lut(x):  # every table at _cell_lut's largest size: one shape for all
            return np.concatenate([x, np.full(_LUT_SIZE - len(x), x[-1], np.int32)])

        # the ends as the stored arrays hold them (the same cast as h_deg's and v_deg's)
        ends = np.asarray([h[0], h[-1], v[0], v[-1]], np.float64)
        return cls(photometric_type=photometric_type,
                   steps=(max(hs, 2), max(vs, 2)),  # 1–2 for usual grids: one bucket
                   h=to_device(_pad_grid(h, nh), dtype), v=to_device(_pad_grid(v, nv), dtype),
                   cd=to_device(cd_p, dtype), lut_h=to_device(lut(hl)), lut_v=to_device(lut(vl)),
                   ends=to_device(ends, dtype),
                   bins=to_device(np.asarray([len(hl) - 1, len(vl) - 1], np.int32)))

    def intensity(self, d: Float[Array, "... 3"]) -> Float[Array, "..."]:
        """Intensity (cd) towards local directions ``d``: :meth:`CandelaDistribution.intensity`."""
        d = jnp.asarray(d)
        if not jnp.issubdtype(d.dtype, jnp.floating):
            d = d.astype(self.cd.dtype)
        return _table_intensity(self, d)


@jax.jit
def _table_intensity(table: KernelTable, d):
    dtype = d.dtype
    h, v = table.h.astype(dtype), table.v.astype(dtype)
    e = table.ends.astype(dtype)
    a, b = _grid_coords(table.photometric_type, d)
    i, s = _locate_lut(h, table.lut_h, table.steps[0], a, e[0], e[1], table.bins[0])
    j, t = _locate_lut(v, table.lut_v, table.steps[1], b, e[2], e[3], table.bins[1])
    return _bilinear(table.photometric_type, table.cd.astype(dtype), i, s, j, t, a, b,
                     (e[0], e[1]), (e[2], e[3]), dtype)


@functools.partial(jax.jit, static_argnums=0)
def _flux(photometric_type: str, h_deg, v_deg, candela):
    return jnp.sum(flux_weights(photometric_type, h_deg, v_deg) * candela)


class CandelaDistribution(eqx.Module):
    """Absolute luminous intensity (cd) of a luminaire on the full sphere of directions.

    The table is expanded from whatever symmetry the file declared, so ``h_deg`` and ``v_deg``
    cover everything the data say; outside their range the intensity is zero.

    Attributes
    ----------
    photometric_type
        ``"C"``, ``"B"`` or ``"A"`` (static): how (``h_deg``, ``v_deg``) map to directions, see
        ``docs/conventions.md``. Type C: ``h_deg`` is the C angle, 0–360 inclusive (the 360 row
        repeats the 0 row), ``v_deg`` is γ in [0, 180]. Types B and A: both in [−90, 90].
    h_deg
        Horizontal angles (deg), strictly ascending, shape ``(h,)``.
    v_deg
        Vertical angles (deg), strictly ascending, shape ``(v,)``.
    candela
        Intensity (cd), shape ``(h, v)``: ``candela[i, j]`` is the intensity at
        ``(h_deg[i], v_deg[j])``.

    Notes
    -----
    The constructor ties degenerate samples (the poles of the angle system and, for Type C, the
    C0/C360 seam) to one value, the azimuthal mean, so that :meth:`intensity` is continuous on the
    whole sphere. This does not change :meth:`flux`.
    """

    photometric_type: str = eqx.field(static=True)
    h_deg: Float[Array, " h"]
    v_deg: Float[Array, " v"]
    candela: Float[Array, "h v"]
    luts: tuple[Array, Array] | None  # cell lookup tables (see _cell_lut), None if traced
    lut_steps: tuple[int, int] = eqx.field(static=True)

    def __init__(
        self,
        photometric_type: str,
        h_deg: ArrayLike,
        v_deg: ArrayLike,
        candela: ArrayLike,
    ) -> None:
        if photometric_type not in _TYPES:
            raise ValueError(f"photometric_type must be one of {_TYPES}, got {photometric_type!r}")
        if _is_concrete(h_deg, v_deg, candela):
            # Loading a file stays in numpy; only the final arrays become JAX arrays.
            hn = np.asarray(h_deg, dtype=np.float64)
            vn = np.asarray(v_deg, dtype=np.float64)
            cn = np.asarray(candela, dtype=np.float64)
            _validate(photometric_type, hn, vn, cn)
            cn = _tie_poles_impl(photometric_type, hn, vn, cn, np)
            dtype = jax.dtypes.canonicalize_dtype(np.float64)  # float32 unless x64 is enabled
            self.photometric_type = photometric_type
            # to_device: numpy's cast and a transfer, no eager kernel per shape and process
            self.h_deg = to_device(hn, dtype)
            self.v_deg = to_device(vn, dtype)
            self.candela = to_device(cn, dtype)
            (hl, hs), (vl, vs) = _cell_lut(hn), _cell_lut(vn)
            self.luts = (to_device(np.asarray(hl)), to_device(np.asarray(vl)))
            self.lut_steps = (hs, vs)
            return
        h = jnp.asarray(h_deg)
        v = jnp.asarray(v_deg)
        cd = jnp.asarray(candela)
        dtype = jnp.result_type(h, v, cd, jnp.zeros((), dtype=float).dtype)
        self.photometric_type = photometric_type
        self.h_deg = h.astype(dtype)
        self.v_deg = v.astype(dtype)
        self.candela = _tie_poles_impl(
            photometric_type, self.h_deg, self.v_deg, cd.astype(dtype), jnp
        )
        self.luts = None
        self.lut_steps = (0, 0)

    def intensity(self, d: Float[Array, "... 3"]) -> Float[Array, "..."]:
        """Intensity (cd) towards local directions ``d``.

        Parameters
        ----------
        d
            Direction vectors in the luminaire frame, shape ``(..., 3)``. Only the direction
            matters (the map to angles uses ``atan2``), so unit length is expected but not
            required; the zero vector gives the γ = 0 value.

        Returns
        -------
        Intensity in cd, shape ``(...)``, of ``d``'s floating dtype. Bilinear in the table's
        angles (wrap-around in C for Type C), zero outside the table's angle range, continuous
        everywhere the data are, and differentiable with finite gradients also at the poles.
        """
        d = jnp.asarray(d)
        if not jnp.issubdtype(d.dtype, jnp.floating):
            d = d.astype(self.candela.dtype)
        if not isinstance(d, jax.core.Tracer):  # eager: the shared, padded program
            kernel = self.kernel
            if kernel is not self:
                return _table_intensity(kernel, d)
        # under a trace the distribution's own arrays (a caller's jit inlines this; the padded
        # table would be a constant of ~0.8 MB in its program)
        return _intensity(self.photometric_type, self.h_deg, self.v_deg, self.candela, d,
                          self.luts, *self.lut_steps)

    def flux(self) -> Float[Array, ""]:
        """Luminous flux (lm): the exact integral of the interpolant over the sphere.

        Type C: ``Φ = ∫∫ I sin γ dγ dC``, piecewise-linear in γ (closed form), trapezoid in C.
        Types B and A: ``Φ = ∫∫ I cos(lat) d(lat) d(az)`` likewise. A 0-d array, usable under
        ``jit`` and differentiable in ``candela``; ``float(dist.flux())`` gives a Python float.
        """
        if _is_concrete(self.h_deg, self.v_deg, self.candela):
            # Float64 numpy for eager calls: exact weights and no per-shape compilation.
            w = flux_weights(
                self.photometric_type, np.asarray(self.h_deg), np.asarray(self.v_deg), np
            )
            total = np.sum(w * np.asarray(self.candela, np.float64))
            return jnp.asarray(total, dtype=self.candela.dtype)
        return _flux(self.photometric_type, self.h_deg, self.v_deg, self.candela)

    @property
    def peak_cd(self) -> float:
        """Largest tabulated intensity (cd); the interpolant never exceeds it."""
        return float(jnp.max(self.candela))

    def max_intensity(self) -> tuple[float, float, float]:
        """``(peak cd, h_deg, v_deg)`` of the largest tabulated intensity."""
        cd = np.asarray(self.candela)
        i, j = np.unravel_index(int(np.argmax(cd)), cd.shape)
        return float(cd[i, j]), float(self.h_deg[i]), float(self.v_deg[j])

    def direction(self, h_deg: ArrayLike, v_deg: ArrayLike) -> Float[Array, "... 3"]:
        """Unit vectors in the luminaire frame for this type's angles (deg), broadcast together."""
        h = jnp.deg2rad(jnp.asarray(h_deg, dtype=self.candela.dtype))
        v = jnp.deg2rad(jnp.asarray(v_deg, dtype=self.candela.dtype))
        h, v = jnp.broadcast_arrays(h, v)
        return angles_to_direction(self.photometric_type, h, v)

    @property
    def kernel(self) -> KernelTable | CandelaDistribution:
        """What a compiled kernel should take to evaluate :meth:`intensity`: the padded
        :class:`KernelTable` of the current arrays (shared shapes: one compile serves many
        photometries; made once per set of arrays and kept), or the distribution itself when
        its arrays are traced. Derived, never stored: a ``tree_at`` of ``candela`` is seen."""
        arrays = (self.h_deg, self.v_deg, self.candela)
        if self.luts is None or not _is_concrete(*arrays):
            return self
        key = (self.photometric_type, *map(id, arrays))
        hit = _KERNELS.get(key)
        if hit is None:
            h, v, cd = (np.asarray(a, np.float64) for a in arrays)
            with jax.ensure_compile_time_eval():  # concrete even when asked under a trace
                table = KernelTable.of(self.photometric_type, h, v, cd, self.candela.dtype)
            hit = (arrays, table)
            if len(_KERNELS) >= _KERNELS_KEPT:
                _KERNELS.pop(next(iter(_KERNELS)))
            _KERNELS[key] = hit  # the arrays are kept with it, so their ids stay theirs
        return hit[1]

    def scaled(self, factor: float) -> CandelaDistribution:
        """The same distribution with every intensity multiplied by ``factor``."""
        return eqx.tree_at(lambda m: m.candela, self, self.candela * factor)


def angles_to_direction(photometric_type: str, h, v, xp=jnp):
    """Local unit direction for a type's (H, V) angles in radians (``docs/conventions.md``)."""
    if photometric_type == "C":
        return xp.stack([xp.sin(v) * xp.cos(h), xp.sin(v) * xp.sin(h), -xp.cos(v)], axis=-1)
    if photometric_type == "B":
        return xp.stack([xp.cos(h) * xp.sin(v), xp.sin(h), -xp.cos(h) * xp.cos(v)], axis=-1)
    return xp.stack([xp.sin(v), xp.cos(v) * xp.sin(h), -xp.cos(v) * xp.cos(h)], axis=-1)
