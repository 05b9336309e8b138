"""Observers in world space: an eye and its lines of sight, built from ``[[observers]]``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Float

from ..errors import ConfigError, GeometryError
from ..scene._frames import Frame, resolve_group_frames

__all__ = ["Observer", "build_observers"]


@dataclass(frozen=True)
class Observer:
    """An eye (m, world) and its unit lines of sight (world), one per fan direction.

    ``azimuths_deg`` are the fan's turns of the configured line of sight (``(0,)`` without a
    fan); ``road_luminance_cdm2``/``road_grid`` give the road's average luminance for TI;
    ``key`` names the config table (``observers[2]``) errors point at.
    """

    name: str
    eye: Float[np.ndarray, "3"]
    directions: Float[np.ndarray, "dirs 3"]
    azimuths_deg: tuple[float, ...] = (0.0,)
    road_luminance_cdm2: float | None = None
    road_grid: str | None = None
    key: str = ""

    def __post_init__(self) -> None:
        d = np.asarray(self.directions, np.float64).reshape(-1, 3)
        n = np.linalg.norm(d, axis=1)
        if not len(d) or not np.all(n > 0):
            raise ConfigError("an observer needs at least one non-zero line of sight",
                              key=f"{self.key}.direction" if self.key else "observer")
        object.__setattr__(self, "directions", d / n[:, None])
        object.__setattr__(self, "eye", np.asarray(self.eye, np.float64).reshape(3))

    @classmethod
    def looking(cls, name: str, eye, direction=None, *, look_at=None, fan_deg=(0.0,),
                **kwargs) -> Observer:
        """An observer at ``eye`` looking along ``direction`` (or at ``look_at``), turned about
        the vertical by each of ``fan_deg`` (degrees, counter-clockwise from above)."""
        eye = np.asarray(eye, np.float64)
        key = kwargs.get("key", "")
        if (direction is None) == (look_at is None):
            raise ConfigError("give exactly one of 'direction' or 'look_at'", key=key or name)
        d = np.asarray(direction if direction is not None else np.asarray(look_at) - eye,
                       np.float64)
        if not np.linalg.norm(d) > 0:
            raise ConfigError("the line of sight is the zero vector", key=key or name)
        fan = tuple(float(a) for a in fan_deg)
        if not fan:
            raise ConfigError("a fan with no directions", key=key or name)
        return cls(name, eye, _turned(d, fan), fan, **kwargs)


def _turned(d: np.ndarray, azimuths_deg) -> np.ndarray:
    """``d`` turned about the world vertical by each angle (deg)."""
    a = np.radians(np.asarray(azimuths_deg, np.float64))
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * d[0] - s * d[1], s * d[0] + c * d[1], np.full_like(a, d[2])], axis=1)


def build_observers(cfg, scene=None) -> tuple[Observer, ...]:
    """The config's ``[[observers]]`` in world space (group frames applied). With ``scene``,
    an eye inside a closed solid is refused (GeometryError naming the observer's key)."""
    frames = resolve_group_frames(cfg.groups)
    out = []
    for i, o in enumerate(cfg.observers):
        key = f"observers[{i}]"
        frame = Frame.identity() if o.group is None else frames[o.group]
        eye = frame.points(np.asarray(o.position, np.float64))
        if o.direction is not None:
            d = frame.vectors(np.asarray(o.direction, np.float64))
            look = None
        else:
            d, look = None, frame.points(np.asarray(o.look_at, np.float64))
        fan = (0.0,) if o.fan is None else tuple(o.fan.offsets_deg())
        out.append(Observer.looking(o.name, eye, d, look_at=look, fan_deg=fan,
                                    road_luminance_cdm2=o.road_luminance_cdm2,
                                    road_grid=o.road_grid, key=key))
    if scene is not None:
        check_outside_solids(out, scene, cfg.source)
    return tuple(out)


def check_outside_solids(observers, scene, source=None) -> None:
    """An eye inside a closed solid (a column, a closed box) sees nothing: a placement error."""
    tri = scene.triangles
    closed = np.flatnonzero(tri.closed)
    if not len(closed) or not observers:
        return
    import trimesh

    eyes = np.array([o.eye for o in observers])
    for item in closed:
        v = tri.vertices[tri.item == item].reshape(-1, 3)
        mesh = trimesh.Trimesh(v, np.arange(len(v)).reshape(-1, 3), process=True)
        lo, hi = mesh.bounds
        cand = np.flatnonzero(np.all((eyes > lo) & (eyes < hi), axis=1))
        if not len(cand):
            continue
        inside = mesh.contains(eyes[cand])
        if inside.any():
            o = observers[cand[int(np.argmax(inside))]]
            raise GeometryError(
                f"observer {o.name!r}'s eye at {np.round(o.eye, 4).tolist()} is inside the "
                f"closed solid geometry[{item}]: it would see nothing. Move it outside",
                file=source, key=f"{o.key}.position" if o.key else o.name)
