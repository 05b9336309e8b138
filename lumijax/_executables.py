"""Compiled programs kept beside the compilation cache, so that a new process calls a hot
function without tracing, lowering or compiling it again.

JAX's persistent compilation cache (:mod:`lumijax._jit_cache`) keeps the *executables*, but a
new process still traces each jitted function and lowers it to StableHLO before it can even
look the executable up: for the radiosity solve of a small study that was ~0.9 s of tracing
and ~1.4 s of lowering (contended), more than the solve itself. A stored ``jax.export`` (this
module until session 16) removed the trace, yet lowering its ``call_exported`` wrapper re-read
the whole program: 0.30 s of lowering and 0.19 s of cache lookup for the cube's solve. Here the
*loaded executable* itself is stored (``jax.experimental.serialize_executable``); a later
process deserialises it (~40 ms) and calls it: nothing is traced, lowered or looked up.

Where: ``<compilation cache folder>/executables/`` — only while the compilation cache is on (the
command line turns it on; a library call that never enabled it stores nothing). One file per
key, ``MAGIC + blake2b(payload) + payload``, written to a temporary file and renamed (as the
compilation cache's entries are). The key is a digest of everything the program depends on:
the function's name, the jax/jaxlib/equinox/lineax/lumijax versions, the source of the
modules it traces (``code``), x64 and the default matmul precision, the backend, its platform
version and device kind, this machine's CPU (architecture and instruction-set flags: an
executable compiled for one CPU must not run on another sharing the folder), XLA's options,
the structure and static values of the arguments (equinox modules' static fields, the solver,
tolerances) and every array's shape and dtype. An argument on several devices, or a static
value whose repr names an address, is not stored (the call is the plain one).

The folder is trusted as the code is: an executable is machine code, as in JAX's own cache.
Bad input: an entry that fails its digest, cannot be loaded (truncated, corrupted, foreign) or
loads but does not run is warned about (:class:`~lumijax.errors.LumijaxWarning`), removed and
compiled again (stored again unless JAX answered the compile from its own cache: see
:func:`_compile`); a folder that cannot be written gives one warning and the plain call.
Nothing here raises on a cache problem.
Clearing: delete the folder (any edit of the traced code or an upgrade changes every key, and
old entries are only read by their own key).
"""

from __future__ import annotations

import functools
import hashlib
import json
import platform
import sys
import threading
import warnings
from collections.abc import Callable
from pathlib import Path

__all__ = ["MAGIC", "SUFFIX", "UNOPTIMISED", "LEGACY_EMITTERS", "unoptimised",
           "quick_to_compile", "call", "store_dir", "source_digest", "stored"]

#: XLA's options for a program that runs about once per process and is small: LLVM's
#: optimisation passes off (compiling then costs more than running; radiosity/_solve.py,
#: "Small solves"). The small solve, the glare terms and the patch output's product use
#: :func:`unoptimised`, which adds :data:`LEGACY_EMITTERS` where this XLA has it.
UNOPTIMISED = {"xla_backend_optimization_level": 0}

#: XLA:CPU's switch from its MLIR fusion emitters back to the LLVM IR ones, off: a small
#: program's fusions compile in half the time (the furnished room's solve 1.0–1.1 → 0.45–0.49
#: s, session 20). For every program (``XLA_FLAGS``) it was measured and not taken: the direct
#: light's kernel ran 10–25 % slower (``benchmarks/direct.py``, 100 × 10⁵), the contour
#: kernel ~9 % (4,096 points a call: 1.99 → 2.17 ms, the same bits).
LEGACY_EMITTERS = "xla_cpu_use_fusion_emitters"


def unoptimised() -> dict:
    """:data:`UNOPTIMISED`, with :data:`LEGACY_EMITTERS` off where this XLA knows the option:
    for programs that run about once per process."""
    return _options(True, LEGACY_EMITTERS)  # type: ignore[return-value]


def quick_to_compile() -> dict | None:
    """:data:`LEGACY_EMITTERS` off where this XLA knows the option, LLVM's passes kept (None
    where it does not): for a kernel a small study calls a few times, which runs at most
    ~10-25 % slower and compiles in about half the time (``contour_flat`` 0.44–0.60 →
    0.19–0.20 s)."""
    return _options(False, LEGACY_EMITTERS)


