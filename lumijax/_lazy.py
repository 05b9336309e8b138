"""Names a package imports on first use (PEP 562), shared by ``lumijax`` and ``lumijax.report``.

Both keep ``import lumijax`` (and the command line's dimmer-only rerun, which never needs JAX)
down to milliseconds: a name is looked up in a table of ``name → module`` and its module is
imported only when the name is first read; the value is then bound in the package's globals,
so later reads are plain attribute look-ups and never come back here.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Mapping
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(package: str, namespace: dict[str, Any], table: Mapping[str, str], *,
               extra: Iterable[str] = ()) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package`` (its ``__name__``), whose module
    globals are ``namespace``, for the names in ``table`` (public name → the module that defines
    it, relative to ``package``); ``extra``: further names ``dir()`` lists (e.g. a property of
    the package's module class)."""
    listed = frozenset(table) | frozenset(extra)

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value  # once: later look-ups are plain attribute reads
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | listed)

    return __getattr__, __dir__
