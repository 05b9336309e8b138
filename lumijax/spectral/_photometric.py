"""Photometric and colorimetric quantities of spectra.

All integrals are taken on the 1 nm grid 360–830 nm of the CIE tables, after evaluating each
:class:`~lumijax.spectral.Spectrum` by its own interpolation/extrapolation rules
(:meth:`Spectrum.at`). The observer is the CIE 1924 photopic V(λ) (= ȳ of the CIE 1931 2°
observer), taken from colour-science.
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import SpectrumError
from ._spectrum import Spectrum

__all__ = [
    "K_M",
    "photopic_v",
    "luminous_efficacy_weighting",
    "luminous_reflectance",
    "tristimulus",
    "xyz_of_illuminance",
]

#: Maximum luminous efficacy of photopic vision, lm/W (CIE; 683 lm/W at 540 THz).
K_M = 683.002

_CMFS = "CIE 1931 2 Degree Standard Observer"


@functools.cache
def _v_table() -> tuple[np.ndarray, np.ndarray]:
    from ._cie import observer_tables

    wl, v, _ = observer_tables()
    return wl, v


def photopic_v(wavelengths_nm: object) -> np.ndarray:
    """CIE 1924 photopic luminous efficiency V(λ) at ``wavelengths_nm`` (linear interpolation of
    the 1 nm table; 0 outside 360–830 nm). Dimensionless, peak 1 at 555 nm."""
    wl, v = _v_table()
    return np.interp(np.asarray(wavelengths_nm, dtype=np.float64), wl, v, left=0.0, right=0.0)


def luminous_efficacy_weighting(wavelengths_nm: object) -> np.ndarray:
    """Quadrature weights (lm per W/nm) that turn a sampled spectral quantity into a photometric one.

    For a spectral power ``P[i]`` in W/nm sampled at the strictly increasing ``wavelengths_nm``,
    ``weights @ P`` is the luminous flux in lm (``K_m ∫ V(λ) P(λ) dλ``, trapezoid rule, with
    ``K_m`` = :data:`K_M`). The same weights turn spectral irradiance (W/m²/nm) into lux. The
    ratio of two such sums (``weights @ (rho * S) / weights @ S``) is independent of ``K_m``.
    """
    x = np.asarray(wavelengths_nm, dtype=np.float64)
    if x.ndim != 1 or x.size < 2 or not np.all(np.isfinite(x)) or np.any(np.diff(x) <= 0):
        raise SpectrumError(
            "luminous_efficacy_weighting needs a 1-D, finite, strictly increasing wavelength "
            f"grid of at least 2 samples (nm), got {x!r}"
        )
    dx = np.diff(x)
    trap = np.zeros_like(x)
    trap[:-1] += dx / 2.0
    trap[1:] += dx / 2.0
    return K_M * photopic_v(x) * trap


def _require(spectrum: object, kind: str, what: str) -> Spectrum:
    if not isinstance(spectrum, Spectrum):
        raise SpectrumError(f"{what} must be a Spectrum, got {type(spectrum).__name__}")
    if spectrum.kind != kind:
        raise SpectrumError(
            f"{what} must be a{'n' if kind == 'emission' else ''} {kind} spectrum, "
            f"got a {spectrum.kind} spectrum",
            key=f"spectrum {spectrum.name!r}",
        )
    return spectrum


def luminous_reflectance(reflectance: Spectrum, illuminant: Spectrum) -> float:
    """The V(λ)-weighted mean reflectance under ``illuminant``: ∫ρ S V dλ / ∫S V dλ.

    This is the fraction of illuminance that a diffuse surface of this reflectance re-emits as
    exitance under that light (the "Y/100" of the surface colour). A flat (grey) reflectance
    gives its own value whatever the illuminant.
    """
    _require(reflectance, "reflectance", "reflectance")
    _require(illuminant, "emission", "illuminant")
    wl, v = _v_table()
    sv = illuminant.at(wl) * v
    den = float(np.sum(sv))
    if not den > 0.0:
        raise SpectrumError(
            "illuminant emits nothing the eye can see (zero where V(λ) > 0)",
            key=f"spectrum {illuminant.name!r}",
        )
    return float(np.sum(reflectance.at(wl) * sv) / den)


@functools.cache
def _cmfs():
    import colour

    return colour.MSDS_CMFS[_CMFS]


def _sd(values: np.ndarray, wl: np.ndarray, name: str):
    import colour

    return colour.SpectralDistribution(values, domain=wl, name=name)


def tristimulus(spectrum: Spectrum, illuminant: Spectrum | None = None) -> np.ndarray:
    """CIE 1931 2° XYZ of a spectrum, as a float64 array of 3, **relative**: Y is a ratio.

    * emission: normalised to Y = 1 (a spectrum sets colour only; its level comes from
      photometry). ``illuminant`` must be None.
    * reflectance: the surface colour under ``illuminant`` (default CIE D65), normalised so that
      the illuminant itself has Y = 1; Y is then :func:`luminous_reflectance`.
    """
    import colour

    if not isinstance(spectrum, Spectrum):
        raise SpectrumError(f"tristimulus needs a Spectrum, got {type(spectrum).__name__}")
    cmfs = _cmfs()
    wl = np.asarray(cmfs.wavelengths, dtype=np.float64)
    if spectrum.kind == "emission":
        if illuminant is not None:
            raise SpectrumError(
                "tristimulus of an emission spectrum takes no illuminant",
                key=f"spectrum {spectrum.name!r}",
            )
        xyz = colour.sd_to_XYZ(
            _sd(spectrum.at(wl), wl, spectrum.name), cmfs=cmfs, method="Integration"
        )
    else:
        if illuminant is None:
            illuminant = Spectrum.from_name("D65", "emission")
        _require(illuminant, "emission", "illuminant")
        xyz = colour.sd_to_XYZ(
            _sd(spectrum.at(wl), wl, spectrum.name),
            cmfs=cmfs,
            illuminant=_sd(illuminant.at(wl), wl, illuminant.name),
            method="Integration",
        )
        return np.asarray(xyz, dtype=np.float64) / 100.0
    xyz = np.asarray(xyz, dtype=np.float64)
    if not xyz[1] > 0.0:
        raise SpectrumError(
            "emission spectrum has no luminance (zero where V(λ) > 0)",
            key=f"spectrum {spectrum.name!r}",
        )
    return xyz / xyz[1]


def xyz_of_illuminance(spectrum: Spectrum, lux: object) -> np.ndarray:
    """Tristimulus XYZ of illuminance ``lux`` (lx, any shape) from a source of this spectrum.

    Y equals ``lux``; X and Z follow the source's chromaticity. Shape ``lux.shape + (3,)``.
    """
    _require(spectrum, "emission", "spectrum")
    e = np.asarray(lux, dtype=np.float64)
    return e[..., None] * tristimulus(spectrum)
