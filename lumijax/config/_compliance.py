"""The ``[compliance]`` table and the calculation grids the standards define (docs/config.md,
docs/compliance.md): sensor grids (cylindrical, semi-cylindrical, hemispherical, vertical),
EN 12464-1 area grids (the spacing rule), grids on a named surface; maintenance (CIE 97:2005),
energy (W/m², LENI per EN 15193-1), the areas each standard judges and obtrusive light
(CIE 150:2017).

Imported by ``_schema`` after its shared types exist (the grid kinds join its ``Grid`` union).
"""

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from ._schema import Name, NonNegative, Positive, Vec3, _GridBase, _Model

__all__ = ["SensorGrid", "AreaGrid", "SurfaceGrid", "ComplianceConfig", "MaintenanceConfig",
           "MaintenanceFactors", "EnergyConfig", "DimmingCurve", "AreaCriteria",
           "ObtrusiveConfig", "SensitivePoint", "ZONES", "LUMINAIRE_TYPES", "ENVIRONMENTS"]

Fraction = Annotated[float, Field(gt=0, le=1)]
Unit = Annotated[float, Field(ge=0, le=1)]
Hours = Annotated[float, Field(ge=0, le=8760)]
#: EN 13201-2:2015 lighting classes of the illuminance method (Tables 3 and 4).
ROAD_CLASSES = tuple(f"C{i}" for i in range(6)) + tuple(f"P{i}" for i in range(1, 7))
#: CIE 150:2017 environmental zones.
ZONES = ("E0", "E1", "E2", "E3", "E4")
#: CIE 97:2005 luminaire types (Table 4's rows) and environments (its columns).
LUMINAIRE_TYPES = ("A", "B", "C", "D", "E", "F")
ENVIRONMENTS = ("very clean", "clean", "normal", "dirty")


class _StandardGrid(_GridBase):
    @model_validator(mode="after")
    def _no_csv(self):
        if self.target_csv is not None:
            raise ValueError(f"a {self.kind} grid takes 'target_lux', not 'target_csv' (a CSV "
                             "map belongs to plane and points grids)")
        return self


class SensorGrid(_StandardGrid):
    """``kind = "sensor"``: cylindrical, semi-cylindrical, hemispherical or vertical sensors at
    ``points`` or at another grid's points (``at_grid``) moved by ``offset_m``."""

    kind: Literal["sensor"]
    sensor: Literal["cylindrical", "semicylindrical", "hemispherical", "vertical"]
    points: Annotated[list[Vec3], Field(min_length=1)] | None = None
    at_grid: Name | None = None
    offset_m: Vec3 = (0.0, 0.0, 0.0)
    axis: Vec3 = (0.0, 0.0, 1.0)
    facing: Vec3 | None = None

    @model_validator(mode="after")
    def _where(self):
        if (self.points is None) == (self.at_grid is None):
            raise ValueError("give 'points' or 'at_grid' (the name of a grid), one of them")
        if self.sensor in ("semicylindrical", "vertical") and self.facing is None:
            raise ValueError(f"a {self.sensor} sensor needs 'facing' (the direction it faces)")
        if sum(a * a for a in self.axis) == 0:
            raise ValueError("'axis' is the zero vector")
        if self.facing is not None:
            f, a = self.facing, self.axis
            cross = (f[1] * a[2] - f[2] * a[1], f[2] * a[0] - f[0] * a[2],
                     f[0] * a[1] - f[1] * a[0])
            if sum(c * c for c in cross) <= 1e-18 * sum(x * x for x in f) * sum(
                    x * x for x in a) or sum(x * x for x in f) == 0:
                raise ValueError("'facing' must be a non-zero direction across 'axis'")
        return self


