"""A study's solution kept between runs, keyed by everything but its dimmers: the iterate loop.

Light adds linearly over networks, so a run that differs from an earlier one only in
``[networks.NAME] dimmer`` values has nothing to compute: each grid's per-network illuminance
(and XYZ) at dimmer 1 is read back and superposed, ``E = Σ αₖ Eₖ``, and so are the patches'
arrays of patches.vtp. A numbers run — ``lumijax run --quick``, or ``lumijax run --no-images
--no-report`` — does that without building the scene or importing JAX (docs/results.md,
"Dimmer-only reruns"); a run that draws images or a report computes (and stores).

The key (:func:`solution_key`) is a SHA-256 of the validated config with every network's
``dimmer`` removed (so any other change — geometry, a material, a luminaire, a grid, a solver
setting — is a new key), the bytes of every file the config names, the run's options
(``--no-shadows``; ``--quick`` or full: a quick solution has no patches and one wavelength),
the source of every lumijax module and the versions of JAX, jaxlib and
numpy. A solution is one ``solution-<key>.npz`` file in the study's operator-cache folder,
written to a temporary file and renamed into place (a reader sees a whole file or none); its
digest is checked on reading, and a file that fails (truncated, corrupted, another key's) is
ignored with a warning and rewritten by the full run. Only the numbers are stored: no pickle
(``allow_pickle=False``), so a foreign file can at worst give wrong numbers, as an edited
config can.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import io
import json
import os
import warnings
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ._atomic import atomic_path
from ._dimmers import DEFAULT as DIMMER_DEFAULT
from .errors import LumijaxWarning, OutputError

__all__ = ["StoredSolution", "solution_key", "solution_path", "store_solution",
           "load_solution", "code_digest", "file_digest", "prune", "KEEP", "MAX_PATCH_BYTES"]

FORMAT = "lumijax-solution-1"

#: Solutions kept per cache folder: the newest, by modification time; older ones (studies
#: since edited in other ways than dimmers) are removed when a new one is stored.
KEEP = 16

#: The most bytes a full solution's patch arrays may take (the 4,332-patch cube with one
#: network: 0.5 MB); a larger study's full runs are not stored (they compute, as before), so
#: that neither its cache folder (up to :data:`KEEP` files) nor its run (one operator product
#: per network for the patches' irradiance) grows with patches × networks without bound.
MAX_PATCH_BYTES = 64 * 2**20



#: Parts of lumijax that do not compute a stored solution's numbers (they draw, fit, rate
#: glare or parse the command line; a study with a fit or observers is never stored): their
#: edits keep the key.
_NOT_NUMBERS = ("cli.py", "__main__.py", "report", "view", "optimise", "glare")
#: ... except the one module of those that makes stored arrays (patches.vtp's).
_NUMBERS_IN_REPORT = ("report/_vtk.py",)


@functools.cache
def code_digest() -> str:
    """SHA-256 of the source of every lumijax module that computes the numbers, the versions
    of JAX, jaxlib and numpy, and the environment's ``JAX_ENABLE_X64`` (64-bit arithmetic
    for the whole process, whatever ``[solver] precision`` says): an edited module (an
    editable install), an upgrade or the other precision is a new key."""
    h = hashlib.sha256(FORMAT.encode())
    root = Path(__file__).resolve().parent
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] in _NOT_NUMBERS and rel.as_posix() not in _NUMBERS_IN_REPORT:
            continue
        h.update(str(rel).encode() + b"\0" + path.read_bytes())
    for name in ("jax", "jaxlib"):  # their version.py, found without importing them
        h.update(f"{name}=".encode() + _version_source(name))
    h.update(f"numpy={np.__version__}".encode())
    h.update(f"JAX_ENABLE_X64={os.environ.get('JAX_ENABLE_X64', '')}".encode())
    return h.hexdigest()


def _version_source(package: str) -> bytes:
    """The bytes of an installed package's ``version.py`` (b"none" without one): what
    ``importlib.metadata.version`` would say, without that module's 25 ms of imports."""
    try:
        spec = importlib.util.find_spec(package)
        origin = spec.origin if spec is not None else None
        return Path(origin).with_name("version.py").read_bytes() if origin else b"none"
    except (ImportError, OSError, ValueError):
        return b"none"


