"""One pair set for the forward direct light and the aim model (project issue 13 §2): at the start
design the aim model's direct light is the forward direct light to float precision, on a study
with a shadow, an extended source split by the 5× rule and an LM-63 TILT lamp."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import lamp, material, network, photometry, plane_grid, rectangle, study_text, table

import lumijax
from lumijax.direct import direct_illuminance, point_illuminance
from lumijax.lighting._solution import float64_scope
from lumijax.optimise._models import build_aim_light
from lumijax.photometry import LuminousOpening, TiltTable, flood, write_ies

# a hand-made TILT table: 1 at 0°, 0.9 at 45°, 0.8 at 90° (the shared file's values)
TILT = TiltTable(geometry=1, angles_deg=(0.0, 45.0, 90.0, 180.0), factors=(1.0, 0.9, 0.8, 1.0))
OCCLUDER = (0.3, 0.9, -2.0, 2.0, 1.2)  # x0, x1, y0, y1, z (m): a plank between lamp and grid


def _study(write_study, folder, tilt_file):
    bar = dataclasses.replace(flood(2000, 100, 80),
                              opening=LuminousOpening(1.2, 0.2, 0.0, "rectangle"))
    write_ies(bar, folder / "bar.ies")
    x0, x1, y0, y1, z = OCCLUDER
    return lumijax.load_study(write_study(study_text(
        table("solver", cache=False, spectral_samples=0), material("grey", 0.3),
        photometry("tilted", file=tilt_file), photometry("bar", file=folder / "bar.ies"),
        network("a"), network("b"),
        rectangle([x0, y0, z], [0, y1 - y0, 0], [x1 - x0, 0, 0], "grey"),
        lamp("tilted", [0.4, 0.1, 2.5], "a", "tilted", aim={"tilt": 30, "pan": 10}),
        lamp("bar", [-0.9, 0.0, 0.3], "b", "bar", aim={"tilt": 8, "pan": 0}),
        plane_grid("g", [-2, -1.5, 0], [4, 0, 0], [0, 3, 0], nu=41, nv=31))))


@pytest.fixture
def tilt_ies(tmp_path):
    write_ies(dataclasses.replace(flood(3000, 50, 40), tilt=TILT), tmp_path / "tilted.ies")
    return tmp_path / "tilted.ies"


def _check(study, *, aims):
    sc = study.scene
    lighting = lumijax.compute(study, indirect=False).lighting
    g = sc.grids[0]
    forward = direct_illuminance(sc, g.points, g.normals)
    with float64_scope():
        span = np.radians([20.0, 20.0]) if aims else np.zeros(2)
        model = build_aim_light(lighting, [0, 1], span, span, aims=aims, levels=False,
                                indirect=False)
        e = np.asarray(model.direct(model.tilt0, model.pan0, jnp.ones(2, jnp.float64)))
    ref = forward.by_network.sum(axis=0)
    assert ref.max() > 0
    np.testing.assert_allclose(e, ref, rtol=2e-6, atol=1e-6 * ref.max())
    return sc, g, forward


@pytest.mark.parametrize("aims", [True, False], ids=["aims-widened", "levels-only"])
def test_aim_model_at_start_is_the_forward_direct_light(write_study, tmp_path, tilt_ies, aims):
    study = _study(write_study, tmp_path, tilt_ies)
    sc, g, forward = _check(study, aims=aims)
    if not aims:
        return
    # the three effects are really in play: the plank shadows part of the grid ...
    open_sky = direct_illuminance(sc, g.points, g.normals, shadows=False).by_network
    x0, x1, _, _, z = OCCLUDER
    lamp = sc.luminaires[0].position
    s = (lamp[2] - z) / lamp[2]  # where the ray lamp → point crosses the plank's plane
    cross = lamp[:2] + s * (g.points[:, :2] - lamp[:2])
    hidden = (cross[:, 0] > x0 + 0.02) & (cross[:, 0] < x1 - 0.02)
    lit = (cross[:, 0] < x0 - 0.02) | (cross[:, 0] > x1 + 0.02)
    assert hidden.sum() > 20 and np.all(forward.by_network[0, hidden] == 0)
    np.testing.assert_allclose(forward.by_network[0, lit], open_sky[0, lit], rtol=1e-6)
    assert open_sky[0, hidden].max() > 0.1 * open_sky[0].max()
    # ... the TILT lamp's scale holds the table's factor at its world tilt (30°: 1 − 0.1·30/45)
    assert sc.luminaires[0].scale == pytest.approx(1.0 - 0.1 * 30 / 45, rel=1e-6)
    # ... and the bar, 0.3 m above the grid, is split: one point source would be far off there
    bar = sc.luminaires[1]
    dist = sc.photometries["bar"].distribution
    point = np.asarray(point_illuminance(
        dist, jnp.asarray(bar.position[None]), jnp.asarray(bar.rotation[None]),
        jnp.asarray([bar.scale]), jnp.asarray(g.points), jnp.asarray(g.normals)))[0]
    near = np.linalg.norm(g.points - bar.position, axis=1) < 1.0
    assert np.max(np.abs(point - forward.by_network[1])[near]) > 0.1 * forward.by_network[1].max()


def test_aim_model_at_start_with_the_shared_tilt_file(write_study, tmp_path, shared_photometry):
    study = _study(write_study, tmp_path, shared_photometry / "er_TILT_TEST_SYNTHETIC.ies")
    assert study.scene.photometries["tilted"].tilt is not None
    _check(study, aims=True)
