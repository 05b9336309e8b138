"""Form-factor kernels (pure JAX, vectorised over any leading axes).

* :func:`form_factor_point_triangle` — Lambert's contour integral (``form-factors.md`` §7) from a
  differential receiver to a triangle, with the triangle first clipped to the receiver's front
  half-space (horizon clipping) so that partly-behind sources are exact too. Exact for an
  unoccluded source: the only error left in a patch-to-patch factor is the quadrature over the
  receiver.
* :func:`form_factor_far` — the reciprocal point-to-point estimate with a second-order
  finite-area correction for well-separated patches (:func:`far_g`, shared with the host-side
  numpy build).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = ["form_factor_point_triangle", "form_factor_far", "far_g", "triangle_spread"]

_TWO_PI = 2.0 * jnp.pi


def _clip_to_front(r: Float[Array, "... 3 3"], s: Float[Array, "... 3"]):
    """Clip a triangle (vertices ``r`` relative to the receiver) to the half-space ``s > 0``.

    Returns a 6-slot closed polygon ``(..., 6, 3)``: slots v0, e01, v1, e12, v2, e20 where e are
    edge/plane intersections. Slots that are not part of the clipped polygon repeat the previous
    valid vertex, so they add zero-length edges (which contribute nothing to the contour sum);
    the shape stays fixed for XLA. Also returns whether any part is in front.
    """
    inside = s > 0
    slots, valid = [], []
    for k in range(3):
        k1 = (k + 1) % 3
        sk, sk1 = s[..., k], s[..., k1]
        t = sk / jnp.where(sk == sk1, 1.0, sk - sk1)
        e = r[..., k, :] + t[..., None] * (r[..., k1, :] - r[..., k, :])
        slots += [r[..., k, :], e]
        valid += [inside[..., k], inside[..., k] != inside[..., k1]]
    # Forward-fill invalid slots cyclically: two passes so that slot 0 can inherit from slot 5.
    cur = slots[5]
    for k in range(6):  # first pass only finds the last valid vertex before each slot
        cur = jnp.where(valid[k][..., None], slots[k], cur)
    out = []
    for k in range(6):
        cur = jnp.where(valid[k][..., None], slots[k], cur)
        out.append(cur)
    return jnp.stack(out, axis=-2), inside.any(axis=-1)


def form_factor_point_triangle(
    point: Float[Array, "... 3"],
    normal: Float[Array, "... 3"],
    triangle: Float[Array, "... 3 3"],
) -> Float[Array, "..."]:
    """Differential-area-to-triangle form factor (dimensionless), unoccluded.

    Parameters
    ----------
    point, normal
        The receiver point (m) and its unit front normal.
    triangle
        The source triangle's vertices (m); its front face follows the right-hand rule.

    Returns
    -------
    The fraction of a Lambertian emission of the triangle's front face... stated reciprocally:
    ``F_{dA→T} = (1/π) ∫_T cosθ cosθ' / r² dA`` over the part of T in front of the receiver,
    zero if the receiver is behind the triangle's plane.
    """
    r = triangle - point[..., None, :]
    # Source front face: light leaves the triangle only on its front side.
    m = jnp.cross(r[..., 1, :] - r[..., 0, :], r[..., 2, :] - r[..., 0, :])
    in_front_of_source = -jnp.sum(r[..., 0, :] * m, axis=-1) > 0
    s = jnp.sum(r * normal[..., None, :], axis=-1)
    poly, any_front = _clip_to_front(r, s)
    a, b = poly, jnp.roll(poly, -1, axis=-2)
    c = jnp.cross(a, b)
    cn = jnp.sqrt(jnp.sum(c * c, axis=-1))
    gamma = jnp.arctan2(cn, jnp.sum(a * b, axis=-1))
    # Zero-length or collinear edges have c = 0: their term is 0 (γ→0 or n·c/|c| bounded).
    term = gamma * jnp.sum(c * normal[..., None, :], axis=-1) / jnp.where(cn > 0, cn, 1.0)
    f = jnp.abs(jnp.sum(term, axis=-1)) / _TWO_PI
    return jnp.where(in_front_of_source & any_front, f, 0.0)


def far_g(a, b, c, d2, ai, aj, si, sj, xp=np):
    """``A_i F_ij`` (m²) of the far kernel from pair quantities (numpy or ``xp=jnp``).

    ``a = n_i·r``, ``b = −n_j·r`` (r = c_j − c_i, both > 0 for facing patches), ``c = n_i·n_j``,
    ``d2 = |r|²``, areas ``ai, aj`` and spreads ``si, sj`` (half the trace of each patch's
    second-moment tensor about its centroid, m²: ``A/4π`` for a disk, ``Σ|v_k − c|²/24`` for a
    triangle). The point kernel ``A_i A_j ab/(π d⁴)`` is corrected to second order in patch
    size by the Taylor expansion of ``cos θ_i cos θ_j / π r²`` over both patches, taking each
    patch's second moments as isotropic in its plane::

        δ = (4/d²)·[s_i (1 − 3a²/d² − c a/b) + s_j (1 − 3b²/d² − c b/a)]

    applied as ``1/(1 − δ)`` when δ < 0 (it stays positive at grazing angles) and ``1 + δ``
    otherwise. Coaxial disks give ``δ = −(A_i + A_j)/(π d²)``, the old correction's first order;
    chords of a sphere give the flat patches' true deficit ``−(A_i + A_j)/(4π R²)``, whatever
    d, where the old ``(A_i + A_j)/(π d²)`` over-corrected every pair closer than the diameter
    (rows of an icosphere summed to 0.998 instead of 1; now 0.99997). Symmetric in i ↔ j.
    """
    delta = (4.0 / d2) * (si * (1.0 - 3.0 * a * a / d2 - c * a / b)
                          + sj * (1.0 - 3.0 * b * b / d2 - c * b / a))
    corr = xp.where(delta < 0, 1.0 / (1.0 - xp.minimum(delta, 0.0)), 1.0 + xp.maximum(delta, 0.0))
    return ai * aj * a * b / (xp.pi * d2 * d2) * corr


def triangle_spread(vertices):
    """Half the trace of a triangle's second-moment tensor about its centroid (m²), per
    triangle of ``vertices`` (…, 3, 3): ``Σ_k |v_k − c|² / 24``."""
    v = vertices - vertices.mean(axis=-2, keepdims=True)
    return (v * v).sum(axis=(-2, -1)) / 24.0


def form_factor_far(
    ci: Float[Array, "... 3"],
    ni: Float[Array, "... 3"],
    ai: Float[Array, "..."],
    cj: Float[Array, "... 3"],
    nj: Float[Array, "... 3"],
    aj: Float[Array, "..."],
    si=None,
    sj=None,
) -> Float[Array, "..."]:
    """``A_i F_ij`` (m²) for well-separated patches, unoccluded; symmetric in i and j.

    The point-to-point kernel with a second-order finite-area correction (:func:`far_g`);
    ``si, sj`` are the patches' spreads (default: disks, ``A/4π``). Reciprocal by construction.
    """
    si = ai / (4.0 * jnp.pi) if si is None else si
    sj = aj / (4.0 * jnp.pi) if sj is None else sj
    d = cj - ci
    d2 = jnp.sum(d * d, axis=-1)
    a = jnp.sum(d * ni, axis=-1)
    b = -jnp.sum(d * nj, axis=-1)
    ok = (a > 0) & (b > 0)
    g = far_g(jnp.where(ok, a, 1.0), jnp.where(ok, b, 1.0), jnp.sum(ni * nj, axis=-1), d2,
              ai, aj, si, sj, xp=jnp)
    return jnp.where(ok, g, 0.0)
