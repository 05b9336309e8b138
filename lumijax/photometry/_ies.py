"""IES LM-63 reader (1986, 1991, 1995, 2002, 2019). Format facts: FORMATS.md §1."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np

from ..errors import LumijaxWarning, PhotometryError
from ._distribution import CandelaDistribution
from ._opening import decode_ies_opening
from ._photometry import Photometry, TiltTable, check_header_flux, integrate_np
from ._symmetry import expand_type_ab, expand_type_c

__all__ = ["parse_ies"]

FEET = 0.3048
_SPLIT = re.compile(r"[,\s]+")
_KEYWORD = re.compile(r"^\s*\[([^\]]*)\]\s?(.*)$")
_VERSIONS = (
    ("IESNA:LM-63-1995", "1995"),
    ("IESNA:LM-63-2002", "2002"),
    ("IES:LM-63-2019", "2019"),
    ("IESNA91", "1991"),
)
_TYPE_NAMES = {1: "C", 2: "B", 3: "A"}


def decode_text(raw: bytes) -> str:
    """Latin-1 never fails and keeps ASCII intact; a UTF-8 BOM is dropped."""
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    return raw.decode("latin-1")


class _Tokens:
    """Numbers of a photometric section as a stream that remembers each token's line."""

    def __init__(self, lines: list[str], first_lineno: int, file: Path) -> None:
        self.file = file
        self.items: list[tuple[str, int]] = []
        for k, line in enumerate(lines):
            for tok in _SPLIT.split(line.strip()):
                if tok:
                    self.items.append((tok, first_lineno + k))
        self.pos = 0
        self.last_line = first_lineno + max(len(lines) - 1, 0)

    def remaining(self) -> int:
        return len(self.items) - self.pos

    def number(self, what: str) -> tuple[float, int]:
        if self.pos >= len(self.items):
            raise PhotometryError(
                f"the file ends early: expected {what} but found no more values (truncated file?)",
                file=self.file,
                line=self.last_line,
            )
        tok, line = self.items[self.pos]
        self.pos += 1
        try:
            val = float(tok)
        except ValueError:
            val = math.nan
        if not math.isfinite(val):
            raise PhotometryError(
                f"expected a number for {what}, found {tok!r}", file=self.file, line=line
            )
        return val, line

    def count(self, what: str, minimum: int = 1) -> tuple[int, int]:
        # The 1986 format allows counts written as "3.0".
        val, line = self.number(what)
        if val != int(val) or val < minimum:
            raise PhotometryError(
                f"{what} must be a whole number ≥ {minimum}, found {val:g}",
                file=self.file,
                line=line,
            )
        return int(val), line

    def array(self, n: int, what: str) -> tuple[np.ndarray, list[int]]:
        vals, lines = [], []
        for k in range(n):
            if self.pos >= len(self.items):
                raise PhotometryError(
                    f"the file ends early: expected {n} values for {what}, found {k} "
                    "(truncated file or wrong counts in the header)",
                    file=self.file,
                    line=self.last_line,
                )
            v, ln = self.number(f"{what} (value {k + 1} of {n})")
            vals.append(v)
            lines.append(ln)
        return np.asarray(vals, dtype=np.float64), lines


def _ascending(values: np.ndarray, lines: list[int], what: str, file: Path) -> None:
    bad = np.nonzero(np.diff(values) <= 0)[0]
    if bad.size:
        k = int(bad[0]) + 1
        raise PhotometryError(
            f"{what} must be strictly ascending, but {values[k]:g} follows {values[k - 1]:g}",
            file=file,
            line=lines[k],
        )


def _read_tilt(tok: _Tokens) -> TiltTable:
    geometry, gline = tok.count("the tilt lamp-to-luminaire geometry (1, 2 or 3)")
    if geometry not in (1, 2, 3):
        raise PhotometryError(
            f"tilt lamp-to-luminaire geometry must be 1, 2 or 3, found {geometry}",
            file=tok.file,
            line=gline,
        )
    n, _ = tok.count("the number of tilt angles")
    angles, alines = tok.array(n, "tilt angles")
    factors, _ = tok.array(n, "tilt multiplying factors")
    _ascending(angles, alines, "tilt angles", tok.file)
    return TiltTable(geometry, tuple(angles.tolist()), tuple(factors.tolist()))


