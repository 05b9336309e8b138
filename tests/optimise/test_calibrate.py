"""Calibration to measured lux: planted light-loss factors and a planted reflectance recovered
from "measurements" made by the full pipeline (another compute of the room at the planted
values), exactly without noise; bad CSVs named by
file and line; the calibrated study written back loads with the fitted values. The noisy
recovery and its uncertainties are measured in studies/design (README.md)."""

from __future__ import annotations

import numpy as np
import pytest

import lumijax
from lumijax import ConfigError
from lumijax.optimise import calibrate
from tests.helpers import box_room

SOLVER = ("target_patches = 60\ngather_rays = 32\nspectral_samples = 0\ncache = false\n"
          'precision = "float64"')


def _write(path, grid, lux, *, shift=None):
    pts = np.array(grid.points, np.float64)
    if shift is not None:
        pts[shift[0]] += shift[1]
    rows = "\n".join(",".join(repr(float(v)) for v in (*p, *n, e))
                     for p, n, e in zip(pts, grid.normals, lux, strict=True))
    path.write_text("x,y,z,nx,ny,nz,lux\n" + rows + "\n", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def planted(tmp_path_factory):
    d = tmp_path_factory.mktemp("calib")
    model = d / "model.toml"
    model.write_text(box_room(SOLVER), "utf-8")
    truth = d / "truth.toml"
    truth.write_text(box_room(SOLVER).replace("reflectance = 0.5", "reflectance = 0.62")
                     .replace('network = "a"\n', 'network = "a"\nmaintenance_factor = 0.8\n'),
                     "utf-8")
    study = lumijax.load_study(model)
    return d, study, lumijax.compute(study), lumijax.compute(lumijax.load_study(truth))


@pytest.mark.slow
def test_planted_parameters_are_recovered(planted):
    d, study, results, measured = planted
    g = measured["floor"]
    exact = calibrate(study, results, _write(d / "exact.csv", g, g.illuminance_lux))
    assert exact.llf["a"] == pytest.approx(0.8, abs=1e-6)
    assert exact.llf["b"] == pytest.approx(1.0, abs=1e-6)
    assert exact.reflectance["wall"] == pytest.approx(0.62, abs=1e-6)
    assert exact.rms_before > 0.1 and exact.rms_after < 1e-8
    # with noise, the uncertainties: studies/design/calibrate.py (1 % noise, 4σ, RESULTS)
    cal = exact
    # the calibrated study, written back, loads with the fitted values
    out = cal.write_config(d / "calibrated.toml")
    again = lumijax.load_study(out)
    assert again.config.materials["wall"].reflectance == pytest.approx(
        cal.reflectance["wall"], abs=1e-4)
    assert again.config.luminaires[0].maintenance_factor == pytest.approx(cal.llf["a"],
                                                                           abs=1e-4)


def test_bad_measurements_are_named_by_file_and_line(planted):
    d, study, results, measured = planted
    g = measured["floor"]
    bad = _write(d / "off.csv", g, g.illuminance_lux, shift=(3, [0.0, 0.0, 0.5]))
    with pytest.raises(ConfigError, match="lies at no grid point") as err:
        calibrate(study, results, bad)
    assert err.value.line == 5 and err.value.key == "calibration.csv"
    head = d / "head.csv"
    head.write_text("x,y,z,lux\n1,1,0,5\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="header"):
        calibrate(study, results, head)
    with pytest.raises(ConfigError, match="'llf' and/or 'reflectance'"):
        calibrate(study, results, head, fit=("aims",))
