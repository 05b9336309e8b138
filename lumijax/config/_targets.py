"""Target maps: the CSV a grid's ``target_csv`` names, read into points and lux."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from jaxtyping import Float

from ..errors import ConfigError

__all__ = ["read_target_csv"]

_COLUMNS = ("x", "y", "z", "lux")


def read_target_csv(path: Path, *, key: str | None = None) -> Float[np.ndarray, "rows 4"]:
    """Read a target map: a header ``x,y,z,lux`` (m, m, m, lx), then one row per grid point.

    Raises :class:`ConfigError` naming the file, the config key and the bad row.
    """
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as e:
        raise ConfigError(f"the target map is not UTF-8 text (byte {e.start + 1}): expected a CSV "
                          "with the header x,y,z,lux", file=path, key=key) from None
    except IsADirectoryError:
        raise ConfigError("the target map is a directory, not a CSV file", file=path,
                          key=key) from None
    except OSError as e:
        raise ConfigError(f"cannot read the target map ({e.strerror or type(e).__name__})",
                          file=path, key=key) from None
    rows = list(csv.reader(text.splitlines()))
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise ConfigError("target map is empty: expected a header x,y,z,lux and one row per "
                          "grid point", file=path, key=key)
    header = tuple(c.strip().lower() for c in rows[0])
    if header != _COLUMNS:
        raise ConfigError("the first line is not the header x,y,z,lux that a target map starts "
                          "with", file=path, key=key, line=1)
    out = np.empty((len(rows) - 1, 4))
    for i, r in enumerate(rows[1:]):
        try:
            if len(r) != 4:
                raise ValueError
            out[i] = [float(c) for c in r]
        except ValueError:
            # The row's text is not echoed: the path may name any file (docs/config.md, "Paths").
            raise ConfigError(f"row {i + 1} is not four numbers x,y,z,lux ({len(r)} fields)",
                              file=path, key=key, line=i + 2) from None
    if not np.all(np.isfinite(out)):
        raise ConfigError("target map holds NaN or infinite values", file=path, key=key)
    if np.any(out[:, 3] < 0):
        i = int(np.argmax(out[:, 3] < 0))
        raise ConfigError(f"row {i + 1}: a target illuminance cannot be negative "
                          f"({out[i, 3]:g} lx)", file=path, key=key, line=i + 2)
    return out
