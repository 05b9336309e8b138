"""Adaptive refinement of radiosity patches where the direct light changes fast.

A patch is constant-radiosity, so a shadow edge or the steep inverse-square fall-off under a
luminaire is smeared over a whole patch. After meshing we compare each patch's direct irradiance
with its edge neighbours' and split both patches of every pair that differs by more than a
relative ``threshold`` into four (midpoint subdivision), then repeat on the new patches only, up
to ``levels`` times. The new patches' irradiance is computed by the caller's function (direct
light on their centroids), so the cost is one direct-light evaluation per new patch.
"""

from __future__ import annotations

from collections.abc import Callable

import equinox as eqx
import numpy as np
from jaxtyping import Float, Int

from ..errors import GeometryError
from ._patches import Patches, _fields, subdivide_triangles

__all__ = ["Refinement", "refine_patches", "edge_neighbours"]

#: Neighbours whose normals differ by more than this are not compared: a floor and a wall
#: meeting at a corner differ by orientation, which subdividing either does not resolve.
_MAX_CREASE_DEG = 20.0


class Refinement(eqx.Module):
    """The refined patches and what was computed on them.

    Attributes
    ----------
    patches
        The refined :class:`Patches` (sorted by source triangle, like :func:`mesh_patches`).
    irradiance
        ``(columns, P)`` the irradiance function's values on them, lx.
    level
        ``(P,)`` how many times each patch's ancestor was split (0: as meshed).
    """

    patches: Patches
    irradiance: Float[np.ndarray, "columns patches"]
    level: Int[np.ndarray, " patches"]


def refine_patches(
    patches: Patches,
    irradiance: Callable[[Patches], np.ndarray],
    levels: int,
    threshold: float = 0.5,
    *,
    floor: float = 0.01,
) -> Refinement:
    """Split patches where the direct irradiance changes fast between edge neighbours.

    Parameters
    ----------
    patches
        The meshed patches.
    irradiance
        ``irradiance(patches) -> (columns, n)`` direct irradiance (lx) on the given patches, one
        column per source group; called once on ``patches`` and once per level on the new ones.
    levels
        Most subdivision levels (0: none). A patch split ``levels`` times is 4^-levels of its
        parent's area.
    threshold
        A pair of edge neighbours with irradiance E_i, E_j (any column) is split when
        ``|E_i − E_j| > threshold · max(E_i, E_j)``.
    floor
        Pairs whose larger irradiance is below ``floor`` × the column's area-weighted mean are
        ignored: relative changes in near-darkness do not matter.

    Raises
    ------
    GeometryError
        ``levels`` negative or ``threshold`` not in (0, 1].
    """
    if int(levels) != levels or levels < 0:
        raise GeometryError(f"refinement levels must be an integer ≥ 0, got {levels!r}",
                            key="solver.refine")
    if not (0 < threshold <= 1):
        raise GeometryError(f"refinement threshold must be in (0, 1], got {threshold!r}",
                            key="solver.refine_threshold")
    e = np.atleast_2d(np.asarray(irradiance(patches), np.float64))
    level = np.zeros(patches.n, np.int64)
    if levels == 0 or patches.n == 0:
        return Refinement(patches, e, level)
    mean = (e * patches.area).sum(axis=1) / max(float(patches.area.sum()), 1e-300)
    cut = floor * mean[:, None]
    new = np.ones(patches.n, bool)
    for _ in range(int(levels)):
        i, j = edge_neighbours(patches, new)
        big = np.maximum(e[:, i], e[:, j])
        fast = ((np.abs(e[:, i] - e[:, j]) > threshold * big) & (big > cut)).any(axis=0)
        split = np.zeros(patches.n, bool)
        split[i[fast]] = True
        split[j[fast]] = True
        if not split.any():
            break
        children = _split4(patches.subset(split))
        e_new = np.atleast_2d(np.asarray(irradiance(children), np.float64))
        keep = ~split
        patches = _concat(patches.subset(keep), children)
        e = np.concatenate([e[:, keep], e_new], axis=1)
        level = np.concatenate([level[keep], np.repeat(level[split] + 1, 4)])
        new = np.concatenate([np.zeros(keep.sum(), bool), np.ones(children.n, bool)])
    order = np.argsort(patches.source_triangle, kind="stable")
    return Refinement(patches.subset(order), e[:, order], level[order])


