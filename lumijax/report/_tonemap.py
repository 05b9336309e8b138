"""Exposure and tone mapping of realistic views, in a photographer's terms.

Exposure is an exposure value at ISO 100 (EV100). A reflected-light meter with calibration
constant K = 12.5 reads EV100 = log2(L · S / K) for a luminance L (cd/m²) at S = 100; the
saturation-based sensor model then puts the largest unclipped luminance at
L_max = 1.2 · 2^EV100 cd/m² (ISO 12232). A pixel's linear value is L / L_max, so a surface
of the metered luminance lands at 1/9.6 ≈ 0.104 (a mid grey, 0.36 after the sRGB curve with
``tone="clip"``), and one EV more halves every linear value: a stop.

Tone curves (applied to linear sRGB after exposure, before the sRGB transfer function):

* ``"filmic"``: the ACES filmic fit of Narkowicz (2015), per channel,
  f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14), clipped to [0, 1]: a toe that keeps
  shadows dark and a shoulder that rolls highlights off instead of clipping them;
* ``"reinhard"``: Reinhard et al. (2002) with white point W = 4 on luminance,
  Y' = Y(1 + Y/W²)/(1 + Y), the colour scaled by Y'/Y (hue kept), then clipped;
* ``"clip"``: a linear camera: values above 1 clip to white.

:data:`TONE_CURVES` is the registry of these curves (colour-science's pattern), checked against
the schema's ``ToneCurveName`` at import: a new curve is one function and one registry line.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._registry import Registry
from ..config._schema import ToneCurveName
from ..errors import ConfigError, OutputError

__all__ = ["ev100", "exposure_scale", "auto_ev100", "tone_map", "Tone", "TONE_CURVES",
           "REINHARD_WHITE"]

Tone = ToneCurveName
#: Reflected-light meter calibration constant (cd·s/m², ISO 2720) and the film speed assumed.
K_METER = 12.5
ISO = 100.0
#: White point of the Reinhard curve, in units of the saturation luminance.
REINHARD_WHITE = 4.0


def ev100(luminance_cdm2: float) -> float:
    """EV100 a reflected-light meter reads for a uniform luminance (cd/m²)."""
    lum = float(luminance_cdm2)
    if not (np.isfinite(lum) and lum > 0):
        raise OutputError(f"metering needs a luminance > 0 cd/m², got {luminance_cdm2!r}")
    return float(np.log2(lum * ISO / K_METER))


def exposure_scale(ev: float) -> float:
    """Linear pixel value per cd/m² at exposure ``ev`` (EV100): 1 / (1.2 · 2^EV100)."""
    if not np.isfinite(ev):
        raise OutputError(f"exposure_ev must be a finite number, got {ev!r}", key="exposure_ev")
    return float(1.0 / (1.2 * 2.0**ev))


def auto_ev100(luminance, weights=None, quantile: float = 0.5) -> float:
    """EV100 metered on a (weighted) quantile of the luminance of the lit surfaces (L > 0):
    by default the median, not the mean, so that a few bright patches near a luminaire do not
    darken the whole picture. An unlit scene meters as 1 cd/m².
    """
    lum = np.asarray(luminance, np.float64).ravel()
    w = np.ones_like(lum) if weights is None else np.asarray(weights, np.float64).ravel()
    lit = (lum > 0) & np.isfinite(lum) & (w > 0)
    if not lit.any():
        return ev100(1.0)
    lum, w = lum[lit], w[lit]
    order = np.argsort(lum)
    cum = np.cumsum(w[order])
    i = min(int(np.searchsorted(cum, quantile * cum[-1])), len(cum) - 1)
    return ev100(lum[order][i])


def _filmic(rgb: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.clip(rgb * (2.51 * rgb + 0.03) / (rgb * (2.43 * rgb + 0.59) + 0.14), 0.0, 1.0)


def _reinhard(rgb: np.ndarray, y: np.ndarray) -> np.ndarray:
    y_new = y * (1.0 + y / REINHARD_WHITE**2) / (1.0 + y)
    ratio = np.divide(y_new, y, out=np.zeros_like(y), where=y > 0)
    return np.clip(rgb * ratio[..., None], 0.0, 1.0)


def _clip(rgb: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.clip(rgb, 0.0, 1.0)


#: ``tone`` name -> curve ``(exposed linear sRGB (..., 3), exposed luminance (...)) -> [0, 1]``.
TONE_CURVES: Registry[Callable[[np.ndarray, np.ndarray], np.ndarray]] = Registry(
    "tone", ToneCurveName, {"filmic": _filmic, "reinhard": _reinhard, "clip": _clip})


def tone_map(xyz_cdm2, ev: float, tone: Tone = "filmic") -> np.ndarray:
    """Display sRGB (encoded, in [0, 1], shape ``(..., 3)``) of luminance tristimulus values.

    ``xyz_cdm2`` is CIE 1931 XYZ with Y the luminance in cd/m². The colour goes through
    colour-science's XYZ → linear sRGB (IEC 61966-2-1, no chromatic adaptation: a warm lamp
    looks warm, as on daylight-balanced film), then exposure, the tone curve and the sRGB curve.
    """
    import colour

    try:
        curve = TONE_CURVES[tone]
    except ConfigError as e:  # not a config key here but an argument: the output's error
        raise OutputError(e.message, key="tone") from None
    a = np.asarray(xyz_cdm2, np.float64)
    scale = exposure_scale(ev)
    rgb = np.asarray(colour.XYZ_to_sRGB(a, apply_cctf_encoding=False), np.float64)
    rgb = curve(np.maximum(rgb, 0.0) * scale, np.maximum(a[..., 1] * scale, 0.0))
    return np.asarray(colour.cctf_encoding(rgb, function="sRGB"), np.float64)
