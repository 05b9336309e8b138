"""Where a gather ray lands: the hit triangle's patch with the nearest centroid, the same by the
padded search (small triangles) as by the k-d tree (large ones), against a plain loop."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.radiosity import mesh_patches
from lumijax.radiosity._gather import patch_of_hits


def _scene():
    # at 0.5 m: a 12 m floor square (two triangles of 1,156 patches), a 3 m dais (81), a 2 m
    # shelf (36), a 1.2 m table top (16) and a 0.3 m tile (one patch): every way of the search
    # (the padded buckets to 4, 16 and 64, the product per triangle) and the tree
    tri = []
    for lo, hi, z in (((0, 0), (12, 12), 0.0), ((6, 1), (9, 4), 0.2), ((1, 8), (3, 10), 1.0),
                      ((3, 3), (4.2, 4.2), 0.75), ((8, 8), (8.3, 8.3), 0.4)):
        a, b, c, d = ((lo[0], lo[1], z), (hi[0], lo[1], z), (hi[0], hi[1], z), (lo[0], hi[1], z))
        tri += [(a, b, c), (a, c, d)]
    return np.asarray(tri, np.float64)


def _hits(tri, n, rng):
    t = rng.integers(0, len(tri), n)
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    p = tri[t, 0] + u[:, None] * (tri[t, 1] - tri[t, 0]) + v[:, None] * (tri[t, 2] - tri[t, 0])
    return p, t


def _nearest_by_loop(patches, points, tri):
    src = np.asarray(patches.source_triangle)
    out = np.empty(len(points), np.int64)
    for k, (p, t) in enumerate(zip(points, tri)):
        own = np.flatnonzero(src == t)
        out[k] = own[np.argmin(np.linalg.norm(patches.centroid[own] - p, axis=1))]
    return out


@pytest.mark.parametrize("few", [1, 4, 16, 64, 256, 4096])
def test_the_search_and_the_tree_find_the_nearest_patch_of_the_hit_triangle(few):
    tri = _scene()
    patches = mesh_patches(tri, patch_size=0.5)
    counts = np.bincount(patches.source_triangle)
    assert set(counts) == {1156, 81, 36, 16, 1}
    points, t = _hits(tri, 3000, np.random.default_rng(7))
    got = patch_of_hits(patches, points, t, few=few, budget=1 << 12)
    np.testing.assert_array_equal(got, _nearest_by_loop(patches, points, t))
    assert (np.asarray(patches.source_triangle)[got] == t).all()


def test_no_hits_give_no_patches():
    patches = mesh_patches(_scene(), patch_size=0.5)
    assert patch_of_hits(patches, np.zeros((0, 3)), np.zeros(0, np.int64)).shape == (0,)