def parse_ies(path: Path, text: str) -> Photometry:
    """Parse an LM-63 file's text (already decoded). See :func:`lumijax.photometry.read_photometry`."""
    lines = text.splitlines()
    if not lines:
        raise PhotometryError("the file is empty", file=path)
    first = lines[0].strip()
    version, start = "1986", 0
    for tag, ver in _VERSIONS:
        if first.upper().startswith(tag):
            version, start = ver, 1
            break

    keywords: dict[str, str] = {}
    labels: list[str] = []
    last_key: str | None = None
    tilt_idx = None
    for k in range(start, len(lines)):
        line = lines[k]
        if line.lstrip().upper().startswith("TILT"):
            stripped = line.strip()
            if "=" in stripped and stripped.split("=", 1)[0].strip().upper() == "TILT":
                tilt_idx = k
                break
        m = _KEYWORD.match(line)
        if m and version != "1986":
            key, val = m.group(1).strip().upper(), m.group(2).rstrip()
            if key == "MORE" and last_key is not None:
                keywords[last_key] += "\n" + val
            elif key in keywords:
                keywords[key] += "\n" + val
                last_key = key
            else:
                keywords[key] = val
                last_key = key
        elif line.strip():
            labels.append(line.rstrip())
    if labels:
        keywords["LABEL"] = "\n".join(labels)
    if tilt_idx is None:
        raise PhotometryError(
            "no 'TILT=' line: an IES LM-63 file must end its label section with TILT=NONE, "
            "TILT=INCLUDE or TILT=<file>",
            file=path,
            line=len(lines),
        )
    tilt_value = lines[tilt_idx].strip().split("=", 1)[1].strip()
    tok = _Tokens(lines[tilt_idx + 1 :], tilt_idx + 2, path)

    tilt = None
    if tilt_value.upper() == "INCLUDE":
        tilt = _read_tilt(tok)
    elif tilt_value.upper() != "NONE":
        tilt_path = (path.parent / tilt_value).resolve()
        if not tilt_path.is_file():
            raise PhotometryError(
                f"TILT={tilt_value}: the tilt file was not found (looked for {tilt_path})",
                file=path,
                line=tilt_idx + 1,
            )
        ttext = decode_text(tilt_path.read_bytes()).splitlines()
        tilt = _read_tilt(_Tokens(ttext, 1, tilt_path))

    n_lamps, _ = tok.number("the number of lamps")
    lm_per_lamp, _ = tok.number("lumens per lamp")
    cd_mult, _ = tok.number("the candela multiplier")
    n_v, _ = tok.count("the number of vertical angles")
    n_h, _ = tok.count("the number of horizontal angles")
    ptype_code, pline = tok.number("the photometric type")
    if ptype_code not in (1.0, 2.0, 3.0):
        raise PhotometryError(
            f"unknown photometric type {ptype_code:g} (expected 1 = Type C, 2 = Type B, 3 = Type A)",
            file=path,
            line=pline,
        )
    ptype = _TYPE_NAMES[int(ptype_code)]
    units, uline = tok.number("the units type")
    if units not in (1.0, 2.0):
        raise PhotometryError(
            f"unknown units type {units:g} (expected 1 = feet, 2 = metres)", file=path, line=uline
        )
    width, _ = tok.number("the luminous width")
    length, _ = tok.number("the luminous length")
    height, _ = tok.number("the luminous height")
    ballast, _ = tok.number("the ballast factor")
    second, _ = tok.number("the ballast-lamp factor / future use / file generation type")
    watts, _ = tok.number("input watts")

    v, vlines = tok.array(n_v, "vertical angles")
    h, hlines = tok.array(n_h, "horizontal angles")
    _ascending(v, vlines, "vertical angles", path)
    _ascending(h, hlines, "horizontal angles", path)
    raw, clines = tok.array(n_v * n_h, "candela values")
    if tok.remaining():
        extra_tok, extra_line = tok.items[tok.pos]
        raise PhotometryError(
            f"{tok.remaining()} value(s) left over after the {n_h} × {n_v} candela table "
            f"(first: {extra_tok!r}); the angle counts in the header are wrong",
            file=path,
            line=extra_line,
        )
    neg = np.nonzero(raw < 0)[0]
    if neg.size:
        k = int(neg[0])
        raise PhotometryError(
            f"negative candela value {raw[k]:g} (horizontal angle {h[k // n_v]:g}, "
            f"vertical angle {v[k % n_v]:g})",
            file=path,
            line=clines[k],
        )

    if ptype == "C":
        if v[0] < 0 or v[-1] > 180:
            raise PhotometryError(
                f"Type C vertical angles must lie in 0…180, found {v[0]:g}…{v[-1]:g}",
                file=path,
                line=vlines[0],
            )
    elif h[0] < -180 or h[-1] > 180 or v[0] < -180 or v[-1] > 180:
        raise PhotometryError(
            f"Type {ptype} angles must lie in −180…180", file=path, line=hlines[0]
        )

    # ies2rad's rule: the second record-2 value multiplies only in 1986/1991; in 1995/2002 it is
    # "future use" and in 2019 a coded file-generation type that must not scale anything.
    multiplier = cd_mult * ballast * (second if version in ("1986", "1991") else 1.0)
    cd = raw.reshape(n_h, n_v) * multiplier

    try:
        if ptype == "C":
            hf, vf, cdf = expand_type_c(h, v, cd)
        else:
            hf, vf, cdf = expand_type_ab(h, v, cd)
    except ValueError as exc:
        raise PhotometryError(str(exc), file=path, line=hlines[0]) from None

    scale = FEET if units == 1.0 else 1.0
    opening, note = decode_ies_opening(width, length, height, version, scale)
    notes: list[str] = []
    if note:
        notes.append(f"{path}: {note}")
        warnings.warn(notes[-1], LumijaxWarning, stacklevel=3)

    absolute = lm_per_lamp < 0
    lamp_lm = None if absolute else abs(n_lamps) * lm_per_lamp
    integrated = integrate_np(ptype, hf, vf, cdf)
    msg = check_header_flux(
        fmt="ies", source=path, integrated_lm=integrated, rated_lm=lamp_lm, absolute=absolute
    )
    if msg:
        notes.append(msg)

    return Photometry(
        distribution=CandelaDistribution(ptype, hf, vf, cdf),
        opening=opening,
        rated_lm=lamp_lm,
        lamp_lm=lamp_lm,
        lor=None,
        integrated_lm=integrated,
        input_watts=watts,
        tilt=tilt,
        source=path,
        format="ies",
        version=version,
        keywords=keywords,
        warnings=tuple(notes),
    )
