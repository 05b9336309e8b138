"""Colour through the whole pipeline: exact lux, the lamp's own CCT, tinted inter-reflection."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import box, lamp, material, photometry, point_grid, study_text, table

import lumijax
from lumijax import load_study


def _room(wall: dict, spectrum: str, samples: int = 8) -> str:
    """A 4 × 3 × 3 m closed room, walls ``wall``, a 4000 lm isotropic lamp of ``spectrum``."""
    return study_text(
        material("wall", **wall), material("floor", 0.2), photometry("iso", "isotropic", 4000),
        lamp("L", [2, 1.5, 1.5], spectrum=spectrum), box([0, 0, 0], [4, 3, 3]),
        point_grid("g", [[2, 1.5, 0.8], [0.5, 0.5, 1.0], [3.5, 2.5, 2.0]],
                   [[0, 0, 1], [1, 0, 0], [0, 0, -1]]),
        table("solver", patch_size=0.6, spectral_samples=samples))


GREY = {"reflectance": 0.5}


def _run(write_study, wall, spectrum, name="s.toml"):
    return lumijax.compute(load_study(write_study(_room(wall, spectrum), name)))


def test_xyz_y_is_the_illuminance_and_direct_light_keeps_the_lamp_colour(write_study):
    from lumijax.spectral import cct_from_xyz

    res = _run(write_study, GREY, "A")
    g = res["g"]
    np.testing.assert_allclose(g.xyz[:, 1], g.illuminance_lux, rtol=1e-9)
    # Grey walls reflect every wavelength alike: the light stays CIE A's colour (2856 K)
    np.testing.assert_allclose(cct_from_xyz(g.xyz), 2856, rtol=0.01)
    d = res.to_dict()["grids"]["g"]
    assert len(d["xyz"]) == 3 and len(d["cct_k"]) == 3


def test_lux_does_not_depend_on_the_lamp_spectrum_with_grey_walls(write_study):
    a = _run(write_study, GREY, "A", "a.toml")["g"].illuminance_lux
    f = _run(write_study, GREY, "FL11", "f.toml")["g"].illuminance_lux
    np.testing.assert_allclose(a, f, rtol=2e-3)


def test_red_walls_tint_the_inter_reflected_light(write_study):
    """Under equal-energy light, red walls (sRGB red albedo) shift the indirect light to red."""
    from lumijax.spectral import xyz_to_chromaticity

    g = _run(write_study, {"srgb": [0.8, 0.1, 0.1]}, "E")["g"]
    xy = xyz_to_chromaticity(g.xyz)
    # illuminant E sits at x = y = 1/3; light reflected by red walls pulls x up
    assert np.all(xy[:, 0] > 1 / 3 + 0.01)
    grey = xyz_to_chromaticity(_run(write_study, GREY, "E", "grey.toml")["g"].xyz)
    np.testing.assert_allclose(grey, 1 / 3, atol=2e-3)


@pytest.mark.parametrize("samples", [0, 8])
def test_photometric_and_spectral_solves_agree_on_grey(write_study, samples):
    wall = {"reflectance": 0.6}
    g = lumijax.compute(load_study(write_study(_room(wall, "D65", samples),
                                               f"{samples}.toml")))["g"]
    ref = lumijax.compute(load_study(write_study(_room(wall, "D65", 16), "ref.toml")))["g"]
    np.testing.assert_allclose(g.illuminance_lux, ref.illuminance_lux, rtol=5e-3)
