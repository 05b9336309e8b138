"""The Guth position index: how much less a glare source bothers the eye the further it lies
from the line of sight (CIE 117:1995, after Luckiesh & Guth 1949).

Above the line of sight the index is the Luckiesh–Guth expression as fitted to Guth's table
(IES Lighting Handbook; the form Radiance's evalglare and CIE 117's tables use)::

    ln p = (35.2 − 0.31889 τ − 1.22 e^(−2τ/9)) 10⁻³ σ + (21 + 0.26667 τ − 0.002963 τ²) 10⁻⁵ σ²

with σ the angle (deg) between the line of sight and the direction of the source and τ the
angle (deg), in the plane across the line of sight, between the vertical and the plane holding
the line of sight and the source (τ = 0: straight above the line of sight). Below the line of
sight Guth's table has no values; as evalglare does, the index there is Iwata & Tokura's
(1997) ``p = 1 + f R`` with ``R = √(tan²φ + tan²θ)`` (φ below, θ beside the line of sight),
``f = 0.8`` for R ≤ 0.6 and 1.2 beyond, R at most 3. The index is held at most 16 (evalglare's
cap: a source that far off the line of sight adds nothing measurable).

The index depends on where the eye and the sources are, not on aims or dimmers: it is computed
once, on the host (numpy, float64).
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float

__all__ = ["guth_index", "position_index", "view_angles", "MAX_POSITION_INDEX"]

#: Largest position index (evalglare's cap).
MAX_POSITION_INDEX = 16.0


def guth_index(sigma_deg, tau_deg):
    """The Luckiesh–Guth expression p(σ, τ) (degrees in, dimensionless out), uncapped."""
    s = np.asarray(sigma_deg, np.float64)
    t = np.asarray(tau_deg, np.float64)
    return np.exp((35.2 - 0.31889 * t - 1.22 * np.exp(-2.0 * t / 9.0)) * 1e-3 * s
                  + (21.0 + 0.26667 * t - 0.002963 * t * t) * 1e-5 * s * s)


def view_angles(directions: Float[np.ndarray, "... 3"], forward: Float[np.ndarray, "... 3"],
                up=(0.0, 0.0, 1.0)):
    """``(σ, τ, φ, θ)`` in degrees of unit ``directions`` (eye → source) for a line of sight
    ``forward`` (unit) and vertical ``up``: σ off the line of sight, τ of the source's plane
    from the vertical (see the module docstring), φ elevation above the line of sight's
    horizontal plane (negative below), θ beside it."""
    d = np.asarray(directions, np.float64)
    f = np.broadcast_to(np.asarray(forward, np.float64), d.shape)
    up = np.asarray(up, np.float64)
    right = np.cross(f, up)
    right /= np.maximum(np.linalg.norm(right, axis=-1, keepdims=True), 1e-300)
    vert = np.cross(right, f)  # the vertical across the line of sight
    cos_s = np.clip(np.einsum("...k,...k->...", d, f), -1.0, 1.0)
    sigma = np.degrees(np.arccos(cos_s))
    u = np.einsum("...k,...k->...", d, vert)
    r = np.einsum("...k,...k->...", d, right)
    tau = np.degrees(np.arctan2(np.abs(r), u))  # 0 above, 90 beside, 180 below
    phi = np.degrees(np.arcsin(np.clip(u, -1.0, 1.0)))
    theta = np.degrees(np.arcsin(np.clip(r, -1.0, 1.0)))
    return sigma, tau, phi, theta


def position_index(directions, forward, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Position index p ≥ 1 of sources in unit ``directions`` (eye → source) for the line of
    sight ``forward``: Guth above the line of sight, Iwata below, capped at 16. Sources behind
    the eye (σ ≥ 90°) get the cap; callers leave them out anyway."""
    sigma, tau, phi, theta = view_angles(directions, forward, up)
    p = guth_index(sigma, np.minimum(tau, 90.0))
    below = phi < 0
    tp = np.tan(np.radians(np.abs(phi)))
    tt = np.tan(np.radians(np.abs(theta)))
    r = np.minimum(np.sqrt(tp * tp + tt * tt), 3.0)
    iwata = 1.0 + np.where(r > 0.6, 1.2, 0.8) * r
    p = np.where(below, iwata, p)
    p = np.where(sigma >= 90.0, MAX_POSITION_INDEX, p)
    return np.asarray(np.clip(p, 1.0, MAX_POSITION_INDEX))
