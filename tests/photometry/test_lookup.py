"""The cell lookup of CandelaDistribution.intensity: exact, and bounded by the table's shape.

A 2000-angle table with clustered angles once unrolled ~300 search steps into the kernel and
took minutes to compile; the bisection through the LUT is ≤ ⌈log2 n⌉ steps whatever the values.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.photometry import CandelaDistribution
from lumijax.photometry._distribution import (
    _cell_lut,
    _intensity,
    _locate,
    _locate_lut,
    _table_intensity,
)


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
        text = _table_intensity.lower(dist.kernel, d).as_text()
        sizes[name] = text.count("\n")
        assert dist.kernel.steps[1] <= math.ceil(math.log2(v.size)) + 1
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


def _files():
    from pathlib import Path

    here = Path(__file__).resolve()
    shared = here.parents[2].parent / "shared" / "photometry"
    bundled = here.parents[2] / "lumijax" / "data" / "studies" / "default" / "courtyard" / "photometry"
    files = sorted(bundled.glob("*.ies"))
    # shared files of each kind (Type B, tilt, lamp sets, symmetries); all 19 once measured
    # equal to 1 ulp on 20,000 directions
    picked = ("ew_flood_2.1.IES", "er_TILT_TEST_SYNTHETIC.ies", "dl_multiple_lamp_sets.ldt",
              "lx_Testlamp_Isym3_symmetryOverC90C270axis.ies")
    return files + [shared / name for name in picked if (shared / name).is_file()]


def _directions(dist, n=4000, seed=5):
    """Random unit directions, the table's own knots (cell edges, where a wrong cell shows) and
    the poles."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    hh, vv = np.meshgrid(np.asarray(dist.h_deg, np.float64), np.asarray(dist.v_deg, np.float64),
                         indexing="ij")
    knots = np.asarray(dist.direction(hh.ravel(), vv.ravel()), np.float64)
    return np.concatenate([d / np.linalg.norm(d, axis=1, keepdims=True), knots,
                           [[0, 0, -1.0], [0, 0, 1.0], [1.0, 0, 0]]])


@pytest.mark.parametrize("path", _files(), ids=lambda p: p.name)
def test_padded_table_is_the_unpadded_binary_search(path):
    """The shared, padded kernel table (``KernelTable``) gives the value of a plain binary search
    on the file's own, unpadded table, to float32 rounding (the two programs' arithmetic is
    fused differently: 1 ulp apart on a few per cent of the directions)."""
    from lumijax.photometry import read_photometry

    dist = read_photometry(path).distribution
    assert dist.kernel is not dist
    d = jnp.asarray(_directions(dist), jnp.float32)
    # the reference: a plain binary search (no lookup table, no padding) on the stored arrays
    ref = _intensity(dist.photometric_type, dist.h_deg, dist.v_deg, dist.candela, d)
    np.testing.assert_allclose(np.asarray(dist.intensity(d)), np.asarray(ref), rtol=2.5e-7,
                               atol=0)


def test_tables_of_one_bucket_share_one_compiled_kernel():
    """Two tables of different sizes in one shape bucket: one compile, not two."""
    a = CandelaDistribution("C", np.linspace(0, 360, 73), np.linspace(0, 180, 361),
                            np.ones((73, 361)))
    b = CandelaDistribution("C", np.linspace(0, 360, 100), np.linspace(0, 180, 233),
                            np.full((100, 233), 2.0))
    assert a.kernel.cd.shape == b.kernel.cd.shape
    d = jnp.asarray([[0.0, 0.0, -1.0], [0.3, 0.1, -0.9]], jnp.float32)
    before = _table_intensity._cache_size()
    np.testing.assert_array_equal(np.asarray(a.intensity(d)), [1.0, 1.0])
    np.testing.assert_array_equal(np.asarray(b.intensity(d)), [2.0, 2.0])
    assert _table_intensity._cache_size() - before <= 1
    # the table follows the arrays: scaled() and a tree_at of candela are seen
    np.testing.assert_array_equal(np.asarray(b.scaled(3.0).intensity(d)), [6.0, 6.0])
    c = eqx.tree_at(lambda m: m.candela, b, 5.0 * b.candela)
    np.testing.assert_array_equal(np.asarray(c.intensity(d)), [10.0, 10.0])
