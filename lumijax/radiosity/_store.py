"""The on-disk container of a :class:`TransportOperator` (the cache on it is ``_cache.py``).

File layout (little-endian)::

    16 bytes   magic  b"LUMIJAX-TRANSPRT"
    32 bytes   HMAC-SHA256, keyed by the user's cache secret, of everything after byte 48
     8 bytes   header length h (uint64)
     h bytes   JSON header, space-padded to a multiple of 64: format, key, shapes, dtypes, offsets
     payload   the arrays, raw, each 64-byte aligned

The tag is keyed (:func:`cache_secret`: ``$LUMIJAX_CACHE_SECRET``, or a random 32-byte file
``~/.config/lumijax/cache-secret`` created 0600 on first use), so whoever can write the cache
folder but cannot read the secret cannot re-sign an edited file: truncation, a bit flip, a
half-written file or a forged one all fail the tag. A file that passes it is still validated
field by field (types, ranges, shapes, dtypes from an allow-list, every index in range, finite
values) before an operator is built from it; any doubt is an :class:`OperatorFileError`, never
a traceback and never a clamped index. Files are written through
:func:`lumijax._atomic.atomic_path` (temporary file, fsync, one rename): concurrent writers of one
key each rename a complete file into place and the last one wins; a reader sees an old complete
file or a new complete file, never a mix.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import math
import os
import secrets
import stat
import struct
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from .._atomic import atomic_path
from .._jit_cache import HOST_ALIGN, host_empty, to_device
from ..errors import OutputError
from ._operator import Bucket, Info, LowRankBucket, SampledBucket, TransportOperator

__all__ = [
    "FORMAT", "SECRET_ENV", "OperatorFileError", "cache_secret", "read_operator", "secret_path",
    "write_operator",
]

FORMAT = "lumijax.transport/8"  # 3: second-order far-field kernel; 4: shadowed low rank;
# 5: hierarchical far field (cluster pairs); 6: keyed HMAC tag, header validated on load;
# 7: ray-sampled links (kind "sampled"); 8: sampled links in 8 bytes (radiosity/_links.py)
"""Container and operator format. Bump it whenever the file layout *or the form-factor maths*
change: it is part of the cache key and of every file's header, and a file of another format is
ignored (rebuilt), never read."""

_MAGIC = b"LUMIJAX-TRANSPRT"
# every array starts at a multiple of this in the file, so read into an aligned buffer it lies
# where JAX adopts it without a copy (``_read_bytes``)
_ALIGN = HOST_ALIGN
_FIELDS = {
    "dense": ("blocks", "recv", "src", "recv_block", "src_block"),
    "lowrank": ("u", "v", "recv", "src", "recv_block", "src_block"),
    "sampled": ("weight", "recv", "src", "base", "scale"),
}
#: The dtypes of a sampled bucket's arrays (an entry a link, a chunk or a patch: all flat).
_SAMPLED = {"weight": ("<f2", "<f4", "<f8"), "recv": ("<u2",), "src": ("<i4", "<i8"),
            "base": ("<i4", "<i8"), "scale": ("<f4", "<f8")}
_FLOATS = ("<f4", "<f8")  # the only dtypes a stored value array may have
_INTS = ("<i4", "<i8")  # ... and an index array
_HEAD_KEYS = {"format", "key", "n_patches", "n_blocks", "buckets", "arrays", "info"}
SECRET_ENV = "LUMIJAX_CACHE_SECRET"
_SECRET_BYTES = 32


class OperatorFileError(OutputError):
    """An operator file cannot be used. ``reason``: ``"corrupt"`` (damaged, forged or invalid),
    ``"format"`` (another container format) or ``"key"`` (another operator's file)."""

    def __init__(self, message, *, reason: str = "corrupt", file=None):
        self.reason = reason
        super().__init__(message, file=file)

    def __reduce__(self):
        return (_rebuild, (self.message, self.reason, self.file))


def _rebuild(message, reason, file):
    return OperatorFileError(message, reason=reason, file=file)


# -- the cache secret -----------------------------------------------------------------------------


def secret_path() -> Path:
    """Where the per-user cache secret lives: ``$XDG_CONFIG_HOME/lumijax/cache-secret``
    (``~/.config/lumijax/cache-secret`` by default), outside every cache folder."""
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "lumijax" / "cache-secret"


def _private(st: os.stat_result) -> bool:
    if sys.platform == "win32":  # no POSIX modes; the profile folder is per-user
        return True
    return st.st_uid == os.getuid() and not st.st_mode & 0o077


def cache_secret() -> bytes:
    """The key of every operator file's HMAC tag.

    ``$LUMIJAX_CACHE_SECRET`` (at least 16 characters) if set, else the 32 random bytes of
    :func:`secret_path`, created mode 0600 on first use. A secret file that is not a regular
    file, not the user's own or readable by others is refused (:class:`OutputError`): anyone who
    can read it can forge cache files.
    """
    env = os.environ.get(SECRET_ENV)
    if env is not None:
        if len(env.encode()) < 16:
            raise OutputError("the cache secret must be at least 16 characters", key=SECRET_ENV)
        return env.encode()
    path = secret_path()
    try:
        return _read_secret(path)
    except FileNotFoundError:
        pass
    except OSError as e:
        raise OutputError(f"cannot read the cache secret: {e.strerror or e}", file=path) from None
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0),
                     0o600)
        try:
            os.write(fd, secrets.token_bytes(_SECRET_BYTES))
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(tmp, path)  # appears whole or not at all; a concurrent first use wins once
        except FileExistsError:
            pass
        finally:
            tmp.unlink(missing_ok=True)
        return _read_secret(path)
    except OSError as e:
        raise OutputError(f"cannot create the cache secret: {e.strerror or e}",
                          file=path) from None