class AreaGrid(_StandardGrid):
    """``kind = "area"``: an EN 12464-1 calculation area (a rectangle ``origin + s·u + t·v``)
    with points at the centres of cells of the standard's spacing ``p = 0.2·5^log10(d)`` m
    (d the longer side, m; p ≤ 10 m), less a ``border_m`` band along its edges and less the
    rectangle of the area grid ``exclude`` (an immediate surrounding or a background).
    ``rule = "EN 13201-3"``: a road field instead, ``u`` along the road between two luminaires
    (S m) and ``v`` across it (W m): N = 10 points along (S ≤ 30 m, else D = S/N ≤ 3 m) and
    n ≥ 3 across (d = W/n ≤ 1.5 m), at the cells' centres."""

    kind: Literal["area"]
    origin: Vec3
    u: Vec3
    v: Vec3
    spacing: Positive | None = None
    border_m: NonNegative = 0.0
    exclude: Name | None = None
    normal: Vec3 | None = None
    rule: Literal["EN 12464-1", "EN 13201-3"] = "EN 12464-1"

    @model_validator(mode="after")
    def _road_rule(self):
        if self.rule == "EN 13201-3":
            given = [k for k in ("spacing", "exclude") if getattr(self, k) is not None]
            if self.border_m:
                given.append("border_m")
            if given:
                raise ValueError("rule = \"EN 13201-3\" sets the points itself: "
                                 f"{', '.join(repr(k) for k in given)} belong to EN 12464-1 "
                                 "areas")
        return self


class SurfaceGrid(_StandardGrid):
    """``kind = "surface"``: points on the named geometry item's own triangles, ``offset_m``
    in front of them along each triangle's normal, about ``spacing`` m apart; each point keeps
    the triangle's normal, area and material (luminance ρE/π from the scene)."""

    kind: Literal["surface"]
    geometry: Name
    offset_m: NonNegative = 0.01
    spacing: Positive = 0.5


class MaintenanceFactors(_Model):
    """MF = LLMF × LSF × LMF × RSMF (CIE 97:2005, section 2), or ``mf`` given directly. LMF may
    be looked up (CIE 97:2005 Table 4) from ``luminaire_type``, ``environment`` and
    ``cleaning_interval_years``."""

    mf: Fraction | None = None
    llmf: Fraction = 1.0
    lsf: Fraction = 1.0
    lmf: Fraction | None = None
    rsmf: Fraction = 1.0
    luminaire_type: Literal["A", "B", "C", "D", "E", "F"] | None = None
    environment: Literal["very clean", "clean", "normal", "dirty"] | None = None
    cleaning_interval_years: Annotated[float, Field(ge=0, le=3)] | None = None

    @model_validator(mode="after")
    def _one_way(self):
        lookup = (self.luminaire_type, self.environment, self.cleaning_interval_years)
        if any(v is not None for v in lookup) and None in lookup:
            raise ValueError("the LMF lookup needs all of 'luminaire_type', 'environment' and "
                             "'cleaning_interval_years'")
        if self.lmf is not None and lookup[0] is not None:
            raise ValueError("give 'lmf' or its lookup ('luminaire_type', ...), not both")
        given = self.lmf is not None or lookup[0] is not None or self.model_fields_set & {
            "llmf", "lsf", "rsmf"}
        if self.mf is not None and given:
            raise ValueError("give 'mf' directly or its factors (llmf, lsf, lmf, rsmf), "
                             "not both")
        return self


class MaintenanceConfig(MaintenanceFactors):
    """``[compliance.maintenance]``: the installation's factors, and per network
    (``[compliance.maintenance.networks.NAME]``) factors that replace them."""

    networks: dict[Name, MaintenanceFactors] = {}


class DimmingCurve(_Model):
    """``[compliance.energy.dimming.NETWORK]``: power against dimmer level. ``linear``:
    ``P = standby + (P₁ − standby)·α``; ``table``: ``power`` (fractions of P₁) at ``levels``
    (dimmer 0–1), linear between, both non-decreasing."""

    curve: Literal["linear", "table"] = "linear"
    levels: list[Unit] | None = None
    power: list[Annotated[float, Field(ge=0, le=1)]] | None = None
    standby_w: NonNegative = 0.0

    @model_validator(mode="after")
    def _table(self):
        if self.curve == "linear":
            if self.levels is not None or self.power is not None:
                raise ValueError("'levels' and 'power' belong to curve = \"table\"")
            return self
        if self.levels is None or self.power is None or len(self.levels) < 2:
            raise ValueError("curve = \"table\" needs 'levels' and 'power', two entries or more")
        if len(self.levels) != len(self.power):
            raise ValueError(f"'levels' has {len(self.levels)} entries but 'power' has "
                             f"{len(self.power)}")
        for name, vals in (("levels", self.levels), ("power", self.power)):
            for i in range(1, len(vals)):
                if vals[i] < vals[i - 1] or (name == "levels" and vals[i] == vals[i - 1]):
                    raise ValueError(f"'{name}' must increase (the curve is monotonic): entry "
                                     f"{i} ({vals[i]:g}) follows {vals[i - 1]:g}")
        if self.levels[0] != 0 or self.levels[-1] != 1:
            raise ValueError("'levels' must run from 0 to 1 (the whole dimmer range)")
        return self


