"""``read_photometry``: pick the parser by content, not by file extension."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import PhotometryError
from ._ies import parse_ies
from ._ldt import looks_like_ldt, parse_ldt
from ._photometry import Photometry
from ._text import FileProblem, decode_text, read_regular_file, split_lines

__all__ = ["read_photometry"]


def read_photometry(path: str | os.PathLike, *, allow_outside: bool = False) -> Photometry:
    """Read an IES LM-63 or EULUMDAT file into absolute photometry.

    The format is recognised by content: an IES file has a ``TILT=`` line (or starts with an
    ``IESNA``/``IES:`` tag); an EULUMDAT file has one value per line with Ityp and Isym on lines
    2 and 3. Intensities are made absolute (cd), symmetric data are expanded to the full sphere,
    luminous dimensions are converted to metres. See ``docs/photometry.md``.

    Parameters
    ----------
    path
        The photometric file.
    allow_outside
        An IES ``TILT=<file>`` line names another file. By default that file must lie in the
        photometric file's own folder or below it (after resolving ``..`` and symbolic links):
        ``TILT=/etc/passwd`` or ``TILT=../../x`` are refused. Pass ``True`` only for files you
        trust to name any file on this machine.

    Returns
    -------
    Photometry

    Raises
    ------
    PhotometryError
        The file is missing, not a regular file, or malformed, or its photometry cannot be
        physical; the error names the file and, where it can, the line. No other exception
        escapes for any file content.

    Warns
    -----
    LumijaxWarning
        The header's flux disagrees with the data (the photometry still loads).
    """
    p = Path(path)
    try:
        raw = read_regular_file(p)
    except FileProblem as exc:
        msg = str(exc)
        raise PhotometryError(
            "photometric file not found" if msg == "not found" else f"the photometric file {msg}",
            file=p,
        ) from None
    return parse_photometry(p, raw, allow_outside=allow_outside)


def parse_photometry(path: Path, raw: bytes, *, allow_outside: bool = False) -> Photometry:
    """Parse the bytes of a photometric file read from ``path`` (which names it in errors).

    ``path``'s folder is where a ``TILT=<file>`` is looked for. See :func:`read_photometry`.
    """
    text = decode_text(raw, path)
    lines = split_lines(text)
    if not any(line.strip() for line in lines):
        raise PhotometryError("the file is empty", file=path)
    head = lines[0].strip().upper()
    has_tilt = any(line.lstrip().upper().startswith("TILT") and "=" in line for line in lines)
    if has_tilt or head.startswith("IESNA") or head.startswith("IES:"):
        return parse_ies(path, text, allow_outside=allow_outside)
    if looks_like_ldt(lines):
        return parse_ldt(path, text)
    raise PhotometryError(
        "not a photometric file lumijax can read: no 'TILT=' line (IES LM-63) and lines 2–3 are "
        "not EULUMDAT's Ityp/Isym",
        file=path,
        line=len(lines),
    )
