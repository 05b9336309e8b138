"""Colorimetry of results (per patch, per grid point): chromaticity, CCT, sRGB.

They take XYZ arrays of any shape ``(..., 3)`` and never return NaN: where Y (or X+Y+Z) is zero
the documented fallback applies. All three are computed from lumijax's own CIE tables and
formulas (``_cie``): the results path does not import colour-science (seconds per process).
"""

from __future__ import annotations

import numpy as np

from ..errors import SpectrumError
from ._cie import srgb_encode, uv_to_cct_ohno2013, xy_to_uv, xyz_to_linear_srgb

__all__ = ["xyz_to_chromaticity", "cct_from_xyz", "xyz_to_srgb"]

#: D65 white chromaticity, the fallback chromaticity of black (X+Y+Z = 0).
_D65_XY = (0.3127, 0.3290)


def _xyz(xyz: object) -> np.ndarray:
    a = np.asarray(xyz, dtype=np.float64)
    if a.ndim < 1 or a.shape[-1] != 3 or not np.all(np.isfinite(a)):
        raise SpectrumError(f"XYZ must be finite with a last axis of 3, got shape {a.shape}")
    return a


def xyz_to_chromaticity(xyz: object) -> np.ndarray:
    """CIE 1931 xy of XYZ, shape ``(..., 2)``. Black (X+Y+Z = 0) gets the D65 white point
    (0.3127, 0.3290), never NaN."""
    a = _xyz(xyz)
    s = a.sum(axis=-1)
    dark = ~(s > 0.0)
    safe = np.where(dark[..., None], np.array([0.95047, 1.0, 1.08883]), a)
    xy = safe[..., :2] / safe.sum(axis=-1, keepdims=True)
    return np.where(dark[..., None], np.array(_D65_XY), xy)


def cct_from_xyz(xyz: object) -> np.ndarray:
    """Correlated colour temperature (K) of XYZ by Ohno (2013), shape ``(...)``, as
    colour-science's ``XYZ_to_CCT(method="Ohno 2013")`` computes it (``_cie``; the same to 1e-10
    relative over 1600–25000 K, |Duv| ≤ 0.02). Where Y ≤ 0 (no light) the result is **0** (not
    NaN). Far from the Planckian locus the CCT is formally defined but means little; check Duv
    with colour if it matters."""
    a = _xyz(xyz)
    dark = ~(a[..., 1] > 0.0) | ~(a.sum(axis=-1) > 0.0)
    safe = np.where(dark[..., None], np.array([0.95047, 1.0, 1.08883]), a)
    uv = xy_to_uv(safe[..., :2] / safe.sum(axis=-1, keepdims=True))
    cct = uv_to_cct_ohno2013(uv)
    return np.where(dark, 0.0, cct)


def xyz_to_srgb(xyz: object, exposure: float = 1.0, *, encode: bool = True) -> np.ndarray:
    """Display sRGB of XYZ for images: ``exposure · XYZ`` (Y = 1 is diffuse white) through
    XYZ → sRGB (IEC 61966-2-1 matrix, no chromatic adaptation; colour-science's numbers to
    1e-12, ``_cie``), clipped to [0, 1], then the sRGB transfer function if ``encode``.
    Shape ``(..., 3)``."""
    a = _xyz(xyz)
    e = float(exposure)
    if not np.isfinite(e) or e < 0.0:
        raise SpectrumError(f"exposure must be a finite number >= 0, got {exposure!r}")
    rgb = np.clip(xyz_to_linear_srgb(a * e), 0.0, 1.0)
    if encode:
        rgb = srgb_encode(rgb)
    return rgb
