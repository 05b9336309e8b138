"""A luminaire (and an area source) seen through a clear pane glares with luminance τ(θ) L and
its solid angle unchanged: Σ L² ω / p² scales by τ(θ)², the veiling luminance by τ(θ), so at
a fixed background UGR moves by 8 log10 τ² = 16 log10 τ(θ) and GR (fixed L_ve) by
24 log10 τ(θ). τ(θ) is the thin slab's (n = 1.52, docs/materials.md), written out here from
the Fresnel equations and Radiance's t_n(τ₀) conversion, not through lumijax's glass module;
θ is the line of sight's incidence on the pane."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from _glare import rect, scene_of, write_with_opening
from helpers import area_lamp, lamp, material, photometry, rectangle

from lumijax.design import Design
from lumijax.glare import Observer, build_glare_model
from lumijax.photometry import isotropic

I0, SIDE, TAU0 = 1000.0, 0.2, 0.88
EYE, FWD = np.array([-4.0, 0.0, 1.2]), np.array([1.0, 0.0, 0.0])


def _slab(cos_i: float, tau0: float, n: float = 1.52) -> float:
    """τ(θ) of a thin absorbing pane: both polarisations' incoherent multiple reflections."""
    tn = (math.sqrt(0.8402528435 + 0.0072522239 * tau0 ** 2) - 0.9166530661) / (
        0.0036261119 * tau0)
    ct = math.sqrt(1.0 - (1.0 - cos_i ** 2) / n ** 2)
    t = tn ** (1.0 / ct)
    out = 0.0
    for r in (((cos_i - n * ct) / (cos_i + n * ct)) ** 2,
              ((n * cos_i - ct) / (n * cos_i + ct)) ** 2):
        out += 0.5 * (1.0 - r) ** 2 * t / (1.0 - r * r * t * t)
    return out


def _pane(x: float, tilt_deg: float) -> str:
    """A 3 × 3 m clear pane through (x, 0, 1.5), its normal tilted ``tilt_deg`` about z from
    −x (the eye's side)."""
    a = math.radians(tilt_deg)
    u = [math.sin(a) * 3.0, math.cos(a) * 3.0, 0.0]  # along the pane, horizontal
    o = [x - u[0] / 2, -u[1] / 2, 0.0]
    return rectangle(o, [0, 0, 3.0], u, "glass")


def _rated(scene):
    model = build_glare_model(scene, [Observer.looking("o", EYE, FWD)])
    model = eqx.tree_at(lambda m: (m.background, m.environment), model,
                        (jnp.asarray(np.full((1, 1), 10.0)), jnp.asarray(np.full((1, 1), 5.0))))
    return model(Design.of(scene))


def _incidence(tilt_deg: float, target) -> float:
    """|cos θ| of the line of sight eye → ``target`` on the pane tilted ``tilt_deg``."""
    a = math.radians(tilt_deg)
    normal = np.array([-math.cos(a), math.sin(a), 0.0])
    v = np.subtract(target, EYE)
    return abs(float(normal @ v)) / float(np.linalg.norm(v))


@pytest.mark.parametrize("tilt", [0.0, 55.0])
def test_luminaire_through_a_pane_counts_with_tau(tmp_path, tilt):
    ies = write_with_opening(tmp_path / "sq.ies", isotropic(4 * math.pi * I0), rect(SIDE))
    parts = (photometry("sq", file=ies), lamp("L", [0, 0, 3], "a", "sq"),
             material("glass", 0.0, transmittance=TAU0, kind="clear"))
    bare = _rated(scene_of(*parts))
    glazed = _rated(scene_of(*parts, _pane(-2.0, tilt)))
    tau = _slab(_incidence(tilt, [0.0, 0.0, 3.0]), TAU0)
    assert 0.5 < tau < TAU0  # the line of sight is oblique even on the untilted pane
    assert float(glazed.ugr_sum[0]) == pytest.approx(tau ** 2 * float(bare.ugr_sum[0]),
                                                     rel=1e-6)
    assert float(glazed.veiling_cdm2[0]) == pytest.approx(tau * float(bare.veiling_cdm2[0]),
                                                          rel=1e-6)
    assert float(glazed.ugr[0] - bare.ugr[0]) == pytest.approx(16 * math.log10(tau), abs=1e-4)
    assert float(glazed.gr[0] - bare.gr[0]) == pytest.approx(24 * math.log10(tau), abs=1e-4)


def test_two_panes_and_an_opaque_wall(tmp_path):
    ies = write_with_opening(tmp_path / "sq.ies", isotropic(4 * math.pi * I0), rect(SIDE))
    parts = (photometry("sq", file=ies), lamp("L", [0, 0, 3], "a", "sq"),
             material("glass", 0.0, transmittance=TAU0, kind="clear"), material("wall", 0.5))
    bare = _rated(scene_of(*parts))
    double = _rated(scene_of(*parts, _pane(-2.0, 0.0), _pane(-1.0, 0.0)))
    tau = _slab(_incidence(0.0, [0.0, 0.0, 3.0]), TAU0)
    assert float(double.ugr_sum[0]) == pytest.approx(tau ** 4 * float(bare.ugr_sum[0]),
                                                     rel=1e-6)
    wall = rectangle([-2.0, -1.5, 0.0], [0, 3.0, 0], [0, 0, 3.0], "wall")
    hidden = _rated(scene_of(*parts, _pane(-1.0, 0.0), wall))
    assert float(hidden.ugr_sum[0]) == 0.0 and float(hidden.veiling_cdm2[0]) == 0.0


def test_area_source_through_a_pane(tmp_path):
    # a 0.4 m square panel at x = 0 facing the eye (−x), centre (0, 0, 2)
    panel = area_lamp("P", [0.0, 0.2, 1.8], [0, -0.4, 0], [0, 0, 0.4], 500.0, "a")
    parts = (panel, material("glass", 0.0, transmittance=TAU0, kind="clear"))
    bare = _rated(scene_of(*parts))
    glazed = _rated(scene_of(*parts, _pane(-2.0, 40.0)))
    tau = _slab(_incidence(40.0, [0.0, 0.0, 2.0]), TAU0)
    assert float(bare.ugr_sum[0]) > 0
    assert float(glazed.ugr_sum[0]) == pytest.approx(tau ** 2 * float(bare.ugr_sum[0]),
                                                     rel=1e-6)
    assert float(glazed.veiling_cdm2[0]) == pytest.approx(tau * float(bare.veiling_cdm2[0]),
                                                          rel=1e-6)
