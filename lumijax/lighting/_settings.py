"""The ``[solver]`` settings of a study's lighting, and the automatic patch size."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SolverSettings", "auto_patch_size"]


@dataclass(frozen=True)
class SolverSettings:
    """How inter-reflection is computed (the config's ``[solver]`` table, docs/config.md).

    ``patch_size`` None means automatic: about ``target_patches`` patches over the scene.
    """

    indirect: bool = True
    patch_size: float | None = None
    target_patches: int = 4_000
    max_block: int = 1024
    method: str = "refined"  # a name in lumijax.radiosity.RADIOSITY_SOLVERS
    tolerance: float | None = None
    max_iterations: int = 1000
    gather_rays: int = 512
    precision: str = "float32"
    spectral_samples: int = 16
    refine: int = 0  # most levels of adaptive refinement (docs/radiosity.md, "Refinement")
    refine_threshold: float = 0.5
    operator_patches: int | None = None  # two levels: elements for the operator (docs/radiosity.md)
    transport: str = "blocks"  # "sampled": ray-sampled form factors (radiosity/_sampled.py)
    rays_per_patch: int = 256  # rays cast from each patch by the sampled transport


def auto_patch_size(total_area_m2: float, target_patches: int) -> float:
    """Patch edge (m) giving about ``target_patches`` patches. A triangle of longest edge L is
    cut into ⌈L/s⌉² pieces; for the right triangles of rectangles and boxes (L² = 4 × area
    of the square they halve) that is 4·area/s² patches per unit area, hence s = √(4A/N).
    No floor in metres: a 4 mm model wants 0.1 mm patches as a 4 m room wants 0.1 m ones (a
    1 mm floor once gave a 4 µm model a single patch per face)."""
    return float(max(np.sqrt(4.0 * total_area_m2 / max(target_patches, 1)),
                     np.finfo(np.float64).tiny))
