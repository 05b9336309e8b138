"""``read_photometry``: pick the parser by content, not by file extension."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import PhotometryError
from ._ies import decode_text, parse_ies
from ._ldt import looks_like_ldt, parse_ldt
from ._photometry import Photometry

__all__ = ["read_photometry"]


def read_photometry(path: str | os.PathLike) -> Photometry:
    """Read an IES LM-63 or EULUMDAT file into absolute photometry.

    The format is recognised by content: an IES file has a ``TILT=`` line (or starts with an
    ``IESNA``/``IES:`` tag); an EULUMDAT file has one value per line with Ityp and Isym on lines
    2 and 3. Intensities are made absolute (cd), symmetric data are expanded to the full sphere,
    luminous dimensions are converted to metres. See ``docs/photometry.md``.

    Parameters
    ----------
    path
        The photometric file.

    Returns
    -------
    Photometry

    Raises
    ------
    PhotometryError
        The file is missing or malformed; the error names the file and, where it can, the line.

    Warns
    -----
    LumijaxWarning
        The header's flux disagrees with the data (the photometry still loads).
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise PhotometryError("photometric file not found", file=p) from None
    except OSError as exc:
        raise PhotometryError(f"cannot read the file: {exc.strerror or exc}", file=p) from None
    text = decode_text(raw)
    lines = text.splitlines()
    if not any(line.strip() for line in lines):
        raise PhotometryError("the file is empty", file=p)
    head = lines[0].strip().upper()
    has_tilt = any(line.lstrip().upper().startswith("TILT") and "=" in line for line in lines)
    if has_tilt or head.startswith("IESNA") or head.startswith("IES:"):
        return parse_ies(p, text)
    if looks_like_ldt(lines):
        return parse_ldt(p, text)
    raise PhotometryError(
        "not a photometric file lumijax can read: no 'TILT=' line (IES LM-63) and lines 2–3 are "
        "not EULUMDAT's Ityp/Isym",
        file=p,
        line=len(lines),
    )
