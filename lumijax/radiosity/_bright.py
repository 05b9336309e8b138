"""Rays aimed at bright patches: the sampled transport's second strategy.

With cosine-weighted rays alone (``_sampled.py``) a patch finds the pool of light under a
downlight only as often as the pool fills its hemisphere, so the first bounce of a peaky direct
field is noisy: 30 % RMS per patch at 256 rays in the furnished test room, 16 % after all
bounces (docs/radiosity.md, "Noise, measured"). Each patch therefore aims a share of its rays at
points drawn on the patches that carry the study's direct light (probability ∝ each patch's
share of its emission group's flux, the groups weighing alike), and both kinds of sample are
combined by the balance heuristic of multiple importance sampling (Veach & Guibas 1995): a
sample that reaches patch j at distance d from patch i weighs

    w = p_c / (n_c p_c + n_a p_a),   p_c = cos θ_i cos θ_j / (π d²),   p_a = P_j / A_j,

whichever strategy drew it (p_c and p_a are the two densities of the point on j, per m²; n_c
and n_a the rays of each kind), and ``F_ij ≈ Σ w`` over the samples reaching j. Every sample's
weight is a fixed number, so the operator stays linear and fixed: it estimates F without bias
for *any* radiosity, dimmers and aims included, only its noise depends on how well the
proposal fits the light (a stale one after an aim changes is still unbiased). The cosine rays
cover every direction, so a dark patch is reached as before (weight 1/n_c where p_a = 0).

The proposal is a function of the direct light, so the operator's cache key holds it
(:attr:`BrightPatches.key`): moving a luminaire builds a new operator; a dimmer does not.

References: E. Veach, L. J. Guibas, "Optimally combining sampling techniques for Monte Carlo
rendering", SIGGRAPH 1995; P. Bekaert, "Hierarchical and stochastic algorithms for radiosity",
PhD thesis, KU Leuven, 1999 (ch. 5: stochastic Jacobi with importance).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np
from jaxtyping import Float, Int

from ..errors import SolveError
from ._patches import Patches

__all__ = ["BrightPatches", "bright_patches", "aimed_rays", "balance_weight", "aimed_samples"]


@dataclass(frozen=True, eq=False)
class BrightPatches:
    """Each patch's probability of being aimed at (``(P,)``, sums to 1), its cumulative sum and
    its density ``p_a = P_j / A_j`` (m⁻²); ``key`` names it in the operator's cache key (the
    float32 probabilities' SHA-256, so last-bit differences of the direct light between runs
    do not miss the cache)."""

    probability: Float[np.ndarray, " patches"]
    cdf: Float[np.ndarray, " patches"] = field(repr=False)
    density: Float[np.ndarray, " patches"] = field(repr=False)
    key: str


def bright_patches(flux: Float[np.ndarray, "groups patches"] | Float[np.ndarray, " patches"],
                   patches: Patches) -> BrightPatches | None:
    """The proposal of the aimed rays from each emission group's direct flux on each patch.

    Parameters
    ----------
    flux
        ``(groups, P)`` or ``(P,)``: direct light per patch, lm (irradiance × area; any common
        scale per group: each group is normalised to 1, then the groups are averaged, so a dim
        network's pools are aimed at as often as a bright one's).
    patches
        The patches the operator is built on.

    Returns None when no patch receives light (the cosine rays alone then). Raises
    :class:`~lumijax.errors.SolveError` for a shape other than ``(…, P)`` or a negative or
    non-finite entry.
    """
    f = np.asarray(flux, np.float64)
    f = f[None] if f.ndim == 1 else f
    if f.ndim != 2 or f.shape[1] != patches.n:
        raise SolveError(f"the bright patches' flux must be (groups, {patches.n}) or "
                         f"({patches.n},) — one entry a patch — not {np.shape(flux)}")
    if not np.all(np.isfinite(f)) or np.any(f < 0):
        raise SolveError("the bright patches' flux must be finite and ≥ 0 (lm); found "
                         f"{int(np.sum(~np.isfinite(f) | (f < 0)))} entries that are not")
    total = f.sum(axis=1)
    lit = total > 0
    if not np.any(lit):
        return None
    p = (f[lit] / total[lit, None]).mean(axis=0).astype(np.float32).astype(np.float64)
    p /= p.sum()
    key = hashlib.sha256(p.astype(np.float32).tobytes()).hexdigest()
    return BrightPatches(p, np.cumsum(p), p / patches.area, key)


def aimed_rays(rays_per_patch: int, share: float, bright: BrightPatches | None) -> int:
    """How many of a patch's rays are aimed at bright patches (0 without a proposal); at least
    one ray is left cosine-weighted, so every direction stays covered."""
    if bright is None:
        return 0
    return min(int(round(share * rays_per_patch)), rays_per_patch - 1)


def balance_weight(cos_i, cos_j, dist, n_cos: int, n_aim: int, aim_density):
    """A sample's weight ``p_c / (n_c p_c + n_a p_a)`` (module docstring): ``aim_density``
    is ``p_a = P_j / A_j`` (m⁻²) of the patch reached; 1/n_c where it is 0.

    Taken as ``c / (n_c c + n_a p_a π d²)``, ``c = cos θ_i cos θ_j``: a cosine ray meeting a
    surface at distance 0 (a ray leaving a patch at a contact line; Embree's float32) has
    ``p_c = ∞`` and weighs 1/n_c, not NaN."""
    c = cos_i * cos_j
    den = n_cos * c + n_aim * aim_density * (np.pi * dist * dist)
    return np.where(den > 0, c / np.where(den > 0, den, 1.0), 1.0 / n_cos)


def aimed_samples(
    patches: Patches,
    start: int,
    stop: int,
    n_aim: int,
    bright: BrightPatches,
    rng: np.random.Generator,
    lift: float,
) -> tuple[Int[np.ndarray, " k"], Int[np.ndarray, " k"], Float[np.ndarray, "k 3"],
           Float[np.ndarray, "k 3"], Float[np.ndarray, " k"], Float[np.ndarray, " k"],
           Float[np.ndarray, " k"]]:
    """The aimed rays of patches ``start..stop`` that face both ways.

    Each receiver draws ``n_aim`` patches stratified over the proposal's cumulative sum (one
    uniform shift for all its strata: each pick is uniform in its stratum), a uniform point on
    each and a uniform start on itself, lifted ``lift`` (m) along its normal.
    Returns ``(receiver, sender, start, direction, distance, cos_i, cos_j)`` (float64, m) of the
    rays whose both ends face each other (the others carry nothing under either strategy)."""
    m = stop - start
    # systematic picks: one shift a receiver for all its strata, each pick uniform in its own.
    # Taken with the receivers in the order of their shifts, every query exceeds the last, so
    # the binary searches stay in the cache (3× faster at 3·10⁵ patches)
    shift = rng.random(m)
    order = np.argsort(shift)
    q = (np.arange(n_aim)[:, None] + shift[order]) * (bright.cdf[-1] / n_aim)
    src = np.empty((m, n_aim), np.int64)
    src[order] = np.searchsorted(bright.cdf, q.ravel(), side="right").reshape(n_aim, m).T
    src = np.minimum(src, patches.n - 1).ravel()
    u = rng.random((4, m, n_aim))  # the start on the receiver, the point on the sender
    # the starts by broadcasting the batch's own triangles (no gather a sample)
    v = patches.vertices[start:stop, None]  # (m, 1, 3, 3)
    n_i = patches.normal[start:stop, None]
    x = _uniform_on(v, u[0:2]) + lift * n_i
    y = _uniform_on(patches.vertices[src].reshape(m, n_aim, 3, 3), u[2:4])
    d = y - x
    dist = np.sqrt(np.einsum("...k,...k->...", d, d))
    d /= np.where(dist > 0, dist, 1.0)[..., None]
    cos_i = np.einsum("...k,...k->...", d, n_i)
    cos_j = -np.einsum("...k,...k->...", d, patches.normal[src].reshape(m, n_aim, 3))
    ok = ((cos_i > 1e-9) & (cos_j > 1e-9) & (dist > 0)).ravel()
    keep = np.flatnonzero(ok)
    return (start + keep // n_aim, src[keep], x.reshape(-1, 3)[keep], d.reshape(-1, 3)[keep],
            dist.ravel()[keep], cos_i.ravel()[keep], cos_j.ravel()[keep])


def _uniform_on(tri: Float[np.ndarray, "... 3 3"], u: Float[np.ndarray, "2 ..."]):
    """Points uniform in area on triangles (broadcast against ``u``'s trailing shape), from
    uniform ``u`` in the unit square: ``v0 + √u₀ ((1 − u₁)(v1 − v0) + u₁ (v2 − v0))``."""
    s, t = np.sqrt(u[0])[..., None], u[1][..., None]
    v0 = tri[..., 0, :]
    return v0 + s * ((1 - t) * (tri[..., 1, :] - v0) + t * (tri[..., 2, :] - v0))
