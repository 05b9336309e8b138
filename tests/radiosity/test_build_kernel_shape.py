"""The near field's contour kernel runs in one shape whatever the patch count: one trace and
one compilation (or one read of JAX's persistent cache) per process, so a new study reuses the
program an earlier, different one compiled (issue 19: a cold cube0.8 run paid 0.3-0.4 s per
extra shape)."""

from __future__ import annotations

import numpy as np
import trimesh

from lumijax.radiosity import _build

from .conftest import room


def test_rooms_of_different_patch_counts_call_the_kernel_in_one_shape(monkeypatch):
    shapes = []

    def spy(kernel):
        def call(q, n, tri):
            shapes.append((q.shape, n.shape, tri.shape))
            return kernel(q, n, tri)
        return call

    # a small build calls the quickly compiled variants (radiosity._operator.DENSE_PATCHES),
    # the clipped and the unclipped kernel alike
    for name in ("_CONTOUR", "_CONTOUR_QUICK"):
        monkeypatch.setattr(_build, name, tuple(spy(k) for k in getattr(_build, name)))
    counts = []
    for size in (0.3, 0.17):
        p, _, op = room(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), size)
        counts.append(p.n)
        # a closed room: every row of F sums to 1 (closure), the far and near parts together
        rows = np.asarray(op.row_sums())
        assert np.all(np.abs(rows - 1) < 0.01), (rows.min(), rows.max())
    assert counts[0] != counts[1]
    b = _build._BATCH
    assert set(shapes) == {((b, 3), (b, 3), (b, 3, 3))}


def test_pairs_wholly_in_front_take_the_unclipped_kernel_and_the_blocks_stay(monkeypatch):
    # docs/radiosity.md, "The near field's two kernels": a near pair each of whose triangles is
    # wholly in front of the other's plane needs no horizon clipping; the pairs that touch a
    # plane (patches meeting at the room's edges) still take the clipped kernel
    from lumijax.radiosity import build_operator

    points = {}

    def spy(name, kernel):
        def call(q, n, tri):
            points[name] = points.get(name, 0) + len(q)
            return kernel(q, n, tri)
        return call

    clipped, front = _build._CONTOUR_QUICK
    monkeypatch.setattr(_build, "_CONTOUR_QUICK", (spy("clipped", clipped), spy("front", front)))
    mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    mesh.invert()
    p, part, op = room(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), 0.17)
    split = dict(points)
    assert split["front"] > split["clipped"] > 0
    points.clear()
    monkeypatch.setattr(_build, "_WHOLE", np.inf)  # nothing counts as whole: all clipped
    every = build_operator(p, part, mesh.triangles)
    assert "front" not in points
    g, g_clipped = np.asarray(op.todense()), np.asarray(every.todense())
    np.testing.assert_allclose(g, g_clipped, rtol=1e-5, atol=1e-6 * g.max())
