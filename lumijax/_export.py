"""Serialised programs (``jax.export``) kept beside the compilation cache, so that a new process
calls a hot compiled function without tracing and lowering it again.

JAX's persistent compilation cache (:mod:`lumijax._jit_cache`) keeps the *executables*, but a
new process still traces each jitted function and lowers it to StableHLO before it can even
look the executable up: for the radiosity solve of a small study that is ~0.9 s of tracing
and ~1.4 s of lowering (contended), more than the solve itself. Here the lowered program is
stored once, serialised by ``jax.export``; a later process deserialises it (milliseconds),
lowers the small ``call_exported`` wrapper and finds its executable in the compilation cache.

Where: ``<compilation cache folder>/export/`` — only while the compilation cache is on (the
command line turns it on; a library call that never enabled it exports nothing). One file per
key, ``MAGIC + blake2b(payload) + payload``, written to a temporary file and renamed (as the
compilation cache's entries are). The key is a digest of everything the trace depends on: the
function's name, the jax/jaxlib/equinox/lineax/lumijax versions, the source of the modules
it traces (``code``), x64 and the default matmul precision, the backend, the structure and
static values of the arguments (equinox modules' static fields, the solver, tolerances) and
every array's shape and dtype. An argument on several devices, or a static value whose repr
names an address, is not cached (the call is the plain one).

Bad input: an entry that fails its digest or cannot be deserialised (truncated, corrupted,
foreign) is ignored with a :class:`~lumijax.errors.LumijaxWarning` and rebuilt; a folder that
cannot be written gives one warning and the plain call. Nothing here raises on a cache
problem. Clearing: delete the folder (``lumijax cache clear`` is not needed: any edit of the
traced code or an upgrade changes every key, and old entries are only read by their own key).
"""

from __future__ import annotations

import hashlib
import re
import sys
import threading
import warnings
from collections.abc import Callable
from pathlib import Path

__all__ = ["MAGIC", "call", "export_dir", "source_digest"]

MAGIC = b"lumijax-export-1\n"
_lock = threading.Lock()
_warned: set[str] = set()
_sources: dict[tuple[str, ...], str] = {}
#: custom-call targets exported without JAX's compatibility guarantee: an entry is only ever
#: read by the same jaxlib on the same backend (both in its key), so the guarantee (that a
#: later jaxlib runs it) is not needed. CPU LAPACK's QR and triangular solve (GMRES's least
#: squares); others met on another backend are added from the exporter's own message.
_TARGETS = tuple(f"lapack_{t}{op}_ffi" for t in "sd" for op in ("geqrf", "ormqr", "orgqr", "trsm"))


def _warn(key: str, message: str) -> None:
    from .errors import LumijaxWarning

    with _lock:
        if key in _warned:
            return
        _warned.add(key)
    warnings.warn(message, LumijaxWarning, stacklevel=3)


def export_dir() -> Path | None:
    """The folder of this process's exported programs: ``export/`` inside the compilation
    cache folder :func:`lumijax._jit_cache.enable_compilation_cache` turned on, or None when it
    is off (nothing is exported then). Nothing is created."""
    from . import _jit_cache

    base = _jit_cache._enabled
    return None if base is None else base / "export"


def source_digest(*modules: str) -> str:
    """blake2b of the source of the named lumijax modules (``"radiosity/_solve.py"``; a folder
    ``"radiosity/"`` means its every ``.py``) and of the versions that shape a trace."""
    with _lock:
        got = _sources.get(modules)
    if got is not None:
        return got
    import equinox
    import jax
    import jaxlib
    import lineax

    from ._version import __version__

    root = Path(__file__).resolve().parent
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{jax.__version__} {jaxlib.__version__} {equinox.__version__} "
             f"{lineax.__version__} {__version__} {sys.version_info[:2]}".encode())
    for rel in modules:
        files = sorted((root / rel).glob("*.py")) if rel.endswith("/") else [root / rel]
        for f in files:
            try:
                h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes())
            except OSError:  # a bytecode-only install: the versions alone must do
                h.update(rel.encode() + b"\0missing")
    digest = h.hexdigest()
    with _lock:
        _sources[modules] = digest
    return digest


