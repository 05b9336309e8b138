"""EULUMDAT reader. Format facts: FORMATS.md §2."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import PhotometryError
from ._distribution import CandelaDistribution
from ._opening import LuminousOpening
from ._photometry import LampSet, Photometry, check_header_flux, integrate_np
from ._symmetry import expand_type_c
from ._text import FLOAT32_MAX, quote, split_lines

__all__ = ["parse_ldt", "looks_like_ldt"]


def looks_like_ldt(lines: list[str]) -> bool:
    """One value per line with Ityp (0–3) on line 2 and Isym (0–4) on line 3."""
    if len(lines) < 42:
        return False
    try:
        ityp = int(lines[1].strip())
        isym = int(lines[2].strip())
        float(lines[3].strip().replace(",", "."))
    except ValueError:
        return False
    return 0 <= ityp <= 3 and 0 <= isym <= 4


class _Lines:
    def __init__(self, lines: list[str], file: Path) -> None:
        self.lines = lines
        self.file = file
        self.pos = 0  # 0-based index of the next line

    def text(self, what: str) -> str:
        if self.pos >= len(self.lines):
            raise PhotometryError(
                f"the file ends early: expected {what} on line {self.pos + 1} (truncated file?)",
                file=self.file,
                line=len(self.lines),
            )
        self.pos += 1
        return self.lines[self.pos - 1].strip()

    def number(self, what: str) -> float:
        tok = self.text(what)
        # Decimal commas are converted only here: text lines may hold commas that are not decimals.
        try:
            val = float(tok.replace(",", "."))
        except ValueError:
            raise PhotometryError(
                f"expected a number for {what}, found {quote(tok)}", file=self.file, line=self.pos
            ) from None
        if not math.isfinite(val):
            raise PhotometryError(
                f"{what} must be a finite number, found {val}",
                file=self.file,
                line=self.pos,
            )
        return val

    def positive(self, what: str) -> float:
        val = self.number(what)
        if not val > 0:
            raise PhotometryError(
                f"{what} must be positive, found {val:g}", file=self.file, line=self.pos
            )
        return val

    def integer(self, what: str, lo: int, hi: int) -> int:
        val = self.number(what)
        if val != int(val) or not lo <= val <= hi:
            raise PhotometryError(
                f"{what} must be a whole number in {lo}…{hi}, found {val:g}",
                file=self.file,
                line=self.pos,
            )
        return int(val)


def _stored_planes(isym: int, mc: int, file: Path, line: int) -> np.ndarray:
    """Indices into the C-angle list of the planes stored in the table, in file order."""
    need = {2: 2, 3: 4, 4: 4}.get(isym, 1)
    if mc % need:
        raise PhotometryError(
            f"Isym {isym} needs the number of C planes to be a multiple of {need}, found Mc = {mc}",
            file=file,
            line=line,
        )
    if isym == 0:
        return np.arange(mc)
    if isym == 1:
        return np.array([0])
    if isym == 2:
        return np.arange(mc // 2 + 1)
    if isym == 3:
        # Stored C270 → C0 → C90 (FORMATS.md §2: Mc1 = 3·Mc/4 + 1 with wrap-around).
        return (3 * mc // 4 + np.arange(mc // 2 + 1)) % mc
    return np.arange(mc // 4 + 1)


def _n_stored(isym: int, mc: int) -> int:
    return {0: mc, 1: 1, 2: mc // 2 + 1, 3: mc // 2 + 1, 4: mc // 4 + 1}[isym]


_ANGLE_TOL = 1e-6  # deg: how far a C angle may be from the plane its symmetry names


def _check_coverage(isym: int, c: np.ndarray, file: Path, c_first: int) -> np.ndarray:
    """Refuse C angles that do not hold the planes the symmetry declares; snap those planes.

    Isym 2 stores C0…C180 (the first Mc/2 + 1 angles), Isym 3 C270…C360=C0…C90, Isym 4 C0…C90;
    Isym 0 needs C0 and planes around the whole circle. Without this check a table would be
    re-mirrored by whatever symmetry its stored angles happen to suggest.
    """
    mc = len(c)
    c = c.copy()

    def require(k: int, angle: float, what: str) -> None:
        if abs(c[k] - angle) > _ANGLE_TOL:
            raise PhotometryError(
                f"Isym {isym} ({what}) needs C angle {k + 1} of {mc} to be C{angle:g}, "
                f"found C{c[k]:g}; the C angles do not cover what the symmetry declares",
                file=file,
                line=c_first + k,
            )
        c[k] = angle

    if isym == 0:
        require(0, 0.0, "no symmetry")
        gaps = np.diff(c)
        wrap = 360.0 - c[-1]
        if mc < 2 or c[-1] <= 180.0 or wrap > float(np.max(gaps)) + _ANGLE_TOL:
            raise PhotometryError(
                f"Isym 0 (no symmetry) needs C planes around the whole circle, but the last "
                f"of the {mc} C angles is C{c[-1]:g}: the gap to C360 is wider than any gap "
                "between the given planes (Isym 1–4 declare a symmetry; Mc may be wrong)",
                file=file,
                line=c_first + mc - 1,
            )
    elif isym == 2:
        require(0, 0.0, "symmetry about the C0–C180 plane")
        require(mc // 2, 180.0, "symmetry about the C0–C180 plane")
    elif isym == 3:
        require(0, 0.0, "symmetry about the C90–C270 plane")
        require(mc // 4, 90.0, "symmetry about the C90–C270 plane")
        require(3 * mc // 4, 270.0, "symmetry about the C90–C270 plane")
    elif isym == 4:
        require(0, 0.0, "symmetry about the C0–C180 and C90–C270 planes")
        require(mc // 4, 90.0, "symmetry about the C0–C180 and C90–C270 planes")
    return c


def _explain_counts(
    lines: list[str], first: int, isym: int, mc: int, ng: int, file: Path
) -> PhotometryError | None:
    """The header count (Mc or Ng) that disagrees with the data, if changing it alone fits all.

    ``first`` is the 0-based index of the first C-angle line. Tried only when the declared
    counts do not account for the lines that follow; a count is reported only if exactly one
    other value for it makes the C and γ angles ascending and accounts for every line.
    """
    body = lines[first:]
    while body and not body[-1].strip():
        body.pop()
    vals = []
    for text in body:
        try:
            vals.append(float(text.strip().replace(",", ".")))
        except ValueError:
            return None
    vals = np.asarray(vals)
    if not np.all(np.isfinite(vals)):
        return None
    total = len(vals)
    if mc + ng + _n_stored(isym, mc) * ng == total:
        return None

    def ordered(m: int, n: int) -> bool:
        return bool(np.all(np.diff(vals[:m]) > 0) and np.all(np.diff(vals[m : m + n]) > 0))

    need = {2: 2, 3: 4, 4: 4}.get(isym, 1)
    found = []
    for m in range(need, min(total, 3600) + 1, need):
        if m != mc and m + ng + _n_stored(isym, m) * ng == total and ordered(m, ng):
            found.append(("C planes (Mc, line 4)", mc, m))
    per = 1 + _n_stored(isym, mc)
    if (total - mc) % per == 0:
        n = (total - mc) // per
        if n >= 2 and n != ng and ordered(mc, n):
            found.append(("γ angles (Ng, line 6)", ng, n))
    if len(found) != 1:
        return None
    what, declared, given = found[0]
    m, n = (given, ng) if what.startswith("C") else (mc, given)
    return PhotometryError(
        f"the header declares {declared} {what}, {given} are given ({m} C angles, {n} γ angles "
        f"and {_n_stored(isym, m)} stored plane(s) of {n} intensities account for the {total} "
        f"lines from line {first + 1})",
        file=file,
        line=4 if what.startswith("C") else 6,
    )


def parse_ldt(path: Path, text: str) -> Photometry:
    """Parse a EULUMDAT file's text. See :func:`lumijax.photometry.read_photometry`."""
    lines = split_lines(text)
    rd = _Lines(lines, path)
    company = rd.text("the company identification (line 1)")
    ityp = rd.integer("Ityp (line 2)", 0, 3)
    isym = rd.integer("Isym (line 3)", 0, 4)
    mc = rd.integer("Mc, the number of C planes (line 4)", 1, 3600)
    mc_line = rd.pos
    rd.number("Dc (line 5)")
    ng = rd.integer("Ng, the number of γ angles (line 6)", 2, 3600)
    rd.number("Dg (line 7)")
    report = rd.text("the measurement report number (line 8)")
    luminaire = rd.text("the luminaire name (line 9)")
    lum_number = rd.text("the luminaire number (line 10)")
    file_name = rd.text("the file name (line 11)")
    date_user = rd.text("the date/user (line 12)")
    body = [rd.number(f"luminaire dimension (line {k})") for k in (13, 14, 15)]
    lum_len = rd.number("length/diameter of the luminous area (line 16)")
    lum_wid = rd.number("width of the luminous area (line 17)")
    heights = [rd.number(f"height of the luminous area (line {k})") for k in (18, 19, 20, 21)]
    dff = rd.number("the downward flux fraction (line 22)")
    lorl = rd.number("LORL, the light output ratio (line 23)")
    conv = rd.positive("the intensity conversion factor (line 24)")
    tilt_meas = rd.number("the measurement tilt (line 25)")
    n_sets = rd.integer("the number of lamp sets (line 26)", 1, 20)
    sets = []
    for s in range(n_sets):
        count = rd.number(f"the number of lamps of set {s + 1}")
        ltype = rd.text(f"the lamp type of set {s + 1}")
        flux = rd.positive(f"the lamp flux of set {s + 1}")
        colour = rd.text(f"the colour temperature of set {s + 1}")
        cri = rd.text(f"the colour rendering of set {s + 1}")
        watts = rd.number(f"the wattage of set {s + 1}")
        sets.append(LampSet(int(count), ltype, flux, colour, cri, watts))
    direct_ratios = [rd.number(f"direct ratio {k + 1} of 10") for k in range(10)]
    first = rd.pos
    try:
        c, g, raw, c_first = _read_table(rd, isym, mc, ng, mc_line)
    except PhotometryError as err:
        raise (_explain_counts(lines, first, isym, mc, ng, path) or err) from None

    lamp_flux = sets[0].flux_lm
    absolute = sets[0].count < 0
    scale = conv * lamp_flux / 1000.0
    with np.errstate(over="ignore"):
        cd = raw * scale
    bad = np.nonzero(~(cd <= FLOAT32_MAX))
    if bad[0].size:
        p, k = int(bad[0][0]), int(bad[1][0])
        raise PhotometryError(
            f"intensity {raw[p, k]:g} cd/klm × conversion factor {conv:g} × lamp flux "
            f"{lamp_flux:g} lm / 1000 exceeds the largest intensity lumijax can hold "
            f"({FLOAT32_MAX:.4g} cd, float32)",
            file=path,
            line=c_first + mc + ng + p * ng + k,
        )

    planes = _stored_planes(isym, mc, path, mc_line)
    angles = c[planes]
    if isym == 1:
        h_stored = np.array([0.0])
    elif isym == 3:
        # Rows run C270 … C360=C0 … C90. Mirror them onto 90…270 (I(C) = I(180 − C)) so the
        # stored half is read with the IES 90–270 rule; reversing makes the angles ascending.
        h_stored = np.mod(180.0 - angles, 360.0)[::-1]
        cd = cd[::-1]
    else:
        h_stored = angles
    try:
        hf, vf, cdf = expand_type_c(h_stored, g, cd)
        distribution = CandelaDistribution("C", hf, vf, cdf)
    except ValueError as exc:
        raise PhotometryError(str(exc), file=path, line=c_first) from None

    mm = 1e-3
    L = lum_len * mm
    W = lum_wid * mm
    H = max(heights) * mm
    if L == 0 and W == 0:
        opening = LuminousOpening(0.0, 0.0, H, "point" if H == 0 else "vertical_cylinder")
    elif W == 0:  # b1 = 0 flags a round luminous area of diameter L
        opening = LuminousOpening(L, L, H, "circle" if H == 0 else "vertical_cylinder")
    else:
        opening = LuminousOpening(L, W, H, "rectangle" if H == 0 else "box")

    rated = lamp_flux if absolute else lorl / 100.0 * lamp_flux
    integrated = integrate_np("C", hf, vf, cdf)
    notes = []
    msg = check_header_flux(
        fmt="ldt", source=path, integrated_lm=integrated, rated_lm=rated, absolute=absolute
    )
    if msg:
        notes.append(msg)

    keywords = {
        "COMPANY": company,
        "ITYP": str(ityp),
        "ISYM": str(isym),
        "TEST": report,
        "LUMINAIRE": luminaire,
        "LUMCAT": lum_number,
        "FILENAME": file_name,
        "DATE": date_user,
        "LUMINAIRE_DIMENSIONS_MM": " ".join(f"{x:g}" for x in body),
        "DFF": f"{dff:g}",
        "LORL": f"{lorl:g}",
        "CONVERSION_FACTOR": f"{conv:g}",
        "MEASUREMENT_TILT": f"{tilt_meas:g}",
        "DIRECT_RATIOS": " ".join(f"{x:g}" for x in direct_ratios),
        "LAMP": sets[0].lamp_type,
    }
    return Photometry(
        distribution=distribution,
        opening=opening,
        rated_lm=rated,
        lamp_lm=lamp_flux,
        lor=lorl / 100.0,
        integrated_lm=integrated,
        input_watts=sets[0].watts,
        tilt=None,
        source=path,
        format="ldt",
        version="eulumdat",
        keywords=keywords,
        warnings=tuple(notes),
        lamp_sets=tuple(sets),
    )


