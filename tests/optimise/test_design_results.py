"""The one Design on a computed study: the scene placed at a design is the scene its config
would build, ``results.at(design)`` equals a fresh computation of the config at that design,
and after a fit every reader (results.json, report, patches.vtp) shows the fitted design.

References come from the config path (a study file written with the new values, parsed and
built by ``load_study``) or from the per-network numbers the files themselves hold."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import lumijax
from lumijax import Design
from lumijax.design import traverse
from lumijax.optimise import optimise
from lumijax.optimise._models import build_aim_light

from .conftest import facade_text

NEW_AIMS = [(121.5, -91.25), (130.0, -97.5), (118.75, -86.0), (126.0, -92.0)]


def _study(facade_dir, name, **kwargs):
    path = facade_dir / name
    path.write_text(facade_text(optimise=None, **kwargs), "utf-8")
    return lumijax.load_study(path)


def test_with_design_places_the_scene_as_its_config_would(facade_dir, facade_results):
    study, _ = facade_results
    start = study.design
    same = study.scene.with_design(start)
    assert all(a is b for a, b in zip(same.luminaires, study.scene.luminaires, strict=True))
    d = start.replace(dimmers=[0.35, 0.8], tilt_deg=[t for t, _ in NEW_AIMS],
                      pan_deg=[p for _, p in NEW_AIMS], level=[1.0, 0.5, 1.0, 0.25])
    placed = study.scene.with_design(d)
    back = Design.of(placed)  # of → with_design → of: the same design, bit for bit
    for f in ("dimmers", "tilt_deg", "pan_deg", "spin_deg", "level"):
        np.testing.assert_array_equal(getattr(back, f), getattr(d, f))
    ref = _study(facade_dir, "placed.toml", aims=NEW_AIMS, dimmers=(0.35, 0.8)).scene
    np.testing.assert_array_equal(placed.dimmers, ref.dimmers)
    for a, b, level in zip(placed.luminaires, ref.luminaires, d.level, strict=True):
        np.testing.assert_allclose(a.rotation, b.rotation, rtol=0, atol=1e-15)
        assert a.scale == pytest.approx(b.scale * level, rel=1e-15)  # multiplier 1 × level
    # a level set back to 1 is rebuilt from the config's multiplier, not divided out
    again = placed.with_design(start)
    assert [lum.scale for lum in again.luminaires] == [lum.scale for lum in ref.luminaires]


def test_a_design_for_another_study_is_refused(facade_results):
    study, _ = facade_results
    other = Design([1.0], [], [], [], [], networks=("x",), luminaires=())
    with pytest.raises(lumijax.ConfigError, match="other networks or luminaires") as e:
        study.scene.with_design(other)
    assert e.value.key == "design"
    with pytest.raises(lumijax.LumijaxError, match="other networks or luminaires"):
        facade_results[1].at(other)


def test_results_at_new_dimmers_equal_a_fresh_compute(facade_dir, facade_results):
    study, results = facade_results
    d = results.design.replace(dimmers={"n0": 0.35, "n1": 0.8})
    at = results.at(d)
    # no solve: the per-network light is shared, only the dimmers are new
    assert at["wall"].by_network_lux is results["wall"].by_network_lux
    fresh = lumijax.compute(_study(facade_dir, "dimmed.toml", dimmers=(0.35, 0.8)))
    for name, g in fresh.grids.items():
        np.testing.assert_allclose(at.grids[name].illuminance_lux, g.illuminance_lux,
                                   rtol=1e-12, atol=0)
        assert at.grids[name].dimmers is at.design.dimmers  # a view of the one Design
    assert at.networks == fresh.networks
    assert at.lighting.scene.dimmers.tolist() == [0.35, 0.8]


def test_results_at_new_aims_equal_the_aim_model(facade_results):
    study, results = facade_results
    d = results.design.replace(tilt_deg=[t for t, _ in NEW_AIMS],
                               pan_deg=[p for _, p in NEW_AIMS])
    at = results.at(d)  # a full computation at the design (the scene as its config would
    # place it: test_with_design_places_the_scene_as_its_config_would)
    assert at.design.only_dimmers_differ(d) and d.only_dimmers_differ(at.design)
    assert at.lighting.scene.luminaires[0].tilt == NEW_AIMS[0][0]
    # an independent model of the same light: the optimiser's pair kernel and linear solve of
    # the change of inter-reflection, exact for this facade's point sources and luminous solve
    # (tests/optimise/conftest.py) up to the solve's tolerance (measured 1.7e-12 of Emax), once
    # its first-order light near the spots is re-centred at the design (test_near_aims.py)
    ranges = [((-8, 8), (-8, 8))] * 4
    params = traverse(results.design, ("dimmers", "aims"), luminaires=range(4),
                      aim_bounds_deg=ranges)
    model = build_aim_light(results.lighting, list(range(4)), np.radians([16.0] * 4),
                            np.radians([16.0] * 4), aims=True, levels=False)
    x = params.flatten(d)
    e, _, _ = model.recentred(x)(x)
    ref = at["wall"].illuminance_lux
    err = np.abs(np.asarray(e) - ref).max() / ref.max()
    assert err < 1e-9, err
    moved = np.abs(ref - results["wall"].illuminance_lux).max() / ref.max()
    assert moved > 0.05  # the new aims do change the light: the comparison means something


def test_every_reader_shows_the_fitted_dimmers(facade_dir, facade_results, tmp_path):
    """Regression: the report read the first grid's dimmers, patches.vtp the lighting's
    scene, results.json the networks' copies; now all read ``results.design``."""
    from lumijax.report import write_results
    from lumijax.report._html import report_context

    path = facade_dir / "readers.toml"
    path.write_text(facade_text(grid_extra="target_lux = 20"), "utf-8")
    study = lumijax.load_study(path)
    fit = optimise(study, facade_results[1])
    fitted = fit.design.dimmer_of()
    assert fitted != study.design.dimmer_of()
    res = fit.results
    # make the lighting's scene stale (the config's dimmers), as the old writer trusted it
    stale = dataclasses.replace(res, lighting=dataclasses.replace(res.lighting,
                                                                  scene=study.scene))
    write_results(stale, tmp_path, images=False)
    data = json.loads((tmp_path / "results.json").read_text())
    assert {n: v["dimmer"] for n, v in data["networks"].items()} == fitted
    assert data["optimisation"]["dimmers"] == fitted
    g = data["grids"]["wall"]
    np.testing.assert_allclose(g["illuminance_lux"], sum(
        fitted[n] * np.array(g["by_network_lux"][n]) for n in fitted), rtol=1e-12)
    import pyvista as pv

    cells = pv.read(tmp_path / "patches.vtp").cell_data
    np.testing.assert_allclose(cells["radiosity_lm_m2"], sum(
        fitted[n] * cells[f"radiosity_lm_m2:{n}"] for n in fitted), rtol=1e-12)
    ctx = report_context(study, stale, pictures=False)
    assert {n["name"]: n["dimmer_value"] for n in ctx["networks"]} == fitted
    start = study.design.dimmer_of()
    for row in ctx["optimisation"]["dimmers"]:
        assert row["after"] != row["before"] or fitted[row["name"]] == start[row["name"]]
