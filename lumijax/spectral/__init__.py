"""Spectral distributions as first-class objects.

:class:`Spectrum` holds a validated, immutable sampled spectrum (emission or reflectance) and
knows how to evaluate itself between and beyond its samples. Named spectra, CIE colorimetry and
V(λ) come from colour-science, the one bridge to colorimetry; nothing here re-implements it.

Modules: ``_spectrum`` (the object and its validation), ``_names`` (colour-science spectra by
name), ``_csv`` (file format), ``_photometric`` (V(λ)-weighted quantities). See
``docs/spectra.md``.
"""

from ._colorimetry import cct_from_xyz, xyz_to_chromaticity, xyz_to_srgb
from ._names import available_names
from ._photometric import (
    K_M,
    luminous_efficacy_weighting,
    luminous_reflectance,
    photopic_v,
    tristimulus,
    xyz_of_illuminance,
)
from ._sampling import (
    SpectralSampling,
    gauss_sampling,
    photometric_normalisation,
    reference_grid,
    segment,
    uniform_sampling,
)
from ._spectrum import KINDS, MAX_EXTRAPOLATION_NM, VISIBLE_NM, Kind, Spectrum

__all__ = [
    "Spectrum",
    "Kind",
    "KINDS",
    "VISIBLE_NM",
    "MAX_EXTRAPOLATION_NM",
    "available_names",
    "K_M",
    "photopic_v",
    "luminous_efficacy_weighting",
    "luminous_reflectance",
    "tristimulus",
    "xyz_of_illuminance",
    "SpectralSampling",
    "segment",
    "uniform_sampling",
    "gauss_sampling",
    "photometric_normalisation",
    "reference_grid",
    "xyz_to_chromaticity",
    "cct_from_xyz",
    "xyz_to_srgb",
]