def file_digest(path: Path) -> str | None:
    """SHA-256 hex of the file's bytes; None where ``path`` is not a readable file."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
    except OSError:
        return None


def _keyed(value: Any, h, files: dict[str, str | None]) -> Any:
    """The config dump as JSON-able values; every existing file it names adds its bytes (and
    its digest to ``files``, by path: what ``lumijax._recorded`` checks instead)."""
    if isinstance(value, dict):
        return {str(k): _keyed(v, h, files) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_keyed(v, h, files) for v in value]
    if isinstance(value, Path):
        digest = file_digest(value)
        if digest is not None:
            h.update(str(value).encode() + b"\0" + digest.encode())
        files[str(value)] = digest
        return str(value)
    if isinstance(value, np.ndarray):  # its bytes: numpy's repr elides long arrays
        a = np.ascontiguousarray(value)
        return [a.dtype.str, list(a.shape), hashlib.sha256(a.tobytes()).hexdigest()]
    if isinstance(value, float | int | str | bool) or value is None:
        return value
    return repr(value)


def solution_key(config, *, shadows: bool = True, full: bool = False,
                 files: dict[str, str | None] | None = None) -> str:
    """SHA-256 hex of everything that decides a study's per-network light except its dimmers.

    ``config``: the validated :class:`~lumijax.config.StudyConfig` as the run uses it (after
    ``--quick``'s change to ``[solver]``); ``shadows``: the run's ``--no-shadows`` negated;
    ``full``: a full numbers run's solution (with patches.vtp's arrays), which a ``--quick``
    run's (grids only) never stands for, nor the other way round, even where the config is
    the same (a study that sets ``spectral_samples = 0`` itself); ``files``, if given, gets
    the SHA-256 of every path the config names (None: not a file).
    """
    dump = config.model_dump(mode="python")
    for net in dump.get("networks", {}).values():
        net.pop("dimmer", None)  # the one thing a rerun may change
    h = hashlib.sha256(code_digest().encode())
    doc = _keyed(dump, h, {} if files is None else files)
    h.update(json.dumps({"config": doc, "shadows": bool(shadows),
                         "mode": "full" if full else "quick"}, sort_keys=True).encode())
    return h.hexdigest()


def solution_path(cache_dir: str | Path, key: str) -> Path:
    """Where the solution of ``key`` lives in ``cache_dir``."""
    return Path(cache_dir) / f"solution-{key}.npz"


@dataclass(frozen=True, eq=False)
class StoredSolution:
    """A stored solution: results.json without its grids (made again at the rerun's dimmers), each grid's
    per-network arrays at dimmer 1 and, for a full run that wrote patches.vtp, that file's
    arrays (``lumijax.report._vtk.patch_arrays``; None otherwise)."""

    document: dict
    grids: dict[str, dict[str, Any]]
    patches: dict[str, np.ndarray] | None = None

    @property
    def networks(self) -> tuple[str, ...]:
        return tuple(self.document["networks"])

    def dimmers_of(self, dimmers: Mapping[str, float]) -> np.ndarray:
        """Each stored network's dimmer from ``dimmers`` (by network name: the config's), and
        the default (``lumijax._dimmers``) for one without a ``[networks]`` entry, as the
        scene gives it."""
        return np.array([dimmers.get(n, DIMMER_DEFAULT) for n in self.networks])

    def grid_results(self, dimmers) -> dict:
        """Each grid as a :class:`~lumijax.results.GridResult` at ``dimmers``."""
        from .results import GridResult

        d = np.asarray(dimmers, np.float64)
        return {name: GridResult(name=name, networks=self.networks, dimmers=d, **g)
                for name, g in self.grids.items()}

    def document_at(self, dimmers, grids: dict, timing_s: dict) -> dict:
        """results.json at ``dimmers``: the stored entries, the grids' and networks' values at
        the new dimmers, and this run's ``timing_s``."""
        doc = dict(self.document)
        doc["grids"] = {n: g.to_dict() for n, g in grids.items()}
        doc["networks"] = {n: {"dimmer": float(a), **{k: v for k, v in info.items()
                                                        if k != "dimmer"}}
                           for (n, info), a in zip(self.document["networks"].items(), dimmers,
                                                   strict=True)}
        doc["timing_s"] = timing_s
        return doc


