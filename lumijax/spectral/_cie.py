"""The CIE observer tables lumijax ships, and the correlated colour temperature from them.

``lumijax/data/cie_observers.npz`` holds, on the 1 nm grid 360–830 nm, the CIE 1924 photopic
V(λ) and the CIE 1931 2° colour-matching functions x̄ ȳ z̄ (CIE 018:2019 / CIE S 014-1), and the
CIE 13.3 test colour samples TCS01–TCS14 (360–830 nm at 5 nm): the same numbers colour-science 0.4
ships as ``SDS_LEFS_PHOTOPIC``, ``MSDS_CMFS`` and ``SDS_TCS["CIE 1995"]``. They are shipped so
that the compute path (every material's luminous reflectance, the spectral segmentation, every
result's CCT) does not import colour-science, which costs seconds per process.

The CCT is Ohno (2013) (J. Illum. Eng. Soc. 10(1), 2014) as colour-science implements it
(``uv_to_CCT_Ohno2013``): a Planckian table 1000–100000 K at spacing 1.001 (finer above), the
nearest entry, then the triangular solution, or the parabolic one where |Duv| ≥ 0.002.
"""

from __future__ import annotations

import functools
from importlib import resources

import numpy as np

__all__ = ["observer_tables", "test_colour_samples", "uv_to_cct_ohno2013", "xy_to_uv", "xyz_to_xy", "xyz_to_lab",
           "xyz_to_linear_srgb", "srgb_encode"]

_T_MIN_K, _T_MAX_K, _SPACING = 1000.0, 100000.0, 1.001
#: First and second radiation constants as colour-science's planck_law uses them (W·m², m·K).
_C1, _C2 = 3.741771e-16, 0.014388
#: The Planckian locus is integrated on colour-science's default shape, 360–780 nm at 1 nm.
_LOCUS_NM = (360.0, 780.0)


@functools.cache
def observer_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(wavelength_nm (471,), V(λ) (471,), x̄ȳz̄ (471, 3))``, read-only, 360–830 nm at 1 nm."""
    path = resources.files("lumijax") / "data" / "cie_observers.npz"
    with resources.as_file(path) as p, np.load(p) as z:
        out = (z["wavelength_nm"].copy(), z["v_photopic"].copy(), z["cmf_1931_2"].copy())
    for a in out:
        a.setflags(write=False)
    return out


@functools.cache
def test_colour_samples() -> tuple[np.ndarray, np.ndarray]:
    """``(wavelength_nm (95,), reflectance (14, 95))`` of CIE 13.3's TCS01–TCS14, read-only."""
    path = resources.files("lumijax") / "data" / "cie_observers.npz"
    with resources.as_file(path) as p, np.load(p) as z:
        out = (z["tcs_wavelength_nm"].copy(), z["tcs_cie1995"].copy())
    for a in out:
        a.setflags(write=False)
    return out


def xy_to_uv(xy: np.ndarray) -> np.ndarray:
    """CIE 1960 UCS uv of CIE 1931 xy, shape ``(..., 2)``."""
    x, y = xy[..., 0], xy[..., 1]
    d = -2.0 * x + 12.0 * y + 3.0
    return np.stack([4.0 * x / d, 6.0 * y / d], axis=-1)


def xyz_to_xy(xyz: np.ndarray) -> np.ndarray:
    """CIE 1931 xy of XYZ (X+Y+Z > 0), shape ``(..., 2)``."""
    return xyz[..., :2] / xyz.sum(axis=-1, keepdims=True)


def xyz_to_lab(xyz: np.ndarray, white_xy: np.ndarray) -> np.ndarray:
    """CIE 1976 L*a*b* of XYZ (Y = 1 is the white's) against the white of chromaticity
    ``white_xy`` (broadcast), as colour-science's ``XYZ_to_Lab`` with domain-1 XYZ."""
    wx, wy = white_xy[..., 0], white_xy[..., 1]
    white = np.stack([wx / wy, np.ones_like(wx), (1.0 - wx - wy) / wy], axis=-1)
    r = xyz / white
    f = np.where(r > (24.0 / 116.0) ** 3, np.sign(r) * np.abs(r) ** (1.0 / 3.0),
                 (841.0 / 108.0) * r + 16.0 / 116.0)
    return np.stack([116.0 * f[..., 1] - 16.0, 500.0 * (f[..., 0] - f[..., 1]),
                     200.0 * (f[..., 1] - f[..., 2])], axis=-1)


#: XYZ → linear sRGB as IEC 61966-2-1 prints it (and colour-science uses it), D65 white.
_SRGB_FROM_XYZ = np.array([[3.2406, -1.5372, -0.4986],
                           [-0.9689, 1.8758, 0.0415],
                           [0.0557, -0.2040, 1.0570]])


