"""Direct and inter-reflected light of a study, per network (see ``docs/radiosity.md``)."""

from ._gather import GatherOperator as GatherOperator, build_gather as build_gather
from ._solution import LightingSolution as LightingSolution
from ._solve import (
    SolverSettings as SolverSettings,
    auto_patch_size as auto_patch_size,
    solve_lighting as solve_lighting,
)
