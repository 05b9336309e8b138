"""``[[observers]]``: where an eye is and where it looks, for the glare ratings (docs/glare.md).

An observer is an eye position (m) and a line of sight (a ``direction`` or a ``look_at``
point), optionally turned into a fan of directions about the vertical (EN 12464-2 and sports
standards rate glare every 15° around the horizon). The models live here, apart from the rest
of the schema; ``_schema.StudyConfig.observers`` holds the list and ``check_observers`` is the
cross-reference check ``_load`` runs (groups, grids, unique names).
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field, model_validator

from ._schema import Finite, Luminance, Name, Vec3, _Model

__all__ = ["FanConfig", "ObserverConfig", "check_observers"]


class FanConfig(_Model):
    """``fan = { step_deg = 15 }`` or ``fan = { azimuths_deg = [...] }``: the line of sight
    turned about the vertical through the eye, by these angles (degrees, counter-clockwise seen
    from above), its elevation kept."""

    step_deg: Annotated[float, Field(gt=0, le=360)] | None = None
    span_deg: Annotated[float, Field(gt=0, le=360)] = 360.0
    azimuths_deg: list[Finite] | None = None

    @model_validator(mode="after")
    def _one(self):
        if (self.step_deg is None) == (self.azimuths_deg is None):
            raise ValueError("give exactly one of 'step_deg' or 'azimuths_deg'")
        if self.azimuths_deg is not None and not self.azimuths_deg:
            raise ValueError("'azimuths_deg' is empty: a fan needs at least one direction")
        return self

    def offsets_deg(self) -> list[float]:
        """The turns of the line of sight (deg), the first 0 for a ``step_deg`` fan."""
        if self.azimuths_deg is not None:
            return [float(a) for a in self.azimuths_deg]
        n = max(1, int(math.floor(self.span_deg / self.step_deg + 1e-9)))
        if self.span_deg < 360.0 - 1e-9:
            n += 1  # an open arc keeps both ends
        return [i * self.step_deg for i in range(n)]


class ObserverConfig(_Model):
    """``[[observers]]``: an eye and its line(s) of sight."""

    name: Name
    position: Vec3 = Field(description="the eye (m)")
    direction: Vec3 | None = None
    look_at: Vec3 | None = None
    group: Name | None = None
    fan: FanConfig | None = None
    road_luminance_cdm2: Luminance | None = None
    road_grid: Name | None = None
    max_luminance_cdm2: dict[Name, Luminance] | None = Field(
        default=None, description="limits (cd/m²) on the luminance of named surfaces this "
        "observer sees: { geometry name = limit }")

    @model_validator(mode="after")
    def _sight(self):
        if (self.direction is None) == (self.look_at is None):
            raise ValueError("give exactly one of 'direction' or 'look_at' (the line of sight)")
        d = self.direction if self.direction is not None else tuple(
            t - p for t, p in zip(self.look_at, self.position, strict=True))
        if math.sqrt(sum(x * x for x in d)) == 0:
            what = "'direction' is the zero vector" if self.direction is not None else (
                "'look_at' is the eye's own position")
            raise ValueError(f"{what}: no line of sight")
        if self.fan is not None and math.hypot(d[0], d[1]) <= 1e-9 * math.sqrt(
                sum(x * x for x in d)):
            raise ValueError("a 'fan' turns the line of sight about the vertical: a vertical "
                             "line of sight has no azimuth to turn")
        if self.road_luminance_cdm2 is not None and self.road_grid is not None:
            raise ValueError("give 'road_luminance_cdm2' or 'road_grid', not both")
        return self


def check_observers(cfg, fail) -> None:
    """Cross-references of ``cfg.observers``: unique names, known groups, road grids and the
    named surfaces of ``max_luminance_cdm2``.
    ``fail(key, message)`` raises the ConfigError (with the line, as ``_load`` finds it)."""
    names: dict[str, int] = {}
    grids = [g.name for g in cfg.grids]
    surfaces = sorted({g.name for g in cfg.geometry if g.name})
    for i, o in enumerate(cfg.observers):
        key = f"observers[{i}]"
        if o.name in names:
            fail(f"{key}.name", f"duplicate observer name {o.name!r} (also "
                                f"observers[{names[o.name]}])")
        names[o.name] = i
        if o.group is not None and o.group not in cfg.groups:
            known = ", ".join(sorted(cfg.groups)) or "none"
            fail(f"{key}.group", f"unknown group {o.group!r}; declared groups: {known}")
        if o.road_grid is not None and o.road_grid not in grids:
            fail(f"{key}.road_grid", f"unknown grid {o.road_grid!r}; grids: "
                                     f"{', '.join(grids) or 'none'}")
        for name in o.max_luminance_cdm2 or {}:
            if name not in surfaces:
                fail(f"{key}.max_luminance_cdm2.{name}",
                     f"no [[geometry]] item is named {name!r}; named surfaces: "
                     f"{', '.join(surfaces) or 'none (give a geometry item a name)'}")
