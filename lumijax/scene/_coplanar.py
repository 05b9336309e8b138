"""Coincident surfaces: triangles of different geometry items in one plane, facing the same way.

A rectangle lying on a box's floor (common in CAD exports) is seen by the rest of the room on
top of the floor it covers: the form factors count that area twice, and a lit room gains
12–18 % light with no error anywhere. :func:`coincident_surfaces` finds such pairs of items;
``build_scene`` warns naming both (docs/radiosity.md, "Coincident surfaces").

Cost is linear in the triangles: planes are bucketed by quantised normal (1° cells) and offset
(``distance`` cells) and joined to their neighbouring buckets; only buckets holding two items
are examined, by sampling the smaller item's triangles and testing the points against the
other item's triangles through a uniform 2-D grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Float, Int

__all__ = ["Coincidence", "coincident_surfaces"]

DISTANCE = 0.5e-3
"""m: two planes closer than this are one (a finish 1 mm proud of its wall is not flagged)."""

ANGLE_DEG = 1.0
"""Normals within this many degrees face the same way."""

MIN_AREA = 1e-3
"""m²: smaller coincident areas (touching edges, slivers) are not reported."""

_SAMPLES = 4  # a triangle is sampled at the centroids of its 4² sub-triangles


@dataclass(frozen=True)
class Coincidence:
    """Items ``a`` and ``b`` share ``area_m2`` of surface, facing the same way."""

    a: int
    b: int
    area_m2: float


def coincident_surfaces(
    vertices: Float[np.ndarray, "tri 3 3"],
    item: Int[np.ndarray, " tri"],
    *,
    distance: float = DISTANCE,
    angle_deg: float = ANGLE_DEG,
    min_area: float = MIN_AREA,
) -> list[Coincidence]:
    """Pairs of geometry items (``item`` per triangle) with coincident, same-facing area.

    Parameters
    ----------
    vertices
        ``(T, 3, 3)`` triangles, m; the front face along ``(v1 − v0) × (v2 − v0)``.
    distance
        Largest separation (m) of two planes counted as one.
    angle_deg
        Largest angle between two normals counted as the same direction.
    min_area
        Smallest coincident area (m²) reported.
    """
    v = np.asarray(vertices, np.float64)
    item = np.asarray(item)
    if len(v) == 0 or len(np.unique(item)) < 2:
        return []
    cross = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    norm = np.linalg.norm(cross, axis=1)
    ok = norm > 0
    v, item, cross, norm = v[ok], item[ok], cross[ok], norm[ok]
    n = cross / norm[:, None]
    area = 0.5 * norm
    d = np.einsum("ij,ij->i", n, v.mean(axis=1))
    step = np.sin(np.radians(angle_deg))
    keys = np.column_stack([np.round(n / step), np.round(d / distance)]).astype(np.int64)
    cluster = _clusters(keys)
    cos_min = np.cos(np.radians(angle_deg))
    out: dict[tuple[int, int], float] = {}
    order = np.argsort(cluster, kind="stable")
    bounds = np.flatnonzero(np.diff(cluster[order])) + 1
    for members in np.split(order, bounds):
        if len(np.unique(item[members])) < 2:
            continue
        # one pass per plane cluster, whatever its item count: every sample against the other
        # items' triangles (a pass per pair of items was quadratic in the items of a plane, minutes
        # on a courtyard whose plinths all share the ground plane)
        for (a, b), shared in _covered_pairs(v, n, area, item, members, distance, cos_min).items():
            if shared >= min_area:
                out[(a, b)] = out.get((a, b), 0.0) + shared
    return [Coincidence(a, b, s) for (a, b), s in sorted(out.items())]


def _clusters(keys: np.ndarray) -> np.ndarray:
    """Connected components of buckets joined to their neighbours (±1 in every key)."""
    uniq, cell = np.unique(keys, axis=0, return_inverse=True)
    cell = cell.ravel()
    span = uniq.max(axis=0) - uniq.min(axis=0) + 3
    base = uniq - uniq.min(axis=0) + 1

    def code(k):
        c = np.zeros(len(k), np.int64)
        for j in range(k.shape[1]):
            c = c * span[j] + k[:, j]
        return c

    codes = code(base)
    sorter = np.argsort(codes)
    rows, cols = [], []
    for off in np.stack(np.meshgrid(*[[-1, 0, 1]] * keys.shape[1]), -1).reshape(-1, keys.shape[1]):
        nb = code(base + off)
        pos = np.clip(np.searchsorted(codes, nb, sorter=sorter), 0, len(codes) - 1)
        hit = codes[sorter[pos]] == nb
        rows.append(np.flatnonzero(hit))
        cols.append(sorter[pos[hit]])
    label = _components(len(uniq), np.concatenate(rows), np.concatenate(cols))
    return label[cell]


def _components(n: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Connected components of the undirected graph on ``n`` nodes with edges ``rows[k] —
    cols[k]``: a label per node, equal within a component. Not scipy's ``connected_components``:
    importing ``scipy.sparse.csgraph`` cost a furnished room's run 0.16 s
    (``python -X importtime``, session 20), and these graphs are small and shallow.

    Each node takes the least label among its neighbours', then follows its label's label
    (pointer jumping), until nothing changes: at most one pass per doubling of the longest
    path."""
    label = np.arange(n)
    while True:
        least = np.minimum(label[rows], label[cols])
        new = label.copy()
        np.minimum.at(new, rows, least)
        np.minimum.at(new, cols, least)
        new = new[new]
        if np.array_equal(new, label):
            return label
        label = new