def _read_table(rd: _Lines, isym: int, mc: int, ng: int, mc_line: int):
    """C angles, γ angles and the stored intensities (cd/klm), checked; and the first C line."""
    path = rd.file
    c_first = rd.pos + 1
    c = np.array([rd.number(f"C angle {k + 1} of {mc}") for k in range(mc)])
    g_first = rd.pos + 1
    g = np.array([rd.number(f"γ angle {k + 1} of {ng}") for k in range(ng)])
    for arr, first, what in ((c, c_first, "C angles"), (g, g_first, "γ angles")):
        bad = np.nonzero(np.diff(arr) <= 0)[0]
        if bad.size:
            k = int(bad[0]) + 1
            raise PhotometryError(
                f"{what} must be strictly ascending, but {arr[k]:g} follows {arr[k - 1]:g}",
                file=path,
                line=first + k,
            )
    if c[0] < 0 or c[-1] >= 360.0 and isym != 1:
        raise PhotometryError(
            f"C angles must lie in 0…<360, found {c[0]:g}…{c[-1]:g}", file=path, line=c_first
        )
    if g[0] < 0 or g[-1] > 180:
        raise PhotometryError(
            f"γ angles must lie in 0…180, found {g[0]:g}…{g[-1]:g}", file=path, line=g_first
        )
    planes = _stored_planes(isym, mc, path, mc_line)
    raw = np.empty((planes.size, ng))
    for p in range(planes.size):
        for k in range(ng):
            raw[p, k] = rd.number(
                f"intensity {k + 1} of {ng} in stored C plane {p + 1} of {planes.size}"
            )
            if raw[p, k] < 0:
                raise PhotometryError(
                    f"negative intensity {raw[p, k]:g} cd/klm", file=path, line=rd.pos
                )
    lines = rd.lines
    extra = [k for k in range(rd.pos, len(lines)) if lines[k].strip()]
    if extra:
        raise PhotometryError(
            f"{len(extra)} non-empty line(s) after the intensity table, which should end at line "
            f"{rd.pos} (Isym {isym}, Mc {mc}, Ng {ng}); the counts in the header are wrong",
            file=path,
            line=extra[0] + 1,
        )
    c = _check_coverage(isym, c, path, c_first)
    return c, g, raw, c_first
