"""The block operator's near-field blocks are computed on threads: the operator must be the
one the plain loop gives, bit for bit, with the same counts of rays and near pairs."""

from __future__ import annotations

import jax
import numpy as np
import trimesh

import lumijax.radiosity._build as build
from lumijax.parallel import threaded_map
from lumijax.radiosity import build_operator, mesh_patches, partition


def test_blocks_on_threads_are_the_blocks_of_the_plain_loop(monkeypatch):
    room = trimesh.creation.box(extents=(4.0, 3.0, 2.8))
    room.invert()
    screen = trimesh.creation.box(extents=(0.05, 1.5, 1.4))  # shadows and near pairs
    screen.apply_translation([-0.8, -0.4, -0.7])
    tri = np.concatenate([room.triangles, screen.triangles])
    p = mesh_patches(tri, patch_size=0.5)
    part = partition(p, max_block=64, occluders=tri)
    assert len(part.pairs) > 8  # enough blocks for both threads to work
    seen: list = []

    def spy(fn, items, threads=None):
        items = list(items)
        seen.append((len(items), threads))
        return threaded_map(fn, items, threads)

    monkeypatch.setattr(build, "threaded_map", spy)
    threaded = build_operator(p, part, tri, dtype=np.float64)
    monkeypatch.setattr(build, "threaded_map", lambda fn, items, threads=None:
                        threaded_map(fn, items, threads=1))
    plain = build_operator(p, part, tri, dtype=np.float64)
    assert seen and seen[0][0] > 8 and seen[0][1] is None  # every CPU this process may use
    for a, b in zip(jax.tree_util.tree_leaves(threaded.buckets),
                    jax.tree_util.tree_leaves(plain.buckets), strict=True):
        assert np.array_equal(np.asarray(a), np.asarray(b))
    for key in ("rays", "near_pairs", "nonzeros"):
        assert threaded.info[key] == plain.info[key] > 0, key
