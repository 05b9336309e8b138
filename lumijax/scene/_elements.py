"""The scene's elements: materials, luminaires, area sources, networks and calculation grids.

Plain frozen records in world space and SI units, built once from a config; the JAX kernels take
their arrays. A luminaire keeps its aim angles (not only a rotation matrix) because aims are what
a designer edits and what the optimiser varies.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from .. import _dimmers
from ._frames import aim_rotation

if TYPE_CHECKING:
    from ..spectral import Spectrum

__all__ = ["Material", "Luminaire", "AreaSource", "Network", "Grid"]


@dataclass(frozen=True)
class Material:
    """A surface material: diffuse reflectance, and optionally specular reflection and transmission.

    Every spectrum is a dimensionless fraction per wavelength (kind ``"reflectance"``), and each
    luminous scalar is its V(λ)-weighted mean under an equal-energy illuminant (photopic, like
    ``luminous_reflectance``). Per wavelength ρ_d + ρ_s + τ ≤ 1 (checked when built).

    ``reflectance`` / ``luminous_reflectance`` (``rho``): the Lambertian part, what the
    radiosity carries. ``specular`` / ``rho_s``: the specular reflectance of the Ward model
    (paper eq. 5) with isotropic ``roughness`` α (rms facet slope, dimensionless, > 0; 0.05 by
    default), for the view pass; the radiosity leaves it out (docs/materials.md).
    ``transmittance`` / ``tau``: the fraction passed through the surface. ``kind`` says how:
    ``"diffuse"`` (opal, frosted: leaves the far side Lambertian, both sides coupled in the
    radiosity) or ``"clear"`` (thin glass: straight through; ``transmittance`` is the value at
    normal incidence, and the angle dependence is the thin pane's Fresnel loss with n = 1.52,
    ``lumijax.direct.glass_transmittance``). ``None`` without transmission.
    """

    name: str
    reflectance: Spectrum
    luminous_reflectance: float
    specular: Spectrum | None = None
    roughness: float = 0.05
    transmittance: Spectrum | None = None
    kind: str | None = None
    rho_s: float = 0.0
    tau: float = 0.0

    @property
    def rho(self) -> float:
        """The luminous diffuse reflectance (same as ``luminous_reflectance``)."""
        return self.luminous_reflectance

    @property
    def clear(self) -> bool:
        """Whether light passes straight through (clear glass)."""
        return self.kind == "clear" and self.tau > 0.0

    @property
    def diffuse_transmitting(self) -> bool:
        """Whether light passes through and leaves the far side Lambertian (opal, frosted)."""
        return self.kind == "diffuse" and self.tau > 0.0


@dataclass(frozen=True)
class Luminaire:
    """A luminaire with a candela distribution, placed and aimed in world space.

    ``tilt``, ``pan`` and ``spin`` (degrees) are the aim in the luminaire's group frame;
    ``frame_rotation`` turns that frame into world (identity without a group).
    ``scale`` multiplies the photometry's candela: multiplier × maintenance factor × TILT factor.
    """

    name: str
    photometry: str
    position: Float[np.ndarray, "3"]
    tilt: float
    pan: float
    spin: float
    network: str
    scale: float = 1.0
    frame_rotation: Float[np.ndarray, "3 3"] = field(default_factory=lambda: np.eye(3))
    spectrum: Spectrum | None = None
    config_index: int = -1

    @functools.cached_property
    def rotation(self) -> Float[np.ndarray, "3 3"]:
        """World rotation ``frame_rotation · Rz(pan) · Ry(−tilt) · Rz(spin)`` (read-only).

        Computed once per luminaire (a frozen record: a new aim is a new luminaire), since the
        direct light asks for it once per luminaire and chunk of receivers: 3,000 luminaires
        × hundreds of chunks at the courtyard's scale."""
        r = self.frame_rotation @ aim_rotation(*np.radians([self.tilt, self.pan, self.spin]),
                                               xp=np)
        r.setflags(write=False)
        return r

    @property
    def axis(self) -> Float[np.ndarray, "3"]:
        """World direction of the photometric axis (γ = 0)."""
        return self.rotation @ np.array([0.0, 0.0, -1.0])


@dataclass(frozen=True)
class AreaSource:
    """A Lambertian emitting rectangle ``origin + s·u + t·v`` (s, t ∈ [0, 1]), front along u × v.

    Its exitance is ``flux_lm × maintenance_factor / area`` (lm/m²), uniform, and its
    luminance that divided by π (cd/m²).
    """

    name: str
    origin: Float[np.ndarray, "3"]
    u: Float[np.ndarray, "3"]
    v: Float[np.ndarray, "3"]
    flux_lm: float
    network: str
    maintenance_factor: float = 1.0
    spectrum: Spectrum | None = None
    config_index: int = -1

    @property
    def normal(self) -> Float[np.ndarray, "3"]:
        n = np.cross(self.u, self.v)
        return n / np.linalg.norm(n)

    @property
    def area(self) -> float:
        return float(np.linalg.norm(np.cross(self.u, self.v)))

    @property
    def exitance(self) -> float:
        """Luminous exitance M = Φ·MF / A (lm/m²)."""
        return self.flux_lm * self.maintenance_factor / self.area


@dataclass(frozen=True)
class Network:
    """A dimmer circuit: its luminaires' light scales linearly with ``dimmer`` ∈ [0, 1]."""

    name: str
    dimmer: float = _dimmers.DEFAULT
    description: str = ""


@dataclass(frozen=True)
class Grid:
    """Calculation points with the normal of the plane each measures illuminance on.

    ``shape = (nu, nv)`` for plane grids: point ``i_u * nv + i_v`` lies at the centre of cell
    ``(i_u, i_v)``, i.e. at ``origin + (i_u + ½)/nu · u + (i_v + ½)/nv · v``.
    """

    name: str
    points: Float[np.ndarray, "points 3"]
    normals: Float[np.ndarray, "points 3"]
    shape: tuple[int, int] | None = None
    origin: Float[np.ndarray, "3"] | None = None
    u: Float[np.ndarray, "3"] | None = None
    v: Float[np.ndarray, "3"] | None = None
    target_lux: float | None = None

    def __len__(self) -> int:
        return len(self.points)


def plane_grid_points(origin, u, v, nu: int, nv: int) -> Float[np.ndarray, "points 3"]:
    """Cell-centred points of a plane grid in the order documented on :class:`Grid`."""
    o, u, v = (np.asarray(a, np.float64) for a in (origin, u, v))
    su = (np.arange(nu) + 0.5) / nu
    sv = (np.arange(nv) + 0.5) / nv
    return (o + su[:, None, None] * u + sv[None, :, None] * v).reshape(-1, 3)
