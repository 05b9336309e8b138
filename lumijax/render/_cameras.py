"""Cameras of the ray-traced pass: a pinhole (perspective) and fisheyes (angular, equisolid,
hemispherical), each mapping pixels to world rays and world directions back to pixels.

Pixels are addressed ``(row, col)`` from the top-left corner, a pixel's centre at ``+0.5``.
A fisheye image is square; its circle of radius ``size/2`` holds the field of view
``fov_deg`` (180° by default: a hemisphere), and pixels outside the circle have no ray.
Radiance's ``-vta`` is the angular (equidistant) fisheye, radius ∝ θ; ``-vth`` the
hemispherical one, radius ∝ sin θ (orthographic); ``equisolid`` is the equal-area lens,
radius ∝ 2 sin(θ/2), whose pixels all hold the same solid angle.
"""

from __future__ import annotations

import abc
from typing import Literal

import equinox as eqx
import numpy as np
from jaxtyping import Bool, Float

__all__ = ["AbstractCamera", "Perspective", "Fisheye", "FISHEYE_PROJECTIONS"]

#: The fisheye projections: radius in the image (0 at the centre, 1 at θ = fov/2) of a
#: direction θ off the axis.
FISHEYE_PROJECTIONS = ("equidistant", "equisolid", "hemispherical")


def _frame(position, target, up) -> np.ndarray:
    """Rows: right, up, forward (unit, world)."""
    f = np.asarray(target, np.float64) - np.asarray(position, np.float64)
    f = f / np.linalg.norm(f)
    r = np.cross(f, np.asarray(up, np.float64))
    if np.linalg.norm(r) < 1e-9:  # looking along ``up``: any right will do
        r = np.cross(f, [1.0, 0.0, 0.0] if abs(f[0]) < 0.9 else [0.0, 1.0, 0.0])
    r = r / np.linalg.norm(r)
    return np.stack([r, np.cross(r, f), f])


