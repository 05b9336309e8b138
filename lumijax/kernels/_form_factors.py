"""Form-factor kernels (pure JAX, vectorised over any leading axes).

* :func:`form_factor_point_triangle` — Lambert's contour integral (``form-factors.md`` §7) from a
  differential receiver to a triangle, with the triangle first clipped to the receiver's front
  half-space (horizon clipping) so that partly-behind sources are exact too. Exact for an
  unoccluded source: the only error left in a patch-to-patch factor is the quadrature over the
  receiver. :func:`form_factor_point_front_triangle` is the same sum without the clipping, for
  a source the caller knows to be wholly in front (most near pairs; 0.4 of the time).
* :func:`form_factor_far` — the reciprocal point-to-point estimate with a second-order
  finite-area correction for well-separated patches (:func:`far_g`, shared with the host-side
  numpy build).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = [
    "form_factor_point_triangle",
    "form_factor_point_front_triangle",
    "form_factor_far",
    "far_g",
    "triangle_spread",
]

_TWO_PI = 2.0 * jnp.pi


def _clip_to_front(r: Float[Array, "... 3 3"], s: Float[Array, "... 3"]):
    """Clip a triangle (vertices ``r`` relative to the receiver) to the half-space ``s > 0``.

    A plane cuts a triangle to at most a quadrilateral, so the result is a closed 4-slot
    polygon ``(..., 4, 3)``; with fewer corners its last slot repeats, a zero-length edge that
    adds nothing to the contour sum, and the shape stays fixed for XLA. The triangle is first
    turned (by selects: a gather was slower) so that its cut is the same in every case: with
    m corners in front, for m = 3 nothing, for m = 2 the one behind at slot 2, for m = 1 the
    one in front at slot 0. Four edges, each an arctangent, where a slot per corner and per
    cut edge made six: a call of 4,096 points takes 0.79–0.88 of the time it took
    (benchmarks/RESULTS.md, session 21). Also returns whether any part is in front.
    """
    inside = s > 0
    m = inside.sum(axis=-1)
    k = jnp.where(m == 2, (jnp.argmin(inside, axis=-1) + 1) % 3,
                  jnp.where(m == 1, jnp.argmax(inside, axis=-1), 0))

    def turned(x, axis):  # x with its corners turned k steps along ``axis``
        def at(x_k):
            return x_k.reshape(x_k.shape + (1,) * (x.ndim - x_k.ndim))
        return jnp.where(at(k == 1), jnp.roll(x, -1, axis=axis),
                         jnp.where(at(k == 2), jnp.roll(x, -2, axis=axis), x))

    w, sw = turned(r, -2), turned(s, -1)

    def cut(a: int, b: int):  # where edge a → b meets the plane (the corner where both are on it)
        sa, sb = sw[..., a], sw[..., b]
        t = sa / jnp.where(sa == sb, 1.0, sa - sb)
        return w[..., a, :] + t[..., None] * (w[..., b, :] - w[..., a, :])

    e01, e12, e20 = cut(0, 1), cut(1, 2), cut(2, 0)
    m3 = m[..., None]
    slot1 = jnp.where(m3 >= 2, w[..., 1, :], e01)
    slot2 = jnp.where(m3 == 3, w[..., 2, :], jnp.where(m3 == 2, e12, e20))
    slot3 = jnp.where(m3 == 3, w[..., 2, :], e20)
    return jnp.stack([w[..., 0, :], slot1, slot2, slot3], axis=-2), m > 0


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
    s = jnp.sum(r * normal[..., None, :], axis=-1)
    poly, any_front = _clip_to_front(r, s)
    return jnp.where(_faces(r) & any_front, _contour(poly, normal), 0.0)


def form_factor_point_front_triangle(
    point: Float[Array, "... 3"],
    normal: Float[Array, "... 3"],
    triangle: Float[Array, "... 3 3"],
) -> Float[Array, "..."]:
    """:func:`form_factor_point_triangle` for a triangle wholly in front of the receiver
    (every vertex ``v`` with ``(v − point)·normal > 0``; the caller's promise, unchecked):
    no horizon clipping, three edges, 0.39–0.43 of the clipped kernel's time for 4,096
    points (docs/radiosity.md, "The near field's two kernels"). Where the promise holds the
    two agree to rounding: clipping leaves such a triangle whole."""
    r = triangle - point[..., None, :]
    return jnp.where(_faces(r), _contour(r, normal), 0.0)


def _faces(r: Float[Array, "... 3 3"]) -> Array:
    """Whether the receiver is in front of the triangle (vertices ``r`` relative to it): light
    leaves a source triangle only on its front side."""
    m = jnp.cross(r[..., 1, :] - r[..., 0, :], r[..., 2, :] - r[..., 0, :])
    return -jnp.sum(r[..., 0, :] * m, axis=-1) > 0


def _contour(poly: Float[Array, "... k 3"], normal: Float[Array, "... 3"]) -> Array:
    """Lambert's contour sum over a closed polygon (vertices relative to the receiver)."""
    a, b = poly, jnp.roll(poly, -1, axis=-2)
    c = jnp.cross(a, b)
    cn = jnp.sqrt(jnp.sum(c * c, axis=-1))
    gamma = jnp.arctan2(cn, jnp.sum(a * b, axis=-1))
    # Zero-length or collinear edges have c = 0: their term is 0 (γ→0 or n·c/|c| bounded).
    term = gamma * jnp.sum(c * normal[..., None, :], axis=-1) / jnp.where(cn > 0, cn, 1.0)
    return jnp.abs(jnp.sum(term, axis=-1)) / _TWO_PI


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
