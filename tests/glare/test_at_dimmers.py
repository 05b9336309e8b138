"""Results.at at new dimmers rates glare by superposition (GlareModel.at_aims), and the record
it makes says the same as the full model evaluated afresh at that design (ratings, per-source
shares, and the results.json entry), while a design that re-aims goes through the full model."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.glare import Glare


def test_new_dimmers_rate_by_superposition_as_the_full_model(glare_room):
    design = glare_room.design.replace(dimmers=[0.3, 0.8])
    fast = glare_room.at(design).glare
    assert fast.unit is not None  # the superposition path
    full = Glare(fast.model, design, fast.observers)  # a fresh record: the full model
    for a, b in zip(fast.ratings, full.ratings, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    got, want = fast.to_dict(), full.to_dict()
    for name in want:
        for rating, w in want[name]["worst"].items():
            g = got[name]["worst"][rating]
            assert (g is None) == (w is None)
            if w is not None:
                assert g["direction"] == w["direction"]
                assert g["value"] == pytest.approx(w["value"], rel=1e-9)
        for g, w in zip(got[name]["top_luminaires"]["gr"], want[name]["top_luminaires"]["gr"],
                        strict=True):
            assert g["name"] == w["name"] and g["share"] == pytest.approx(w["share"], rel=1e-9)
    # and a second step from the first keeps the same dimmer-1 terms
    again = fast.at(design.replace(dimmers=[1.0, 0.1]))
    assert again.unit is fast.unit


def test_a_new_aim_uses_the_full_model(glare_room):
    tilt = np.asarray(glare_room.design.tilt_deg, np.float64) + 10.0
    moved = glare_room.glare.at(glare_room.design.replace(tilt_deg=tilt))
    assert moved.unit is None
