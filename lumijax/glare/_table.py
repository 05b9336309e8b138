"""CIE 190:2010 tabular UGR: the table manufacturers print on a luminaire's data sheet.

The standard rooms (CIE 117:1995 section 4.2; CIE 190:2010 section 4): a rectangular room of
X × Y (X across the observer's line of sight, Y along it, both multiples of H), a regular array
of the luminaire at spacing S on a plane H = 2 m above the eye, the observer at the middle of
one wall at eye height looking horizontally along Y. Every luminaire in the room counts, with
``L = I / A_p`` toward the eye, ``ω = A_p / d²`` and Guth's position index (as
:mod:`lumijax.glare._model` rates an observer in a study).

The background is CIE 190's (its equations 7 and 8b): ``L_b = E_WID / π`` with the indirect
illuminance on the walls between the eye's plane and the luminaires' plane

    E_WID = B · (F_DF · F_T,FW + F_DW · F_T,WW−1 + F_DC · F_T,CW),   B = N Φ / A_w,

N luminaires of lamp flux Φ (lm), walls of area ``A_w = 2 H (X + Y)`` (m²). ``F_DF``, ``F_DW``,
``F_DC`` are the fractions of Φ that reach the floor (the reference plane at eye height,
ρ = 0.2), the walls and the ceiling directly; the transfer factors ``F_T`` are the three
surfaces' inter-reflection: here solved exactly from the room's form factors (they reproduce
CIE 190's Table 5 to its three decimals), and ``F_DF`` integrated from the candela table over
the array (CIE 190 approximates the same fraction with CIE 52's zonal factors F_GL). UGR
scales with the lamp flux as ``8 log10(Φ / Φ0)`` (CIE 190 eq. 2): the table is at the file's own
flux unless ``lamp_flux_lm`` is given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from ..errors import PhotometryError
from ._area import projected_area
from ._position import position_index

__all__ = ["UGRTable", "ugr_table", "STANDARD_ROOMS", "STANDARD_REFLECTANCES",
           "STANDARD_SPACING_H", "room_transfer_factors"]

#: CIE 190's 19 standard rooms (X, Y) in multiples of H: X across the line of sight, Y along it.
STANDARD_ROOMS: tuple[tuple[float, float], ...] = (
    *((2.0, y) for y in (2.0, 3.0, 4.0, 6.0, 8.0, 12.0)),
    *((4.0, y) for y in (2.0, 3.0, 4.0, 6.0, 8.0, 12.0)),
    *((8.0, y) for y in (4.0, 6.0, 8.0, 12.0)),
    *((12.0, y) for y in (4.0, 6.0, 8.0)),
)
#: Ceiling / walls / floor (reference plane) reflectances of the table's columns.
STANDARD_REFLECTANCES: tuple[tuple[float, float, float], ...] = (
    (0.7, 0.5, 0.2), (0.7, 0.3, 0.2), (0.5, 0.5, 0.2), (0.5, 0.3, 0.2), (0.3, 0.3, 0.2))
#: Luminaire spacing S / H of the printed tables (CIE 117's and the catalogues' 0.25 H; CIE
#: 190's "standard-condition" table and its worked example use S = 1 H: pass spacing_h=1).
STANDARD_SPACING_H = 0.25
#: H (m): luminaire plane above the eye. UGR does not depend on it (ω and L_b both go as 1/H²).
_H_M = 2.0
_ORIENTATIONS = ("crosswise", "endwise")


@dataclass(frozen=True)
class UGRTable:
    """A luminaire's CIE 190 UGR table.

    ``ugr[r, o, k]``: room ``rooms[r]`` (X, Y in H), orientation ``orientations[o]``
    (``crosswise``: the opening's length, the luminaire frame's C0 axis, across the line of
    sight; ``endwise``: along it), reflectances ``reflectances[k]`` (ceiling, walls, floor).
    ``background_cdm2`` (same shape) is CIE 190's L_b; ``source_sum`` (rooms × orientations)
    is ``Σ L² ω / p²`` (cd²/m⁴·sr); ``luminaires[r]`` the count N in room r.
    """

    name: str
    rooms: tuple[tuple[float, float], ...]
    reflectances: tuple[tuple[float, float, float], ...]
    orientations: tuple[str, ...]
    spacing_h: float
    lamp_flux_lm: float
    ugr: np.ndarray
    background_cdm2: np.ndarray
    source_sum: np.ndarray
    luminaires: tuple[int, ...]

    def to_dict(self) -> dict:
        """JSON-ready: one row per room with its UGR per orientation and reflectance."""
        rows = []
        for r, (x, y) in enumerate(self.rooms):
            rows.append({"x_h": x, "y_h": y, "luminaires": self.luminaires[r],
                         **{o: [round(float(v), 2) for v in self.ugr[r, j]]
                            for j, o in enumerate(self.orientations)}})
        return {"name": self.name, "spacing_h": self.spacing_h,
                "lamp_flux_lm": self.lamp_flux_lm,
                "reflectances": [list(c) for c in self.reflectances], "rooms": rows}


def _parallel_form_factor(a: float, b: float, c: float) -> float:
    """View factor between two directly opposed parallel a × b rectangles c apart."""
    x, y = a / c, b / c
    return 2.0 / (math.pi * x * y) * (
        math.log(math.sqrt((1 + x * x) * (1 + y * y) / (1 + x * x + y * y)))
        + x * math.sqrt(1 + y * y) * math.atan(x / math.sqrt(1 + y * y))
        + y * math.sqrt(1 + x * x) * math.atan(y / math.sqrt(1 + x * x))
        - x * math.atan(x) - y * math.atan(y))


def room_transfer_factors(x_m: float, y_m: float, h_m: float,
                          reflectances: tuple[float, float, float]) -> np.ndarray:
    """CIE 190's ``(F_T,FW, F_T,WW−1, F_T,CW)``: the flux that reaches the walls after
    inter-reflection per unit of flux first falling on the floor, the walls, the ceiling (the
    walls' own first incidence left out), for a room ``x_m × y_m`` with the walls ``h_m`` high
    and (ceiling, walls, floor) reflectances."""
    a_f, a_w = x_m * y_m, 2.0 * h_m * (x_m + y_m)
    f_fc = _parallel_form_factor(x_m, y_m, h_m)
    f_wf = a_f * (1.0 - f_fc) / a_w
    form = np.array([[0.0, 1.0 - f_fc, f_fc],              # floor → floor, walls, ceiling
                     [f_wf, 1.0 - 2.0 * f_wf, f_wf],       # walls
                     [f_fc, 1.0 - f_fc, 0.0]])             # ceiling
    rc, rw, rf = reflectances
    rho = np.array([rf, rw, rc])
    # incident flux Φ = Φ0 + (ρ F)ᵀ Φ: column j of the inverse is the response to Φ0 on j
    transfer = np.linalg.inv(np.eye(3) - (rho[:, None] * form).T)
    return np.array([transfer[1, 0], transfer[1, 1] - 1.0, transfer[1, 2]])


def _quadrature(steps_deg: float = 1.0):
    """Midpoint directions (luminaire frame, unit) over the sphere and their solid angles."""
    g = np.radians(np.arange(steps_deg / 2, 180.0, steps_deg))
    c = np.radians(np.arange(steps_deg / 2, 360.0, steps_deg))
    gg, cc = np.meshgrid(g, c, indexing="ij")
    d = np.stack([np.sin(gg) * np.cos(cc), np.sin(gg) * np.sin(cc), -np.cos(gg)], axis=-1)
    w = np.sin(gg) * math.radians(steps_deg) ** 2
    return d.reshape(-1, 3), w.reshape(-1)


def _inside_fraction(starts: np.ndarray, offsets: np.ndarray, length: float) -> np.ndarray:
    """For each offset, the fraction of ``starts`` whose ``start + offset`` lies in [0, length]:
    the share of the array whose ray in that direction lands on the floor (per axis)."""
    ordered = np.sort(starts)
    inside = (np.searchsorted(ordered, length - offsets, side="right")
              - np.searchsorted(ordered, -offsets, side="left"))
    return inside / len(starts)


def ugr_table(photometry, *, spacing_h: float = STANDARD_SPACING_H,
              rooms=STANDARD_ROOMS, reflectances=STANDARD_REFLECTANCES,
              lamp_flux_lm: float | None = None) -> UGRTable:
    """The CIE 190 UGR table of ``photometry`` (a :class:`lumijax.photometry.Photometry`).

    ``spacing_h``: luminaire spacing S / H; ``rooms``: (X, Y) in H; ``reflectances``:
    (ceiling, walls, floor); ``lamp_flux_lm``: the lamp flux Φ (lm) the table is for (default:
    the file's own, its intensities as read). PhotometryError where the file gives no
    luminous area (a data sheet's table needs one) or sends no light down.
    """
    opening = photometry.opening
    if opening.is_point:
        raise PhotometryError(f"photometry {photometry.name!r} gives no luminous dimensions: a "
                              "UGR table needs the luminous area (L = I / A)",
                              file=photometry.source)
    if not spacing_h > 0:
        raise PhotometryError(f"spacing_h must be > 0 (S / H), got {spacing_h}")
    own_lm = photometry.lamp_lm or photometry.integrated_lm
    scale = 1.0 if lamp_flux_lm is None else float(lamp_flux_lm) / own_lm
    dist = photometry.distribution
    quad_d, quad_w = _quadrature()
    h = _H_M
    s = spacing_h * h
    # the luminaire frame per orientation, as world = R · local (world: x across, y along
    # the line of sight, z up)
    frames = {"crosswise": np.eye(3),
              "endwise": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])}
    cd_quad = np.asarray(dist.intensity(jnp.asarray(quad_d)), np.float64) * scale
    phi_down = float(np.sum((cd_quad * quad_w)[quad_d[:, 2] < 0]))
    phi_up = float(np.sum((cd_quad * quad_w)[quad_d[:, 2] >= 0]))
    if not phi_down > 0:
        raise PhotometryError(f"photometry {photometry.name!r} sends no light downward: no UGR "
                              "table (its luminaires cannot be seen from below)",
                              file=photometry.source)
    flux = own_lm * scale
    ugr = np.zeros((len(rooms), 2, len(reflectances)))
    lb = np.zeros_like(ugr)
    sums = np.zeros((len(rooms), 2))
    down = quad_d[:, 2] < 0
    down_flux = (cd_quad * quad_w)[down]
    tan_d = quad_d[down, :2] / -quad_d[down, 2:3] * h  # landing offset on the floor (m)
    arrays = []
    for xh, yh in rooms:
        x_m, y_m = xh * h, yh * h
        nx, ny = max(1, int(round(x_m / s))), max(1, int(round(y_m / s)))
        xs = (np.arange(nx) + 0.5) * (x_m / nx)
        ys = (np.arange(ny) + 0.5) * (y_m / ny)
        px, py = np.meshgrid(xs - x_m / 2.0, ys, indexing="ij")
        arrays.append((x_m, y_m, xs, ys, np.stack([px.ravel(), py.ravel(),
                                                   np.full(px.size, h)], axis=-1)))
    counts = [len(a[4]) for a in arrays]
    pos = np.concatenate([a[4] for a in arrays])  # every room's luminaires, the eye at 0
    dist_m = np.linalg.norm(pos, axis=1)
    to_eye = -pos / dist_m[:, None]
    p = position_index(-to_eye, np.array([0.0, 1.0, 0.0]))
    room_of = np.repeat(np.arange(len(rooms)), counts)
    for o, name in enumerate(_ORIENTATIONS):
        rot = frames[name]
        local = to_eye @ rot  # Rᵀ w, row-wise
        cd = np.asarray(dist.intensity(jnp.asarray(local)), np.float64) * scale
        area = np.asarray(projected_area(opening, jnp.asarray(local)), np.float64)
        terms = (cd / area) ** 2 * (area / dist_m ** 2) / p ** 2
        sums[:, o] = np.bincount(room_of, terms, minlength=len(rooms))
        world = tan_d @ rot[:2, :2].T
        for r, (x_m, y_m, xs, ys, _) in enumerate(arrays):
            # direct flux on the floor: the array's share of each downward direction landing
            # inside the room (separable in x and y for a rectangular array)
            hit = _inside_fraction(xs, world[:, 0], x_m) * _inside_fraction(ys, world[:, 1],
                                                                             y_m)
            f_df = float(np.sum(down_flux * hit)) / flux
            f_dw = phi_down / flux - f_df
            f_dc = phi_up / flux
            b = counts[r] * flux / (2.0 * h * (x_m + y_m))
            for k, refl in enumerate(reflectances):
                ft = room_transfer_factors(x_m, y_m, h, tuple(refl))
                e_wid = b * (f_df * ft[0] + f_dw * ft[1] + f_dc * ft[2])
                lb[r, o, k] = e_wid / math.pi
                ugr[r, o, k] = 8.0 * math.log10(0.25 / lb[r, o, k] * sums[r, o])
    return UGRTable(name=photometry.name, rooms=tuple(tuple(map(float, rm)) for rm in rooms),
                    reflectances=tuple(tuple(map(float, c)) for c in reflectances),
                    orientations=_ORIENTATIONS, spacing_h=float(spacing_h),
                    lamp_flux_lm=float(flux), ugr=ugr, background_cdm2=lb, source_sum=sums,
                    luminaires=tuple(counts))
