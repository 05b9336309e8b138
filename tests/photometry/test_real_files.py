"""The real files in ../shared/photometry: parsing, flux references, twins, symmetry, warnings."""

from __future__ import annotations

import warnings
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.errors import LumijaxWarning
from lumijax.photometry import Photometry, read_photometry

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "photometry"

ALL_FILES = (
    sorted(p.name for p in SHARED.glob("*") if p.suffix.lower() in (".ies", ".ldt"))
    if SHARED.is_dir()
    else []
)

TWINS = [
    "lx_Testlamp_Isym1_007cfb11e343e2f42e3b476be4ab684e",
    "lx_Testlamp_Isym2_theta180+_erco_33499000_1xqt32_230w",
    "lx_Testlamp_Isym3_symmetryOverC90C270axis",
    "lx_Testlamp_Isym4_43cef5d76a391dd85c41d4d09d68600d",
]

# Files whose headers disagree with their own data (PROVENANCE.md); the Isym3 IES twin states
# 102.52 lm of lamp lumens for a 6151 lm table.
INCONSISTENT = [
    "lx_luxpy_test_lid_file2b.ies",
    "er_TILT_TEST_SYNTHETIC.ies",
    "dl_multiple_lamp_sets.ldt",
    "lx_Testlamp_Isym3_symmetryOverC90C270axis.ies",
]


def _load(shared, name) -> Photometry:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LumijaxWarning)
        return read_photometry(shared / name)


def _twin(shared, stem, ext) -> Path:
    (path,) = [p for p in shared.glob(stem + ".*") if p.suffix.lower() == ext]
    return path


def _random_dirs(n=4000, seed=0):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_folder_has_files(shared):
    assert len(ALL_FILES) >= 19


@pytest.mark.parametrize("name", ALL_FILES)
def test_every_file_parses(shared, name):
    p = _load(shared, name)
    dist = p.distribution
    assert p.format == ("ldt" if name.lower().endswith(".ldt") else "ies")
    assert np.all(np.diff(np.asarray(dist.h_deg)) > 0)
    assert np.all(np.diff(np.asarray(dist.v_deg)) > 0)
    assert np.all(np.asarray(dist.candela) >= 0)
    assert p.integrated_lm > 0
    assert float(dist.flux()) == pytest.approx(p.integrated_lm, rel=1e-4)
    if dist.photometric_type == "C":
        assert float(dist.h_deg[0]) == 0.0 and float(dist.h_deg[-1]) == 360.0


# (file, reference lm, relative tolerance, what the reference is)
FLUX_REFERENCES = [
    ("er_OutdoorRoadway_IES_OS_8988-2022_03_AM01_60W_4000K.ies", 9155.7, 0.005, "header lumens"),
    # The next two are rough independent integrations (PROVENANCE.md), hence the 1.5 % tolerance.
    ("ew_flood_2.1.IES", 10730.0, 0.015, "independent integration"),
    ("er_ITALO_1_5P5_S05_3.140-3M.IES", 10580.0, 0.015, "independent integration"),
]


@pytest.mark.parametrize("name, ref, tol, what", FLUX_REFERENCES)
def test_flux_against_references(shared, name, ref, tol, what):
    assert _load(shared, name).integrated_lm == pytest.approx(ref, rel=tol), what


@pytest.mark.parametrize("name", [n for n in ALL_FILES if n.lower().endswith(".ldt")])
def test_ldt_flux_is_lor_times_lamp_flux(shared, name):
    p = _load(shared, name)
    if name == "dl_multiple_lamp_sets.ldt":  # synthetic, ~90 % (PROVENANCE.md)
        assert p.warnings
        return
    assert p.integrated_lm == pytest.approx(p.lor * p.lamp_lm, rel=0.005)
    assert p.rated_lm == pytest.approx(p.lor * p.lamp_lm)
    assert not p.warnings


@pytest.mark.parametrize("stem", TWINS)
def test_twins_same_flux_and_intensity(shared, stem):
    ies = _load(shared, _twin(shared, stem, ".ies").name)
    ldt = _load(shared, _twin(shared, stem, ".ldt").name)
    # Reference: the LDT header's LORL × lamp flux.
    assert ies.integrated_lm == pytest.approx(ldt.rated_lm, rel=0.005)
    d = jnp.asarray(_random_dirs())
    a = np.asarray(ies.distribution.intensity(d))
    b = np.asarray(ldt.distribution.intensity(d))
    peak = max(a.max(), b.max())
    np.testing.assert_allclose(a, b, atol=1e-3 * peak)


