"""What the designer asks of each grid, as arrays: target maps, limits and their weights.

A config states targets per grid (``target_lux`` or ``target_csv``, ``min_lux``, ``max_lux``,
``uniformity_min``, ``max_luminance_cdm2``) and for the whole study (``[optimise]
max_luminance_cdm2``, ``energy_weight``). This module reads them into :class:`GridGoal` records
over the grids' points, in the order ``lumijax.compute`` concatenates the grids.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Float

from ..config import read_target_csv
from ..errors import ConfigError

__all__ = ["GridGoal", "grid_goals"]

@dataclass(frozen=True)
class GridGoal:
    """One grid's targets over its points ``start:stop`` of the concatenated grid points.

    ``target`` is the wanted illuminance per point (lx) or None; limits are None when unset.
    ``rho`` is the grid's reflectance (for its luminance limit, L = ρE/π).
    """

    name: str
    start: int
    stop: int
    target: Float[np.ndarray, " points"] | None = None
    target_kind: str | None = None
    weight: float = 1.0
    min_lux: float | None = None
    max_lux: float | None = None
    uniformity_min: float | None = None
    max_luminance_cdm2: float | None = None
    rho: float | None = None

    @property
    def any(self) -> bool:
        return self.target is not None or any(
            v is not None for v in (self.min_lux, self.max_lux, self.uniformity_min,
                                    self.max_luminance_cdm2))


def grid_goals(study) -> tuple[GridGoal, ...]:
    """The goals of every grid of ``study`` that has one, checking target maps against the
    grid's points (a map whose rows are not at the grid's points is a :class:`ConfigError`)."""
    cfg, scene = study.config, study.scene
    out = []
    start = 0
    for i, (gc, g) in enumerate(zip(cfg.grids, scene.grids, strict=True)):
        n = len(g)
        target = kind = None
        if gc.target_lux is not None:
            target, kind = np.full(n, float(gc.target_lux)), "target_lux"
        elif gc.target_csv is not None:
            key = f"grids[{i}].target_csv"
            rows = read_target_csv(gc.target_csv, key=key)
            if len(rows) != n:
                raise ConfigError(f"{len(rows)} rows for {n} points of grid {g.name!r}",
                                  file=gc.target_csv, key=key)
            size = float(np.ptp(g.points, axis=0).max()) if n > 1 else 1.0
            err = np.linalg.norm(rows[:, :3] - g.points, axis=1)
            tol = 1e-3 + 1e-6 * size
            if np.any(err > tol):
                j = int(np.argmax(err > tol))
                raise ConfigError(
                    f"row {j + 1} is at {rows[j, :3].round(4).tolist()} but point {j} of grid "
                    f"{g.name!r} is at {g.points[j].round(4).tolist()} (off by {err[j]:.3g} m): "
                    "the rows must be the grid's points in its order (see grids/NAME.csv of a "
                    "run)", file=gc.target_csv, key=key, line=j + 2)
            target, kind = rows[:, 3].copy(), "target_csv"
        goal = GridGoal(
            name=g.name, start=start, stop=start + n, target=target, target_kind=kind,
            weight=float(gc.target_weight), min_lux=gc.min_lux, max_lux=gc.max_lux,
            uniformity_min=gc.uniformity_min, max_luminance_cdm2=gc.max_luminance_cdm2,
            rho=gc.reflectance,
        )
        start += n
        if goal.any:
            out.append(goal)
    return tuple(out)
