"""Maintenance factors (CIE 97:2005) and the power model, without a solve."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.compliance import PowerModel, luminaire_maintenance_factor, maintenance_factor
from lumijax.compliance._maintenance import LMF_TABLE, LMF_YEARS
from lumijax.config._compliance import MaintenanceFactors


def test_lmf_lookup_interpolates_and_is_monotonic():
    # a tabulated cell, and halfway between two columns by hand: type A, normal, 1.25 years
    assert luminaire_maintenance_factor("A", "normal", 1.0) == pytest.approx(0.89)
    assert luminaire_maintenance_factor("A", "normal", 1.25) == pytest.approx((0.89 + 0.85) / 2)
    assert luminaire_maintenance_factor("C", "dirty", 0.0) == 1.0
    assert luminaire_maintenance_factor("C", "dirty", 0.25) == pytest.approx((1 + 0.83) / 2)
    for t, rows in LMF_TABLE.items():
        a = np.array(rows)
        assert a.shape == (len(LMF_YEARS), 4), t
        assert np.all(np.diff(a, axis=0) <= 0), t  # dirtier with time
        assert np.all(np.diff(a, axis=1) <= 0), t  # and with the environment


def test_mf_is_the_product_of_its_factors():
    f = MaintenanceFactors(llmf=0.9, lsf=0.95, luminaire_type="E", environment="clean",
                           cleaning_interval_years=2, rsmf=0.97)
    assert maintenance_factor(f) == pytest.approx(0.9 * 0.95 * 0.90 * 0.97)
    assert maintenance_factor(MaintenanceFactors(mf=0.67)) == 0.67


def test_power_model_linear_table_and_gradient():
    m = PowerModel(jnp.array([100.0, 40.0]), jnp.array([2.0, 1.0]),
                   (None, (0.0, 0.5, 1.0)), (None, (0.1, 0.3, 1.0)))
    p = np.asarray(m.network_w(jnp.array([0.25, 0.75])))
    assert p[0] == pytest.approx(2 + 98 * 0.25)
    assert p[1] == pytest.approx(1 + 39 * (0.3 + 0.5 * 0.7))
    g = np.asarray(jax.grad(lambda d: m.total_w(d))(jnp.array([0.25, 0.75])))
    np.testing.assert_allclose(g, [98.0, 39 * 0.7 / 0.5], rtol=1e-5)
