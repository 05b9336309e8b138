"""The on-disk container of a :class:`TransportOperator`, and the cache built on it.

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

The cache key (:func:`operator_key`) is a SHA-256 of everything that changes F: the patches'
geometry and groups (so the triangles and the meshing settings), the occluding triangles, the
partition and form-factor settings, the storage dtype and :data:`FORMAT`. Materials, reflectances,
luminaires and dimmers are deliberately not in it: they do not change F.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import struct
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from .._atomic import atomic_path
from ..errors import LumijaxWarning, OutputError
from ..mesh._partition import PartitionSettings, partition
from ..mesh._patches import Patches
from ._operator import Bucket, Info, LowRankBucket, TransportOperator

__all__ = ["FORMAT", "OperatorFileError", "cache_path", "cached_operator", "operator_key", "read_operator",
           "write_operator"]

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


def _jsonable(x):
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {"__type__": type(x).__name__, **dataclasses.asdict(x)}
    if isinstance(x, (np.dtype, type)):
        return np.dtype(x).str
    return str(x)


def _hash_array(h, a) -> None:
    a = np.ascontiguousarray(a)
    h.update(str((a.dtype.str, a.shape)).encode())
    h.update(memoryview(a.reshape(-1)).cast("B") if a.size else b"")


def operator_key(geometry, group=None, *, occluders=None, **settings) -> str:
    """SHA-256 hex digest of everything that determines the form factors F.

    Parameters
    ----------
    geometry
        :class:`~lumijax.mesh.Patches` (then their vertices, normals and groups are hashed:
        this covers the triangles *and* the meshing settings exactly), or the scene's triangles
        ``(T, 3, 3)`` with ``group`` and the meshing settings passed in ``settings``.
    group
        ``(T,)`` user groups of the triangles (ignored for Patches, which carry their own).
    occluders
        Triangles ``(T, 3, 3)`` used for shadow rays, or ``None``.
    settings
        Anything else that changes F, JSON-serialisable or dataclasses: ``patch_size=``,
        ``partition=PartitionSettings(...)``, ``form_factors=FormFactorSettings(...)``,
        ``dtype=np.float32``.

    Materials and reflectances must *not* be passed: they do not change F, and a study that only
    changes them must hit the cache.
    """
    h = hashlib.sha256(FORMAT.encode())
    if isinstance(geometry, Patches):
        for a in (geometry.vertices, geometry.normal, geometry.group):
            _hash_array(h, a)
    else:
        tri = np.asarray(geometry, np.float64)
        _hash_array(h, tri)
        _hash_array(h, np.full(len(tri), -1, np.int64) if group is None else np.asarray(group))
    h.update(b"occluders")
    if occluders is not None:
        _hash_array(h, np.asarray(occluders, np.float64))
    h.update(json.dumps(settings, sort_keys=True, default=_jsonable).encode())
    return h.hexdigest()


def cache_path(cache_dir: str | Path, key: str) -> Path:
    """Where the operator of ``key`` lives in ``cache_dir``."""
    return Path(cache_dir) / f"transport-{key}.lmjop"


def cached_operator(
    patches: Patches,
    occluders=None,
    settings=None,
    *,
    cache_dir: str | Path,
    partition_settings: PartitionSettings | None = None,
    dtype=np.float32,
    caster=None,
) -> tuple[TransportOperator, bool]:
    """The transport operator of ``patches``, from ``cache_dir`` if it holds it, else built.

    On a miss the partition (with its occlusion rays) and the operator are built and written
    atomically to ``cache_dir/transport-<key>.lmjop``; on a hit no ray is cast at all. A
    corrupt or truncated file gives a :class:`~lumijax.errors.LumijaxWarning` ("cache file …
    is corrupt; rebuilding") and is rebuilt and rewritten; a file of another format version is
    rebuilt silently. A cache folder that cannot be written gives a warning, not an error.

    Parameters
    ----------
    patches
        From :func:`~lumijax.mesh.mesh_patches`.
    occluders
        Scene triangles ``(T, 3, 3)`` for shadow rays (an array: it is part of the key), or
        ``None``.
    settings
        :class:`FormFactorSettings` (default settings if ``None``).
    cache_dir
        The cache folder (the study's ``.lumijax-cache/``); created if missing.
    partition_settings
        :class:`~lumijax.mesh.PartitionSettings` for :func:`~lumijax.mesh.partition`.
    dtype
        Block storage, float32 or float64.
    caster
        An already built ``RayCaster`` of ``occluders`` to reuse on a miss (not part of the key).

    Returns
    -------
    ``(operator, hit)``: ``hit`` is True when the operator came from the cache.
    """
    from ._build import FormFactorSettings, build_operator

    settings = settings or FormFactorSettings()
    ps = partition_settings or PartitionSettings()
    occ = None if occluders is None else np.asarray(occluders, np.float64)
    key = operator_key(patches, occluders=occ, partition=ps, form_factors=settings,
                       dtype=np.dtype(dtype))
    path = cache_path(cache_dir, key)
    if path.exists():
        try:
            return read_operator(path, key=key), True
        except OperatorFileError as e:
            if e.reason != "format":
                warnings.warn(f"cache file {path} is corrupt ({e.message}); rebuilding",
                              LumijaxWarning, stacklevel=2)
    if occ is not None and caster is None:
        from ..scene._raycast import RayCaster

        caster = RayCaster(occ)
    part = partition(patches, **dataclasses.asdict(ps), occluders=caster)
    op = build_operator(patches, part, caster, settings, dtype=dtype, occluder_triangles=occ)
    try:
        write_operator(path, op, key=key)
    except OutputError as e:
        warnings.warn(f"cannot write cache file {path} ({e.message}); continuing without it",
                      LumijaxWarning, stacklevel=2)
    return op, False
