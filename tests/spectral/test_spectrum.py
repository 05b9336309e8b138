"""Spectrum: names, CSV, validation, extrapolation."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from lumijax.errors import LumijaxWarning, SpectrumError
from lumijax.spectral import Spectrum, available_names

WL = np.arange(380.0, 781.0, 10.0)


# ------------------------------------------------------------------------------- names
@pytest.mark.parametrize(
    "name, expected",
    [
        ("A", "A"),
        ("D65", "D65"),
        ("FL11", "FL11"),
        ("F11", "FL11"),
        ("f3.1", "FL3.1"),
        ("LED-B3", "LED-B3"),
        ("led b3", "LED-B3"),
        ("d65", "D65"),
        ("CIE D65", "D65"),
        ("Illuminant A", "A"),
        ("hps", "HPS"),
        ("Phosphor LED YAG", "Phosphor LED YAG"),
    ],
)
def test_emission_names_resolve(name, expected):
    s = Spectrum.from_name(name, "emission")
    assert s.name == expected
    assert s.kind == "emission"
    assert s.wavelengths_nm.dtype == np.float64
    assert np.all(np.diff(s.wavelengths_nm) > 0)
    assert np.all(s.values >= 0) and np.any(s.values > 0)


def test_emission_default_kind_and_values_match_colour():
    import colour

    s = Spectrum.from_name("fl11")
    sd = colour.SDS_ILLUMINANTS["FL11"]
    np.testing.assert_array_equal(s.wavelengths_nm, sd.wavelengths)
    np.testing.assert_array_equal(s.values, sd.values)


@pytest.mark.parametrize(
    "name, expected",
    [
        ("dark skin", "ColorChecker N Ohta/dark skin"),
        ("DARK SKIN", "ColorChecker N Ohta/dark skin"),
        ("ColorChecker N Ohta/dark skin", "ColorChecker N Ohta/dark skin"),
        ("colorchecker 1", "ColorChecker N Ohta/dark skin"),
        ("ColorChecker N Ohta/19", "ColorChecker N Ohta/white 9.5 (.05 D)"),
        ("white", "ColorChecker N Ohta/white 9.5 (.05 D)"),
        ("neutral 5", "ColorChecker N Ohta/neutral 5 (.70 D)"),
        ("TCS01", "TCS01"),
        ("tcs1", "TCS01"),
    ],
)
def test_reflectance_names_resolve(name, expected):
    s = Spectrum.from_name(name, "reflectance")
    assert s.name == expected
    assert s.kind == "reflectance"
    assert np.all((s.values >= 0) & (s.values < 1))


def test_unknown_name_suggests_close_matches():
    with pytest.raises(SpectrumError, match=r"closest: D65") as exc:
        Spectrum.from_name("D66")
    assert exc.value.key == "spectrum 'D66'"
    with pytest.raises(SpectrumError, match="dark skin"):
        Spectrum.from_name("drak skin", "reflectance")
    with pytest.raises(SpectrumError, match="LED-B5"):
        Spectrum.from_name("LED-B9")


def test_wrong_kind_for_name_is_explained():
    with pytest.raises(SpectrumError, match="emission spectrum, not reflectance"):
        Spectrum.from_name("D65", "reflectance")
    with pytest.raises(SpectrumError, match="reflectance spectrum, not emission"):
        Spectrum.from_name("dark skin", "emission")
    with pytest.raises(SpectrumError, match="kind must be"):
        Spectrum.from_name("D65", "light")


def test_named_spectrum_not_covering_visible_range_is_refused():
    # ISO 7589 illuminants stop at 690 nm: 90 nm short of 780 nm.
    with pytest.raises(SpectrumError, match="must cover 380-780 nm"):
        Spectrum.from_name("ISO 7589 Photoflood")


def test_available_names():
    em = available_names("emission")
    assert {"A", "D65", "FL11", "LED-B1"} <= set(em)
    assert "dark skin" in available_names("reflectance")


# --------------------------------------------------------------------------------- CSV
def test_csv_round_trip(tmp_path):
    s = Spectrum.from_name("LED-B2")
    path = s.to_csv(tmp_path / "led.csv")
    back = Spectrum.from_csv(path, "emission", name="LED-B2")
    assert back == s
    assert back.source == str(path)
    r = Spectrum.from_name("dark skin", "reflectance")
    back = Spectrum.from_csv(r.to_csv(tmp_path / "skin.csv"), "reflectance")
    np.testing.assert_array_equal(back.values, r.values)
    assert back.name == "skin"
    assert {p.name for p in tmp_path.iterdir()} == {"led.csv", "skin.csv"}  # no temp leftovers


def test_csv_comments_extra_columns_case(tmp_path):
    p = tmp_path / "s.csv"
    rows = "\n".join(f"{w:g},{0.5:g},x" for w in WL)
    p.write_text(f"# measured 2024\nWavelength_nm, Reflectance ,note\n\n{rows}\n")
    s = Spectrum.from_csv(p, "reflectance")
    np.testing.assert_array_equal(s.wavelengths_nm, WL)
    assert np.all(s.values == 0.5)


def _write(tmp_path, body, header="wavelength_nm,value"):
    p = tmp_path / "bad.csv"
    p.write_text((header + "\n" if header else "") + body)
    return p


def _rows(wl, v):
    return "".join(f"{a!r},{b!r}\n" for a, b in zip(wl, v))


@pytest.mark.parametrize(
    "header, kind, match, line",
    [
        (None, "emission", "no header.*wavelength_nm,value", 1),
        ("wavelength,value", "emission", "lacks column.*'wavelength_nm'", 1),
        ("wavelength_nm,reflectance", "emission", "'reflectance' is for a reflectance", 1),
        ("wavelength_nm,value", "reflectance", "wavelength_nm,reflectance", 1),
    ],
)
def test_csv_header_errors(tmp_path, header, kind, match, line):
    p = _write(tmp_path, _rows(WL, np.full(WL.size, 0.5)), header)
    with pytest.raises(SpectrumError, match=match) as exc:
        Spectrum.from_csv(p, kind)
    assert exc.value.file == str(p)
    assert exc.value.line == line


def _bad_case(case):
    v = np.full(WL.size, 0.5)
    wl = WL.copy()
    if case == "negative":
        v[5] = -0.1
    elif case == "nan":
        v[5] = np.nan
    elif case == "inf":
        wl[5] = np.inf
    elif case == "duplicate":
        wl[5] = wl[4]
    elif case == "unsorted":
        wl[5], wl[6] = wl[6], wl[5]
    elif case == "reflectance>=1":
        v[5] = 1.0
    return wl, v


@pytest.mark.parametrize(
    "case, kind, match, bad_index",
    [
        ("negative", "emission", "negative", 5),
        ("negative", "reflectance", "negative", 5),
        ("nan", "emission", "not a finite number", 5),
        ("inf", "emission", "not a finite number", 5),
        ("duplicate", "emission", "duplicates the previous 420 nm", 5),
        ("unsorted", "reflectance", "strictly increasing: 430 nm at sample 6", 6),
        ("reflectance>=1", "reflectance", "reflectance must be < 1", 5),
    ],
)
def test_bad_values_raise_with_file_and_line(tmp_path, case, kind, match, bad_index):
    wl, v = _bad_case(case)
    header = "wavelength_nm," + ("value" if kind == "emission" else "reflectance")
    p = _write(tmp_path, _rows(wl, v), header)
    with pytest.raises(SpectrumError, match=match) as exc:
        Spectrum.from_csv(p, kind)
    assert exc.value.file == str(p)
    assert exc.value.line == bad_index + 2  # header is line 1, sample 0 is line 2
    # The same data given directly raise the same error (no file/line then).
    with pytest.raises(SpectrumError, match=match):
        Spectrum(wl, v, kind, "direct")


def test_csv_non_numeric_and_ragged_rows(tmp_path):
    p = _write(tmp_path, "380,0.1\n390,abc\n")
    with pytest.raises(SpectrumError, match="'value' .field 2. is not a number") as exc:
        Spectrum.from_csv(p)
    assert (exc.value.file, exc.value.line) == (str(p), 3)
    assert "abc" not in str(exc.value)  # file text is never echoed (docs/config.md, "Paths")
    p = _write(tmp_path, "380,0.1\n390,0.2,7\n")
    with pytest.raises(SpectrumError, match="3 fields") as exc:
        Spectrum.from_csv(p)
    assert exc.value.line == 3


def test_csv_missing_empty_file(tmp_path):
    with pytest.raises(SpectrumError, match="not found") as exc:
        Spectrum.from_csv(tmp_path / "nope.csv")
    assert exc.value.file == str(tmp_path / "nope.csv")
    p = _write(tmp_path, "", header=None)
    with pytest.raises(SpectrumError, match="empty"):
        Spectrum.from_csv(p)
    p = _write(tmp_path, "")
    with pytest.raises(SpectrumError, match="no data rows"):
        Spectrum.from_csv(p)


def test_csv_coverage_error_and_all_zero_name_file(tmp_path):
    wl = np.arange(420.0, 781.0, 10.0)
    p = _write(tmp_path, _rows(wl, np.ones(wl.size)))
    with pytest.raises(SpectrumError, match="cover 420-780 nm") as exc:
        Spectrum.from_csv(p)
    assert exc.value.file == str(p)
    p = _write(tmp_path, _rows(WL, np.zeros(WL.size)))
    with pytest.raises(SpectrumError, match="zero everywhere") as exc:
        Spectrum.from_csv(p)
    assert exc.value.file == str(p)


# -------------------------------------------------------------------- direct validation
def test_all_zero_emission_is_an_error_but_black_reflectance_is_not():
    with pytest.raises(SpectrumError, match="zero everywhere"):
        Spectrum(WL, np.zeros(WL.size), "emission")
    black = Spectrum(WL, np.zeros(WL.size), "reflectance")
    assert black.at(555.0) == 0.0


def test_shape_and_kind_errors():
    with pytest.raises(SpectrumError, match="pair up"):
        Spectrum(WL, np.ones(3), "emission")
    with pytest.raises(SpectrumError, match="at least 2"):
        Spectrum([550.0], [1.0], "emission")
    with pytest.raises(SpectrumError, match="kind must be"):
        Spectrum(WL, np.ones(WL.size), "glow")
    with pytest.raises(SpectrumError, match="percent"):
        Spectrum(WL, np.full(WL.size, 50.0), "reflectance")
    with pytest.raises(SpectrumError, match="in nm"):
        Spectrum(WL / 1000.0, np.ones(WL.size), "emission")


def test_immutable_and_copies_input():
    v = np.ones(WL.size)
    s = Spectrum(WL, v, "emission", "flat")
    v[0] = 5.0
    assert s.values[0] == 1.0
    with pytest.raises(ValueError):
        s.values[0] = 2.0
    with pytest.raises(AttributeError):
        s.name = "other"  # type: ignore[misc]
    assert hash(s) == hash(Spectrum(WL, np.ones(WL.size), "emission", "flat"))


# ------------------------------------------------------------------------ extrapolation
def test_small_gap_warns_and_extrapolates_zero_for_emission():
    wl = np.arange(390.0, 771.0, 10.0)  # 10 nm short at both ends
    with pytest.warns(LumijaxWarning, match="extrapolated as zero"):
        s = Spectrum(wl, np.ones(wl.size), "emission", "led")
    np.testing.assert_array_equal(s.at([380.0, 385.0, 775.0, 800.0]), 0.0)
    assert s.at(390.0) == 1.0 and s.at(395.0) == 1.0


def test_small_gap_warns_and_extrapolates_constant_for_reflectance():
    wl = np.arange(400.0, 761.0, 10.0)  # exactly 20 nm short at both ends: allowed
    v = np.linspace(0.2, 0.6, wl.size)
    with pytest.warns(LumijaxWarning, match="as the end value"):
        s = Spectrum(wl, v, "reflectance", "paint")
    np.testing.assert_allclose(s.at([300.0, 380.0, 780.0, 900.0]), [0.2, 0.2, 0.6, 0.6])


def test_gap_over_20_nm_is_an_error():
    wl = np.arange(380.0, 759.0, 1.0)  # ends at 758: 22 nm short
    with pytest.raises(SpectrumError, match="at most 20 nm"):
        Spectrum(wl, np.ones(wl.size), "emission")


def test_full_coverage_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Spectrum(WL, np.ones(WL.size), "emission")
        Spectrum.from_name("D65")


def test_at_interpolates_linearly_and_never_nan():
    s = Spectrum([380.0, 580.0, 780.0], [0.0, 2.0, 0.0], "emission")
    assert s(480.0) == pytest.approx(1.0)
    assert s.at(np.array([[380.0, 680.0]])).shape == (1, 2)
    y = s.at(np.linspace(0, 2000, 1001))
    assert np.all(np.isfinite(y))
    with pytest.raises(SpectrumError):
        s.at(np.nan)


def test_resample():
    s = Spectrum.from_name("A")
    r = s.resample(np.arange(380.0, 831.0, 1.0))
    assert r.name == "A" and r.kind == "emission"
    assert r.at(560.0) == pytest.approx(s.at(560.0))
    assert r.at(562.5) == pytest.approx(np.interp(562.5, s.wavelengths_nm, s.values), rel=1e-3)
    np.testing.assert_array_equal(r.at(np.arange(781.0, 831.0)), 0.0)  # A stops at 780
    with pytest.raises(SpectrumError, match="strictly increasing"):
        s.resample([500.0, 400.0])


def test_to_colour():
    s = Spectrum.from_name("dark skin", "reflectance")
    sd = s.to_colour()
    np.testing.assert_array_equal(sd.wavelengths, s.wavelengths_nm)
    np.testing.assert_array_equal(sd.values, s.values)


# ------------------------------------------------------------------------------- grey, sRGB
def test_grey():
    g = Spectrum.grey(0.4)
    assert g.kind == "reflectance"
    np.testing.assert_array_equal(g.at([300.0, 555.0, 900.0]), 0.4)
    with pytest.raises(SpectrumError, match="< 1"):
        Spectrum.grey(1.0)
    with pytest.raises(SpectrumError, match="negative"):
        Spectrum.grey(-0.1)


def test_from_srgb_validation():
    with pytest.raises(SpectrumError, match="255"):
        Spectrum.from_srgb([128, 128, 128])
    with pytest.raises(SpectrumError, match="3 finite numbers"):
        Spectrum.from_srgb([0.5, 0.5])
    with pytest.raises(SpectrumError, match="reflectance must be < 1"):
        Spectrum.from_srgb([1.0, 1.0, 1.0])
    red = Spectrum.from_srgb([0.8, 0.1, 0.1])
    assert red.at(650.0) > 3 * red.at(450.0)
    assert np.all((red.values >= 0) & (red.values < 1))
