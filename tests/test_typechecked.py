"""The README's test command checks array annotations at run time (jaxtyping + beartype, set in
pyproject's pytest addopts): a wrongly shaped argument to an instrumented function fails."""

from __future__ import annotations

import jax.numpy as jnp
import jaxtyping
import pytest

from lumijax.kernels import form_factor_point_triangle


def test_a_wrong_shape_is_refused_at_the_call(pytestconfig):
    if not pytestconfig.getoption("jaxtyping_packages", None):
        pytest.skip("run without --jaxtyping-packages (pyproject's addopts set it)")
    point, normal = jnp.zeros(3), jnp.array([0.0, 0.0, 1.0])
    triangle = jnp.array([[0.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 0.0, 1.0]])
    assert float(form_factor_point_triangle(point, normal, triangle)) > 0
    with pytest.raises(jaxtyping.TypeCheckError):  # "... 3 3" given a (3, 2) triangle
        form_factor_point_triangle(point, normal, triangle[:, :2])
