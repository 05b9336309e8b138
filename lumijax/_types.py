"""Shape-annotated array aliases used across lumijax (jaxtyping).

Axis names: ``points`` are calculation points, ``lum`` luminaires, ``tri`` triangles, ``patches``
radiosity patches, ``wl`` wavelength samples, ``net`` networks.
"""

from __future__ import annotations

from jaxtyping import Array, Bool, Float, Int

Vec3 = Float[Array, "3"]
Points = Float[Array, "points 3"]
Directions = Float[Array, "points 3"]
Normals = Float[Array, "points 3"]
Rotation = Float[Array, "3 3"]
Rotations = Float[Array, "lum 3 3"]
LuxMap = Float[Array, " points"]
Triangles = Float[Array, "tri 3 3"]
Mask = Bool[Array, "..."]
Index = Int[Array, "..."]

__all__ = [
    "Vec3",
    "Points",
    "Directions",
    "Normals",
    "Rotation",
    "Rotations",
    "LuxMap",
    "Triangles",
    "Mask",
    "Index",
]
