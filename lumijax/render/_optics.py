"""What the view pass needs of each material beyond its radiosity: specular reflectance and its
Ward roughness, transmittance and how it passes light, as per-material arrays.

Colours are carried as CIE XYZ (Y in cd/m²), like the radiosity the views draw, so a spectral
factor (a specular reflectance, a transmittance) becomes three channel factors: the
material's tristimulus under D65 divided by D65's own, which is exactly ρ for a grey and the
surface's colour otherwise (the product of two spectra is approximated channel by channel —
the usual RGB-renderer approximation, exact for grey factors).
"""

from __future__ import annotations

import equinox as eqx
import numpy as np
from jaxtyping import Bool, Float

__all__ = ["Optics", "optics_of", "MIRROR_ROUGHNESS"]

#: Below this Ward α (rms slope) a specular reflection is traced as one ideal mirror ray;
#: above it the lobe is sampled. At α = 0.01 the lobe's half-width is ~0.6°: a few pixels of
#: a 1080-line view at 50°, where sampling would add noise without changing the picture.
MIRROR_ROUGHNESS = 0.01

_D65_XYZ = np.array([0.95047, 1.0, 1.08883])


def _channels(spectrum) -> np.ndarray:
    from ..spectral import tristimulus

    return np.asarray(tristimulus(spectrum), np.float64) / _D65_XYZ


class Optics(eqx.Module):
    """Per material (the scene's material order): ``specular`` (M, 3) XYZ channel factors of
    the specular reflectance, ``roughness`` (M,) Ward α, ``transmittance`` (M, 3) at normal
    incidence and ``tau`` (M,) its luminous value, ``clear`` (M,) straight-through transmission, ``diffuse`` (M,) Lambertian
    transmission (the far side's radiosity is what is seen)."""

    specular: Float[np.ndarray, "m 3"]
    roughness: Float[np.ndarray, " m"]
    transmittance: Float[np.ndarray, "m 3"]
    tau: Float[np.ndarray, " m"]
    clear: Bool[np.ndarray, " m"]
    diffuse: Bool[np.ndarray, " m"]

    @classmethod
    def lambertian(cls, n: int) -> Optics:
        """``n`` opaque diffuse materials (what every material was before issue 18)."""
        z = np.zeros((n, 3))
        return cls(z, np.full(n, 0.05), z.copy(), np.zeros(n), np.zeros(n, bool),
                   np.zeros(n, bool))

    @property
    def two_sided(self) -> Bool[np.ndarray, " m"]:
        """Materials seen from both sides (light passes through them)."""
        return self.clear | self.diffuse

    @property
    def any_specular(self) -> bool:
        """Whether any material needs the traced pass (a raster of the radiosity shows the
        rest exactly)."""
        return bool(np.any(self.specular > 0) or np.any(self.clear))


def optics_of(materials) -> Optics:
    """The :class:`Optics` of scene :class:`~lumijax.scene.Material` records."""
    n = len(materials)
    out = Optics.lambertian(n)
    for i, m in enumerate(materials):
        if m.specular is not None and m.rho_s > 0:
            out.specular[i] = _channels(m.specular)
            out.roughness[i] = m.roughness
        if m.transmittance is not None and m.tau > 0:
            out.transmittance[i] = _channels(m.transmittance)
            out.tau[i] = m.tau
            out.clear[i] = m.clear
            out.diffuse[i] = m.diffuse_transmitting
    return out
