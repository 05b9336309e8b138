"""Diffuse transmission: an opal panel between two rooms couples its two faces in the radiosity.

Room A (x 0–2 m) holds a 1000 lm isotropic lamp at its centre; room B (x 2–4 m) has no light of
its own; the 2 × 2 m wall between them is the panel. By symmetry the lamp sends Φ/6 to each
face of the cube, so the panel's front receives 166.7 lm (hand calculation: the solid angle of
a 2 × 2 m square at 1 m is 4 asin(1/2) = 2π/3). The references below are the hand figure, the
closed enclosure's flux balance (what the surfaces absorb, Σ A H (1 − ρ − τ), equals what the
lamp emits), and the coupled system assembled densely in the test and solved by numpy."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import lamp, material, network, photometry, point_grid, rectangle, study_text, table

from lumijax import LumijaxError, compute, load_study

RHO, RHO_P, TAU = 0.5, 0.3, 0.5


def _room(x0: float, mat: str) -> list[str]:
    """Floor, ceiling and the two side walls of the 2 m cube at x0 … x0 + 2, facing in."""
    return [rectangle([x0, 0, 0], [2, 0, 0], [0, 2, 0], mat),
            rectangle([x0, 0, 2], [0, 2, 0], [2, 0, 0], mat),
            rectangle([x0, 0, 0], [0, 0, 2], [2, 0, 0], mat),
            rectangle([x0, 2, 0], [2, 0, 0], [0, 0, 2], mat)]


@pytest.fixture(scope="module")
def rooms(tmp_path_factory):
    path = tmp_path_factory.mktemp("diffuser") / "s.toml"
    path.write_text(study_text(
        material("wall", RHO), material("opal", RHO_P, transmittance=TAU, kind="diffuse"),
        photometry("iso", "isotropic", 1000.0), network("n"), lamp("L", [1, 1, 1]),
        *_room(0, "wall"), *_room(2, "wall"),
        rectangle([0, 0, 0], [0, 2, 0], [0, 0, 2], "wall"),  # x = 0, facing +x
        rectangle([4, 0, 0], [0, 0, 2], [0, 2, 0], "wall"),  # x = 4, facing −x
        rectangle([2, 0, 0], [0, 0, 2], [0, 2, 0], "opal"),  # the panel, front toward the lamp
        point_grid("g", [[3, 1, 0.01]], [0, 0, 1]),
        # Jacobi: the quickest to compile; it converges here (ρ + τ ≤ 0.8)
        table("solver", patch_size=0.5, precision="float64", tolerance=1e-10, method="jacobi")),
        encoding="utf-8")
    study = load_study(path)
    return study, compute(study)


def _c(sol) -> np.ndarray:
    """The solve's per-patch rescaling of outgoing light (rows of F summing off 1)."""
    from lumijax.radiosity import row_correction

    return np.asarray(row_correction(sol.transport.row_sums())[0])


def _sides(p):
    on = np.abs(p.centroid[:, 0] - 2.0) < 0.01
    return on & (p.normal[:, 0] < -0.5), on & (p.normal[:, 0] > 0.5)


def test_the_panel_has_two_faces_and_each_patch_its_mirror(rooms):
    study, res = rooms
    p = res.lighting.coarse.patches
    front, back = _sides(p)
    assert front.sum() == back.sum() > 0
    partner = res.lighting.spectral.transmission(p)[1]
    np.testing.assert_array_equal(partner[partner[front]], np.flatnonzero(front))
    assert back[partner[front]].all()
    np.testing.assert_allclose(p.area[partner[front]], p.area[front], rtol=1e-12)
    np.testing.assert_allclose(p.centroid[partner[front], 1:], p.centroid[front, 1:], atol=1e-9)


def _solved(study, res):
    """The coarse solution's patches, radiosity, direct light and luminous ρ, τ per patch."""
    sol = res.lighting
    p, b, e = sol.coarse.patches, sol.coarse.radiosity[0], sol.coarse.patch_direct[0]
    mats = study.scene.materials
    rho = np.array([m.rho for m in mats])[p.material]
    tau = np.array([m.tau for m in mats])[p.material]
    return sol, p, b, e, rho, tau


