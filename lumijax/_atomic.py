"""Atomic file writes: a temporary file in the destination's folder, then one rename.

A reader never sees a half-written file, and a failure leaves the old file (or none) in place.
Every writer in lumijax (results, caches, photometry, spectra, images) goes through here.

A temporary file's name carries its writer's process id (``.NAME.lumijax-tmp-PID-XXXX``), so
one orphaned by a killed process (kill -9 skips every ``finally``) is recognised and removed by
:func:`remove_orphans` on a later run, while a live writer's file is left alone.
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from collections.abc import Iterator
from pathlib import Path

from .errors import OutputError

__all__ = [
    "atomic_path", "atomic_write_bytes", "atomic_write_text", "file_mode", "pid_alive",
    "remove_orphans",
]

_TMP_TAG = ".lumijax-tmp-"
_TMP_RE = re.compile(re.escape(_TMP_TAG) + r"(\d+)-")


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this machine (another user's counts as alive)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError:  # e.g. Windows, where signal 0 is not a probe: assume alive (keep the file)
        return True
    return True


def remove_orphans(folder: str | Path) -> list[Path]:
    """Delete the temporary files in ``folder`` whose writing process is dead; return them.

    Only names :func:`atomic_path` makes are considered, and never a live process's. A pid reused
    by an unrelated live process keeps its orphan until that process ends (the safe side).
    """
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        m = _TMP_RE.search(e.name)
        if m is None or not e.name.startswith(".") or pid_alive(int(m.group(1))):
            continue
        with contextlib.suppress(OSError):
            os.unlink(e.path)
            removed.append(Path(e.path))
    return removed


def file_mode() -> int:
    """The mode a plain ``open`` would give under the current umask (mkstemp's is 0600)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def atomic_path(path: str | Path, *, what: str = "file", suffix: str = ".tmp") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` atomically.

    ``OSError`` becomes an :class:`OutputError` naming the file; the temporary file never
    outlives the block. ``suffix`` is the temporary file's ending, for writers that choose a
    format by it (VTK's screenshot).
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(dir=path.parent, suffix=suffix,
                                    prefix=f".{path.name}{_TMP_TAG}{os.getpid()}-")
        os.close(fd)
    except OSError as e:
        raise OutputError(f"cannot write the {what}: {e.strerror or e}", file=path) from None
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except OSError as e:
        raise OutputError(f"cannot write the {what}: {e.strerror or e}", file=path) from None
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | Path, data: bytes, *, what: str = "file") -> Path:
    """Write ``data`` to ``path`` atomically (flushed to disk before the rename)."""
    with atomic_path(path, what=what) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    return Path(path)


def atomic_write_text(path: str | Path, text: str, *, what: str = "file") -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"), what=what)
