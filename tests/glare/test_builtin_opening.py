"""A built-in source's luminous diameter: the glare ratings see the opening the config gives.

A Lambertian disk of area A shows the luminance Φ/(πA) from every direction below it, and an
isotropic sphere of radius r shows Φ/(4π · πr²): closed forms, against the distribution's
intensity over the opening's projected area as the glare model forms it."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import photometry, study_text

from lumijax.config import parse_config
from lumijax.errors import ConfigError, PhotometryError
from lumijax.glare import projected_area
from lumijax.photometry import isotropic, lambertian


def _luminance(photometry, gamma_deg):
    g = np.deg2rad(np.asarray(gamma_deg, np.float64))
    d = jnp.asarray(np.stack([np.sin(g), np.zeros_like(g), -np.cos(g)], axis=-1))
    return np.asarray(photometry.distribution.intensity(d) / projected_area(photometry.opening, d))


def test_a_lambertian_disk_shows_one_luminance_every_way():
    p = lambertian(3000.0, 0.2)
    area = math.pi / 4 * 0.2 ** 2
    np.testing.assert_allclose(_luminance(p, [0.0, 30.0, 60.0, 80.0]),
                               3000.0 / (math.pi * area), rtol=1e-4)


def test_an_isotropic_sphere_shows_one_luminance_every_way():
    p = isotropic(1000.0, 0.1)
    np.testing.assert_allclose(_luminance(p, [0.0, 45.0, 90.0, 170.0]),
                               1000.0 / (4 * math.pi) / (math.pi * 0.05 ** 2), rtol=1e-9)


def test_without_a_diameter_the_source_is_a_point():
    assert lambertian(3000.0).opening.is_point and isotropic(10.0).opening.is_point
    with pytest.raises(PhotometryError, match="positive number of metres"):
        lambertian(3000.0, -0.2)


def test_a_diameter_that_is_not_positive_names_its_key():
    text = study_text(photometry("lamp", "lambertian", 3000, luminous_diameter_m=0))
    with pytest.raises(ConfigError) as err:
        parse_config(text)
    assert "photometry.lamp" in str(err.value) and "luminous_diameter_m" in str(err.value)