def test_the_enclosure_absorbs_what_the_lamp_emits(rooms):
    study, res = rooms
    sol, p, b, e, rho, tau = _solved(study, res)
    h = e + np.asarray(sol.transport.matmul(jnp.asarray(_c(sol) * b)))  # arriving, lx
    absorbed = float(np.sum(p.area * h * (1 - rho - tau)))
    assert absorbed == pytest.approx(float(np.sum(p.area * e)), rel=1e-6)
    assert float(np.sum(p.area * e)) == pytest.approx(1000.0, rel=0.01)  # the lamp's flux
    # room B is lit: through the panel only
    assert res.grids["g"].by_network_lux[0, 0] > 1.0


def test_the_coupled_solve_against_a_dense_solve(rooms):
    study, res = rooms
    sol, p, b, e, rho, tau = _solved(study, res)
    f = np.asarray(sol.transport.matmul(jnp.eye(p.n, dtype=jnp.float64)))
    f = f * _c(sol)[None, :]  # the solve's row correction: F_ij → F_ij c_j
    front, back = _sides(p)
    other = np.arange(p.n)  # the other face, found here by position, not by back_partners
    key = lambda i: (round(p.centroid[i, 1], 6), round(p.centroid[i, 2], 6))  # noqa: E731
    backs = {key(i): i for i in np.flatnonzero(back)}
    fronts = {key(i): i for i in np.flatnonzero(front)}
    for k, i in fronts.items():
        other[i], other[backs[k]] = backs[k], i
    swap = np.eye(p.n)[other]
    k_mat = rho[:, None] * f + tau[:, None] * (swap @ f)
    assert k_mat.sum(axis=1).max() <= 1.0 + 1e-9  # no row creates light
    want = np.linalg.solve(np.eye(p.n) - k_mat, rho * e + tau * (swap @ e))
    np.testing.assert_allclose(b, want, rtol=1e-6, atol=1e-9 * want.max())


def test_light_through_a_black_room_panel_by_hand(rooms):
    """ρ = 0 everywhere: the back face emits exactly τ × the front's direct flux, Φ τ / 6."""
    from lumijax.lighting._spectral import solve_spectral

    study, res = rooms
    sol = res.lighting
    p, e = sol.coarse.patches, sol.coarse.patch_direct
    tau, partner = sol.spectral.transmission(p)
    b, _ = solve_spectral(sol.transport, np.zeros((p.n, 1)), e, np.ones((1, 1)), jnp.float64,
                          transmission=(tau, partner), rtol=1e-10, solver="jacobi")
    front, back = _sides(p)
    through = float(np.sum(p.area[back] * b[back, 0, 0]))
    assert through == pytest.approx(TAU * 1000.0 / 6.0, rel=0.01)


def test_the_fine_faces_of_a_panel_pass_on_the_other_face_by_hand(rooms):
    """The two-level solve's fine patches of the panel couple their faces as the elements do:
    with ρ = 0 everywhere the fine back face emits exactly τ × the fine front face's direct
    flux, Φ τ / 6 (the hand figure above); without the coupling it would emit nothing."""
    from lumijax.direct import direct_illuminance
    from lumijax.lighting._spectral import SpectralSetup
    from lumijax.radiosity import mesh_patches
    from lumijax.radiosity._final_gather import final_gather

    study, res = rooms
    sc, elements = study.scene, res.lighting.coarse.patches
    tri = sc.triangles
    fine = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=0.25)
    tau = np.array([m.tau for m in sc.materials])[elements.material][:, None]
    black = SpectralSetup(None, np.zeros((elements.n, 1)), tau)  # photometric, ρ = 0
    direct = direct_illuminance(sc, fine.centroid, fine.normal).by_network  # (1, fine) lx
    level = final_gather(fine, elements, sc.raycaster, black, [None],
                         np.zeros((elements.n, 1, 1)), direct, rays=16)
    front, back = _sides(fine)
    assert back.sum() == front.sum() > 0
    through = float(np.sum(fine.area[back] * level.radiosity[0, back]))
    assert through == pytest.approx(TAU * 1000.0 / 6.0, rel=0.01)
    assert through == pytest.approx(TAU * float(np.sum(fine.area[front] * direct[0, front])),
                                    rel=1e-9)
    assert np.all(level.radiosity[0, ~back] == 0.0)  # ρ = 0: nothing else leaves a surface


