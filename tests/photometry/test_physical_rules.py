"""Photometry that cannot be physical is refused, precisely (file, line, value); TILT=<file> safety.

Every file here is hand-made and small; line numbers in the comments refer to its text.
"""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

from lumijax.errors import LumijaxWarning, PhotometryError
from lumijax.photometry import read_photometry

IES = [
    "IESNA:LM-63-2002",  # 1
    "[TEST] synthetic",  # 2
    "TILT=NONE",  # 3
    "1 -1 1 5 3 1 2 0.1 0.2 0",  # 4: lamps, lm, multiplier, nV, nH, type, units, w, l, h
    "1 1 10",  # 5: ballast, future use, watts
    "0 22.5 45 67.5 90",  # 6
    "0 90 180",  # 7
    "100 90 70 40 10",  # 8
    "100 85 60 30 5",  # 9
    "100 80 50 20 0",  # 10
]


def _write(tmp_path, lines, name="t.ies", *, encoding="latin-1", newline="\r\n"):
    path = tmp_path / name
    path.write_bytes((newline.join(lines) + newline).encode(encoding))
    return path


def _refused(path, line, match, **kw):
    with pytest.raises(PhotometryError, match=match) as info:
        read_photometry(path, **kw)
    err = info.value
    assert err.line == line, str(err)
    return err


def _read(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LumijaxWarning)
        return read_photometry(path, **kw)


def _edit(lines, k, text):
    out = list(lines)
    out[k - 1] = text
    return out


def test_the_template_reads(tmp_path):
    p = _read(_write(tmp_path, IES))
    assert p.distribution.candela.shape == (5, 5)


# ---- multipliers ------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["0", "-1", "-0.5"])
def test_candela_multiplier_must_be_positive(tmp_path, value):
    path = _write(tmp_path, _edit(IES, 4, f"1 -1 {value} 5 3 1 2 0.1 0.2 0"))
    err = _refused(path, 4, "candela multiplier must be positive")
    assert f"found {float(value):g}" in err.message


@pytest.mark.parametrize("value", ["0", "-1"])
def test_ballast_factor_must_be_positive(tmp_path, value):
    _refused(_write(tmp_path, _edit(IES, 5, f"{value} 1 10")), 5, "ballast factor must be positive")


def test_ballast_lamp_factor_1986_must_be_positive_but_future_use_is_free(tmp_path):
    old = ["a 1986 file", "TILT=NONE"] + IES[3:]
    assert _read(_write(tmp_path, old, "old.ies")).version == "1986"
    _refused(_write(tmp_path, _edit(old, 4, "1 0 10"), "old0.ies"), 4, "ballast-lamp")
    # In LM-63-2002 the second value is "future use": a 0 there scales nothing.
    p = _read(_write(tmp_path, _edit(IES, 5, "1 0 10")))
    assert float(p.distribution.candela[0, 1]) == pytest.approx(90.0)


def _with_tilt(block):
    return IES[:2] + ["TILT=INCLUDE"] + block + IES[3:]


def test_tilt_factors_must_be_positive(tmp_path):
    assert _read(_write(tmp_path, _with_tilt(["1", "3", "0 45 90", "1 0.9 0.8"]))).tilt
    for bad in ("0", "-0.9"):
        path = _write(tmp_path, _with_tilt(["1", "3", "0 45 90", f"1 {bad} 0.8"]))
        err = _refused(path, 7, "tilt multiplying factors must be positive")
        assert "factor 2 of 3" in err.message


# ---- intensities -------------------------------------------------------------------------------


@pytest.mark.parametrize("token", ["nan", "inf", "-inf", "NaN"])
def test_non_finite_candela_refused(tmp_path, token):
    path = _write(tmp_path, _edit(IES, 9, f"100 85 {token} 30 5"))
    err = _refused(path, 9, "must be a finite number")
    assert f"found {float(token)}" in err.message


