"""Two-sided surfaces for diffuse transmission (opal, frosted): a back face per front triangle.

Every lumijax surface is one-sided (its front along the right-hand rule). A surface whose
material transmits diffusely (``kind = "diffuse"``) must receive and emit on both sides, so
each of its triangles gets a copy with the opposite orientation, set back by
:data:`BACK_OFFSET` × the scene's extent behind the front one. The offset (ten times the ray
nudge of ``RayCaster``) is what lets a ray arriving from behind meet the back face first, and a
ray from the front the front face, instead of whichever of two coincident triangles Embree
returns. The radiosity couples the two sides (``lumijax.radiosity.back_partners``).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from ._geometry import Triangles

__all__ = ["BACK_OFFSET", "two_sided"]

BACK_OFFSET = 1e-4
"""Back face set-back as a fraction of the scene's largest bounding-box side (1 mm in 10 m)."""


def two_sided(triangles: Triangles, materials, src) -> Triangles:
    """``triangles`` with a back face appended for each diffusely transmitting triangle.

    A transmitting material (clear or diffuse) on a closed solid (an outward box or a watertight
    mesh facing out) whose interior holds no other geometry is refused: the light would pass
    into an interior the model says is solid, with nothing there to receive it (``ConfigError``
    naming the geometry item and the material). "Holds" is judged by the solid's bounding box:
    a centroid of another item's triangle strictly inside it (a glass showcase with its
    exhibit) makes it a legitimate enclosure.
    """
    if not len(triangles):
        return triangles
    tau = np.array([m.tau > 0 for m in materials], bool)
    diffuse = np.array([m.diffuse_transmitting for m in materials], bool)
    centroid = triangles.vertices.mean(axis=1)
    for i in np.flatnonzero(triangles.closed):
        mine = triangles.item == i
        bad = [materials[k].name for k in np.unique(triangles.material[mine]) if tau[k]]
        if not bad:
            continue
        corners = triangles.vertices[mine].reshape(-1, 3)
        lo, hi = corners.min(0), corners.max(0)
        inside = np.all((centroid[~mine] > lo) & (centroid[~mine] < hi), axis=1)
        if not inside.any():
            raise ConfigError(
                f"material '{bad[0]}' transmits light, but this geometry is a closed solid "
                "(an outward box or a watertight mesh) with nothing inside it: the light would "
                "pass into an interior that is not in the model; expected an open surface (a "
                "rectangle, an inward box, an open mesh, or flip_normals) for a pane or panel",
                file=src, key=f"geometry[{i}].material")
    back = diffuse[triangles.material]
    if not back.any():
        return triangles
    extent = float(np.max(triangles.bounds[1] - triangles.bounds[0]))
    flipped = triangles.vertices[back][:, ::-1] - BACK_OFFSET * extent * (
        triangles.normals[back][:, None, :])
    return Triangles(
        vertices=np.concatenate([triangles.vertices, flipped]),
        item=np.concatenate([triangles.item, triangles.item[back]]),
        material=np.concatenate([triangles.material, triangles.material[back]]),
        group=np.concatenate([triangles.group, triangles.group[back]]),
        closed=triangles.closed,
    )
