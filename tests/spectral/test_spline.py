"""The segmentation's not-a-knot spline basis is scipy's CubicSpline (the independent program
here), computed without importing scipy.interpolate (0.9 s of every run that segments)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from lumijax.spectral._sampling import _spline

interpolate = pytest.importorskip("scipy.interpolate")


@pytest.mark.parametrize("m", [1, 2, 3, 4, 5, 8, 16, 24])
def test_basis_is_scipys_not_a_knot_spline(m):
    rng = np.random.default_rng(m)
    x = np.arange(360.0, 831.0)
    for _ in range(20):
        nodes = np.sort(rng.choice(np.arange(380.0, 781.0), m, replace=False))  # ≥ 1 nm apart
        got = _spline(nodes, x)
        if m == 1:
            ref = np.ones((1, x.size))
        else:
            ref = interpolate.CubicSpline(nodes, np.eye(m), axis=1, bc_type="not-a-knot"
                                          )(np.clip(x, nodes[0], nodes[-1]))
            if m == 2:  # scipy's two-node "not-a-knot" is the straight line
                ref = np.stack([np.interp(x, nodes, e) for e in np.eye(2)])
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-11)
        # reproduces constants (1 nm node gaps cost a few digits, as in scipy)
        np.testing.assert_allclose(got.sum(axis=0), 1.0, rtol=0, atol=1e-10)


def test_segmentation_does_not_import_scipy_interpolate():
    code = ("import sys; from lumijax.spectral import Spectrum, segment; "
            "e = Spectrum.from_name('F11', 'emission'); s = segment([e]); s.for_emission(e); "
            "print('scipy.interpolate' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert proc.stdout.strip() == "False"
