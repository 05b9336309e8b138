"""The photometry kernel's float32 ``atan2`` against numpy's float64 one."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from lumijax.photometry._distribution import _atan2


def _inputs():
    rng = np.random.default_rng(11)
    y, x = rng.normal(size=(2, 200_000))
    scale = 10.0 ** rng.integers(-30, 30, size=(2, 200_000))  # every magnitude, either ratio
    y, x = y * scale[0], x * scale[1]
    axes = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, -1.0], [-1.0, 0.0], [1.0, 1.0], [-1.0, 1.0],
                     [1.0, -1.0], [-1.0, -1.0], [0.0, 0.0], [-0.0, 0.0], [0.0, -0.0],
                     [-0.0, -0.0], [0.41421356, 1.0], [1.0, 0.41421356], [1e-38, -1.0]])
    return (np.concatenate([y, axes[:, 0]]).astype(np.float32),
            np.concatenate([x, axes[:, 1]]).astype(np.float32))


def test_float32_is_within_three_tenths_of_a_microradian():
    y, x = _inputs()
    got = np.asarray(jax.jit(_atan2)(jnp.asarray(y), jnp.asarray(x)))
    assert got.dtype == np.float32
    exact = np.arctan2(y.astype(np.float64), x.astype(np.float64))  # signed zeros included
    assert np.max(np.abs(got - exact)) < 3e-7
    assert np.array_equal(np.signbit(got[-15:]), np.signbit(exact[-15:].astype(np.float32)))


def test_float32_gradient_is_atan2_s():
    y, x = _inputs()
    y, x = y[:2000] / 1e3, x[:2000] / 1e3  # away from float32's range ends
    y, x = y[np.hypot(y, x) > 1e-3], x[np.hypot(y, x) > 1e-3]
    gy, gx = jax.grad(lambda a, b: jnp.sum(_atan2(a, b)), argnums=(0, 1))(jnp.asarray(y),
                                                                         jnp.asarray(x))
    r2 = x.astype(np.float64) ** 2 + y.astype(np.float64) ** 2
    np.testing.assert_allclose(np.asarray(gy), x / r2, rtol=2e-5, atol=1e-9)
    np.testing.assert_allclose(np.asarray(gx), -y / r2, rtol=2e-5, atol=1e-9)


def test_float64_is_jax_s_own():
    y, x = (a.astype(np.float64) for a in _inputs())
    with jax.enable_x64(True):
        got = np.asarray(_atan2(jnp.asarray(y), jnp.asarray(x)))
        assert got.dtype == np.float64
        assert np.array_equal(got, np.asarray(jnp.arctan2(jnp.asarray(y), jnp.asarray(x))))
