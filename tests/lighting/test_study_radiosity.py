"""Inter-reflection through the whole pipeline (config → scene → patches → solve → gather),
against the exact enclosure identities of shared/reference §9."""

from __future__ import annotations

import dataclasses

import helpers as h
import numpy as np
import pytest

import lumijax
from lumijax import LumijaxWarning, load_study
from lumijax.lighting import solve_lighting

# The integrating sphere through this same pipeline is in tests/validation.


ROOM = h.study_text(
    h.material("wall", 0.7), h.material("floor", 0.3),
    h.photometry("iso", "isotropic", 3000), h.photometry("down", "lambertian", 2000),
    h.network("a", 0.3), h.network("b", 0.9),
    h.box([0, 0, 0], [4, 3, 2.5]), h.rectangle([0.5, 0.5, 0.01], [3, 0, 0], [0, 2, 0], "floor"),
    h.lamp("A1", [1, 1.5, 2.0], "a"), h.lamp("B1", [3, 1.0, 2.4], "b", "down"),
    h.lamp("B2", [3, 2.0, 2.4], "b", "down", aim={"tilt": 30, "pan": 90}),
    h.plane_grid("wp", [0.2, 0.2, 0.8], [3.6, 0, 0], [0, 2.6, 0], nu=6, nv=5),
    # colour is tested elsewhere; four samples keep the spectral path cheap. The identities
    # checked here hold at any mesh: 0.6 m patches (~870) solve in a third of 0.4 m's (~1,850)
    h.table("solver", patch_size=0.6, tolerance=1e-11, spectral_samples=4))


def test_any_dimmer_vector_equals_a_full_resolve(write_study):
    """B = Σ α_k B_k (paper eq. 10) against a solve with the dimmers baked into the sources."""
    study = load_study(write_study(ROOM))
    sc = study.scene
    sol = lumijax.compute(study).lighting
    alpha = np.array([0.3, 0.9])
    scaled = dataclasses.replace(sc, luminaires=tuple(
        dataclasses.replace(lum, scale=lum.scale * alpha[sc.network_names.index(lum.network)],
                            network="a")
        for lum in sc.luminaires))
    settings = lumijax._study.solver_settings(study)
    one = solve_lighting(scaled, sol.points, sol.normals, settings)
    np.testing.assert_allclose(sol.radiosity_at(alpha), one.coarse.radiosity[0], rtol=1e-6)
    np.testing.assert_allclose(alpha @ sol.point_total, one.point_total[0], rtol=1e-6)


def test_replacing_one_luminaire_equals_a_full_resolve(write_study):
    study = load_study(write_study(ROOM))
    sc = study.scene
    sol = lumijax.compute(study).lighting
    moved = dataclasses.replace(sc.luminaires[2], position=np.array([2.0, 1.5, 2.3]), tilt=45.0,
                                pan=-60.0, network="a")
    fast = sol.replace_luminaire(2, moved)
    full = solve_lighting(fast.scene, sol.points, sol.normals,
                          lumijax._study.solver_settings(study))
    np.testing.assert_allclose(fast.coarse.radiosity, full.coarse.radiosity, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(fast.point_total, full.point_total, rtol=1e-6, atol=1e-9)
    assert not np.allclose(fast.point_total, sol.point_total)  # it did change something


def test_open_scene_says_light_escapes(write_study):
    text = ROOM.replace('normals = "inward"\nmaterial = "wall"', 'normals = "outward"\nmaterial = "wall"')
    text = text.replace("position = [1, 1.5, 2.0]", "position = [6, 1.5, 2.0]")
    text = text.replace("position = [3, 1.0, 2.4]", "position = [6, 1.0, 5]")
    text = text.replace("position = [3, 2.0, 2.4]", "position = [6, 2.0, 5]")
    with pytest.warns(LumijaxWarning, match="the scene is open"):
        lumijax.compute(load_study(write_study(text)))


def test_indirect_adds_light_and_direct_is_unchanged(write_study):
    study = load_study(write_study(ROOM))
    with_gi = lumijax.compute(study)["wp"]
    without = lumijax.compute(study, indirect=False)["wp"]
    np.testing.assert_allclose(with_gi.at_dimmers_direct(with_gi.dimmers),
                               without.illuminance_lux, rtol=1e-12)
    assert np.all(with_gi.illuminance_lux > without.illuminance_lux)


def test_patches_file_opens_in_pyvista_with_consistent_light(write_study, tmp_path):
    import pyvista as pv

    study = load_study(write_study(ROOM))
    res = lumijax.compute(study)
    paths = lumijax.write_results(res, tmp_path / "out", images=False)
    mesh = pv.read(paths["patches.vtp"])
    sol = res.lighting
    assert mesh.n_cells == sol.coarse.patches.n
    b = mesh.cell_data["radiosity_lm_m2"]
    np.testing.assert_allclose(b, study.scene.dimmers @ sol.coarse.radiosity, rtol=1e-6)
    np.testing.assert_allclose(mesh.cell_data["luminance_cd_m2"], b / np.pi, rtol=1e-6)
    # a diffuse patch reflects ρ of what it receives: B = ρ E (the solve's own equation)
    e = mesh.cell_data["illuminance_lux"]
    np.testing.assert_allclose(b, mesh.cell_data["reflectance"] * e, rtol=1e-3,
                               atol=1e-6 * b.max())
    # written with one product at the dimmers: the per-network irradiance, dimmed
    np.testing.assert_allclose(e, study.scene.dimmers @ sol.patch_illuminance(), rtol=1e-5,
                               atol=1e-6 * e.max())
    assert "radiosity_lm_m2:a" in mesh.cell_data and "radiosity_lm_m2:b" in mesh.cell_data
