"""The polar diagram draws the distribution's own intensity lookup: at a file's own angles it
gives the file's candela values."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.photometry import read_photometry
from lumijax.report._polar import _plane_curve, beam_angle_deg

# Type C, absolute (−1 lm/lamp), multiplier 1; γ = 0…90, C = 0…360; one table row per C plane
HAND = """IESNA:LM-63-2002
[TEST] hand-made polar check
TILT=NONE
1 -1 1.0 4 5 1 2 0 0 0
1.0 1.0 10
0 30 60 90
0 90 180 270 360
1000 800 400 0
1000 700 300 0
1000 600 200 0
1000 500 100 0
1000 800 400 0
"""
TABLE = {0: [1000, 800, 400, 0], 90: [1000, 700, 300, 0], 180: [1000, 600, 200, 0],
         270: [1000, 500, 100, 0]}


def test_plane_curves_give_the_files_values_at_its_angles(tmp_path):
    path = tmp_path / "hand.ies"
    path.write_text(HAND, encoding="ascii")
    dist = read_photometry(path).distribution
    gamma = np.array([0.0, 30.0, 60.0, 90.0])
    for c, row in TABLE.items():
        np.testing.assert_allclose(_plane_curve(dist, c, gamma), row, rtol=1e-6, atol=1e-3)
    # between samples: bilinear by hand, C45 γ15 = mean of C0 (900) and C90 (850) = 875 cd
    assert _plane_curve(dist, 45.0, np.array([15.0]))[0] == pytest.approx(875.0, rel=1e-5)
    # C0–C180 half-peak: C0 falls to 500 cd at γ = 52.5°, C180 at γ = 37.5° (0.25° sampling)
    assert beam_angle_deg(dist) == pytest.approx(90.0, abs=0.5)


def test_plane_curves_on_a_real_file_at_its_angles(shared_photometry):
    phot = read_photometry(shared_photometry / "lx_Testlamp_Isym4_43cef5d76a391dd85c41d4d09d68600d.ies")
    dist = phot.distribution
    assert dist.photometric_type == "C"
    h, v, cd = (np.asarray(a, np.float64) for a in (dist.h_deg, dist.v_deg, dist.candela))
    inner = (v > 0) & (v < 180)  # the poles are tied to their azimuthal mean on loading
    for i in range(0, len(h) - 1, max(1, len(h) // 8)):
        np.testing.assert_allclose(_plane_curve(dist, h[i], v[inner]), cd[i, inner],
                                   rtol=1e-5, atol=1e-4 * cd.max())
