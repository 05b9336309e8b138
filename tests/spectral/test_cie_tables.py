"""lumijax's own CIE tables and colorimetry (``spectral._cie``) against colour-science, the
independent reference (imported in the tests only), and the compute path free of colour."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from lumijax.spectral import (
    Spectrum,
    cct_from_xyz,
    luminous_reflectance,
    xyz_to_chromaticity,
    xyz_to_srgb,
)
from lumijax.spectral._cie import observer_tables, test_colour_samples

colour = pytest.importorskip("colour")


def test_tables_are_colour_sciences():
    from colour.colorimetry import SDS_LEFS_PHOTOPIC
    from colour.quality.datasets import SDS_TCS

    wl, v, cmf = observer_tables()
    ref_v = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    ref_c = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    assert np.array_equal(wl, ref_v.wavelengths) and np.array_equal(v, ref_v.values)
    assert np.array_equal(cmf, ref_c.values)
    # published anchor points (CIE 018): V(555) = 1, ȳ(555) = 1, x̄(600) = 1.0622
    assert v[wl == 555.0][0] == 1.0 and cmf[wl == 600.0, 0][0] == pytest.approx(1.0622)
    twl, tcs = test_colour_samples()
    for i in range(14):
        ref = SDS_TCS["CIE 1995"][f"TCS{i + 1:02d}"]
        assert np.array_equal(twl, ref.wavelengths) and np.array_equal(tcs[i], ref.values)


def test_equal_energy_is_colour_sciences():
    e = Spectrum.from_name("E", "emission")
    ref = colour.SDS_ILLUMINANTS["E"]
    assert np.array_equal(e.wavelengths_nm, ref.wavelengths)
    assert np.array_equal(e.values, ref.values)
    assert Spectrum.from_name("illuminant E", "emission") == e


def test_cct_against_colour_ohno2013():
    # points on isotemperature lines made by colour itself, 1600–25000 K, |Duv| ≤ 0.02
    t = np.geomspace(1600.0, 25000.0, 60)
    duv = np.linspace(-0.02, 0.02, 60)
    uv = colour.temperature.CCT_to_uv_Ohno2013(np.stack([t, duv], -1))
    xy = colour.UCS_uv_to_xy(uv)
    xyz = colour.xy_to_XYZ(xy) * 250.0
    ref = colour.temperature.uv_to_CCT_Ohno2013(uv)[:, 0]
    got = cct_from_xyz(xyz)
    np.testing.assert_allclose(got, ref, rtol=1e-9)
    np.testing.assert_allclose(got, t, rtol=1e-3)  # and the temperatures they were built at
    # CIE D65 ≈ 6504 K and illuminant A ≈ 2856 K (published)
    white = colour.sd_to_XYZ(colour.SDS_ILLUMINANTS["A"])
    assert cct_from_xyz(white) == pytest.approx(2856.0, abs=2.0)
    assert cct_from_xyz(np.zeros(3)) == 0.0


def test_chromaticity_and_srgb_against_colour():
    rng = np.random.default_rng(3)
    xyz = rng.uniform(0.0, 1.3, (500, 3))
    np.testing.assert_allclose(xyz_to_chromaticity(xyz), colour.XYZ_to_xy(xyz), atol=1e-15)
    ref = np.clip(colour.XYZ_to_sRGB(0.7 * xyz, apply_cctf_encoding=False), 0.0, 1.0)
    np.testing.assert_allclose(xyz_to_srgb(xyz, 0.7, encode=False), ref, atol=1e-13)
    enc = colour.cctf_encoding(ref, function="sRGB")
    np.testing.assert_allclose(xyz_to_srgb(xyz, 0.7), enc, atol=1e-13)


def test_luminous_reflectance_against_colour():
    # Y of a ColorChecker patch under E by colour's own integration, over Y of E
    patch = Spectrum.from_name("dark skin", "reflectance")
    e = Spectrum.from_name("E", "emission")
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ill = colour.SpectralDistribution(np.full(471, 100.0), domain=cmfs.wavelengths)
    sd = colour.SpectralDistribution(patch.at(cmfs.wavelengths), domain=cmfs.wavelengths)
    y = colour.sd_to_XYZ(sd, cmfs, ill, method="Integration")[1] / 100.0
    assert luminous_reflectance(patch, e) == pytest.approx(y, rel=1e-12)


def test_a_grey_study_does_not_import_colour(tmp_path):
    code = textwrap.dedent("""
        import sys
        from lumijax.spectral import Spectrum, cct_from_xyz, luminous_reflectance
        from lumijax.spectral._sampling import segment
        rho = luminous_reflectance(Spectrum.grey(0.5), Spectrum.from_name("E", "emission"))
        segment([Spectrum.from_name("E", "emission")], [Spectrum.grey(0.5)])
        cct_from_xyz([[1.0, 1.0, 1.0]])
        print("colour" in sys.modules)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, check=True)
    assert out.stdout.strip() == "False"
