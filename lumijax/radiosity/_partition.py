"""Admissible partitioning: spatial blocks of patches and which block pairs can exchange light.

Following Fasse & Paul (1995, §5.1), the patches are split into sub-domains (blocks) so that the
form-factor matrix has a block structure whose zero blocks are known *before* any form factor is
computed. A block never mixes user groups (a facade, a bay, a room stay apart) and is made by
recursive bisection of patch centroids, so it is spatially compact. A block pair is dropped when

1. **facing**: one block lies entirely behind every patch plane of the other (light leaves and
   arrives on front faces only). The test is exact against the axis-aligned box of the block's
   vertices, hence conservative and tighter than a normal-cone test; or
2. **occlusion**: at least ``min_facing`` (64) of ``samples`` (1,024) rays between random points
   of the two blocks face both ways, and all of those are blocked (the scene's walls between
   two rooms). A pair with fewer facing samples is kept: too few rays to decide.

Only the remaining (visible) pairs are ever computed.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import numpy as np
from jaxtyping import Float, Int

from ..errors import GeometryError
from ..kernels import length_tolerance
from ._patches import Patches

__all__ = ["Partition", "PartitionSettings", "partition"]


@dataclasses.dataclass(frozen=True)
class PartitionSettings:
    """The keyword arguments of :func:`partition` as one hashable value (part of a cache key)."""

    max_block: int = 1024
    samples: int = 1024
    min_facing: int = 64
    max_samples: int = 8192
    seed: int = 0


class Partition(eqx.Module):
    """Blocks of patches and the visible (unordered) block pairs.

    Attributes
    ----------
    members
        ``(P,)`` patch indices ordered block by block.
    offsets
        ``(B+1,)`` block ``b`` is ``members[offsets[b]:offsets[b+1]]``.
    block_group
        ``(B,)`` the user group of each block.
    pairs
        ``(N, 2)`` visible unordered block pairs ``(a, b)`` with ``a ≤ b``; a pair stands for
        light both ways (form factors are reciprocal).
    lo, hi
        ``(B, 3)`` bounding boxes of the blocks' vertices, m.
    stats
        Counts: candidate pairs, culled by facing, culled by occlusion, occlusion rays cast
        (all rounds).
    """

    members: Int[np.ndarray, " patches"]
    offsets: Int[np.ndarray, " blocks_plus_one"]
    block_group: Int[np.ndarray, " blocks"]
    pairs: Int[np.ndarray, "pairs 2"]
    lo: Float[np.ndarray, "blocks 3"]
    hi: Float[np.ndarray, "blocks 3"]
    stats: dict = eqx.field(static=True)

    @property
    def n_blocks(self) -> int:
        return int(len(self.offsets) - 1)

    @property
    def sizes(self) -> Int[np.ndarray, " blocks"]:
        return np.diff(self.offsets)

    def block(self, b: int | np.integer) -> Int[np.ndarray, " members"]:
        """Patch indices of block ``b``."""
        return self.members[self.offsets[b] : self.offsets[b + 1]]

    @property
    def block_of(self) -> Int[np.ndarray, " patches"]:
        """``(P,)`` the block of each patch."""
        out = np.empty(len(self.members), np.int64)
        out[self.members] = np.repeat(np.arange(self.n_blocks), self.sizes)
        return out


_TIE = 1e-7
"""Relative resolution of the bisection (of the set's extent): coordinates closer than this
are equal, and equal ones keep their index order."""


def bisection_order(p: np.ndarray) -> np.ndarray:
    """Order of points ``p`` (n, 3) along their longest bounding-box side, for a bisection.

    Translation- and scale-invariant, including ties: a square room's x and y sides are equal
    (the first is taken), and the centroids of a regular mesh share coordinates that rounding at
    site coordinates (10⁻⁹ m at 5·10⁶ m) would otherwise order at random. So sides within
    ``_TIE`` of the longest count as equal, and coordinates are compared at ``_TIE`` × the
    extent, equal ones in index order (a stable sort): the same blocks wherever the model sits.
    """
    if len(p) < 2:
        return np.arange(len(p))
    lo = p.min(0)
    ext = p.max(0) - lo
    longest = float(ext.max())
    if longest <= 0:
        return np.arange(len(p))
    axis = int(np.flatnonzero(ext >= longest * (1 - _TIE))[0])
    key = np.round((p[:, axis] - lo[axis]) / (_TIE * longest))
    return np.argsort(key, kind="stable")


def _bisect(points: np.ndarray, idx: np.ndarray, k: int, out: list) -> None:
    """Split ``idx`` into ``k`` spatially compact leaves of equal size (±1)."""
    if k <= 1:
        out.append(idx)
        return
    k1 = k // 2
    cut = int(round(len(idx) * k1 / k))
    order = bisection_order(points[idx])
    _bisect(points, idx[order[:cut]], k1, out)
    _bisect(points, idx[order[cut:]], k - k1, out)


def _facing_max(patches: Patches, members, offsets, lo, hi, chunk: int = 64) -> np.ndarray:
    """M[a, b] = max over patches j of block b of (support of box a along n_j) − n_j·x_j.

    Box a lies entirely behind every patch plane of block b exactly when M[a, b] ≤ 0.
    """
    nb = len(offsets) - 1
    n = patches.normal[members]
    # about the scene's centre: n·x of site coordinates (10⁷ m) would carry more rounding
    # than the tolerance this is compared with
    centre = 0.5 * (lo.min(0) + hi.max(0)) if nb else np.zeros(3)
    off = np.einsum("ij,ij->i", n, patches.centroid[members] - centre)
    c, h = 0.5 * (lo + hi) - centre, 0.5 * (hi - lo)
    out = np.empty((nb, nb))
    for s in range(0, nb, chunk):
        val = c[s : s + chunk] @ n.T + h[s : s + chunk] @ np.abs(n).T - off[None]
        out[s : s + chunk] = np.maximum.reduceat(val, offsets[:-1], axis=1)
    return out


def _random_points(vertices: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One uniform random point on each triangle."""
    u, v = rng.random((2, len(vertices)))
    flip = u + v > 1
    u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
    v0 = vertices[:, 0]
    return v0 + u[:, None] * (vertices[:, 1] - v0) + v[:, None] * (vertices[:, 2] - v0)


def partition(
    patches: Patches,
    max_block: int = 1024,
    *,
    occluders=None,
    samples: int = 1024,
    min_facing: int = 64,
    max_samples: int = 8192,
    seed: int = 0,
) -> Partition:
    """Partition patches into blocks and find the block pairs that can exchange light.

    Parameters
    ----------
    patches
        From :func:`mesh_patches`.
    max_block
        Largest block, in patches. Each group of n patches is cut into ceil(n / max_block) blocks
        of equal size, so blocks hold between about max_block/2 and max_block patches.
    occluders
        The scene's triangles ``(T, 3, 3)`` or a :class:`~lumijax.scene._raycast.RayCaster`; if
        given, block pairs with no unoccluded sample ray are dropped.
    samples
        Sample rays per block pair and round (random patch of each block, uniform point on it).
    min_facing
        A pair is only dropped for occlusion when at least this many of its samples faced each
        other (and all of those were blocked); fewer means the two blocks barely face and the
        rays say too little, so the pair is kept. The bound that matters is on the facing
        samples, not on ``samples``: a pair that sees a fraction v of its facing rays is dropped
        by mistake with probability (1 − v)^facing ≤ (1 − v)^min_facing (v = 5 %: 3.7 %), and
        with none seen of ≥ 64 facing, v < 4.7 % at 95 % confidence.

        Why 1,024 and 64 (until session 7: 256 and 8): a pair of blocks that mostly turn away
        from each other (a facade block against a block of reveals or column flanks) has only
        8–20 facing samples of 256, and partly visible pairs were dropped — on the courtyard
        quarter (docs/radiosity.md, "Accuracy on the courtyard") 113 of 406 pairs, 0.98 % of
        the receivers' first bounce against Radiance, one patch losing 85 % of it. 1,024 / 64
        loses 0.00 % there. But a fixed bound keeps dark pairs that barely face: blocks get
        smaller against the scene as it grows, and fewer of their samples face. So a pair
        with fewer than ``min_facing`` facing samples draws further rounds of ``samples`` rays
        until it has that many, has seen through, or has cast ``max_samples``; only then does
        too few facing keep it (facing fraction < min_facing / max_samples = 0.8 %). On the
        10-room benchmark scene (223,640 patches, closed rooms) this keeps 2,850 pairs, against
        3,095 at 256 / 8 and 3,611 at 1,024 / 64 without rounds, for 4.6× the old rays.
    max_samples
        Most sample rays for one pair (the top-up rounds above).
    seed
        Of the sample points (the partition is deterministic for a given seed).
    """
    if max_block < 1:
        raise GeometryError(f"max_block must be at least 1 patch, got {max_block}")
    leaves: list[np.ndarray] = []
    groups: list[int] = []
    for g in np.unique(patches.group):
        idx = np.flatnonzero(patches.group == g)
        k = -(-len(idx) // max_block)
        before = len(leaves)
        _bisect(patches.centroid, idx, k, leaves)
        groups += [int(g)] * (len(leaves) - before)
    leaves = [np.sort(x) for x in leaves]
    members = np.concatenate(leaves) if leaves else np.zeros(0, np.int64)
    offsets = np.concatenate([[0], np.cumsum([len(x) for x in leaves])]).astype(np.int64)
    nb = len(leaves)
    v = patches.vertices
    lo = np.array([v[x].reshape(-1, 3).min(0) for x in leaves]).reshape(nb, 3)
    hi = np.array([v[x].reshape(-1, 3).max(0) for x in leaves]).reshape(nb, 3)
    # relative to the scene (any unit) and above its coordinates' rounding (any site)
    tol = length_tolerance(np.concatenate([lo, hi]), 1e-9) if nb else 0.0

    facing = np.zeros((nb, nb), bool)
    if nb:
        m = _facing_max(patches, members, offsets, lo, hi)
        facing = (m > tol) & (m.T > tol)
    a, b = np.nonzero(np.triu(facing))
    n_candidates = nb * (nb + 1) // 2
    culled_facing = n_candidates - len(a)
    culled_occluded, rays = 0, 0
    if occluders is not None and len(a):
        from ..scene._raycast import RayCaster

        caster = occluders if isinstance(occluders, RayCaster) else RayCaster(occluders)
        # a convex room seen from inside blocks nothing (RayCaster.sees_everything): no rays
        if not caster.sees_everything:
            keep, rays = _occlusion_test(patches, members, offsets, a, b, caster, samples,
                                         min_facing, max(samples, max_samples), seed)
            culled_occluded = int((~keep).sum())
            a, b = a[keep], b[keep]
    pairs = np.stack([a, b], axis=1).astype(np.int64)
    stats = dict(
        blocks=nb,
        candidate_pairs=n_candidates,
        culled_facing=int(culled_facing),
        culled_occluded=culled_occluded,
        visible_pairs=len(pairs),
        occlusion_rays=rays,
    )
    return Partition(members, offsets, np.asarray(groups, np.int64), pairs, lo, hi, stats)


def _occlusion_test(patches, members, offsets, a, b, caster, samples, min_facing, max_samples,
                    seed):
    """Keep a pair unless ≥ min_facing of its sample rays face each other and all are blocked.

    Rounds of ``samples`` rays per pair; a pair is drawn again while it has seen nothing, has
    fewer than ``min_facing`` facing samples and has cast fewer than ``max_samples``. Returns
    the kept mask and the rays cast.
    """
    rng = np.random.default_rng(seed)
    size = np.diff(offsets)
    n_ok = np.zeros(len(a), np.int64)
    seen = np.zeros(len(a), bool)
    active = np.arange(len(a))
    step = max(1, (1 << 20) // samples)  # pairs per batch: ~1 M rays
    rays = 0
    for _ in range(max(1, max_samples // samples)):
        for s in range(0, len(active), step):
            act = active[s : s + step]
            aa, bb = np.repeat(a[act], samples), np.repeat(b[act], samples)
            i = members[offsets[aa] + rng.integers(0, size[aa])]
            j = members[offsets[bb] + rng.integers(0, size[bb])]
            pi = _random_points(patches.vertices[i], rng)
            pj = _random_points(patches.vertices[j], rng)
            d = pj - pi
            ok = (np.einsum("ij,ij->i", d, patches.normal[i]) > 0) & (
                np.einsum("ij,ij->i", d, patches.normal[j]) < 0
            )
            blocked = caster.occluded(pi, pj)
            seen[act] |= (ok & ~blocked).reshape(-1, samples).any(1)
            n_ok[act] += ok.reshape(-1, samples).sum(1)
            rays += len(aa)
        active = active[~seen[active] & (n_ok[active] < min_facing)]
        if not len(active):
            break
    return seen | (n_ok < min_facing), rays
