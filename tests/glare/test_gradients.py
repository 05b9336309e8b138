"""The ratings are differentiable in dimmers, aims and levels: jax.grad against central
differences of the same model (tests/helpers.central_difference calls the function only)."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _glare import rect, scene_of, write_with_opening
from helpers import central_difference, lamp, network, photometry

from lumijax.design import Design
from lumijax.glare import Observer, build_glare_model
from lumijax.photometry import spot


@pytest.fixture(scope="module")
def model_and_design(tmp_path_factory):
    path = write_with_opening(tmp_path_factory.mktemp("grad") / "spot.ies", spot(3000.0, 40.0),
                              rect(0.15, 0.1))
    scene = scene_of(
        photometry("spot", file=path), network("a", 0.8), network("b", 0.6),
        lamp("A", [0, 0, 4], "a", "spot", aim={"tilt": 35, "pan": 185}),
        lamp("B", [2, 3, 5], "b", "spot", aim={"tilt": 25, "pan": 230}))
    observers = [Observer.looking("o", [-6, -1, 1.5], [1, 0.2, 0], fan_deg=(0.0, 30.0))]
    model = build_glare_model(scene, observers)
    model = eqx.tree_at(lambda m: (m.background, m.environment), model,
                        (jnp.asarray(np.full((2, 2), 3.0)), jnp.asarray(np.full((2, 2), 2.0))))
    return model, Design.of(scene)


def _at(design, x):
    """Dimmers (2), tilt (2), pan (2), level (2) from one flat vector."""
    return Design(x[0:2], x[2:4], x[4:6], design.spin_deg, x[6:8],
                  networks=design.networks, luminaires=design.luminaires)


def test_gradient_in_dimmers_aims_and_levels_matches_finite_differences(model_and_design):
    """UGR and GR of the first view, differentiated in all eight variables at once."""
    model, design = model_and_design
    x0 = np.concatenate([design.dimmers, design.tilt_deg, design.pan_deg, design.level])

    @jax.jit
    def f(x):
        r = model.ratings(_at(design, x))
        return jnp.stack([r.ugr[0], r.gr[0]])

    jac = np.asarray(jax.jit(jax.jacrev(f))(jnp.asarray(x0)))  # (2 ratings, 8 variables)
    fd = central_difference(f, jnp.asarray(x0), h=1e-4).T
    assert np.all(np.isfinite(jac))
    assert np.all(np.abs(jac[:, :2]) > 0.05)  # both dimmers move both ratings
    assert np.abs(jac[:, 2:6]).max() > 0.05  # and so do the aims
    np.testing.assert_allclose(jac, fd, rtol=2e-3, atol=1e-5)


def test_worst_ratings_are_the_largest_over_the_fan(model_and_design):
    from lumijax.glare import worst_ratings

    model, design = model_and_design
    r = model(design)
    w = jax.jit(lambda d: worst_ratings(model, d))(design)
    assert float(w["gr"][0]) == pytest.approx(float(jnp.max(r.gr)), rel=1e-9)
    assert float(w["ugr"][0]) == pytest.approx(float(jnp.max(r.ugr)), rel=1e-9)
    assert float(r.gr[0]) != pytest.approx(float(r.gr[1]), abs=0.1)  # the fan's views differ


def test_a_new_dimmer_vector_superposes_without_the_luminaires(model_and_design):
    """``at_aims`` sums each network's terms once; at any dimmers its ratings are the full
    model's (α² for Σ L²ω/p², α for the veiling and background luminances), and so are their
    derivatives in the dimmers."""
    model, design = model_and_design
    fast = model.at_aims(design)
    rng = np.random.default_rng(3)
    for alpha in (rng.uniform(0.1, 1.0, 2), np.array([1.0, 0.0]), np.array([0.0, 0.7])):
        full, quick = model(design.replace(dimmers=alpha)), fast(alpha)
        for name in ("ugr", "gr", "ugr_sum", "veiling_cdm2", "background_cdm2"):
            np.testing.assert_allclose(getattr(quick, name), getattr(full, name), rtol=1e-10,
                                       atol=1e-12, err_msg=name)

    def gr_full(a):
        return model.ratings(design.replace(dimmers=a)).gr[0]

    a0 = jnp.asarray([0.4, 0.9])
    np.testing.assert_allclose(jax.grad(lambda a: fast.ratings(a).gr[0])(a0),
                               jax.grad(gr_full)(a0), rtol=1e-9)
