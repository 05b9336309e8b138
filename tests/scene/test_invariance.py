"""Results do not depend on where the model sits or on its unit (project issue 12 §2).

The same room (an inward box with a solid block on the floor, an isotropic point luminaire, a
luminous ceiling panel) is placed by a group frame at site coordinates up to 10⁷ m, and scaled
uniformly by s from 10⁻⁶ to 10³ with every source's flux × s² (E = I cos θ / d² and the form
factors are then unchanged). Direct and total illuminance on a floor grid and a wall grid must
equal the run at the origin, as properties. Before the fix the room read 5 % high at
(5·10⁵, 5·10⁶) m, 34 % off at 10⁷ m, and the 4 µm model 55 % off (float32 kernels, absolute
epsilons in metres).

The float32 runs switch JAX's 64-bit mode off, as a user's process has it (the test suite runs
in float64): that is where ``point − position`` at site coordinates lost its metres.
"""

from __future__ import annotations

import warnings

import helpers as h
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import lumijax
from lumijax.direct import direct_illuminance
from lumijax.errors import GeometryError
from lumijax.kernels import offset_illuminance
from lumijax.lighting._pipeline import auto_patch_size
from lumijax.photometry import isotropic
from lumijax.radiosity import build_operator, mesh_patches, partition
from lumijax.radiosity._gather import build_gather
from lumijax.radiosity._partition import bisection_order
from lumijax.scene import RayCaster
from lumijax.scene._geometry import box_triangles, check_triangles, triangle_shape

TOL = {"float64": 1e-4, "float32": 2e-3}


def _study(offset=(0.0, 0.0, 0.0), s=1.0, precision="float32") -> str:
    # the block's corners are generic on purpose: a ray lying exactly in a face's plane (a patch
    # row's centroids at the block's top height) is decided by float32 rounding at any
    # position; see docs/conventions.md, "Tolerances"
    site = {"group": "site"}
    return h.study_text(
        h.table("solver", target_patches=200, gather_rays=48, spectral_samples=0, cache=False,
                precision=precision),
        h.table("groups.site", translate=list(offset), scale=s),
        h.material("wall", 0.6), h.photometry("iso", "isotropic", 1000.0 * s * s),
        h.network("main", 1.0), h.network("panel", 0.5),
        h.box([0, 0, 0], [4, 4, 3], **site),
        h.box([1.0713, 0.9687, 0], [1.6291, 1.5742, 0.8317], normals="outward", **site),
        h.lamp("L", [2.5, 2.3, 2.6], "main", **site),
        h.area_lamp("P", [0.6, 2.9, 2.99], [0, 0.5, 0], [0.7, 0, 0], 500.0 * s * s, "panel", **site),
        h.plane_grid("floor", [0.05, 0.05, 0.01], [3.9, 0, 0], [0, 3.9, 0], nu=6, nv=6, **site),
        h.point_grid("wall", [[3.99, 0.7, 1.0], [3.99, 2.1, 2.2], [3.99, 3.3, 0.4]], [-1, 0, 0],
                     **site))


@pytest.fixture
def x64_as(request):
    """JAX's 64-bit mode for the test's precision, restored after it."""
    prev = jax.config.read("jax_enable_x64")

    def use(precision: str) -> None:
        jax.config.update("jax_enable_x64", precision == "float64")

    yield use
    jax.config.update("jax_enable_x64", prev)


_CACHE: dict = {}


