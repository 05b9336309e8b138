"""The operator cache: one container file per key, rebuilt on any doubt.

The cache key (:func:`operator_key`) is a SHA-256 of everything that changes F: the patches'
geometry and groups (so the triangles and the meshing settings), the occluding triangles, the
partition and form-factor settings, the storage dtype, :data:`FORMAT` and the code version (the
lumijax version and a digest of the modules that compute F, so an edited build rebuilds even in
an editable install). Materials, reflectances, luminaires and dimmers are deliberately not in it:
they do not change F. Files are tagged with the user's cache secret and validated on load
(``_store.py``); a file that fails is rebuilt with a warning, never trusted.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import warnings
from pathlib import Path

import numpy as np

from .._atomic import remove_orphans
from .._version import __version__
from ..errors import LumijaxWarning, OutputError
from ..scene._raycast import RayCaster
from ._bright import BrightPatches
from ._build import FormFactorSettings, build_operator
from ._operator import TransportOperator
from ._partition import PartitionSettings, partition
from ._patches import Patches
from ._sampled import SampledSettings, build_sampled
from ._store import FORMAT, OperatorFileError, cache_secret, read_operator, write_operator

__all__ = ["cache_path", "cached_operator", "cached_sampled_operator", "code_version",
           "operator_key"]

# The modules whose code decides the numbers in F (relative to the package): an edit to any of
# them changes the key. Add a module here when it starts to take part in building F.
_F_MODULES = (
    "radiosity/_build.py", "radiosity/_hierarchy.py", "radiosity/_lowrank.py",
    "radiosity/_operator.py", "radiosity/_partition.py", "radiosity/_store.py",
    "kernels/_form_factors.py", "scene/_raycast.py", "scene/_glass.py", "radiosity/_sampled.py",
    "radiosity/_gather.py",
)


@functools.cache
def code_version() -> str:
    """``"<lumijax version>+<SHA-256 of the F modules' source, 16 hex>"``: part of every key."""
    h = hashlib.sha256()
    root = Path(__file__).resolve().parents[1]
    for rel in _F_MODULES:
        try:
            h.update(rel.encode() + b"\0" + (root / rel).read_bytes())
        except OSError:  # a bytecode-only install: the version alone must do
            h.update(rel.encode() + b"\0missing")
    return f"{__version__}+{h.hexdigest()[:16]}"


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
        :class:`~lumijax.radiosity.Patches` (then their vertices, normals and groups are hashed:
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
    h.update(code_version().encode())
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
    corrupt, truncated, forged (not tagged with the user's secret) or invalid file gives a
    :class:`~lumijax.errors.LumijaxWarning` ("cache file … is corrupt; rebuilding") and is
    rebuilt and rewritten; a file of another format version is rebuilt silently. A cache folder
    that cannot be written, or no usable cache secret, gives a warning, not an error.

    Parameters
    ----------
    patches
        From :func:`~lumijax.radiosity.mesh_patches`.
    occluders
        Scene triangles ``(T, 3, 3)`` for shadow rays (an array: it is part of the key), or
        ``None``.
    settings
        :class:`FormFactorSettings` (default settings if ``None``).
    cache_dir
        The cache folder (the study's ``.lumijax-cache/``); created if missing.
    partition_settings
        :class:`~lumijax.radiosity.PartitionSettings` for :func:`~lumijax.radiosity.partition`.
    dtype
        Block storage, float32 or float64.
    caster
        An already built ``RayCaster`` of ``occluders`` to reuse on a miss (not part of the key).

    Returns
    -------
    ``(operator, hit)``: ``hit`` is True when the operator came from the cache.
    """
    settings = settings or FormFactorSettings()
    ps = partition_settings or PartitionSettings()
    occ = None if occluders is None else np.asarray(occluders, np.float64)
    # clear glass changes what a ray carries (lumijax.scene.GlazedCaster): its τ is in the key
    glazing = {} if caster is None or caster.glazing_key is None else {
        "glazing": caster.glazing_key}
    key = operator_key(patches, occluders=occ, partition=ps, form_factors=settings,
                       dtype=np.dtype(dtype), **glazing)

    def build():
        c = caster if caster is not None or occ is None else RayCaster(occ)
        part = partition(patches, **dataclasses.asdict(ps), occluders=c)
        return build_operator(patches, part, c, settings, dtype=dtype, occluder_triangles=occ)

    return _cached(patches, key, cache_dir, build)


def cached_sampled_operator(
    patches: Patches,
    occluders,
    settings: SampledSettings | None = None,
    *,
    cache_dir: str | Path,
    dtype=np.float32,
    caster=None,
    progress=None,
    bright: BrightPatches | None = None,
) -> tuple[TransportOperator, bool]:
    """:func:`cached_operator` for the ray-sampled transport (``_sampled.py``): the key holds
    the :class:`SampledSettings` (rays, seed, batch) in place of the partition and form-factor
    settings, so a sampled and a block operator of one mesh never share a file.

    ``occluders``: the scene's triangles ``(T, 3, 3)`` (every one casts shadows; required, the
    rays need them). ``progress(done, total)`` is called per batch of a build. ``bright``: the
    aimed rays' proposal (:func:`~lumijax.radiosity.bright_patches`), named in the key by its
    hash: moving a luminaire builds anew, a dimmer does not."""
    settings = settings or SampledSettings()
    occ = np.asarray(occluders, np.float64)
    glazing = {} if caster is None or caster.glazing_key is None else {
        "glazing": caster.glazing_key}  # the rays carry the panes' τ(θ), as the blocks' do
    aimed = {} if bright is None else {"bright": bright.key}
    key = operator_key(patches, occluders=occ, sampled=settings, dtype=np.dtype(dtype),
                       **glazing, **aimed)

    def build():
        c = caster if caster is not None else RayCaster(occ)
        return build_sampled(patches, occ, settings, caster=c, dtype=dtype, progress=progress,
                             bright=bright)

    return _cached(patches, key, cache_dir, build)


def _cached(patches: Patches, key: str, cache_dir, build) -> tuple[TransportOperator, bool]:
    """The operator of ``key`` from ``cache_dir``, else ``build()`` written there."""
    path = cache_path(cache_dir, key)
    remove_orphans(cache_dir)  # temporaries of writers killed mid-write (the operator's size)
    try:
        secret = cache_secret()
    except OutputError as e:
        warnings.warn(f"no cache secret ({e}); the operator is built and not cached",
                      LumijaxWarning, stacklevel=3)
        secret = None
    if secret is not None and (path.exists() or path.is_symlink()):
        try:
            op = read_operator(path, key=key, secret=secret)
            if op.n_patches != patches.n:
                raise OperatorFileError(f"holds {op.n_patches} patches, the study has "
                                        f"{patches.n}", file=path)
            return op, True
        except OperatorFileError as e:
            if e.reason != "format":
                warnings.warn(f"cache file {path} is corrupt ({e.message}); rebuilding",
                              LumijaxWarning, stacklevel=3)
    op = build()
    if secret is None:
        return op, False
    try:
        write_operator(path, op, key=key, secret=secret)
    except OutputError as e:
        warnings.warn(f"cannot write cache file {path} ({e.message}); continuing without it",
                      LumijaxWarning, stacklevel=3)
    return op, False
