"""A constrained design of a whole study (``[optimise] objective = "power"``): the least power
against a linear programme on the computed per-network light, the verdict checked on the exact
light, the price against a re-solve, infeasibility as an answer from the CLI (exit 0), and the
bad inputs named by key."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.optimize import linprog

import lumijax
from lumijax import ConfigError
from lumijax.cli import main
from lumijax.optimise import optimise
from tests.helpers import box_room

SOLVER = "indirect = false\nspectral_samples = 0\ncache = false\nprecision = \"float64\""
POWER = {"a": 40.0, "b": 25.0}


def _text(grid_extra="", optimise='objective = "power"', extra=""):
    text = box_room(SOLVER, extra=grid_extra + "\n" + extra + (
        "" if optimise is None else "[optimise]\n" + optimise + "\n"))
    for n, w in POWER.items():
        text = text.replace(f"[networks.{n}]\n", f"[networks.{n}]\npower_w = {w}\n")
    return text


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    d = tmp_path_factory.mktemp("room")
    path = d / "room.toml"
    path.write_text(_text(optimise=None), "utf-8")
    study = lumijax.load_study(path)
    return d, study, lumijax.compute(study)


def _study(d, name, **kw):
    path = d / f"{name}.toml"
    path.write_text(_text(**kw), "utf-8")
    return lumijax.load_study(path)


def test_least_power_meets_the_constraints_on_the_exact_light(room):
    d, _, results = room
    study = _study(d, "lp", grid_extra="target_lux = 20\nmin_lux = 13")
    opt = optimise(study, results)
    rec = opt.constrained
    assert rec["verdict"] == "met"
    a = results["floor"].by_network_lux  # the computed light, at dimmer 1 per network
    p = np.array([POWER[n] for n in results.design.networks])
    lp = linprog(p, A_ub=np.vstack([-a.mean(axis=1)[None], -a.T]),
                 b_ub=np.r_[-20.0, np.full(a.shape[1], -13.0)], bounds=[(0, 1)] * 2,
                 method="highs")
    assert rec["objective_end"] == pytest.approx(lp.fun, rel=2e-3)
    # the design's own light, lit again by hand, meets both
    lux = np.array(list(opt.dimmers.values())) @ a
    assert lux.mean() >= 20 * (1 - 1e-3) and lux.min() >= 13 * (1 - 1e-3)
    np.testing.assert_allclose(opt.results["floor"].illuminance_lux, lux, rtol=1e-9)
    rows = {r["criterion"]: r for r in rec["constraints"]}
    assert rows["avg"]["met"] and rows["min"]["met"]
    assert rows["avg"]["achieved"] == pytest.approx(lux.mean(), rel=1e-9)
    # dimmers only: the solver's light model is the superposition, exact
    assert all(r["model"] == pytest.approx(r["achieved"], rel=1e-9) for r in rows.values())
    # Eavg's price, raised 10 %, against the re-solve at the raised floor
    active = [r for r in rec["constraints"] if r["active"]]
    assert active and all("costs" in r["price_sentence"] for r in active)
    avg = rows["avg"]
    if avg["active"]:
        again = optimise(study, results, constraints=[
            {"criterion": "avg", "grid": "floor", "min": 20.0 + avg["price_step"]}])
        real = again.constrained["objective_end"] - rec["objective_end"]
        assert avg["price"] == pytest.approx(real, rel=0.05)
    json.dumps(opt.to_dict())  # results.json can hold it


def test_infeasible_is_an_answer_from_the_cli(room, capsys):
    """Eavg ≥ 100 lx is out of reach (the room gives about 32 lx at full output): exit 0, the
    plain verdict, and the best achievable average solved for — every network at full output,
    the by-network light summed by hand."""
    d, _, results = room
    path = d / "infeasible.toml"
    path.write_text(_text(grid_extra="target_lux = 100\nuniformity_min = 0.3"), "utf-8")
    out = d / "out"
    assert main(["run", str(path), "--out", str(out), "--no-images", "--no-report"]) == 0
    printed = capsys.readouterr().out
    assert "verdict: infeasible" in printed and "best achievable" in printed
    rec = json.loads((out / "results.json").read_text())["optimisation"]["constrained"]
    assert rec["verdict"] == "infeasible"
    conflict = rec["infeasibility"]["conflict"]
    assert [c["key"] for c in conflict] == ["grids[0].target_lux"]  # U0 alone is met
    full = results["floor"].by_network_lux.sum(axis=0).mean()
    assert conflict[0]["best_achievable"] == pytest.approx(full, rel=1e-4)
    assert any("more flux on network" in s for s in conflict[0]["needed"])


@pytest.mark.parametrize(("grid_extra", "settings", "key", "match"), [
    ("min_lux = 30", 'objective = "power"\n[[optimise.constraints]]\ncriterion = "max"\n'
     'grid = "floor"\nmax = 20', "grids[0].min_lux", "no design can meet both"),
    ("", 'objective = "power"\n[[optimise.constraints]]\ncriterion = "avg"\ngrid = "desk"\n'
     "min = 20", "optimise.constraints[0].grid", "no grid named 'desk'"),
    ("", 'objective = "power"\n[[optimise.constraints]]\ncriterion = "luminance"\n'
     'grid = "floor"\nmax = 20', "optimise.constraints[0].max", "needs the grid's"),
    ("", 'objective = "power"\n[[optimise.constraints]]\ncriterion = "ugr"\nmax = 19',
     "optimise.constraints[0].criterion", "has no \\[\\[observers"),
    ("target_lux = 20", 'objective = "power"\ndimmer_min = 1', "optimise.dimmer_min",
     "nothing can change"),
    ("min_lux = 5", 'objective = "misfit"', "optimise.objective", "needs a grid"),
])
def test_bad_constraints_are_named_by_key(room, grid_extra, settings, key, match):
    d, _, results = room
    with pytest.raises(ConfigError, match=match) as err:  # when it loads, or when it is solved
        optimise(_study(d, "bad", grid_extra=grid_extra, optimise=settings), results)
    assert err.value.key == key


@pytest.mark.parametrize(("optimise", "key", "match"), [
    ('[[optimise.constraints]]\ncriterion = "u0"\ngrid = "floor"\nmin = 0.4',
     "optimise", "give 'objective'"),
    ('objective = "power"\n[[optimise.constraints]]\ncriterion = "avg"\ngrid = "floor"\n'
     "min = 30\nmax = 20", "optimise.constraints[0]", "no design can meet both"),
    ('objective = "power"', "optimise", "nothing to optimise"),
    ('objective = "power"\n[[optimise.constraints]]\ncriterion = "min"\ngrid = "floor"\n'
     "max = 20", "optimise.constraints[0]", "takes only a .min. bound"),
])
def test_contradictory_settings_are_refused_when_the_config_loads(tmp_path, optimise, key,
                                                                  match):
    path = tmp_path / "s.toml"
    path.write_text(_text(optimise=optimise), "utf-8")
    with pytest.raises(ConfigError, match=match) as err:
        lumijax.load_study(path)
    assert (err.value.key or "").startswith(key)


def test_multiple_starts_agree_on_a_convex_design(room):
    """Dimmers only: the problem is convex (linear objective, concave soft minimum, linear
    average), so every start reaches the one optimum: three starts, three agree."""
    d, _, results = room
    study = _study(d, "starts", grid_extra="target_lux = 20\nmin_lux = 13",
                   optimise='objective = "power"\nstarts = 3\nseed = 4')
    rec = optimise(study, results).constrained
    assert rec["starts"]["count"] == 3 and rec["starts"]["feasible"] == 3
    assert rec["starts"]["agreed"] == 3
    objs = rec["starts"]["objectives"]
    assert max(objs) - min(objs) <= 1e-3 * min(objs)