def _grids(tmp_path_factory, precision, offset=(0.0, 0.0, 0.0), s=1.0):
    """``{grid: (direct, total)}`` lx at the config's dimmers."""
    key = (precision, tuple(offset), s)
    if key not in _CACHE:
        path = tmp_path_factory.mktemp("inv") / "study.toml"
        path.write_text(_study(offset, s, precision), encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", lumijax.LumijaxWarning)
            res = lumijax.compute(lumijax.load_study(path))
        _CACHE[key] = {
            name: (np.asarray(g.dimmers) @ np.asarray(g.direct_by_network_lux),
                   np.asarray(g.illuminance_lux))
            for name, g in res.grids.items()
        }
    return _CACHE[key]


def _assert_same(got, ref, tol):
    for name, (d0, t0) in ref.items():
        d, t = got[name]
        assert np.all(np.isfinite(d)) and np.all(np.isfinite(t))
        # relative to the grid's brightest point: the block's shadow reads near zero
        assert np.max(np.abs(d - d0)) <= tol * np.max(d0), (name, "direct", d, d0)
        assert np.max(np.abs(t - t0)) <= tol * np.max(t0), (name, "total", t, t0)
        assert np.max(t0 - d0) > 0.1 * np.max(t0)  # inter-reflection is part of what is compared


# End to end, as a user runs it (float32, JAX's 64-bit mode off): the whole pipeline, direct
# and inter-reflected, at the hardest positions and scales. Each run costs a solve, so the
# other positions and scales are checked stage by stage below (in float64, no solve).
@pytest.mark.parametrize("offset, s", [((5e5, 5e6, 0), 1.0), ((1e7, 1e7, 0), 1.0),
                                       ((0, 0, 0), 1e-6)], ids=["5e5_5e6", "1e7", "s1e-6"])
def test_the_room_reads_the_same_anywhere_and_at_any_scale(tmp_path_factory, x64_as, offset, s):
    x64_as("float32")
    ref = _grids(tmp_path_factory, "float32")
    _assert_same(_grids(tmp_path_factory, "float32", offset=offset, s=s), ref, TOL["float32"])


def _stages(tmp_path_factory, offset=(0.0, 0.0, 0.0), s=1.0):
    """Every coordinate-dependent stage of the float64 pipeline, no solve: patches, blocks,
    the form factors ``F`` (dense), the point and patch direct light, the gather weights."""
    key = ("stages", tuple(offset), s)
    if key not in _CACHE:
        path = tmp_path_factory.mktemp("stg") / "study.toml"
        path.write_text(_study(offset, s, "float64"), encoding="utf-8")
        sc = lumijax.load_study(path).scene
        tri = sc.triangles
        pts = np.concatenate([g.points for g in sc.grids])
        nrm = np.concatenate([g.normals for g in sc.grids])
        patches = mesh_patches(tri.vertices, tri.material, tri.group,
                               patch_size=auto_patch_size(float(tri.areas.sum()), 200))
        part = partition(patches, max_block=32, occluders=sc.raycaster)  # several blocks
        op = build_operator(patches, part, sc.raycaster, dtype=np.float64,
                            occluder_triangles=tri.vertices)
        gather = build_gather(pts, nrm, patches, sc.raycaster, rays=48)
        _CACHE[key] = dict(
            n=patches.n, blocks=part.n_blocks, pairs=len(part.pairs),
            F=op.todense(),  # form factors: dimensionless, the same at every scale
            direct=direct_illuminance(sc, pts, nrm).by_network,
            patch_direct=direct_illuminance(sc, patches.centroid, patches.normal).by_network,
            gather=(gather.point, gather.patch, gather.weight),
        )
    return _CACHE[key]


@pytest.mark.parametrize("offset, s", [((1e3, 0, 0), 1.0), ((5e5, 0, 0), 1.0),
                                       ((5e5, 5e6, 0), 1.0), ((1e7, 1e7, 0), 1.0),
                                       ((0, 0, 0), 1e-6), ((0, 0, 0), 1e-3), ((0, 0, 0), 1e3)],
                         ids=["1e3", "5e5", "5e5_5e6", "1e7", "s1e-6", "s1e-3", "s1e3"])
def test_every_stage_is_the_same_anywhere_and_at_any_scale(tmp_path_factory, offset, s):
    """Float64: the same patches and blocks, the same form factors, the same direct
    light on points and patches and the same gather rays: so the same solve and the same lux."""
    ref, got = _stages(tmp_path_factory), _stages(tmp_path_factory, offset, s)
    assert (got["n"], got["blocks"], got["pairs"]) == (ref["n"], ref["blocks"], ref["pairs"])
    assert ref["blocks"] >= 6 and ref["F"].max() > 0
    tol = TOL["float64"]
    for k in ("direct", "patch_direct"):
        assert np.max(np.abs(got[k] - ref[k])) <= tol * np.max(ref[k]), k
    # the first bounce, F·E_direct (lx per unit reflectance): what the grids get from the patches
    bounce = ref["F"] @ ref["patch_direct"].T
    assert np.max(np.abs(got["F"] @ got["patch_direct"].T - bounce)) <= tol * np.max(bounce)
    np.testing.assert_allclose(got["F"].sum(axis=1), ref["F"].sum(axis=1), rtol=tol)
    # entry by entry, a grazing visibility ray (a quadrature point a hair in front of the face
    # the ray ends on) may flip with float32 rounding at any scale: one ray of four in a few
    # small entries (docs/conventions.md, "Tolerances")
    assert np.max(np.abs(got["F"] - ref["F"])) <= 10 * tol * np.max(ref["F"])
    for a, b in zip(got["gather"], ref["gather"], strict=True):
        np.testing.assert_array_equal(a, b)


def test_direct_light_at_1e7_m_in_float32_meets_the_closed_form(x64_as):
    """I cos θ / d² by hand, in float64 numpy, against the float32 kernel fed site offsets."""
    x64_as("float32")
    site = np.array([1e7, 1e7, 0.0])
    iso = isotropic(1000.0).distribution  # I = 1000 / 4π cd
    pos = site + [2.0, 2.0, 2.5]
    pts = site + np.stack(np.meshgrid(np.linspace(0, 4, 5), np.linspace(0, 4, 5)), -1).reshape(
        -1, 2) @ np.eye(2, 3)
    nrm = np.tile([0.0, 0.0, 1.0], (len(pts), 1))
    d = pts - pos
    r = np.linalg.norm(d, axis=1)
    truth = 1000.0 / (4 * np.pi) * 2.5 / r**3
    e = offset_illuminance(iso, jnp.asarray(d, jnp.float32), jnp.eye(3)[None],
                           jnp.ones(1), jnp.asarray(nrm, jnp.float32),
                           jnp.zeros(len(pts), jnp.int32), jnp.arange(len(pts)))
    np.testing.assert_allclose(np.asarray(e, np.float64), truth, rtol=1e-5)


@pytest.mark.parametrize("site, s", [((0, 0, 0), 1.0), ((5e5, 5e6, 0), 1.0), ((0, 0, 0), 1e-6),
                                     ((3e6, -4e6, 120.0), 1e-3)])
def test_shadow_and_first_hit_rays_resolve_a_thin_wall_anywhere(site, s):
    """A wall 1/1000 of the room thick, 10⁻³ of the room from a receiver: a shadow ray that
    passes through it is blocked, one that passes beside it is not, and a first-hit ray meets
    it at the distance worked out by hand, whatever the position and unit."""
    site = np.asarray(site, float)
    room = box_triangles([0, 0, 0], [4, 4, 3], inward=True)
    wall = box_triangles([2.0, 0.0, 0.0], [2.004, 3.0, 3.0], inward=False)
    caster = RayCaster(site + s * np.concatenate([room, wall]))
    a = site + s * np.array([[1.0, 1.0, 1.0], [1.0, 3.5, 1.0]])
    b = site + s * np.array([[3.0, 1.0, 1.0], [3.0, 3.5, 1.0]])
    assert caster.occluded(a, b).tolist() == [True, False]
    tri, dist = caster.first_hit(a, np.array([[1.0, 0, 0], [1.0, 0, 0]]))
    np.testing.assert_allclose(dist / s, [1.0, 3.0], rtol=1e-5)  # the wall, then the room
    # a receiver on the floor 1/1000 of the room from the wall still sees the ceiling
    p = site + s * np.array([[1.996, 1.0, 0.0]])
    assert not caster.occluded(p, p + s * np.array([[0.0, 0.0, 3.0]]))[0]


def test_one_degeneracy_rule_for_the_scene_and_the_mesh_in_any_unit():
    """``triangle_shape`` is the rule both use; it depends on shape, not size or position."""
    good = np.array([[[0, 0, 0], [1, 0, 0], [0, 1e-6, 0]]], float)  # thin but a real normal
    bad = np.array([[[0, 0, 0], [1, 0, 0], [0, 1e-10, 0]]], float)  # height 1e-10 of its length
    for s, site in [(1.0, 0.0), (1e-6, 0.0), (1e3, 0.0), (1.0, 5e6)]:
        _, _, deg = triangle_shape(site + s * np.concatenate([good, bad]))
        assert deg.tolist() == [False, True], (s, site)
        check_triangles(site + s * good, key="k")
        with pytest.raises(GeometryError, match="triangle 0 has zero area"):
            check_triangles(site + s * bad, key="k")
        with pytest.raises(GeometryError, match="triangle 0 is degenerate"):
            mesh_patches(site + s * bad, patch_size=s)
        assert mesh_patches(site + s * good, patch_size=s).n >= 1
    # a micrometre facet at 10⁷ m is below the rounding of its own coordinates
    tiny = 1e7 + np.array([[[0, 0, 0], [1e-9, 0, 0], [0, 1e-9, 0]]])
    assert triangle_shape(tiny)[2].tolist() == [True]


def test_mesh_and_blocks_are_the_same_wherever_the_model_sits():
    """Patch counts and the bisection that makes blocks do not change with position, even on
    the ties a regular mesh is full of (a square room's equal sides, rows of equal centroids)."""
    room = box_triangles([0, 0, 0], [4, 4, 3], inward=True)
    ref = mesh_patches(room, patch_size=0.5)
    for site in ([5e5, 5e6, 0.0], [1e7, 1e7, 0.0]):
        p = mesh_patches(room + np.asarray(site), patch_size=0.5)
        assert p.n == ref.n  # 4 m / 0.5 m = 8 per edge, although 4 m carries 1e-9 m rounding
        np.testing.assert_allclose(p.centroid - site, ref.centroid, atol=1e-6)
        assert np.array_equal(bisection_order(p.centroid), bisection_order(ref.centroid))
    for s in (1e-6, 1e3):
        p = mesh_patches(room * s, patch_size=0.5 * s)
        assert p.n == ref.n
        assert np.array_equal(bisection_order(p.centroid), bisection_order(ref.centroid))
