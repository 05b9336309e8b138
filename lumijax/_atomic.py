"""Atomic file writes: a temporary file in the destination's folder, then one rename.

A reader never sees a half-written file, and a failure leaves the old file (or none) in place.
Every writer in lumijax (results, caches, photometry, spectra, images) goes through here.

A temporary file's name carries its writer's process id (``.NAME.lumijax-tmp-PID-XXXX``), so
one orphaned by a killed process (kill -9 skips every ``finally``) is recognised and removed by
:func:`remove_orphans` on a later run, while a live writer's file is left alone.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

from .errors import OutputError

__all__ = [
    "FolderLock", "atomic_path", "atomic_write_bytes", "atomic_write_text", "exchange_paths",
    "file_mode", "fsync_dir", "fsync_tree", "is_temporary", "pid_alive", "remove_orphans",
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


def is_temporary(name: str) -> bool:
    """Whether ``name`` is one of :func:`atomic_path`'s temporary files."""
    return name.startswith(".") and _TMP_RE.search(name) is not None


def remove_orphans(folder: str | Path) -> list[Path]:
    """Delete the temporary files in ``folder`` whose writing process is dead; return them.

    Only names :func:`atomic_path` makes are considered, and never a live process's. A pid reused
    by an unrelated live process keeps its orphan until that process ends (the safe side).
    """
    removed: list[Path] = []
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


# -- folders: a lock beside one, and swapping a staged folder in --------------------------------

try:
    import fcntl
except ImportError:  # Windows: no advisory locks here; runs into one folder are not serialised
    fcntl = None


class FolderLock:
    """An exclusive lock on the folder ``out``, held through the file ``<out>.lock`` beside it.

    ``fcntl.flock`` on that file: the kernel drops it when the holder exits, however it exits
    (kill -9 included), so a lock is never stale; a leftover lock file is simply locked again.
    A second holder fails at once with an :class:`OutputError` naming the folder and the pid of
    the holder (written into the lock file). Use as a context manager.
    """

    def __init__(self, out: str | Path) -> None:
        self.out = Path(out)
        self.path = self.out.with_name(self.out.name + ".lock")
        self._fd: int | None = None

    def __enter__(self) -> FolderLock:
        if fcntl is None:
            return self
        while True:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0),
                             0o644)
            except OSError as e:
                raise OutputError(f"cannot lock the output folder: {e.strerror or e}",
                                  file=self.out) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = os.read(fd, 32).decode("ascii", "replace").strip() or "unknown"
                os.close(fd)
                raise OutputError(f"another lumijax run (pid {holder}) is writing this folder; "
                                  "wait for it, or give another --out", file=self.out) from None
            try:  # a holder that just released unlinked the file we opened: lock the new one
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except OSError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path)  # before the unlock: a waiter then sees a new file
            os.close(self._fd)
            self._fd = None


_RENAME_EXCHANGE = 2


def exchange_paths(a: str | Path, b: str | Path) -> bool:
    """Swap two folders in one atomic step (Linux ``renameat2(RENAME_EXCHANGE)``).

    False where the system or file system cannot (then nothing was changed).
    """
    if not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):  # glibc < 2.28, musl
        return False
    at_fdcwd = -100
    rc = fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EXDEV):
        return False
    raise OSError(err, os.strerror(err), str(b))


def fsync_tree(folder: str | Path) -> None:
    """Flush every file under ``folder``, and the folders themselves, to disk."""
    for root, _dirs, files in os.walk(folder):
        for name in files:
            fd = os.open(os.path.join(root, name), os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        fsync_dir(root)


def fsync_dir(folder: str | Path) -> None:
    """Flush a folder's entries (renames into it) to disk, where the system allows."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems refuse fsync on a folder
        pass
    finally:
        os.close(fd)
