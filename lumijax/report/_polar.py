"""Polar candela diagrams of photometry (matplotlib), as in a luminaire data sheet."""

from __future__ import annotations

import threading

import numpy as np

from ._png import figure_png

__all__ = ["polar_plot", "prerender", "beam_angle_deg", "intensity_np"]

_PLANES = {"C": ((0.0, 180.0), (90.0, 270.0)), "B": ((0.0, 180.0), (90.0, 270.0)),
           "A": ((0.0, 180.0), (90.0, 270.0))}


#: Directions are looked up in batches of a power of two rows, at least this many (zero rows
#: pad them): the lookup compiles once per (table, batch) shape, so a report's polar plots,
#: beam angles and beam outlines reuse a few kernels instead of compiling one per call's shape
#: (ten of ~0.4 s each in a cold ``lumijax demo``, contended).
MIN_BATCH = 4096


def intensity_np(dist, d) -> np.ndarray:
    """Intensity (cd) towards local directions ``d`` (..., 3), as a numpy array: the
    distribution's own lookup (:meth:`CandelaDistribution.intensity`), the one the light is
    computed with, so a data sheet draws what the study lit with (no second interpolant)."""
    import jax.numpy as jnp

    from .._jit_cache import size_class

    d = np.asarray(d, np.float64)
    flat = d.reshape(-1, 3)
    n = len(flat)
    rows = size_class(n, MIN_BATCH)
    padded = np.zeros((rows, 3)) if n < rows else flat
    if n < rows:
        padded[:n] = flat
    cd = np.asarray(dist.intensity(jnp.asarray(padded)), np.float64)[:n]
    return cd.reshape(d.shape[:-1])


def _plane_curve(dist, c_deg: float, gamma: np.ndarray) -> np.ndarray:
    """Intensity (cd) in the half-plane at azimuth ``c_deg`` about the luminaire's axis
    (local −z), for angles ``gamma`` from the axis: the C-plane of a Type C file."""
    g, c = np.radians(gamma), np.radians(c_deg)
    d = np.stack([np.sin(g) * np.cos(c), np.sin(g) * np.sin(c), -np.cos(g)], axis=-1)
    return intensity_np(dist, d)


#: γ (deg) of the plane curves: 0.25° steps for the beam angle; the polar plot draws every
#: other one (0.5°), the same angles exactly (k · 0.25 is exact in binary)
_GAMMA = np.linspace(0.0, 180.0, 721)
_MAIN_PLANES = (0.0, 90.0, 180.0, 270.0)
#: (id(distribution), x64) → (distribution, {C: curve}); the distribution is held, so its id
#: stays its own; x64 is JAX's mode the lookup ran in (it sets the lookup's precision)
_CURVES: dict[tuple[int, bool], tuple[object, dict[float, np.ndarray]]] = {}
_MAX_CURVES = 32
_lock = threading.Lock()


def _main_curves(dist) -> dict[float, np.ndarray]:
    """Intensity (cd) in the C0, C90, C180 and C270 half-planes at :data:`_GAMMA`, from one
    lookup, kept per distribution: a report asks for them three times (the two beam angles and
    the polar plot), and :func:`prefetch` may have asked first, in another thread."""
    import jax

    key = (id(dist), bool(jax.config.read("jax_enable_x64")))
    with _lock:
        hit = _CURVES.get(key)
    if hit is not None and hit[0] is dist:
        return hit[1]
    g = np.radians(_GAMMA)
    c = np.radians(np.asarray(_MAIN_PLANES))[:, None]
    d = np.stack(np.broadcast_arrays(np.sin(g) * np.cos(c), np.sin(g) * np.sin(c), -np.cos(g)),
                 axis=-1)
    curves = dict(zip(_MAIN_PLANES, intensity_np(dist, d), strict=True))
    with _lock:
        if len(_CURVES) >= _MAX_CURVES:
            _CURVES.pop(next(iter(_CURVES)))
        _CURVES[key] = (dist, curves)
    return curves


def prefetch(photometries) -> None:
    """Figure the report's plane curves of each photometry (``{name: Photometry}``) now: each
    table shape compiles its own lookup (~0.2 s cold), so a run that will write a report does
    this in the background while it computes (``report._prewarm``), and the report finds
    them kept. The same lookups, so the same curves."""
    for p in photometries.values():
        _main_curves(p.distribution)


