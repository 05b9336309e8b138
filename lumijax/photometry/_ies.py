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
from ._text import FLOAT32_MAX, FileProblem, decode_text, quote, read_regular_file, split_lines

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
_MAX_TILT_BYTES = 1 << 20  # a tilt table is a few dozen numbers


class _Tokens:
    """Numbers of a photometric section as a stream that remembers each token's line.

    ``echo=False`` (a tilt file named by ``TILT=<file>``, which may be any file on the machine)
    keeps every token out of the error messages: they give the line and what was expected.
    """

    def __init__(
        self, lines: list[str], first_lineno: int, file: Path, *, echo: bool = True
    ) -> None:
        self.file = file
        self.echo = echo
        self.items: list[tuple[str, int]] = []
        for k, line in enumerate(lines):
            for tok in _SPLIT.split(line.strip()):
                if tok:
                    self.items.append((tok, first_lineno + k))
        self.pos = 0
        self.last_line = first_lineno + max(len(lines) - 1, 0)

    def remaining(self) -> int:
        return len(self.items) - self.pos

    def found(self, tok: str) -> str:
        return f"found {quote(tok)}" if self.echo else "found something else"

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
            raise PhotometryError(
                f"expected a number for {what}, {self.found(tok)}", file=self.file, line=line
            ) from None
        if not math.isfinite(val):
            raise PhotometryError(
                f"{what} must be a finite number, found {val}", file=self.file, line=line
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

    def positive(self, what: str) -> tuple[float, int]:
        val, line = self.number(what)
        if not val > 0:
            raise PhotometryError(
                f"{what} must be positive, found {val:g}", file=self.file, line=line
            )
        return val, line

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

    def values(self) -> np.ndarray:
        """Every token as a float (NaN where it is not a number), for count diagnosis."""
        return np.array([_to_float(t) for t, _ in self.items], dtype=np.float64)


def _to_float(tok: str) -> float:
    try:
        return float(tok)
    except ValueError:
        return math.nan


def _ascending(values: np.ndarray, lines: list[int], what: str, file: Path) -> None:
    bad = np.nonzero(np.diff(values) <= 0)[0]
    if bad.size:
        k = int(bad[0]) + 1
        raise PhotometryError(
            f"{what} must be strictly ascending, but {values[k]:g} follows {values[k - 1]:g}",
            file=file,
            line=lines[k],
        )


def _in_range(
    values: np.ndarray, lines: list[int], lo: float, hi: float, what: str, file: Path
) -> None:
    bad = np.nonzero((values < lo) | (values > hi))[0]
    if bad.size:
        k = int(bad[0])
        raise PhotometryError(
            f"{what} must lie in {f'{lo:g}…{hi:g}'.replace('-', '−')}, found {values[k]:g}",
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
    factors, flines = tok.array(n, "tilt multiplying factors")
    _ascending(angles, alines, "tilt angles", tok.file)
    bad = np.nonzero(~(factors > 0))[0]
    if bad.size:
        k = int(bad[0])
        raise PhotometryError(
            f"tilt multiplying factors must be positive, found {factors[k]:g} "
            f"(factor {k + 1} of {n})",
            file=tok.file,
            line=flines[k],
        )
    return TiltTable(geometry, tuple(angles.tolist()), tuple(factors.tolist()))


def _whole(x: float, minimum: int = 1) -> bool:
    return math.isfinite(x) and x == int(x) and x >= minimum


def _strictly_ascending(a: np.ndarray) -> bool:
    return bool(np.all(np.diff(a) > 0))


def _table_fits(vals: np.ndarray, off: int, *, ordered: bool = True) -> bool:
    """Whether a photometric header at ``vals[off]`` and its counts account for every value.

    ``ordered`` also asks for both angle lists to be strictly ascending.
    """
    if off + 13 > len(vals):
        return False
    n_v, n_h = vals[off + 3], vals[off + 4]
    if not (_whole(n_v) and _whole(n_h)):
        return False
    n_v, n_h = int(n_v), int(n_h)
    a = off + 13
    if n_v + n_h + n_v * n_h != len(vals) - a:
        return False
    return not ordered or (
        _strictly_ascending(vals[a : a + n_v])
        and _strictly_ascending(vals[a + n_v : a + n_v + n_h])
    )


def _explain_counts(tok: _Tokens, include: bool) -> PhotometryError | None:
    """A count in the file that disagrees with the data, when one explains the data exactly.

    Tried only when the declared counts do not account for the values that follow; a count
    is reported only if exactly one other value for it (the others kept) fits every value.
    """
    vals = tok.values()
    if np.isnan(vals).any():
        return None
    lines = [ln for _, ln in tok.items]
    off = 0
    if include:
        if len(vals) < 2 or not _whole(vals[1]):
            return None
        n_t = int(vals[1])
        if not _table_fits(vals, 2 + 2 * n_t, ordered=False):
            given = [
                k
                for k in range(1, (len(vals) - 15) // 2 + 1)
                if k != n_t
                and _table_fits(vals, 2 + 2 * k)
                and _strictly_ascending(vals[2 : 2 + k])
                and bool(np.all(vals[2 + k : 2 + 2 * k] > 0))
            ]
            if len(given) == 1:
                k = given[0]
                return PhotometryError(
                    f"the TILT=INCLUDE block declares {n_t} tilt angle(s), {k} are given "
                    f"({k} angles and {k} factors, then a photometric header and table that fit "
                    "its own counts)",
                    file=tok.file,
                    line=lines[1],
                )
        off = 2 + 2 * n_t
    if off + 13 > len(vals) or _table_fits(vals, off, ordered=False):
        return None
    n_v, n_h = vals[off + 3], vals[off + 4]
    if not (_whole(n_v) and _whole(n_h)):
        return None
    n_v, n_h = int(n_v), int(n_h)
    a = off + 13
    rest = len(vals) - a
    found = []
    # The vertical count kept, another horizontal count; then the other way round.
    if (rest - n_v) % (n_v + 1) == 0:
        k = (rest - n_v) // (n_v + 1)
        if k >= 1 and k != n_h and _strictly_ascending(vals[a : a + n_v]):
            if _strictly_ascending(vals[a + n_v : a + n_v + k]):
                found.append(("horizontal", n_h, k, n_v, k, off + 4))
    if (rest - n_h) % (n_h + 1) == 0:
        k = (rest - n_h) // (n_h + 1)
        if k >= 1 and k != n_v and _strictly_ascending(vals[a : a + k]):
            if _strictly_ascending(vals[a + k : a + k + n_h]):
                found.append(("vertical", n_v, k, k, n_h, off + 3))
    if len(found) != 1:
        return None
    which, declared, k, nv, nh, idx = found[0]
    return PhotometryError(
        f"the header declares {declared} {which} angle(s), {k} are given ({nv} vertical angles, "
        f"{nh} horizontal angles and {nv} × {nh} candela values account for the {rest} values "
        "after the header)",
        file=tok.file,
        line=lines[idx],
    )


def _tilt_file(path: Path, value: str, line: int, allow_outside: bool) -> Path:
    """The file a ``TILT=<file>`` line names, refused if it escapes the photometric file's folder."""
    shown = quote(value)

    def refuse(why: str) -> PhotometryError:
        return PhotometryError(f"the file TILT= names ({shown}): {why}", file=path, line=line)

    if not value:
        raise refuse("names no file (expected TILT=NONE, TILT=INCLUDE or TILT=<file name>)")
    if "\x00" in value:
        raise refuse("the tilt file name holds a NUL character")
    if len(value) > 1024 or any(len(part) > 255 for part in re.split(r"[\\/]", value)):
        raise refuse("the tilt file name is too long to be a file name")
    folder = path.parent
    try:
        target = (folder / value).resolve()
        base = folder.resolve()
    except (OSError, ValueError, RuntimeError):
        raise refuse("the tilt file name cannot be resolved to a path") from None
    if not allow_outside and not target.is_relative_to(base):
        raise refuse(
            f"the tilt file lies outside the photometric file's folder {base}; lumijax reads "
            "TILT files only from that folder or below (read_photometry(..., "
            "allow_outside=True) lifts this for trusted files)"
        )
    return target


def _read_tilt_file(path: Path, value: str, line: int, allow_outside: bool) -> TiltTable:
    target = _tilt_file(path, value, line, allow_outside)
    try:
        raw = read_regular_file(target, _MAX_TILT_BYTES)
    except FileProblem as exc:
        what = "was not found" if str(exc) == "not found" else str(exc)
        raise PhotometryError(
            f"the file TILT= names ({quote(value)}) {what} (looked for {target})",
            file=path,
            line=line,
        ) from None
    # Nothing of this file is ever quoted: it may be any file (allow_outside=True), and a file
    # that is not a tilt table must not have its content shown.
    tok = _Tokens(split_lines(decode_text(raw, target)), 1, target, echo=False)
    def miscounted() -> PhotometryError | None:
        vals = tok.values()
        if len(vals) < 2 or np.isnan(vals).any() or len(vals) % 2 or not _whole(vals[1]):
            return None
        k = (len(vals) - 2) // 2
        if k < 1 or int(vals[1]) == k or not _strictly_ascending(vals[2 : 2 + k]):
            return None
        return PhotometryError(
            f"the tilt file declares {int(vals[1])} tilt angle(s), {k} are given (it holds "
            f"{len(vals)} values: the geometry, the count, {k} angles and {k} factors)",
            file=target,
            line=tok.items[1][1],
        )

    try:
        tilt = _read_tilt(tok)
    except PhotometryError as err:
        raise (miscounted() or err) from None
    if tok.remaining():
        raise miscounted() or PhotometryError(
            f"{tok.remaining()} value(s) left over after the tilt table of "
            f"{len(tilt.angles_deg)} angles and factors: the tilt angle count is wrong, or this "
            "is not a tilt file",
            file=target,
            line=tok.items[tok.pos][1],
        )
    return tilt


def parse_ies(path: Path, text: str, *, allow_outside: bool = False) -> Photometry:
    """Parse an LM-63 file's text (already decoded). See :func:`lumijax.photometry.read_photometry`."""
    lines = split_lines(text)
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
    include = tilt_value.upper() == "INCLUDE"
    tilt = None
    if not include and tilt_value.upper() != "NONE":
        tilt = _read_tilt_file(path, tilt_value, tilt_idx + 1, allow_outside)
    tok = _Tokens(lines[tilt_idx + 1 :], tilt_idx + 2, path)
    try:
        data = _read_data(tok, version, include)
    except PhotometryError as err:
        raise (_explain_counts(tok, include) or err) from None
    if include:
        tilt = data.pop("tilt")
    return _build(path, version, keywords, tilt, **data)


def _read_data(tok: _Tokens, version: str, include: bool) -> dict:
    """Everything after the ``TILT=`` line, read and checked (see ``docs/photometry.md``)."""
    path = tok.file
    out: dict = {}
    if include:
        out["tilt"] = _read_tilt(tok)
    n_lamps, _ = tok.number("the number of lamps")
    lm_per_lamp, lm_line = tok.number("lumens per lamp")
    cd_mult, _ = tok.positive("the candela multiplier")
    n_v, nv_line = tok.count("the number of vertical angles")
    n_h, nh_line = tok.count("the number of horizontal angles")
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
    ballast, _ = tok.positive("the ballast factor")
    # ies2rad's rule: the second record-2 value multiplies only in 1986/1991; in 1995/2002 it is
    # "future use" and in 2019 a coded file-generation type that must not scale anything.
    if version in ("1986", "1991"):
        second, _ = tok.positive("the ballast-lamp photometric factor")
    else:
        second, _ = tok.number("future use / file generation type")
        second = 1.0
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
            f"(first: {quote(extra_tok)}); the angle counts in the header are wrong",
            file=path,
            line=extra_line,
        )
    if n_v == 1:
        raise PhotometryError(
            "the header declares a single vertical angle: one angle describes no distribution "
            "over directions; a candela table needs at least two vertical angles",
            file=path,
            line=nv_line,
        )
    if ptype != "C" and n_h == 1:
        raise PhotometryError(
            f"the header declares a single horizontal angle: a Type {ptype} table needs at "
            "least two (or 0…H for a laterally symmetric one)",
            file=path,
            line=nh_line,
        )
    if ptype == "C":
        _in_range(v, vlines, 0.0, 180.0, "Type C vertical angles (γ)", path)
    elif ptype == "B":  # H is the latitude (elevation from the photometric equator)
        _in_range(h, hlines, -90.0, 90.0, "Type B horizontal angles", path)
        _in_range(v, vlines, -180.0, 180.0, "Type B vertical angles", path)
    else:  # Type A: V is the latitude
        _in_range(v, vlines, -90.0, 90.0, "Type A vertical angles", path)
        _in_range(h, hlines, -180.0, 180.0, "Type A horizontal angles", path)

    bad = np.nonzero(raw < 0)[0]
    if bad.size:
        k = int(bad[0])
        raise PhotometryError(
            f"negative candela value {raw[k]:g} (horizontal angle {h[k // n_v]:g}, "
            f"vertical angle {v[k % n_v]:g})",
            file=path,
            line=clines[k],
        )
    multiplier = cd_mult * ballast * second
    with np.errstate(over="ignore"):
        cd = raw * multiplier
    bad = np.nonzero(~(cd <= FLOAT32_MAX))[0]
    if bad.size:
        k = int(bad[0])
        raise PhotometryError(
            f"candela value {raw[k]:g} × multiplier {multiplier:g} (candela multiplier × ballast "
            f"factor{' × ballast-lamp factor' if second != 1.0 else ''}) exceeds the largest "
            f"intensity lumijax can hold ({FLOAT32_MAX:.4g} cd, float32)",
            file=path,
            line=clines[k],
        )
    with np.errstate(over="ignore"):
        lamp_lm = None if lm_per_lamp < 0 else abs(n_lamps) * lm_per_lamp
    if lamp_lm is not None and not math.isfinite(lamp_lm):
        raise PhotometryError(
            f"number of lamps × lumens per lamp = {n_lamps:g} × {lm_per_lamp:g} overflows",
            file=path,
            line=lm_line,
        )
    out.update(
        ptype=ptype, v=v, h=h, cd=cd.reshape(n_h, n_v), hline=hlines[0], units=units,
        dims=(width, length, height), lamp_lm=lamp_lm, absolute=lm_per_lamp < 0, watts=watts,
    )
    return out


def _build(
    path: Path, version: str, keywords: dict, tilt: TiltTable | None, *, ptype: str,
    v: np.ndarray, h: np.ndarray, cd: np.ndarray, hline: int, units: float,
    dims: tuple[float, float, float],
    lamp_lm: float | None, absolute: bool, watts: float,
) -> Photometry:
    try:
        if ptype == "C":
            hf, vf, cdf = expand_type_c(h, v, cd)
        else:
            hf, vf, cdf = expand_type_ab(h, v, cd)
        distribution = CandelaDistribution(ptype, hf, vf, cdf)
    except ValueError as exc:
        raise PhotometryError(str(exc), file=path, line=hline) from None

    scale = FEET if units == 1.0 else 1.0
    opening, note = decode_ies_opening(*dims, version, scale)
    notes: list[str] = []
    if note:
        notes.append(f"{path}: {note}")
        warnings.warn(notes[-1], LumijaxWarning, stacklevel=4)

    integrated = integrate_np(ptype, hf, vf, cdf)
    msg = check_header_flux(
        fmt="ies", source=path, integrated_lm=integrated, rated_lm=lamp_lm, absolute=absolute
    )
    if msg:
        notes.append(msg)

    return Photometry(
        distribution=distribution,
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