def test_candela_beyond_float32_refused_also_after_the_multiplier(tmp_path):
    _refused(_write(tmp_path, _edit(IES, 9, "100 85 1e39 30 5")), 9, "float32")
    assert _read(_write(tmp_path, _edit(IES, 9, "100 85 3e38 30 5")))  # fits as given
    lines = _edit(_edit(IES, 9, "100 85 3e38 30 5"), 4, "1 -1 10 5 3 1 2 0.1 0.2 0")
    err = _refused(_write(tmp_path, lines), 9, "multiplier 10")
    assert "3e+38" in err.message
    lines = _edit(_edit(IES, 9, "100 85 3e38 30 5"), 5, "2 1 10")  # ballast factor 2
    _refused(_write(tmp_path, lines), 9, "float32")


def test_negative_candela_still_refused(tmp_path):
    _refused(_write(tmp_path, _edit(IES, 10, "100 80 -50 20 0")), 10, "negative candela")


# ---- angles --------------------------------------------------------------------------------------


def _type_ab(ptype, v, h):
    n = len(v) * len(h)
    return [
        "IESNA:LM-63-2002",
        "TILT=NONE",
        f"1 -1 1 {len(v)} {len(h)} {ptype} 2 0 0 0",  # 3
        "1 1 10",  # 4
        " ".join(v),  # 5
        " ".join(h),  # 6
        " ".join(["100"] * n),  # 7
    ]


def test_type_a_vertical_and_type_b_horizontal_angles_are_latitudes(tmp_path):
    assert _read(_write(tmp_path, _type_ab(3, ["-90", "0", "90"], ["-180", "0", "180"])))
    assert _read(_write(tmp_path, _type_ab(2, ["-180", "0", "180"], ["-90", "0", "90"])))
    err = _refused(_write(tmp_path, _type_ab(3, ["0", "45", "95"], ["0", "90"])), 5,
                   "Type A vertical angles must lie in −90…90")
    assert "found 95" in err.message
    _refused(_write(tmp_path, _type_ab(2, ["0", "45"], ["-91", "0", "90"])), 6,
             "Type B horizontal angles must lie in −90…90")
    _refused(_write(tmp_path, _type_ab(2, ["0", "181"], ["0", "90"])), 5,
             "Type B vertical angles must lie in −180…180")


def test_single_vertical_angle_refused(tmp_path):
    lines = IES[:3] + ["1 -1 1 1 3 1 2 0.1 0.2 0", "1 1 10", "0", "0 90 180", "100 100 100"]
    _refused(_write(tmp_path, lines), 4, "single vertical angle")
    lines = _type_ab(2, ["-45", "45"], ["10"])
    _refused(_write(tmp_path, lines), 3, "single horizontal angle")


def test_type_c_vertical_range(tmp_path):
    _refused(_write(tmp_path, _edit(IES, 6, "0 22.5 45 67.5 190")), 6, "must lie in 0…180")


# ---- header counts that disagree with the data -------------------------------------------------


def test_horizontal_count_disagrees(tmp_path):
    # 3 horizontal angles declared, 2 given with a 2 × 5 table: the data fit 2 exactly.
    lines = _edit(IES, 7, "0 90")[:-1]
    err = _refused(_write(tmp_path, lines), 4, "the header declares 3 horizontal angle")
    assert "2 are given" in err.message and "ascending" not in err.message


def test_vertical_count_disagrees(tmp_path):
    # 6 vertical angles declared, 5 given with the 3 × 5 table.
    lines = _edit(IES, 4, "1 -1 1 6 3 1 2 0.1 0.2 0")
    err = _refused(_write(tmp_path, lines), 4, "the header declares 6 vertical angle")
    assert "5 are given" in err.message


def test_tilt_include_count_disagrees(tmp_path):
    path = _write(tmp_path, _with_tilt(["1", "4", "0 45 90", "1 0.9 0.8"]))
    err = _refused(path, 5, "TILT=INCLUDE block declares 4 tilt angle")
    assert "3 are given" in err.message