def _samples(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroids of the k² congruent sub-triangles of each triangle, ``(T, k², 3)``, and the
    fraction of the area each stands for."""
    k = _SAMPLES
    weights: list[tuple[float, float]] = []
    for i in range(k):
        for j in range(k - i):
            weights.append(((i + 1 / 3) / k, (j + 1 / 3) / k))  # upright sub-triangles
            if i + j < k - 1:
                weights.append(((i + 2 / 3) / k, (j + 2 / 3) / k))  # inverted ones
    bary = np.array(weights)  # (k², 2): weights of v1 and v2
    p = (v[:, None, 0] + bary[None, :, 0, None] * (v[:, None, 1] - v[:, None, 0])
         + bary[None, :, 1, None] * (v[:, None, 2] - v[:, None, 0]))
    return p, np.full(len(bary), 1.0 / len(bary))


def _covered_pairs(v, n, area, item, members, distance, cos_min) -> dict[tuple[int, int], float]:
    """Coincident area (m²) of each pair of items among the triangles ``members`` of one plane
    cluster: the area of the smaller item lying on the larger, measured by the smaller item's
    samples (the larger one's triangles may be too big for their samples to resolve it)."""
    pts, w = _samples(v[members])
    weight = (area[members][:, None] * w[None]).ravel()
    owner = np.repeat(item[members], pts.shape[1])
    pn = np.repeat(n[members], pts.shape[1], axis=0)
    pts = pts.reshape(-1, 3)
    axis = n[members].mean(axis=0)
    axis /= np.linalg.norm(axis)
    e1 = np.cross(axis, [1.0, 0, 0] if abs(axis[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    to2 = np.stack([e1, np.cross(axis, e1)], axis=1)
    tri2 = v[members] @ to2  # (M, 3, 2) in the cluster's plane
    p2 = pts @ to2
    lo, hi = tri2.min(axis=1), tri2.max(axis=1)
    cell = max(2.0 * np.sqrt(area[members].sum() / len(members)), distance)
    origin = lo.min(axis=0)
    c0 = np.floor((lo - origin) / cell).astype(np.int64)
    c1 = np.floor((hi - origin) / cell).astype(np.int64)
    width = int(c1[:, 0].max()) + 1
    nx, ny = c1[:, 0] - c0[:, 0] + 1, c1[:, 1] - c0[:, 1] + 1
    count = nx * ny
    tri_of = np.repeat(np.arange(len(members)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    cell_code = (c0[tri_of, 1] + local // np.repeat(nx, count)) * width \
        + c0[tri_of, 0] + local % np.repeat(nx, count)
    order = np.argsort(cell_code, kind="stable")
    cell_code, tri_of = cell_code[order], tri_of[order]
    pc = np.floor((p2 - origin) / cell).astype(np.int64)
    inside_grid = (pc[:, 0] >= 0) & (pc[:, 1] >= 0) & (pc[:, 0] < width)
    pcode = np.where(inside_grid, pc[:, 1] * width + pc[:, 0], -1)
    start = np.searchsorted(cell_code, pcode, "left")
    k = np.searchsorted(cell_code, pcode, "right") - start
    pid = np.repeat(np.arange(len(pts)), k)
    t = members[tri_of[np.repeat(start, k) + (np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k))]]
    other = item[t] != owner[pid]
    pid, t = pid[other], t[other]
    q = pts[pid]
    hit = (np.einsum("ij,ij->i", n[t], pn[pid]) >= cos_min) \
        & (np.abs(np.einsum("ij,ij->i", n[t], q - v[t, 0])) <= distance) \
        & _in_triangle(q, v[t, 0], v[t, 1], v[t, 2], n[t])
    # each sample counts once per other item it lies on
    lies_on = np.unique(np.column_stack([pid[hit], item[t[hit]]]), axis=0)
    if not len(lies_on):
        return {}
    on: dict[tuple[int, int], float] = {}
    for (a, b), s in zip(map(tuple, np.column_stack([owner[lies_on[:, 0]], lies_on[:, 1]])),
                         weight[lies_on[:, 0]], strict=True):
        on[(int(a), int(b))] = on.get((int(a), int(b)), 0.0) + float(s)
    ids, inv = np.unique(item[members], return_inverse=True)
    size = dict(zip(ids.tolist(), np.bincount(inv.ravel(), weights=area[members]), strict=True))
    out = {}
    for a, b in {(min(a, b), max(a, b)) for a, b in on}:
        small, large = (a, b) if size[a] <= size[b] else (b, a)
        out[(a, b)] = on.get((small, large), 0.0)
    return out


def _in_triangle(q, a, b, c, n) -> np.ndarray:
    """Whether each q (projected along n) lies in its triangle abc, edges included."""
    def side(p0, p1):
        return np.einsum("ij,ij->i", np.cross(p1 - p0, q - p0), n) >= -1e-12
    return side(a, b) & side(b, c) & side(c, a)
