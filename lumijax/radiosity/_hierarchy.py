"""The far field as a hierarchy: a cluster tree over the partition's blocks and the block tree of
well-separated cluster pairs (an H-matrix; Hackbusch 1999; in radiosity, Hanrahan, Salzman &
Aupperle 1991).

The partition's blocks are the leaves. They are merged by recursive bisection of their centres
(patch-weighted, along the longest axis) into a binary cluster tree; user groups matter only at
the leaves. The block tree is walked from (root, root):

* a cluster pair with no visible block pair under it is dropped (the partition's admissible
  zero blocks, now at every level);
* a well-separated pair is offered to ``compress`` whole; if that returns factors, the pair is
  one low-rank leaf covering every block pair under it;
* otherwise the larger cluster is split and the child pairs are visited; two leaf blocks that
  end here are a near-field (dense) pair of the partition.

Why near-linear: a cluster at one level has a bounded number of well-separated partners whose
parents are not (a geometric packing bound), and a leaf of rank r over clusters of m and n
patches costs r (m + n) numbers, so the far field takes O(r P log P) memory instead of the
O(P²) of one level of blocks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from ._partition import bisection_order

__all__ = ["Cluster", "cluster_tree", "walk_block_tree"]


@dataclasses.dataclass(eq=False)
class Cluster:
    """A node of the cluster tree: a set of the partition's blocks."""

    blocks: np.ndarray
    """Block ids (sorted)."""
    patches: np.ndarray
    """Patch indices, block by block."""
    lo: np.ndarray
    hi: np.ndarray
    """Bounding box of the blocks' vertices, m."""
    centre: np.ndarray
    radius: float
    """Bounding sphere (conservative: from the blocks' spheres), m."""
    max_diameter: float
    """Largest patch diameter in the cluster, m."""
    children: tuple[Cluster, ...] = ()

    @property
    def leaf(self) -> bool:
        return not self.children

    @property
    def size(self) -> int:
        return len(self.patches)


def cluster_tree(part, centre: np.ndarray, radius: np.ndarray, dmax: np.ndarray) -> Cluster | None:
    """Binary cluster tree over ``part``'s blocks.

    ``centre, radius``: the blocks' bounding spheres; ``dmax``: each block's largest patch
    diameter. ``None`` for a partition with no block.
    """
    if part.n_blocks == 0:
        return None
    sizes = part.sizes

    def node(blocks: np.ndarray) -> Cluster:
        blocks = np.sort(blocks)
        lo, hi = part.lo[blocks].min(0), part.hi[blocks].max(0)
        c = 0.5 * (lo + hi)
        r = float(np.max(np.linalg.norm(centre[blocks] - c, axis=1) + radius[blocks]))
        patches = np.concatenate([part.block(b) for b in blocks])
        children: tuple[Cluster, ...] = ()
        if len(blocks) > 1:
            order = blocks[bisection_order(centre[blocks])]  # ties broken the same anywhere
            w = np.cumsum(sizes[order])
            cut = int(np.clip(np.searchsorted(w, 0.5 * w[-1]) + 1, 1, len(order) - 1))
            children = (node(order[:cut]), node(order[cut:]))
        return Cluster(blocks, patches, lo, hi, c, r, float(dmax[blocks].max()), children)

    return node(np.arange(part.n_blocks))


def walk_block_tree(
    root: Cluster,
    visible: np.ndarray,
    admissible: Callable[[Cluster, Cluster], bool],
    compress: Callable[[Cluster, Cluster], object | None],
) -> tuple[list[tuple[Cluster, Cluster, object]], list[tuple[int, int]]]:
    """Walk the block tree from (root, root).

    ``visible``: ``(B, B)`` symmetric bool, the partition's visible block pairs.
    Returns ``(far, near)``: far leaves ``(s, t, compress(s, t))`` and the near block pairs
    ``(a, b)`` with ``a ≤ b`` that are visible and under no far leaf.
    """
    far: list[tuple[Cluster, Cluster, object]] = []
    near: list[tuple[int, int]] = []
    stack = [(root, root)]
    while stack:
        s, t = stack.pop()
        if s is t:
            if s.leaf:
                b = int(s.blocks[0])
                if visible[b, b]:
                    near.append((b, b))
            else:
                c1, c2 = s.children
                stack += [(c1, c2), (c2, c2), (c1, c1)]
            continue
        if not visible[np.ix_(s.blocks, t.blocks)].any():
            continue
        if admissible(s, t):
            res = compress(s, t)
            if res is not None:
                far.append((s, t, res))
                continue
        if s.leaf and t.leaf:
            a, b = int(s.blocks[0]), int(t.blocks[0])
            near.append((min(a, b), max(a, b)))
            continue
        if t.leaf or (not s.leaf and s.size >= t.size):
            stack += [(c, t) for c in reversed(s.children)]
        else:
            stack += [(s, c) for c in reversed(t.children)]
    return far, near
