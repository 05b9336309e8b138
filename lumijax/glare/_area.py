"""The luminous area a luminaire shows an eye: its opening projected on the plane across the
direction of view (m²), from the photometry's luminous dimensions (``LuminousOpening``).

Luminance toward the eye is ``L = I / A_p`` (cd/m²) and the source's solid angle
``ω = A_p / d²`` (sr), so a rating depends on ``A_p`` and an opening the file does not give
must be assumed: a point-source file is read as a sphere of ``POINT_DIAMETER_M``, with a
:class:`NoLuminousSizeWarning` naming the photometry.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..errors import LumijaxWarning

__all__ = ["POINT_DIAMETER_M", "EDGE_ON_FRACTION", "NoLuminousSizeWarning", "projected_area",
           "opening_size"]

#: Diameter (m) of the sphere a photometry without luminous dimensions is taken to be: 0.1 m,
#: the aperture of a small spot or a bare lamp in its reflector. Its area (π/4·0.01 m²) is the
#: one a point source shows from every side.
POINT_DIAMETER_M = 0.1

#: A flat opening seen edge on has no area but may still send light (a table's γ = 90° value):
#: its projected area is held at this fraction of its face (cos 87°) so that L = I/A stays
#: finite; the luminance of such a grazing view is then an upper bound.
EDGE_ON_FRACTION = 0.05


class NoLuminousSizeWarning(LumijaxWarning):
    """A photometry has no luminous dimensions: its glare was computed for a sphere of
    ``POINT_DIAMETER_M``."""


_FLAT = ("rectangle", "disk", "circle", "ellipse")


def opening_size(opening) -> float:
    """The largest extent (m) of an opening (``POINT_DIAMETER_M`` for a point): an eye closer
    than this to the luminaire's centre is inside or against it."""
    if opening.is_point:
        return POINT_DIAMETER_M
    return max(opening.length_m, opening.width_m, opening.height_m)


def projected_area(opening, local: Float[Array | np.ndarray, "... 3"],
                   xp=jnp) -> Float[Array | np.ndarray, "..."]:
    """Area (m²) of ``opening`` projected across the unit direction ``local`` (luminaire frame:
    photometric axis −z, C0 +x, C90 +y; docs/conventions.md), pure JAX and differentiable.
    ``xp=np`` on a host array: the same operations in numpy, in ``local``'s dtype, so the same
    bits as JAX's (each is one correctly rounded +, ×, |·|, max or √) without an eager kernel
    compiled per shape (the results' glare geometry compiled ~25 of them).

    Flat openings (``rectangle``, ``disk``/``circle``, ``ellipse``, facing −z): ``A |z|``;
    ``box``: ``LW|z| + WH|x| + LH|y|``; vertical cylinders: ``A_end |z| + D H √(1 − z²)``;
    horizontal cylinders: the end discs plus ``length × diameter × sin``; ``sphere``/
    ``ellipsoid``: ``π/4 × (mean diameter)²``; ``vertical_circle``/``vertical_ellipse``:
    ``π/4 W H |x|``. Flat faces are held at ``EDGE_ON_FRACTION`` of their area edge on.
    """
    x, y, z = local[..., 0], local[..., 1], local[..., 2]
    ax, ay, az = xp.abs(x), xp.abs(y), xp.abs(z)
    L, W, H = opening.length_m, opening.width_m, opening.height_m
    shape = opening.shape
    quarter_pi = math.pi / 4.0

    def side(c):  # √(1 − c²) with a finite gradient at |c| = 1
        return xp.sqrt(xp.maximum(1.0 - c * c, 1e-12))

    if opening.is_point:
        return xp.full(x.shape, quarter_pi * POINT_DIAMETER_M ** 2, local.dtype)
    if shape in _FLAT:
        face = L * W * (quarter_pi if shape != "rectangle" else 1.0)
        return face * xp.maximum(az, EDGE_ON_FRACTION)
    if shape == "box":
        area = L * W * az + W * H * ax + L * H * ay
        return xp.maximum(area, EDGE_ON_FRACTION * max(L * W, W * H, L * H))
    if shape in ("vertical_cylinder", "vertical_elliptical_cylinder"):
        return quarter_pi * L * W * az + 0.5 * (L + W) * H * side(z)
    if shape == "horizontal_cylinder_along":  # axis along x: diameter W (= H)
        return quarter_pi * W * H * ax + L * 0.5 * (W + H) * side(x)
    if shape == "horizontal_cylinder_across":  # axis along y
        return quarter_pi * L * H * ay + W * 0.5 * (L + H) * side(y)
    if shape in ("sphere", "ellipsoid"):
        d = (L + W + H) / 3.0
        return xp.full(x.shape, quarter_pi * d * d, local.dtype)
    if shape in ("vertical_circle", "vertical_ellipse"):
        return quarter_pi * W * H * xp.maximum(ax, EDGE_ON_FRACTION)
    # an opening of a shape not listed above: its bounding box
    area = L * W * az + W * H * ax + L * H * ay
    return xp.maximum(area, EDGE_ON_FRACTION * max(L * W, W * H, L * H, 1e-12))
