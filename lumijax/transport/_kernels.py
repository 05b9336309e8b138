"""Form-factor kernels (pure JAX, vectorised over any leading axes).

* :func:`form_factor_point_triangle` — Lambert's contour integral (``form-factors.md`` §7) from a
  differential receiver to a triangle, with the triangle first clipped to the receiver's front
  half-space (horizon clipping) so that partly-behind sources are exact too. Exact for an
  unoccluded source: the only error left in a patch-to-patch factor is the quadrature over the
  receiver.
* :func:`form_factor_far` — the reciprocal point-to-point estimate with a finite-area correction
  for well-separated patches.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

__all__ = ["form_factor_point_triangle", "form_factor_far"]

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


def form_factor_far(
    ci: Float[Array, "... 3"],
    ni: Float[Array, "... 3"],
    ai: Float[Array, "..."],
    cj: Float[Array, "... 3"],
    nj: Float[Array, "... 3"],
    aj: Float[Array, "..."],
) -> Float[Array, "..."]:
    """``A_i F_ij`` (m²) for well-separated patches, unoccluded; symmetric in i and j.

    ``A_i A_j cosθ_i cosθ_j / (π d² + A_i + A_j)``: the point-to-point kernel with the finite-area
    correction that makes it exact to second order for coaxial disks (``form-factors.md`` §5 with
    R ≪ 1 gives R²/(1 + 2R²)); it is reciprocal by construction.
    """
    d = cj - ci
    d2 = jnp.sum(d * d, axis=-1)
    cos_i = jnp.sum(d * ni, axis=-1)
    cos_j = -jnp.sum(d * nj, axis=-1)
    g = ai * aj * cos_i * cos_j / (d2 * (jnp.pi * d2 + ai + aj))
    return jnp.where((cos_i > 0) & (cos_j > 0), g, 0.0)
