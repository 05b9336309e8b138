"""The aim convention of docs/conventions.md, and gradients of illuminance w.r.t. aims."""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import central_difference, lamp, photometry, point_grid, study_text

import lumijax
from lumijax import load_study
from lumijax.direct import point_illuminance
from lumijax.scene import aim_rotation

# these tests check direct light against closed forms: inter-reflection off
compute = partial(lumijax.compute, indirect=False)

BEGA = "lx_Testlamp_Isym1_007cfb11e343e2f42e3b476be4ab684e.ies"  # rotationally symmetric
ERCO = "lx_Testlamp_Isym2_theta180+_erco_33499000_1xqt32_230w.IES"  # asymmetric wall-washer


def test_aim_axis_formula():
    for tilt, pan, spin in [(0, 0, 0), (30, 60, 20), (90, 0, 0), (90, 90, 45), (135, -30, 10)]:
        r = np.asarray(aim_rotation(*np.radians([tilt, pan, spin])))
        t, p = np.radians([tilt, pan])
        expected = [np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), -np.cos(t)]
        np.testing.assert_allclose(r @ [0, 0, -1], expected, atol=1e-12)
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
        assert np.isclose(np.linalg.det(r), 1.0)


def test_spin_turns_c_planes_counter_clockwise():
    # spin 90 about the (downward) axis at zero tilt: C0 (+x) goes to +y
    r = np.asarray(aim_rotation(0.0, 0.0, np.pi / 2))
    np.testing.assert_allclose(r @ [1, 0, 0], [0, 1, 0], atol=1e-12)


def _wall_study(write_study, photometry_file, aim, tmp_dir):
    return write_study(study_text(
        photometry("p", file=photometry_file), lamp("L", [0, 0, 0], photometry="p", **aim),
        point_grid("walls", [[3, 0, 0], [-3, 0, 0], [0, 3, 0], [0, -3, 0], [0, 0, -3], [0, 0, 3]],
                   [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1]])))


@pytest.mark.parametrize(
    "aim,brightest",
    [({}, 4), ({"aim": {"tilt": 90}}, 0), ({"aim": {"tilt": 90, "pan": 90}}, 2),
     ({"aim": {"tilt": 90, "pan": 180}}, 1), ({"aim": {"tilt": 180}}, 5),
     ({"aim_at": [0, -7, 0]}, 3), ({"aim": {"tilt": 90, "pan": -90, "spin": 33}}, 3)],
)
def test_beam_goes_where_the_convention_says(write_study, shared_photometry, tmp_path, aim,
                                             brightest):
    path = _wall_study(write_study, shared_photometry / BEGA, aim, tmp_path)
    lux = compute(load_study(path))["walls"].illuminance_lux
    assert int(np.argmax(lux)) == brightest
    # on axis at 3 m: the file's nadir intensity, 330.8 cd (read from the file's first value)
    np.testing.assert_allclose(lux[brightest], 330.8 / 9, rtol=2e-3)


def test_real_downlight_matches_its_tabulated_candela(write_study, shared_photometry):
    """E = I(γ) cos³γ / h² at points placed on the file's own angles (values read off the file)."""
    h = 2.0
    gammas = np.array([0.0, 10.0, 20.0, 30.0])
    table = np.array([330.8, 336.8, 331.4, 90.7])  # cd at those γ, as printed in the file
    xs = h * np.tan(np.radians(gammas))
    pts = [[float(x), 0.0, 0.0] for x in xs]
    path = write_study(study_text(photometry("p", file=shared_photometry / BEGA),
                             lamp("L", [0, 0, h], photometry="p"), point_grid("g", pts)))
    lux = compute(load_study(path))["g"].illuminance_lux
    np.testing.assert_allclose(lux, table * np.cos(np.radians(gammas)) ** 3 / h**2, rtol=1e-3)


def test_illuminance_gradient_wrt_aim_matches_finite_differences(shared_photometry):
    from lumijax.photometry import read_photometry

    dist = read_photometry(shared_photometry / ERCO).distribution
    rng = np.random.default_rng(0)
    pts = jnp.asarray(rng.uniform([-3, -3, 0], [3, 3, 0.5], size=(40, 3)))
    nrm = jnp.tile(jnp.array([0.0, 0.0, 1.0]), (40, 1))
    pos = jnp.array([[0.2, -0.1, 2.5]])

    def total(angles):
        rot = aim_rotation(angles[0], angles[1], angles[2])[None]
        e = point_illuminance(dist, pos, rot, jnp.ones(1), pts, nrm)
        return jnp.sum(e * jnp.linspace(0.5, 1.5, 40))  # a weighted objective, like a fit

    x0 = jnp.radians(jnp.array([155.0, 40.0, 10.0]))  # an up-light (DFF 0 %) turned downwards
    grad = jax.grad(total)(x0)
    fd = central_difference(total, x0, h=1e-6)
    np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-6 * float(jnp.abs(fd).max()))
    assert float(jnp.abs(grad).min()) > 0  # every angle matters for an asymmetric beam
