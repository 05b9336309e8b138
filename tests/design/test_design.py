"""The Design pytree and its flat view (``traverse``): layout, bounds, the way back, errors.

References are written out by hand here (the radians of a degree, the box of a range), never
taken from the code under test."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax import ConfigError, Design
from lumijax.design import traverse


def _design() -> Design:
    return Design([0.6, 0.9, 0.0], [124.0, 128.0, 30.0], [-90.0, -95.0, 10.0],
                  [0.0, 15.0, -5.0], [1.0, 0.8, 1.0], networks=("n0", "n1", "n2"),
                  luminaires=("s0", "s1", "s2"))


def test_leaves_are_read_only_float64_and_names_say_which_is_which():
    d = _design()
    assert d.dimmers.dtype == np.float64 and not d.dimmers.flags.writeable
    assert d.dimmer_of() == {"n0": 0.6, "n1": 0.9, "n2": 0.0}
    assert d.aim_of("s1") == {"tilt": 128.0, "pan": -95.0, "spin": 15.0}
    assert d.level_of("s1") == 0.8
    # the names are static: they are not leaves, so a vector of the design is all numbers
    assert len(jax.tree_util.tree_leaves(d)) == 5


def test_replace_by_network_name_keeps_the_others():
    d = _design().replace(dimmers={"n1": 0.25})
    np.testing.assert_array_equal(d.dimmers, [0.6, 0.25, 0.0])
    assert _design().only_dimmers_differ(d)
    assert not _design().only_dimmers_differ(d.replace(tilt_deg=[124.0, 128.0, 30.5]))
    with pytest.raises(ConfigError, match="no network named 'n9'") as e:
        d.replace(dimmers={"n9": 1.0})
    assert e.value.key == "design.dimmers"


@pytest.mark.parametrize(("field", "value", "words"), [
    ("dimmers", [1.0, 1.0], "expected 3 values"),
    ("tilt_deg", [0.0, float("nan"), 0.0], "expected finite numbers"),
    ("level", [1.0, 1.0, float("inf")], "expected finite numbers"),
])
def test_bad_values_name_the_field(field, value, words):
    with pytest.raises(ConfigError, match=words) as e:
        _design().replace(**{field: value})
    assert e.value.key.startswith("design.") and field in e.value.key


def test_traverse_lays_out_dimmers_aims_levels_with_their_bounds():
    d = _design()
    p = traverse(d, ("dimmers", "aims", "levels"), luminaires=[0, 1],
                 dimmer_bounds=(0.05, 1.0),
                 aim_bounds_deg=[((-10, 10), (-5, 5)), ((0, 0), (-20, 3))],
                 level_bounds=(0.05, 1.0))
    r = math.pi / 180
    # by hand: dimmers clipped into [0.05, 1]; angles in radians; levels relative, 1 at start
    x0 = [0.6, 0.9, 0.05, 124 * r, 128 * r, -90 * r, -95 * r, 1.0, 1.0]
    lo = [0.05] * 3 + [114 * r, 128 * r, -95 * r, -115 * r, 0.05, 0.05]
    hi = [1.0] * 3 + [134 * r, 128 * r, -85 * r, -92 * r, 1.0, 1.0]
    np.testing.assert_allclose(p.x0, x0, rtol=1e-15)
    np.testing.assert_allclose(p.lower, lo, rtol=1e-15)
    np.testing.assert_allclose(p.upper, hi, rtol=1e-15)
    assert p.labels[3] == "tilt_rad[s0]" and p.labels[-1] == "level[s1]"
    assert p.free.tolist() == [True] * 4 + [False] + [True] * 4  # s1's tilt range is [0, 0]
    # the way back: degrees again, the third luminaire untouched, levels times the start's
    x = np.array(x0)
    x[3], x[6], x[8] = 120 * r, -100 * r, 0.5
    back = p.unflatten(x)
    np.testing.assert_allclose(back.tilt_deg, [120.0, 128.0, 30.0], rtol=1e-14)
    np.testing.assert_allclose(back.pan_deg, [-90.0, -100.0, 10.0], rtol=1e-14)
    np.testing.assert_allclose(back.level, [1.0, 0.4, 1.0], rtol=1e-15)
    np.testing.assert_array_equal(back.spin_deg, d.spin_deg)
    np.testing.assert_allclose(p.flatten(back), x, rtol=1e-14)


def test_without_dimmers_as_variables_they_are_pinned_at_the_clipped_start():
    p = traverse(_design(), ("aims",), luminaires=[2], dimmer_bounds=(0.1, 1.0),
                 aim_bounds_deg=[((-1, 1), (-1, 1))])
    np.testing.assert_array_equal(p.lower[:3], [0.6, 0.9, 0.1])
    np.testing.assert_array_equal(p.upper[:3], [0.6, 0.9, 0.1])
    assert len(p.x0) == 5  # 3 dimmers, one tilt, one pan; no level block


def test_unflatten_is_traceable_and_its_derivative_is_the_degree():
    p = traverse(_design(), ("dimmers", "aims"), luminaires=[0, 1, 2],
                 aim_bounds_deg=[((-5, 5), (-5, 5))] * 3)
    jax.config.update("jax_enable_x64", True)

    def tilt_sum(x):
        return jnp.sum(p.unflatten(x).tilt_deg)

    g = jax.jit(jax.grad(tilt_sum))(jnp.asarray(p.x0))
    expect = np.zeros_like(p.x0)
    expect[3:6] = 180 / math.pi  # d(degrees)/d(radians)
    np.testing.assert_allclose(np.asarray(g), expect, rtol=1e-12)


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"variables": ("dimmers", "spin")}, "unknown design variable 'spin'"),
    ({"dimmer_bounds": (0.9, 0.1)}, "bounds .* are empty"),
    ({"variables": ("aims",), "luminaires": [0], "aim_bounds_deg": [((5, -5), (0, 0))]},
     "tilt range of luminaire 's0' is empty"),
    ({"variables": ("aims",), "luminaires": [0, 1], "aim_bounds_deg": [((0, 1), (0, 1))]},
     "expected aim bounds for each of the 2"),
])
def test_bad_layouts_are_refused_with_the_key(kwargs, words):
    with pytest.raises(ConfigError, match=words) as e:
        traverse(_design(), **kwargs)
    assert e.value.key is not None


def test_unflatten_refuses_a_vector_of_the_wrong_length():
    p = traverse(_design())
    with pytest.raises(ConfigError, match=r"expected 3 variables \(dimmers\[n0\]"):
        p.unflatten(np.zeros(4))


def test_unflatten_of_the_start_is_the_start_bit_for_bit():
    d = _design().replace(tilt_deg=[124.1, 128.3, 30.7])  # not exact in radians and back
    p = traverse(d, ("dimmers", "aims", "levels"), luminaires=[0, 1, 2],
                 aim_bounds_deg=[((0, 0), (0, 0))] * 3)
    back = p.unflatten(p.x0)
    for f in ("dimmers", "tilt_deg", "pan_deg", "spin_deg", "level"):
        np.testing.assert_array_equal(getattr(back, f), getattr(d, f))
    assert d.only_dimmers_differ(back)
