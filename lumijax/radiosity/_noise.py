"""The sampled transport's own noise per patch, estimated by casting a sample of its rows again.

At the default 256 rays a patch, a sampled operator's error per patch is mostly its own noise
(the courtyard quarter: 6.5 % RMS of the inter-reflected light per patch, the furnished room
with aimed rays 1.5 %; docs/radiosity.md, "Sampled transport"), and how large it is depends on
the scene: on how much the radiosity a patch sees varies within one stratum of its rays. The
operator alone cannot tell. Casting some of its rows again with another seed can: two
independent estimates of one row differ by √2 times the noise of either, so

    noise = RMS_i (x_i − x'_i) / √2  /  RMS_i x_i,     x = F B,  x' = F' B,

over ``sample`` patches (area-weighted, as benchmarks/hierarchy.py and docs/radiosity.md
define the RMS per patch), B the solved radiosity, F' the same rows cast with seed + 1. The
patches are taken in ``runs`` runs spread along the mesh: consecutive patches lie on one
triangle, and a sample from one corner of a scene says little about the rest. The figure is
itself a sample: ≈ 1/√(2 · sample) relative for independent patches, more where neighbours
share their light's texture (the runs); tests/radiosity/test_noise.py checks it against both
whole operators' difference.

With a final gather (``_sampled_gather``) the rows that give each patch its light are the
gather's, not the operator's: ``x`` and ``x'`` are then both cast with the gather's settings
(its seed, and seed + 1), and the figure is the gather's noise.

It is the noise of one product F B with B fixed — what a patch's inter-reflected irradiance
(``patches.vtp``, the surface maps) carries. B itself carries ρ times it, and a grid point
gathers from hundreds of patches, so the points' noise is far smaller. Given the gather and
the patches' reflectance, the points' is estimated to first order: each patch's noise taken
independent (its rays are its own) and proportional to its light, σ_j = noise · (F B)_j, so a
point's inter-reflected illuminance E_p = Σ_j g_pj B_j carries

    σ_p² = Σ_j g_pj² (ρ_j σ_j)²,     points noise = RMS_p σ_p / RMS_p E_p

(the light passed on by further bounces is averaged over many patches again, and left out).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from ._gather import GatherOperator
from ._operator import TransportOperator
from ._patches import Patches
from ._sampled import SampledSettings, front_normals, sample_batch

__all__ = ["SampledNoise", "sampled_noise"]


@dataclass(frozen=True)
class SampledNoise:
    """The own noise of a sampled operator's rows (module docstring).

    Attributes
    ----------
    rms
        RMS per patch of one estimate's noise of the inter-reflected irradiance, relative to
        the field's RMS over the sample (0.065: 6.5 %).
    mean
        Area-weighted mean of ``x − x'`` relative to the mean of ``x``: the sample's own
        imbalance (near 0; the estimator is unbiased).
    patches
        Patches in the sample.
    rays_per_patch
        Rays a patch of the operator (and of the sample).
    seconds
        Wall time of the estimate (s).
    points_rms
        The calculation points' noise of their inter-reflected illuminance, RMS over the
        points relative to the field's (first order: module docstring); None without a gather.
    """

    rms: float
    mean: float
    patches: int
    rays_per_patch: int
    seconds: float
    points_rms: float | None = None


def sampled_noise(
    operator: TransportOperator,
    patches: Patches,
    settings: SampledSettings,
    radiosity: Float[np.ndarray, " patches"],
    *,
    caster,
    triangles: Float[np.ndarray, "tri 3 3"] | None = None,
    bright=None,
    gather: GatherOperator | None = None,
    rho: Float[np.ndarray, " patches"] | None = None,
    sample: int = 4096,
    runs: int = 64,
    final: SampledSettings | None = None,
) -> SampledNoise:
    """The own noise per patch of ``operator`` (built by :func:`~lumijax.radiosity.
    build_sampled` from ``patches`` with ``settings`` and ``bright``) for the radiosity
    ``radiosity`` (lm/m², luminous, one value a patch): module docstring.

    ``caster`` traces the rays (the one the operator was built on, or one of the same
    triangles); ``triangles``: the scene's triangles when the caster does not hold them.
    ``sample`` patches (all where fewer) in ``runs`` runs; the same arguments give the same
    figure. With ``gather`` (the patches → points :class:`~lumijax.radiosity.GatherOperator`)
    and ``rho`` (each patch's reflectance, luminous) the points' noise too. With ``final``
    (the settings of a final gather's rows, ``_sampled_gather``) the noise of the light that
    gather gives each patch: the sample's rows cast with those settings, and again with their
    seed + 1."""
    from ._gather import _locator
    from ._sampled import PatchLocator
    from ._solve import row_correction

    t0 = time.perf_counter()
    n = patches.n
    m = min(sample, n)
    rows_of = settings if final is None else final
    if m == 0:
        return SampledNoise(0.0, 0.0, 0, rows_of.rays_per_patch, 0.0)
    length = max(1, m // max(1, min(runs, m)))
    starts = np.unique(np.linspace(0, n - length, max(1, m // length)).round().astype(int))
    spans = [(int(a), int(a) + length) for a in starts]
    # one compiled ray kernel for runs of this length, and an independent sample of each row
    again = dataclasses.replace(rows_of, seed=rows_of.seed + 1, batch=length)
    locator = _locator(patches, caster)
    if locator is None:
        locator = PatchLocator(patches, np.asarray(
            caster.triangles if triangles is None else triangles, np.float64))
    front = front_normals(patches, caster, locator)
    # the solve's outgoing-light correction (F_ij → F_ij c_j), as the reported irradiance has it
    c, _ = row_correction(operator.row_sums())
    b = np.asarray(radiosity, np.float64).reshape(n) * np.asarray(c, np.float64)
    x = np.asarray(operator.matmul(jnp.asarray(b[:, None], operator.area.dtype)),
                   np.float64)[:, 0]
    area = np.asarray(patches.area, np.float64)
    rows = np.concatenate([np.arange(a, z) for a, z in spans])

    def cast(s_):  # the sample's rows of another sample of F, times b (lx · m²)
        out = np.zeros(n)
        for a, z in spans:
            r, s, w, _ = sample_batch(patches, caster, a, z, s_, locator, front, bright)
            out += np.bincount(r, weights=np.asarray(w, np.float64) * b[s], minlength=n)
        return out

    again_x = cast(again)[rows] / area[rows]
    if final is None:
        xs = x[rows]
    else:  # the gather's rows (its settings, the sample's batch length), not the operator's
        xs = cast(dataclasses.replace(final, batch=length))[rows] / area[rows]
    area = area[rows]
    field = np.sum(area * xs**2)
    if field <= 0:  # nothing lit reaches the sample
        return SampledNoise(0.0, 0.0, len(rows), rows_of.rays_per_patch,
                            time.perf_counter() - t0)
    rms = float(np.sqrt(np.sum(area * (xs - again_x) ** 2) / 2.0 / field))
    mean = float(np.sum(area * (xs - again_x)) / np.sum(area * xs))
    points = None
    if gather is not None and rho is not None and gather.n_patches == n:
        points = _points_noise(gather, np.asarray(radiosity, np.float64).reshape(n),
                               rms * np.asarray(rho, np.float64) * x)
    return SampledNoise(rms, mean, len(rows), rows_of.rays_per_patch, time.perf_counter() - t0,
                        points)


def _points_noise(gather: GatherOperator, b, sigma_b) -> float | None:
    """RMS over the points of ``√(Σ_j g_pj² σ_j²)`` relative to the RMS of ``Σ_j g_pj b_j``
    (``sigma_b``: each patch's radiosity noise, independent between patches)."""
    w = np.asarray(gather.weight, np.float64)
    e = np.bincount(gather.point, weights=w * b[gather.patch], minlength=gather.n_points)
    var = np.bincount(gather.point, weights=(w * sigma_b[gather.patch]) ** 2,
                      minlength=gather.n_points)
    field = np.sqrt(np.mean(e**2)) if len(e) else 0.0
    return float(np.sqrt(np.mean(var)) / field) if field > 0 else None