def _key(name: str, code: str, treedef, static, leaves) -> str | None:
    """The entry's key (hex), or None when the call cannot be keyed safely."""
    import jax

    parts = [name, code, str(jax.config.jax_enable_x64),
             str(jax.config.jax_default_matmul_precision), jax.default_backend(),
             str(treedef), str(jax.tree.structure(static))]
    for v in jax.tree.leaves(static):
        r = repr(v)
        if " at 0x" in r:  # a function or object without a value repr: nothing stable to key
            return None
        parts.append(f"{type(v).__qualname__}:{r}")
    for x in leaves:
        if len(x.sharding.device_set) > 1:  # sharded over devices: the plain call
            return None
        parts.append(f"{x.dtype}{x.shape}{getattr(x, 'weak_type', False)}")
    return hashlib.blake2b("\n".join(parts).encode(), digest_size=24).hexdigest()


def _read(file: Path):
    """The deserialised program in ``file``, or None (missing, or warned and to be rebuilt)."""
    from jax import export

    try:
        data = file.read_bytes()
    except (FileNotFoundError, NotADirectoryError):  # no entry (or no folder) yet
        return None
    except OSError as e:
        _warn("read", f"exported program {file} is unreadable ({type(e).__name__}): ignored and "
              "rebuilt")
        return None
    from ._jit_cache import unseal

    payload, why = unseal(data, MAGIC)
    if payload is not None:
        try:
            return export.deserialize(bytearray(payload))
        except Exception as e:  # a payload from another JAX that passed the digest
            why = f"not readable by this JAX ({type(e).__name__})"
    _warn("corrupt", f"exported program {file} is {why}: ignored and rebuilt (any other such "
          f"entries in {file.parent} are rebuilt silently)")
    return None


def _write(folder: Path, file: Path, payload: bytes) -> None:
    from ._jit_cache import write_sealed

    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_sealed(file, payload, MAGIC)
    except OSError as e:
        _warn("write", f"cannot write exported programs in {folder} ({type(e).__name__}: "
              f"{e.strerror or e}); each run traces its kernels again")


def _export(flat: Callable, leaves):
    """``jax.export`` of ``flat`` at ``leaves``' shapes, letting through the custom calls the
    exporter names (``_TARGETS`` first): the entry is keyed by the exact jaxlib and backend."""
    import jax
    from jax import export

    targets = set(_TARGETS)
    for _ in range(4):
        checks = [export.DisabledSafetyCheck.custom_call(t) for t in sorted(targets)]
        try:
            return export.export(jax.jit(flat), disabled_checks=checks)(*leaves)
        except ValueError as e:
            more = set(re.findall(r"custom_call @(\w+)", str(e))) - targets
            if "custom call" not in str(e) or not more:
                raise
            targets |= more
    raise ValueError("too many custom-call targets to export")


def call(name: str, fn: Callable, args: tuple, code: str,
         compiler_options: dict | None = None):
    """``fn(*args)``, through a stored export of ``fn`` when the compilation cache is on.

    ``fn`` must be traceable with its array arguments (equinox's ``is_array`` leaves of
    ``args``) as inputs and everything else static, and return a ``dict`` of arrays (a
    structure ``jax.export`` can serialise). ``code`` is :func:`source_digest` of the modules
    it traces; ``compiler_options`` are XLA's for the executable (the stored program does not
    depend on them; the compilation cache keys its executables by them). Returns None, having
    traced nothing, when the call is not for the cache (the
    cache off, a traced or multi-device argument, an unkeyable static value) or ``fn`` cannot
    be exported (warned once): the caller then makes its plain call.
    """
    import equinox as eqx
    import jax

    folder = export_dir()
    dyn, static = eqx.partition(args, eqx.is_array)
    leaves, treedef = jax.tree.flatten(dyn)

    def flat(*xs):
        return fn(*eqx.combine(jax.tree.unflatten(treedef, list(xs)), static))

    if folder is None or any(isinstance(x, jax.core.Tracer) for x in leaves):
        return None
    from ._jit_cache import to_device

    leaves = [x if isinstance(x, jax.Array) else to_device(x) for x in leaves]
    key = _key(name, code, treedef, static, leaves)
    if key is None:
        return None
    file = folder / f"{name}-{key}.ljxe"
    def run(exp):
        if compiler_options is None:
            return exp.call(*leaves)
        return jax.jit(exp.call, compiler_options=compiler_options)(*leaves)

    exp = _read(file)
    if exp is not None:
        try:
            return run(exp)
        except Exception as e:  # a program that does not fit its key: rebuilt below
            _warn("call", f"exported program {file} could not be called ({type(e).__name__}: "
                  f"{e}): rebuilt")
    try:
        exp = _export(flat, leaves)
        payload = bytes(exp.serialize())
    except Exception as e:  # not exportable here: the plain call, every time (said once)
        _warn("export", f"{name} cannot be exported ({type(e).__name__}: {e}); it is traced "
              "in every process")
        return None
    _write(folder, file, payload)
    return run(exp)
