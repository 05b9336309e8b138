"""Text handling shared by the IES and EULUMDAT readers: decoding, lines, quoting, limits."""

from __future__ import annotations

import errno
import os
import re
import stat
from pathlib import Path

import numpy as np

from ..errors import PhotometryError

__all__ = [
    "FLOAT32_MAX",
    "MAX_FILE_BYTES",
    "decode_text",
    "quote",
    "split_lines",
]

# Intensities are stored as float32 unless x64 is enabled: anything larger is not representable.
FLOAT32_MAX = float(np.finfo(np.float32).max)
# The largest real photometric files are a few hundred kB; this only stops a runaway read.
MAX_FILE_BYTES = 64 * 2**20
_LINE_BREAK = re.compile(r"\r\n|\r|\n")


def quote(token: str) -> str:
    """What an offending token is, without its text.

    A study may name any readable file as photometry (docs/config.md, "Paths"), so a file that
    fails to parse may be ``/etc/passwd``: the message gives the line and what was expected, and
    only the token's length — never its characters."""
    return f"text of {len(token)} character{'s' if len(token) != 1 else ''}"


def split_lines(text: str) -> list[str]:
    """Lines split at CR LF, CR or LF only, so line numbers are those an editor shows.

    ``str.splitlines`` would also break at form feeds, NEL (0x85, common as "…" in cp1252
    labels) and other separators, shifting every later line number and EULUMDAT's fixed lines.
    """
    lines = _LINE_BREAK.split(text)
    if lines and lines[-1] == "":
        lines.pop()
    return lines


def decode_text(raw: bytes, file: str | Path | None = None) -> str:
    """Latin-1 (never fails, keeps ASCII intact) after a UTF-8 BOM is dropped; UTF-16 with a BOM.

    Raises :class:`PhotometryError` for a file that is not text: invalid UTF-16 after a UTF-16
    byte-order mark, or NUL bytes (a binary file, or UTF-16 without a byte-order mark). The
    message gives the line, never the content.
    """
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            text = raw.decode("utf-16")
        except UnicodeDecodeError as exc:
            raise PhotometryError(
                f"the file starts with a UTF-16 byte-order mark but is not valid UTF-16 "
                f"({exc.reason} at byte {exc.start})",
                file=file,
            ) from None
        if text.startswith("\ufeff"):
            text = text[1:]
    else:
        if raw.startswith(b"\xef\xbb\xbf"):
            raw = raw[3:]
        text = raw.decode("latin-1")
    nul = text.find("\x00")
    if nul >= 0:
        line = len(_LINE_BREAK.findall(text, 0, nul)) + 1
        raise PhotometryError(
            "the file holds a NUL character: not a text photometric file (binary data, or "
            "UTF-16/UTF-32 text without a byte-order mark?)",
            file=file,
            line=line,
        )
    return text


class FileProblem(Exception):
    """Why a file could not be read (internal: callers turn it into a PhotometryError)."""


def read_regular_file(path: Path, limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes, else :class:`FileProblem`.

    Directories, devices, pipes and sockets are refused before anything is read (reading
    ``/dev/zero`` or a FIFO would never end).
    """
    try:
        st = os.stat(path)
        if stat.S_ISDIR(st.st_mode):
            raise FileProblem("is a directory, not a file")
        if not stat.S_ISREG(st.st_mode):
            raise FileProblem("is not a regular file (a device, pipe or socket?)")
        if st.st_size > limit:
            raise FileProblem(f"is {st.st_size} bytes, more than the {limit} bytes lumijax reads")
        with open(path, "rb") as fh:
            raw = fh.read(limit + 1)
    except FileProblem:
        raise
    except ValueError:  # an embedded NUL character in the name
        raise FileProblem("has a NUL character in its name") from None
    except (FileNotFoundError, NotADirectoryError):
        raise FileProblem("not found") from None
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise FileProblem("has a name too long for the file system") from None
        if exc.errno == errno.ELOOP:
            raise FileProblem("is a loop of symbolic links") from None
        raise FileProblem(f"cannot be read: {exc.strerror or type(exc).__name__}") from None
    if len(raw) > limit:
        raise FileProblem(f"is more than the {limit} bytes lumijax reads")
    return raw