def edge_neighbours(
    patches: Patches, among: np.ndarray | None = None
) -> tuple[Int[np.ndarray, " pairs"], Int[np.ndarray, " pairs"]]:
    """Unordered pairs ``(i, j)`` of patches that share a piece of an edge, on surfaces that
    meet at less than 20°, with at least one of the two in the mask ``among`` (default: all).

    Meshes need not conform: a refined patch next to an unrefined one meets it at a T-junction,
    and two source triangles cut into different grids meet along offset vertices. So two
    triangles are edge neighbours when at least two distinct vertices of either lie on the
    other's boundary (a shared corner alone gives one).
    """
    n = patches.n
    if n < 2:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    among = np.ones(n, bool) if among is None else np.asarray(among, bool)
    c, d = patches.centroid, patches.diameter
    # A triangle lies within 2/3 of its longest edge of its centroid, so touching patches'
    # centroids are at most (2/3)(d_i + d_j) apart. Refined meshes mix sizes, so candidates are
    # looked up per pair of size classes (factors of two) with that class pair's radius, not the
    # largest patch's, which would make every small patch query hundreds of its peers.
    from scipy.spatial import cKDTree  # here: scipy.spatial costs ~0.3 s of every import

    size = np.floor(np.log2(d / d.min())).astype(np.int64)
    ii, jj = [], []
    for b in np.unique(size):
        inb = np.flatnonzero(size == b)
        tree = cKDTree(c[inb])
        for a in np.unique(size[among]):
            q = np.flatnonzero(among & (size == a))
            r = (2.0 / 3.0) * (d[q].max() + d[inb].max()) * (1 + 1e-9)
            hits = tree.query_ball_point(c[q], r=r)
            counts = np.fromiter((len(h) for h in hits), np.int64, len(hits))
            ii.append(np.repeat(q, counts))
            jj.append(inb[np.concatenate(hits).astype(np.int64)] if counts.sum() else
                      np.zeros(0, np.int64))
    if not ii:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    i, j = np.concatenate(ii), np.concatenate(jj)
    # each unordered pair once: i < j, or j not itself queried (then only (i, j) was found)
    once = (i < j) | ((i > j) & ~among[j])
    i, j = i[once], j[once]
    cos = np.cos(np.radians(_MAX_CREASE_DEG))
    ok = np.einsum("pk,pk->p", patches.normal[i], patches.normal[j]) >= cos
    i, j = i[ok], j[ok]
    if len(i) == 0:
        return i, j
    v = patches.vertices
    eps = 1e-6 * np.minimum(d[i], d[j])
    on_i = _on_boundary(v[j], v[i], eps)  # (pairs, 3): j's vertices on i's boundary
    on_j = _on_boundary(v[i], v[j], eps)
    shared = (np.linalg.norm(v[i][:, :, None] - v[j][:, None], axis=-1) <= eps[:, None, None])
    distinct = on_i.sum(1) + on_j.sum(1) - shared.any(axis=2).sum(1)
    touch = distinct >= 2
    return i[touch], j[touch]


def _on_boundary(points, tri, eps):
    """``(pairs, 3)``: is each of ``points`` (pairs, 3, 3) within ``eps`` of an edge of ``tri``."""
    a = tri[:, :, None]  # (pairs, edge, 1, 3)
    b = np.roll(tri, -1, axis=1)[:, :, None]
    p = points[:, None]  # (pairs, 1, point, 3)
    ab = b - a
    t = np.clip(np.einsum("...k,...k->...", p - a, ab) / np.einsum("...k,...k->...", ab, ab),
                0.0, 1.0)
    dist = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)  # (pairs, edge, point)
    return (dist <= eps[:, None, None]).any(axis=1)


def _split4(p: Patches) -> Patches:
    """Each patch cut at its edge midpoints into four of a quarter of its area, same orientation
    and normal, material, group and source triangle."""
    sub = subdivide_triangles(p.vertices, 2).reshape(-1, 3, 3)
    rep = lambda a: np.repeat(a, 4, axis=0)  # noqa: E731
    return Patches(
        centroid=sub.mean(axis=1), normal=rep(p.normal), area=rep(p.area) / 4.0, vertices=sub,
        material=rep(p.material), group=rep(p.group), source_triangle=rep(p.source_triangle),
    )


def _concat(a: Patches, b: Patches) -> Patches:
    return Patches(*(np.concatenate([x, y]) for x, y in zip(_fields(a), _fields(b), strict=True)))
