"""The light of a study's sensor grids (``kind = "sensor"``): the pipeline lights every grid
as planes; a cylindrical, semi-cylindrical or hemispherical grid's values are computed again
here with its sensor's response and replace them in the results (a ``vertical`` sensor is a
plane facing ``facing``, which the pipeline already computes)."""

from __future__ import annotations

import numpy as np

from ..direct import SensorResponse
from ..lighting import GATHER_RAYS
from ._sensors import SensorLight, sensor_light

__all__ = ["sensor_grids"]


def sensor_grids(study, lighting, *, rays: int | None = None,
                 shadows: bool = True) -> dict[str, SensorLight]:
    """Per non-planar sensor grid of ``study``: its :class:`SensorLight` in ``lighting``."""
    from ..scene._frames import resolve_group_frames

    cfg = study.config
    frames = None
    out: dict[str, SensorLight] = {}
    rays = rays if rays is not None else 2 * (cfg.solver.gather_rays or GATHER_RAYS)
    for g, built in zip(cfg.grids, study.scene.grids, strict=True):
        if g.kind != "sensor" or g.sensor == "vertical":
            continue
        axis = np.asarray(g.axis, np.float64)
        facing = None if g.facing is None else np.asarray(g.facing, np.float64)
        if g.group is not None:
            frames = frames if frames is not None else resolve_group_frames(cfg.groups)
            axis = frames[g.group].normals(axis)
            facing = None if facing is None else frames[g.group].normals(facing)
        resp = SensorResponse.uniform(g.sensor, len(built.points), axis=axis, facing=facing)
        out[g.name] = sensor_light(lighting, built.points, resp, rays=rays, shadows=shadows)
    return out
