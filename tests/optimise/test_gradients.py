"""Every objective term's gradient against central finite differences (float64), for the
dimmer model and for the aim model (direct light and the inter-reflected change through the
radiosity solve)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import central_difference

from lumijax.optimise import DimmerLight, Objective
from lumijax.optimise._models import build_aim_light
from lumijax.optimise._targets import GridGoal


def _goals(n):
    rng = np.random.default_rng(1)
    return (
        GridGoal("a", 0, n // 2, target=rng.uniform(20, 60, n // 2), target_kind="target_csv",
                 weight=2.0, min_lux=25.0, max_lux=45.0, uniformity_min=0.8,
                 max_luminance_cdm2=5.0, rho=0.5),
        GridGoal("b", n // 2, n, target=np.full(n - n // 2, 30.0), target_kind="target_lux",
                 min_lux=28.0),
    )


TERMS = ["target", "min_lux", "uniformity_min", "max_lux", "max_luminance_cdm2",
         "patch_luminance", "energy"]


@pytest.mark.parametrize("term", TERMS)
def test_dimmer_objective_gradient(term):
    rng = np.random.default_rng(0)
    k, n, p = 3, 40, 25
    model = DimmerLight(jnp.asarray(rng.uniform(0, 40, (k, n))),
                        jnp.asarray(rng.uniform(0, 30, (k, p))))
    obj = Objective.build(_goals(n), [30.0, 50.0, 20.0], energy_weight=0.7,
                          patch_max_luminance=4.0).only(term)
    x = np.array([0.55, 0.8, 0.35])

    def f(x):
        e, b, a = model(jnp.asarray(x))
        return obj.value(e, b, a)

    value = float(f(x))
    assert value > 1e-6, f"term {term} is inactive at the test point: the check would be empty"
    g = np.asarray(jax.grad(f)(jnp.asarray(x)))
    np.testing.assert_allclose(g, central_difference(f, x), rtol=1e-5, atol=1e-9)


AIM_TERMS = ["target", "min_lux", "uniformity_min", "max_lux", "max_luminance_cdm2",
             "patch_luminance"]


@pytest.fixture(scope="module")
def aim_model(facade_results):
    """The aim model of the four facade spots (±10°), built once for this module."""
    lighting = facade_results[1].lighting
    span = np.radians(np.full(4, 10.0))
    return build_aim_light(lighting, [0, 1, 2, 3], span, span, aims=True, levels=False)


def test_aim_objective_gradient(facade_results, aim_model):
    """d f / d(dimmers, tilt, pan) of each term: the direct pair kernel through the aim
    rotation, and the change of inter-reflection through the adjoint radiosity solve."""
    model = aim_model
    n = len(facade_results[1].lighting.points)
    obj = Objective.build(_goals(n), [30.0, 50.0], patch_max_luminance=0.5)
    x0 = np.concatenate([[0.7, 0.9], np.asarray(model.tilt0) + 0.03,
                         np.asarray(model.pan0) - 0.02])

    @jax.jit
    def f(x):
        e, b, a = model(x)
        return jnp.stack([obj.only(t).value(e, b, a) for t in AIM_TERMS])

    values = np.asarray(f(jnp.asarray(x0)))
    assert np.all(values > 1e-8), dict(zip(AIM_TERMS, values, strict=True))
    jac = np.asarray(jax.jacrev(f)(jnp.asarray(x0)))
    # small steps: the candela table is bilinear, so the slope jumps at its cells; a step of
    # 1e-5 rad already straddles one in this scene
    fds = central_difference(f, jnp.asarray(x0), h=1e-6)
    for i, fd in enumerate(fds):
        err = np.abs(jac[:, i] - fd)
        ok = err <= 1e-5 * np.abs(fd) + 1e-8 * np.abs(jac).max(axis=1)
        assert ok.all(), (i, [(t, jac[j, i], fd[j]) for j, t in enumerate(AIM_TERMS)
                              if not ok[j]])


def test_aim_model_reproduces_the_study_at_the_start(facade_results, aim_model):
    """At the config's aims the model's light is the computed study's, exactly."""
    study, results = facade_results
    lighting = results.lighting
    model = aim_model
    alpha = np.array([0.6, 0.9])
    x = np.concatenate([alpha, np.asarray(model.tilt0), np.asarray(model.pan0)])
    e, b, _ = model(jnp.asarray(x))
    np.testing.assert_allclose(np.asarray(e), results["wall"].illuminance_lux, rtol=1e-9,
                               atol=1e-9)
    np.testing.assert_allclose(np.asarray(b), alpha @ lighting.coarse.radiosity, rtol=1e-9,
                               atol=1e-9)


def test_float32_pairs_agree_with_float64(facade_results, aim_model):
    """A float32 study runs the pairs in float32: away from the start aims its light is the
    (finite-difference checked) float64 model's to float32 rounding."""
    lighting = facade_results[1].lighting
    span = np.radians(np.full(4, 10.0))
    m32 = build_aim_light(lighting, [0, 1, 2, 3], span, span, aims=True, levels=False,
                          pair_dtype=np.float32)
    assert m32.pairs[0].gain.dtype == np.float32
    x = jnp.asarray(np.concatenate([[0.7, 0.9], np.asarray(aim_model.tilt0) + 0.05,
                                    np.asarray(aim_model.pan0) - 0.04]))
    e64, b64, _ = aim_model(x)
    e32, b32, _ = m32(x)
    assert e32.dtype == np.float64  # the objective stays float64
    np.testing.assert_allclose(np.asarray(e32), np.asarray(e64), rtol=1e-5,
                               atol=1e-6 * float(jnp.max(e64)))
    np.testing.assert_allclose(np.asarray(b32), np.asarray(b64), rtol=1e-5,
                               atol=1e-6 * float(jnp.max(b64)))
