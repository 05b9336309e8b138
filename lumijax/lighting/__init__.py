"""The lighting pipeline: runs the stages (direct light, radiosity, gather) of a study, per network,
and holds their :class:`LightingSolution` (see ``docs/architecture.md``)."""

from ._pipeline import (
    SolverSettings as SolverSettings,
    auto_patch_size as auto_patch_size,
    solve_lighting as solve_lighting,
)
from ._settings import GATHER_RAYS as GATHER_RAYS, gather_rays_for as gather_rays_for
from ._solution import LightingSolution as LightingSolution
