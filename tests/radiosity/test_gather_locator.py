"""The gather's patch of each ray (radiosity/_gather.py): the patch that holds the hit, found
by the triangle's own grid (``PatchLocator``), against a brute-force point-in-triangle test of
every patch of the hit triangle (independent of the locator); and the lookup made once per
caster and mesh."""

from __future__ import annotations

import numpy as np

from lumijax.radiosity import build_gather, mesh_patches
from lumijax.radiosity._gather import _locator
from lumijax.scene import RayCaster


def _room():
    # a floor of two long right triangles (far from equilateral: its nearest centroid is not
    # always the patch that holds a point) and a ceiling
    a, b, h = 3.0, 1.0, 2.0
    floor = [[[0, 0, 0], [a, 0, 0], [a, b, 0]], [[0, 0, 0], [a, b, 0], [0, b, 0]]]
    ceiling = [[[0, 0, h], [a, b, h], [a, 0, h]], [[0, 0, h], [0, b, h], [a, b, h]]]
    return np.array(floor + ceiling, np.float64)


def _holder(patches, tri, point):
    """The patch of triangle ``tri`` whose triangle holds ``point`` (barycentric test)."""
    for i in np.flatnonzero(np.asarray(patches.source_triangle) == tri):
        v = patches.vertices[i]
        m = np.stack([v[1] - v[0], v[2] - v[0]], axis=1)[:2]
        u = np.linalg.solve(m, (point - v[0])[:2])
        if u.min() >= -1e-9 and u.sum() <= 1 + 1e-9:
            return i
    raise AssertionError("no patch holds the point")


def test_each_ray_lands_on_the_patch_that_holds_its_hit():
    tri = _room()
    patches = mesh_patches(tri, patch_size=0.25)
    caster = RayCaster(tri)
    rng = np.random.default_rng(1)
    points = np.c_[rng.uniform(0.1, 2.9, 40), rng.uniform(0.1, 0.9, 40), np.full(40, 2.0 - 1e-3)]
    down = np.tile([0.0, 0.0, -1.0], (40, 1))
    # straight down from just under the ceiling: each ray's hit is known without Embree
    loc = _locator(patches, caster)
    hit_tri, _ = caster.first_hit(points, down)
    got = loc(np.c_[points[:, :2], np.zeros(40)], hit_tri)
    want = [_holder(patches, t, np.r_[p[:2], 0.0]) for t, p in zip(hit_tri, points, strict=True)]
    np.testing.assert_array_equal(got, want)
    # the gather's weights of a point sum to its view factor to the floor (closed form: a
    # differential area parallel to a rectangle, summed over the four rectangles that meet
    # below the point; Howell's catalogue, B-3)
    g = build_gather(points, down, patches, caster, rays=4096)
    sums = np.bincount(g.point, weights=g.weight, minlength=40)
    exact = np.array([_view_factor(p, 3.0, 1.0) for p in points])
    np.testing.assert_allclose(sums, exact, rtol=0.03)  # ~600 hits a point: stratified noise
    assert abs(np.mean(sums / exact - 1)) < 0.005  # and no bias


def _corner(x, y, h):
    a, b = x / h, y / h
    return (a / np.hypot(1, a) * np.arctan(b / np.hypot(1, a))
            + b / np.hypot(1, b) * np.arctan(a / np.hypot(1, b))) / (2 * np.pi)


def _view_factor(p, a, b):
    x, y, h = p
    return sum(_corner(dx, dy, h) for dx in (x, a - x) for dy in (y, b - y))


def test_the_lookup_is_made_once_per_caster_and_mesh():
    tri = _room()
    caster = RayCaster(tri)
    a = mesh_patches(tri, patch_size=0.25)
    b = mesh_patches(tri, patch_size=0.5)
    assert _locator(a, caster) is _locator(a, caster)
    assert _locator(b, caster) is not _locator(a, caster)
    # a caster of other triangles (fewer than the patches' sources): no exact lookup
    assert _locator(a, RayCaster(tri[:1])) is None


def test_the_padded_product_is_the_sum_over_links_concrete_and_traced():
    # the product runs on padded shapes (a weight-0 link to a point past the last): its answer
    # must still be each point's sum of weight × B over its own links, with B concrete and
    # inside a trace, for counts on and off the padded sizes
    import jax
    import jax.numpy as jnp

    from lumijax.radiosity._gather import GatherOperator

    rng = np.random.default_rng(3)
    # all padded, exactly the room size, none padded, and each axis alone above its size
    for n_points, n_patches, links in ((7, 50, 300), (1024, 4096, 1 << 19), (1500, 5000, 600_000),
                                       (7, 5000, 300), (2000, 60, 200_000), (9, 70, 600_000)):
        op = GatherOperator(n_points, n_patches, rng.integers(0, n_points, links).astype(np.int32),
                            rng.integers(0, n_patches, links).astype(np.int32),
                            rng.random(links))
        b = rng.random((n_patches, 2, 3)).astype(np.float32)
        want = np.zeros((n_points, 2, 3))
        np.add.at(want, op.point, op.weight[:, None, None] * b[op.patch])
        got = np.asarray(op(jnp.asarray(b)))
        traced = np.asarray(jax.jit(lambda x, op=op: op(x))(jnp.asarray(b)))
        assert got.shape == traced.shape == want.shape
        np.testing.assert_allclose(got, want, rtol=2e-5, atol=1e-4)
        np.testing.assert_allclose(traced, want, rtol=2e-5, atol=1e-4)