@pytest.mark.slow  # one compiled Krylov solve (and its tangent) of ~900 patches
def test_the_reflectance_sensitivity_through_a_panel_against_a_finite_difference(rooms):
    """∂E/∂ρ_m at the point in room B (lit only through the panel) from the optimise layer's
    solve, against central differences of the forward solve (``lighting._solution.shoot``,
    what ``compute`` runs) with each material's reflectance scaled."""
    import dataclasses

    import jax
    from helpers import central_difference

    from lumijax.lighting._solution import shoot
    from lumijax.optimise._sensitivity import reflectance_light

    study, res = rooms
    sol = res.lighting
    used, f = reflectance_light(sol, [1.0])
    index = np.searchsorted(used, sol.coarse.patches.material)
    assert [study.scene.materials[int(m)].name for m in used] == ["wall", "opal"]

    def forward(s):
        sp = dataclasses.replace(sol.spectral, rho=sol.spectral.rho * np.asarray(s)[index, None])
        shot = shoot(dataclasses.replace(sol, spectral=sp), sol.coarse.patch_direct, [None],
                     sol.point_direct)
        return (sol.point_direct + shot.point_indirect)[0]

    ones = np.ones(len(used))
    # value and derivatives from one forward-mode pass (one compiled solve, not two)
    def twice(s):
        e = f(s)
        return e, e

    jac, value = jax.jacfwd(twice, has_aux=True)(jnp.asarray(ones))
    np.testing.assert_allclose(value, forward(ones), rtol=1e-7)
    np.testing.assert_allclose(forward(ones), sol.point_total[0], rtol=1e-7)
    got = np.asarray(jac).T  # (materials, points)
    want = central_difference(forward, ones, h=1e-3)
    assert np.all(want > 0)  # brighter walls or a brighter panel: more light behind it
    np.testing.assert_allclose(got, want, rtol=1e-5)


@pytest.mark.slow  # one compiled Krylov solve (and its tangent) of ~900 patches
def test_calibration_and_the_aim_model_solve_through_the_panel(rooms, tmp_path):
    """The calibration's model at the computed design reproduces the computed lux behind the
    panel (its residual 0), and the aim model's light at a luminaire level of 1.1 is 1.1 × the
    computed light, inter-reflection through the panel included (one lamp: exactly linear)."""
    from lumijax.optimise import calibrate
    from lumijax.optimise._models import build_aim_light

    study, res = rooms
    sol = res.lighting
    (x, y, z), lux = sol.points[0], float(sol.point_total[0, 0])
    csv = tmp_path / "m.csv"
    csv.write_text(f"x,y,z,nx,ny,nz,lux\n{x},{y},{z},0,0,1,{lux!r}\n", encoding="utf-8")
    cal = calibrate(study, res, csv, fit=("llf",))
    assert abs(cal.residuals_before[0]) < 1e-7
    assert cal.llf["n"] == pytest.approx(1.0, abs=1e-6)
    model = build_aim_light(sol, [0], [0.0], [0.0], aims=False, levels=True)
    assert model.lu is not None and model.tau is not None  # the dense LU of the coupled solve
    e, _, _ = model(jnp.asarray([1.0, 1.1]))
    np.testing.assert_allclose(np.asarray(e), 1.1 * sol.point_total[0], rtol=1e-7)


def test_transmission_on_a_closed_solid_with_nothing_inside_is_refused(tmp_path):
    (tmp_path / "s.toml").write_text(study_text(
        material("opal", 0.3, transmittance=0.5, kind="diffuse"),
        table("[[geometry]]", kind="box", min=[0, 0, 0], max=[1, 1, 1], normals="outward",
              material="opal")), encoding="utf-8")
    with pytest.raises(LumijaxError) as e:
        load_study(tmp_path / "s.toml")
    assert e.value.key == "geometry[0].material" and "'opal'" in e.value.message


