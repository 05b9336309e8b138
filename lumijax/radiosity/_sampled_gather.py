"""The sampled transport's final gather: each patch's inter-reflected light cast once more, with
more rays than the operator holds, and never stored (``[solver] final_gather_rays``).

A sampled operator's error per patch is its own noise, ≈ 1/√N of N rays a patch, and its
memory and its solve's time grow like N: at the courtyard's level of detail 3 (10⁶ patches,
288 columns) the 740 rays that fit in 16 GiB leave 3.9 % per patch (docs/radiosity.md, "Own
noise"). But the solved radiosity B is far less noisy than any one patch's row of F — a
patch's irradiance ``(F B)_i`` averages the errors of the hundreds of patches its rays meet —
so one more product with an independent, finer sample ``F_g`` of N_g rays a patch,

    H = E + F_g (c B),     B_final = ρ H + τ H[partner],

carries the noise of N_g rays (plus the gathered noise of B, far smaller), as a final gather
does in Monte Carlo radiosity (Bekaert's "final gathering"). The rows of ``F_g`` are cast patch
batch by patch batch (:func:`~._sampled.sample_batch`, a seed of their own), multiplied into
all columns of ``c B`` at once and dropped: O(batch) memory whatever N_g, and its rays cost
what a build of N_g rays costs, without the solve over N_g rays' links. ``c`` is the solve's
outgoing-light correction (``_solve.row_correction``: rows of a closed room back to 1), so a
uniformly lit closed room stays exact.

Measured against the block operator (docs/radiosity.md, "Final gather of the sampled
transport"): in the furnished room of tests/radiosity/test_sampled.py, a quarter of the rays
aimed, a 64-ray operator gathered with 1,024 rays reads 1.64 % RMS per patch, a 1,024-ray
operator 1.57 % (the 64-ray operator alone 3.25 %); on the courtyard quarter a 256-ray operator
gathered with 4,096 rays 3.33 % (2.10 % on the open patches), a 4,096-ray operator 3.41 %
(2.08 %). At the courtyard's LoD 3 (10⁶ patches) the 256-ray operator and 1,856 gathered rays a
patch read 2.29 % per patch in 1,296 s and 12.2 GiB.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from jaxtyping import Float

from ._bright import BrightPatches
from ._patches import Patches
from ._sampled import SampledSettings, front_normals, sample_batch

__all__ = ["SampledGather", "gather_sampled"]


@dataclass(frozen=True, eq=False)
class SampledGather:
    """A final gather's rows, as a lighting solution keeps them so that a re-shot luminaire
    (``replace_luminaire``) is gathered through the very same rows: the settings (rays a
    patch, a seed of their own) and where the aimed rays aim (None: cosine rays only)."""

    settings: SampledSettings
    bright: BrightPatches | None = None

    @classmethod
    def of(cls, operator: SampledSettings, rays: int,
           bright: BrightPatches | None = None) -> SampledGather:
        """The final gather of ``rays`` rays a patch for an operator built with ``operator``:
        its seed + 2 (the operator has the seed, its noise estimate seed + 1: independent
        samples), and batches of as many rays as the operator's (fewer patches a batch), so
        that a batch's arrays stay the size a build's are whatever the rays: 2048 patches of
        16,384 rays held 8.1 GiB on the courtyard quarter."""
        rays = int(rays)
        batch = max(16, operator.batch * operator.rays_per_patch // max(rays, 1))
        return cls(dataclasses.replace(operator, rays_per_patch=rays, seed=operator.seed + 2,
                                       batch=min(batch, operator.batch)), bright)

    @property
    def rays_per_patch(self) -> int:
        return int(self.settings.rays_per_patch)

    def __call__(self, patches: Patches, caster, y, *, outgoing=None, progress=None):
        """:func:`gather_sampled` of ``y`` through these rows."""
        return gather_sampled(patches, caster, self.settings, y, bright=self.bright,
                              outgoing=outgoing, progress=progress)


def gather_sampled(
    patches: Patches,
    caster,
    settings: SampledSettings,
    y: Float[np.ndarray, "patches columns"],
    *,
    bright: BrightPatches | None = None,
    outgoing: Float[np.ndarray, " patches"] | None = None,
    triangles: Float[np.ndarray, "tri 3 3"] | None = None,
    threads: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[Float[np.ndarray, "patches columns"], dict]:
    """``F_g y``: each patch's irradiance from the exitance ``y`` (lm/m², one row a patch, any
    columns) through a sampled F of ``settings.rays_per_patch`` rays a patch, cast batch by
    batch and never stored (module docstring).

    Parameters
    ----------
    patches, caster
        The patches (``mesh_patches``) and a ray caster of the scene's triangles.
    settings
        The rays a patch, their seed (another than the operator's: the gather must be an
        independent sample) and the aimed share.
    y
        ``(P, C)`` exitance, lm/m² (float32 or float64; read, never copied).
    bright
        Where the direct light lies (``bright_patches``), as for ``build_sampled``.
    outgoing
        ``(P,)`` factor on each sender's exitance: the solve's row correction ``c`` (module
        docstring; None: 1), applied to the links rather than to a copy of ``y``.
    triangles
        The scene's triangles where the caster does not hold them.
    threads
        Batches traced at once (default: every CPU this process may use).
    progress
        Called with (patches done, patches) after every batch.

    Returns
    -------
    ``(P, C)`` float32 irradiance, lx, and counts: ``rays`` cast, ``links`` met, ``seconds``.
    """
    import scipy.sparse as sp

    from ..parallel import threaded_map
    from ._gather import _locator
    from ._sampled import PatchLocator

    t0 = time.perf_counter()
    n = patches.n
    y = np.asarray(y)
    if y.ndim != 2 or y.shape[0] != n:
        raise ValueError(f"y must be (patches, columns) with {n} rows, got shape {y.shape}")
    out = np.zeros(y.shape, np.float32)
    if n == 0:
        return out, dict(rays=0, links=0, seconds=0.0)
    locator = _locator(patches, caster)
    if locator is None:
        locator = PatchLocator(patches, np.asarray(
            caster.triangles if triangles is None else triangles, np.float64))
    front = front_normals(patches, caster, locator)
    area = np.asarray(patches.area, np.float64)
    c = None if outgoing is None else np.asarray(outgoing, np.float64).reshape(n)
    spans = [(a, min(a + settings.batch, n)) for a in range(0, n, settings.batch)]

    def one(span):
        a, z = span
        r, s, w, counts = sample_batch(patches, caster, a, z, settings, locator, front, bright)
        w = np.asarray(w, np.float64) / area[r] * (1.0 if c is None else c[s])
        rows = sp.csr_matrix((w, (r - a, s)), shape=(z - a, n))
        out[a:z] = rows @ y  # each batch its own rows: the threads never write one row twice
        return int(counts["rays"]), len(r)

    rays = links = 0
    for (_, z), (k, m) in zip(spans, threaded_map(one, spans, threads), strict=True):
        rays, links = rays + k, links + m
        if progress is not None:
            progress(z, n)
    return out, dict(rays=rays, links=links, seconds=time.perf_counter() - t0)
