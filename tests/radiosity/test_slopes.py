"""The gather's linear radiosity (radiosity/_slopes.py): each patch's slope fitted from its
neighbours, and a point close to a wall gathering it.

Checked against closed forms and a quadrature written here: a linear field's gradient is
recovered exactly; the irradiance of a point 0.15 m from a wall whose radiosity varies linearly
is the integral ∫ B(y) cos θ cos θ' / (π r²) dA, summed on a 1 cm grid (independent of the
patches and rays)."""

from __future__ import annotations

import numpy as np

from lumijax.radiosity import build_gather, mesh_patches, patch_slopes
from lumijax.scene import RayCaster

FLOOR = np.array([[[0, 0, 0], [4, 0, 0], [4, 4, 0]], [[0, 0, 0], [4, 4, 0], [0, 4, 0]]],
                 np.float64)
# a 4 × 3 m wall in the plane x = 0, facing +x
WALL = np.array([[[0, 0, 0], [0, 4, 0], [0, 4, 3]], [[0, 0, 0], [0, 4, 3], [0, 0, 3]]],
                np.float64)


def _wall_b(c):
    """Radiosity (lm/m²) linear on the wall: brighter up and along it."""
    return 10.0 + 20.0 * c[:, 2] + 5.0 * c[:, 1]


def test_a_linear_field_gives_its_gradient_and_a_constant_none():
    patches = mesh_patches(FLOOR, patch_size=0.5)
    slopes = patch_slopes(patches)
    g = slopes(3.0 + 0.7 * patches.centroid[:, 0] - 0.4 * patches.centroid[:, 1])
    fitted = np.any(g != 0.0, axis=1)
    assert fitted.mean() > 0.95  # the patches whose neighbours span the plane: nearly all
    np.testing.assert_allclose(g[fitted], np.broadcast_to([0.7, -0.4, 0.0], g[fitted].shape),
                               atol=1e-9)
    np.testing.assert_allclose(slopes(np.full(patches.n, 5.0)), 0.0, atol=1e-12)


def test_neighbours_share_the_plane_and_the_material():
    """Floor patches of two materials beside a wall: each fit sees its own material's plane
    only, whatever the others hold."""
    tri = np.concatenate([FLOOR, WALL[:, :, [1, 0, 2]][:, ::-1]])  # a wall along y = 0
    patches = mesh_patches(tri, np.array([0, 1, 2, 2]), patch_size=0.5)
    rng = np.random.default_rng(3)
    c = patches.centroid
    b = np.where(patches.material == 0, 1.0 + 2.0 * c[:, 0], 7.0 - 3.0 * c[:, 1])
    wall = patches.material == 2
    b[wall] = rng.uniform(0.0, 100.0, wall.sum())
    g = patch_slopes(patches)(b)
    for m, want in ((0, [2.0, 0.0, 0.0]), (1, [0.0, -3.0, 0.0])):
        mine = (patches.material == m) & np.any(g != 0.0, axis=1)
        assert mine.sum() > 0.8 * (patches.material == m).sum()
        np.testing.assert_allclose(g[mine], np.broadcast_to(want, g[mine].shape), atol=1e-9)


def _exact_wall_irradiance(points):
    """∫ B cos θ cos θ' / (π r²) dA over the wall, for points facing it (normal −x), on a 1 cm
    midpoint grid."""
    h = 0.01
    y, z = np.meshgrid(np.arange(h / 2, 4, h), np.arange(h / 2, 3, h), indexing="ij")
    y, z = y.ravel(), z.ravel()
    b = _wall_b(np.c_[np.zeros_like(y), y, z])
    out = []
    for p in points:
        r2 = p[0] ** 2 + (y - p[1]) ** 2 + (z - p[2]) ** 2
        out.append(np.sum(b * p[0] ** 2 / (np.pi * r2 * r2)) * h * h)
    return np.array(out)


