"""Spectra as CSV files.

Format (comma-separated, UTF-8, header row required)::

    # optional comment lines start with '#'
    wavelength_nm,value          <- emission; 'reflectance' instead of 'value' for a reflectance
    380,0.0123
    385,0.0150
    ...

Column names are case-insensitive; other columns are ignored; blank lines are skipped.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_text
from ..errors import SpectrumError

__all__ = ["read_csv", "write_csv", "WAVELENGTH_COLUMN", "VALUE_COLUMN"]

WAVELENGTH_COLUMN = "wavelength_nm"
#: The value column for each kind.
VALUE_COLUMN = {"emission": "value", "reflectance": "reflectance"}


def read_csv(path: Path, kind: str) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """``(wavelengths_nm, values, line numbers)`` from a spectrum CSV; raw, not yet validated."""
    value_col = VALUE_COLUMN[kind]
    expected = f"a header row '{WAVELENGTH_COLUMN},{value_col}'"
    try:
        with open(path, encoding="utf-8-sig", newline="") as fh:
            text = fh.read()
    except FileNotFoundError:
        raise SpectrumError("spectrum file not found", file=path) from None
    except UnicodeDecodeError as exc:
        # the decoder's message quotes the offending bytes; say where instead
        raise SpectrumError(f"not UTF-8 text (byte {exc.start}): expected a CSV spectrum",
                            file=path) from None
    except OSError as exc:
        raise SpectrumError(f"cannot read spectrum file ({exc.strerror or type(exc).__name__})",
                            file=path) from None

    header: list[str] | None = None
    header_line = 0
    wl: list[float] = []
    values: list[float] = []
    lines: list[int] = []
    i_wl = i_val = -1
    for lineno, row in enumerate(csv.reader(text.splitlines()), start=1):
        if not row or all(not f.strip() for f in row) or row[0].lstrip().startswith("#"):
            continue
        fields = [f.strip() for f in row]
        if header is None:
            header, header_line = [f.casefold() for f in fields], lineno
            if _is_number(fields[0]):
                raise SpectrumError(
                    f"no header: the first row must be {expected} (a header is required)",
                    file=path,
                    line=lineno,
                )
            missing = [c for c in (WAVELENGTH_COLUMN, value_col) if c not in header]
            if missing:
                other = VALUE_COLUMN["reflectance" if kind == "emission" else "emission"]
                hint = ""
                if other in header and value_col in missing:
                    hint = f" (column '{other}' is for a {'reflectance' if kind == 'emission' else 'emission'} spectrum)"
                # The header's own text is not echoed: the path may name any file
                # (docs/config.md, "Paths"); only the known column names are.
                raise SpectrumError(
                    f"header lacks column(s) {', '.join(repr(c) for c in missing)}: "
                    f"expected {expected} for a{'n' if kind == 'emission' else ''} {kind} "
                    f"spectrum{hint}",
                    file=path,
                    line=lineno,
                )
            i_wl, i_val = header.index(WAVELENGTH_COLUMN), header.index(value_col)
            continue
        if len(fields) != len(header):
            raise SpectrumError(
                f"row has {len(fields)} fields but the header (line {header_line}) has "
                f"{len(header)}",
                file=path,
                line=lineno,
            )
        pair = []
        for idx, col in ((i_wl, WAVELENGTH_COLUMN), (i_val, value_col)):
            try:
                pair.append(float(fields[idx]))
            except ValueError:
                raise SpectrumError(
                    f"column {col!r} (field {idx + 1}) is not a number", file=path, line=lineno
                ) from None
        wl.append(pair[0])
        values.append(pair[1])
        lines.append(lineno)
    if header is None:
        raise SpectrumError(f"spectrum file is empty: expected {expected}", file=path)
    if not wl:
        raise SpectrumError("spectrum file has a header but no data rows", file=path)
    return np.asarray(wl), np.asarray(values), lines


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def write_csv(path: Path, wavelengths_nm, values, kind: str, name: str = "") -> Path:
    """Write a spectrum CSV atomically (temporary file in the same folder, then rename).

    Numbers are written with ``repr`` so that reading them back is exact.
    """
    path = Path(path)
    rows = [f"# lumijax spectrum {name!r} ({kind}); wavelengths in nm\n"]
    rows.append(f"{WAVELENGTH_COLUMN},{VALUE_COLUMN[kind]}\n")
    rows += [f"{float(w)!r},{float(v)!r}\n" for w, v in zip(wavelengths_nm, values)]
    return atomic_write_text(path, "".join(rows), what="spectrum file")