def test_isym3_row_order_regression(shared):
    """LDT Isym 3 stores C270 → C0 → C90: row k is IES H = 270 + 15 k (FORMATS.md §2)."""
    stem = "lx_Testlamp_Isym3_symmetryOverC90C270axis"
    ldt = _load(shared, stem + ".ldt")
    ies = _load(shared, stem + ".ies")
    dl, di = ldt.distribution, ies.distribution
    for c in (90.0, 135.0, 180.0, 225.0, 270.0, 300.0, 0.0, 45.0):
        i = int(np.argmin(np.abs(np.asarray(dl.h_deg) - c)))
        j = int(np.argmin(np.abs(np.asarray(di.h_deg) - c)))
        np.testing.assert_allclose(
            dl.candela[i, 1:], di.candela[j, 1:], rtol=2e-3
        )  # IES rounded to 0.01 cd
    # The test discriminates: the C90 and C270 sides differ, C0 and C180 agree (90–270 symmetry).
    at = {
        c: np.asarray(dl.candela[int(np.argmin(np.abs(np.asarray(dl.h_deg) - c)))])
        for c in (0.0, 90.0, 180.0, 270.0)
    }
    assert np.max(np.abs(at[90.0] - at[270.0])) > 0.05 * np.max(at[90.0])
    np.testing.assert_allclose(at[0.0], at[180.0])
    # Intensity towards +y_l (C90) and −y_l (C270) at γ = 40° follows the same rows.
    for c in (90.0, 270.0):
        d = dl.direction(c, 40.0)
        assert float(dl.intensity(d)) == pytest.approx(float(di.intensity(d)), rel=1e-5)


@pytest.mark.parametrize("name", INCONSISTENT)
def test_inconsistent_headers_load_and_warn(shared, name):
    with pytest.warns(LumijaxWarning, match=r"\d+\.\d lm") as rec:
        p = read_photometry(shared / name)
    assert any(name in str(w.message) for w in rec)
    assert p.warnings and name in p.warnings[0]


def test_consistent_files_do_not_warn(shared):
    for name in ALL_FILES:
        if name in INCONSISTENT:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error", LumijaxWarning)
            read_photometry(shared / name)


def test_header_details(shared):
    tilt = _load(shared, "er_TILT_TEST_SYNTHETIC.ies")
    assert tilt.tilt is not None and tilt.tilt.geometry == 1
    assert tilt.tilt.angles_deg == (0.0, 45.0, 90.0, 180.0)
    assert float(tilt.tilt.factor(22.5)) == pytest.approx(0.95)
    assert tilt.rated_lm == 1000.0

    imperial = _load(shared, "dl_ies95_imperial_units.ies")
    op = imperial.opening
    assert (op.width_m, op.length_m, op.height_m) == pytest.approx(
        (0.12 * 0.3048, 0.34 * 0.3048, 0.56 * 0.3048)
    )
    assert op.shape == "box"
    assert imperial.rated_lm is None and imperial.version == "1995"
    assert "[MORE]" not in imperial.keywords["LUMINAIRE"]
    assert imperial.keywords["LUMINAIRE"].splitlines()[-1] == "Licensed under MIT License"

    cyl = _load(shared, "dl_ies95_horizontal_cylinder_opening_along_length.ies").opening
    assert cyl.shape == "horizontal_cylinder_along"
    assert (cyl.length_m, cyl.width_m, cyl.height_m) == pytest.approx((0.12, 0.34, 0.34))

    disk = _load(shared, "lx_Testlamp_Isym1_007cfb11e343e2f42e3b476be4ab684e.ies").opening
    assert disk.shape == "disk" and disk.length_m == pytest.approx(0.08)

    old = _load(shared, "lx_luxpy_test_lid_file2b.ies")
    assert old.version == "1986" and "REPORT NUMBER" in old.keywords["LABEL"]
    assert old.opening.length_m == pytest.approx(4 * 0.3048)

    sets = _load(shared, "dl_multiple_lamp_sets.ldt")
    assert [s.flux_lm for s in sets.lamp_sets] == [500.0, 1200.0, 500.0]
    assert sets.lamp_lm == 500.0

    absolute = _load(shared, "lx_Testlamp_Isym1_007cfb11e343e2f42e3b476be4ab684e.ldt")
    assert absolute.lamp_sets[0].count == -1 and absolute.rated_lm == 321.0
    assert absolute.lamp_sets[0].lamp_type == "LED  7,9W"  # the comma in a text line survives

    road = _load(shared, "er_road_luminaire.ldt")
    assert road.opening.shape == "vertical_cylinder" and road.opening.height_m == pytest.approx(
        0.14
    )

    flood = _load(shared, "ew_flood_2.1.IES")
    assert flood.distribution.photometric_type == "B"
    assert float(flood.distribution.h_deg[0]) == -90.0  # lateral symmetry expanded
    assert flood.keywords["_ABSOLUTELUMENS"] == "10601"