@functools.cache
def _options(unoptimised: bool, legacy: str) -> dict | None:
    options = dict(UNOPTIMISED) if unoptimised else {}
    if _accepts(legacy):
        options[legacy] = False
    return options or None


@functools.cache
def _accepts(option: str) -> bool:
    """Whether XLA takes ``option`` (off): XLA is retiring the legacy emitters, and an option
    it does not know fails the compile, so a one-off compile of a trivial program asks first
    (~20 ms, once per process)."""
    import jax
    import numpy as np

    try:
        jax.jit(lambda x: x + 1, compiler_options={option: False}).lower(np.float32(0)).compile()
    except Exception:  # jaxlib's runtime error: "No such compile option"
        return False
    return True


MAGIC = b"lumijax-executable-1\n"
SUFFIX = ".ljxc"
_lock = threading.Lock()
_warned: set[str] = set()
_sources: dict[tuple[str, ...], str] = {}
_loaded: dict[str, object] = {}  # key → jax.stages.Compiled, this process's programs
_key_locks: dict[str, threading.Lock] = {}
_machine: list[str] = []


def _warn(key: str, message: str) -> None:
    from .errors import LumijaxWarning

    with _lock:
        if key in _warned:
            return
        _warned.add(key)
    warnings.warn(message, LumijaxWarning, stacklevel=3)


def store_dir() -> Path | None:
    """The folder of this process's stored programs: ``executables/`` inside the compilation
    cache folder :func:`lumijax._jit_cache.enable_compilation_cache` turned on, or None when it
    is off (nothing is stored then). Nothing is created."""
    from . import _jit_cache

    base = _jit_cache._enabled
    return None if base is None else base / "executables"


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


def _machine_id() -> str:
    """The CPU an executable was compiled for: architecture, and on Linux the instruction-set
    flags (XLA:CPU compiles for the host's features; a cache folder in a home shared by
    different machines must not hand one's code to another)."""
    if not _machine:
        ident = platform.machine()
        try:
            with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
                flags = next((ln for ln in f if ln.startswith(("flags", "Features"))), "")
            ident += " " + " ".join(sorted(flags.split(":", 1)[-1].split()))
        except OSError:  # not Linux: the processor's name
            ident += " " + platform.processor()
        _machine.append(hashlib.blake2b(ident.encode(), digest_size=8).hexdigest())
    return _machine[0]


def _key(name: str, code: str, treedef, static, leaves, options=None) -> str | None:
    """The entry's key (hex), or None when the call cannot be keyed safely."""
    import jax

    device = jax.devices()[0]
    parts = [name, code, str(jax.config.jax_enable_x64),
             str(jax.config.jax_default_matmul_precision), jax.default_backend(),
             device.client.platform_version, device.device_kind, _machine_id(),
             json.dumps(options, sort_keys=True, default=str),
             str(treedef), str(jax.tree.structure(static))]
    for v in jax.tree.leaves(static):
        r = repr(v)
        if " at 0x" in r:  # a function or object without a value repr: nothing stable to key
            return None
        parts.append(f"{type(v).__qualname__}:{r}")
    for x in leaves:
        if isinstance(x, jax.Array) and len(x.sharding.device_set) > 1:  # the plain call
            return None
        parts.append(f"{x.dtype}{x.shape}{getattr(x, 'weak_type', False)}")
    return hashlib.blake2b("\n".join(parts).encode(), digest_size=24).hexdigest()


def _spec(tree) -> object:
    """A JSON description of an output structure of dicts (str keys), tuples, lists, None and
    arrays: the output tree is rebuilt from it without tracing."""
    if isinstance(tree, dict):
        return {"d": {k: _spec(v) for k, v in tree.items()}}
    if isinstance(tree, (tuple, list)):
        return {"t" if isinstance(tree, tuple) else "l": [_spec(v) for v in tree]}
    return None if tree is None else 0


def _unspec(spec) -> object:
    if spec is None or spec == 0:
        return spec
    if "d" in spec:
        return {k: _unspec(v) for k, v in spec["d"].items()}
    items = [_unspec(v) for v in spec.get("t", spec.get("l", []))]
    return tuple(items) if "t" in spec else items


