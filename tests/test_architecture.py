"""The package tree is the data flow (docs/architecture.md): each layer imports only layers below
it, imports hidden inside functions included, so the graph has no circles and no upward arrows."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "lumijax"

# The order of docs/architecture.md, bottom first. A module may import its own layer's modules and
# any layer with a smaller rank.
LAYERS = [
    ("errors", "_version", "_lazy", "_dimmers"),
    ("_atomic", "_registry", "_jit_cache"),
    ("_executables",),
    ("parallel",),
    ("config",),
    ("spectral",),
    ("photometry",),
    ("kernels",),
    ("scene",),
    ("direct",),
    ("radiosity",),
    ("lighting",),
    ("design",),
    ("results",),
    ("glare",),
    ("render",),
    ("compliance",),
    ("_study", "_stored"),
    ("_recorded",),
    ("optimise",),
    ("report",),
    ("view",),
    ("cli", "__main__"),
    ("__init__",),
]
RANK = {name: i for i, names in enumerate(LAYERS) for name in names}


def _layer(module: str) -> str:
    """``lumijax.radiosity._solve`` → ``radiosity``; ``lumijax`` → ``__init__``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[int, str]]:
    """Every lumijax module ``path`` imports, with the line, resolving relative imports."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith("lumijax")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target == "lumijax" and node.level:  # ``from .. import x``: x is a subpackage
                out += [(node.lineno, f"lumijax.{a.name}") for a in node.names]
            elif target.startswith("lumijax"):
                out.append((node.lineno, target))
    return out


FILES = sorted(PACKAGE.rglob("*.py"))


def test_every_package_has_a_layer():
    missing = {_layer(_module_name(f)) for f in FILES} - set(RANK)
    assert not missing, f"add {sorted(missing)} to LAYERS and to docs/architecture.md"


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down(path):
    here = _layer(_module_name(path))
    upward = [
        f"{path.relative_to(PACKAGE.parent)}:{line} imports {target}"
        for line, target in _imports(path)
        if _layer(target) != here and RANK.get(_layer(target), -1) >= RANK[here]
    ]
    assert not upward, "imports that run up the layers:\n" + "\n".join(upward)


def test_test_modules_outside_packages_have_unique_names():
    # pytest's default import mode imports a test file outside a package by its bare name, so two
    # tests/*/test_x.py break collection of the whole suite ("import file mismatch").
    tests = Path(__file__).parent
    seen: dict[str, list[str]] = {}
    for f in tests.rglob("test_*.py"):
        if not (f.parent / "__init__.py").exists():
            seen.setdefault(f.name, []).append(str(f.relative_to(tests)))
    clashes = {name: paths for name, paths in seen.items() if len(paths) > 1}
    assert not clashes, f"rename one of each: {clashes}"
