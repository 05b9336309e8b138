"""Cameras of realistic and false-colour views: from ``[cameras.NAME]`` or an automatic overview."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Camera", "cameras_of", "overview_camera"]


@dataclass(frozen=True)
class Camera:
    """A pinhole camera (m, degrees) and how its picture is drawn (see ``docs/report.md``)."""

    name: str
    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    fov_deg: float = 50.0
    kind: str = "realistic"
    quantity: str = "luminance"
    scale: str = "log"
    levels: tuple[float, ...] | None = None
    exposure_ev: float | None = None
    tone: str = "filmic"
    size: tuple[int, int] = (1280, 800)
    markers: bool = False

    @classmethod
    def from_config(cls, name: str, c) -> Camera:
        return cls(
            name=name, position=tuple(c.position), target=tuple(c.target), up=tuple(c.up),
            fov_deg=float(c.fov_deg), kind=c.kind, quantity=c.quantity, scale=c.scale,
            levels=None if c.levels is None else tuple(c.levels), exposure_ev=c.exposure_ev,
            tone=c.tone, size=tuple(c.size), markers=c.markers,
        )

    def replace(self, **changes) -> Camera:
        import dataclasses

        return dataclasses.replace(self, **changes)


def cameras_of(study) -> list[Camera]:
    """The study's ``[cameras]`` in config order, or one automatic overview when it has none."""
    cams = study.config.cameras
    if cams:
        return [Camera.from_config(name, c) for name, c in cams.items()]
    return [overview_camera(study.scene)]


def overview_camera(scene, size=(1280, 800), fov_deg: float = 50.0) -> Camera:
    """A view of the calculation grids (or of the whole scene without grids) from in front of
    and above them: along the grids' mean normal, lifted by about 25°, framing their bounding
    sphere. Back faces are culled when drawing, so a room seen from above is open like a
    doll's house."""
    if scene.grids:
        pts = np.concatenate([g.points for g in scene.grids])
        nrm = np.concatenate([g.normals for g in scene.grids]).mean(axis=0)
    else:
        pts = scene.triangles.vertices.reshape(-1, 3)
        nrm = np.array([0.0, -1.0, 0.0])
    lum = [lum.position for lum in scene.luminaires]
    box = np.concatenate([pts, np.asarray(lum).reshape(-1, 3)])
    lo, hi = box.min(axis=0), box.max(axis=0)
    centre = (lo + hi) / 2.0
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 0.5)
    n = nrm / np.linalg.norm(nrm) if np.linalg.norm(nrm) > 1e-9 else np.array([0.0, -1.0, 0.0])
    if abs(n[2]) > 0.9:  # grids facing up (a floor): look down at an angle, from the south-west
        d = n + np.array([-0.45, -0.75, 0.0])
    else:  # facades: stand in front of them, a little above
        d = n + np.array([0.0, 0.0, 0.45])
    d = d / np.linalg.norm(d)
    aspect = size[0] / size[1]
    half = np.radians(fov_deg) / 2.0
    half = min(half, np.arctan(np.tan(half) * aspect))
    dist = 1.08 * radius / np.sin(half)
    return Camera(name="overview", position=tuple(centre + dist * d), target=tuple(centre),
                  fov_deg=fov_deg, size=tuple(size))
