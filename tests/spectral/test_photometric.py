"""Photometric helpers: V(λ)-weighted reflectance and tristimulus."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.errors import SpectrumError
from lumijax.spectral import (
    K_M,
    Spectrum,
    luminous_efficacy_weighting,
    luminous_reflectance,
    photopic_v,
    tristimulus,
    xyz_of_illuminance,
)


@pytest.mark.parametrize("illuminant", ["D65", "A", "FL11", "LED-B3"])
@pytest.mark.parametrize("rho", [0.0, 0.05, 0.5, 0.95])
def test_grey_luminous_reflectance_is_its_value(rho, illuminant):
    assert luminous_reflectance(Spectrum.grey(rho), Spectrum.from_name(illuminant)) == (
        pytest.approx(rho, abs=1e-14)
    )


@pytest.mark.filterwarnings("ignore::colour.utilities.ColourRuntimeWarning")
def test_colorchecker_white_against_colour_sd_to_xyz():
    """Independent check: colour-science's own CIE 1931 2° integration (ASTM E308 tables, its
    own interpolation) of the ColorChecker N Ohta "white 9.5 (.05 D)" patch (Ohta's
    spectrophotometric data as shipped by colour-science) under D65 gives Y/100."""
    import colour

    patch = Spectrum.from_name("white", "reflectance")
    d65 = Spectrum.from_name("D65")
    rho = luminous_reflectance(patch, d65)
    xyz = colour.sd_to_XYZ(
        colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]["white 9.5 (.05 D)"],
        cmfs=colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"],
        illuminant=colour.SDS_ILLUMINANTS["D65"],
    )
    assert rho == pytest.approx(xyz[1] / 100.0, abs=2e-3)
    assert rho == pytest.approx(0.887, abs=0.01)
    # The published chart value (X-Rite ColorChecker 2005, xyY under D50) agrees loosely: the
    # patch is nearly flat, so the illuminant matters little; the chart is another specimen.
    published_y = colour.CCS_COLOURCHECKERS["ColorChecker 2005"].data["white 9.5 (.05 D)"][2]
    assert rho == pytest.approx(published_y, abs=0.03)


def test_dark_patch_depends_on_illuminant():
    red = Spectrum.from_name("red", "reflectance")
    under_a = luminous_reflectance(red, Spectrum.from_name("A"))
    under_d65 = luminous_reflectance(red, Spectrum.from_name("D65"))
    assert under_a > under_d65  # a red surface looks relatively brighter under warm light


def test_from_srgb_mid_grey_is_flat_with_linear_luminance():
    import colour

    srgb = np.array([0.5, 0.5, 0.5])
    s = Spectrum.from_srgb(srgb)
    linear_y = float(colour.sRGB_to_XYZ(srgb)[1])  # relative luminance of the sRGB colour
    assert np.ptp(s.values) < 1e-3 * np.mean(s.values)
    assert luminous_reflectance(s, Spectrum.from_name("D65")) == pytest.approx(linear_y, rel=2e-3)


def test_from_srgb_colour_round_trip_under_d65():
    import colour

    srgb = np.array([0.7, 0.4, 0.2])
    s = Spectrum.from_srgb(srgb)
    xyz = tristimulus(s)  # under D65 by default
    np.testing.assert_allclose(xyz, colour.sRGB_to_XYZ(srgb), atol=5e-3)


def test_photopic_v_and_weighting():
    assert photopic_v(555.0) == pytest.approx(1.0, abs=1e-4)
    assert photopic_v(300.0) == 0.0 and photopic_v(900.0) == 0.0
    wl = np.arange(360.0, 831.0, 1.0)
    w = luminous_efficacy_weighting(wl)
    # 1 W/nm flat spectrum: K_m * ∫V dλ, ∫V ≈ 106.86 nm.
    assert w.sum() == pytest.approx(K_M * 106.86, rel=2e-3)
    # Monochromatic-ish: a narrow band around 555 nm of 1 W total gives ~683 lm.
    band = np.where(np.abs(wl - 555.0) <= 0.5, 1.0, 0.0)
    assert w @ band == pytest.approx(K_M, rel=1e-3)
    with pytest.raises(SpectrumError):
        luminous_efficacy_weighting([500.0, 400.0])


def test_tristimulus_and_xyz_of_illuminance():
    d65 = Spectrum.from_name("D65")
    xyz = tristimulus(d65)
    assert xyz[1] == 1.0
    np.testing.assert_allclose(xyz[:2] / xyz.sum(), [0.3127, 0.3290], atol=2e-4)
    a = xyz_of_illuminance(Spectrum.from_name("A"), np.array([100.0, 500.0]))
    assert a.shape == (2, 3)
    np.testing.assert_allclose(a[:, 1], [100.0, 500.0])
    np.testing.assert_allclose(a[0, :2] / a[0].sum(), [0.4476, 0.4074], atol=2e-4)
    w = Spectrum.from_name("white", "reflectance")
    assert tristimulus(w)[1] == pytest.approx(luminous_reflectance(w, d65), rel=1e-9)


def test_kind_mismatch_errors():
    d65 = Spectrum.from_name("D65")
    with pytest.raises(SpectrumError, match="must be a reflectance"):
        luminous_reflectance(d65, d65)
    with pytest.raises(SpectrumError, match="must be an emission"):
        luminous_reflectance(Spectrum.grey(0.5), Spectrum.grey(0.5))
    with pytest.raises(SpectrumError, match="takes no illuminant"):
        tristimulus(d65, d65)
