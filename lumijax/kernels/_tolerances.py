"""Geometric tolerances relative to the model, never absolute metres (docs/conventions.md,
"Tolerances"): one degeneracy rule for triangles, and the rounding floor of coordinates.

Plain numpy on the host (float64), shared by the scene's checks, meshing, partition, the
operator build and direct light, so that a 1 mm model and a model at site coordinates are
treated like a 1 m model at the origin.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Bool, Float

__all__ = ["DEGENERATE_ASPECT", "rounding_length", "length_tolerance", "triangle_shape"]

#: A triangle is degenerate when its height is below this fraction of its longest edge.
DEGENERATE_ASPECT = 2e-9

#: Float64 units in the last place a coordinate's rounding may reach in derived lengths.
_ROUNDING_ULPS = 64


def rounding_length(points) -> float:
    """The length (m) below which coordinates of this size cannot tell two points apart: a
    few float64 ulps of the largest coordinate. A model at site coordinates (5·10⁶ m north)
    carries ~10⁻⁹ m of rounding in every vertex; a test finer than that reads noise."""
    a = np.asarray(points, np.float64)
    big = float(np.max(np.abs(a))) if a.size else 0.0
    return _ROUNDING_ULPS * float(np.finfo(np.float64).eps) * big


def length_tolerance(points, relative: float = 1e-9) -> float:
    """A geometric tolerance (m) for ``points`` (any shape ``(..., 3)``): ``relative`` × the
    extent of their bounding box, and never below their coordinates' rounding
    (:func:`rounding_length`). Scale-invariant (a 1 mm model gets a 1000× smaller tolerance
    than a 1 m one) and translation-invariant: never an absolute number of metres."""
    a = np.asarray(points, np.float64).reshape(-1, 3)
    extent = float(np.max(np.ptp(a, axis=0))) if len(a) else 0.0
    return max(relative * extent, rounding_length(a), float(np.finfo(np.float64).tiny))


def triangle_shape(
    tri: Float[np.ndarray, "t 3 3"],
) -> tuple[Float[np.ndarray, " t"], Float[np.ndarray, " t"], Bool[np.ndarray, " t"]]:
    """``(area m², longest edge m, degenerate)`` of each triangle: the one rule, used by the
    scene's checks and by meshing alike (docs/conventions.md, "Tolerances").

    Degenerate: a non-finite vertex, or a height (2·area / longest edge) below
    ``DEGENERATE_ASPECT`` × the longest edge (no defined normal, whatever the model's unit),
    or below the rounding of the triangle's own coordinates (:func:`rounding_length`, per
    triangle: a 1 µm facet at 10⁷ m is noise).
    """
    tri = np.asarray(tri, np.float64)
    finite = np.all(np.isfinite(tri), axis=(1, 2))
    t = np.where(finite[:, None, None], tri, 0.0)
    e = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 1], t[:, 0] - t[:, 2]], axis=1)
    longest = np.linalg.norm(e, axis=-1).max(axis=1)
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    noise = _ROUNDING_ULPS * float(np.finfo(np.float64).eps) * np.abs(t).max(axis=(1, 2))
    height = 2.0 * area / np.where(longest > 0, longest, 1.0)
    degenerate = ~finite | (longest <= 0) | (height <= np.maximum(DEGENERATE_ASPECT * longest,
                                                                  noise))
    return area, longest, degenerate