def _read_secret(path: Path) -> bytes:
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or not _private(st):
            raise OutputError("the cache secret must be a regular file of yours, mode 0600 "
                              "(chmod 600 it, or delete it to make a new one)", file=path)
        data = os.read(fd, 4096)
    finally:
        os.close(fd)
    if len(data) < 16:
        raise OutputError("the cache secret is shorter than 16 bytes (delete it to make a new "
                          "one)", file=path)
    return data


# -- container ------------------------------------------------------------------------------------


def _arrays(op: TransportOperator):
    """(name, numpy array) of everything stored, and the header's bucket list."""
    out = [("area", np.asarray(op.area, np.float64)), ("block_of", np.asarray(op.block_of))]
    buckets = []
    for k, bk in enumerate(op.buckets):
        kind = bk.kind
        buckets.append({"kind": kind, "diagonal": bool(bk.diagonal), "chunk": bk.chunk})
        out += [(f"b{k}_{f}", np.ascontiguousarray(np.asarray(getattr(bk, f))))
                for f in _FIELDS[kind]]
    return out, buckets


def write_operator(path: str | Path, op: TransportOperator, *, key: str | None = None,
                   secret: bytes | None = None) -> Path:
    """Write ``op`` to ``path`` atomically, tagged with ``secret`` (default
    :func:`cache_secret`; see the module docstring)."""
    secret = cache_secret() if secret is None else secret
    arrays, buckets = _arrays(op)
    table, off = {}, 0
    for name, a in arrays:
        off = -(-off // _ALIGN) * _ALIGN
        table[name] = [off, a.dtype.str, list(a.shape)]
        off += a.nbytes
    head = {
        "format": FORMAT,
        "key": key,
        "n_patches": op.n_patches,
        "n_blocks": op.n_blocks,
        "buckets": buckets,
        "arrays": table,
        "info": op.info,
    }
    hb = json.dumps(head, default=str).encode()
    hb += b" " * (-(len(hb) + 56) % _ALIGN)  # payload starts aligned
    h = hmac.new(secret, digestmod=hashlib.sha256)
    with atomic_path(path, what="transport operator") as tmp, open(tmp, "wb") as f:
        f.write(_MAGIC + bytes(32))
        for chunk in (struct.pack("<Q", len(hb)), hb):
            f.write(chunk)
            h.update(chunk)
        pos = 0
        for name, a in arrays:
            pad = table[name][0] - pos
            if pad:
                f.write(bytes(pad))
                h.update(bytes(pad))
            mv = memoryview(a.reshape(-1)).cast("B") if a.size else b""
            f.write(mv)
            h.update(mv)
            pos = table[name][0] + a.nbytes
        f.seek(len(_MAGIC))
        f.write(h.digest())
        f.flush()
        os.fsync(f.fileno())
    return Path(path)


def _read_bytes(path: Path) -> np.ndarray:
    # O_NONBLOCK: a FIFO planted under the cache file's name must not hang the run
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(path, flags)
    except OSError as e:
        raise OperatorFileError(f"cannot read the operator: {e.strerror or e}", file=path) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OperatorFileError("not a regular file", file=path)
        with open(fd, "rb", closefd=False) as f:
            # aligned, so the arrays read are adopted by JAX, not copied (one operator in
            # memory, not two, while it loads: _jit_cache.host_empty)
            buf = host_empty(st.st_size, np.uint8)
            n = f.readinto(memoryview(buf))
    except OSError as e:
        raise OperatorFileError(f"cannot read the operator: {e.strerror or e}", file=path) from None
    finally:
        os.close(fd)
    if n != len(buf):
        raise OperatorFileError("the file changed while it was read", file=path)
    return buf


def _peek_format(mv: memoryview) -> object:
    """The ``format`` an untagged header claims (only to tell an old file from a forged one)."""
    try:
        (hl,) = struct.unpack("<Q", mv[48:56])
        if hl > len(mv) - 56 or hl > 1 << 24:
            return None
        head = json.loads(bytes(mv[56 : 56 + hl]).decode())
        return head.get("format") if isinstance(head, dict) else None
    except (ValueError, UnicodeDecodeError, struct.error):
        return None


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _check(ok: bool, what: str, path: Path) -> None:
    if not ok:
        raise OperatorFileError(f"invalid header: {what}", file=path)


def _table(head: dict, payload: int, path: Path) -> dict[str, tuple[int, np.dtype, tuple]]:
    """The array table, every entry checked: names, offsets, dtypes, ranks, inside the payload,
    no two overlapping."""
    buckets = head["buckets"]
    _check(isinstance(buckets, list), "'buckets' is not a list", path)
    want: dict[str, tuple[tuple[str, ...], int]] = {"area": (_FLOATS, 1), "block_of": (_INTS, 1)}
    for k, b in enumerate(buckets):
        _check(isinstance(b, dict) and set(b) == {"kind", "diagonal", "chunk"},
               f"bucket {k} is not {{kind, diagonal, chunk}}", path)
        _check(b["kind"] in _FIELDS, f"bucket {k}: kind is not 'dense', 'lowrank' or "
               "'sampled'", path)
        _check(isinstance(b["diagonal"], bool), f"bucket {k}: 'diagonal' is not true/false", path)
        _check(b["kind"] == "dense" or not b["diagonal"],
               f"bucket {k}: a {b['kind']} bucket cannot be diagonal", path)
        _check(_is_int(b["chunk"]) and b["chunk"] >= 1,
               f"bucket {k}: 'chunk' is not a whole number >= 1", path)
        if b["kind"] == "sampled":  # one link per entry: every array is a flat list
            want.update({f"b{k}_{f}": (_SAMPLED[f], 1) for f in _FIELDS["sampled"]})
            continue
        for f in _FIELDS[b["kind"]]:
            want[f"b{k}_{f}"] = ((_FLOATS, 3) if f in ("blocks", "u", "v") else
                                 (_INTS, 2) if f in ("recv", "src") else (_INTS, 1))
    arrays = head["arrays"]
    _check(isinstance(arrays, dict) and set(arrays) == set(want),
           "the array table does not list exactly the arrays its buckets need", path)
    out, spans = {}, []
    for name, (dtypes, ndim) in want.items():
        e = arrays[name]
        _check(isinstance(e, list) and len(e) == 3, f"array {name}: not [offset, dtype, shape]",
               path)
        off, dt, shape = e
        _check(_is_int(off) and off >= 0 and off % _ALIGN == 0,
               f"array {name}: offset is not a non-negative multiple of {_ALIGN}", path)
        _check(dt in dtypes, f"array {name}: dtype {dt!r} is not one of {', '.join(dtypes)}",
               path)
        _check(isinstance(shape, list) and len(shape) == ndim
               and all(_is_int(d) and 0 <= d < 1 << 40 for d in shape),
               f"array {name}: shape is not {ndim} non-negative whole numbers", path)
        dtype = np.dtype(dt)
        end = off + math.prod(shape) * dtype.itemsize
        _check(end <= payload, f"array {name}: runs past the end of the file", path)
        out[name] = (off, dtype, tuple(shape))
        spans.append((off, end, name))
    spans.sort()
    for (_, e0, a), (o1, _, b) in zip(spans, spans[1:]):
        _check(o1 >= e0, f"arrays {a} and {b} overlap", path)
    return out


def _all_finite(a: np.ndarray) -> bool:
    flat = a.reshape(-1)
    step = 1 << 22  # in slices: no temporary the size of the operator
    return all(np.isfinite(flat[i : i + step]).all() for i in range(0, flat.size, step))


def _in_range(a: np.ndarray, lo: int, hi: int) -> bool:
    """Every value in [lo, hi] (an empty array is in range)."""
    return a.size == 0 or (int(a.min()) >= lo and int(a.max()) <= hi)


def _sampled_bucket(f: dict, chunk: int, k: int, n_p: int, path: Path) -> SampledBucket:
    """A sampled bucket's arrays (``_links.py``), checked as the block buckets' are: whole
    chunks, one base a chunk and one scale a patch, every patch index (base + offset) in ``0..n_patches``
    (the padding patch), weights finite and non-negative (a weight is area × a hit fraction),
    the patches' scales finite and positive."""
    n = f["weight"].shape[0]
    _check(f["recv"].shape == (n,) and f["src"].shape == (n,),
           f"bucket {k}: index arrays do not match the weights' length", path)
    _check(n % chunk == 0, f"bucket {k}: {n} links are not whole chunks of {chunk}", path)
    steps = n // chunk
    _check(f["base"].shape == (steps,) and f["scale"].shape == (n_p + 1,),
           f"bucket {k}: not one base a chunk and one scale a patch (and the padding's)", path)
    top = (f["recv"].reshape(steps, chunk).max(axis=1).astype(np.int64) if n else
           np.zeros(0, np.int64))  # each chunk's farthest receiver, from its base
    _check(_in_range(f["base"], 0, n_p) and bool(np.all(f["base"] + top <= n_p))
           and _in_range(f["src"], 0, n_p), f"bucket {k}: a patch index outside 0..n_patches",
           path)
    _check(_all_finite(f["weight"]) and (n == 0 or float(f["weight"].min()) >= 0),
           f"bucket {k}: weights must be finite and >= 0", path)
    _check(_all_finite(f["scale"]) and bool(np.all(f["scale"] > 0)),
           f"bucket {k}: patch scales must be finite and > 0", path)
    return SampledBucket(*(to_device(f[name]) for name in _FIELDS["sampled"]), chunk=chunk)


def read_operator(path: str | Path, *, key: str | None = None,
                  secret: bytes | None = None) -> TransportOperator:
    """Read, authenticate and validate an operator file (see the module docstring).

    ``key``: the operator key the file must hold (the cache passes the one it recomputed from
    the study). :class:`OperatorFileError` says why a file is unusable.
    """
    path = Path(path)
    buf = _read_bytes(path)
    if len(buf) < 56 or bytes(buf[:16]) != _MAGIC:
        raise OperatorFileError("not a lumijax operator file, or truncated", file=path)
    mv = memoryview(buf)
    secret = cache_secret() if secret is None else secret
    tag = hmac.new(secret, mv[48:], hashlib.sha256).digest()
    if not hmac.compare_digest(tag, bytes(mv[16:48])):
        fmt = _peek_format(mv)
        if isinstance(fmt, str) and fmt != FORMAT and fmt.startswith("lumijax.transport/"):
            raise OperatorFileError(f"written in format {fmt!r}; this lumijax reads {FORMAT!r}",
                                    reason="format", file=path)
        raise OperatorFileError("signature mismatch: the file is truncated, corrupt, or was "
                                "not written with your cache secret", file=path)
    (hl,) = struct.unpack("<Q", mv[48:56])
    _check(hl <= len(buf) - 56, "header length runs past the end of the file", path)
    try:
        head = json.loads(bytes(mv[56 : 56 + hl]).decode())
    except (ValueError, UnicodeDecodeError, RecursionError):
        raise OperatorFileError("unreadable header", file=path) from None
    _check(isinstance(head, dict) and set(head) == _HEAD_KEYS,
           f"not exactly the fields {', '.join(sorted(_HEAD_KEYS))}", path)
    if head["format"] != FORMAT:
        raise OperatorFileError(
            f"written in format {head['format']!r}; this lumijax reads {FORMAT!r}",
            reason="format", file=path,
        )
    if key is not None and head["key"] != key:
        raise OperatorFileError("holds another operator (cache key mismatch)", reason="key",
                                file=path)
    _check(head["key"] is None or isinstance(head["key"], str), "'key' is not a string", path)
    n_p, n_b = head["n_patches"], head["n_blocks"]
    _check(_is_int(n_p) and n_p >= 1, "'n_patches' is not a whole number >= 1", path)
    _check(_is_int(n_b) and 1 <= n_b <= n_p, "'n_blocks' is not a whole number in "
           "1..n_patches", path)
    _check(isinstance(head["info"], dict), "'info' is not a table", path)
    base = 56 + hl
    table = _table(head, len(buf) - base, path)

    def arr(name):
        off, dt, shape = table[name]
        return np.frombuffer(buf, dt, math.prod(shape), base + off).reshape(shape)

    area, block_of = arr("area"), arr("block_of")
    _check(area.shape == (n_p,) and block_of.shape == (n_p,),
           "'area' and 'block_of' must hold one value per patch", path)
    _check(_all_finite(area) and bool((area > 0).all()), "patch areas must be finite and > 0",
           path)
    _check(_in_range(block_of, 0, n_b - 1), "'block_of' holds a block outside 0..n_blocks-1",
           path)
    buckets = []
    for k, b in enumerate(head["buckets"]):
        f = {name: arr(f"b{k}_{name}") for name in _FIELDS[b["kind"]]}
        if b["kind"] == "sampled":
            buckets.append(_sampled_bucket(f, b["chunk"], k, n_p, path))
            continue
        if b["kind"] == "lowrank":
            (n, sa, r), (nv, sb, rv) = f["u"].shape, f["v"].shape
            _check(nv == n and rv == r, f"bucket {k}: u and v disagree in count or rank", path)
            values = (f["u"], f["v"])
        else:
            n, sa, sb = f["blocks"].shape
            _check(not b["diagonal"] or sa == sb, f"bucket {k}: a diagonal block is not square",
                   path)
            values = (f["blocks"],)
        _check(f["recv"].shape == (n, sa) and f["src"].shape == (n, sb)
               and f["recv_block"].shape == (n,) and f["src_block"].shape == (n,),
               f"bucket {k}: index arrays do not match the blocks' shape", path)
        _check(n % b["chunk"] == 0, f"bucket {k}: {n} blocks are not whole chunks of "
               f"{b['chunk']}", path)
        # index n_patches is the zero padding patch; anything else outside would be clamped
        # or dropped by JAX's gather and scatter, silently losing light
        _check(_in_range(f["recv"], 0, n_p) and _in_range(f["src"], 0, n_p),
               f"bucket {k}: a patch index outside 0..n_patches", path)
        _check(_in_range(f["recv_block"], -1, n_b - 1) and _in_range(f["src_block"], -1, n_b - 1),
               f"bucket {k}: a block index outside -1..n_blocks-1", path)
        _check(all(_all_finite(v) for v in values), f"bucket {k}: NaN or infinite values", path)
        fields = [to_device(f[name]) for name in _FIELDS[b["kind"]]]  # no eager kernels
        if b["kind"] == "lowrank":
            buckets.append(LowRankBucket(*fields, chunk=b["chunk"]))
        else:
            buckets.append(Bucket(*fields, diagonal=b["diagonal"], chunk=b["chunk"]))
    area_dtype = jnp.float64 if jax.config.jax_enable_x64 else jnp.float32
    return TransportOperator(
        tuple(buckets),
        to_device(np.asarray(area), area_dtype),
        to_device(np.asarray(block_of)),
        n_p,
        n_b,
        Info(head["info"]),
    )


# -- key and cache --------------------------------------------------------------------------------