def _pack(compiled, out_spec, lapack: bool) -> bytes:
    from jax.experimental.serialize_executable import serialize

    payload, _, _ = serialize(compiled)
    head = json.dumps({"out": out_spec, "lapack": lapack}).encode()
    return head + b"\n" + payload


def _unpack(payload: bytes, n_in: int):
    """The loaded executable in ``payload`` (raises on a foreign or damaged one)."""
    import jax
    from jax.experimental.serialize_executable import deserialize_and_load

    head, _, exe = payload.partition(b"\n")
    meta = json.loads(head)
    if meta.get("lapack"):  # CPU LAPACK's kernels find their BLAS only once initialised
        import numpy as np
        from jaxlib import lapack

        lapack.prepare_lapack_call("geqrf", np.float32)
    in_tree = jax.tree.structure(((0,) * n_in, {}))
    out_tree = jax.tree.structure(_unspec(meta["out"]))
    return deserialize_and_load(exe, in_tree, out_tree)


def _read(file: Path, n_in: int):
    """The loaded program in ``file``, or None (missing, or warned and to be rebuilt)."""
    try:
        data = file.read_bytes()
    except (FileNotFoundError, NotADirectoryError):  # no entry (or no folder) yet
        return None
    except OSError as e:
        _warn("read", f"stored program {file} is unreadable ({type(e).__name__}): ignored and "
              "rebuilt")
        return None
    from ._jit_cache import unseal

    payload, why = unseal(data, MAGIC)
    if payload is not None:
        try:
            return _unpack(payload, n_in)
        except Exception as e:  # a payload from another JAX that passed the digest
            why = f"not loadable by this JAX ({type(e).__name__})"
    _warn("corrupt", f"stored program {file} is {why}: ignored and rebuilt (any other such "
          f"entries in {file.parent} are rebuilt silently)")
    _drop(file)
    return None


def _drop(file: Path) -> None:
    """Remove a bad entry, so that no later process meets it (the rebuild may not store)."""
    try:
        file.unlink()
    except OSError:
        pass


def _write(folder: Path, file: Path, payload: bytes) -> None:
    from ._jit_cache import write_sealed

    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_sealed(file, payload, MAGIC)
    except OSError as e:
        _warn("write", f"cannot write stored programs in {folder} ({type(e).__name__}: "
              f"{e.strerror or e}); each run traces its kernels again")


def call(name: str, fn: Callable, args: tuple, code: str,
         compiler_options: dict | None = None):
    """``fn(*args)``, through a stored executable of ``fn`` when the compilation cache is on.

    ``fn`` must be traceable with its array arguments (equinox's ``is_array`` leaves of
    ``args``) as inputs and everything else static, and return arrays in dicts, tuples and
    lists. ``code`` is :func:`source_digest` of the modules it traces; ``compiler_options``
    are XLA's for the executable (part of the key). Returns None, having traced nothing, when
    the call is not for the cache (the cache off, a traced or multi-device argument, an
    unkeyable static value): the caller then makes its plain call. A program that cannot be
    serialised runs compiled here and is said once.
    """
    import equinox as eqx
    import jax

    folder = store_dir()
    dyn, static = eqx.partition(args, eqx.is_array)
    leaves, treedef = jax.tree.flatten(dyn)
    if folder is None or any(isinstance(x, jax.core.Tracer) for x in leaves):
        return None
    leaves = [x if isinstance(x, jax.Array) else _host(x) for x in leaves]
    key = _key(name, code, treedef, static, leaves, compiler_options)
    if key is None:
        return None
    with _lock:
        compiled = _loaded.get(key)
        if compiled is None:  # one thread reads or compiles a key, the others wait for it
            key_lock = _key_locks.setdefault(key, threading.Lock())
    if compiled is None:
        with key_lock:
            return _load_or_compile(name, fn, static, treedef, leaves, compiler_options,
                                    folder, key)
    return compiled(*leaves)


def _host(x):
    """A host array as the executable takes it: numpy, in JAX's dtype for it
    (:func:`~lumijax._jit_cache.host_cast`); anything else as ``to_device`` makes it. The
    executable's own transfer of a numpy argument costs ~0.2 ms a call less than
    ``jax.device_put`` first (three 4,096-point arguments of the contour kernel, which an
    operator build calls thousands of times)."""
    from ._jit_cache import host_cast, to_device

    host = host_cast(x)
    return to_device(x) if host is None else host


