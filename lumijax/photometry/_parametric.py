"""Built-in photometry and the parametric luminaire model (redistributable, no vendor data).

Every generator samples a smooth model onto a Type C table and then scales the table so that its
exact flux (the same integral as :meth:`CandelaDistribution.flux`) equals the requested flux.

The beam profile is a generalised Gaussian in the angle θ from the beam axis::

    I(θ) = I0 · exp(−ln 2 · (θ / θ_b)^p)

with θ_b the half beam angle (``I = I0/2`` at θ_b, i.e. ``beam_deg = 2 θ_b`` is the full angle at
half peak, the usual "beam angle") and ``p`` fixed by the field angle (``I = I0/10``):
``p = ln(ln 10 / ln 2) / ln(θ_f / θ_b)``; ``p = 2`` (a Gaussian) when no field angle is given, for
which ``θ_f = 1.82 θ_b``. Elliptical beams use an angle-dependent half angle
``θ_b(C) = (cos²C / a² + sin²C / b²)^(−1/2)`` with ``a`` the half beam in the C0 plane and ``b``
in the C90 plane.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import PhotometryError
from ._distribution import CandelaDistribution
from ._opening import LuminousOpening
from ._photometry import Photometry, integrate_np

__all__ = ["isotropic", "lambertian", "spot", "flood", "linear_washer"]

_LN2 = math.log(2.0)
_FIELD_RATIO = math.log(10.0) / _LN2  # (θ_f/θ_b)^p at the 10 % field angle


def _check_flux(flux_lm: float) -> float:
    flux_lm = float(flux_lm)
    if not (flux_lm > 0 and math.isfinite(flux_lm)):
        raise ValueError(f"flux_lm must be a positive number of lumens, got {flux_lm!r}")
    return flux_lm


def _check_beam(name: str, deg: float, hi: float = 179.0) -> float:
    deg = float(deg)
    if not 0.5 <= deg <= hi:
        raise ValueError(f"{name} must lie in 0.5…{hi:g} degrees, got {deg:g}")
    return deg


def _build(flux_lm, h, v, cd, opening, name, description) -> Photometry:
    cd = np.array(cd, dtype=np.float64)
    # Far tails of the profiles (below 1e-9 of the peak) are set to zero: invisible, and they
    # would only clutter written files with values like 1e-64.
    cd[cd < 1e-9 * cd.max()] = 0.0
    cd *= flux_lm / integrate_np("C", h, v, cd)
    dist = CandelaDistribution("C", h, v, cd)
    return Photometry(
        distribution=dist,
        opening=opening,
        rated_lm=flux_lm,
        lamp_lm=None,
        lor=None,
        integrated_lm=integrate_np("C", h, v, cd),
        input_watts=None,
        tilt=None,
        source=None,
        format="builtin",
        version="lumijax",
        keywords={"LUMCAT": name, "LUMINAIRE": description, "MANUFAC": "lumijax parametric model"},
    )


def _gamma_grid(knots_deg, fine_deg: float, fine_until: float) -> np.ndarray:
    """γ samples: ``fine_deg`` steps up to ``fine_until``, 1° beyond, with the knots inserted."""
    fine_until = min(180.0, fine_until)
    n_fine = max(2, int(math.ceil(fine_until / fine_deg)) + 1)
    g = np.linspace(0.0, fine_until, n_fine)
    if fine_until < 180.0:
        g = np.concatenate([g, np.arange(math.ceil(fine_until) + 1.0, 180.0, 1.0), [180.0]])
    g = np.concatenate([g, np.asarray(knots_deg, dtype=np.float64)])
    g = np.unique(np.round(g, 12))
    return g[(g >= 0.0) & (g <= 180.0)]


def _round(shape: str, diameter_m: float | None) -> LuminousOpening:
    """A round opening of ``diameter_m`` (m), or a point when None."""
    if diameter_m is None:
        return LuminousOpening()
    if not (math.isfinite(diameter_m) and diameter_m > 0):
        raise PhotometryError(f"a luminous diameter must be a positive number of metres, got "
                              f"{diameter_m!r}")
    height = diameter_m if shape == "sphere" else 0.0
    return LuminousOpening(diameter_m, diameter_m, height, shape)


def isotropic(flux_lm: float, diameter_m: float | None = None) -> Photometry:
    """A source emitting ``flux_lm`` (lm) equally in all directions: ``I = Φ / 4π`` cd; a point,
    or a sphere of ``diameter_m`` (m) as its luminous opening."""
    flux_lm = _check_flux(flux_lm)
    h = np.array([0.0, 360.0])
    v = np.array([0.0, 180.0])
    cd = np.full((2, 2), flux_lm / (4.0 * math.pi))
    return _build(flux_lm, h, v, cd, _round("sphere", diameter_m), "ISOTROPIC",
                  f"isotropic {flux_lm:g} lm")


def lambertian(flux_lm: float, diameter_m: float | None = None) -> Photometry:
    """A downward Lambertian emitter: ``I(γ) = Φ/π · cos γ`` for γ ≤ 90°, zero above; a point,
    or a downward disk of ``diameter_m`` (m) as its opening (luminance Φ/(πA) every way).

    Sampled every 0.25° and scaled to the exact flux; the linear interpolant then differs from
    ``Φ/π · cos γ`` by less than 3·10⁻⁶ of the peak.
    """
    flux_lm = _check_flux(flux_lm)
    h = np.array([0.0, 360.0])
    v = np.linspace(0.0, 90.0, 361)
    row = flux_lm / math.pi * np.cos(np.deg2rad(v))
    row[-1] = 0.0
    cd = np.stack([row, row])
    return _build(flux_lm, h, v, cd, _round("disk", diameter_m), "LAMBERTIAN",
                  f"Lambertian {flux_lm:g} lm")


def _profile(theta_deg, half_deg, p):
    return np.exp(-_LN2 * (np.asarray(theta_deg) / half_deg) ** p)


def spot(flux_lm: float, beam_deg: float, field_deg: float | None = None) -> Photometry:
    """A rotationally symmetric spot: ``I(γ) = I0 exp(−ln 2 (γ/θ_b)^p)``, ``θ_b = beam_deg/2``.

    Parameters
    ----------
    flux_lm
        Total flux (lm), met exactly by the table.
    beam_deg
        Full angle (deg) at half peak intensity.
    field_deg
        Full angle (deg) at 10 % of peak; sets the exponent ``p``. Default: ``p = 2`` (Gaussian),
        field ≈ 1.82 × beam.
    """
    flux_lm = _check_flux(flux_lm)
    beam = _check_beam("beam_deg", beam_deg)
    hb = beam / 2.0
    if field_deg is None:
        p = 2.0
        hf = hb * _FIELD_RATIO ** (1.0 / p)
    else:
        field = _check_beam("field_deg", field_deg, 359.0)
        if field <= beam:
            raise ValueError(f"field_deg ({field:g}) must be larger than beam_deg ({beam:g})")
        hf = field / 2.0
        p = math.log(_FIELD_RATIO) / math.log(hf / hb)
    tail = hb * (math.log(1e8) / _LN2) ** (1.0 / p)  # where I falls below 1e-8 of the peak
    v = _gamma_grid([hb, hf], min(0.5, beam / 40.0), tail)
    row = _profile(v, hb, p)
    cd = np.stack([row, row])
    return _build(
        flux_lm,
        np.array([0.0, 360.0]),
        v,
        cd,
        LuminousOpening(),
        f"SPOT-{beam:g}",
        f"parametric spot, beam {beam:g} deg, field {2 * hf:.3g} deg, {flux_lm:g} lm",
    )


def _elliptical(a_deg, b_deg, p, offset_deg, c_step, fine, knots):
    """Sample the elliptical model on a Type C grid, optionally with its axis turned to +y_l."""
    h = np.linspace(0.0, 360.0, int(round(360.0 / c_step)) + 1)
    tail = max(a_deg, b_deg) * (math.log(1e8) / _LN2) ** (1.0 / p) + abs(offset_deg)
    v = _gamma_grid(knots, fine, tail)
    C, G = np.meshgrid(np.deg2rad(h), np.deg2rad(v), indexing="ij")
    d = np.stack([np.sin(G) * np.cos(C), np.sin(G) * np.sin(C), -np.cos(G)], axis=-1)
    o = math.radians(offset_deg)
    # Undo the turn of the beam axis from −z_l towards +y_l (a rotation about x_l).
    dx = d[..., 0]
    dy = math.cos(o) * d[..., 1] + math.sin(o) * d[..., 2]
    dz = -math.sin(o) * d[..., 1] + math.cos(o) * d[..., 2]
    theta = np.degrees(np.arctan2(np.hypot(dx, dy), -dz))
    phi = np.arctan2(dy, dx)
    half = 1.0 / np.sqrt(np.cos(phi) ** 2 / a_deg**2 + np.sin(phi) ** 2 / b_deg**2)
    return h, v, np.exp(-_LN2 * (theta / half) ** p)


def flood(flux_lm: float, h_beam_deg: float, v_beam_deg: float) -> Photometry:
    """An elliptical floodlight beam along the photometric axis (Gaussian profile, ``p = 2``).

    ``v_beam_deg`` is the full half-peak angle in the C0 plane (``x_l``: "vertical" once the
    luminaire is tilted towards ``+x``, as for Type B in ``docs/conventions.md``) and
    ``h_beam_deg`` that in the C90 plane (``y_l``, horizontal). Flux ``flux_lm`` (lm) is exact.
    """
    flux_lm = _check_flux(flux_lm)
    hb = _check_beam("h_beam_deg", h_beam_deg)
    vb = _check_beam("v_beam_deg", v_beam_deg)
    fine = min(0.5, min(hb, vb) / 40.0)
    h, v, cd = _elliptical(vb / 2.0, hb / 2.0, 2.0, 0.0, 5.0, fine, [hb / 2.0, vb / 2.0])
    return _build(
        flux_lm,
        h,
        v,
        cd,
        LuminousOpening(),
        f"FLOOD-{hb:g}x{vb:g}",
        f"parametric flood, {hb:g} x {vb:g} deg (horizontal x vertical), {flux_lm:g} lm",
    )


def linear_washer(
    flux_lm: float,
    length_m: float,
    beam_across_deg: float,
    beam_along_deg: float = 120.0,
    *,
    width_m: float = 0.05,
    offset_deg: float = 0.0,
) -> Photometry:
    """A linear bar (length along C0 = ``+x_l``) with an elliptical beam, optionally thrown sideways.

    Parameters
    ----------
    flux_lm
        Total flux (lm), met exactly.
    length_m, width_m
        The rectangular luminous opening (m), length along ``+x_l``, width along ``+y_l``.
    beam_across_deg
        Full half-peak angle across the bar (C90 plane).
    beam_along_deg
        Full half-peak angle along the bar (C0 plane); wide for a washer.
    offset_deg
        Turns the beam axis from the nadir towards ``+y_l`` (the washed wall's side), in degrees;
        the beam angles then apply about the turned axis.
    """
    flux_lm = _check_flux(flux_lm)
    across = _check_beam("beam_across_deg", beam_across_deg)
    along = _check_beam("beam_along_deg", beam_along_deg)
    if not (length_m > 0 and width_m >= 0):
        raise ValueError("length_m must be positive and width_m non-negative")
    if not -90.0 <= offset_deg <= 90.0:
        raise ValueError(f"offset_deg must lie in −90…90, got {offset_deg:g}")
    fine = min(0.5, min(across, along) / 40.0)
    knots = [across / 2.0, along / 2.0]
    h, v, cd = _elliptical(along / 2.0, across / 2.0, 2.0, offset_deg, 5.0, fine, knots)
    return _build(
        flux_lm,
        h,
        v,
        cd,
        LuminousOpening(float(length_m), float(width_m), 0.0, "rectangle"),
        f"WASHER-{length_m:g}M",
        f"parametric linear washer {length_m:g} m, beam {across:g} deg across x {along:g} deg "
        f"along, offset {offset_deg:g} deg, {flux_lm:g} lm",
    )
