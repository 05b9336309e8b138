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

The system is linear and the source spectrum enters B₀ only as a factor per wavelength:
``B(λ) = s(λ) · solve(ρ(λ) E)``. :func:`solve_spectral` solves ``ρ(λ) E`` and multiplies by
``s`` after, so the solve sees one column per (source group, distinct reflectance column) — a
grey material set needs one wavelength whatever the luminaires' spectra, and sources sharing
one direct light share its column (docs/radiosity.md, "Distinct columns").
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from jaxtyping import Float

from ..spectral import SpectralSampling, Spectrum

__all__ = ["SpectralSetup", "DEFAULT_EMISSION", "source_spectrum", "solve_spectral"]

DEFAULT_EMISSION = "E"
"""Spectrum of a luminaire that names none: CIE illuminant E (equal energy), a neutral white."""


def source_spectrum(spectrum: Spectrum | None) -> Spectrum:
    """A light source's spectrum, or the default one."""
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
    tau
        ``(patches, W)`` diffuse transmittance there (opal, frosted: ``kind = "diffuse"``; 0
        elsewhere, clear glass included), or None when no material transmits diffusely.
    """

    sampling: SpectralSampling | None
    rho: Float[np.ndarray, "patches w"]
    tau: Float[np.ndarray, "patches w"] | None = None

    def transmission(self, patches) -> tuple | None:
        """``(tau, partner)`` for :func:`solve_spectral` on these patches (None: no diffuse
        transmission): each transmitting patch's other face (``radiosity.back_partners``)."""
        if self.tau is None:
            return None
        from ..radiosity import back_partners

        return self.tau, back_partners(patches, self.tau.max(axis=1) > 0)

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
        diffuse = [m.diffuse_transmitting for m in scene.materials]
        if samples == 0:
            rho = np.array([m.luminous_reflectance for m in scene.materials])[patch_material]
            tau = np.array([m.tau if d else 0.0 for m, d in zip(scene.materials, diffuse)])
            return cls(None, rho[:, None], tau[patch_material][:, None] if any(diffuse) else None)
        from ..spectral import segment

        emissions = list(dict.fromkeys(
            source_spectrum(s.spectrum) for s in (*scene.luminaires, *scene.area_sources)))
        reflectances = [m.reflectance for m in scene.materials]
        sampling = segment(emissions or [source_spectrum(None)], reflectances,
                           max_samples=samples)
        wl = np.asarray(sampling.wavelengths_nm)
        table = np.array([np.asarray(m.reflectance.at(wl), np.float64) for m in scene.materials])
        if not any(diffuse):
            return cls(sampling, table[patch_material])
        tau = np.array([np.asarray(m.transmittance.at(wl), np.float64) if d else np.zeros(len(wl))
                        for m, d in zip(scene.materials, diffuse)])
        return cls(sampling, table[patch_material], tau[patch_material])


def solve_spectral(transport, rho, patch_direct, s, dtype, transmission=None, **solve):
    """Spectral radiosity of source groups: ``(B, solution)``.

    Parameters
    ----------
    transport
        The form factors (``radiosity.TransportOperator``).
    rho
        ``(patches, W)`` reflectance at the sample wavelengths (dimensionless).
    patch_direct
        ``(src, patches)`` direct illuminance on the patches (lx), one row per source group.
    s
        ``(src, W)`` each group's sampled spectrum, scaled to Y = 1 (:meth:`SpectralSetup.weights`).
    dtype
        The solve's precision.
    transmission
        ``(tau, partner)`` of :meth:`SpectralSetup.transmission` (None: none): τ ``(patches, W)``
        couples each diffusely transmitting patch to its other face, in B₀ = ρ E + τ E[partner]
        and in the operator.
    solve
        Passed on to :func:`lumijax.radiosity.solve_radiosity` (``solver``, ``rtol``,
        ``max_steps``).

    Returns
    -------
    ``B``, ``(patches, src, W)`` float64 radiosity (lm/m² per unit of Y), equal to the solve of
    ``ρ E s`` column by column (linearity), and the :class:`RadiositySolution` of the distinct
    columns (its ``escaped`` per (src, W); 0 where ``s`` is 0, as a column without light has).
    """
    import jax

    from .._jit_cache import to_device
    from ..radiosity import solve_radiosity

    # B₀ in numpy in the solve's precision (IEEE products, the same bits as JAX's): every eager
    # jnp op here would compile a kernel in each new process (docs/radiosity.md, "Caches")
    want = jax.dtypes.canonicalize_dtype(np.dtype(dtype))
    s = np.asarray(s, np.float64)
    rho_h = np.asarray(rho, want)  # (P, W)
    e = np.asarray(np.asarray(patch_direct, np.float64).T[:, :, None], want)  # (P, src, 1)
    b0 = rho_h[:, None, :] * e
    if transmission is not None:
        tau_h = np.asarray(transmission[0], want)[:, None, :]
        partner = np.asarray(transmission[1])
        b0 = b0 + tau_h * e[partner]
        solve = dict(solve, transmission=(to_device(tau_h), partner))
    res = solve_radiosity(transport, to_device(rho_h[:, None, :]), to_device(b0), **solve)
    b = np.asarray(res.value, np.float64) * s[None]
    res = _masked(res, s != 0)
    return b, res


def _masked(res, lit):
    """The solution's per-column flux fractions set to 0 where a column has no light (host
    values: ``res`` is a concrete solve's)."""
    from .._jit_cache import to_device
    from ..radiosity import RadiositySolution

    dt = res.escaped.dtype
    escaped = to_device(np.where(lit, np.asarray(res.escaped), 0.0).astype(dt))
    created = to_device(np.where(lit, np.asarray(res.stats["created"]), 0.0).astype(dt))
    return RadiositySolution(res.value, res.iterations, res.residual, res.result, escaped,
                             dict(res.stats, created=created))
