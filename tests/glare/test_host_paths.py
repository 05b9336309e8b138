"""The host (numpy) paths of the glare results give JAX's bits: the results' glare geometry, the
seen surfaces' statistics and the sources' networks are figured on the host so that writing
results.json compiles no eager kernel per shape (issue 19), and results.json must not change by
it. Each host path is compared, bit for bit, with the JAX expression it stands for."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.glare import SeenSurfaces
from lumijax.glare._area import projected_area
from lumijax.photometry import LuminousOpening

SHAPES = ("point", "rectangle", "disk", "ellipse", "box", "vertical_cylinder",
          "horizontal_cylinder_along", "horizontal_cylinder_across", "sphere",
          "vertical_circle", "some_future_shape")


@pytest.mark.parametrize("shape", SHAPES)
def test_projected_area_on_the_host_is_jax_bit_for_bit(shape):
    rng = np.random.default_rng(3)
    d = rng.normal(size=(3, 7, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    d[0, 0] = (1.0, 0.0, 0.0)  # edge on to a flat face, and |c| = 1 for the cylinders' sides
    d[0, 1] = (0.0, 0.0, -1.0)
    opening = LuminousOpening(length_m=0.61, width_m=0.23, height_m=0.17, shape=shape)
    dt = jax.dtypes.canonicalize_dtype(np.float64)
    local = np.asarray(d, dt)
    host = projected_area(opening, local, xp=np)
    dev = np.asarray(projected_area(opening, jnp.asarray(local)))
    assert isinstance(host, np.ndarray) and host.dtype == dev.dtype
    np.testing.assert_array_equal(host, dev)
    assert np.all(host > 0)


@pytest.mark.parametrize("x64", [True, False])
def test_seen_surfaces_statistics_in_one_program_are_op_by_op_bit_for_bit(x64):
    rng = np.random.default_rng(5)
    n_links, n_patches = 400, 150
    radiosity = rng.uniform(0.0, 300.0, n_patches) * rng.uniform(0.5, 2.0, n_patches)
    with jax.enable_x64(x64):
        links = SeenSurfaces(
            patch=jnp.asarray(rng.integers(0, n_patches, n_links), jnp.int32),
            observer=jnp.asarray(rng.integers(0, 3, n_links), jnp.int32),
            surface=jnp.asarray(rng.integers(0, 3, n_links), jnp.int32),
            observers=("a", "b", "c"), surfaces=("wall", "floor", "panel", "roof"))
        mx = np.asarray(links.maximum(radiosity), np.float64)  # op by op, as results had it
        mean = np.asarray(links.mean(radiosity), np.float64)
        d = links.to_dict(radiosity)  # one compiled program
    assert mx.dtype == np.float64 and mx[:, 3].max() == 0.0  # nobody sees the roof
    got_mx = np.array([[d[o][s]["max_luminance_cdm2"] for s in ("wall", "floor", "panel")]
                       for o in ("a", "b", "c")])
    got_mean = np.array([[d[o][s]["mean_luminance_cdm2"] for s in ("wall", "floor", "panel")]
                         for o in ("a", "b", "c")])
    np.testing.assert_array_equal(got_mx, mx[:, :3])
    np.testing.assert_array_equal(got_mean, mean[:, :3])
    assert "roof" not in d["a"]
    # the closed form of one cell: the largest and mean B / π of its links
    sel = (np.asarray(links.observer) == 1) & (np.asarray(links.surface) == 0)
    lum = radiosity[np.asarray(links.patch)[sel]] / math.pi
    np.testing.assert_allclose(got_mx[1, 0], lum.max(), rtol=1e-6)
    np.testing.assert_allclose(got_mean[1, 0], lum.mean(), rtol=1e-5)
