"""The one error family of lumijax.

Every error a user can cause is a :class:`LumijaxError`. Each carries *where* the problem is
(``file``, ``line``, ``key`` — a config key path such as ``luminaires[3].aim.tilt``) and *what was
expected*, so the command line can print it as one precise sentence without a traceback.
"""

from __future__ import annotations

from pathlib import Path

__all__ = [
    "LumijaxError",
    "ConfigError",
    "PhotometryError",
    "SpectrumError",
    "GeometryError",
    "SolveError",
    "OutputError",
    "LumijaxWarning",
]


class LumijaxError(Exception):
    """Base class of every error lumijax raises on bad input or an impossible request.

    Parameters
    ----------
    message
        What is wrong and what was expected, as a sentence.
    file
        The file the problem is in, if any.
    line
        1-based line number in ``file``, if known.
    key
        Config key path (``grids[0].nu``) or another name of the offending item.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | Path | None = None,
        line: int | None = None,
        key: str | None = None,
    ) -> None:
        self.message = message
        self.file = None if file is None else str(file)
        self.line = line
        self.key = key
        super().__init__(self._render())

    def _render(self) -> str:
        where = ""
        if self.file is not None:
            where = self.file if self.line is None else f"{self.file}:{self.line}"
        if self.key is not None:
            where = f"{where}: {self.key}" if where else self.key
        return f"{where}: {self.message}" if where else self.message

    def __reduce__(self):  # keep keyword fields through pickling (multiprocessing, caches)
        return (_rebuild, (type(self), self.message, self.file, self.line, self.key))


def _rebuild(cls, message, file, line, key):
    return cls(message, file=file, line=line, key=key)


class ConfigError(LumijaxError):
    """A study config is malformed: bad TOML, unknown key, wrong type or value, missing file."""


class PhotometryError(LumijaxError):
    """An IES LM-63 or EULUMDAT file cannot be read, or photometric data are invalid."""


class SpectrumError(LumijaxError):
    """A spectral distribution is invalid (negative, unsorted, too short, unknown name)."""


class GeometryError(LumijaxError):
    """Geometry is degenerate or inconsistent (NaN or zero-area triangles, a light inside a solid)."""


class SolveError(LumijaxError):
    """A lighting solve has no meaningful solution (e.g. a closed enclosure with reflectance 1)."""


class OutputError(LumijaxError):
    """Results cannot be written where asked."""


class LumijaxWarning(UserWarning):
    """A suspicious but usable input: header flux that disagrees with the data, light escaping."""
