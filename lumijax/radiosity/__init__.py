"""The radiosity wing: patches, partition, transport operator, its cache, the solve and the gather.

Data flow inside the wing (see ``docs/radiosity.md`` and ``docs/architecture.md``)::

    triangles ─ mesh_patches ─▶ Patches ─ partition ─▶ Partition ─ build_operator ─▶ TransportOperator
        (cached by cached_operator)                                                     │
        (or build_sampled: rays from every patch, [solver] transport = "sampled")     │
    B₀ (direct light per patch) ───────────────────── solve_radiosity ◀────────────────┘
                                                            │
    grids ─ build_gather ─▶ GatherOperator ◀── B (radiosity per patch) ─▶ illuminance on grids
"""

from ._bright import BrightPatches as BrightPatches, bright_patches as bright_patches
from ._build import FormFactorSettings as FormFactorSettings, build_operator as build_operator
from ._cache import (
    cache_path as cache_path,
    cached_operator as cached_operator,
    cached_sampled_operator as cached_sampled_operator,
    operator_key as operator_key,
)
from ._exact_gather import (
    EXACT_GATHER_PAIRS as EXACT_GATHER_PAIRS,
    build_exact_gather as build_exact_gather,
)
from ._gather import GatherOperator as GatherOperator, build_gather as build_gather
from ._noise import SampledNoise as SampledNoise, sampled_noise as sampled_noise
from ._operator import (
    Bucket as Bucket,
    LowRankBucket as LowRankBucket,
    ReflectionOperator as ReflectionOperator,
    SampledBucket as SampledBucket,
    TransportOperator as TransportOperator,
)
from ._partition import (
    Partition as Partition,
    PartitionSettings as PartitionSettings,
    partition as partition,
)
from ._patch_samples import (
    NearSamples as NearSamples,
    near_light as near_light,
    near_samples as near_samples,
)
from ._patches import (
    Patches as Patches,
    mesh_patches as mesh_patches,
    subdivide_triangles as subdivide_triangles,
)
from ._refine import (
    Refinement as Refinement,
    edge_neighbours as edge_neighbours,
    refine_patches as refine_patches,
)
from ._sampled import (
    PatchLocator as PatchLocator,
    SampledSettings as SampledSettings,
    build_sampled as build_sampled,
    sample_batch as sample_batch,
)
from ._sampled_gather import SampledGather as SampledGather, gather_sampled as gather_sampled
from ._slopes import PatchSlopes as PatchSlopes, patch_slopes as patch_slopes
from ._solve import (
    CLOSED_TOL as CLOSED_TOL,
    RadiositySolution as RadiositySolution,
    check_reflectance as check_reflectance,
    escaped_fraction as escaped_fraction,
    row_correction as row_correction,
    solve_radiosity as solve_radiosity,
)
from ._solvers import (
    DEFAULT_RADIOSITY_SOLVER as DEFAULT_RADIOSITY_SOLVER,
    GMRES as GMRES,
    RADIOSITY_SOLVERS as RADIOSITY_SOLVERS,
    AbstractKrylovSolver as AbstractKrylovSolver,
    AbstractRadiositySolver as AbstractRadiositySolver,
    BiCGStab as BiCGStab,
    Jacobi as Jacobi,
    Refined as Refined,
    Southwell as Southwell,
    radiosity_solver as radiosity_solver,
)
from ._store import (
    FORMAT as FORMAT,
    OperatorFileError as OperatorFileError,
    read_operator as load_operator,
    write_operator as save_operator,
)
from ._transmission import back_partners as back_partners