def test_tilt_file_count_disagrees(tmp_path):
    (tmp_path / "lamp.tlt").write_text("1\n4\n0 45 90\n1 0.9 0.8\n")
    path = _write(tmp_path, _edit(IES, 3, "TILT=lamp.tlt"))
    err = _refused(path, 2, "the tilt file declares 4 tilt angle")
    assert err.file == str((tmp_path / "lamp.tlt").resolve())
    (tmp_path / "lamp.tlt").write_text("1\n3\n0 45 90\n1 0.9 0.8\n7 8\n")
    _refused(path, 5, "left over after the tilt table")


def test_counts_that_do_not_explain_the_data_keep_the_precise_error(tmp_path):
    # Counts right, an angle out of order: the ordering error, not a count diagnosis.
    _refused(_write(tmp_path, _edit(IES, 6, "0 22.5 67.5 45 90")), 6, "strictly ascending")


# ---- TILT=<file>: names, folder policy, no echo -----------------------------------------------


def test_tilt_file_name_with_nul_or_too_long(tmp_path):
    _refused(_write(tmp_path, _edit(IES, 3, "TILT=a\x00b")), 3, "NUL")
    _refused(_write(tmp_path, _edit(IES, 3, "TILT=")), 3, "names no file")
    _refused(_write(tmp_path, _edit(IES, 3, "TILT=" + "a" * 300)), 3, "too long")
    _refused(_write(tmp_path, _edit(IES, 3, "TILT=" + "a/" * 3000)), 3, "too long")


def test_tilt_file_that_is_a_directory(tmp_path):
    (tmp_path / "tilts").mkdir()
    _refused(_write(tmp_path, _edit(IES, 3, "TILT=tilts")), 3, "is a directory")


@pytest.mark.parametrize("name", ["/etc/passwd", "../outside.tlt", "sub/../../outside.tlt"])
def test_tilt_file_outside_the_folder_refused_by_default(tmp_path, name):
    inner = tmp_path / "lums"
    inner.mkdir()
    (tmp_path / "outside.tlt").write_text("1\n2\n0 90\n1 0.5\n")
    path = _write(inner, _edit(IES, 3, f"TILT={name}"))
    err = _refused(path, 3, "outside the photometric file's folder")
    assert "allow_outside=True" in err.message
    if not name.startswith("/"):
        assert _read(path, allow_outside=True).tilt.factors == (1.0, 0.5)


def test_tilt_file_in_a_subfolder_is_inside(tmp_path):
    (tmp_path / "tilt").mkdir()
    (tmp_path / "tilt" / "a.tlt").write_text("1\n2\n0 90\n1 0.5\n")
    assert _read(_write(tmp_path, _edit(IES, 3, "TILT=tilt/a.tlt"))).tilt.geometry == 1


@pytest.mark.skipif(not hasattr(os, "symlink"), reason="no symbolic links")
def test_tilt_symlink_leaving_the_folder_refused(tmp_path):
    inner = tmp_path / "lums"
    inner.mkdir()
    (tmp_path / "outside.tlt").write_text("1\n2\n0 90\n1 0.5\n")
    (inner / "link.tlt").symlink_to(tmp_path / "outside.tlt")
    _refused(_write(inner, _edit(IES, 3, "TILT=link.tlt")), 3, "outside")


