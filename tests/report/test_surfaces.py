"""The surfaces a report draws are the solution's own: its patches and radiosity, or, without
patches, the direct stage's light with the solution's own shadows."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import lamp, material, network, photometry, plane_grid, rectangle, study_text, table

import lumijax
from lumijax.photometry import isotropic, write_ies
from lumijax.report import surface_light

FLUX = 4000.0  # lm: I = 4000 / 4π cd every way
RHO = 0.4


def _study(write_study, tmp_path, indirect):
    write_ies(isotropic(FLUX), tmp_path / "iso.ies")
    return lumijax.load_study(write_study(study_text(
        table("solver", cache=False, spectral_samples=0, indirect=indirect, target_patches=150),
        material("grey", RHO), photometry("iso", file=tmp_path / "iso.ies"), network("n"),
        rectangle([-2, -2, 0], [4, 0, 0], [0, 4, 0], "grey"),
        rectangle([-0.5, -0.5, 1], [1, 0, 0], [0, 1, 0], "grey"), lamp("lamp", [0, 0, 2]),
        plane_grid("g", [-1.9, -1.9, 0.01], [3.8, 0, 0], [0, 3.8, 0], nu=5, nv=5))))


def test_drawn_patches_are_the_solutions(write_study, tmp_path):
    res = lumijax.compute(_study(write_study, tmp_path, True))
    s = surface_light(res)
    p = res.lighting.display.patches
    assert len(s.faces) == p.n
    np.testing.assert_allclose(s.patch_luminance, res.lighting.display.radiosity / np.pi)
    np.testing.assert_allclose(s.area, p.area)


@pytest.mark.parametrize("shadows", [True, False])
def test_without_patches_the_direct_light_is_drawn_with_the_solutions_shadows(
        write_study, tmp_path, shadows):
    res = lumijax.compute(_study(write_study, tmp_path, False), shadows=shadows)
    assert res.lighting.coarse.patches is None
    s = surface_light(res)
    centre = s.points[s.faces].mean(axis=1)
    floor = np.abs(centre[:, 2]) < 1e-9
    d = np.linalg.norm(centre[floor] - [0, 0, 2], axis=1)
    open_sky = FLUX / (4 * np.pi) * 2.0 / d**3  # I cos θ / d², cos θ = h / d
    drawn = s.patch_luminance[0, floor] * np.pi / RHO  # L = ρE/π
    # the plank (1 × 1 m at half height) hides the floor within |x|, |y| < 1 m from the lamp
    under = np.all(np.abs(centre[floor, :2]) < 0.9, axis=1)
    outside = np.any(np.abs(centre[floor, :2]) > 1.1, axis=1)
    assert under.sum() >= 3 and outside.sum() >= 10
    np.testing.assert_allclose(drawn[outside], open_sky[outside], rtol=1e-5)
    if shadows:
        assert np.all(drawn[under] == 0)
    else:
        np.testing.assert_allclose(drawn[under], open_sky[under], rtol=1e-5)
