"""Pure JAX kernels of direct illuminance: point sources with a candela distribution, and
Lambertian polygons through Lambert's contour integral.

No visibility here: the kernels give unshadowed illuminance, and the caller multiplies by
visibility from ray casting. Keeping visibility out is what lets the optimiser re-aim a luminaire
and differentiate without casting a single new ray (the paper, section 6: visibility does not
change when a source is only re-aimed).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

__all__ = ["point_illuminance", "pair_illuminance", "polygon_form_factor", "quad_form_factors"]

_TINY = 1e-12


def point_illuminance(
    distribution,
    positions: Float[Array, "lum 3"],
    rotations: Float[Array, "lum 3 3"],
    scales: Float[Array, " lum"],
    points: Float[Array, "points 3"],
    normals: Float[Array, "points 3"],
) -> Float[Array, "lum points"]:
    """Unshadowed illuminance (lx) at each point from each point source: ``s·I(ω)·cos θ / d²``.

    Parameters
    ----------
    distribution
        A :class:`lumijax.photometry.CandelaDistribution` (cd) shared by these luminaires.
    positions, rotations
        Luminaire positions (m) and world-from-local rotations (docs/conventions.md).
    scales
        Candela multipliers (multiplier × maintenance factor × …).
    points, normals
        Receiver positions (m) and unit normals; light from behind a receiver's plane adds 0.
    """

    def one(pos, rot, s):
        d = points - pos
        r2 = jnp.maximum(jnp.sum(d * d, axis=-1), _TINY)
        w = d * jax.lax.rsqrt(r2)[:, None]
        intensity = distribution.intensity(w @ rot)  # rotᵀ·w: the direction in the luminaire frame
        cos_r = jnp.maximum(-jnp.sum(w * normals, axis=-1), 0.0)
        return s * intensity * cos_r / r2

    return jax.vmap(one)(positions, rotations, scales)


def pair_illuminance(
    distribution,
    positions: Float[Array, "lum 3"],
    rotations: Float[Array, "lum 3 3"],
    scales: Float[Array, " lum"],
    points: Float[Array, "points 3"],
    normals: Float[Array, "points 3"],
    source: Int[Array, " pairs"],
    receiver: Int[Array, " pairs"],
) -> Float[Array, " pairs"]:
    """Unshadowed illuminance (lx) for a list of (source, receiver) index pairs.

    The same physics as :func:`point_illuminance`, evaluated only where the caller found light
    can arrive (inside a source's beam, on a receiver's front side): for a spot aimed at a facade
    that is a few per cent of all pairs. Index arrays may be padded; pad with a source whose
    scale is 0.
    """
    pos = positions[source]
    d = points[receiver] - pos
    r2 = jnp.maximum(jnp.sum(d * d, axis=-1), _TINY)
    w = d * jax.lax.rsqrt(r2)[:, None]
    local = jnp.einsum("nij,ni->nj", rotations[source], w)  # rotᵀ·w per pair
    cos_r = jnp.maximum(-jnp.sum(w * normals[receiver], axis=-1), 0.0)
    return scales[source] * distribution.intensity(local) * cos_r / r2


def _edge_term(a, b, n):
    """γ · n·(a×b)/|a×b| for one polygon edge seen from the origin (0 for a degenerate edge)."""
    c = jnp.cross(a, b)
    s2 = jnp.sum(c * c, axis=-1)
    ok = s2 > _TINY * _TINY
    s = jnp.sqrt(jnp.where(ok, s2, 1.0))
    gamma = jnp.arctan2(s, jnp.sum(a * b, axis=-1))
    return jnp.where(ok, gamma * jnp.sum(n * c, axis=-1) / s, 0.0)


def polygon_form_factor(
    point: Float[Array, "3"], normal: Float[Array, "3"], vertices: Float[Array, "v 3"]
) -> Float[Array, ""]:
    """Form factor from a differential receiver to a convex planar polygon.

    Lambert's contour integral ``F = |Σ γ_i n·(R_i×R_{i+1})/|R_i×R_{i+1}|| / 2π``
    (reference: form-factors §7), after clipping the polygon to the half-space in front of the
    receiver (``n·R > 0``) so that the horizon is handled exactly. The clipped polygon's edges are
    the kept parts of the original edges plus one closing edge in the receiver's plane, from
    where the contour leaves the half-space to where it re-enters.
    """
    r_a = vertices - point
    r_b = jnp.roll(r_a, -1, axis=0)
    h_a = r_a @ normal
    h_b = jnp.roll(h_a, -1)
    in_a, in_b = h_a > 0, h_b > 0
    denom = h_a - h_b
    t = jnp.where(jnp.abs(denom) > _TINY, h_a / jnp.where(jnp.abs(denom) > _TINY, denom, 1.0), 0.0)
    cross_pt = r_a + t[:, None] * (r_b - r_a)
    a = jnp.where(in_a[:, None], r_a, cross_pt)
    b = jnp.where(in_b[:, None], r_b, cross_pt)
    total = jnp.sum(jnp.where(in_a | in_b, _edge_term(a, b, normal), 0.0))
    leaving = in_a & ~in_b
    entering = ~in_a & in_b
    exit_pt = jnp.sum(jnp.where(leaving[:, None], cross_pt, 0.0), axis=0)
    entry_pt = jnp.sum(jnp.where(entering[:, None], cross_pt, 0.0), axis=0)
    total = total + jnp.where(jnp.any(leaving), _edge_term(exit_pt, entry_pt, normal), 0.0)
    return jnp.abs(total) / (2.0 * jnp.pi)


def quad_form_factors(
    points: Float[Array, "points 3"],
    normals: Float[Array, "points 3"],
    quads: Float[Array, "quads 4 3"],
    quad_normals: Float[Array, "quads 3"],
) -> Float[Array, "points quads"]:
    """Form factors from each receiver point to each one-sided quad (0 behind a quad's front)."""

    def per_point(p, n):
        f = jax.vmap(lambda q: polygon_form_factor(p, n, q))(quads)
        front = jnp.sum((p - quads[:, 0]) * quad_normals, axis=-1) > 0
        return jnp.where(front, f, 0.0)

    return jax.vmap(per_point)(points, normals)
