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

    # a small build calls the quickly compiled variant (radiosity._operator.DENSE_PATCHES)
    for name in ("_contour_flat", "_contour_flat_quick"):
        monkeypatch.setattr(_build, name, spy(getattr(_build, name)))
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
