"""Meshing into radiosity patches and admissible block partitioning (see ``docs/radiosity.md``)."""

from ._partition import (
    Partition as Partition,
    PartitionSettings as PartitionSettings,
    partition as partition,
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
