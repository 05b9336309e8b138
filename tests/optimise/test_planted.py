"""Planted solutions, exact bounds, infeasible goals and bad settings.

The targets are made by the full ``lumijax.compute`` pipeline from known dimmers and aims; the
fit starts elsewhere and must find them."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

import lumijax
from lumijax import ConfigError, config
from lumijax.optimise import SOLVERS, DimmerLight, Objective, minimise, optimise
from lumijax.optimise._optimise import _residuals
from lumijax.optimise._targets import GridGoal

from .conftest import START_AIMS, facade_text


def _write_map(path, grid, lux):
    # float(): numpy 2 writes a numpy scalar's repr as "np.float64(…)", which is not a number
    rows = "\n".join(",".join(repr(float(c)) for c in (*p, v))
                     for p, v in zip(grid.points, lux, strict=True))
    path.write_text("x,y,z,lux\n" + rows + "\n", encoding="utf-8")


@pytest.mark.parametrize("solver", SOLVERS)
def test_bounded_least_squares_matches_scipy_and_keeps_the_box(solver):
    """A target no dimmer setting in the box can meet: the exact box-constrained least-squares
    answer (scipy's lsq_linear, an independent solver) has dimmers on both bounds."""
    rng = np.random.default_rng(3)
    k, n = 4, 60
    a = rng.uniform(0, 50, (k, n))
    target = np.array([1.6, -0.4, 0.5, 0.3]) @ a  # outside the box on two networks
    goal = GridGoal("g", 0, n, target=target, target_kind="target_csv")
    obj = Objective.build((goal,), np.ones(k))
    lo, hi = np.full(k, 0.1), np.ones(k)
    run = minimise(_residuals, (DimmerLight(a, None), obj), np.full(k, 0.5), lo, hi,
                   solver=solver, max_steps=500, tolerance=1e-12)
    ref = lsq_linear(a.T, target, bounds=(lo, hi), tol=1e-14).x
    assert np.all(run.x >= lo) and np.all(run.x <= hi)
    f = 0.5 * np.mean(((run.x @ a - target) / target.mean()) ** 2)
    assert f == pytest.approx(min(run.history), rel=1e-9) and f < run.history[0]
    if solver == "gauss_newton":
        return  # undamped: it may stop short with active bounds (docs/optimise.md)
    # projected gradient is first order: slow on this ill-conditioned problem, held to 1e-3
    np.testing.assert_allclose(run.x, ref, atol=1e-3 if solver == "projected_gradient" else 1e-4)
    assert run.x[0] == pytest.approx(1.0, abs=1e-4) and run.x[1] == pytest.approx(0.1, abs=1e-4)


def test_dimmers_recovered_from_a_planted_map(facade_dir, facade_results):
    study, results = facade_results
    truth = np.array([0.35, 0.8])
    _write_map(facade_dir / "dimmer_target.csv", results["wall"],
               results["wall"].at_dimmers(truth))
    path = facade_dir / "dimmers.toml"
    path.write_text(facade_text(grid_extra='target_csv = "dimmer_target.csv"'), "utf-8")
    s = lumijax.load_study(path)
    opt = optimise(s, results, tolerance=1e-12)
    got = np.array([opt.dimmers["n0"], opt.dimmers["n1"]])
    np.testing.assert_allclose(got, truth, atol=1e-3)
    assert not opt.unmet
    np.testing.assert_allclose(opt.results["wall"].illuminance_lux,
                               results["wall"].at_dimmers(truth), rtol=1e-3, atol=1e-6)
    assert opt.before["wall"] == results["wall"].stats


def test_aims_and_dimmers_recovered_from_a_planted_map(facade_dir, facade_results,
                                                       monkeypatch):
    """The target is the full pipeline's light at known aims and dimmers; the fit starts from
    aims 3–5° away and other dimmers, and finds the aims within 0.5° and dimmers within 1e-3."""
    true_aims = [(t + dt, p + dp) for (t, p), (dt, dp) in
                 zip(START_AIMS, [(4, -3), (-3, 4), (5, 2), (-2, -5)], strict=True)]
    truth = facade_dir / "truth.toml"
    truth.write_text(facade_text(aims=true_aims, dimmers=(0.45, 0.7), optimise=None), "utf-8")
    true_results = lumijax.compute(lumijax.load_study(truth))
    _write_map(facade_dir / "aim_target.csv", true_results["wall"],
               true_results["wall"].illuminance_lux)
    path = facade_dir / "aims.toml"
    path.write_text(facade_text(grid_extra='target_csv = "aim_target.csv"',
                                optimise='variables = ["dimmers", "aims"]\n'
                                         'tilt_range_deg = [-8, 8]\npan_range_deg = [-8, 8]\n'
                                         'tolerance = 1e-12\nmax_steps = 100'), "utf-8")
    study, results = facade_results
    s = lumijax.load_study(path)

    def refuse(*args, **kwargs):
        raise AssertionError("the optimiser parsed config text to light its design")

    # the fitted design is lit by scene.with_design, never by writing and parsing TOML
    monkeypatch.setattr(config, "parse_config", refuse)
    monkeypatch.setattr(config, "load_config", refuse)
    opt = optimise(s, results)
    monkeypatch.undo()
    for name, (t, p) in zip(["s0", "s1", "s2", "s3"], true_aims, strict=True):
        assert opt.aims[name]["tilt"] == pytest.approx(t, abs=0.5), opt.aims
        assert opt.aims[name]["pan"] == pytest.approx(p, abs=0.5), opt.aims
    assert opt.dimmers["n0"] == pytest.approx(0.45, abs=1e-3)
    assert opt.dimmers["n1"] == pytest.approx(0.7, abs=1e-3)
    # the results are lit at the fitted design itself, and optimised.toml (written for the
    # designer, 4 decimals) loads back to it
    for f in ("dimmers", "tilt_deg", "pan_deg", "spin_deg", "level"):
        np.testing.assert_array_equal(getattr(opt.results.design, f), getattr(opt.design, f))
    (facade_dir / "aims-optimised.toml").write_text(opt.config_text(facade_dir), "utf-8")
    again = lumijax.load_study(facade_dir / "aims-optimised.toml").design
    np.testing.assert_allclose(again.tilt_deg, opt.design.tilt_deg, rtol=0, atol=5e-5)
    np.testing.assert_allclose(again.pan_deg, opt.design.pan_deg, rtol=0, atol=5e-5)
    # the results are a full re-computation at the optimised design
    np.testing.assert_allclose(opt.results["wall"].illuminance_lux,
                               true_results["wall"].illuminance_lux, rtol=0.02,
                               atol=0.01 * true_results["wall"].stats["max"])


def test_infeasible_target_says_by_how_much_and_keeps_the_best(facade_dir, facade_results):
    study, results = facade_results
    full = results["wall"].at_dimmers(np.ones(2)).mean()
    path = facade_dir / "bright.toml"
    path.write_text(facade_text(grid_extra=f"target_lux = {10 * full:.6g}"), "utf-8")
    opt = optimise(lumijax.load_study(path), results)
    assert opt.dimmers == pytest.approx({"n0": 1.0, "n1": 1.0}, abs=1e-6)
    [t] = opt.targets
    assert not t["met"] and t["achieved"] == pytest.approx(full, rel=1e-9)
    [line] = opt.unmet
    assert "wall" in line and "short by 90 %" in line and "full output" in line
    d = opt.results.to_dict()["optimisation"]
    assert d["unmet"] == [line] and d["dimmers"]["n0"] == pytest.approx(1.0)


def test_limits_are_met_when_feasible(facade_dir, facade_results):
    """A maximum and the energy term together: the fit dims until Emax meets the limit."""
    study, results = facade_results
    emax = results["wall"].at_dimmers(np.ones(2)).max()
    path = facade_dir / "limit.toml"
    path.write_text(facade_text(grid_extra=f"max_lux = {0.5 * emax:.6g}",
                                optimise="energy_weight = 0.001\nconstraint_weight = 1000"),
                    "utf-8")
    opt = optimise(lumijax.load_study(path), results, tolerance=1e-12)
    after = opt.results["wall"].stats["max"]
    assert after <= 0.5 * emax * 1.02
    assert not opt.unmet


@pytest.mark.parametrize(("opt", "grid", "key", "words"), [
    ("dimmer_min = 1.5", "target_lux = 10", "optimise.dimmer_min", "less than or equal to 1"),
    ("tilt_range_deg = [10, -10]", "target_lux = 10", "optimise.tilt_range_deg", "empty"),
    ("variables = []", "target_lux = 10", "optimise.variables", "at least 1"),
    ('variables = ["dimmers"]', "min_lux = 50\nmax_lux = 20", "grids[0]", "exceeds"),
    ('variables = ["dimmers"]', "max_luminance_cdm2 = 5", "grids[0]", "reflectance"),
    ('variables = ["dimmers"]', "", "optimise", "nothing to optimise"),
    ('solver = "newton"', "target_lux = 10", "optimise.solver", "lbfgsb"),
])
def test_bad_settings_name_the_key(facade_dir, opt, grid, key, words):
    path = facade_dir / "bad.toml"
    path.write_text(facade_text(grid_extra=grid, optimise=opt), "utf-8")
    with pytest.raises(ConfigError) as e:
        lumijax.load_study(path)
    assert e.value.key == key and words in str(e.value)


def test_target_map_must_fit_the_grid(facade_dir, facade_results):
    study, results = facade_results
    g = results["wall"]
    (facade_dir / "short.csv").write_text("x,y,z,lux\n1,2,3,4\n", "utf-8")
    path = facade_dir / "short.toml"
    path.write_text(facade_text(grid_extra='target_csv = "short.csv"'), "utf-8")
    with pytest.raises(ConfigError, match="1 rows but grid 'wall' has 216 points") as e:
        lumijax.load_study(path)
    assert e.value.key == "grids[0].target_csv"
    moved = g.points + [0.5, 0, 0]
    (facade_dir / "moved.csv").write_text(
        "x,y,z,lux\n" + "\n".join(f"{a},{b},{c},10" for a, b, c in moved) + "\n", "utf-8")
    path.write_text(facade_text(grid_extra='target_csv = "moved.csv"'), "utf-8")
    with pytest.raises(ConfigError, match="off by 0.5 m") as e:
        optimise(lumijax.load_study(path), results)
    assert e.value.key == "grids[0].target_csv" and e.value.line == 2


def test_a_target_level_is_met_by_the_grid_average(facade_dir, facade_results):
    """``target_lux`` is the grid's average (Ēm), however peaky the light: the average is linear
    in the dimmers (superposition) and T is within reach, so the fit must land on it exactly —
    a pointwise fit of the level would settle lower, by mean(E)²/mean(E²)."""
    study, results = facade_results
    one = results["wall"].by_network_lux[1]
    wanted = 0.4 * one.mean()
    path = facade_dir / "level.toml"
    path.write_text(facade_text(dimmers=(0.0, 0.9), grid_extra=f"target_lux = {wanted:.9g}"),
                    "utf-8")
    opt = optimise(lumijax.load_study(path), results, tolerance=1e-12, dimmer_min=0.0,
                           variables=["dimmers"])
    assert opt.results["wall"].stats["avg"] == pytest.approx(wanted, rel=1e-4)
    assert opt.results["wall"].stats["u0"] < 0.5  # peaky: a pointwise fit would settle lower
    [t] = opt.targets
    assert t["met"] and not opt.unmet
