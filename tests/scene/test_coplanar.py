"""Coincident surfaces (a rug lying on a room's floor) are named at scene build; a finish 1 mm
proud of its wall, or a face pressed against another (facing away), is not."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from helpers import box, material, rectangle, study_text

from lumijax import LumijaxWarning, load_study
from lumijax.scene._coplanar import coincident_surfaces


def _room(z, ux, vy):
    """A 6 × 5 × 3 m room and a ``ux`` × ``vy`` m rug at height ``z`` (m), facing ``u × v``."""
    return study_text(material("wall", 0.5), box([0, 0, 0], [6, 5, 3], name="room"),
                 rectangle([1, 1, z], [ux, 0, 0], [0, vy, 0], name="rug"))


def _coincidence_warnings(write_study, **kw):
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        load_study(write_study(_room(**kw)))
    return [str(w.message) for w in rec
            if issubclass(w.category, LumijaxWarning) and "lies on" in str(w.message)]


def test_a_rug_on_the_floor_is_named_with_its_area(write_study):
    # 2 m × 1.5 m facing up, on the inward floor (also facing up): 3.00 m² counted twice
    (msg,) = _coincidence_warnings(write_study, z=0, ux=2, vy=1.5)
    assert "geometry 'rug' (geometry[1])" in msg and "geometry 'room' (geometry[0])" in msg
    assert "3.00 m² coincident" in msg and "facing the same way" in msg
    assert "study.toml" in msg and "offset it by ≥ 1 mm" in msg


def test_a_finish_1_mm_proud_and_a_face_turned_away_are_not_flagged(write_study):
    assert _coincidence_warnings(write_study, z=0.001, ux=2, vy=1.5) == []
    # u, v swapped: the rectangle faces down onto the floor (a pressed face, not doubled light)
    assert _coincidence_warnings(write_study, z=0, ux=-2, vy=1.5) == []


def _grid_mesh(lo, hi, z, size, up=True):
    """A horizontal rectangle [lo, hi] at height z cut into triangles of about ``size`` m."""
    v = np.array([[lo[0], lo[1], z], [hi[0], lo[1], z], [hi[0], hi[1], z], [lo[0], hi[1], z]])
    f = np.array([[0, 1, 2], [0, 2, 3]] if up else [[0, 2, 1], [0, 3, 2]])
    vv, ff = trimesh.remesh.subdivide_to_size(v, f, size)
    return vv[ff]


def test_partial_overlap_of_fine_meshes_measures_the_shared_area():
    # A 6 × 5 m floor of ~0.06 m triangles and a 1.5 × 1 m mat hanging 0.5 m over its edge:
    # the shared area is 1.0 × 1.0 = 1 m² (the rectangles' intersection, by hand); a tilted
    # panel and a far plane add triangles that must not count.
    floor = _grid_mesh([0, 0], [6, 5], 0.0, 0.06)
    mat = _grid_mesh([5, 2], [6.5, 3], 0.0, 0.05)
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.5).triangles + [3, 2.5, 1.5]
    tri = np.concatenate([floor, mat, sphere])
    item = np.repeat([0, 1, 2], [len(floor), len(mat), len(sphere)])
    assert len(tri) > 2 * 10**4
    (c,) = coincident_surfaces(tri, item)
    assert (c.a, c.b) == (0, 1)
    assert c.area_m2 == pytest.approx(1.0, rel=0.03)


def test_a_scene_of_one_item_loads_without_importing_scipy(tmp_path):
    # a box room has no second item to coincide with: its build must not pay for scipy.sparse
    # (0.3-0.6 s of a cold run), so the import sits where two items share a plane
    import subprocess
    import sys

    code = ("import sys, numpy as np; from lumijax.scene._coplanar import coincident_surfaces; "
            "v = np.random.default_rng(0).random((40, 3, 3)); "
            "assert coincident_surfaces(v, np.zeros(40, int)) == []; "
            "print(sorted(m for m in sys.modules if m.startswith('scipy')))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert proc.stdout.strip() == "[]"