def test_a_point_near_a_wall_reads_its_linear_radiosity():
    """Points 0.15 m from a wall of 0.5 m patches: a constant B per patch misses the integral
    by up to 1.6 %; read linearly across each patch it is within 0.03 % (16,384 rays; 0.12 %
    at 4,096, the rays' own noise), and every point's weights still sum to what the wall
    covers of its hemisphere."""
    patches = mesh_patches(WALL, patch_size=0.5)
    caster = RayCaster(WALL)
    points = np.array([[0.15, y, z] for y in (0.6, 1.3, 2.05, 2.9) for z in (0.4, 1.1, 1.7, 2.5)])
    normals = np.tile([-1.0, 0.0, 0.0], (len(points), 1))
    exact = _exact_wall_irradiance(points)
    b = _wall_b(patches.centroid)

    def read(gather):
        return np.bincount(gather.point, weights=gather.weight * b[gather.patch],
                           minlength=len(points))

    constant = build_gather(points, normals, patches, caster, rays=16384)
    linear = build_gather(points, normals, patches, caster, rays=16384,
                          slopes=patch_slopes(patches))
    err_c = np.abs(read(constant) / exact - 1)
    err_l = np.abs(read(linear) / exact - 1)
    assert err_c.max() > 0.01
    assert err_l.max() < 0.001
    assert err_l.max() < 0.1 * err_c.max()
    np.testing.assert_allclose(linear.coverage, constant.coverage, atol=1e-12)


def test_a_large_mesh_finds_the_same_neighbours(monkeypatch):
    """A small mesh compares every pair, a large one asks k-d trees by size class: the same
    slopes either way, on patches of two sizes (a refined corner)."""
    import lumijax.radiosity._slopes as sl

    small = mesh_patches(WALL + [4.0, 0.0, 0.0], patch_size=0.12).vertices  # 0.12 m triangles
    tri = np.concatenate([FLOOR, WALL[:, :, [1, 0, 2]][:, ::-1], small])
    mesh = mesh_patches(tri, np.r_[0, 0, 1, 1, np.full(len(small), 2)], patch_size=0.5)
    assert mesh.diameter.max() > 3 * mesh.diameter.min()
    brute = sl.patch_slopes(mesh)
    monkeypatch.setattr(sl, "_BRUTE_FORCE_PAIRS", 0)
    tree = sl.patch_slopes(mesh)
    np.testing.assert_array_equal(brute.start, tree.start)
    np.testing.assert_array_equal(brute.col, tree.col)
    np.testing.assert_allclose(brute.coef, tree.coef, rtol=1e-12, atol=1e-12)


def test_a_far_point_reads_each_patch_constant():
    """Seen from farther than SLOPE_DISTANCE of its edges, a patch's slope is not read: the
    linear gather's links are the constant gather's, weight for weight; moved within reach,
    the same point's links change."""
    from lumijax.radiosity._gather import SLOPE_DISTANCE

    patches = mesh_patches(WALL, patch_size=0.5)
    caster = RayCaster(WALL)
    slopes = patch_slopes(patches)
    normals = np.array([[-1.0, 0.0, 0.0]])
    far = np.array([[SLOPE_DISTANCE * patches.diameter.max() + 0.5, 2.0, 1.5]])
    constant = build_gather(far, normals, patches, caster, rays=4096)
    linear = build_gather(far, normals, patches, caster, rays=4096, slopes=slopes)
    assert len(constant.weight) > 0
    np.testing.assert_array_equal(linear.patch, constant.patch)
    np.testing.assert_allclose(linear.weight, constant.weight, rtol=1e-12)
    near = np.array([[1.0, 2.0, 1.5]])
    moved = build_gather(near, normals, patches, caster, rays=4096, slopes=slopes)
    plain = build_gather(near, normals, patches, caster, rays=4096)
    assert len(moved.weight) != len(plain.weight) or not np.allclose(moved.weight, plain.weight)