def xyz_to_linear_srgb(xyz: np.ndarray) -> np.ndarray:
    """Linear sRGB of XYZ (Y = 1 white), no chromatic adaptation, shape ``(..., 3)``."""
    return xyz @ _SRGB_FROM_XYZ.T


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1]."""
    a = np.asarray(linear, dtype=np.float64)
    return np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.abs(a) ** (1 / 2.4) - 0.055)


#: The Planckian table below, computed once by ``scripts/make_planckian_table.py`` (the
#: formula of :func:`planckian_locus`; a test checks they agree): computing it took 0.2-0.3 s
#: of every run that reports a CCT (contended), reading it takes a millisecond.
PLANCKIAN_FILE = "planckian_ohno2013.npy"


def planckian_locus() -> np.ndarray:
    """Rows (T K, u, v) of the Planckian locus at Ohno's cascade of temperatures, from the
    formula (Planck's law on the shipped CMFs)."""
    t = [_T_MIN_K, _T_MIN_K + 1.0]
    nxt, step = _T_MIN_K + 1.0, _SPACING
    while (nxt := nxt * step) < _T_MAX_K:
        t.append(nxt)
        d = min(max((nxt - _T_MIN_K) / (_T_MAX_K - _T_MIN_K), 0.0), 1.0)
        step = _SPACING * (1.0 - d) + (1.0 + (_SPACING - 1.0) / 10.0) * d
    temps = np.concatenate([t, [_T_MAX_K - 1.0, _T_MAX_K]])
    wl, _, cmf = observer_tables()
    keep = (wl >= _LOCUS_NM[0]) & (wl <= _LOCUS_NM[1])
    lam = wl[keep][:, None] * 1e-9
    # spectral radiance of a black body (the common factors cancel in u, v)
    p = (_C1 / np.pi) * lam**-5 / np.expm1(_C2 / (lam * temps[None, :])) * 1e-9
    xyz = p.T @ cmf[keep]
    den = xyz[:, 0] + 15.0 * xyz[:, 1] + 3.0 * xyz[:, 2]
    uv = np.stack([4.0 * xyz[:, 0] / den, 6.0 * xyz[:, 1] / den], axis=1)
    return np.concatenate([temps[:, None], uv], axis=1)


@functools.cache
def _planckian_table() -> np.ndarray:
    """:func:`planckian_locus` as shipped (``lumijax/data``), read-only."""
    path = resources.files("lumijax") / "data" / PLANCKIAN_FILE
    with resources.as_file(path) as p:
        table = np.load(p, allow_pickle=False)
    table.setflags(write=False)
    return table


def _nearest_row(table: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Each uv's nearest row of the locus ``table`` (the first of equals), as the argmin over
    every row: the rows within the distance to the nearest of every 16th row, whose u lies
    within that distance and so form one run of the table (u falls along it), are compared
    by squared distance (which orders as the distance does). 100 points: 14.8 → ~1 ms."""
    u, v = table[:, 1], table[:, 2]
    du, dv = u[None, ::16] - flat[:, None, 0], v[None, ::16] - flat[:, None, 1]
    reach = np.sqrt((du * du + dv * dv).min(axis=1)) * (1 + 1e-9) + 1e-15
    # u decreases along the table: the run is where u ∈ [u_point − reach, u_point + reach]
    back = -u
    lo = np.searchsorted(back, -(flat[:, 0] + reach), "left")
    hi = np.searchsorted(back, -(flat[:, 0] - reach), "right")
    idx = np.empty(len(flat), dtype=np.intp)
    width = int((hi - lo).max(initial=1))
    for a in range(0, len(flat), 256):  # chunks bound the (n, run) distance matrix
        rows = np.minimum(lo[a:a + 256, None] + np.arange(width), len(table) - 1)
        du = u[rows] - flat[a:a + 256, None, 0]
        dv = v[rows] - flat[a:a + 256, None, 1]
        d2 = np.where(rows < hi[a:a + 256, None], du * du + dv * dv, np.inf)
        idx[a:a + 256] = rows[np.arange(len(rows)), np.argmin(d2, axis=1)]
    return idx


def uv_to_cct_ohno2013(uv: np.ndarray) -> np.ndarray:
    """CCT (K) of CIE 1960 uv (``(..., 2)``) by Ohno (2013), shape ``(...)``."""
    uv = np.asarray(uv, dtype=np.float64)
    flat = uv.reshape(-1, 2)
    table = _planckian_table()
    if flat.shape[0] == 0:
        return np.zeros(uv.shape[:-1])
    # nearest table entry, kept off the ends so both neighbours exist (colour-science's rule)
    idx = np.clip(_nearest_row(table, flat), 1, len(table) - 2)
    rows = [table[idx + k] for k in (-1, 0, 1)]
    dist = [np.hypot(r[:, 1] - flat[:, 0], r[:, 2] - flat[:, 1]) for r in rows]
    (tip, uip, vip), (ti, _, _), (tin, uin, vin) = ([r[:, j] for j in range(3)] for r in rows)
    dip, di, din = dist
    line = np.hypot(uin - uip, vin - vip)
    x = (dip**2 - din**2 + line**2) / (2.0 * line)
    t_t = tip + (tin - tip) * (x / line)
    vtx = vip + (vin - vip) * (x / line)
    sign = np.sign(flat[:, 1] - vtx)
    duv_t = np.sqrt(np.maximum(dip**2 - x**2, 0.0)) * sign
    big = (tin - ti) * (tip - tin) * (ti - tip)
    a = (tip * (din - di) + ti * (dip - din) + tin * (di - dip)) / big
    b = -(tip**2 * (din - di) + ti**2 * (dip - din) + tin**2 * (di - dip)) / big
    t_p = -b / (2.0 * a)
    cct = np.where(np.abs(duv_t) >= 0.002, t_p, t_t)
    return cct.reshape(uv.shape[:-1])
