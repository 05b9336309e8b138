"""Fuzzing both readers (hypothesis): any bytes give a valid distribution or a LumijaxError.

Mutated real files (../shared/photometry; skipped without it) and generated ones: byte and bit
flips, truncation, numeric tokens replaced by negatives, NaN, inf, huge or empty values, line
edits, odd TILT= lines, UTF-16. The outcome must be either a ``Photometry`` whose candela table
and flux are finite and non-negative, or a ``LumijaxError`` subclass; nothing else may escape.
Bounded by ``max_examples`` (a few seconds each); ``benchmarks/fuzz_photometry.py`` runs longer.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from lumijax.errors import LumijaxError
from lumijax.photometry import read_photometry

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "photometry"
FILES = (
    sorted(p for p in SHARED.iterdir() if p.suffix.lower() in (".ies", ".ldt"))
    if SHARED.is_dir()
    else []
)
IES_FILES = [p for p in FILES if p.suffix.lower() == ".ies"]
LDT_FILES = [p for p in FILES if p.suffix.lower() == ".ldt"]

FUZZ = settings(
    max_examples=150,
    deadline=None,  # the machine is shared; a hang would show as a slow test, not a flake
    database=None,  # leave nothing behind in the checkout
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)

_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
TOKENS = [
    b"-1", b"0", b"-0", b"nan", b"inf", b"-inf", b"1e39", b"3.5e38", b"1e308", b"1e-320", b"",
    b"abc", b"1,5", b"99999", b"2", b"1", b"90", b"180", b"360", b"-90", b"0.0001",
]
TILTS = [b"TILT=/etc/passwd", b"TILT=../../x", b"TILT=" + b"a" * 300, b"TILT=a\x00b",
         b"TILT=.", b"TILT=INCLUDE", b"TILT=/dev/zero"]

# A mutation is (kind, position in [0, 1), a number, a token); kinds below.
MUTATION = st.tuples(
    st.sampled_from(["flip", "bit", "truncate", "delete", "duplicate", "token", "tokens",
                     "line", "tilt", "utf16"]),
    st.floats(0.0, 1.0, exclude_max=True),
    st.integers(0, 255),
    st.sampled_from(TOKENS),
)


def mutate(data: bytes, mutation) -> bytes:
    kind, where, byte, token = mutation
    n = len(data)
    k = int(where * n)
    if n == 0:
        return bytes([byte])
    if kind == "flip":
        return data[:k] + bytes([byte]) + data[k + 1 :]
    if kind == "bit":
        return data[:k] + bytes([data[k] ^ (1 << (byte % 8))]) + data[k + 1 :]
    if kind == "truncate":
        return data[:k]
    if kind == "delete":
        return data[:k] + data[k + 1 + byte % 64 :]
    if kind == "duplicate":
        return data[:k] + data[k : k + 1 + byte % 64] + data[k:]
    if kind in ("token", "tokens"):
        matches = list(_NUMBER.finditer(data))
        if not matches:
            return data
        chosen = [matches[int(where * len(matches))]]
        if kind == "tokens":  # the same token in several places (counts and angles together)
            chosen = matches[int(where * len(matches)) :: 1 + byte][:4]
        for m in sorted(chosen, key=lambda m: -m.start()):
            data = data[: m.start()] + token + data[m.end() :]
        return data
    lines = data.split(b"\n")
    i = int(where * len(lines))
    if kind == "line":
        if byte % 3 == 0:
            del lines[i]
        elif byte % 3 == 1:
            lines.insert(i, lines[(i + byte) % len(lines)])
        else:
            lines.insert(i, token)
        return b"\n".join(lines)
    if kind == "tilt":
        for j, line in enumerate(lines):
            if line.lstrip().upper().startswith(b"TILT"):
                lines[j] = TILTS[byte % len(TILTS)]
                break
        return b"\n".join(lines)
    out = data.decode("latin-1").encode("utf-16")
    return out[: int(where * len(out))] if byte % 4 == 0 else out


def check(path: Path) -> str:
    """The outcome of reading ``path``: ``"accepted"`` or ``"refused"``; anything else fails."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p = read_photometry(path)
    except LumijaxError:
        return "refused"
    cd = np.asarray(p.distribution.candela)
    assert np.all(np.isfinite(cd)) and np.all(cd >= 0), (cd.min(), cd.max())
    assert np.isfinite(p.integrated_lm) and p.integrated_lm >= 0
    h, v = np.asarray(p.distribution.h_deg), np.asarray(p.distribution.v_deg)
    assert np.all(np.isfinite(h)) and np.all(np.isfinite(v))
    return "accepted"


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    # One folder down, so that "TILT=../../x" leaves the photometric file's folder.
    folder = tmp_path_factory.mktemp("fuzz") / "in"
    folder.mkdir()
    return folder


