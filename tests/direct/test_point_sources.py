"""Direct light from point sources against closed-form photometry (no lumijax numbers)."""

from __future__ import annotations

from functools import partial

import helpers as h
import numpy as np
import pytest

import lumijax
from lumijax import load_study

# these tests check direct light against closed forms: inter-reflection off
compute = partial(lumijax.compute, indirect=False)

ISO = 4000.0  # lm


def _plane_study(write_study, **grid):
    """A 4000 lm isotropic lamp 2.5 m above a 10 × 10 m grid of 21 × 21 points at z = 0."""
    return write_study(h.study_text(
        h.photometry("iso", "isotropic", ISO), h.lamp("L", [0, 0, 2.5]),
        h.plane_grid("g", [-5, -5, 0], [10, 0, 0], [0, 10, 0], nu=21, nv=21, **grid)))


def _lamp_over(points, *parts, **lamp_keys):
    """A 1000 lm isotropic lamp at (0, 0, 2) m over a grid of ``points``, and ``parts``."""
    return h.study_text(h.photometry("iso", "isotropic", 1000), *parts,
                   h.lamp("L", [0, 0, 2], **lamp_keys), h.point_grid("g", points))


def test_isotropic_point_over_plane_is_inverse_square_cosine(write_study):
    """E = I cos³θ / h² with I = Φ / 4π on a horizontal plane (reference §10)."""
    res = compute(load_study(_plane_study(write_study)))
    g = res["g"]
    h = 2.5
    r2 = g.points[:, 0] ** 2 + g.points[:, 1] ** 2
    expected = ISO / (4 * np.pi) * h / (h * h + r2) ** 1.5
    np.testing.assert_allclose(g.illuminance_lux, expected, rtol=1e-9)


def test_vertical_receiver_uses_its_own_cosine(write_study):
    """A grid facing +x receives I·x/d³ from a source on its +x side only... or none at all."""
    path = _plane_study(write_study, normal=[-1, 0, 0])
    g = compute(load_study(path))["g"]
    p = g.points - np.array([0, 0, 2.5])
    d = np.linalg.norm(p, axis=1)
    cos = np.clip(p[:, 0] / d, 0, None)  # light travels along p; receiver normal is −x
    expected = ISO / (4 * np.pi) * cos / d**2
    np.testing.assert_allclose(g.illuminance_lux, expected, rtol=1e-9, atol=1e-12)


def test_dimmer_scales_exactly_and_networks_superpose(write_study):
    path = write_study(h.study_text(
        h.photometry("iso", "isotropic", 1000), h.network("a", 0.25), h.network("b", 0.5),
        h.lamp("A", [0, 0, 2], "a"), h.lamp("B", [1, 0, 3], "b"),
        h.point_grid("g", [[0, 0, 0], [1, 1, 0], [3, -1, 0]])))
    g = compute(load_study(path))["g"]
    pts = g.points
    i = 1000 / (4 * np.pi)
    ea = i * 2 / np.linalg.norm(pts - [0, 0, 2], axis=1) ** 3
    eb = i * 3 / np.linalg.norm(pts - [1, 0, 3], axis=1) ** 3
    np.testing.assert_allclose(g.by_network_lux[0], ea, rtol=1e-9)
    np.testing.assert_allclose(g.by_network_lux[1], eb, rtol=1e-9)
    np.testing.assert_allclose(g.illuminance_lux, 0.25 * ea + 0.5 * eb, rtol=1e-9)
    np.testing.assert_allclose(g.at_dimmers([1, 0]), ea, rtol=1e-12)


def test_shadow_of_a_box_matches_projection(write_study):
    """A point source above a cube: the floor inside the cube's projected outline is dark,
    the floor outside it gets the unobstructed closed form."""
    path = write_study(h.study_text(
        h.material("m", 0.5), h.photometry("iso", "isotropic", ISO),
        h.box([-0.5, -0.5, 1.0], [0.5, 0.5, 2.0], "m", normals=None), h.lamp("L", [0, 0, 4]),
        h.plane_grid("g", [-3, -3, 0], [6, 0, 0], [0, 6, 0], nu=60, nv=60)))
    g = compute(load_study(path))["g"]
    x, y = g.points[:, 0], g.points[:, 1]
    # The outline is the projection of the box's top face (z = 2, nearest the source at z = 4)
    # onto z = 0: half-width 0.5 · 4 / (4 − 2); the bottom face projects inside it.
    half = 0.5 * 4 / 2
    umbra = (np.abs(x) < half - 0.02) & (np.abs(y) < half - 0.02)
    lit = (np.abs(x) > half + 0.02) | (np.abs(y) > half + 0.02)
    expected = ISO / (4 * np.pi) * 4 / (16 + x**2 + y**2) ** 1.5
    assert umbra.sum() > 100
    assert np.all(g.illuminance_lux[umbra] == 0)
    np.testing.assert_allclose(g.illuminance_lux[lit], expected[lit], rtol=1e-9)


def test_no_shadows_option_ignores_geometry(write_study):
    path = write_study(_lamp_over([[0, 0, 0]], h.material("m", 0.5),
                                  h.rectangle([-1, -1, 1], [2, 0, 0], [0, 2, 0], "m")))
    study = load_study(path)
    assert compute(study)["g"].illuminance_lux[0] == 0.0
    np.testing.assert_allclose(
        compute(study, shadows=False)["g"].illuminance_lux[0], 1000 / (4 * np.pi) / 4, rtol=1e-12
    )


def test_spectrum_never_changes_lux(write_study):
    pts = [[0, 0, 0], [1, 2, 0]]
    plain = compute(load_study(write_study(_lamp_over(pts), "a.toml")))
    for name in ("A", "FL11", "D65"):
        tinted = compute(load_study(write_study(_lamp_over(pts, spectrum=name), f"{name}.toml")))
        np.testing.assert_array_equal(tinted["g"].illuminance_lux, plain["g"].illuminance_lux)


@pytest.mark.parametrize("mf,mult", [(0.8, 1.0), (1.0, 2.5), (0.7, 0.5)])
def test_multiplier_and_maintenance_factor_scale_light_and_flux(write_study, mf, mult):
    path = write_study(_lamp_over([[0, 0, 0]], multiplier=mult, maintenance_factor=mf))
    res = compute(load_study(path))
    np.testing.assert_allclose(res["g"].illuminance_lux[0], mf * mult * 1000 / (16 * np.pi))
    np.testing.assert_allclose(res.networks["n"]["flux_lm"], mf * mult * 1000, rtol=1e-6)
