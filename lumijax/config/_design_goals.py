"""``[optimise]`` keys of a constrained design (docs/optimise.md, "Design to a standard"):
the objective, the constrained method and the hard constraints beyond the grids' own limits.

Kept apart from ``_schema.py`` so that the design goals grow here; ``OptimiseConfig`` refers to
them. The models repeat ``_schema._Model``'s settings (unknown keys refused, frozen) rather than
import it, so that ``_schema`` can import this module at its top.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

__all__ = ["ConstraintConfig", "DesignObjective", "ConstrainedMethod", "CRITERIA",
           "CRITERION_SENSE", "GLARE_CRITERIA"]

#: ``objective`` of a constrained design: the installed power in use (W, Σ dimmer × power_w),
#: the annual energy LENI of EN 15193-1 (kWh/(m²·a), from ``[compliance.energy]``'s hours and
#: factors and its power model: input watts, standby, dimming curves) or the target-map misfit
#: of the grids with a ``target_csv``.
DesignObjective = Literal["power", "leni", "misfit"]
#: ``method``: scipy's SLSQP or trust-constr, fed by JAX gradients and Jacobians, or the
#: augmented Lagrangian with L-BFGS-B inner solves fed one reverse pass a step (thousands of
#: aims), or GCMMA (moving asymptotes: one margins-and-Jacobian evaluation a step, few steps);
#: ``"auto"`` picks by the number of free variables (``optimise._augmented``).
ConstrainedMethod = Literal["auto", "slsqp", "trust-constr", "augmented_lagrangian", "mma"]

#: What a ``[[optimise.constraints]]`` entry may bound. Per grid: ``avg``, ``min``, ``max``
#: (lx), ``u0`` (Emin/Eavg), ``luminance`` (ρ·Emax/π, cd/m², needs the grid's reflectance),
#: ``misfit`` (RMS of E − target map over the map's mean); study-wide (no ``grid``): ``power``
#: (W) and ``patch_luminance`` (cd/m², brightest radiosity patch); per observer (``observer``,
#: every observer when omitted), from ``lumijax.glare``: ``ugr``, ``gr`` (dimensionless) and
#: ``ti`` (%), each the observer's worst over its directions; ``surface_luminance`` (cd/m²,
#: ``surface``: a geometry name), the largest luminance of that surface the observer sees.
CRITERIA = ("avg", "min", "max", "u0", "luminance", "misfit", "power", "patch_luminance",
            "ugr", "gr", "ti", "surface_luminance")
Criterion = Literal["avg", "min", "max", "u0", "luminance", "misfit", "power",
                    "patch_luminance", "ugr", "gr", "ti", "surface_luminance"]
#: Which bounds each criterion takes: "min" (a floor), "max" (a ceiling) or both.
CRITERION_SENSE = {"avg": ("min", "max"), "min": ("min",), "max": ("max",), "u0": ("min",),
                   "luminance": ("max",), "misfit": ("max",), "power": ("max",),
                   "patch_luminance": ("max",), "ugr": ("max",), "gr": ("max",),
                   "ti": ("max",), "surface_luminance": ("max",)}
_STUDY_WIDE = ("power", "patch_luminance")
#: The criteria of an observer (``lumijax.glare``): no grid, an optional ``observer``.
GLARE_CRITERIA = ("ugr", "gr", "ti")


def _finite(v):
    if v is not None and not math.isfinite(v):
        raise ValueError("must be a finite number")
    return v


class ConstraintConfig(BaseModel):
    """``[[optimise.constraints]]``: one hard constraint ``min ≤ criterion ≤ max``."""

    model_config = ConfigDict(extra="forbid", frozen=True, str_strip_whitespace=True)

    criterion: Criterion
    grid: Annotated[str, Field(min_length=1)] | None = None
    observer: Annotated[str, Field(min_length=1)] | None = None
    surface: Annotated[str, Field(min_length=1)] | None = None
    min: Annotated[float, Field(ge=0, le=1e10)] | None = None
    max: Annotated[float, Field(gt=0, le=1e10)] | None = None

    @field_validator("min", "max")
    @classmethod
    def _is_finite(cls, v):
        return _finite(v)

    @model_validator(mode="after")
    def _consistent(self):
        if self.min is None and self.max is None:
            raise ValueError(f"a constraint on {self.criterion!r} needs 'min' or 'max'")
        allowed = CRITERION_SENSE[self.criterion]
        for side in ("min", "max"):
            if getattr(self, side) is not None and side not in allowed:
                raise ValueError(f"criterion {self.criterion!r} takes only a "
                                 f"{' or '.join(repr(a) for a in allowed)} bound, not {side!r}")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"'min' ({self.min:g}) exceeds 'max' ({self.max:g}): no design "
                             "can meet both")
        if self.criterion == "u0" and self.min is not None and self.min > 1:
            raise ValueError(f"U0 = Emin/Eavg is at most 1, got min = {self.min:g}")
        if (self.surface is not None) != (self.criterion == "surface_luminance"):
            raise ValueError("'surface' (a geometry name) goes with criterion "
                             "'surface_luminance', and that criterion needs it")
        if self.criterion in GLARE_CRITERIA or self.criterion == "surface_luminance":
            if self.grid is not None:
                raise ValueError(f"{self.criterion!r} is an observer's rating: give "
                                 "'observer' (or none, for every observer), not 'grid'")
            return self
        if self.observer is not None:
            raise ValueError(f"'observer' is for the glare ratings (ugr, gr, ti), not "
                             f"{self.criterion!r}")
        wide = self.criterion in _STUDY_WIDE
        if wide and self.grid is not None:
            raise ValueError(f"{self.criterion!r} is study-wide: give no 'grid'")
        if not wide and self.grid is None:
            raise ValueError(f"a constraint on {self.criterion!r} needs the 'grid' it is on")
        return self
