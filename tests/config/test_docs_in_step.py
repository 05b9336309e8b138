"""docs/config.md keeps up with the schema, and the example configs in configs/ stay valid.

The schema (``lumijax/config/_schema.py``) is the truth; this test walks every pydantic model
reachable from :class:`StudyConfig` (through ``Annotated``, unions, dicts, lists and tuples) and
fails, listing what is missing, when a key name or an allowed literal value is not documented.
"""

from __future__ import annotations

import re
import types
import typing
from pathlib import Path

import pytest
from pydantic import BaseModel

from lumijax import load_study
from lumijax.config import StudyConfig, _schema as _schema_module, load_config

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "config.md"
CONFIGS = sorted((REPO / "configs").glob("*.toml"))


def _walk(annotation, seen: set[type], found: dict[str, set[str]], literals: dict[str, set]):
    """Collect ``key -> {Model, ...}`` and ``Model.key -> literal values`` from an annotation."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        _walk(typing.get_args(annotation)[0], seen, found, literals)
        return
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        if annotation in seen:
            return
        seen.add(annotation)
        for key, field in annotation.model_fields.items():
            found.setdefault(key, set()).add(annotation.__name__)
            for value in _literal_values(field.annotation):
                literals.setdefault(f"{annotation.__name__}.{key}", set()).add(value)
            _walk(field.annotation, seen, found, literals)
        return
    if origin is not None or isinstance(annotation, types.UnionType):
        for arg in typing.get_args(annotation):
            if arg is not Ellipsis:
                _walk(arg, seen, found, literals)


def _literal_values(annotation) -> list:
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        return list(typing.get_args(annotation))
    if origin is not None or isinstance(annotation, types.UnionType):
        return [v for a in typing.get_args(annotation) for v in _literal_values(a)]
    return []


def _schema():
    found: dict[str, set[str]] = {}
    literals: dict[str, set] = {}
    _walk(StudyConfig, set(), found, literals)
    return found, literals


def test_the_walk_reaches_every_model():
    """Guard the walker itself: a union or container it failed to enter would hide keys."""
    found, literals = _schema()
    models = {m for owners in found.values() for m in owners}
    unreached = set(_schema_module.__all__) - models
    assert not unreached, f"models of the schema the walk did not reach: {sorted(unreached)}"
    assert {"tilt", "aim_at", "flip_normals", "spacing", "dimmer", "srgb"} <= set(found)
    assert literals["MeshGeometry.units"] == {"m", "mm", "cm", "ft", "in"}


def test_every_schema_key_is_documented():
    text = DOC.read_text(encoding="utf-8")
    documented = set(re.findall(r"`([^`\n]+)`", text))
    found, _ = _schema()
    missing = sorted(
        f"{key} (in {', '.join(sorted(owners))})"
        for key, owners in found.items()
        if key not in documented
    )
    assert not missing, (
        f"{len(missing)} config key(s) of lumijax/config/_schema.py are not documented in "
        f"docs/config.md as `key`:\n  " + "\n  ".join(missing)
    )


def test_every_allowed_value_is_documented():
    text = DOC.read_text(encoding="utf-8")
    _, literals = _schema()
    missing = sorted(
        f'"{value}" (for {where})'
        for where, values in literals.items()
        for value in values
        if f'"{value}"' not in text
    )
    assert not missing, (
        'allowed values of the schema are not documented in docs/config.md (as "value"):\n  '
        + "\n  ".join(missing)
    )


def test_there_are_example_configs():
    assert CONFIGS, "configs/ has no *.toml example"


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_example_config_loads(path):
    cfg = load_config(path)
    assert cfg.source == path.resolve()
    study = load_study(path)
    assert study.scene.grids, f"{path.name} has no grids: it would compute nothing"
    assert study.scene.luminaires or study.scene.area_sources, f"{path.name} has no luminaires"