@pytest.mark.parametrize("keys, key, words", [
    (dict(reflectance=0.5, transmittance=0.4, specular=0.2, kind="diffuse"), "materials.m",
     "> 1"),
    (dict(reflectance=0.5, specular=0.1, roughness=0.0), "materials.m.roughness", "greater"),
    (dict(reflectance=0.5, specular=0.1, roughness=-0.1), "materials.m.roughness", "greater"),
    (dict(reflectance=0.5, transmittance=0.4), "materials.m", "kind"),
    (dict(reflectance=0.5, kind="clear"), "materials.m", "transmittance"),
    (dict(reflectance=0.5, roughness=0.1), "materials.m", "specular"),
])
def test_bad_materials_name_the_key(tmp_path, keys, key, words):
    (tmp_path / "s.toml").write_text(study_text(material("m", **keys)), encoding="utf-8")
    with pytest.raises(LumijaxError) as e:
        load_study(tmp_path / "s.toml")
    assert e.value.key == key and words in e.value.message


def test_a_spectral_sum_above_one_names_the_wavelength(tmp_path):
    csv = tmp_path / "t.csv"
    csv.write_text("wavelength_nm,reflectance\n380,0.1\n600,0.1\n700,0.6\n780,0.6\n",
                   encoding="utf-8")
    (tmp_path / "s.toml").write_text(study_text(
        material("m", 0.45, transmittance=str(csv), kind="diffuse")), encoding="utf-8")
    with pytest.raises(LumijaxError) as e:
        load_study(tmp_path / "s.toml")
    # 0.45 + τ = 1 where the CSV passes 0.55, at 600 + 100 × 0.45/0.5 = 690 nm: the first
    # wavelength checked above it is 691 nm; the largest sum is 0.45 + 0.6
    assert e.value.key == "materials.m" and "from 691 nm" in e.value.message
    assert "1.0500" in e.value.message


def test_a_sampled_final_gather_passes_light_through_the_panel(tmp_path):
    # the two rooms with the sampled transport and a final gather (radiosity/_sampled_gather.py):
    # each patch's light is then ρ H + τ H[partner], H its gathered irradiance
    path = tmp_path / "g.toml"
    path.write_text(study_text(
        material("wall", RHO), material("opal", RHO_P, transmittance=TAU, kind="diffuse"),
        photometry("iso", "isotropic", 1000.0), network("n"), lamp("L", [1, 1, 1]),
        *_room(0, "wall"), *_room(2, "wall"),
        rectangle([0, 0, 0], [0, 2, 0], [0, 0, 2], "wall"),
        rectangle([4, 0, 0], [0, 0, 2], [0, 2, 0], "wall"),
        rectangle([2, 0, 0], [0, 0, 2], [0, 2, 0], "opal"),
        point_grid("g", [[3, 1, 0.01]], [0, 0, 1]),
        table("solver", patch_size=0.5, spectral_samples=0, transport="sampled",
              rays_per_patch=64, aimed_share=0.0, final_gather_rays=1024)), encoding="utf-8")
    study = load_study(path)
    res = compute(study)
    sol, p, b, e, rho, tau = _solved(study, res)
    assert sol.stats["final_gather_rays"] == 1024
    h = sol.patch_illuminance()[0]  # direct + gathered, lx
    partner = sol.spectral.transmission(p)[1]
    has = tau > 0
    want = rho * h + np.where(has, tau * h[np.where(has, partner, 0)], 0.0)
    np.testing.assert_allclose(b, want, rtol=1e-5)
    # the closed pair of rooms absorbs what the lamp emits, to the gather's noise
    absorbed = float(np.sum(p.area * h * (1 - rho - tau)))
    assert absorbed == pytest.approx(float(np.sum(p.area * e)), rel=0.02)
    assert res.grids["g"].by_network_lux[0, 0] > 1.0  # room B, lit through the panel only
