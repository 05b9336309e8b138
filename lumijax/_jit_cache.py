"""JAX's persistent compilation cache for lumijax's command line: compiled kernels kept on disk,
so a new process (a new study, the next ``lumijax run``) loads them instead of recompiling.

Where: ``$LUMIJAX_JAX_CACHE`` if set (``0``, ``off``, ``false``, ``no`` or empty: no cache),
else ``$XDG_CACHE_HOME/lumijax/jax``, else ``~/.cache/lumijax/jax``; inside it one folder per
(jax, jaxlib, lumijax) version, so an upgrade never reads another version's executables.

Entries are written as ``MAGIC + blake2b(payload) + payload`` to a temporary file in the same
folder and renamed into place (``os.replace`` is atomic on one filesystem): concurrent runs
never see half an entry, and two runs writing the same key leave one whole copy. An entry that
fails its digest (truncated, corrupted, or a foreign file) is ignored with a
:class:`~lumijax.errors.LumijaxWarning` and recompiled — JAX then replaces it. A folder that
cannot be written falls back to no persistent cache, with a warning; nothing here raises.

A cache is trusted code (JAX's warning): it lives in the user's own cache folder. A user who
set ``jax_compilation_cache_dir`` (``JAX_COMPILATION_CACHE_DIR``) keeps theirs.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
import threading
import warnings
from pathlib import Path

__all__ = ["ENV", "MIN_COMPILE_S", "cache_dir", "enable_compilation_cache", "to_device",
           "host_cast", "host_empty", "HOST_ALIGN", "size_class", "VerifiedFileCache"]

ENV = "LUMIJAX_JAX_CACHE"
"""Environment variable: a folder for the cache, or ``0``/``off``/``false``/``no``/empty."""

MIN_COMPILE_S = 0.0
"""Compilations faster than this (s) are not written. Every one is (JAX's default is 1 s): a
warm ``lumijax run`` of a small study compiled ~76 kernels under 0.1 s each, 3.1 s of its 7.1 s
of XLA time (measured with ``JAX_LOG_COMPILES``, contended), and loading an entry costs a few
ms; a study's entries take ~1.5 MB (212 files for two small rooms)."""

MAGIC = b"lumijax-jax-cache-1\n"
_DIGEST = 32


def seal(payload: bytes, magic: bytes = MAGIC) -> bytes:
    """``magic + blake2b(payload) + payload``: what a cache entry holds on disk."""
    return magic + hashlib.blake2b(payload, digest_size=_DIGEST).digest() + payload


def unseal(data: bytes, magic: bytes = MAGIC) -> tuple[bytes | None, str]:
    """The payload of a sealed entry, or None and why it is not one (foreign, truncated,
    corrupted)."""
    head = len(magic) + _DIGEST
    if not data.startswith(magic) or len(data) < head:
        return None, "not one lumijax wrote (foreign or truncated)"
    payload = data[head:]
    if hashlib.blake2b(payload, digest_size=_DIGEST).digest() != data[len(magic):head]:
        return None, "corrupted (its digest does not match)"
    return payload, ""


def write_sealed(file: Path, payload: bytes, magic: bytes = MAGIC) -> None:
    """Write a sealed entry through a temporary file in its folder and one rename, so concurrent
    runs never see half an entry; raises ``OSError`` (the callers warn and carry on)."""
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=file.parent, prefix=f".{file.name[:20]}-", suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(seal(payload, magic))
        os.replace(tmp, file)
        tmp = None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
_OFF = {"", "0", "off", "false", "no"}

_lock = threading.Lock()
_enabled: Path | None = None


def _versions() -> str:
    import jax
    import jaxlib

    from ._version import __version__

    return f"jax-{jax.__version__}_jaxlib-{jaxlib.__version__}_lumijax-{__version__}"


def cache_dir() -> Path | None:
    """The folder this process's cache would use (versions included), or None when turned off
    by ``$LUMIJAX_JAX_CACHE``. Nothing is created."""
    env = os.environ.get(ENV)
    if env is not None:
        if env.strip().lower() in _OFF:
            return None
        root = Path(env).expanduser()
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
        root = base / "lumijax" / "jax"
    return root / _versions()


def _warn(message: str) -> None:
    from .errors import LumijaxWarning

    warnings.warn(message, LumijaxWarning, stacklevel=3)


def _writable(path: Path) -> str | None:
    """None if ``path`` can be created and written, else why not."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=path, prefix=".probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        return f"{type(e).__name__}: {e.strerror or e}"
    return None


def _cache_base():
    try:  # JAX's (private) interface; any object with get/put serves where it moved
        from jax._src.compilation_cache_interface import CacheInterface
    except ImportError:
        return object
    return CacheInterface


class VerifiedFileCache(_cache_base()):
    """A JAX compilation cache of one file per key, digest-checked and atomically written."""

    def __init__(self, path: str | Path):
        self._path = Path(path)
        self._warned = False

    def _file(self, key: str) -> Path:
        return self._path / f"{key}.ljx"

    def _corrupt(self, file: Path, why: str) -> None:
        if not self._warned:
            self._warned = True
            _warn(f"compilation cache entry {file} is {why}: ignored and recompiled (any "
                  f"other such entries in {self._path} are ignored silently)")

    def get(self, key: str) -> bytes | None:
        file = self._file(key)
        try:
            data = file.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as e:
            self._corrupt(file, f"unreadable ({type(e).__name__})")
            return None
        payload, why = unseal(data)
        if payload is None:
            self._corrupt(file, why)
        return payload

    def put(self, key: str, value: bytes) -> None:
        try:
            write_sealed(self._file(key), value)
        except OSError as e:
            if not self._warned:
                self._warned = True
                _warn(f"cannot write the compilation cache in {self._path} "
                      f"({type(e).__name__}: {e.strerror or e}); compiled kernels are not kept")

    def clear(self) -> None:
        for f in self._path.glob("*.ljx"):
            f.unlink(missing_ok=True)


def enable_compilation_cache() -> Path | None:
    """Turn JAX's persistent compilation cache on at :func:`cache_dir` (once per process).

    Returns the folder in use, or None: turned off by ``$LUMIJAX_JAX_CACHE``, a cache the user
    configured in JAX (kept as it is), or a folder that cannot be written (warned). Call it
    before the first compilation: JAX reads its cache setting once.
    """
    global _enabled
    import jax

    with _lock:
        if _enabled is not None:
            return _enabled
        if jax.config.jax_compilation_cache_dir:
            return None  # the user's own JAX cache
        path = cache_dir()
        if path is None:
            return None
        why = _writable(path)
        if why is not None:
            _warn(f"cannot use the compilation cache folder {path} ({why}); running without a "
                  f"persistent compilation cache (set {ENV} to another folder, or to 0)")
            return None
        try:
            from jax._src import compilation_cache as cc

            with cc._cache_initialized_mutex:
                if cc._cache is None:
                    cc._cache = VerifiedFileCache(path)
                    cc._cache_initialized = True
        except (ImportError, AttributeError):
            pass  # another JAX: its own file cache at the same folder, without the digest
        jax.config.update("jax_compilation_cache_dir", str(path))
        if jax.config.jax_persistent_cache_min_compile_time_secs == 1.0:  # JAX's default
            jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_S)
        _enabled = path
        return path


def size_class(n: int, least: int = 1) -> int:
    """The length an axis of ``n`` is padded to before a compiled call: the next power of two,
    at least ``least``. A compiled program depends on its shapes, so calls whose counts fall in
    one class share it (in the process and, through the cache, in the next) instead of each
    compiling its own."""
    return max(least, 1 << max(int(n) - 1, 0).bit_length())


def to_device(x, dtype=None):
    """``jnp.asarray(x, dtype)`` without compiling a kernel when ``x`` is a numpy array.

    JAX 0.10's ``jnp.asarray`` of a numpy array binds ``lax.stage`` (and ``convert_element_type``
    when ``dtype`` differs), and each binds an eager kernel compiled once per shape and process:
    ~20-60 ms each (a persistent-cache hit still lowers and loads it), 30-40 of them in a small
    study's run. Here the cast is numpy's on the host (round to nearest, as XLA's) and the
    transfer ``jax.device_put``'s, which compiles nothing: the same values, dtype (JAX's
    canonical one: float64 is float32 unless x64 is on) and placement. Anything else (JAX arrays,
    tracers, Python scalars with their weak types) goes to ``jnp.asarray`` unchanged.
    """
    import jax
    import jax.numpy as jnp

    host = host_cast(x, dtype)
    if host is None:
        return jnp.asarray(x) if dtype is None else jnp.asarray(x, dtype)
    return jax.device_put(host)


#: Alignment (bytes) at which JAX's CPU client adopts a host buffer instead of copying it.
HOST_ALIGN = 64


def host_empty(n: int, dtype):
    """An uninitialised 1-D numpy array of ``n`` items that :func:`to_device` hands to JAX
    without a copy on the CPU (``jax.device_put`` adopts a buffer aligned to
    :data:`HOST_ALIGN` bytes, and copies any other). An operator of 10⁹ links (8 GB) is then
    held once, not twice while it is assembled (benchmarks/RESULTS.md, session 34). Write it
    before it is handed over and never after: JAX reads the same memory."""
    import numpy as np

    dtype = np.dtype(dtype)
    raw = np.empty(int(n) * dtype.itemsize + HOST_ALIGN, np.uint8)
    skip = -raw.ctypes.data % HOST_ALIGN
    return raw[skip:skip + int(n) * dtype.itemsize].view(dtype)


def host_cast(x, dtype=None):
    """A numpy array ``x`` in the dtype JAX would hold it in (``dtype``, or its own, made
    canonical: float64 is float32 unless x64 is on), cast by numpy on the host; None for
    anything else (JAX arrays, tracers, Python scalars, masked arrays)."""
    import jax
    import numpy as np

    if not isinstance(x, (np.ndarray, np.generic)) or isinstance(x, np.ma.MaskedArray):
        return None
    return np.asarray(x, jax.dtypes.canonicalize_dtype(
        x.dtype if dtype is None else np.dtype(dtype)))