def beam_angle_deg(dist, c_deg: float = 0.0) -> float:
    """Full angle (deg) between the half-peak points of the plane pair ``c_deg``/``c_deg+180``
    (the beam angle of a symmetric distribution)."""
    gamma = _GAMMA
    c0, c1 = float(c_deg) % 360.0, (float(c_deg) + 180.0) % 360.0
    if c0 in _MAIN_PLANES:
        curves = _main_curves(dist)
        right, left = curves[c0], curves[c1]
    else:
        right, left = _plane_curve(dist, c_deg, gamma), _plane_curve(dist, c_deg + 180.0, gamma)
    full = np.concatenate([left[::-1], right[1:]])
    ang = np.concatenate([-gamma[::-1], gamma[1:]])
    peak = full.max()
    if peak <= 0:
        return 0.0
    inside = ang[full >= 0.5 * peak]
    return float(inside.max() - inside.min())


#: (id(photometry), name, dpi) → (photometry, PNG): what :func:`prerender` drew in the background
#: for the report (the photometry is held, so its id stays its own)
_PLOTS: dict[tuple[int, str, int], tuple[object, bytes]] = {}
_MAX_PLOTS = 32


def prerender(photometries, *, dpi: int = 110) -> None:
    """Draw the report's polar diagram of each photometry (``{name: Photometry}``) now, and
    keep it for :func:`polar_plot`: a run that will write a report does this in the background
    while it computes (``report._prewarm``; ~1 s of a demo report). A drawing that fails here
    is left for the report to draw and report."""
    for name, p in photometries.items():
        try:
            png = _draw_polar(p, name, dpi)
        except Exception:
            continue
        with _lock:
            if len(_PLOTS) >= _MAX_PLOTS:
                _PLOTS.pop(next(iter(_PLOTS)))
            _PLOTS[id(p), name, dpi] = (p, png)


def polar_plot(photometry, name: str, *, dpi: int = 110) -> bytes:
    """PNG of the polar candela diagram: the C0–C180 and C90–C270 planes, γ = 0 (the axis)
    pointing down, intensity in cd."""
    with _lock:
        hit = _PLOTS.get((id(photometry), name, dpi))
    if hit is not None and hit[0] is photometry:
        return hit[1]
    return _draw_polar(photometry, name, dpi)


def _draw_polar(photometry, name: str, dpi: int) -> bytes:
    # matplotlib's object API, not pyplot: no global figure list, so another thread may draw
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    dist = photometry.distribution
    gamma = _GAMMA[::2]  # 0.5° steps
    curves = _main_curves(dist)
    fig = Figure(figsize=(4.2, 4.4), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("S")
    styles = (("#1f4e79", "-"), ("#c0504d", "--"))
    for (c0, c1), (colour, ls) in zip(_PLANES["C"], styles, strict=True):
        right, left = curves[c0][::2], curves[c1][::2]
        theta = np.concatenate([-np.radians(gamma[::-1]), np.radians(gamma[1:])])
        r = np.concatenate([left[::-1], right[1:]])
        ax.plot(theta, r, color=colour, ls=ls, lw=1.8, label=f"C{c0:g}–C{c1:g}")
    ax.set_thetagrids(range(0, 360, 30), labels=[f"{a if a <= 180 else 360 - a}°"
                                                 for a in range(0, 360, 30)], fontsize=7)
    ax.tick_params(axis="y", labelsize=7, colors="#555555")
    ax.set_rlabel_position(100)
    ax.grid(color="#cccccc", lw=0.6)
    peak = float(np.max(np.asarray(dist.candela)))
    fig.text(0.5, 0.965, name, ha="center", va="top", fontsize=10, fontweight="bold")
    fig.text(0.5, 0.915, f"intensity in cd; peak {peak:,.0f} cd, {float(dist.flux()):,.0f} lm",
             ha="center", va="top", fontsize=8, color="#444444")
    ax.legend(loc="lower center", bbox_to_anchor=(0.5, -0.2), ncol=2, fontsize=7, frameon=False)
    fig.subplots_adjust(top=0.80, bottom=0.14)
    return figure_png(fig, dpi=dpi)
