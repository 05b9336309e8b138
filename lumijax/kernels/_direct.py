"""Pure JAX kernels of direct illuminance: point sources with a candela distribution, and
Lambertian quads through Lambert's contour integral (shared with the transport operator).

No visibility here: the kernels give unshadowed illuminance, and the caller multiplies by
visibility from ray casting. Keeping visibility out is what lets the optimiser re-aim a luminaire
and differentiate without casting a single new ray (the paper, section 6: visibility does not
change when a source is only re-aimed).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from ._form_factors import form_factor_point_triangle

__all__ = ["point_illuminance", "pair_light", "offset_illuminance",
           "quad_form_factors"]


def pair_light(
    distribution,
    rotations: Float[Array, "*#pairs 3 3"],
    directions: Float[Array, "*#pairs 3"],
    gains: Float[Array, "*#pairs"],
) -> Float[Array, "*#pairs"]:
    """``gain · I(Rᵀ w)`` (lx): the one point-source kernel. ``directions`` are unit vectors
    source → receiver (world), ``rotations`` world-from-local per pair, ``gains`` the
    aim-independent ``scale · cos θ_r / d²`` (m⁻²). Every other point-source form here, the
    forward light and the optimiser's aim model (``lumijax.direct.PairSet``) evaluate this."""
    local = jnp.einsum("...ij,...i->...j", rotations, directions)  # Rᵀ·w: luminaire frame
    return gains * distribution.intensity(local)


def _offset(distribution, d, rot, scale, normal):
    """``s·I(ω)·cos θ / d²`` (lx) from the offsets ``d`` = receiver − source (m).

    The guard on ``d²`` is the dtype's smallest normal number, not a length: a fixed one
    (1e-12 m² once) clamps every pair of a millimetre model's sub-millimetre parts.
    """
    r2 = jnp.sum(d * d, axis=-1)
    r2 = jnp.maximum(r2, jnp.finfo(r2.dtype).tiny)
    w = d * jax.lax.rsqrt(r2)[..., None]
    cos_r = jnp.maximum(-jnp.sum(w * normal, axis=-1), 0.0)
    return pair_light(distribution, rot, w, scale * cos_r / r2)


def _pair(distribution, pos, rot, scale, point, normal):
    """``s·I(ω)·cos θ / d²`` (lx) for matching rows of sources and receivers."""
    return _offset(distribution, point - pos, rot, scale, normal)


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
    return jax.vmap(lambda p, r, s: _pair(distribution, p, r, s, points, normals))(
        positions, rotations, scales)


def offset_illuminance(
    distribution,
    offsets: Float[Array, "pairs 3"],
    rotations: Float[Array, "lum 3 3"],
    scales: Float[Array, " lum"],
    normals: Float[Array, "points 3"],
    source: Int[Array, " pairs"],
    receiver: Int[Array, " pairs"],
) -> Float[Array, " pairs"]:
    """Unshadowed illuminance (lx) of (source, receiver) index pairs, from each pair's offset
    ``receiver − source`` (m), which the caller computes in float64 on the host.

    This is the form for site coordinates: in float32, ``point − position`` at 5·10⁶ m from the
    origin is rounded to 0.5 m before the kernel sees it (a 4 m room read 8 % off there, 34 %
    at 10⁷ m); the offset itself is a few metres and keeps float32's relative precision.
    """
    return _offset(distribution, offsets, rotations[source], scales[source], normals[receiver])


def quad_form_factors(
    points: Float[Array, "points 3"],
    normals: Float[Array, "points 3"],
    quads: Float[Array, "quads 4 3"],
) -> Float[Array, "points quads"]:
    """Form factors from each receiver point to each one-sided quad ``v0 v1 v2 v3`` (front face
    by the right-hand rule): the sum over its two triangles of Lambert's contour integral with
    horizon clipping (:func:`lumijax.radiosity.form_factor_point_triangle`), exact."""
    tris = jnp.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1)  # (quads, 2, 3, 3)
    f = form_factor_point_triangle(points[:, None, None, :], normals[:, None, None, :],
                                   tris[None])
    return jnp.sum(f, axis=-1)
