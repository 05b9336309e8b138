"""The glare ratings, as pure JAX functions of luminances, solid angles and illuminances.

Each takes the per-source quantities an eye sees and returns the rating; all are
differentiable, and since a network's luminances and illuminances scale with its dimmer,
:class:`lumijax.glare.GlareModel` evaluates them at any design without a ray.

* UGR, CIE 117:1995: ``8 log10(0.25/L_b · Σ L² ω / p²)``; valid for sources of 0.0003–0.1 sr
  (``SOLID_ANGLE_RANGE_SR``): smaller ones over-rate (CIE 147 has the small-source form),
  larger ones under-rate.
* GR, CIE 112:1994 / EN 12464-2: ``27 + 24 log10(L_vl / L_ve^0.9)`` with the luminaires'
  veiling luminance ``L_vl = 10 Σ E_eye / θ²`` (θ in degrees, the Stiles–Holladay form, valid
  for 1.5° < θ < 60°) and the environment's ``L_ve = 0.035 L_av``.
* TI, CIE 140 / EN 13201-3: ``65 L_v / L_av^0.8`` (%), for a road's average luminance
  ``L_av`` ≤ 5 cd/m²; ``95 L_v / L_av^1.05`` above (CIE 140, section 4.2).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = ["ugr", "ugr_of_sum", "glare_rating", "threshold_increment", "veiling_luminance",
           "SOLID_ANGLE_RANGE_SR", "VEILING_ANGLE_RANGE_DEG", "ENVIRONMENT_VEILING_FACTOR"]

#: CIE 117's range of source solid angles (sr) for which UGR is defined.
SOLID_ANGLE_RANGE_SR = (3e-4, 0.1)
#: The range of glare angles (deg) of the disability-glare formula 10 E / θ².
VEILING_ANGLE_RANGE_DEG = (1.5, 60.0)
#: CIE 112: the environment's veiling luminance is 0.035 × its average luminance.
ENVIRONMENT_VEILING_FACTOR = 0.035
#: Floors that keep a rating finite where its formula is not (no source seen, no background):
#: the arguments of the logarithms are held ≥ these, so UGR ≥ 0 and GR ≥ 0; callers flag the
#: views where the floor acted (``GlareRatings.valid``).
_TINY = 1e-30


def veiling_luminance(eye_illuminance: Float[Array, "... src"],
                      angle_deg: Float[Array, "... src"]) -> Float[Array, "..."]:
    """``L_v = 10 Σ E_i / θ_i²`` (cd/m²): E_i the illuminance (lx) each source makes at the
    eye on the plane across the line of sight, θ_i its angle from the line of sight (deg, held
    ≥ 1.5°, the formula's lower end)."""
    theta = jnp.maximum(angle_deg, VEILING_ANGLE_RANGE_DEG[0])
    return 10.0 * jnp.sum(eye_illuminance / (theta * theta), axis=-1)


def ugr(luminance: Float[Array, "... src"], solid_angle: Float[Array, "... src"],
        position: Float[Array, "... src"], background: Float[Array, "..."]) -> Float[Array, "..."]:
    """CIE 117 unified glare rating of sources of luminance L (cd/m²), solid angle ω (sr) and
    Guth position index p, against background luminance L_b (cd/m²); held ≥ 0."""
    s = jnp.sum(luminance * luminance * solid_angle / (position * position), axis=-1)
    return ugr_of_sum(s, background)


def ugr_of_sum(s, background):
    """UGR from ``Σ L² ω / p²`` (cd²/m⁴·sr) and L_b (cd/m²), held ≥ 0. Host numbers (floats,
    numpy) are rated in numpy, the same formula: eagerly in JAX each of its four operations
    compiles a kernel per process (an image's own UGR, ``render._image``)."""
    xp = jnp if isinstance(s, jax.Array) or isinstance(background, jax.Array) else np
    x = 0.25 * s / xp.maximum(background, _TINY)
    return 8.0 * xp.log10(xp.maximum(x, 1.0))


def glare_rating(luminaire_veiling: Float[Array, "..."],
                 environment_luminance: Float[Array, "..."]) -> Float[Array, "..."]:
    """CIE 112 glare rating from the luminaires' veiling luminance L_vl (cd/m²) and the
    environment's average luminance L_av (cd/m², ``L_ve = 0.035 L_av``); held ≥ 0."""
    lve = ENVIRONMENT_VEILING_FACTOR * jnp.maximum(environment_luminance, _TINY)
    y = jnp.maximum(luminaire_veiling, _TINY) / lve ** 0.9
    # the floor's 27 + 24 log10(10^(−27/24)) is 0 only up to rounding: held at 0 exactly
    return jnp.maximum(27.0 + 24.0 * jnp.log10(jnp.maximum(y, 10.0 ** (-27.0 / 24.0))), 0.0)


def threshold_increment(veiling: Float[Array, "..."],
                        road_luminance: Float[Array, "..."]) -> Float[Array, "..."]:
    """CIE 140 threshold increment TI (%) from the luminaires' veiling luminance L_v (cd/m²)
    and the road's average luminance L_av (cd/m²): 65 L_v / L_av^0.8 up to 5 cd/m²,
    95 L_v / L_av^1.05 above."""
    lav = jnp.maximum(road_luminance, _TINY)
    return jnp.where(lav <= 5.0, 65.0 * veiling / lav ** 0.8, 95.0 * veiling / lav ** 1.05)
