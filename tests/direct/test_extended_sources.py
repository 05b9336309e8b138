"""Luminaires with a large luminous opening: the 5× rule splits them near receivers."""

from __future__ import annotations

from functools import partial

import jax.numpy as jnp
import numpy as np
from helpers import lamp, photometry, plane_grid, study_text

import lumijax
from lumijax import load_study
from lumijax.direct import point_illuminance, sub_source_offsets

# these tests check direct light against closed forms: inter-reflection off
compute = partial(lumijax.compute, indirect=False)

BAR = "lx_Testlamp_Isym4_43cef5d76a391dd85c41d4d09d68600d.ldt"  # 1.12 m linear LED luminaire


def test_offsets_follow_the_five_times_rule():
    assert len(sub_source_offsets(1.0, 0.0, 10.0)) == 1  # 10 m away: a point
    off = sub_source_offsets(1.0, 0.0, 0.5)  # 0.5 m away: pieces of at most 0.1 m
    assert len(off) == 10
    np.testing.assert_allclose(off[:, 0].mean(), 0.0, atol=1e-15)
    assert np.all(np.diff(np.sort(off[:, 0])) <= 0.1 + 1e-12)
    assert len(sub_source_offsets(2.0, 0.5, 0.05)) == 32 * 32  # capped


def _study(write_study, folder, height):
    return write_study(study_text(
        photometry("bar", file=folder / BAR), lamp("bar", [0, 0, height], photometry="bar"),
        plane_grid("g", [-1, -0.5, 0], [2, 0, 0], [0, 1, 0], nu=21, nv=11)))


def _converged(dist, height, pts, n=1120, length=1.12):
    """The same luminaire as 1 mm segments: the continuous line-source integral."""
    x = ((np.arange(n) + 0.5) / n - 0.5) * length
    pos = jnp.asarray(np.stack([x, np.zeros(n), np.full(n, height)], 1))
    e = point_illuminance(dist, pos, jnp.tile(jnp.eye(3), (n, 1, 1)), jnp.full(n, 1 / n),
                          jnp.asarray(pts), jnp.tile(jnp.array([0.0, 0, 1]), (len(pts), 1)))
    return np.asarray(e.sum(0))


def test_close_linear_luminaire_matches_the_line_integral(write_study, shared_photometry):
    study = load_study(_study(write_study, shared_photometry, 0.3))
    g = compute(study)["g"]
    dist = study.scene.photometries["bar"].distribution
    ref = _converged(dist, 0.3, g.points)
    np.testing.assert_allclose(g.illuminance_lux, ref, rtol=0.02, atol=1e-3 * ref.max())
    # and a single point source would be badly wrong there: the reason for the rule
    point = np.asarray(point_illuminance(
        dist, jnp.array([[0, 0, 0.3]]), jnp.eye(3)[None], jnp.ones(1), jnp.asarray(g.points),
        jnp.tile(jnp.array([0.0, 0, 1]), (len(g.points), 1))))[0]
    assert np.max(np.abs(point - ref) / ref.max()) > 0.2


def test_far_linear_luminaire_is_a_point(write_study, shared_photometry):
    study = load_study(_study(write_study, shared_photometry, 8.0))
    g = compute(study)["g"]
    ref = _converged(study.scene.photometries["bar"].distribution, 8.0, g.points)
    # beyond five lengths a source is a point to within about 1 % (the rule's design error)
    np.testing.assert_allclose(g.illuminance_lux, ref, rtol=1e-2)
