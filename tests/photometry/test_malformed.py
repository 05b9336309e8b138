"""Malformed files raise PhotometryError naming the file and the line."""

from __future__ import annotations

import pytest

from lumijax.errors import LumijaxWarning, PhotometryError
from lumijax.photometry import read_photometry

# A small valid LM-63-2002 file; line numbers below refer to this text.
GOOD = [
    "IESNA:LM-63-2002",  # 1
    "[TEST] synthetic",  # 2
    "[MANUFAC] lumijax tests",  # 3
    "TILT=NONE",  # 4
    "1 -1 1 5 3 1 2 0.1 0.2 0",  # 5
    "1 1 10",  # 6
    "0 22.5 45 67.5 90",  # 7
    "0 90 180",  # 8
    "100 90 70 40 10",  # 9
    "100 85 60 30 5",  # 10
    "100 80 50 20 0",  # 11
]


def _write(tmp_path, lines, name="bad.ies"):
    path = tmp_path / name
    path.write_text("\r\n".join(lines) + "\r\n", encoding="latin-1")
    return path


def _expect(tmp_path, lines, line, match, name="bad.ies"):
    path = _write(tmp_path, lines, name)
    with pytest.raises(PhotometryError, match=match) as info:
        read_photometry(path)
    err = info.value
    assert err.file == str(path)
    assert err.line == line
    assert f"{path}:{line}" in str(err)
    return err


def test_good_file_reads(tmp_path):
    p = read_photometry(_write(tmp_path, GOOD, "good.ies"))
    assert p.distribution.candela.shape == (5, 5)  # 0–180 expanded to 0,90,180,270,360


def test_truncated(tmp_path):
    _expect(tmp_path, GOOD[:-1], 10, "ends early")


def test_wrong_counts_left_over(tmp_path):
    lines = GOOD.copy()
    lines[4] = "1 -1 1 5 2 1 2 0.1 0.2 0"  # 2 horizontal angles declared, 3 planes given
    lines[7] = "0 180"
    _expect(tmp_path, lines, 11, "left over")


def test_wrong_counts_too_many_declared(tmp_path):
    lines = GOOD.copy()
    lines[4] = "1 -1 1 6 3 1 2 0.1 0.2 0"  # 6 vertical angles declared, rows of 5 given
    lines[6] = "0 22.5 45 67.5 90 112.5"
    _expect(tmp_path, lines, 11, "ends early")


def test_non_numeric_token(tmp_path):
    lines = GOOD.copy()
    lines[9] = "100 85 6O 30 5"  # letter O instead of zero
    err = _expect(tmp_path, lines, 10, "value 8 of 15.*text of 2 characters")
    assert "candela" in err.message


def test_negative_candela(tmp_path):
    lines = GOOD.copy()
    lines[10] = "100 80 -50 20 0"
    _expect(tmp_path, lines, 11, "negative candela")


def test_missing_tilt(tmp_path):
    lines = [ln for ln in GOOD if not ln.startswith("TILT")]
    _expect(tmp_path, lines, len(lines), "TILT")


def test_unknown_photometric_type(tmp_path):
    lines = GOOD.copy()
    lines[4] = "1 -1 1 5 3 4 2 0.1 0.2 0"
    _expect(tmp_path, lines, 5, "photometric type 4")


def test_angles_not_ascending(tmp_path):
    lines = GOOD.copy()
    lines[6] = "0 22.5 67.5 45 90"
    _expect(tmp_path, lines, 7, "ascending")


def test_tilt_file_missing_and_present(tmp_path):
    lines = GOOD.copy()
    lines[3] = "TILT=lamp.tlt"
    _expect(tmp_path, lines, 4, "TILT= names .text of 8 characters. was not found")
    (tmp_path / "lamp.tlt").write_text("2\n3\n0 45\n90\n1 0.9 0.7\n")
    p = read_photometry(tmp_path / "bad.ies")
    assert p.tilt.geometry == 2 and p.tilt.factors == (1.0, 0.9, 0.7)


def test_tilt_include_wrapped_tokens_and_commas(tmp_path):
    lines = GOOD[:3] + ["TILT=INCLUDE", "1", "2 0", "90, 1.0,", "0.5"] + GOOD[4:]
    p = read_photometry(_write(tmp_path, lines, "tilt.ies"))
    assert p.tilt.angles_deg == (0.0, 90.0) and p.tilt.factors == (1.0, 0.5)


def test_not_photometry(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("hello\nworld\n")
    with pytest.raises(PhotometryError, match="not a photometric file"):
        read_photometry(path)


def test_missing_file(tmp_path):
    with pytest.raises(PhotometryError, match="not found"):
        read_photometry(tmp_path / "nope.ies")


def _ldt_lines():
    head = ["Co", "1", "1", "4", "90", "3", "45", "r", "n", "num", "f", "d"]
    head += ["100", "0", "50", "80", "0", "0", "0", "0", "0", "100", "100", "1", "0", "1"]
    head += ["1", "LED 7,9W", "1000", "3000", "80", "10"]
    head += ["0.5"] * 10 + ["0", "90", "180", "270"] + ["0", "45", "90"] + ["300", "200", "0"]
    return head


def test_ldt_good_and_malformed(tmp_path):
    good = _ldt_lines()
    with pytest.warns(LumijaxWarning, match="good.ldt"):  # 851 lm of table vs 1000 lm header
        p = read_photometry(_write(tmp_path, good, "good.ldt"))
    assert p.format == "ldt" and float(p.distribution.candela[0, 1]) == pytest.approx(200.0)
    bad = good.copy()
    bad[len(good) - 2] = "2OO"
    _expect(tmp_path, bad, len(good) - 1, "text of 3 characters", name="bad.ldt")
    _expect(tmp_path, good[:-1], len(good) - 1, "ends early", name="short.ldt")
    neg = good.copy()
    neg[-1] = "-3"
    _expect(tmp_path, neg, len(good), "negative", name="neg.ldt")
    _expect(tmp_path, good + ["7"], len(good) + 1, "counts", name="long.ldt")
