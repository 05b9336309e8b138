"""Radiosity solves against exact enclosure identities (form-factors.md §9) and autodiff."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import pytest
import trimesh
from helpers import central_difference

from lumijax.errors import ConfigError, SolveError
from lumijax.radiosity import (
    GMRES,
    RADIOSITY_SOLVERS,
    AbstractRadiositySolver,
    BiCGStab,
    Refined,
    build_operator,
    mesh_patches,
    partition,
    radiosity_solver,
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
    # solve of that column alone. 2 × 2 columns: the compiled solve of the tests around it (four
    # columns), and every column is checked, so ρ taken along the wrong axis would show.
    p, _, op = cube_room
    rng = np.random.default_rng(0)
    b0 = jnp.asarray(rng.random((p.n, 2, 2)), jnp.float32)
    rho = jnp.asarray(rng.uniform(0.2, 0.7, (p.n, 1, 2)), jnp.float32)
    full = solve_radiosity(op, rho, b0).value
    for s in range(2):
        for w in range(2):
            one = solve_radiosity(op, rho[:, 0, w], b0[:, s, w]).value
            assert np.allclose(full[:, s, w], one, rtol=1e-3, atol=1e-5), (s, w)


@pytest.fixture(scope="module")
def small_cube():
    m = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    m.invert()
    p = mesh_patches(m.triangles, patch_size=0.5)
    return p, build_operator(p, partition(p, 64), None)


@pytest.fixture(scope="module")
def weighted_sum(small_cube):
    """``Σ w·B`` of the small cube's solve, jitted once for the module so that the two gradient
    tests below share its compiled programs (the value, and its derivative in ρ and B₀) per
    method; the operator is a constant of the program, as in a closure."""
    _, op = small_cube

    @functools.partial(jax.jit, static_argnames="method")
    def fn(rho, b0, w, method):
        return jnp.sum(w * solve_radiosity(op, rho, b0, method=method).value)

    return fn


@pytest.mark.parametrize("method", ["refined", "bicgstab"])
def test_gradients_match_finite_differences(small_cube, weighted_sum, method):
    # Reverse mode goes through lineax's adjoint solve with our Kᵀ = Fᵀρ: a wrong transpose
    # would show here. The refined solve is a lineax solver too, so lineax differentiates it
    # implicitly (the adjoint runs the same refinement on Kᵀ). (GMRES shares the machinery.)
    p, _ = small_cube
    rng = np.random.default_rng(1)
    b0 = jnp.asarray(rng.random((p.n, 2)))
    rho = jnp.asarray(rng.uniform(0.3, 0.8, p.n))
    w = jnp.asarray(rng.random((p.n, 2)))

    def loss(b0, rho):
        return weighted_sum(rho, b0, w, method)

    g_b0, g_rho = jax.grad(loss, argnums=(0, 1))(b0, rho)
    ks = (0, 17, p.n - 1)
    fd_rho = central_difference(lambda r: loss(b0, r), rho, indices=ks)
    fd_b0 = central_difference(lambda b: loss(b, rho), b0, indices=[2 * k + 1 for k in ks])
    for k, fd, fd2 in zip(ks, fd_rho, fd_b0, strict=True):
        assert float(g_rho[k]) == pytest.approx(float(fd), rel=1e-6)
        assert float(g_b0[k, 1]) == pytest.approx(float(fd2), rel=1e-6)


@pytest.mark.parametrize("method", ["refined", "bicgstab", "gmres"])
def test_adjoint_is_independent_of_the_right_hand_side_and_of_scale(small_cube, weighted_sum,
                                                                   method):
    # ∂(w·B)/∂B₀ = (I − K)⁻ᵀ w is the same at every B₀, zero included, and scales with w. The
    # adjoint's right-hand side is w, not B₀: a tolerance fixed for a unit B₀ stopped a tiny w's
    # adjoint at once (the aim model's first gradient, at a zero change of light, lost its
    # inter-reflected part).
    p, _ = small_cube
    rng = np.random.default_rng(2)
    rho = jnp.asarray(rng.uniform(0.3, 0.8, p.n))
    w = jnp.asarray(rng.random((p.n, 2)))

    def grad_b0(b0, scale):
        # the adjoint's right-hand side is scale · w either way; differentiated in ρ as well
        # (unused) only to reuse test_gradients_match_finite_differences' compiled derivative
        return jax.grad(weighted_sum, argnums=(0, 1))(rho, b0, scale * w, method)[1]

    reference = grad_b0(jnp.asarray(rng.random((p.n, 2))), 1.0)
    assert float(jnp.max(jnp.abs(reference - w))) > 0.1  # inter-reflection is in it
    for b0 in (jnp.zeros((p.n, 2)), jnp.asarray(rng.random((p.n, 2)))):
        for scale in (1.0, 1e-12):
            np.testing.assert_allclose(grad_b0(b0, scale) / scale, reference, rtol=1e-6)


@pytest.mark.parametrize("rho", [0.5, 0.95])
def test_solver_comparison(cube_room, rho, capsys):
    p, _, op = cube_room
    b0 = jnp.asarray(np.random.default_rng(0).random((p.n, 4)), jnp.float32)
    r = jnp.full(p.n, rho, jnp.float32)
    out = {m: solve_radiosity(op, r, b0, solver=m) for m in RADIOSITY_SOLVERS}
    ref = out["refined"].value
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


def test_non_convergence_names_the_config_keys(small_cube):
    # The message names what a user can change, not lineax's max_steps / restart.
    p, op = small_cube
    solver = Refined(inner=BiCGStab(stall=0), fallback=GMRES(restart=2), restarts=1,
                     direct=False)
    with pytest.raises(SolveError) as err:
        solve_radiosity(op, jnp.full(p.n, 0.9), jnp.ones((p.n, 1)), solver=solver, max_steps=4,
                        rtol=1e-7)
    msg = str(err.value)
    for key in ("[solver] max_iterations", "[solver] tolerance = 1e-07", "[solver] method"):
        assert key in msg
    assert "max_steps" not in msg and "restart" not in msg
    sol = solve_radiosity(op, jnp.full(p.n, 0.9), jnp.ones((p.n, 1)), solver="jacobi",
                          max_steps=3, rtol=1e-7, throw=False)
    assert sol.result != lx.RESULTS.successful


def test_solvers_are_objects_or_registry_names(small_cube):
    p, op = small_cube
    assert isinstance(radiosity_solver("refined"), Refined)
    assert all(issubclass(c, AbstractRadiositySolver) for c in RADIOSITY_SOLVERS.values())
    with pytest.raises(ConfigError, match="solver.method"):
        radiosity_solver("cg")
    b0 = jnp.ones((p.n, 1))
    by_name = solve_radiosity(op, jnp.full(p.n, 0.5), b0, solver="gmres").value
    by_object = solve_radiosity(op, jnp.full(p.n, 0.5), b0, solver=GMRES(restart=10)).value
    assert np.array_equal(np.asarray(by_name), np.asarray(by_object))


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


@pytest.mark.parametrize("rho", [0.9, 0.99, 0.999])
def test_bright_closed_box_matches_the_enclosure_value(cube_room, rho):
    """A closed 1 m box of uniform ρ lit by a point source inside, nothing in the way.

    Which quantity: in a closed enclosure every lumen leaving a surface lands on a surface,
    and a fraction ρ of what lands is emitted again. The total exitance flux Φ_B = Σ A_i B_i
    therefore satisfies Φ_B = ρ (Φ_d + Φ_B), Φ_d = Σ A_i E_i the direct flux the surfaces
    receive, so the mean exitance is M = ρ Φ_d / (A (1 − ρ)), the first reflection B₀ = ρE
    included. We compare the part the solve adds, M − ρ Φ_d / A = ρ² Φ_d / (A (1 − ρ)), for
    any distribution of the first bounce. Φ_d is the test's own closed-form irradiance
    I cos θ / d² averaged over 16 points per patch, so the direct-light discretisation is not
    what is judged (it is within 0.5 % of the 1000 lm emitted). Without the row correction the
    box's rows (0.994 … 1.005) made ρ = 0.999 read far off (the issue's +62 %).
    """
    p, _, op = cube_room
    src = np.array([0.1, -0.05, 0.2])
    pts = subdivide_triangles(p.vertices, 4).mean(axis=2) - src
    d2 = np.sum(pts**2, axis=-1)
    cos = np.clip(-np.sum(pts * p.normal[:, None], axis=-1) / np.sqrt(d2), 0, None)
    e = (1000.0 / (4 * np.pi) * cos / d2).mean(axis=1)  # lx
    phi_d, area = float(np.sum(e * p.area)), float(p.area.sum())
    assert phi_d == pytest.approx(1000.0, rel=5e-3)
    b0 = rho * e[:, None]
    sol = solve_radiosity(op, jnp.full(p.n, rho, jnp.float32), jnp.asarray(b0, jnp.float32))
    b = np.asarray(sol.value, np.float64)[:, 0]
    inter = np.sum((b - b0[:, 0]) * p.area) / area
    assert inter == pytest.approx(rho**2 * phi_d / (area * (1 - rho)), rel=2e-3)
    assert bool(sol.stats["closed"])
    assert float(sol.escaped[0]) == pytest.approx(0.0, abs=1e-6)


def test_a_plain_solve_compiles_the_refinement_without_its_fallback(small_cube, monkeypatch):
    # radiosity/_solve.py, "Lazy fallback": outside a trace the default solver first runs
    # without GMRES; only a first try that stops where GMRES would take over runs the whole
    # solver (test_solver_regression's breakdown test: the fallback then finishes the job).
    # The first try's answer is (I − ρF)⁻¹ B₀ by numpy.
    from lumijax.radiosity import _solve

    p, op = small_cube
    seen, real = [], _solve._solve_compiled

    def spy(*args, **kw):
        seen.append(args[3])
        return real(*args, **kw)

    monkeypatch.setattr(_solve, "_solve_compiled", spy)
    rho, b0 = np.full(p.n, 0.8), np.ones((p.n, 2))
    exact = np.linalg.solve(np.eye(p.n) - rho[:, None] * op.todense(), b0)
    plain = solve_radiosity(op, jnp.asarray(rho), jnp.asarray(b0), rtol=1e-9,
                            correct_rows=False, solver=Refined(direct=False))
    assert [type(s).__name__ for s in seen] == ["Refined"] and seen[0].fallback is None
    np.testing.assert_allclose(np.asarray(plain.value), exact, rtol=1e-7)


@pytest.mark.parametrize("method", ["refined", "southwell", "gmres"])
def test_one_dense_block_solves_as_the_buckets_do(monkeypatch, method):
    # radiosity/_solve.py, "Small solves": up to DENSE_PATCHES the solve applies one dense
    # block; above, the buckets. Both against numpy's dense solve (Southwell's shots from one
    # block at a time included: the dense block spans all six).
    from lumijax.radiosity import _operator

    m = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    m.invert()
    p = mesh_patches(m.triangles, patch_size=0.25)
    part = partition(p, 16)
    assert part.n_blocks >= 6
    op = build_operator(p, part, None)
    rho, b0 = np.full(p.n, 0.7), np.random.default_rng(3).random((p.n, 2))
    exact = np.linalg.solve(np.eye(p.n) - rho[:, None] * op.todense(), b0)
    for limit in (_operator.DENSE_PATCHES, 0):
        monkeypatch.setattr(_operator, "DENSE_PATCHES", limit)
        got = solve_radiosity(op, jnp.asarray(rho), jnp.asarray(b0), rtol=1e-9,
                              correct_rows=False, solver=method, max_steps=20_000)
        np.testing.assert_allclose(np.asarray(got.value), exact, rtol=1e-6)