class EnergyConfig(_Model):
    """``[compliance.energy]``: input power and the EN 15193-1 annual energy (LENI)."""

    watts: dict[Name, NonNegative] = Field({}, description="W per luminaire, by photometry")
    dimming: dict[Name, DimmingCurve] = {}
    hours_day: Hours = 2250.0
    hours_night: Hours = 250.0
    occupancy_factor: Unit = 1.0
    daylight_factor: Unit = 1.0
    constant_illuminance_factor: Unit = 1.0
    parasitic_w_per_m2: NonNegative = 0.0
    emergency_w_per_m2: NonNegative = 0.0
    emergency_charge_hours: Hours = 0.0
    area_m2: Positive | None = None
    leni_max: Positive | None = Field(None, description="kWh/(m²·a), a limit to judge")
    w_per_m2_max: Positive | None = None

    @model_validator(mode="after")
    def _year(self):
        if self.hours_day + self.hours_night > 8760:
            raise ValueError(f"hours_day + hours_night = {self.hours_day + self.hours_night:g}"
                             " h, more than the 8760 h of a year")
        return self


class AreaCriteria(_Model):
    """``[[compliance.areas]]``: an area a standard judges. Limits come from the standard's
    table row ``reference`` (docs/compliance.md lists those transcribed) or are given."""

    name: Name
    standard: Literal["EN 12464-1", "EN 12464-2", "EN 13201-2"]
    grid: Name
    reference: str | None = None
    road_class: str | None = None
    em_lux: Positive | None = None
    u0: Fraction | None = None
    ugr_l: Positive | None = None
    gr_l: Positive | None = None
    ra: Annotated[float, Field(gt=0, le=100)] | None = None
    ez_lux: Positive | None = None
    cylindrical: Name | None = None
    modelling: tuple[Positive, Positive] | None = None
    surrounding: Name | None = None
    background: Name | None = None
    networks: list[Name] | None = None
    area_m2: Positive | None = None
    observers: list[Name] | None = None

    @field_validator("road_class")
    @classmethod
    def _road_class(cls, v):
        if v is not None and v not in ROAD_CLASSES:
            raise ValueError(f"unknown EN 13201-2 lighting class {v!r}; the illuminance classes "
                             f"are {', '.join(ROAD_CLASSES)} (M classes are not implemented)")
        return v

    @model_validator(mode="after")
    def _road(self):
        road = self.standard == "EN 13201-2"
        if road and self.road_class is None:
            raise ValueError("an EN 13201-2 area needs 'road_class' (C0–C5 or P1–P6)")
        if not road and self.road_class is not None:
            raise ValueError(f"'road_class' belongs to standard = \"EN 13201-2\", not "
                             f"{self.standard!r}")
        if road:
            extra = [k for k in ("reference", "ugr_l", "gr_l", "ra", "ez_lux", "cylindrical",
                                 "modelling", "surrounding", "background", "observers")
                     if getattr(self, k) is not None]
            if extra:
                raise ValueError(f"an EN 13201-2 area takes 'road_class' (and 'em_lux', 'u0', "
                                 f"'area_m2'), not {', '.join(repr(k) for k in extra)}")
        return self

    @model_validator(mode="after")
    def _some(self):
        if self.modelling is not None and self.modelling[0] > self.modelling[1]:
            raise ValueError("'modelling' is [lowest, highest] Ēz/Ēh")
        if self.modelling is not None and self.cylindrical is None:
            raise ValueError("'modelling' (Ēz/Ēh) needs 'cylindrical', a cylindrical sensor "
                             "grid")
        return self


class SensitivePoint(_Model):
    """A place the luminaires must not glare into (a neighbour's window, a bedroom)."""

    name: Name
    point: Vec3