def test_content_of_a_file_that_is_not_a_tilt_table_is_never_echoed(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("root:x:0:0:SECRET-CONTENT:/root:/bin/bash\nmore SECRET\n")
    inner = tmp_path / "lums"
    inner.mkdir()
    path = _write(inner, _edit(IES, 3, "TILT=../secret.txt"))
    with pytest.raises(PhotometryError) as info:
        read_photometry(path, allow_outside=True)
    assert "SECRET" not in str(info.value) and "root:x" not in str(info.value)
    assert info.value.line == 1 and "expected a number" in info.value.message
    # A tilt file whose numbers run on (a table of another kind): no value is quoted either.
    secret.write_text("1\n2\n0 90\n1 0.5\n12345 SECRET\n")
    with pytest.raises(PhotometryError) as info:
        read_photometry(path, allow_outside=True)
    assert "SECRET" not in str(info.value) and "12345" not in str(info.value)


def test_tokens_of_the_photometric_file_are_never_quoted(tmp_path):
    err = _refused(_write(tmp_path, _edit(IES, 9, "100 85 " + "x" * 500 + " 30 5")), 9,
                   "expected a number")
    assert "xx" not in str(err) and "500 characters" in str(err)


# ---- encodings, lines, paths --------------------------------------------------------------------


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be"])
def test_utf16_with_bom_is_decoded(tmp_path, encoding):
    ref = _read(_write(tmp_path, IES, "ref.ies"))
    path = tmp_path / "u16.ies"
    text = "\r\n".join(IES) + "\r\n"
    data = text.encode(encoding)
    if encoding != "utf-16":  # explicit-endian codecs write no BOM: add it
        data = "\ufeff".encode(encoding) + data
    path.write_bytes(data)
    p = _read(path)
    np.testing.assert_array_equal(p.distribution.candela, ref.distribution.candela)


def test_broken_utf16_and_nul_bytes_refused(tmp_path):
    path = tmp_path / "odd.ies"
    path.write_bytes(("\r\n".join(IES)).encode("utf-16")[:-1])  # odd length
    with pytest.raises(PhotometryError, match="UTF-16"):
        read_photometry(path)
    path.write_bytes(("\r\n".join(IES)).encode("utf-16-le"))  # no BOM: NUL bytes
    with pytest.raises(PhotometryError, match="NUL"):
        read_photometry(path)


def test_line_numbers_ignore_form_feeds_and_nel(tmp_path):
    lines = _edit(IES, 2, "[TEST] a\x0cb\x85c")  # FF and NEL (cp1252 "…") inside a label
    _refused(_write(tmp_path, _edit(lines, 9, "100 85 6O 30 5")), 9, "text of 2 characters")


def test_directory_is_not_not_found(tmp_path):
    with pytest.raises(PhotometryError, match="is a directory") as info:
        read_photometry(tmp_path)
    assert "not found" not in str(info.value)


@pytest.mark.skipif(not os.path.exists("/dev/null"), reason="no /dev/null")
def test_device_refused_without_reading(tmp_path):
    with pytest.raises(PhotometryError, match="not a regular file"):
        read_photometry("/dev/null")


# ---- EULUMDAT -----------------------------------------------------------------------------------


def _ldt(isym=1, c=("0", "90", "180", "270"), g=("0", "45", "90"), rows=None, mc=None, ng=None,
         conv="1", flux="1000"):
    """A small EULUMDAT file; lines 1–41 header, then C angles, γ angles, intensities."""
    mc = len(c) if mc is None else mc
    ng = len(g) if ng is None else ng
    head = ["Co", "1", str(isym), str(mc), "90", str(ng), "45", "r", "n", "num", "f", "d"]
    head += ["100", "0", "50", "80", "0", "0", "0", "0", "0", "100", "100", conv, "0", "1"]
    head += ["1", "LED", flux, "3000", "80", "10"]  # lines 27–32: set 1
    head += ["0.5"] * 10  # lines 33–42
    if rows is None:
        stored = {0: len(c), 1: 1, 2: len(c) // 2 + 1, 3: len(c) // 2 + 1, 4: len(c) // 4 + 1}
        rows = [["300", "200", "0"][: len(g)] + ["0"] * (len(g) - 3)] * stored[isym]
    return head + list(c) + list(g) + [x for row in rows for x in row]


C_FIRST = 43  # line of the first C angle


def test_ldt_template_reads(tmp_path):
    for isym, c in ((1, "0 90 180 270"), (0, "0 90 180 270"), (2, "0 90 180 270"),
                    (3, "0 90 180 270"), (4, "0 90 180 270")):
        p = _read(_write(tmp_path, _ldt(isym, c.split()), f"i{isym}.ldt"))
        assert p.format == "ldt"


def test_ldt_conversion_factor_and_lamp_flux_must_be_positive(tmp_path):
    _refused(_write(tmp_path, _ldt(conv="0"), "a.ldt"), 24, "conversion factor .* must be positive")
    _refused(_write(tmp_path, _ldt(conv="-1"), "a.ldt"), 24, "must be positive")
    _refused(_write(tmp_path, _ldt(flux="0"), "a.ldt"), 29, "lamp flux of set 1 must be positive")
    _refused(_write(tmp_path, _ldt(flux="-5"), "a.ldt"), 29, "found -5")


def test_ldt_intensity_overflow_after_factors(tmp_path):
    rows = [["3e38", "200", "0"]]
    assert _read(_write(tmp_path, _ldt(rows=rows, flux="1000"), "a.ldt"))
    path = _write(tmp_path, _ldt(rows=rows, flux="2000"), "b.ldt")
    err = _refused(path, C_FIRST + 4 + 3, "float32")
    assert "2000 lm" in err.message
    _refused(_write(tmp_path, _ldt(rows=[["nan", "1", "0"]]), "c.ldt"), C_FIRST + 7, "finite")


def test_ldt_isym2_planes_must_reach_c180(tmp_path):
    # Stored planes C0, C45, C90: today they were silently re-mirrored as quadrant symmetry.
    path = _write(tmp_path, _ldt(2, ["0", "45", "90", "135"]), "a.ldt")
    err = _refused(path, C_FIRST + 2, "Isym 2")
    assert "C180" in err.message and "found C90" in err.message


def test_ldt_isym4_planes_must_end_at_c90(tmp_path):
    # Stored planes C0, C180: today they were silently read as bilateral symmetry.
    path = _write(tmp_path, _ldt(4, ["0", "180", "200", "300"]), "a.ldt")
    _refused(path, C_FIRST + 1, "Isym 4 .* C90, found C180")


def test_ldt_isym3_needs_c0(tmp_path):
    # The first C angle is 0.5: today a ValueError from CandelaDistribution escaped.
    path = _write(tmp_path, _ldt(3, ["0.5", "90", "180", "270"]), "a.ldt")
    _refused(path, C_FIRST, "Isym 3 .* C0, found C0.5")
    path = _write(tmp_path, _ldt(3, ["0", "90", "180", "260"]), "b.ldt")
    _refused(path, C_FIRST + 3, "C270, found C260")


def test_ldt_isym0_planes_must_go_round(tmp_path):
    # C0…C180 only: today re-mirrored as if Isym 2 had been declared.
    path = _write(tmp_path, _ldt(0, ["0", "45", "90", "135", "180"]), "a.ldt")
    _refused(path, C_FIRST + 4, "Isym 0 .* whole circle")
    path = _write(tmp_path, _ldt(0, ["0", "90", "180", "200"]), "b.ldt")
    _refused(path, C_FIRST + 3, "gap to C360")
    assert _read(_write(tmp_path, _ldt(0, ["0", "90", "180", "270"]), "c.ldt"))


def test_ldt_mc_count_disagrees(tmp_path):
    c = [str(30 * k) for k in range(12)]
    err = _refused(_write(tmp_path, _ldt(0, c, mc=13), "a.ldt"), 4,
                   "the header declares 13 C planes .*, 12 are given")
    assert "ascending" not in err.message
    _refused(_write(tmp_path, _ldt(1, c, mc=11), "b.ldt"), 4, "declares 11 C planes .*, 12 are")


def test_ldt_ng_count_disagrees(tmp_path):
    lines = _ldt(1, g=("0", "30", "60", "90"), rows=[["3", "2", "1", "0"]], ng=5)
    err = _refused(_write(tmp_path, lines, "a.ldt"), 6, "the header declares 5 γ angles")
    assert "4 are given" in err.message
