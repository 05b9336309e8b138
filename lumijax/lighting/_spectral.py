"""The spectral set-up of a solve: sample wavelengths, per-patch reflectance there, and the
weights that turn a light source's sampled radiosity into lux and CIE XYZ.

The solve runs at the wavelengths of the paper's segmentation (``lumijax.spectral.segment``,
§5.2). Each light source's spectrum S gets its own weights (``for_emission``): a quantity
``S(λ)·g(λ)`` with g smooth (products of reflectances) has XYZ ``H_S @ g(λ_i)``-like sums that
integrate the emission lines exactly. The sampled spectrum is scaled so that its Y is 1: a
source's lux stays its photometric value whatever the spectrum, and inter-reflected light gets
the colour the materials give it.

``samples = 0`` is the photometric solve: one "wavelength" with the luminous (V(λ)-weighted)
reflectance, Y only.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from jaxtyping import Float

__all__ = ["SpectralSetup", "DEFAULT_EMISSION", "source_spectrum"]

DEFAULT_EMISSION = "E"
"""Spectrum of a luminaire that names none: CIE illuminant E (equal energy), a neutral white."""


def source_spectrum(spectrum):
    """A light source's spectrum, or the default one."""
    from ..spectral import Spectrum

    return spectrum if spectrum is not None else Spectrum.from_name(DEFAULT_EMISSION, "emission")


@dataclass(frozen=True, eq=False)
class SpectralSetup:
    """Wavelengths, reflectances and weights of one study's solve.

    Attributes
    ----------
    sampling
        The :class:`lumijax.spectral.SpectralSampling` (None for the photometric solve).
    rho
        ``(patches, W)`` reflectance at the sample wavelengths (W = 1 photometric).
    """

    sampling: object | None
    rho: Float[np.ndarray, "patches w"]

    @property
    def n(self) -> int:
        return self.rho.shape[1]

    @cached_property
    def _weights(self) -> dict:
        return {}

    def weights(self, spectrum) -> tuple[Float[np.ndarray, " w"], Float[np.ndarray, "3 w"]]:
        """``(s, H)`` for light of ``spectrum``: the sampled spectrum ``s`` scaled to Y = 1 lx,
        and ``H`` with ``XYZ = H @ x`` for any sampled quantity ``x = s·g``.

        Photometric solve: ``s = [1]`` and ``H = [[0], [1], [0]]`` (Y only).
        """
        if self.sampling is None:
            return np.ones(1), np.array([[0.0], [1.0], [0.0]])
        from ..spectral import photometric_normalisation

        spectrum = source_spectrum(spectrum)
        key = spectrum
        if key not in self._weights:
            samp = self.sampling.for_emission(spectrum)
            f = photometric_normalisation(spectrum, samp)
            s = f * np.asarray(spectrum.at(samp.wavelengths_nm), np.float64)
            self._weights[key] = (s, np.asarray(samp.weights_xyz, np.float64))
        return self._weights[key]

    @classmethod
    def build(cls, scene, patch_material, samples: int) -> SpectralSetup:
        """Segment the scene's own spectra into ``samples`` wavelengths (0: photometric)."""
        if samples == 0:
            rho = np.array([m.luminous_reflectance for m in scene.materials])[patch_material]
            return cls(None, rho[:, None])
        from ..spectral import segment

        emissions = list(dict.fromkeys(
            source_spectrum(s.spectrum) for s in (*scene.luminaires, *scene.area_sources)))
        reflectances = [m.reflectance for m in scene.materials]
        sampling = segment(emissions or [source_spectrum(None)], reflectances,
                           max_samples=samples)
        wl = np.asarray(sampling.wavelengths_nm)
        table = np.array([np.asarray(m.reflectance.at(wl), np.float64) for m in scene.materials])
        return cls(sampling, table[patch_material])
