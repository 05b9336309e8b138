"""One small luminaire of known intensity and area at known positions: luminance, solid angle,
position index, UGR, GR and TI by hand (CIE 117, CIE 112, CIE 140), against the model.

The scene has no surfaces, so nothing hides the luminaire and the background is set by hand
(``eqx.tree_at``): what is checked is the geometry and photometry of the eye's view and the
rating formulas, each written out here from the standards' text, not through the code."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from _glare import rect, scene_of, write_with_opening
from helpers import lamp, photometry

from lumijax.glare import (
    NoLuminousSizeWarning,
    Observer,
    build_glare_model,
    guth_index,
    position_index,
)
from lumijax.photometry import LuminousOpening, isotropic

I0 = 1000.0  # cd, every direction
SIDE = 0.2  # m, a square opening facing down
SQUARE = rect(SIDE)


def _scene(tmp_path, opening=SQUARE):
    """One isotropic luminaire L of I0 cd at (0, 0, 3) m with ``opening``, nothing else."""
    ies = write_with_opening(tmp_path / "sq.ies", isotropic(4 * math.pi * I0), opening)
    return scene_of(photometry("sq", file=ies), lamp("L", [0, 0, 3], "a", "sq"))


def _hand(eye, forward, lum=(0.0, 0.0, 3.0)):
    """L, ω, σ (deg), p above the line of sight, E at the eye, by hand."""
    v = np.subtract(lum, eye)
    d = float(np.linalg.norm(v))
    cos_gamma = (lum[2] - eye[2]) / d  # the opening faces straight down
    area = SIDE * SIDE * cos_gamma
    sigma = math.degrees(math.acos(float(np.dot(v, forward)) / d))
    # the source straight above the line of sight: τ = 0 in Guth's expression
    p = math.exp((35.2 - 1.22) * 1e-3 * sigma + 21e-5 * sigma ** 2)
    e_eye = I0 * math.cos(math.radians(sigma)) / d ** 2
    return I0 / area, area / d ** 2, sigma, p, e_eye


def test_luminance_solid_angle_position_index_and_ugr_by_hand(tmp_path):
    scene = _scene(tmp_path)
    eye, fwd = np.array([-4.0, 0.0, 1.2]), np.array([1.0, 0.0, 0.0])
    model = build_glare_model(scene, [Observer.looking("o", eye, fwd)])
    lb, lav = 10.0, 5.0  # cd/m², set by hand
    model = _with_background(model, lb, lav)
    r = model(scene_design(scene))
    L, omega, sigma, p, e_eye = _hand(eye, fwd)
    assert 1e-4 < omega < 0.1  # inside CIE 117's range: the rating is valid here
    ugr = 8 * math.log10(0.25 / lb * L ** 2 * omega / p ** 2)
    assert float(r.ugr[0]) == pytest.approx(ugr, abs=0.02)
    assert float(r.ugr_sum[0]) == pytest.approx(L ** 2 * omega / p ** 2, rel=2e-3)
    lvl = 10 * e_eye / sigma ** 2
    assert float(r.veiling_cdm2[0]) == pytest.approx(lvl, rel=1e-3)
    gr = 27 + 24 * math.log10(lvl / (0.035 * lav) ** 0.9)
    assert float(r.gr[0]) == pytest.approx(gr, abs=0.02)


def test_dimmer_scales_luminance_and_background(tmp_path):
    """Superposition: at dimmer α the source's L is αL and L_b is αL_b, so UGR changes by
    8 log10(α) (CIE 117: L² against L_b)."""
    scene = _scene(tmp_path)
    model = build_glare_model(scene, [Observer.looking("o", [-4, 0, 1.2], [1, 0, 0])])
    model = _with_background(model, 10.0)
    full = float(model(scene_design(scene)).ugr[0])
    half = float(model(scene_design(scene).replace(dimmers=[0.5])).ugr[0])
    assert half - full == pytest.approx(8 * math.log10(0.5), abs=0.01)


def test_threshold_increment_by_hand(tmp_path):
    """TI = 65 L_v / L_av^0.8 (CIE 140) with a given road luminance."""
    scene = _scene(tmp_path)
    eye, fwd = np.array([-30.0, 0.0, 1.5]), np.array([1.0, 0.0, -math.tan(math.radians(1))])
    fwd /= np.linalg.norm(fwd)
    obs = Observer.looking("driver", eye, fwd, road_luminance_cdm2=1.0)
    r = build_glare_model(scene, [obs])(scene_design(scene))
    _, _, sigma, _, e_eye = _hand(eye, fwd)
    assert float(r.ti[0]) == pytest.approx(65 * 10 * e_eye / sigma ** 2 / 1.0 ** 0.8, rel=1e-3)


def test_point_source_uses_the_documented_sphere_and_warns(tmp_path):
    scene = _scene(tmp_path, opening=LuminousOpening())
    with pytest.warns(NoLuminousSizeWarning, match="sq"):
        model = build_glare_model(scene, [Observer.looking("o", [-4, 0, 1.2], [1, 0, 0])])
    model = _with_background(model, 10.0)
    r = model(scene_design(scene))
    area = math.pi / 4 * 0.1 ** 2  # POINT_DIAMETER_M = 0.1, from every side
    d2 = 4 ** 2 + 1.8 ** 2
    _, _, _, p, _ = _hand(np.array([-4, 0, 1.2]), np.array([1, 0, 0]))
    assert float(r.ugr_sum[0]) == pytest.approx((I0 / area) ** 2 * area / d2 / p ** 2, rel=2e-3)


def test_source_behind_the_eye_adds_nothing(tmp_path):
    scene = _scene(tmp_path)
    model = build_glare_model(scene, [Observer.looking("o", [-4, 0, 1.2], [-1, 0, 0])])
    r = model(scene_design(scene))
    assert float(r.ugr_sum[0]) == 0.0 and float(r.veiling_cdm2[0]) == 0.0


@pytest.mark.parametrize(("h_over_r", "table"), [(0.3, 1.90), (0.5, 2.86), (1.0, 7.00)])
def test_position_index_against_guths_table(h_over_r, table):
    """Guth's table (IES Lighting Handbook; CIE 117's position index), T/R = 0 column: a source
    at height H above the line of sight, R ahead along it."""
    d = np.array([1.0, 0.0, h_over_r])
    p = position_index(d / np.linalg.norm(d), np.array([1.0, 0.0, 0.0]))
    assert float(p) == pytest.approx(table, rel=0.03)


def test_position_index_beside_the_line_of_sight_uses_tau():
    """A source beside the line of sight (τ = 90°) at σ = 30°: Guth's expression with τ = 90,
    not τ = 0 (which would give a larger index)."""
    s = math.radians(30)
    p = float(position_index(np.array([math.cos(s), math.sin(s), 0.0]), np.array([1.0, 0, 0])))
    assert p == pytest.approx(float(guth_index(30.0, 90.0)), rel=1e-9)
    assert p < float(guth_index(30.0, 0.0))


def _with_background(model, lb, lav=0.0):
    """The model with L_b and L_av (cd/m², one network) set by hand; float64 arrays like the
    built ones, so the compiled evaluation is reused."""
    return eqx.tree_at(lambda m: (m.background, m.environment), model,
                       (jnp.asarray(np.full((1, 1), lb)), jnp.asarray(np.full((1, 1), lav))))


def scene_design(scene):
    from lumijax.design import Design

    return Design.of(scene)


def test_ugr_of_host_numbers_is_the_cie_formula_in_numpy():
    # an image's own UGR (render._image) rates host floats; CIE 117: 8 log10(0.25/L_b Σ L²ω/p²)
    from lumijax.glare._ratings import ugr_of_sum

    s, lb = 3.7e5, 42.0
    host = ugr_of_sum(s, lb)
    assert isinstance(host, np.floating)  # numpy, no JAX kernel
    assert host == pytest.approx(8.0 * math.log10(0.25 / lb * s), rel=1e-12)
    assert float(ugr_of_sum(jnp.asarray(s), jnp.asarray(lb))) == pytest.approx(host, rel=1e-6)
    assert ugr_of_sum(1.0, 1e3) == 0.0  # held ≥ 0 below the formula's range
