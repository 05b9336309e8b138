"""Results own one Design: the grids' dimmers and the networks' "dimmer" are read from it,
whatever copies they were made with (the old "readers disagree" bug), checked on results made
by hand so the expected numbers are a hand-written weighted sum."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax import Design, GridResult, LumijaxError, Results


def _grid(dimmers) -> GridResult:
    return GridResult(name="g", points=np.zeros((3, 3)), normals=np.tile([0, 0, 1.0], (3, 1)),
                      networks=("a", "b"), by_network_lux=np.array([[10.0, 20, 30],
                                                                    [1.0, 2, 4]]),
                      dimmers=np.asarray(dimmers, np.float64))


def _networks(da, db):
    return {"a": {"dimmer": da, "luminaires": ["l1"], "flux_lm": 100.0},
            "b": {"dimmer": db, "luminaires": ["l2"], "flux_lm": 50.0}}


def test_the_design_overrides_every_stale_copy():
    design = Design([0.5, 0.25], [], [], [], [], networks=("a", "b"), luminaires=())
    r = Results(study="s", grids={"g": _grid([1.0, 1.0])}, networks=_networks(1.0, 1.0),
                design=design)
    np.testing.assert_array_equal(r["g"].illuminance_lux, [5.25, 10.5, 16.0])  # by hand
    assert r["g"].dimmers is r.design.dimmers and not r["g"].dimmers.flags.writeable
    assert r.networks == _networks(0.5, 0.25)  # same keys, same order: results.json's contract
    d = r.to_dict()
    assert list(d["networks"]["a"]) == ["dimmer", "luminaires", "flux_lm"]
    assert d["grids"]["g"]["illuminance_lux"] == [5.25, 10.5, 16.0]


def test_results_made_without_a_design_take_the_networks_dimmers():
    r = Results(study="s", grids={"g": _grid([1.0, 1.0])}, networks=_networks(0.5, 0.0))
    assert r.design.dimmer_of() == {"a": 0.5, "b": 0.0}
    np.testing.assert_array_equal(r["g"].illuminance_lux, [5.0, 10.0, 15.0])


def test_at_new_dimmers_is_the_weighted_sum_and_a_turn_needs_the_study():
    r = Results(study="s", grids={"g": _grid([1.0, 1.0])}, networks=_networks(1.0, 1.0))
    at = r.at(r.design.replace(dimmers={"b": 0.5}))
    np.testing.assert_array_equal(at["g"].illuminance_lux, [10.5, 21.0, 32.0])
    assert at.networks["b"]["dimmer"] == 0.5 and r.networks["b"]["dimmer"] == 1.0
    lit = Design([1.0, 1.0], [30.0], [0.0], [0.0], [1.0], networks=("a", "b"),
                 luminaires=("l1",))
    r2 = Results(study="s", grids={"g": _grid([1.0, 1.0])}, networks=_networks(1.0, 1.0),
                 design=lit)
    with pytest.raises(LumijaxError, match="re-aims or re-levels") as e:
        r2.at(lit.replace(tilt_deg=[35.0]))
    assert e.value.key == "design"


def test_a_design_of_other_networks_is_refused():
    wrong = Design([1.0], [], [], [], [], networks=("a",), luminaires=())
    with pytest.raises(LumijaxError, match=r"expected a design of the results' networks") as e:
        Results(study="s", grids={}, networks=_networks(1.0, 1.0), design=wrong)
    assert e.value.key == "design.networks"
