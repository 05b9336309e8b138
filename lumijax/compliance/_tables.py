"""Rows of the standards' tables, transcribed with their numbers (docs/compliance.md says which,
and that a project should check them against its own copy of the standard, or give the values
in the config instead: ``em_lux``, ``u0``, ...). ``None``: the row sets no such requirement."""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["AreaRequirement", "EN12464_1", "EN12464_2", "surrounding_lux",
           "SURROUNDING_U0", "BACKGROUND_RATIO", "BACKGROUND_U0", "CIE150", "CIE150_2003_ULR",
           "ZoneLimits", "RoadClass", "EN13201_2", "P_CLASS_MAX_RATIO"]


class AreaRequirement(NamedTuple):
    """One row: maintained illuminance Ēm (lx), uniformity U0, glare limit (UGR_L indoors,
    GR_L outdoors), colour rendering Ra, cylindrical illuminance Ēz (lx), and its title."""

    em_lux: float
    u0: float
    glare: float | None
    ra: float
    ez_lux: float | None
    title: str


#: EN 12464-1:2021, Table 34 (Offices), "required" values.
EN12464_1 = {
    "34.1": AreaRequirement(300, 0.40, 19, 80, 100, "Filing, copying, etc."),
    "34.2": AreaRequirement(500, 0.60, 19, 80, 150,
                            "Writing, typing, reading, data processing"),
    "34.3": AreaRequirement(750, 0.70, 16, 80, 150, "Technical drawing"),
    "34.4": AreaRequirement(500, 0.60, 19, 80, 150, "CAD work stations"),
    "34.5": AreaRequirement(500, 0.60, 19, 80, 150, "Conference and meeting rooms"),
    "34.6": AreaRequirement(300, 0.60, 22, 80, 100, "Reception desk"),
    "34.7": AreaRequirement(200, 0.40, 25, 80, 50, "Archives"),
}

#: EN 12464-2:2014, Table 5.1 (general circulation areas at outdoor work places) and Table 5.9
#: (parking areas); the glare column is GR_L.
EN12464_2 = {
    "5.1.1": AreaRequirement(5, 0.25, 50, 20, None, "Walkways exclusively for pedestrians"),
    "5.1.2": AreaRequirement(10, 0.40, 50, 20, None,
                             "Traffic areas for slowly moving vehicles (max. 10 km/h)"),
    "5.1.3": AreaRequirement(20, 0.40, 45, 20, None, "Regular vehicle traffic (max. 40 km/h)"),
    "5.9.1": AreaRequirement(5, 0.25, 55, 20, None, "Parking areas: light traffic"),
    "5.9.2": AreaRequirement(10, 0.25, 50, 20, None, "Parking areas: medium traffic"),
    "5.9.3": AreaRequirement(20, 0.25, 50, 20, None, "Parking areas: heavy traffic"),
}


def surrounding_lux(task_lux: float) -> float:
    """Ēm required on the immediate surrounding of a task area of Ēm ``task_lux`` (lx):
    EN 12464-1:2011, Table 1 (≥ 750 → 500, 500 → 300, 300 → 200, ≤ 200 → Ē_task; between
    rows, the row at or below the task's value)."""
    for task, surround in ((750, 500), (500, 300), (300, 200)):
        if task_lux >= task:
            return float(surround)
    return float(task_lux)


#: EN 12464-1:2011, 4.3.1: U0 of the immediate surrounding ≥ 0.40.
SURROUNDING_U0 = 0.40
#: EN 12464-1:2011, 4.3.2: the background area's Ēm ≥ 1/3 of the immediate surrounding's, its
#: U0 ≥ 0.10.
BACKGROUND_RATIO = 1.0 / 3.0
BACKGROUND_U0 = 0.10


class ZoneLimits(NamedTuple):
    """CIE 150:2017 Table 2 limits of one environmental zone: vertical illuminance on
    properties Ev (lx) and luminous intensity toward sensitive directions I (cd), before and
    after curfew; upward light ratio ULR (fraction); average building facade luminance Lb
    (cd/m², before curfew; after curfew facades are to be unlit by the guide's text)."""

    ev_pre: float
    ev_post: float
    i_pre: float
    i_post: float
    ulr: float
    lb: float


#: CIE 150:2017, Table 2 (E1 after curfew: 0 lx; 1 lx where it is public road lighting). The
#: ULR column is the 2017 edition's (0, 0, 2.5 %, 5 %, 15 %); the 2003 edition's, which
#: EN 12193:2008 repeats, is :data:`CIE150_2003_ULR` (give ``ulr_max`` to judge by it).
CIE150 = {
    "E0": ZoneLimits(0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    "E1": ZoneLimits(2.0, 0.0, 2500.0, 0.0, 0.0, 0.0),
    "E2": ZoneLimits(5.0, 1.0, 7500.0, 500.0, 0.025, 5.0),
    "E3": ZoneLimits(10.0, 2.0, 10000.0, 1000.0, 0.05, 10.0),
    "E4": ZoneLimits(25.0, 5.0, 25000.0, 2500.0, 0.15, 25.0),
}
#: CIE 150:2003 Table 2's ULR (E1–E4; E0 did not exist), also EN 12193:2008 Table 5.
CIE150_2003_ULR = {"E1": 0.0, "E2": 0.05, "E3": 0.15, "E4": 0.25}


class RoadClass(NamedTuple):
    """One EN 13201-2:2015 lighting class of the illuminance method: the least maintained
    average horizontal illuminance Ē (lx) and, per family, the least overall uniformity U0
    (C classes) or the least point illuminance Emin (lx, P classes); None: not required."""

    em_lux: float
    u0: float | None
    emin_lux: float | None
    title: str


#: EN 13201-2:2015 Table 3 (C classes, conflict areas) and Table 4 (P classes, pedestrian and
#: low-speed areas). M classes (luminance, r-tables) and the HS, SC and EV classes are not here.
EN13201_2 = {
    **{f"C{i}": RoadClass(e, 0.40, None, "conflict area") for i, e in enumerate(
        (50.0, 30.0, 20.0, 15.0, 10.0, 7.5))},
    **{f"P{i + 1}": RoadClass(e, None, m, "pedestrian and low-speed area") for i, (e, m) in
       enumerate(((15.0, 3.0), (10.0, 2.0), (7.5, 1.5), (5.0, 1.0), (3.0, 0.6), (2.0, 0.4)))},
}
#: EN 13201-2:2015 Table 4, note: to keep the light even, a P class's actual Ē should not
#: exceed 1.5 × the class's Ē.
P_CLASS_MAX_RATIO = 1.5
