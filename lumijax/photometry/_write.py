"""``write_ies``: LM-63-2019 output with absolute photometry, written atomically."""

from __future__ import annotations

import datetime
import os
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_bytes
from ._opening import encode_ies_opening
from ._photometry import Photometry

__all__ = ["write_ies"]

_TYPE_CODES = {"C": 1, "B": 2, "A": 3}
# LM-63-2019 file generation type "computer simulation" [mem: check the standard's table].
_GENERATED = "1.00010"


def _fmt(x: float) -> str:
    # 10 significant digits keep a round trip through text well below any photometric tolerance.
    s = f"{float(x):.10g}"
    return "0" if s == "-0" else s


def _rows(values, per_line: int = 10) -> list[str]:
    vals = [_fmt(x) for x in values]
    return [" ".join(vals[k : k + per_line]) for k in range(0, len(vals), per_line)]


def _keyword_lines(key: str, text: str) -> list[str]:
    parts = str(text).splitlines() or [""]
    return [f"[{key}] {parts[0]}".rstrip()] + [f"[MORE] {p}".rstrip() for p in parts[1:]]


def write_ies(photometry: Photometry, path: str | os.PathLike) -> Path:
    """Write ``photometry`` as an IES LM-63-2019 file (absolute photometry, metres).

    The full expanded table is written (Type C: C = 0…360, no symmetry folding), with candela
    multiplier 1, lumens per lamp −1 and the luminous opening in the 2002/2019 sign convention,
    so :func:`read_photometry` reads back the same distribution. A tilt table, if any, is written
    as ``TILT=INCLUDE``. The file is written to a temporary file beside ``path`` and moved into
    place, so readers never see a half-written file.

    Returns
    -------
    The path written.
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        gen = f"lumijax {version('lumijax')}"
    except PackageNotFoundError:
        gen = "lumijax"
    path = Path(path)
    dist = photometry.distribution
    kw = dict(photometry.keywords)
    name = photometry.name
    src = f" from {photometry.source.name}" if photometry.source is not None else ""
    lines = ["IES:LM-63-2019"]
    lines += _keyword_lines(
        "TEST", kw.get("TEST") or f"{gen} generated photometry, not a measurement"
    )
    lines += _keyword_lines("TESTLAB", kw.get("TESTLAB") or f"none: computed by {gen}")
    lines += _keyword_lines("ISSUEDATE", datetime.date.today().isoformat())
    lines += _keyword_lines("MANUFAC", kw.get("MANUFAC") or "lumijax")
    lines += _keyword_lines("LUMCAT", kw.get("LUMCAT") or name)
    lines += _keyword_lines("LUMINAIRE", kw.get("LUMINAIRE") or name)
    lines += _keyword_lines(
        "FILEGENINFO",
        f"Written by {gen}{src} ({photometry.format} {photometry.version}); "
        "absolute photometry, full table without symmetry folding",
    )
    if photometry.tilt is None:
        lines.append("TILT=NONE")
    else:
        t = photometry.tilt
        lines += ["TILT=INCLUDE", str(t.geometry), str(len(t.angles_deg))]
        lines += [" ".join(_fmt(a) for a in t.angles_deg), " ".join(_fmt(f) for f in t.factors)]
    h = np.asarray(dist.h_deg, dtype=np.float64)
    v = np.asarray(dist.v_deg, dtype=np.float64)
    cd = np.asarray(dist.candela, dtype=np.float64)
    w, ln, ht = encode_ies_opening(photometry.opening)
    lines.append(
        f"1 -1 1 {v.size} {h.size} {_TYPE_CODES[dist.photometric_type]} 2 "
        f"{_fmt(w)} {_fmt(ln)} {_fmt(ht)}"
    )
    lines.append(f"1 {_GENERATED} {_fmt(photometry.input_watts or 0.0)}")
    lines += _rows(v)
    lines += _rows(h)
    for row in cd:
        lines += _rows(row)
    data = ("\r\n".join(lines) + "\r\n").encode("latin-1", errors="replace")

    atomic_write_bytes(path, data, what="IES file")
    return path
