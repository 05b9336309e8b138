"""Choices are registries checked against the schema's Literal (lumijax/_registry.py)."""

from __future__ import annotations

import typing

import numpy as np
import pytest

from lumijax._registry import Registry
from lumijax.config._schema import CameraConfig, OptimiseConfig
from lumijax.errors import ConfigError, OutputError
from lumijax.optimise._solvers import OPTIMISERS, AbstractOptimiser, minimise
from lumijax.report._tonemap import TONE_CURVES, tone_map


def test_each_schema_literal_is_its_registry():
    for model, key, registry in ((OptimiseConfig, "solver", OPTIMISERS),
                                 (CameraConfig, "tone", TONE_CURVES)):
        allowed = typing.get_args(model.model_fields[key].annotation)
        assert set(allowed) == set(registry.names), key
        for name in allowed:  # every accepted name reaches an implementation
            assert registry[name] is not None


def test_a_registry_out_of_step_with_its_literal_refuses_to_build():
    with pytest.raises(TypeError, match=r"missing from the registry \['b'\]"):
        Registry("k", typing.Literal["a", "b"], {"a": 1})
    with pytest.raises(TypeError, match=r"missing from the Literal \['c'\]"):
        Registry("k", typing.Literal["a"], {"a": 1, "c": 2})


def test_unknown_names_name_the_key_and_the_choices():
    with pytest.raises(ConfigError, match=r"optimise\.solver: expected one of 'lbfgsb'.*'newton'"):
        minimise(lambda x, a: x, None, np.zeros(1), np.zeros(1), np.ones(1), solver="newton")
    with pytest.raises(OutputError, match=r"tone: expected one of 'filmic', 'reinhard', 'clip'"):
        tone_map(np.ones(3), 0.0, "gamma")


def test_auto_is_the_default_optimiser_and_an_object_is_accepted():
    assert OPTIMISERS["auto"] is OPTIMISERS["lbfgsb"]

    class Half(AbstractOptimiser):  # a method that needs no registry line to be passed directly
        name: typing.ClassVar[str] = "half"

        def run(self, residuals, args, x0, lo, hi, max_steps, tolerance):
            from lumijax.optimise._solvers import SolverRun

            return SolverRun(self.name, 0.5 * (lo + hi))

    run = minimise(lambda x, a: x, None, np.zeros(2), np.zeros(2), np.array([1.0, 3.0]),
                   solver=Half())
    np.testing.assert_array_equal(run.x, [0.5, 1.5])


def test_tone_curves_match_their_published_formulas():
    """Each curve against its formula written out here (Narkowicz 2015; Reinhard et al. 2002,
    W = 4; a linear clip), on exposed linear values of a grey (r = g = b = Y)."""
    y = np.array([0.05, 0.5, 1.0, 3.0])
    rgb = np.repeat(y[:, None], 3, axis=1)
    filmic = np.clip(y * (2.51 * y + 0.03) / (y * (2.43 * y + 0.59) + 0.14), 0, 1)
    reinhard = np.clip(y * (1 + y / 16) / (1 + y), 0, 1)
    for name, expected in (("filmic", filmic), ("reinhard", reinhard),
                           ("clip", np.clip(y, 0, 1))):
        np.testing.assert_allclose(TONE_CURVES[name](rgb, y)[:, 0], expected, rtol=1e-12)
    assert TONE_CURVES["filmic"](rgb, y)[2, 0] == pytest.approx(2.54 / 3.16)