class ObtrusiveConfig(_Model):
    """``[compliance.obtrusive]``: CIE 150:2017 obtrusive light in environmental zone
    ``zone``, before and (with ``curfew``) after the curfew, when the networks are at
    ``after_curfew`` (dimmers by network; the others keep theirs)."""

    zone: str
    curfew: str | None = None
    after_curfew: dict[Name, Unit] | None = None
    windows: list[Name] = []
    facades: list[Name] = []
    sensitive: list[SensitivePoint] = []
    upward_light: bool = True
    reflected_ulr: Literal["report", "judge", "off"] = "report"
    ulr_max: Unit | None = None

    @field_validator("zone")
    @classmethod
    def _zone(cls, v):
        if v not in ZONES:
            raise ValueError(f"unknown environmental zone {v!r}; CIE 150:2017 zones are "
                             f"{', '.join(ZONES)}")
        return v

    @field_validator("curfew")
    @classmethod
    def _time(cls, v):
        if v is not None and not re.fullmatch(r"([01]\d|2[0-3]):[0-5]\d", v):
            raise ValueError(f"expected a time HH:MM, got {v!r}")
        return v

    @model_validator(mode="after")
    def _curfew(self):
        if self.after_curfew is not None and self.curfew is None:
            raise ValueError("'after_curfew' dimmers need 'curfew' (the time, HH:MM)")
        return self


class ComplianceConfig(_Model):
    """``[compliance]``: maintenance, energy, the areas a standard judges, obtrusive light."""

    maintenance: MaintenanceConfig | None = None
    energy: EnergyConfig | None = None
    areas: list[AreaCriteria] = []
    obtrusive: ObtrusiveConfig | None = None

    @model_validator(mode="after")
    def _unique(self):
        names = [a.name for a in self.areas]
        for n in names:
            if names.count(n) > 1:
                raise ValueError(f"two areas are named {n!r}")
        return self


def check_compliance(cfg, fail) -> None:
    """Names the standards' grids and ``[compliance]`` refer to exist (``fail(key, message)``
    raises the loader's ConfigError with the key's line)."""
    grids = {g.name: g for g in cfg.grids}
    geometry = [g.name for g in cfg.geometry if g.name]
    networks = set(cfg.networks) or {lum.network for lum in cfg.luminaires}

    def known(what, names):
        return f"{what}: {', '.join(sorted(names))}" if names else f"no {what} are declared"

    def grid(key, name, kinds=None):
        if name not in grids:
            fail(key, f"unknown grid {name!r}; {known('grids', grids)}")
        if kinds is not None and grids[name].kind not in kinds:
            fail(key, f"grid {name!r} is a {grids[name].kind} grid; expected "
                      f"{' or '.join(kinds)}")

    def network(key, name):
        if name not in networks:
            fail(key, f"unknown network {name!r}; {known('networks', networks)}")

    for i, g in enumerate(cfg.grids):
        key = f"grids[{i}]"
        if g.kind == "sensor" and g.at_grid is not None:
            grid(f"{key}.at_grid", g.at_grid, ("plane", "points", "area", "surface"))
        if g.kind == "area" and g.exclude is not None:
            grid(f"{key}.exclude", g.exclude, ("area",))
        if g.kind == "surface" and g.geometry not in geometry:
            fail(f"{key}.geometry", f"no geometry named {g.geometry!r}; "
                                    f"{known('named geometry', geometry)}")
    comp = cfg.compliance
    if comp is None:
        return
    if comp.maintenance is not None:
        for n in comp.maintenance.networks:
            network(f"compliance.maintenance.networks.{n}", n)
    if comp.energy is not None:
        for n in comp.energy.dimming:
            network(f"compliance.energy.dimming.{n}", n)
        for p in comp.energy.watts:
            if p not in cfg.photometry:
                fail(f"compliance.energy.watts.{p}",
                     f"unknown photometry {p!r}; {known('photometry', cfg.photometry)}")
    for i, a in enumerate(comp.areas):
        key = f"compliance.areas[{i}]"
        grid(f"{key}.grid", a.grid)
        if a.cylindrical is not None:
            grid(f"{key}.cylindrical", a.cylindrical, ("sensor",))
        for attr in ("surrounding", "background"):
            if getattr(a, attr) is not None:
                grid(f"{key}.{attr}", getattr(a, attr))
        for n in a.networks or ():
            network(f"{key}.networks", n)
        observers = {o.name for o in cfg.observers}
        for o in a.observers or ():
            if o not in observers:
                fail(f"{key}.observers", f"unknown observer {o!r}; "
                                         f"{known('observers', observers)}")
    ob = comp.obtrusive
    if ob is not None:
        for i, w in enumerate(ob.windows):
            grid(f"compliance.obtrusive.windows[{i}]", w)
        for i, f in enumerate(ob.facades):
            grid(f"compliance.obtrusive.facades[{i}]", f, ("surface",))
        for n in ob.after_curfew or {}:
            network(f"compliance.obtrusive.after_curfew.{n}", n)
