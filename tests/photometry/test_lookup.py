"""The cell lookup of CandelaDistribution.intensity: exact, and bounded by the table's shape.

A 2000-angle table with clustered angles once unrolled ~300 search steps into the kernel and
took minutes to compile; the bisection through the LUT is ≤ ⌈log2 n⌉ steps whatever the values.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.photometry import CandelaDistribution
from lumijax.photometry._distribution import _cell_lut, _intensity, _locate, _locate_lut


def _clustered(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    cluster = 10.0 + np.sort(rng.choice(np.arange(1, 20 * n), n - 10, replace=False)) * 1e-6
    return np.unique(np.concatenate([cluster, np.linspace(0.0, 180.0, 10)]))


GRIDS = {
    "uniform": np.linspace(0.0, 180.0, 37),
    "random": np.unique(np.r_[0.0, np.random.default_rng(1).uniform(0, 180, 60), 180.0]),
    "clustered": _clustered(),
    "two knots": np.array([-90.0, 90.0]),
}


_LOCATE_LUT = jax.jit(_locate_lut, static_argnums=2)
_LOCATE = jax.jit(_locate)


@pytest.mark.parametrize("name", GRIDS)
def test_lut_cells_equal_searchsorted(name):
    g = GRIDS[name]
    lut, steps = _cell_lut(g)
    assert steps <= math.ceil(math.log2(len(g))) + 1
    rng = np.random.default_rng(2)
    x = np.concatenate([rng.uniform(g[0] - 3, g[-1] + 3, 5000), g, np.nextafter(g, -np.inf),
                        np.nextafter(g, np.inf)])
    for dtype in (jnp.float64, jnp.float32):
        gg, xx = jnp.asarray(g, dtype), jnp.asarray(x, dtype)
        i_lut, s_lut = _LOCATE_LUT(gg, jnp.asarray(lut), steps, xx)
        i_ref, s_ref = _LOCATE(gg, xx)
        np.testing.assert_array_equal(np.asarray(i_lut), np.asarray(i_ref))
        np.testing.assert_array_equal(np.asarray(s_lut), np.asarray(s_ref))


def test_kernel_size_does_not_grow_with_clustering():
    """The lowered kernel of a clustered 2000-angle table is no bigger than a uniform one's."""
    d = jnp.zeros((8, 3), jnp.float32)
    sizes = {}
    for name, v in (("uniform", np.linspace(0.0, 180.0, 2000)), ("clustered", _clustered())):
        dist = CandelaDistribution("C", [0.0, 360.0], v, np.ones((2, v.size)))
        text = _intensity.lower(dist.photometric_type, dist.h_deg, dist.v_deg, dist.candela, d,
                                dist.luts, *dist.lut_steps).as_text()
        sizes[name] = text.count("\n")
        assert dist.lut_steps[1] <= math.ceil(math.log2(v.size)) + 1
    assert sizes["clustered"] < 1.5 * sizes["uniform"], sizes


def test_clustered_table_evaluates_as_the_binary_search():
    v = _clustered(300)
    cd = 1000.0 * np.cos(np.radians(v / 2.0))[None, :].repeat(2, 0)
    dist = CandelaDistribution("C", [0.0, 360.0], v, cd)
    traced = jax.jit(lambda h, vv, c: CandelaDistribution("C", h, vv, c))(
        dist.h_deg, dist.v_deg, jnp.asarray(cd)
    )  # built under a trace: the plain binary search
    dirs = np.random.default_rng(3).normal(size=(500, 3))
    d = jnp.asarray(dirs / np.linalg.norm(dirs, axis=1, keepdims=True))
    np.testing.assert_allclose(np.asarray(dist.intensity(d)), np.asarray(traced.intensity(d)),
                               rtol=1e-12)


def test_angles_equal_in_float32_give_no_nan():
    # 90 and 90.000001 are distinct in float64 and one float32: a zero-width cell.
    v = np.array([0.0, 45.0, 90.0, 90.000001])
    dist = CandelaDistribution("C", [0.0, 360.0], v, np.array([[4.0, 3.0, 2.0, 1.0]] * 2))
    d = jnp.asarray(np.asarray(dist.direction(30.0, jnp.array([89.0, 90.0, 90.0000005]))),
                    jnp.float32)
    vals = np.asarray(dist.intensity(d))
    assert np.all(np.isfinite(vals)), vals
    g = jax.vmap(jax.grad(lambda x: dist.intensity(x)))(d)
    assert np.all(np.isfinite(np.asarray(g)))