class AbstractCamera(eqx.Module):
    """An eye at ``position`` (m) looking at ``target`` (m), ``up`` the image's vertical."""

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    size: tuple[int, int] = (1280, 800)  # (width, height) px

    @property
    def basis(self) -> Float[np.ndarray, "3 3"]:
        """Rows right, up, forward (unit vectors, world)."""
        return _frame(self.position, self.target, self.up)

    @abc.abstractmethod
    def _local(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Camera-frame unit directions (right, up, forward components) of image coordinates
        ``x`` (right) and ``y`` (up) in units of half the height, and which exist."""

    @abc.abstractmethod
    def _image_xy(self, local) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Inverse of ``_local``: ``(x, y, inside)``."""

    def rays(self, rows: slice | None = None) -> tuple[Float[np.ndarray, "n 3"],
                                                      Bool[np.ndarray, " n"]]:
        """Unit world directions through the centres of the pixels of ``rows`` (all rows by
        default), row-major, and which pixels have a ray (a fisheye's corners have none)."""
        w, h = self.size
        r = np.arange(h)[rows if rows is not None else slice(None)]
        col, row = np.meshgrid(np.arange(w) + 0.5, r + 0.5)
        x = (col.ravel() - w / 2.0) / (h / 2.0)
        y = (h / 2.0 - row.ravel()) / (h / 2.0)
        local, ok = self._local(x, y)
        return local @ self.basis, ok

    def pixel(self, directions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(row, col, inside)`` (float pixel coordinates) of world ``directions`` seen from
        the camera."""
        d = np.asarray(directions, np.float64)
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        x, y, inside = self._image_xy(d @ self.basis.T)
        w, h = self.size
        col = w / 2.0 + x * h / 2.0
        row = h / 2.0 - y * h / 2.0
        inside = inside & (col >= 0) & (col < w) & (row >= 0) & (row < h)
        return row, col, inside

    @abc.abstractmethod
    def solid_angles(self) -> Float[np.ndarray, "h w"]:
        """Solid angle (sr) of each pixel (0 where it has no ray)."""


class Perspective(AbstractCamera):
    """A pinhole camera; ``fov_deg`` is the vertical field of view (as VTK's and the report's
    cameras)."""

    fov_deg: float = 50.0

    def _local(self, x, y):
        t = np.tan(np.radians(self.fov_deg) / 2.0)
        v = np.stack([x * t, y * t, np.ones_like(x)], axis=-1)
        return v / np.linalg.norm(v, axis=-1, keepdims=True), np.ones(len(x), bool)

    def _image_xy(self, local):
        t = np.tan(np.radians(self.fov_deg) / 2.0)
        z = local[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x, y = local[..., 0] / (z * t), local[..., 1] / (z * t)
        return x, y, z > 0

    def solid_angles(self):
        w, h = self.size
        d, _ = self.rays()
        t = np.tan(np.radians(self.fov_deg) / 2.0)
        pix = (2.0 * t / h) ** 2  # pixel area on the image plane at unit distance
        cos = d @ self.basis[2]
        return (pix * cos ** 3).reshape(h, w)


class Fisheye(AbstractCamera):
    """A fisheye lens of ``projection`` (:data:`FISHEYE_PROJECTIONS`) over ``fov_deg``
    (at most 360° for the angular one, 180° for the others); square images."""

    projection: Literal["equidistant", "equisolid", "hemispherical"] = "equidistant"
    fov_deg: float = 180.0

    def __check_init__(self):
        if self.projection not in FISHEYE_PROJECTIONS:
            raise ValueError(f"projection must be one of {FISHEYE_PROJECTIONS}")
        top = 360.0 if self.projection == "equidistant" else 180.0
        if not 0.0 < self.fov_deg <= top:
            raise ValueError(f"a {self.projection} fisheye covers at most {top:g}°")

    def _radius(self, theta):
        half = np.radians(self.fov_deg) / 2.0
        if self.projection == "equidistant":
            return theta / half
        if self.projection == "equisolid":
            return np.sin(theta / 2.0) / np.sin(half / 2.0)
        return np.sin(theta) / np.sin(half)

    def _theta(self, radius):
        half = np.radians(self.fov_deg) / 2.0
        if self.projection == "equidistant":
            return radius * half
        if self.projection == "equisolid":
            return 2.0 * np.arcsin(np.clip(radius * np.sin(half / 2.0), -1.0, 1.0))
        return np.arcsin(np.clip(radius * np.sin(half), -1.0, 1.0))

    def _local(self, x, y):
        # the circle of radius 1 (half the height) holds the field of view
        rad = np.hypot(x, y)
        ok = rad <= 1.0
        theta = self._theta(np.minimum(rad, 1.0))
        phi = np.arctan2(y, x)
        s = np.sin(theta)
        v = np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], axis=-1)
        return v, ok

    def _image_xy(self, local):
        theta = np.arccos(np.clip(local[..., 2], -1.0, 1.0))
        phi = np.arctan2(local[..., 1], local[..., 0])
        inside = theta <= np.radians(self.fov_deg) / 2.0 + 1e-12
        rad = self._radius(theta)
        return rad * np.cos(phi), rad * np.sin(phi), inside

    def solid_angles(self):
        # dΩ = sinθ dθ dφ and dA = r dr dφ in the image: Ω_pixel = sinθ (dθ/dr) / r · A_pixel,
        # evaluated at the pixel centre
        w, h = self.size
        col, row = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        x = (col - w / 2.0) / (h / 2.0)
        y = (h / 2.0 - row) / (h / 2.0)
        rad = np.hypot(x, y)
        eps = 1e-6
        r0 = np.maximum(rad, eps)
        dtheta = (self._theta(np.minimum(r0 + eps, 1.0)) - self._theta(np.maximum(r0 - eps,
                                                                                 0.0)))
        dr = np.minimum(r0 + eps, 1.0) - np.maximum(r0 - eps, 0.0)
        theta = self._theta(np.minimum(r0, 1.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            omega = np.where(rad > 1e-9, np.sin(theta) / r0, dtheta / dr) * (dtheta / dr)
        pix = (2.0 / h) ** 2
        return np.where(rad <= 1.0, omega * pix, 0.0)
