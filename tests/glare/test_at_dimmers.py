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



def test_the_terms_at_the_aims_do_not_depend_on_the_callers_x64(glare_room, caplog):
    """A float32 model (the demo's): the optimiser builds its glare constraints under x64, the
    results rate glare outside it, and at_aims gives both the same terms, bitwise, from one
    compiled program (before, each flag compiled its own, ~4 s of the demo's first run, and
    the optimisation's GR read-backs differed from results.json's glare in the last digits)."""
    import logging

    import equinox as eqx
    import jax

    from lumijax.lighting._solution import float64_scope

    def f32(x):
        return x.astype(np.float32) if eqx.is_array(x) and x.dtype == np.float64 else x

    design = glare_room.design
    n = len(design.luminaires)
    aimed = design.replace(tilt_deg=np.linspace(13.7, 31.3, n), pan_deg=np.linspace(7.1, 41.9, n))
    with jax.enable_x64(False):
        model = jax.tree.map(f32, glare_room.glare.model)
        with jax.log_compiles(), caplog.at_level(logging.DEBUG):
            a = model.at_aims(aimed)
            caplog.clear()
            with float64_scope():
                b = model.at_aims(aimed)
    assert not [r for r in caplog.records if "Compiling" in r.getMessage()]
    for x, y in ((a.ugr_terms, b.ugr_terms), (a.veil_terms, b.veil_terms)):
        assert x.dtype == y.dtype == np.float32
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
