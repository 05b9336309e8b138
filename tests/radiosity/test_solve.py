"""Radiosity solves against exact enclosure identities (form-factors.md §9) and autodiff."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import pytest
import trimesh
from helpers import central_difference

from lumijax.errors import SolveError
from lumijax.radiosity import (
    build_operator,
    mesh_patches,
    partition,
    solve_radiosity,
    subdivide_triangles,
)

from .conftest import quad, surface_factor


def test_furnace_cube(cube_room):
    # Every surface emits M_e and reflects ρ: B = M_e / (1 − ρ) everywhere, exactly.
    p, _, op = cube_room
    m_e, rho = 100.0, 0.5
    sol = solve_radiosity(op, jnp.full(p.n, rho, jnp.float32), jnp.full((p.n, 2), m_e, jnp.float32))
    b = np.asarray(sol.value)
    assert np.all(np.abs(b / (m_e / (1 - rho)) - 1) < 0.01)
    assert np.all(np.asarray(sol.escaped) < 0.01)


def _direct_on_sphere(p, flux):
    """Irradiance (lx) of an isotropic point source at the centre, averaged over each patch."""
    pts = subdivide_triangles(p.vertices, 4).mean(axis=2)  # 16 sub-triangle centroids each
    d2 = np.sum(pts**2, axis=-1)
    cos = -np.sum(pts * p.normal[:, None], axis=-1) / np.sqrt(d2)  # inward normals face it
    return (flux / (4 * np.pi) * cos / d2).mean(axis=1)


@pytest.mark.parametrize("rho", [0.2, 0.5, 0.8])
def test_integrating_sphere(sphere_room, rho):
    p, _, op = sphere_room
    flux = 1000.0
    e_d = _direct_on_sphere(p, flux)
    b0 = jnp.asarray((rho * e_d)[:, None], jnp.float32)
    sol = solve_radiosity(op, jnp.full(p.n, rho, jnp.float32), b0)
    e = e_d + np.asarray(op.matmul(sol.value))[:, 0]
    ref = flux / (p.area.sum() * (1 - rho))
    mean = np.sum(e * p.area) / p.area.sum()
    assert mean == pytest.approx(ref, rel=0.01)
    assert np.all(np.abs(e / ref - 1) < 0.03)


def test_many_columns_with_spectral_reflectance(cube_room):
    # (P, networks, wavelengths) right-hand sides with per-wavelength ρ: each column equals a
    # solve of that column alone.
    p, _, op = cube_room
    rng = np.random.default_rng(0)
    b0 = jnp.asarray(rng.random((p.n, 3, 4)), jnp.float32)
    rho = jnp.asarray(rng.uniform(0.2, 0.7, (p.n, 1, 4)), jnp.float32)
    full = solve_radiosity(op, rho, b0).value
    one = solve_radiosity(op, rho[:, 0, 2], b0[:, 1, 2]).value
    assert np.allclose(full[:, 1, 2], one, rtol=1e-3, atol=1e-5)


@pytest.fixture(scope="module")
def small_cube():
    m = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    m.invert()
    p = mesh_patches(m.triangles, patch_size=0.5)
    return p, build_operator(p, partition(p, 64), None)


def test_gradients_match_finite_differences(small_cube, method="bicgstab"):
    # Reverse mode goes through lineax's adjoint solve with our Kᵀ = Fᵀρ: a wrong transpose
    # would show here. (GMRES shares the operator and the adjoint machinery.)
    p, op = small_cube
    rng = np.random.default_rng(1)
    b0 = jnp.asarray(rng.random((p.n, 2)))
    rho = jnp.asarray(rng.uniform(0.3, 0.8, p.n))
    w = jnp.asarray(rng.random((p.n, 2)))

    @jax.jit
    def loss(b0, rho):
        return jnp.sum(w * solve_radiosity(op, rho, b0, method=method).value)

    g_b0, g_rho = jax.grad(loss, argnums=(0, 1))(b0, rho)
    ks = (0, 17, p.n - 1)
    fd_rho = central_difference(lambda r: loss(b0, r), rho, indices=ks)
    fd_b0 = central_difference(lambda b: loss(b, rho), b0, indices=[2 * k + 1 for k in ks])
    for k, fd, fd2 in zip(ks, fd_rho, fd_b0, strict=True):
        assert float(g_rho[k]) == pytest.approx(float(fd), rel=1e-6)
        assert float(g_b0[k, 1]) == pytest.approx(float(fd2), rel=1e-6)


@pytest.mark.parametrize("rho", [0.5, 0.95])
def test_solver_comparison(cube_room, rho, capsys):
    p, _, op = cube_room
    b0 = jnp.asarray(np.random.default_rng(0).random((p.n, 4)), jnp.float32)
    r = jnp.full(p.n, rho, jnp.float32)
    out = {m: solve_radiosity(op, r, b0, method=m) for m in ("bicgstab", "gmres", "jacobi", "southwell")}
    ref = out["bicgstab"].value
    for m, sol in out.items():
        assert sol.result == lx.RESULTS.successful
        assert np.allclose(sol.value, ref, rtol=2e-3 / (1 - rho), atol=1e-6), m
    its = {m: int(s.iterations) for m, s in out.items()}
    with capsys.disabled():
        print(f"\nρ={rho}: operator products / shots {its}")
    if rho == 0.95:
        assert its["bicgstab"] * 5 < its["jacobi"]  # Krylov does not slow down like Jacobi


def test_reflectance_of_one_in_closed_room_is_refused(cube_room):
    p, _, op = cube_room
    with pytest.raises(SolveError, match="closed enclosure"):
        solve_radiosity(op, jnp.full(p.n, 1.0), jnp.ones((p.n, 1)))
    with pytest.raises(SolveError, match="≥ 0"):
        solve_radiosity(op, jnp.full(p.n, -0.1), jnp.ones((p.n, 1)))


def test_non_convergence_names_the_tolerance(cube_room):
    p, _, op = cube_room
    with pytest.raises(SolveError, match="rtol=1e-07"):
        solve_radiosity(op, jnp.full(p.n, 0.9), jnp.ones((p.n, 1)), method="jacobi", max_steps=3,
                        rtol=1e-7)
    sol = solve_radiosity(op, jnp.full(p.n, 0.9), jnp.ones((p.n, 1)), method="jacobi",
                          max_steps=3, rtol=1e-7, throw=False)
    assert sol.result != lx.RESULTS.successful


def test_open_scene_reports_escaping_light_and_blind_patches_are_fine():
    t1 = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    t2 = quad([0, 0, 1], [0, 1, 0], [1, 0, 0])
    t3 = quad([5, 5, 0], [0, 1, 0], [1, 0, 0])  # faces down into nothing: sees no patch
    f12, *_ = surface_factor(t1, t2, 0.25)
    tri = np.concatenate([t1, t2, t3])
    p = mesh_patches(tri, group=np.repeat([0, 1, 2], 2), patch_size=0.25)
    op = build_operator(p, partition(p, 256, occluders=tri), tri)
    sol = solve_radiosity(op, jnp.full(p.n, 0.5), jnp.ones((p.n, 1)))
    blind = p.group == 2
    assert np.allclose(np.asarray(sol.value)[blind], 1.0)
    # every patch emits alike: the escaping fraction is 1 − the mean exchange (≈ 1 − F12)
    assert float(sol.escaped[0]) == pytest.approx(1 - 2 * f12 / 3, rel=0.05)
