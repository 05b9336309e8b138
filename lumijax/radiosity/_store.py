"""The on-disk container of a :class:`TransportOperator` (the cache on it is ``_cache.py``).

File layout (little-endian)::

    16 bytes   magic  b"LUMIJAX-TRANSPRT"
    32 bytes   SHA-256 of everything after byte 48 (header length, header, payload)
     8 bytes   header length h (uint64)
     h bytes   JSON header, space-padded to a multiple of 64: format, key, shapes, dtypes, offsets
     payload   the arrays, raw, each 64-byte aligned

Any truncation, bit flip or half-written file fails the checksum (or the magic), so a reader
never builds an operator from damaged bytes. Files are written through
:func:`lumijax._atomic.atomic_path` (temporary file, fsync, one rename): concurrent writers of one
key each rename a complete file into place and the last one wins; a reader sees an old complete
file or a new complete file, never a mix.
"""

from __future__ import annotations

import hashlib
import json
import os
import struct
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from .._atomic import atomic_path
from ..errors import OutputError
from ._operator import Bucket, Info, LowRankBucket, TransportOperator

__all__ = ["FORMAT", "OperatorFileError", "read_operator", "write_operator"]

FORMAT = "lumijax.transport/5"  # 3: second-order far-field kernel; 4: shadowed low rank;
# 5: hierarchical far field (cluster pairs)
"""Container and operator format. Bump it whenever the file layout *or the form-factor maths*
change: it is part of the cache key and of every file's header, and a file of another format is
ignored (rebuilt), never read."""

_MAGIC = b"LUMIJAX-TRANSPRT"
_ALIGN = 64
_FIELDS = {
    "dense": ("blocks", "recv", "src", "recv_block", "src_block"),
    "lowrank": ("u", "v", "recv", "src", "recv_block", "src_block"),
}


class OperatorFileError(OutputError):
    """An operator file cannot be used. ``reason``: ``"corrupt"``, ``"format"`` or ``"key"``."""

    def __init__(self, message, *, reason: str = "corrupt", file=None):
        self.reason = reason
        super().__init__(message, file=file)

    def __reduce__(self):
        return (_rebuild, (self.message, self.reason, self.file))


def _rebuild(message, reason, file):
    return OperatorFileError(message, reason=reason, file=file)


# -- container ------------------------------------------------------------------------------------


def _arrays(op: TransportOperator):
    """(name, numpy array) of everything stored, and the header's bucket list."""
    out = [("area", np.asarray(op.area, np.float64)), ("block_of", np.asarray(op.block_of))]
    buckets = []
    for k, bk in enumerate(op.buckets):
        kind = "lowrank" if isinstance(bk, LowRankBucket) else "dense"
        buckets.append({"kind": kind, "diagonal": bool(bk.diagonal), "chunk": bk.chunk})
        out += [(f"b{k}_{f}", np.ascontiguousarray(np.asarray(getattr(bk, f))))
                for f in _FIELDS[kind]]
    return out, buckets


def write_operator(path: str | Path, op: TransportOperator, *, key: str | None = None) -> Path:
    """Write ``op`` to ``path`` atomically, checksummed (see the module docstring)."""
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
    h = hashlib.sha256()
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


def read_operator(path: str | Path, *, key: str | None = None) -> TransportOperator:
    """Read and verify an operator file; :class:`OperatorFileError` says why it is unusable."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            buf = bytearray(os.fstat(f.fileno()).st_size)
            n = f.readinto(buf)
    except OSError as e:
        raise OperatorFileError(f"cannot read the operator: {e.strerror or e}", file=path) from None
    if n != len(buf) or len(buf) < 56 or buf[:16] != _MAGIC:
        raise OperatorFileError("not a lumijax operator file, or truncated", file=path)
    mv = memoryview(buf)
    if hashlib.sha256(mv[48:]).digest() != bytes(mv[16:48]):
        raise OperatorFileError("checksum mismatch: the file is truncated or corrupt", file=path)
    (hl,) = struct.unpack("<Q", mv[48:56])
    try:
        head = json.loads(bytes(mv[56 : 56 + hl]).decode())
    except (ValueError, UnicodeDecodeError):
        raise OperatorFileError("unreadable header", file=path) from None
    if head.get("format") != FORMAT:
        raise OperatorFileError(
            f"written in format {head.get('format')!r}; this lumijax reads {FORMAT!r}",
            reason="format", file=path,
        )
    if key is not None and head.get("key") != key:
        raise OperatorFileError("holds another operator (cache key mismatch)", reason="key",
                                file=path)
    base = 56 + hl

    def arr(name):
        off, dt, shape = head["arrays"][name]
        count = int(np.prod(shape))
        return np.frombuffer(buf, np.dtype(dt), count, base + off).reshape(shape)

    buckets = []
    for k, b in enumerate(head["buckets"]):
        fields = [jnp.asarray(arr(f"b{k}_{f}")) for f in _FIELDS[b["kind"]]]
        if b["kind"] == "lowrank":
            buckets.append(LowRankBucket(*fields, chunk=b["chunk"]))
        else:
            buckets.append(Bucket(*fields, diagonal=b["diagonal"], chunk=b["chunk"]))
    area_dtype = jnp.float64 if jax.config.jax_enable_x64 else jnp.float32
    return TransportOperator(
        tuple(buckets),
        jnp.asarray(arr("area"), area_dtype),
        jnp.asarray(arr("block_of")),
        head["n_patches"],
        head["n_blocks"],
        Info(head["info"]),
    )


# -- key and cache --------------------------------------------------------------------------------


