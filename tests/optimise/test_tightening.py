"""The model-error tightening wired into ``design_to_standard`` (issue 16): an aims design whose
exact recompute finds a constraint short is solved again with that bound moved by the light
model's error there, and ends met; a dimmer-only design (superposition, exact) never enters it.

The facade's aim model is exact (point spots, luminous solve), so the error is forced: the exact
light the check reads is 3 % below the true light on the wall, the way an aim model that is 3 %
high would leave it. The expected values are the bound itself and the 3 % (closed form)."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.optimise import _standard, optimise
from lumijax.optimise._constraints import DesignLight

_LOW = 0.97  # the forced model error: exact light 3 % below what the solver's model says


def _forced(monkeypatch):
    real = _standard.exact_light

    def low(study, after, params):
        light = real(study, after, params)
        return DesignLight(light.e * _LOW, light.b, light.alpha, light.x)

    monkeypatch.setattr(_standard, "exact_light", low)


def _eavg(results):
    return {"criterion": "avg", "grid": "wall", "min": 0.6 * results.grids["wall"].stats["avg"]}


def test_an_aims_design_short_after_the_recompute_is_tightened_until_met(facade_results,
                                                                         monkeypatch):
    study, results = facade_results
    _forced(monkeypatch)
    opt = optimise(study, results, objective="power", variables=["dimmers", "aims"],
                   tilt_range_deg=(-2.0, 2.0), pan_range_deg=(-2.0, 2.0),
                   constraints=[_eavg(results)])
    rec = opt.constrained
    tol = rec["tolerance"]
    bound = _eavg(results)["min"]
    # the first solve met the model's Eavg, so the forced error left it ~3 % short
    assert rec["shortfall_first"] == pytest.approx(1 - _LOW, abs=5e-3)
    rounds = rec["tightening_rounds"]
    assert 1 <= len(rounds) <= _standard.TIGHTEN_ROUNDS
    # round 1's bound: the original raised by the model's error there (≈ 3 % of the model's
    # Eavg ≈ the bound) plus the documented safety margin
    assert rounds[0]["bounds"][0] == pytest.approx(bound / _LOW, rel=5e-3)
    assert rounds[-1]["worst_shortfall"] <= tol
    assert rec["verdict"] == "met"
    row = next(r for r in rec["constraints"] if r["criterion"] == "avg")
    assert row["met"] and row["achieved"] >= bound * (1 - tol)
    # the final light really is the forced one: achieved = 0.97 x the model there (the aim
    # model itself is ~1e-6 off the recompute at these aims)
    assert row["achieved"] == pytest.approx(_LOW * row["model"], rel=1e-4)


def test_a_dimmer_only_design_is_never_tightened(facade_results, monkeypatch):
    """Superposition is exact, so a shortfall there is not a model error: the same forced error
    is reported as it is (not met), with no re-solve."""
    study, results = facade_results
    _forced(monkeypatch)
    opt = optimise(study, results, objective="power", variables=["dimmers"],
                   constraints=[_eavg(results)])
    rec = opt.constrained
    assert rec["tightening_rounds"] == []
    assert rec["verdict"] == "not met exactly"
    assert rec["shortfall_first"] == pytest.approx(1 - _LOW, abs=5e-3)
    assert np.isfinite(rec["objective_end"])
