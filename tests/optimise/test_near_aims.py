"""The aim model's light on patches near a re-aimed luminaire (``AimLight.near_*``): what the
mean over such a patch adds to its centroid's light, against the forward solve's own samples
(``radiosity.near_light``, lit by the direct stage at each aim, not by the model): equal at the
start and wherever the model is re-centred, and to first order in the aim elsewhere — the
model's error falls as the square of the aim change."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import lamp, material, network, photometry, rectangle, study_text, table

import lumijax
from lumijax.lighting._solution import float64_scope
from lumijax.optimise import _models
from lumijax.optimise._models import build_aim_light
from lumijax.photometry import flood, write_ies
from lumijax.radiosity import near_light

TILT, PAN = 35.0, 20.0  # the flood's start aim (degrees): its beam lands on the floor near it


@pytest.fixture(scope="module")
def grazer(tmp_path_factory):
    """A 4 × 4 m floor and a wall, a 60° × 40° flood 0.15 m over the floor (coarse patches,
    0.5 m and more: every patch under it is sampled), and a bare lamp far up on another
    network, so that the flood's network holds the flood alone."""
    d = tmp_path_factory.mktemp("grazer")
    write_ies(flood(3000, 60, 40), d / "flood.ies")
    path = d / "study.toml"
    path.write_text(study_text(
        table("solver", precision="float64", cache=False, spectral_samples=0,
              target_patches=60, gather_rays=32),
        material("grey", 0.5), photometry("flood", file=d / "flood.ies"),
        photometry("iso", kind="isotropic", flux_lm=500.0), network("a"), network("b"),
        rectangle([0, 0, 0], [4, 0, 0], [0, 4, 0], "grey"),
        rectangle([0, 4, 0], [4, 0, 0], [0, 0, 3], "grey"),
        lamp("flood", [1.5, 1.2, 0.15], "a", "flood", aim={"tilt": TILT, "pan": PAN}),
        lamp("high", [2.0, 2.0, 2.8], "b", "iso")), encoding="utf-8")
    study = lumijax.load_study(path)
    return study, lumijax.compute(study)


def _exact(results, tilt, pan):
    """The forward solve's near addition on each patch of the flood alone at this aim (lx)."""
    design = results.design.replace(tilt_deg=[tilt, 0.0], pan_deg=[pan, 0.0])
    scene = results.lighting.scene.with_design(design)
    return near_light(scene, results.lighting.coarse.patches)[0][0]


def _model_near(model, tilt, pan):
    """The model's near addition on each patch of the flood at unit weight at this aim (lx):
    its patch light less the centroids' light."""
    t, p, w = (jnp.asarray([np.radians(tilt)]), jnp.asarray([np.radians(pan)]),
               jnp.ones(1))
    flat = model.direct(t, p, w)
    n, count = model.n_points, int(model.rho.shape[0])
    return np.asarray(model.patch_light(flat, t, p, w) - flat[n:n + count])


def _model(results):
    span = np.radians([10.0])
    return build_aim_light(results.lighting, [0], span, span, aims=True, levels=True)


def test_near_addition_errs_as_the_square_of_the_aim_change(grazer):
    """Equal to the forward solve's at the start; halving the aim change quarters the error."""
    study, results = grazer
    with float64_scope():
        model = _model(results)
        assert model.near_var.shape[0] > 10
        start = _exact(results, TILT, PAN)
        assert np.abs(start).max() > 0.05 * results.lighting.coarse.patch_direct.max()
        np.testing.assert_allclose(_model_near(model, TILT, PAN), start,
                                   atol=1e-6 * np.abs(start).max())
        errors = []
        for step in (4.0, 2.0):
            aim = (TILT + step, PAN - step)
            exact = _exact(results, *aim)
            moved = np.abs(exact - start).max()
            errors.append(np.abs(_model_near(model, *aim) - exact).max())
            assert errors[-1] < 0.2 * moved  # first order: most of the change is modelled
        assert moved > 0.02 * np.abs(start).max()  # and the aim does move it
        # second order: halving the aim change quarters the error (3.2-4.8 allowed)
        assert 3.2 < errors[0] / errors[1] < 4.8, errors


def test_a_recentred_model_is_exact_at_its_new_centre(grazer):
    """Re-centred at other aims, the model's near addition there is the forward solve's, and
    its light at the start aims is still the forward's to first order (the error of the
    other side)."""
    study, results = grazer
    with float64_scope():
        model = _model(results)
        aim = (TILT + 4.0, PAN - 4.0)
        x = jnp.asarray([1.0, 1.0, np.radians(aim[0]), np.radians(aim[1]), 1.0])
        moved = model.recentred(x)
        assert moved.pairs[0].gain is model.pairs[0].gain  # only the near terms are new
        exact = _exact(results, *aim)
        np.testing.assert_allclose(_model_near(moved, *aim), exact,
                                   atol=1e-9 * np.abs(exact).max())
        start = _exact(results, TILT, PAN)
        np.testing.assert_allclose(_model_near(moved, TILT, PAN), start,
                                   atol=0.2 * np.abs(exact - start).max())


def test_trust_region_holds_the_aims_near_the_centre(grazer):
    """A tightening round's box: aims within TRUST_AIM of the centre and inside the original
    bounds, the dimmers' and levels' bounds untouched."""
    study, results = grazer
    with float64_scope():
        model = _model(results)
    x = np.array([0.5, 1.0, np.radians(TILT), np.radians(PAN + 9.5), 0.7])
    lo = np.array([0.1, 0.1, np.radians(TILT - 10), np.radians(PAN - 10), 0.1])
    hi = np.array([1.0, 1.0, np.radians(TILT + 10), np.radians(PAN + 10), 1.0])
    box_lo, box_hi = model.trust_region(x, lo, hi)
    np.testing.assert_allclose(box_lo, [0.1, 0.1, x[2] - _models.TRUST_AIM,
                                        x[3] - _models.TRUST_AIM, 0.1])
    np.testing.assert_allclose(box_hi, [1.0, 1.0, x[2] + _models.TRUST_AIM, hi[3], 1.0])
