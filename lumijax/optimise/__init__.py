"""Fit dimmers, aims and levels to the light a designer asks for (docs/optimise.md)."""

from ._calibrate import Calibration as Calibration, calibrate as calibrate
from ._models import AimLight as AimLight, DimmerLight as DimmerLight
from ._objective import Objective as Objective
from ._optimise import Optimisation as Optimisation, optimise as optimise
from ._sensitivity import (
    Sensitivity as Sensitivity,
    sensitivity as sensitivity,
    what_moves_the_needle as what_moves_the_needle,
)
from ._solvers import SOLVERS as SOLVERS, minimise as minimise
from ._targets import GridGoal as GridGoal, grid_goals as grid_goals

__all__ = ["optimise", "Optimisation", "Objective", "DimmerLight", "AimLight", "minimise",
           "SOLVERS", "GridGoal", "grid_goals",
           "sensitivity", "Sensitivity", "what_moves_the_needle", "calibrate", "Calibration"]