def _load_or_compile(name, fn, static, treedef, leaves, options, folder: Path, key: str):
    """``fn`` at ``leaves`` by the program in memory, in the store, or compiled now."""
    with _lock:
        compiled = _loaded.get(key)
    if compiled is not None:  # another thread got it while this one waited
        return compiled(*leaves)
    file = folder / f"{name}-{key}{SUFFIX}"
    compiled = _read(file, len(leaves))
    if compiled is not None:
        try:
            out = compiled(*leaves)
        except Exception as e:  # loaded, yet it does not run: rebuilt below
            _warn("call", f"stored program {file} could not be called "
                  f"({type(e).__name__}: {e}): rebuilt")
            _drop(file)
        else:
            with _lock:
                _loaded[key] = compiled
            return out
    compiled = _compile(name, fn, static, treedef, leaves, options, folder, file)
    with _lock:
        _loaded[key] = compiled
    return compiled(*leaves)


def _compile(name, fn, static, treedef, leaves, options, folder: Path, file: Path):
    """``fn`` traced, lowered and compiled at ``leaves``; stored in ``file`` when XLA compiled
    it here. An executable JAX took from its own cache is not stored: serialised again it
    loses its code in XLA:CPU 0.10 (a later process fails with "Function … not found"), so
    such a key keeps JAX's path until its entry leaves that cache (an edit of lumijax that
    does not change the program, a deleted store)."""
    import equinox as eqx
    import jax

    out_spec: list = []

    def flat(*xs):
        out = fn(*eqx.combine(jax.tree.unflatten(treedef, list(xs)), static))
        out_spec.append(_spec(out))
        return out

    flat.__name__ = flat.__qualname__ = name  # JAX's events and profiles name the program
    _listen()
    lowered = jax.jit(flat, compiler_options=options).lower(*leaves)
    _hits.n = 0
    compiled = lowered.compile()
    if _hits.n:
        return compiled
    try:
        payload = _pack(compiled, out_spec[0], "lapack_" in lowered.as_text())
    except Exception as e:  # e.g. closed-over constants: compiled in every process
        _warn(f"serialise {name}", f"{name} cannot be stored ({type(e).__name__}: {e}); "
              "it is compiled in every process")
    else:
        _write(folder, file, payload)
    return compiled


_hits = threading.local()  # JAX's compilation-cache hits on this thread since it was zeroed


def _count_hit(event: str, **kwargs) -> None:
    if event == "/jax/compilation_cache/cache_hits":
        _hits.n = getattr(_hits, "n", 0) + 1


def _listen() -> None:
    import jax

    with _lock:
        if not getattr(_listen, "on", False):
            jax.monitoring.register_event_listener(_count_hit)
            _listen.on = True  # type: ignore[attr-defined]


def stored(name: str, *modules: str, static_argnums: int | tuple[int, ...] = (),
           options: Callable[..., dict | None] | None = None):
    """Decorator: ``fn`` jitted, its executables kept across processes through :func:`call`
    while the compilation cache is on (``modules``: what it traces, for
    :func:`source_digest`). Inside a trace, or with the cache off, the plain ``jax.jit`` of
    ``fn``. Its array arguments are its inputs, everything else is static (as
    ``equinox.filter_jit``; ``static_argnums`` is for the plain path's ``jax.jit``).
    ``options(*args)`` gives XLA's options for a call (None: XLA's defaults)."""
    import functools

    def wrap(fn: Callable) -> Callable:
        import jax

        jitted: dict[str, Callable] = {}

        @functools.wraps(fn)
        def run(*args):
            opts = None if options is None else options(*args)
            if store_dir() is not None:
                out = call(name, fn, args, source_digest(*modules), compiler_options=opts)
                if out is not None:
                    return out
            key = json.dumps(opts, sort_keys=True)
            plain = jitted.get(key)
            if plain is None:
                plain = jitted.setdefault(key, jax.jit(fn, static_argnums=static_argnums,
                                                       compiler_options=opts))
            return plain(*args)

        return run

    return wrap
