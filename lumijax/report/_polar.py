"""Polar candela diagrams of photometry (matplotlib), as in a luminaire data sheet."""

from __future__ import annotations

import io

import numpy as np

__all__ = ["polar_plot", "beam_angle_deg", "intensity_np"]

_PLANES = {"C": ((0.0, 180.0), (90.0, 270.0)), "B": ((0.0, 180.0), (90.0, 270.0)),
           "A": ((0.0, 180.0), (90.0, 270.0))}


def intensity_np(dist, d) -> np.ndarray:
    """Intensity (cd) towards local directions ``d`` (..., 3), as a numpy array: the
    distribution's own lookup (:meth:`CandelaDistribution.intensity`), the one the light is
    computed with, so a data sheet draws what the study lit with (no second interpolant)."""
    import jax.numpy as jnp

    d = np.asarray(d, np.float64)
    flat = np.asarray(dist.intensity(jnp.asarray(d.reshape(-1, 3))), np.float64)
    return flat.reshape(d.shape[:-1])


def _plane_curve(dist, c_deg: float, gamma: np.ndarray) -> np.ndarray:
    """Intensity (cd) in the half-plane at azimuth ``c_deg`` about the luminaire's axis
    (local −z), for angles ``gamma`` from the axis: the C-plane of a Type C file."""
    g, c = np.radians(gamma), np.radians(c_deg)
    d = np.stack([np.sin(g) * np.cos(c), np.sin(g) * np.sin(c), -np.cos(g)], axis=-1)
    return intensity_np(dist, d)


def beam_angle_deg(dist, c_deg: float = 0.0) -> float:
    """Full angle (deg) between the half-peak points of the plane pair ``c_deg``/``c_deg+180``
    (the beam angle of a symmetric distribution)."""
    gamma = np.linspace(0.0, 180.0, 721)
    right, left = _plane_curve(dist, c_deg, gamma), _plane_curve(dist, c_deg + 180.0, gamma)
    full = np.concatenate([left[::-1], right[1:]])
    ang = np.concatenate([-gamma[::-1], gamma[1:]])
    peak = full.max()
    if peak <= 0:
        return 0.0
    inside = ang[full >= 0.5 * peak]
    return float(inside.max() - inside.min())


def polar_plot(photometry, name: str, *, dpi: int = 110) -> bytes:
    """PNG of the polar candela diagram: the C0–C180 and C90–C270 planes, γ = 0 (the axis)
    pointing down, intensity in cd."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    dist = photometry.distribution
    gamma = np.linspace(0.0, 180.0, 361)
    fig = plt.figure(figsize=(4.2, 4.4), dpi=dpi)
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("S")
    styles = (("#1f4e79", "-"), ("#c0504d", "--"))
    for (c0, c1), (colour, ls) in zip(_PLANES["C"], styles, strict=True):
        right, left = _plane_curve(dist, c0, gamma), _plane_curve(dist, c1, gamma)
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
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return buf.getvalue()
