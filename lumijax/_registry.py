"""One registry per choice (colour-science's pattern): a read-only name → implementation map.

A config key that picks an implementation (``optimise.solver``, ``cameras.NAME.tone``) is typed
in ``config/_schema.py`` by a ``Literal`` of the allowed names; the implementations live in a
registry beside their code. The config is the bottom layer of the package and must not import
what it configures (that was the config → optimise import circle), so the ``Literal`` cannot be
computed from the registry there; instead each registry is built *against* its ``Literal`` and
refuses, at import, any name missing on either side. Adding a method is then one class, one
registry line and one word in the schema's ``Literal``, and forgetting either fails at import.
"""

from __future__ import annotations

import typing
from collections.abc import Iterator, Mapping
from typing import Generic, TypeVar

from .errors import ConfigError

__all__ = ["Registry"]

V = TypeVar("V")


class Registry(Mapping[str, V], Generic[V]):
    """Read-only ``name -> implementation`` map whose names are exactly those of ``names``
    (a ``typing.Literal``), for the config key ``key``; an unknown name is a
    :class:`~lumijax.errors.ConfigError` naming the key and the choices."""

    def __init__(self, key: str, names: object, entries: Mapping[str, V],
                 aliases: Mapping[str, str] | None = None):
        self.key = key
        self._entries = dict(entries)
        self._aliases = dict(aliases or {})
        allowed = set(typing.get_args(names))
        known = set(self._entries) | set(self._aliases)
        if allowed != known:
            raise TypeError(
                f"registry {key!r} is out of step with its schema Literal: "
                f"missing from the registry {sorted(allowed - known)}, "
                f"missing from the Literal {sorted(known - allowed)}")
        unaliased = set(self._aliases.values()) - set(self._entries)
        if unaliased:
            raise TypeError(f"registry {key!r}: aliases name no entry: {sorted(unaliased)}")

    def __getitem__(self, name: str) -> V:
        name = self._aliases.get(name, name)
        try:
            return self._entries[name]
        except KeyError:
            choices = ", ".join(repr(n) for n in self.names)
            raise ConfigError(f"expected one of {choices}, got {name!r}", key=self.key) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._entries or name in self._aliases

    @property
    def names(self) -> tuple[str, ...]:
        """Every accepted name: the entries, then the aliases (``"auto"``)."""
        return (*self._entries, *self._aliases)

    def resolve(self, name: str) -> str:
        """The entry a name stands for (an alias's target, or the name itself)."""
        self[name]  # an unknown name raises here
        return self._aliases.get(name, name)
