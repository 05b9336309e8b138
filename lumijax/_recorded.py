"""A study file's stored solution, found without validating its config: the rerun without the
schema.

Validating a config (pydantic, ``lumijax.config``) costs more than half of a dimmer-only
rerun's half second (benchmarks/RESULTS.md, session 21). Yet a study file that reads, as TOML
and with its dimmers left out, as it read in an earlier run — at the same resolved path, with
every file it names holding the same bytes, under the same lumijax and with the same run
options — validates to the same config, and so to the same solution key (``lumijax._stored``).
So a run that stores or reads a solution also writes a *record*: under the key of its TOML
without dimmers (:func:`read_study`), the solution's key and the SHA-256 of every path the
config named. A later numbers run parses its TOML (tomllib, no schema), finds the record,
checks those files and its own dimmers, and superposes the stored solution.

Anything else goes the validated way, which also names what is wrong: a file that cannot be
read or parsed, a dimmer that is not a plain number from 0 to 1 (a string, a boolean, NaN,
out of range), a named file whose bytes changed, tables in another order, a record missing,
another key's or unreadable (warned). Records live beside the solutions, one small
``record-<key>.json`` each, written atomically; the :data:`~lumijax._stored.KEEP` newest are
kept.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path

from . import _dimmers
from ._atomic import atomic_path
from ._stored import code_digest, file_digest, prune
from .errors import LumijaxWarning, OutputError

__all__ = ["StudyFile", "read_study", "record_path", "write_record", "recorded_solution"]

FORMAT = "lumijax-record-1"


@dataclass(frozen=True)
class StudyFile:
    """A study file read as TOML without the schema.

    ``text``: the file's text, for the config's validation (read once: a record never joins
    one text's key to another's solution); ``key``: SHA-256 hex of its resolved path, its TOML
    with every network's ``dimmer`` removed, the run's options and lumijax's code
    (``code_digest``), or None where no record may stand for it; ``dimmers``: each
    ``[networks.NAME]``'s dimmer (the default where the table gives none).
    """

    text: str
    key: str | None
    dimmers: dict[str, float]


def read_study(path: str | Path, options: dict) -> StudyFile | None:
    """``path`` read as TOML and keyed with ``options`` (the run's, JSON-able: whatever else
    decides its numbers); None where it cannot be read (``load_config`` says why). Its key is
    None where the TOML does not parse or a dimmer is not a plain number within the range
    (``lumijax._dimmers``): the validated way then runs and names the problem."""
    try:
        path = Path(path).resolve()
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    unkeyed = StudyFile(text, None, {})
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return unkeyed
    networks = data.get("networks", {})
    if not isinstance(networks, dict):
        return unkeyed
    dimmers = {}
    for name, table in networks.items():
        if not isinstance(table, dict):
            return unkeyed
        d = table.pop("dimmer", _dimmers.DEFAULT)
        # bool is an int in Python, not a dimmer; NaN fails both comparisons
        if isinstance(d, bool) or not isinstance(d, int | float) or not (
                _dimmers.LOW <= d <= _dimmers.HIGH):
            return unkeyed
        dimmers[name] = float(d)
    # the tables in the file's order (no sort_keys): a reordered study goes the validated way
    keyed = json.dumps({"study": str(path), "toml": data, "options": options}, default=repr)
    h = hashlib.sha256(f"{FORMAT}\0{code_digest()}\0".encode())
    h.update(keyed.encode())
    return StudyFile(text, h.hexdigest(), dimmers)


def record_path(cache_dir: str | Path, key: str) -> Path:
    """Where the record of the study file key ``key`` lives in ``cache_dir``."""
    return Path(cache_dir) / f"record-{key}.json"


def write_record(cache_dir: str | Path, key: str, solution: str,
                 files: dict[str, str | None]) -> None:
    """Record that the study file ``key`` validates to the solution ``solution`` while every
    path of ``files`` has the SHA-256 given (None: not a file). A folder that cannot be
    written keeps no record (the next run validates its config; the solution's store has
    warned)."""
    path = record_path(cache_dir, key)
    text = json.dumps({"format": FORMAT, "key": key, "solution": solution, "files": files})
    try:
        with atomic_path(path, what="study record", suffix=".json") as tmp:
            tmp.write_text(text, encoding="utf-8")
    except OutputError:
        return
    prune(path.parent, "record-*.json")


def recorded_solution(cache_dir: str | Path, key: str) -> str | None:
    """The solution key recorded for the study file key ``key`` if every file it names still
    has its recorded bytes; else None (no record, a changed file; an unreadable record or
    another key's, warned)."""
    path = record_path(cache_dir, key)
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
        good = (isinstance(record, dict) and record.get("format") == FORMAT
                and record.get("key") == key and isinstance(record.get("solution"), str)
                and isinstance(record.get("files"), dict))
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError, ValueError):
        good = False
    if not good:
        warnings.warn(f"study record {path} is unreadable or not this study's: ignored, "
                      "reading the config", LumijaxWarning, stacklevel=2)
        return None
    if any(file_digest(Path(name)) != digest for name, digest in record["files"].items()):
        return None
    return record["solution"]
