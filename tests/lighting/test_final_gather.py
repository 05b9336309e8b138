"""Two-level radiosity (``[solver] operator_patches``, docs/radiosity.md "Two levels"): the
operator and the solve on coarse elements, a final gather onto the fine patches.

Checked against closed-form physics (the integrating sphere) and against the one-level solve at
the fine resolution (an independent path: the fine patches' own operator, no gather)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import box, lamp, material, network, photometry, plane_grid, study_text, table

import lumijax
from lumijax import load_study
from lumijax._study import solver_settings
from lumijax.lighting import solve_lighting

FLUX = 10_000.0


def _room(patch_size: float = 0.3, gather_rays: int = 1024) -> str:
    """The furnished room, its patches ``patch_size`` (m) and ``gather_rays`` a patch."""
    return study_text(
        material("wall", 0.7), material("floor", 0.3), material("desk", 0.5),
        photometry("iso", "isotropic", 3000), photometry("down", "lambertian", 2000),
        network("a"), network("b"),
        box([0, 0, 0], [4, 3, 2.5]), box([1.0, 0.8, 0.0], [2.6, 1.8, 0.75], "desk", "outward"),
        box([3.0, 0.0, 0.0], [3.3, 2.0, 2.0], "desk", "outward"),
        lamp("A1", [1, 1.5, 2.0], "a"), lamp("B1", [3.6, 1.0, 2.4], "b", "down"),
        lamp("B2", [2, 2.5, 2.4], "b", "down", aim={"tilt": 30, "pan": 90}),
        plane_grid("wp", [0.2, 0.2, 0.8], [3.6, 0, 0], [0, 2.6, 0], nu=6, nv=5),
        table("solver", patch_size=patch_size, spectral_samples=3, tolerance=1e-6,
              gather_rays=gather_rays))


ROOM = _room()
ELEMENTS = 300  # operator_patches: about a quarter of the fine patches


def _area_mean(v, area):
    return float(np.sum(v * area) / np.sum(area))


def _loaded(tmp_path_factory, name: str, text: str):
    """``(study, points, normals)`` of the study ``text``, its grids concatenated."""
    path = tmp_path_factory.mktemp(name) / "room.toml"
    path.write_text(text, encoding="utf-8")
    study = load_study(path)
    grids = study.scene.grids
    return (study, np.concatenate([g.points for g in grids]),
            np.concatenate([g.normals for g in grids]))


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    study, pts, nrm = _loaded(tmp_path_factory, "room", ROOM)
    sc = study.scene
    one = solve_lighting(sc, pts, nrm, solver_settings(study))
    two = solve_lighting(sc, pts, nrm, solver_settings(study, operator_patches=ELEMENTS))
    return study, pts, nrm, one, two


# Superposition and the incremental replacement are identities of the two-level solve at any
# resolution: checked on the same room meshed coarser (about 1,500 fine patches over the same
# 380 elements, so the elements' compiled solve is the room's) with fewer gather rays, where a
# two-level solve costs a second, not the ~6 s of the 4,000 fine patches' 1,024-ray gather.
SMALL_ROOM = _room(patch_size=0.5, gather_rays=256)


@pytest.fixture(scope="module")
def small_room(tmp_path_factory):
    study, pts, nrm = _loaded(tmp_path_factory, "small_room", SMALL_ROOM)
    two = solve_lighting(study.scene, pts, nrm, solver_settings(study, operator_patches=ELEMENTS))
    # two levels for real: the fine patches several times the elements
    assert two.fine is not None and two.coarse.patches.n < two.fine.patches.n / 3
    return study, pts, nrm, two


def test_elements_are_coarser_and_fine_patches_are_the_one_level_patches(room):
    _, _, _, one, two = room
    assert two.fine is not None and two.display.patches is two.fine.patches
    assert two.coarse.patches.n < two.fine.patches.n / 3
    np.testing.assert_array_equal(two.fine.patches.vertices, one.coarse.patches.vertices)
    assert one.fine is None and one.display.patches is one.coarse.patches
    assert two.stats["fine_patches"] == one.coarse.patches.n


def test_direct_light_on_fine_patches_is_the_one_level_direct(room):
    _, _, _, one, two = room
    np.testing.assert_allclose(two.fine.patch_direct, one.coarse.patch_direct, rtol=1e-12,
                               atol=1e-9)
    np.testing.assert_allclose(two.point_direct, one.point_direct, rtol=1e-12)


def test_indirect_on_fine_patches_and_points_matches_the_fine_one_level_solve(room):
    """Occluded, furnished room, lamps close to walls, elements ~10× coarser than the patches
    (the full courtyard's ratio is 8×): the final gather's inter-reflected light against the
    one-level solve at the fine resolution. Measured (networks a / b): area-mean −2.2 / −2.6 %,
    RMS per patch 3.2 / 5.9 %, grid points mean −2.3 / −2.7 %, worst point 6.6 %. The bias is the
    coarse operator's (the gather itself carries the elements' irradiance flux within 0.5 %);
    at 3× coarser it is −0.4 / −1.1 % (docs/radiosity.md)."""
    _, _, _, one, two = room
    a = one.coarse.patches.area
    ind_one = one.patch_illuminance() - one.coarse.patch_direct
    ind_two = two.fine.patch_indirect
    for k in range(2):
        assert _area_mean(ind_two[k], a) == pytest.approx(_area_mean(ind_one[k], a), rel=0.04)
        rms = np.sqrt(np.sum(a * (ind_two[k] - ind_one[k]) ** 2) / np.sum(a * ind_one[k] ** 2))
        assert rms < 0.08
        np.testing.assert_allclose(two.point_indirect[k], one.point_indirect[k], rtol=0.08)
    # radiosity = ρ (direct + indirect) on the fine patches, luminous
    rho = two.display_rho
    np.testing.assert_allclose(
        two.fine.radiosity, rho * (two.fine.patch_direct + two.fine.patch_indirect), rtol=0.02)


def test_superposition_per_network_is_exact_on_fine_patches(small_room):
    """A study with only network a's luminaires gives exactly network a's row."""
    study, pts, nrm, two = small_room
    sc = study.scene
    only_a = dataclasses.replace(
        sc, luminaires=tuple(lum for lum in sc.luminaires if lum.network == "a"))
    sol = solve_lighting(only_a, pts, nrm, solver_settings(study, operator_patches=ELEMENTS))
    np.testing.assert_allclose(sol.fine.radiosity[0], two.fine.radiosity[0], rtol=2e-4,
                               atol=1e-6 * two.fine.radiosity[0].max())
    np.testing.assert_allclose(sol.fine.radiosity[1], 0.0, atol=0.0)
    d = np.array([0.3, 0.9])
    np.testing.assert_allclose(two.display_radiosity_at(d),
                               0.3 * two.fine.radiosity[0] + 0.9 * two.fine.radiosity[1])


def test_replacing_a_luminaire_updates_the_fine_level_like_a_full_resolve(small_room):
    study, pts, nrm, two = small_room
    sc = study.scene
    moved = dataclasses.replace(sc.luminaires[1], position=np.array([0.6, 2.4, 2.3]))
    inc = two.replace_luminaire(1, moved)
    lums = list(sc.luminaires)
    lums[1] = moved
    full = solve_lighting(dataclasses.replace(sc, luminaires=tuple(lums)), pts, nrm,
                          solver_settings(study, operator_patches=ELEMENTS))
    for got, ref in ((inc.fine.patch_direct, full.fine.patch_direct),
                     (inc.fine.patch_indirect, full.fine.patch_indirect),
                     (inc.fine.radiosity, full.fine.radiosity)):
        np.testing.assert_allclose(got, ref, rtol=1e-3, atol=1e-4 * ref.max())


def _validation_script():
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "studies" / "validation" / "run_validation.py"
    spec = importlib.util.spec_from_file_location("run_validation", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("rho", [0.5, 0.8])
def test_integrating_sphere_two_levels(tmp_path, rho):
    """Inward icosphere (1,280 triangles = the elements), 5,120 fine patches: every fine patch's
    irradiance is Φ/(A(1−ρ)) within the one-level tolerances (mean 1 %, every patch 3 %)."""
    path, area, _ = _validation_script().sphere_study(
        tmp_path, rho, subdivisions=3, patch_size=0.2, gather_rays=256, points=8, flux=FLUX)
    path.write_text(path.read_text() + "operator_patches = 100\n", encoding="utf-8")
    sol = lumijax.compute(load_study(path)).lighting
    assert sol.coarse.patches.n == 1280 and sol.fine.patches.n == 4 * 1280
    ref = FLUX / (area * (1 - rho))
    e = sol.display_patch_illuminance()[0]
    assert _area_mean(e, sol.fine.patches.area) == pytest.approx(ref, rel=0.01)
    np.testing.assert_allclose(e, ref, rtol=0.03)
    np.testing.assert_allclose(sol.display.radiosity[0], rho * e, rtol=1e-9)


def test_patches_file_holds_the_fine_patches(room, tmp_path):
    import pyvista as pv

    from lumijax.report._vtk import write_patches_vtp

    _, _, _, _, two = room
    mesh = pv.read(write_patches_vtp(two, [1.0, 0.5], tmp_path / "p.vtp"))
    assert mesh.n_cells == two.fine.patches.n
    np.testing.assert_allclose(mesh.cell_data["radiosity_lm_m2"],
                               two.fine.radiosity[0] + 0.5 * two.fine.radiosity[1], rtol=1e-6)
