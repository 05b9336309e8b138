"""Spectral sampling: the wavelength-domain segmentation against independent 1 nm integrals."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.errors import LumijaxWarning, SpectrumError
from lumijax.spectral import (
    K_M,
    SpectralSampling,
    Spectrum,
    cct_from_xyz,
    gauss_sampling,
    photometric_normalisation,
    segment,
    uniform_sampling,
    xyz_to_chromaticity,
    xyz_to_srgb,
)

pytestmark = pytest.mark.filterwarnings("ignore::colour.utilities.ColourRuntimeWarning")

PATCHES = ["dark skin", "blue", "red", "yellow", "cyan", "purple"]
CMFS = "CIE 1931 2 Degree Standard Observer"


def _colour_xyz(emission: Spectrum, reflectance: Spectrum | None = None, k: int = 1):
    """colour-science's own 1 nm integration of E·ρ^k (linear interpolation, lumijax's
    extrapolation), absolute: K_m Σ c̄ E ρ^k Δλ."""
    import colour
    from colour.algebra import Extrapolator, LinearInterpolator

    cmfs = colour.MSDS_CMFS[CMFS]

    def on_cmf_grid(spectrum, **rule):  # linear interpolation (colour's default is Sprague)
        return (
            spectrum.to_colour()
            .copy()
            .align(
                cmfs.shape,
                interpolator=LinearInterpolator,
                extrapolator=Extrapolator,
                extrapolator_kwargs={"method": "Constant", **rule},
            )
        )

    sd = on_cmf_grid(emission, left=0.0, right=0.0)
    if reflectance is not None:
        sd = sd * on_cmf_grid(reflectance) ** k
    # method "Integration" without illuminant: k = 1 would normalise; undo it with K_m scale
    xyz = colour.sd_to_XYZ(sd, cmfs=cmfs, method="Integration", k=1)
    return np.asarray(xyz, dtype=np.float64) * K_M


@pytest.fixture(scope="module")
def colorchecker():
    return [Spectrum.from_name(p, "reflectance") for p in PATCHES]


@pytest.fixture(scope="module")
def seg_fl11(colorchecker):
    return segment([Spectrum.from_name("FL11")], colorchecker, max_samples=16)


def test_api_shapes(seg_fl11):
    s = seg_fl11
    assert isinstance(s, SpectralSampling) and s.method == "segmentation"
    n = s.wavelengths_nm.size
    assert 1 <= n <= 16 and np.all(np.diff(s.wavelengths_nm) > 0)
    assert s.weights_xyz.shape == (3, n) and s.weights_v.shape == (n,)
    assert np.array_equal(s.weights_v, s.weights_xyz[1])
    assert sum(iv[3] for iv in s.intervals) == n
    assert not s.wavelengths_nm.flags.writeable


@pytest.mark.parametrize("make", [lambda: uniform_sampling(16), lambda: gauss_sampling(16)])
def test_classic_samplings_integrate_smooth_spectra(make):
    s = make()
    flat = _colour_xyz(Spectrum(np.array([360.0, 830.0]), np.ones(2), "emission"))
    assert s.weights_xyz @ np.ones(s.n) == pytest.approx(flat, rel=2e-2)
    a = Spectrum.from_name("A")
    assert s.tristimulus(a.at(s.wavelengths_nm)) == pytest.approx(_colour_xyz(a), rel=2e-2)


def test_generic_weights_integrate_constant_and_cie_a(seg_fl11):
    s = seg_fl11
    flat = _colour_xyz(Spectrum(np.array([360.0, 830.0]), np.ones(2), "emission"))
    assert s.weights_xyz @ np.ones(s.n) == pytest.approx(flat, rel=1e-12)
    a = Spectrum.from_name("A")
    assert s.tristimulus(a.at(s.wavelengths_nm)) == pytest.approx(_colour_xyz(a), rel=3e-2)


@pytest.mark.parametrize("lamp", ["FL11", "A", "LED-RGB1", "FL3"])
def test_emission_weighted_is_exact_for_the_lamp(lamp, colorchecker):
    e = Spectrum.from_name(lamp)
    s = segment([e], colorchecker, max_samples=8).for_emission(e)
    assert s.method == "segmentation/emission-weighted"
    assert s.tristimulus(e.at(s.wavelengths_nm)) == pytest.approx(_colour_xyz(e), rel=1e-9)


def test_emission_line_gets_a_node_at_its_data_point_and_is_exact():
    # a narrow line at 545 nm (data at 540/545/550) on a weak continuum: the FL11 situation
    wl = np.array([380.0, 540.0, 545.0, 550.0, 780.0])
    line = Spectrum(wl, np.array([0.01, 0.01, 1.0, 0.01, 0.01]), "emission", name="line")
    s = segment([line], [Spectrum.from_name("red", "reflectance")], max_samples=6)
    assert 545.0 in s.wavelengths_nm
    assert "trapezoid" in [iv[2] for iv in s.intervals if iv[0] <= 545.0 < iv[1]]
    sw = s.for_emission(line)
    assert sw.tristimulus(line.at(sw.wavelengths_nm)) == pytest.approx(_colour_xyz(line), rel=1e-9)
    # FL11's three strong lines sit on nodes at the data points
    fl11 = segment([Spectrum.from_name("FL11")], max_samples=16)
    for peak in (435.0, 545.0, 610.0):
        assert peak in fl11.wavelengths_nm


def test_generic_trapezoid_weights_capture_a_line_with_nodes_at_its_data_points():
    """Generic weights are trapezoid product integration: a line whose three data points are
    nodes (and zero at them outside) is integrated exactly, whatever its height."""
    from lumijax.spectral._sampling import _weights, reference_grid

    nodes = np.array([400.0, 540.0, 545.0, 550.0, 700.0])
    _, cmf = reference_grid()
    h = _weights(nodes, ((360.0, 831.0, "trapezoid", tuple(range(5))),), cmf)
    line = Spectrum(
        np.array([380.0, 540.0, 545.0, 550.0, 780.0]), np.array([0, 0, 7.0, 0, 0]), "emission"
    )
    assert h @ line.at(nodes) == pytest.approx(_colour_xyz(line), rel=1e-12)


@pytest.mark.parametrize("lamp", ["FL11", "A", "D65", "LED-B5", "FL2"])
def test_photometric_normalisation_is_exact(lamp, colorchecker):
    e = Spectrum.from_name(lamp)
    seg = segment([e], colorchecker, max_samples=12)
    for s in (seg, seg.for_emission(e), uniform_sampling(9), gauss_sampling(5)):
        f = photometric_normalisation(e, s)
        assert s.weights_v @ (f * e.at(s.wavelengths_nm)) == pytest.approx(1.0, rel=1e-14)
    # emission-weighted: the factor is the exact 1 nm photometric normalisation
    f = photometric_normalisation(e, seg.for_emission(e))
    assert f == pytest.approx(1.0 / _colour_xyz(e)[1], rel=1e-12)


@pytest.mark.parametrize("lamp", ["FL11", "A"])
@pytest.mark.parametrize("k", [1, 3])
def test_delta_e00_against_colour_1nm_reference(lamp, k, colorchecker):
    import colour

    e = Spectrum.from_name(lamp)
    s = segment([e], colorchecker, max_samples=16).for_emission(e)
    f = photometric_normalisation(e, s)
    white = _colour_xyz(e)
    xy_w = colour.XYZ_to_xy(white)
    for r in colorchecker:
        ref = _colour_xyz(e, r, k) / white[1]
        got = s.tristimulus(f * e.at(s.wavelengths_nm) * r.at(s.wavelengths_nm) ** k)
        de = colour.delta_E(
            colour.XYZ_to_Lab(got, xy_w), colour.XYZ_to_Lab(ref, xy_w), method="CIE 2000"
        )
        assert de < 0.5, (r.name, de)


def test_two_lamps_share_samples():
    a, f = Spectrum.from_name("A"), Spectrum.from_name("FL11")
    s = segment([a, f], [Spectrum.grey(0.25)], max_samples=16)
    for e in (a, f):
        sw = s.for_emission(e)
        assert np.array_equal(sw.wavelengths_nm, s.wavelengths_nm)
        assert sw.tristimulus(e.at(s.wavelengths_nm)) == pytest.approx(_colour_xyz(e), rel=1e-9)


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "wl, v, match",
    [
        ([380, 500, 780], [1, -0.1, 1], "negative"),
        ([380, 600, 500, 780], [1, 1, 1, 1], "strictly increasing"),
        ([380, 500, 500, 780], [1, 1, 1, 1], "duplicates"),
        ([450, 500, 700], [1, 1, 1], "must cover"),
        ([380, 500, 780], [0, 0, 0], "zero everywhere"),
    ],
)
def test_bad_spectra_raise(wl, v, match):
    with pytest.raises(SpectrumError, match=match):
        Spectrum(np.array(wl, float), np.array(v, float), "emission")


def test_bad_arguments_raise():
    a = Spectrum.from_name("A")
    with pytest.raises(SpectrumError):
        segment([], [])
    with pytest.raises(SpectrumError):
        segment([a], max_samples=0)
    with pytest.raises(SpectrumError):
        segment([Spectrum.grey(0.5)])  # a reflectance is not an emission
    with pytest.raises(SpectrumError):
        segment([a], [a])  # an emission is not a reflectance
    with pytest.raises(SpectrumError):
        uniform_sampling(0)
    # emission invisible at the samples: a clear error, not a division by zero
    uv = Spectrum(np.array([360.0, 370.0, 371.0, 830.0]), np.array([1.0, 1.0, 0, 0]), "emission")
    with pytest.raises(SpectrumError, match="no luminance"):
        photometric_normalisation(uv, gauss_sampling(4))


def test_extrapolated_and_gappy_emissions_give_finite_weights():
    # 20 nm short at each end (extrapolated as zero, with a warning) and a dark gap inside
    with pytest.warns(LumijaxWarning, match="extrapolated as zero"):
        e = Spectrum(
            np.array([400.0, 450.0, 460.0, 600.0, 610.0, 760.0]),
            np.array([1.0, 1.0, 0.0, 0.0, 1.0, 1.0]),
            "emission",
        )
    s = segment([e, Spectrum.from_name("A")], max_samples=10)
    for w in (s.weights_xyz, s.for_emission(e).weights_xyz):
        assert np.all(np.isfinite(w))
    assert np.isfinite(photometric_normalisation(e, s.for_emission(e)))


def test_colorimetry_helpers_never_nan():
    xyz = np.array([[0.0, 0.0, 0.0], [0.95047, 1.0, 1.08883], [1.0985, 1.0, 0.35585]])
    xy = xyz_to_chromaticity(xyz)
    assert xy[0] == pytest.approx([0.3127, 0.3290]) and xy[1] == pytest.approx(
        [0.3127, 0.329], abs=1e-3
    )
    cct = cct_from_xyz(xyz)
    assert (
        cct[0] == 0.0
        and cct[1] == pytest.approx(6504, abs=15)
        and cct[2] == pytest.approx(2856, abs=10)
    )
    rgb = xyz_to_srgb(xyz, exposure=1.0)
    assert np.all(np.isfinite(rgb)) and rgb[0].tolist() == [0, 0, 0]
    assert rgb[1] == pytest.approx([1, 1, 1], abs=2e-3)
    with pytest.raises(SpectrumError):
        xyz_to_srgb(xyz, exposure=-1)
    with pytest.raises(SpectrumError):
        cct_from_xyz([1.0, np.nan, 1.0])
