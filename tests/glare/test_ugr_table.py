"""CIE 190:2010 tabular UGR of real luminaire files, against CIE 190's own worksheet written
here: the zonal fluxes at 10° midpoints, its zonal factors F_GL and transfer factors F_T as the
standard tabulates them for the room index k = 2.67 (rooms 4H × 8H and 8H × 4H; the values
are CIE 190's Tables 4 and 5), B = N Φ / A_w, L_b = E_WID / π; the glare sum from the file's
candela table (scipy's interpolation), the flat opening's A cos γ and the Luckiesh–Guth
expression. lumijax's ugr_table integrates the direct flux on the floor instead of using F_GL
and solves the transfer from the room's form factors: the two must meet.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from lumijax.cli import main
from lumijax.errors import PhotometryError
from lumijax.glare import STANDARD_REFLECTANCES, room_transfer_factors, ugr_table
from lumijax.photometry import isotropic, read_photometry

FILES = ["er_fluorescent_luminaire.ldt", "lx_Testlamp_Isym4_43cef5d76a391dd85c41d4d09d68600d.ldt"]
H = 2.0
# CIE 190:2010 Table 5, k = 2.67: (F_T,FW, F_T,WW-1, F_T,CW) per (ceiling, walls, floor)
TABLE5_K267 = {(0.7, 0.5, 0.2): (0.115, 0.211, 0.307), (0.7, 0.3, 0.2): (0.106, 0.117, 0.283),
               (0.5, 0.5, 0.2): (0.100, 0.187, 0.211), (0.5, 0.3, 0.2): (0.093, 0.104, 0.196),
               (0.3, 0.3, 0.2): (0.081, 0.092, 0.114)}
# CIE 190:2010 Table 4, k = 2.67: F_GL1..4, weighting the cumulative zonal fluxes
TABLE4_K267 = (0.280, 0.165, 0.499, 0.006)


def _cie190(phot, x_h, y_h, endwise, spacing_h=0.25):
    """UGR per reflectance combination, CIE 190's way (see the module docstring)."""
    d = phot.distribution
    table = RegularGridInterpolator((np.asarray(d.h_deg, float), np.asarray(d.v_deg, float)),
                                    np.asarray(d.candela, float), bounds_error=False,
                                    fill_value=0.0)

    def cd(c, g):
        return table(np.stack([np.mod(c, 360.0), g], axis=-1))

    # zonal fluxes: C-averaged intensity at 5°, 15°, …, 175° times the zone's solid angle
    mids = np.arange(5.0, 180.0, 10.0)
    cs = np.arange(0.0, 360.0, 7.5)
    mean_cd = np.array([cd(cs, np.full_like(cs, g)).mean() for g in mids])
    zone = mean_cd * 2 * math.pi * np.sin(np.radians(mids)) * math.radians(10.0)
    dn, up = zone[:9], zone[9:]
    phi_zl = (dn[:4].sum() + 0.130 * dn[4], dn[:6].sum(), dn[:7].sum() + 0.547 * dn[7],
              dn.sum())
    lamp = phot.lamp_lm
    f_df = sum(f * z for f, z in zip(TABLE4_K267, phi_zl, strict=True)) / lamp
    f_dw, f_dc = dn.sum() / lamp - f_df, up.sum() / lamp

    s = spacing_h * H
    x_m, y_m = x_h * H, y_h * H
    xs = s / 2 + s * np.arange(round(x_m / s)) - x_m / 2  # across the sight, eye at 0
    ys = s / 2 + s * np.arange(round(y_m / s))  # along the sight
    area = phot.opening.length_m * phot.opening.width_m
    total = 0.0
    for t in xs:
        for r in ys:
            dist = math.sqrt(r * r + t * t + H * H)
            gamma = math.degrees(math.acos(H / dist))
            # C from the opening's length axis (C0): across the sight (crosswise) it is x
            c = math.degrees(math.atan2(-r, -t)) if not endwise else math.degrees(
                math.atan2(t, -r))
            lum = float(cd(np.array([c]), np.array([gamma]))[0]) / (area * H / dist)
            omega = area * (H / dist) / dist ** 2
            sigma = math.degrees(math.atan(math.hypot(t, H) / r))
            tau = math.degrees(math.atan2(abs(t), H))
            p = min(16.0, math.exp((35.2 - 0.31889 * tau - 1.22 * math.exp(-2 * tau / 9))
                                   * 1e-3 * sigma + (21 + 0.26667 * tau - 0.002963 * tau ** 2)
                                   * 1e-5 * sigma ** 2))
            total += lum ** 2 * omega / p ** 2
    b = len(xs) * len(ys) * lamp / (2 * H * (x_m + y_m))
    out = []
    for refl in STANDARD_REFLECTANCES:
        fw, ww, cw = TABLE5_K267[refl]
        lb = b * (f_df * fw + f_dw * ww + f_dc * cw) / math.pi
        out.append(8 * math.log10(0.25 / lb * total))
    return np.array(out)


def test_transfer_factors_are_cie190_table5():
    for refl, want in TABLE5_K267.items():
        for x, y in ((4, 8), (8, 4)):  # k = 2.67 both ways
            got = room_transfer_factors(x * H, y * H, H, refl)
            assert got == pytest.approx(want, abs=6e-4), (refl, x, y)


_TABLES: dict = {}  # computed once per process: each file's table in the two k = 2.67 rooms


@pytest.fixture
def tables(shared_photometry):
    for name in FILES:
        if name not in _TABLES:
            phot = read_photometry(shared_photometry / name)
            _TABLES[name] = (phot, ugr_table(phot, rooms=((4.0, 8.0), (8.0, 4.0))))
    return _TABLES


@pytest.mark.parametrize("name", FILES)
def test_ugr_table_against_the_cie190_worksheet(tables, name):
    phot, table = tables[name]
    for r, (x, y) in enumerate(table.rooms):
        for o, endwise in enumerate((False, True)):
            want = _cie190(phot, x, y, endwise)
            # F_GL (CIE 52's zonal fit) against the integrated direct ratio: 0.06 UGR at most
            assert table.ugr[r, o] == pytest.approx(want, abs=0.1), (x, y, endwise)


def test_ugr_scales_with_the_lamp_flux_as_cie190_eq2(tables):
    phot, table = tables[FILES[0]]
    half = ugr_table(phot, rooms=table.rooms, lamp_flux_lm=0.5 * phot.lamp_lm)
    assert half.ugr == pytest.approx(table.ugr + 8 * math.log10(0.5), abs=1e-9)


def test_a_point_source_file_has_no_table():
    with pytest.raises(PhotometryError, match="luminous dimensions"):
        ugr_table(isotropic(1000.0))


def test_cli_prints_the_table_and_refuses_a_point_source(shared_photometry, capsys):
    path = shared_photometry / FILES[0]
    assert main(["ugr-table", str(path), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert [(r["x_h"], r["y_h"]) for r in got["rooms"]][:2] == [(2.0, 2.0), (2.0, 3.0)]
    assert len(got["rooms"]) == 19 and len(got["rooms"][0]["crosswise"]) == 5
    point = shared_photometry / "er_OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies"
    assert main(["ugr-table", str(point)]) == 1
    assert "no luminous dimensions" in capsys.readouterr().err
