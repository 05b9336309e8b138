"""Form factors against the closed forms of /work/shared/reference/form-factors.md (§8)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.kernels import form_factor_point_front_triangle, form_factor_point_triangle
from lumijax.radiosity import FormFactorSettings, build_operator, mesh_patches, partition
from lumijax.scene._raycast import RayCaster

from .conftest import disk, quad, surface_factor


def point_to_quad(p, n, o, u, v):
    t = jnp.asarray(quad(o, u, v))
    f = form_factor_point_triangle(jnp.asarray(p, float), jnp.asarray(n, float), t)
    return float(f.sum())


@pytest.mark.parametrize(
    ("a", "b", "c", "ref"),
    [(1, 1, 1, 0.1385316060), (2, 3, 1.5, 0.1880837353), (0.5, 0.5, 2, 0.0183694087)],
)
def test_point_to_parallel_rectangle(a, b, c, ref):
    # The rectangle faces down (−z) at height c, above the receiver at its corner.
    f = point_to_quad([0, 0, 0], [0, 0, 1], [0, 0, c], [0, b, 0], [a, 0, 0])
    assert f == pytest.approx(ref, rel=1e-9)


@pytest.mark.parametrize(
    ("a", "b", "c", "ref"),
    [(1, 1, 1, 0.1385316060), (2, 3, 1.5, 0.1880837353), (0.5, 0.5, 2, 0.0183694087)],
)
def test_the_unclipped_kernel_on_a_parallel_rectangle(a, b, c, ref):
    # the same closed form through the kernel for sources wholly in front (no clipping)
    t = jnp.asarray(quad([0, 0, c], [0, b, 0], [a, 0, 0]))
    f = form_factor_point_front_triangle(jnp.zeros(3), jnp.asarray([0.0, 0.0, 1.0]), t)
    assert float(f.sum()) == pytest.approx(ref, rel=1e-9)


def test_the_unclipped_kernel_is_the_clipped_one_in_front_and_faces_the_same_way():
    # random triangles every corner of which is in front of the receiver, of either winding
    rng = np.random.default_rng(0)
    p = rng.normal(size=(500, 3))
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    corners = rng.normal(size=(500, 3, 3))
    corners += (0.05 + np.abs(np.einsum("tkc,tc->tk", corners, n)))[..., None] * n[:, None]
    assert np.all(np.einsum("tkc,tc->tk", corners, n) > 0)
    tri = p[:, None] + corners
    args = jnp.asarray(p), jnp.asarray(n), jnp.asarray(tri)
    clipped, unclipped = form_factor_point_triangle(*args), form_factor_point_front_triangle(*args)
    assert 0 < int(np.sum(np.asarray(clipped) == 0)) < 500  # some face away: 0 from both
    np.testing.assert_allclose(np.asarray(unclipped), np.asarray(clipped), rtol=1e-12,
                               atol=1e-15)


@pytest.mark.parametrize("below", [0.0, 1.0])
def test_point_to_perpendicular_rectangle_with_horizon_clipping(below):
    # §2 a=2 b=1 c=0.7; with below=1 the wall extends 1 m under the receiver's plane and the
    # clipped part must not count.
    a, b, c = 2.0, 1.0, 0.7
    f = point_to_quad([0, 0, 0], [0, 0, 1], [c, 0, -below], [0, 0, a + below], [0, b, 0])
    assert f == pytest.approx(0.1296166926, rel=1e-9)


def test_point_to_tilted_parallelogram_and_back_face():
    n = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    o, u, v = [0.5, -1, 1], [1.5, 1, 0.5], [-0.5, 4, 0.2]
    # facing the receiver (normal v × u) ...
    assert point_to_quad([0, 0, 0], n, o, v, u) == pytest.approx(0.2096227883, rel=1e-9)
    # ... and seen from behind, it emits nothing towards the receiver
    assert point_to_quad([0, 0, 0], n, o, u, v) == 0.0


def _lambert_clipped(p, n, tri):
    """Independent reference in numpy float64: Sutherland–Hodgman clipping of the triangle to
    the receiver's front half-space, then Lambert's contour sum over the clipped polygon."""
    r = [np.asarray(v, float) - p for v in tri]
    if np.dot(r[0], np.cross(r[1] - r[0], r[2] - r[0])) >= 0:
        return 0.0  # the receiver is behind the source's front face
    poly = []
    for k in range(3):
        a, b = r[k], r[(k + 1) % 3]
        sa, sb = np.dot(a, n), np.dot(b, n)
        if sa > 0:
            poly.append(a)
        if (sa > 0) != (sb > 0):
            poly.append(a + sa / (sa - sb) * (b - a))
    total = 0.0
    for k in range(len(poly)):
        a, b = poly[k], poly[(k + 1) % len(poly)]
        c = np.cross(a, b)
        cn = np.linalg.norm(c)
        if cn > 0:
            total += np.arctan2(cn, np.dot(a, b)) * np.dot(c, n) / cn
    return abs(total) / (2 * np.pi)


def test_every_way_a_plane_cuts_a_triangle_against_an_independent_clipper():
    # random receivers and triangles around their plane: 0, 1, 2 or 3 corners in front, and
    # corners on the plane (the cut falls on the corner)
    rng = np.random.default_rng(7)
    m = 2000
    p = rng.normal(size=(m, 3))
    n = rng.normal(size=(m, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    tri = p[:, None] + rng.normal(size=(m, 3, 3))
    on = rng.random(m) < 0.2  # one corner moved onto the receiver's plane
    tri[on, 1] -= np.einsum("mc,mc->m", tri[on, 1] - p[on], n[on])[:, None] * n[on]
    got = np.asarray(form_factor_point_triangle(jnp.asarray(p), jnp.asarray(n),
                                                jnp.asarray(tri)))
    want = np.array([_lambert_clipped(p[i], n[i], tri[i]) for i in range(m)])
    ahead = np.einsum("mkc,mc->mk", tri - p[:, None], n) > 0
    counts = np.bincount(ahead.sum(axis=1), minlength=4)
    assert np.all(counts > 100), counts  # every case drawn often
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)


PARALLEL = [  # two a×b rectangles c apart, facing each other
    ("parallel squares c=1 (cube)", (1, 1, 1), 0.1998248957),
    ("parallel rects 2×3 c=1.5", (2, 3, 1.5), 0.3416939135),
]
PERPENDICULAR = [  # l = common edge, w = floor width, h = wall height
    ("perpendicular squares (cube)", (1, 1, 1), 0.2000437761),
    ("perpendicular l=2 w=1 h=3", (2, 1, 3), 0.3081402930),
    ("perpendicular l=3 w=2 h=0.5", (3, 2, 0.5), 0.0974350960),
]


@pytest.mark.parametrize(("name", "abc", "ref"), PARALLEL, ids=[c[0] for c in PARALLEL])
def test_parallel_rectangles(name, abc, ref):
    a, b, c = abc
    f12, f21, a1, a2, _ = surface_factor(
        quad([0, 0, 0], [a, 0, 0], [0, b, 0]), quad([0, 0, c], [0, b, 0], [a, 0, 0]), 0.2
    )
    assert f12 == pytest.approx(ref, rel=0.01)
    assert a1 * f12 == pytest.approx(a2 * f21, rel=0.02)


@pytest.mark.parametrize(("name", "lwh", "ref"), PERPENDICULAR, ids=[c[0] for c in PERPENDICULAR])
def test_perpendicular_rectangles_with_common_edge(name, lwh, ref):
    ln, w, h = lwh
    floor = quad([0, 0, 0], [w, 0, 0], [0, ln, 0])  # normal +z
    wall = quad([0, 0, 0], [0, ln, 0], [0, 0, h])  # normal +x
    f12, f21, a1, a2, _ = surface_factor(floor, wall, 0.25)
    assert f12 == pytest.approx(ref, rel=0.01)
    assert a1 * f12 == pytest.approx(a2 * f21, rel=0.02)


@pytest.mark.parametrize("symmetrise", [True, False])
def test_a_shadow_across_a_near_pair_is_weighed_where_the_kernel_is(symmetrise):
    # A 1 × 1 wall on a floor 2 m deep, and a screen 2 m tall standing on the floor 1 m out:
    # the wall sees exactly the floor's first metre, the cube's wall-to-floor factor (§8). Whole
    # triangles as patches, so each wall-floor pair is a near pair half in shadow; the product
    # of the unblocked factor and the fraction of clear rays read 0.146 here (−27 %). Now one way
    # reads −0.2 % (the unshadowed cube's whole triangles: the same), symmetrised −1.5 % (the
    # floor's points in the light are half of them: a coarser quadrature of the way back).
    wall = quad([0, 0, 0], [0, 1, 0], [0, 0, 1])  # normal +x
    floor = quad([0, 0, 0], [2, 0, 0], [0, 1, 0])  # normal +z
    screen = quad([1, -1, 0], [0, 0, 2], [0, 3, 0])  # facing the wall (−x)
    tri = np.concatenate([wall, floor, screen])
    p = mesh_patches(tri, group=np.repeat([0, 1, 2], 2), patch_size=3.0)
    assert (p.group < 2).sum() == 4  # whole: the floor's pieces meet the screen's foot on an edge
    caster = RayCaster(tri)
    op = build_operator(p, partition(p, 1024, occluders=caster), caster,
                        FormFactorSettings(symmetrise=symmetrise), occluder_triangles=tri)
    assert op.info["shadowed_near_pairs"] > 0
    w, f = p.group == 0, p.group == 1
    g = p.area[:, None] * op.todense()
    assert g[np.ix_(w, f)].sum() / p.area[w].sum() == pytest.approx(0.2000437761, rel=0.02)


def test_a_patch_cut_by_its_partners_plane_leaves_the_pair_to_the_partners_quadrature():
    # A 1 × 1 fin standing across a 4 × 1 floor, 1 m of it in front and 3 m behind: the fin
    # sees the cube's wall-to-floor factor (§8). The floor's points average a step (nothing
    # behind the fin's plane, the factor near its foot in front), so the symmetrised mean read
    # 5.6 % low; the fin's own points, exact in the floor, read 0.16 % low.
    fin = quad([0, 0, 0], [0, 1, 0], [0, 0, 1])  # normal +x
    floor = quad([-3, 0, 0], [4, 0, 0], [0, 1, 0])  # normal +z
    p = mesh_patches(np.concatenate([fin, floor]), group=np.repeat([0, 1], 2), patch_size=5.0)
    assert p.n == 4
    op = build_operator(p, partition(p, 1024), None)
    g = p.area[:, None] * op.todense()
    w, f = p.group == 0, p.group == 1
    assert g[np.ix_(w, f)].sum() / p.area[w].sum() == pytest.approx(0.2000437761, rel=0.005)


@pytest.mark.parametrize(
    ("r1", "r2", "h", "ref"), [(1, 1, 1, 0.3819660113), (0.5, 2, 1, 0.7917560805)]
)
def test_coaxial_disks(r1, r2, h, ref):
    f12, f21, a1, a2, _ = surface_factor(disk([0, 0, 0], r1, True), disk([0, 0, h], r2, False), 0.3)
    assert f12 == pytest.approx(ref, rel=0.01)
    assert a1 * f12 == pytest.approx(a2 * f21, rel=0.02)


def test_patch_reciprocity_is_exact_by_construction(cube_room):
    p, _, op = cube_room
    g = p.area[:, None] * op.todense()
    assert np.allclose(g, g.T, rtol=1e-5, atol=1e-9)
    assert np.all(np.diag(g) == 0)


def test_closure_cube_room(cube_room):
    _, part, op = cube_room
    rows = np.asarray(op.row_sums())
    assert np.all(np.abs(rows - 1) < 0.01), (rows.min(), rows.max())
    # Face-to-face factors of the meshed cube (Howell §3/§4) come out of the same operator.
    assert part.stats["visible_pairs"] > 0


def test_closure_inward_icosphere(sphere_room):
    _, _, op = sphere_room
    rows = np.asarray(op.row_sums())
    assert np.all(np.abs(rows - 1) < 0.01), (rows.min(), rows.max())


def test_open_scene_row_sums_are_the_exchange():
    f12, _, _, _, op = surface_factor(
        quad([0, 0, 0], [1, 0, 0], [0, 1, 0]), quad([0, 0, 1], [0, 1, 0], [1, 0, 0]), 0.25
    )
    rows = np.asarray(op.row_sums())
    assert np.mean(rows) == pytest.approx(f12, rel=1e-6)  # equal areas: mean row sum = F12