def _fuzz(scratch, seed: Path, mutations) -> str:
    data = seed.read_bytes()
    for m in mutations:
        data = mutate(data, m)
    path = scratch / ("input" + seed.suffix)
    path.write_bytes(data)
    return check(path)


def _fuzz_test(files):
    """A fuzz test of one reader: 1 to 4 mutations of one of its real ``files``."""
    @pytest.mark.skipif(not files, reason="the shared photometry folder is not available")
    @FUZZ
    @given(seed=st.sampled_from(files or [Path("none")]),
           mutations=st.lists(MUTATION, min_size=1, max_size=4))
    def test(scratch, seed, mutations):
        _fuzz(scratch, seed, mutations)

    return test


test_fuzz_ies_reader = _fuzz_test(IES_FILES)
test_fuzz_ldt_reader = _fuzz_test(LDT_FILES)


# Generated files: a valid-looking header and a numeric section of arbitrary tokens, so the
# counts, angles and table are exercised without a real file (runs without ../shared too).
NUMBERS = st.one_of(
    st.sampled_from(["0", "1", "2", "3", "5", "90", "180", "360", "-90", "-1", "nan", "1e39"]),
    st.floats(-400, 400, allow_nan=False).map(lambda x: f"{x:.3g}"),
    st.integers(0, 12).map(str),
)


@FUZZ
@given(head=st.lists(NUMBERS, min_size=13, max_size=13),
       body=st.lists(NUMBERS, min_size=0, max_size=80),
       tilt=st.sampled_from(["NONE", "INCLUDE"]))
def test_fuzz_generated_ies(scratch, head, body, tilt):
    # Plausible counts most of the time: the header's nV, nH, type and units.
    head[3], head[4] = str(len(body) % 7 + 1), str(len(body) % 5 + 1)
    text = f"IESNA:LM-63-2002\n[TEST] fuzz\nTILT={tilt}\n" + " ".join(head + body) + "\n"
    path = scratch / "gen.ies"
    path.write_text(text, encoding="latin-1")
    check(path)


@FUZZ
@given(isym=st.integers(0, 4), mc=st.integers(1, 8), ng=st.integers(2, 6),
       body=st.lists(NUMBERS, min_size=0, max_size=60))
def test_fuzz_generated_ldt(scratch, isym, mc, ng, body):
    head = ["Co", "1", str(isym), str(mc), "90", str(ng), "45", "r", "n", "num", "f", "d"]
    head += ["100", "0", "50", "80", "0", "0", "0", "0", "0", "100", "100", "1", "0", "1"]
    head += ["1", "LED", "1000", "3000", "80", "10"] + ["0.5"] * 10
    path = scratch / "gen.ldt"
    path.write_text("\n".join(head + body) + "\n", encoding="latin-1")
    check(path)


@FUZZ
@given(data=st.binary(max_size=400),
       prefix=st.sampled_from([b"", b"IESNA:LM-63-2002\nTILT=NONE\n", b"\xff\xfe", b"Co\n1\n1\n"]))
def test_fuzz_arbitrary_bytes(scratch, data, prefix):
    path = scratch / "raw.ies"
    path.write_bytes(prefix + data)
    check(path)
