"""A traced picture: CIE XYZ per pixel with Y the luminance (cd/m²), and what glare work reads
from it (evalglare's way: sources are the pixels far brighter than the scene)."""

from __future__ import annotations

import equinox as eqx
import numpy as np
from jaxtyping import Bool, Float

from ._cameras import AbstractCamera

__all__ = ["LuminanceImage", "SOURCE_FACTOR"]

#: A pixel brighter than this multiple of the image's average luminance (solid-angle weighted)
#: is a glare source: evalglare's default source threshold (5 × the average luminance).
SOURCE_FACTOR = 5.0


class LuminanceImage(eqx.Module):
    """``xyz`` (H, W, 3): CIE 1931 XYZ per pixel, Y in cd/m²; ``camera`` the view it was
    traced from; ``hit`` (H, W) whether the pixel's ray met a surface or a source (False:
    the sky, or outside a fisheye's circle)."""

    xyz: Float[np.ndarray, "h w 3"]
    camera: AbstractCamera
    hit: Bool[np.ndarray, "h w"] | None = None

    @property
    def luminance(self) -> Float[np.ndarray, "h w"]:
        """Luminance per pixel, cd/m²."""
        return self.xyz[..., 1]

    def illuminance(self) -> float:
        """Vertical illuminance at the eye (lx) across the line of sight: Σ L cos θ Ω over the
        pixels (meaningful for a fisheye covering the hemisphere)."""
        d, ok = self.camera.rays()
        cos = np.maximum(d @ self.camera.basis[2], 0.0)
        omega = self.camera.solid_angles().ravel()
        return float(np.sum(self.luminance.ravel() * cos * omega * ok))

    def ugr(self, factor: float = SOURCE_FACTOR) -> tuple[float, float]:
        """``(UGR, L_b)`` from the image as evalglare rates one: source pixels are those above
        ``factor`` × the image's average luminance (solid-angle weighted), each a source of its
        own solid angle ω and Guth position index p (:func:`lumijax.glare.position_index`);
        ``L_b`` (cd/m²) is CIE 117's background, the illuminance the other pixels give the eye
        across the line of sight over π (so a hemispherical fisheye is what it needs);
        UGR through :func:`lumijax.glare._ratings.ugr_of_sum`, the ratings' own formula.
        NaN where no pixel is a source or the background is black."""
        from ..glare import position_index
        from ..glare._ratings import ugr_of_sum

        cam = self.camera
        d, ok = cam.rays()
        omega = cam.solid_angles().ravel()
        lum = self.luminance.ravel()
        cos = np.maximum(d @ cam.basis[2], 0.0)
        w = omega * ok
        if not w.sum() > 0:
            return float("nan"), 0.0
        average = float(np.sum(lum * w) / w.sum())
        src = ok & (lum > factor * average) & (omega > 0) & (cos > 0)
        rest = ok & ~src
        lb = float(np.sum(lum[rest] * cos[rest] * omega[rest]) / np.pi)
        if not src.any() or not lb > 0:
            return float("nan"), lb
        p = np.asarray(position_index(d[src], cam.basis[2], up=cam.basis[1]), np.float64)
        total = float(np.sum(lum[src] ** 2 * omega[src] / p ** 2))
        return float(ugr_of_sum(total, lb)), lb
