"""Points inside closed meshes (``scene._inside``) and the plane clusters' components
(``scene._coplanar._components``), against closed-form shapes and scipy."""

import numpy as np
import pytest
import trimesh

from lumijax.scene._coplanar import _components
from lumijax.scene._inside import inside_closed


def _points(n=3000, half=1.6, seed=0):
    return np.random.default_rng(seed).uniform(-half, half, (n, 3))


def test_box_inside_is_the_box():
    half = np.array([0.5, 1.0, 1.5])
    box = trimesh.creation.box(extents=2 * half)
    p = _points()
    margin = np.min(np.abs(np.abs(p) - half), axis=1) > 1e-6  # not on a face
    expect = np.all(np.abs(p) < half, axis=1)
    got = inside_closed(box.triangles, p)
    assert np.array_equal(got[margin], expect[margin])
    assert 0 < expect.sum() < len(p)


def test_orientation_does_not_matter():
    box = trimesh.creation.box(extents=(1, 1, 1))
    p = _points(half=0.9)
    flipped = box.triangles[:, ::-1]  # every normal inward
    assert np.array_equal(inside_closed(box.triangles, p), inside_closed(flipped, p))


def test_sphere_and_a_ring_with_a_hole():
    sphere = trimesh.creation.icosphere(subdivisions=4)  # vertices on the unit sphere
    p = _points()
    r = np.linalg.norm(p, axis=1)
    # the tessellation lies between the inscribed radius (cos of half the edge's angle) and 1
    clear = (r < 0.99) | (r > 1.0 + 1e-9)
    assert np.array_equal(inside_closed(sphere.triangles, p)[clear], (r < 1)[clear])
    ring = trimesh.creation.annulus(r_min=0.5, r_max=1.0, height=1.0, sections=256)
    rho = np.hypot(p[:, 0], p[:, 1])
    expect = (rho > 0.5) & (rho < 1.0) & (np.abs(p[:, 2]) < 0.5)
    clear = ((np.abs(rho - 0.5) > 1e-3) & (np.abs(rho - 1.0) > 1e-3)
             & (np.abs(np.abs(p[:, 2]) - 0.5) > 1e-6))
    got = inside_closed(ring.triangles, p)
    assert np.array_equal(got[clear], expect[clear])
    assert not got[np.hypot(p[:, 0], p[:, 1]) < 0.45].any()  # the hole is outside


def test_on_a_shared_edge_the_vote_decides():
    # points on the box's diagonal planes: their rays often pass the triangles' shared edges
    box = trimesh.creation.box(extents=(2, 2, 2))
    t = np.linspace(-0.9, 0.9, 37)
    p = np.concatenate([np.stack([t, t, t], 1), np.stack([t, -t, 0 * t], 1)])
    assert inside_closed(box.triangles, p).all()
    assert not inside_closed(box.triangles, p + 3.0).any()


@pytest.mark.parametrize("n,m", [(10, 5), (1000, 900), (4000, 3900)])
def test_components_match_scipy(n, m):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rng = np.random.default_rng(n)
    rows, cols = rng.integers(0, n, m), rng.integers(0, n, m)
    got = _components(n, rows, cols)
    count, expect = connected_components(coo_matrix((np.ones(m), (rows, cols)), shape=(n, n)),
                                         directed=False)
    assert len(np.unique(got)) == count
    # the same partition: each of our labels maps to one of scipy's, and back
    assert len(set(zip(got, expect))) == count


def test_components_of_a_long_chain():
    n = 513
    label = _components(n, np.arange(n - 1), np.arange(1, n))
    assert (label == label[0]).all()
