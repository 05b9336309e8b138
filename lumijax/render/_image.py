"""A traced picture: CIE XYZ per pixel with Y the luminance (cd/m²), and what glare work reads
from it (evalglare's way: sources are the pixels far brighter than the scene)."""

from __future__ import annotations

import equinox as eqx
import numpy as np
from jaxtyping import Bool, Float

from ._cameras import AbstractCamera

__all__ = ["LuminanceImage", "SOURCE_FACTOR", "RADIANCE_EFFICACY"]

#: lm/W Radiance converts radiance to luminance with (L = 179 × (0.265 R + 0.670 G + 0.065 B)).
RADIANCE_EFFICACY = 179.0

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

    def write_hdr(self, path) -> None:
        """Write the image as a Radiance picture (RGBE, ``VIEW=`` in the header, grey: each
        channel the luminance / 179), which evalglare and Radiance's tools read. A fisheye is
        written as ``-vta`` (equidistant) or ``-vth`` (hemispherical); an equisolid one has no
        Radiance view type and is refused."""
        from pathlib import Path

        from .._atomic import atomic_path
        from ._cameras import Fisheye

        cam = self.camera
        p, f, u = (np.asarray(v, np.float64) for v in (cam.position, cam.basis[2],
                                                        cam.basis[1]))
        w, h = cam.size
        if isinstance(cam, Fisheye):
            vt = {"equidistant": "-vta", "hemispherical": "-vth"}.get(cam.projection)
            if vt is None:
                raise ValueError("Radiance has no equisolid view type; trace -vta or -vth")
            vh = vv = cam.fov_deg
        else:
            vt, vv = "-vtv", cam.fov_deg
            vh = float(np.degrees(2 * np.arctan(np.tan(np.radians(vv) / 2) * w / h)))
        view = (f"VIEW= {vt} -vp {p[0]:.6g} {p[1]:.6g} {p[2]:.6g} -vd {f[0]:.6g} {f[1]:.6g} "
                f"{f[2]:.6g} -vu {u[0]:.6g} {u[1]:.6g} {u[2]:.6g} -vh {vh:.6g} -vv {vv:.6g}")
        head = (f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n{view}\n\n-Y {h} +X {w}\n").encode()
        v = np.maximum(self.luminance, 0.0) / RADIANCE_EFFICACY
        mant, expo = np.frexp(v)
        rgbe = np.zeros((h, w, 4), np.uint8)
        on = v > 1e-32
        m = np.clip(np.floor(mant * 256.0), 0, 255).astype(np.uint8)
        for c in range(3):
            rgbe[..., c] = np.where(on, m, 0)
        rgbe[..., 3] = np.where(on, expo + 128, 0).astype(np.uint8)
        with atomic_path(Path(path), what="Radiance picture", suffix=".hdr") as tmp:
            Path(tmp).write_bytes(head + rgbe.tobytes())

    def ugr(self, factor: float = SOURCE_FACTOR,
            threshold_cdm2: float | None = None) -> tuple[float, float]:
        """``(UGR, L_b)`` from the image as evalglare rates one: source pixels are those above
        ``factor`` × the image's average luminance (solid-angle weighted), each a source of its
        own solid angle ω and Guth position index p (``threshold_cdm2``: an absolute
        threshold instead, evalglare's ``-b``) (:func:`lumijax.glare.position_index`);
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
        cut = factor * average if threshold_cdm2 is None else threshold_cdm2
        src = ok & (lum > cut) & (omega > 0) & (cos > 0)
        rest = ok & ~src
        lb = float(np.sum(lum[rest] * cos[rest] * omega[rest]) / np.pi)
        if not src.any() or not lb > 0:
            return float("nan"), lb
        p = np.asarray(position_index(d[src], cam.basis[2], up=cam.basis[1]), np.float64)
        total = float(np.sum(lum[src] ** 2 * omega[src] / p ** 2))
        return float(ugr_of_sum(total, lb)), lb
