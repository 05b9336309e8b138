"""Sensitivities (``lumijax.optimise.sensitivity``): autodiff derivatives against central finite
differences of the same light, the light against the computed study at the start, and the
dimmer rows against the superposition written out by hand."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax import ConfigError
from lumijax.lighting._solution import float64_scope
from lumijax.optimise import sensitivity
from lumijax.optimise._constraints import DesignLight, GridUniformity
from lumijax.optimise._models import build_aim_light
from lumijax.optimise._sensitivity import _full_light, reflectance_light
from tests.helpers import central_difference


@pytest.fixture(scope="module")
def wall_u0(facade_results):
    study, results = facade_results
    return study, results, sensitivity(study, results, "wall.u0")


def test_dimmer_rows_are_the_superposition(facade_results):
    study, results = facade_results
    s = sensitivity(study, results, "wall.avg", aims=False, reflectances=False)
    by_net = results["wall"].by_network_lux
    for k, n in enumerate(results.design.networks):
        assert s.derivative("dimmer", n) == pytest.approx(by_net[k].mean(), rel=1e-12)
    assert s.value == pytest.approx(results["wall"].stats["avg"], rel=1e-12)


@float64_scope()
def test_aim_and_flux_rows_match_finite_differences(facade_results, wall_u0):
    """The rows for tilt, pan and flux against central differences of the light the rows are
    taken from; that light at the start is the computed study's (so the derivative is the
    study's, not a model's of something else)."""
    study, results, s = wall_u0
    lighting = results.lighting
    n = len(results["wall"].points)
    c = GridUniformity(label="u0", key="k", unit="", sense=1, bound=jnp.asarray(0.0), ref=1.0,
                       start=0, stop=n)
    crit = lambda e, a: c.value(DesignLight(e, None, a, a), None)  # noqa: E731
    idx = list(range(len(lighting.scene.luminaires)))
    model = build_aim_light(lighting, idx, np.zeros(4), np.zeros(4), aims=True, levels=True)
    at = jax.jit(_full_light(model, lighting, crit))
    alpha = jnp.asarray(results.design.dimmers)
    x0 = jnp.concatenate([alpha, model.tilt0, model.pan0, jnp.ones(4)])
    assert float(at(x0)) == pytest.approx(results["wall"].stats["u0"], rel=1e-6)
    fd = central_difference(at, x0, h=1e-6, indices=range(2, 14))
    for j, lum in enumerate(lighting.scene.luminaires):
        assert s.derivative("tilt", lum.name) == pytest.approx(
            fd[j] * np.pi / 180, rel=1e-3, abs=1e-7)
        assert s.derivative("pan", lum.name) == pytest.approx(
            fd[4 + j] * np.pi / 180, rel=1e-3, abs=1e-7)
        assert s.derivative("flux", lum.name) == pytest.approx(fd[8 + j], rel=1e-3, abs=1e-7)
    # the aims matter on this facade: some rows are far from zero
    assert max(abs(s.derivative("tilt", lum.name)) for lum in lighting.scene.luminaires) > 1e-3


@float64_scope()
def test_reflectance_row_matches_finite_differences(facade_results, wall_u0):
    study, results, s = wall_u0
    lighting = results.lighting
    used, f = reflectance_light(lighting, results.design.dimmers)
    e1 = np.asarray(f(jnp.ones(len(used))))
    # the light through the solve at the computed reflectances is the study's
    np.testing.assert_allclose(e1, results["wall"].illuminance_lux, rtol=1e-4,
                               atol=1e-4 * e1.max())
    rho = lighting.scene.materials[int(used[0])].luminous_reflectance

    def u0(sv):
        e = f(sv)
        return jnp.min(e) / jnp.mean(e)

    fd = central_difference(u0, jnp.ones(len(used)), h=1e-4)[0]
    assert s.derivative("reflectance", "wall") == pytest.approx(fd / rho, rel=1e-3)
    # and against the gradient of the other criterion, avg, taken independently
    g = jax.grad(lambda sv: jnp.mean(f(sv)))(jnp.ones(len(used)))
    s_avg = sensitivity(study, results, "wall.avg", aims=False)
    assert s_avg.derivative("reflectance", "wall") == pytest.approx(float(g[0]) / rho,
                                                                   rel=1e-9)


def test_rows_are_ranked_by_effect_and_bad_metrics_are_named(wall_u0, facade_results):
    _, _, s = wall_u0
    effects = [abs(r["effect"]) for r in s.rows]
    assert effects == sorted(effects, reverse=True)
    assert {r["kind"] for r in s.rows} >= {"dimmer", "tilt", "pan", "flux",
                                          "maintenance_factor", "reflectance"}
    study, results = facade_results
    with pytest.raises(ConfigError, match="no grid named 'desk'"):
        sensitivity(study, results, "desk.avg")
    with pytest.raises(ConfigError, match="unknown criterion 'median'"):
        sensitivity(study, results, "wall.median")