_GRID_ARRAYS = ("points", "normals", "by_network_lux", "direct_by_network_lux",
                "xyz_by_network")


def store_solution(results, cache_dir: str | Path, key: str,
                   patches: dict[str, np.ndarray] | None = None) -> Path | None:
    """Write ``results``' solution under ``key`` (atomically); warn and return None where the
    folder cannot be written. ``results`` must be at the config's design, not optimised;
    ``patches``: patches.vtp's arrays (``patch_arrays``), kept as they are (their dtypes)."""
    arrays: dict[str, np.ndarray] = {}
    for name, values in (patches or {}).items():
        arrays[f"p.{name}"] = np.asarray(values)
    grids = {}
    for i, (name, g) in enumerate(results.grids.items()):
        for a in _GRID_ARRAYS:
            v = getattr(g, a)
            if v is not None:
                arrays[f"g{i}.{a}"] = np.asarray(v, np.float64)
        grids[name] = {"index": i, "shape": None if g.shape is None else list(g.shape),
                       "target_lux": g.target_lux}
    # the grids' entries are made again at the rerun's dimmers (document_at): not made here,
    # where their CCT alone took ~0.1 s of a 100-point run (contended)
    doc = replace(results, grids={}).to_dict()
    meta = {"format": FORMAT, "key": key, "document": doc, "grids": grids,
            "patches": None if patches is None else sorted(patches)}
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    payload = buf.getvalue()
    path = solution_path(cache_dir, key)
    try:
        with atomic_path(path, what="stored solution", suffix=".npz") as tmp:
            tmp.write_bytes(hashlib.blake2b(payload, digest_size=32).digest() + payload)
    except OutputError as e:
        warnings.warn(f"cannot keep the solution for dimmer-only reruns ({e}); the next run "
                      "computes again", LumijaxWarning, stacklevel=2)
        return None
    prune(path.parent)
    return path


def prune(folder: Path, pattern: str = "solution-*.npz") -> None:
    """Remove all but the :data:`KEEP` newest files of ``pattern`` in ``folder`` (a reader
    that loses its file to this finds none and computes)."""
    try:
        found = [(p.stat().st_mtime, p) for p in folder.glob(pattern)]
    except OSError:
        return
    for _, p in sorted(found, reverse=True)[KEEP:]:
        with contextlib.suppress(OSError):
            p.unlink()


def load_solution(cache_dir: str | Path, key: str) -> StoredSolution | None:
    """The solution stored under ``key``, or None: none stored, or one that fails its digest
    or its key (warned; the full run then replaces it)."""
    path = solution_path(cache_dir, key)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as e:
        return _bad(path, f"unreadable ({e.strerror or e})")
    payload = data[32:]
    if len(data) < 32 or hashlib.blake2b(payload, digest_size=32).digest() != data[:32]:
        return _bad(path, "corrupted or truncated (its digest does not match)")
    try:
        with np.load(io.BytesIO(payload), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("meta").tobytes())
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as e:
        return _bad(path, f"unreadable ({type(e).__name__})")
    if meta.get("format") != FORMAT or meta.get("key") != key:
        return _bad(path, "not the solution of this study")
    if any(f"p.{n}" not in arrays for n in meta.get("patches") or ()):
        return _bad(path, "missing its patches' arrays")
    grids = {}
    for name, g in meta["grids"].items():
        i = g["index"]
        grids[name] = {a: arrays.get(f"g{i}.{a}") for a in _GRID_ARRAYS}
        grids[name].update(shape=None if g["shape"] is None else tuple(g["shape"]),
                           target_lux=g["target_lux"])
    names = meta.get("patches")
    patches = None if names is None else {n: arrays[f"p.{n}"] for n in names}
    return StoredSolution(meta["document"], grids, patches)


def _bad(path: Path, why: str) -> StoredSolution | None:
    """None, with the warning that says why the file at ``path`` was not used."""
    warnings.warn(f"stored solution {path} is {why}: ignored, computing again", LumijaxWarning,
                  stacklevel=3)
    return None
