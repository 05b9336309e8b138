"""Real luminaire files in CIE 117/190's standard room, lengthwise and crosswise: the glare
sources' sum Σ L²ω/p² and the UGR at a given background, against an independent implementation
written here from the CIE definitions (the file's candela table interpolated by scipy, the
position index from H/R and T/R, the flat opening's projected area), not lumijax's code path.

The standard room: luminaires H = 2 m above the eye (1.2 m), spaced 0.25 H over X = 4H
(along the line of sight) by Y = 4H, the observer at the middle of a wall looking along the
room. The background L_b is set here (the tabular method's L_b comes from its room flux
transfer, not modelled): what is checked is everything that depends on the photometry.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from _glare import scene_of
from helpers import lamp, photometry
from scipy.interpolate import RegularGridInterpolator

from lumijax.design import Design
from lumijax.glare import Observer, build_glare_model
from lumijax.photometry import read_photometry

H, EYE = 2.0, 1.2
S = 0.25 * H
X, Y = 4 * H, 4 * H
LB = 40.0  # cd/m², set by hand
FILES = ["er_fluorescent_luminaire.ldt", "lx_Testlamp_Isym3_symmetryOverC90C270axis.ldt"]


def _layout():
    xs = S / 2 + S * np.arange(int(round(X / S)))
    ys = S / 2 + S * np.arange(int(round(Y / S)))
    return np.array([(x, y) for x in xs for y in ys])


def _independent_sum(phot, spin_deg: float) -> float:
    d = phot.distribution
    table = RegularGridInterpolator((np.asarray(d.h_deg, np.float64),
                                     np.asarray(d.v_deg, np.float64)),
                                    np.asarray(d.candela, np.float64))
    area = phot.opening.length_m * phot.opening.width_m
    eye = np.array([0.0, Y / 2, EYE])
    total = 0.0
    for x, y in _layout():
        w = eye - np.array([x, y, EYE + H])  # luminaire → eye, world
        dist = float(np.linalg.norm(w))
        a = math.radians(spin_deg)  # local = Rz(−spin) · world
        lx, ly = math.cos(a) * w[0] + math.sin(a) * w[1], -math.sin(a) * w[0] + math.cos(a) * w[1]
        c = math.degrees(math.atan2(ly, lx)) % 360.0
        gamma = math.degrees(math.acos(-w[2] / dist))
        cd = float(table([[c, gamma]])[0])
        cos_g = H / dist
        lum, omega = cd / (area * cos_g), area * cos_g / dist ** 2
        r, t = x - eye[0], abs(y - eye[1])  # ahead, beside; H above
        sigma = math.degrees(math.atan(math.hypot(t, H) / r))
        tau = math.degrees(math.atan2(t, H))
        p = min(16.0, math.exp((35.2 - 0.31889 * tau - 1.22 * math.exp(-2 * tau / 9)) * 1e-3
                               * sigma + (21 + 0.26667 * tau - 0.002963 * tau ** 2) * 1e-5
                               * sigma ** 2))
        total += lum ** 2 * omega / p ** 2
    return total


@pytest.mark.parametrize("name", FILES)
def test_standard_room_glare_sources_against_an_independent_sum(shared_photometry, name):
    path = shared_photometry / name
    phot = read_photometry(path)
    assert phot.opening.shape == "rectangle"
    scene = scene_of(photometry("f", file=path), *(
        lamp(f"L{i}-{o}", [x, y, EYE + H], o, "f", aim={"spin": s})
        for o, s in (("lengthwise", 0), ("crosswise", 90)) for i, (x, y) in enumerate(_layout())))
    model = build_glare_model(scene, [Observer.looking("o", [0, Y / 2, EYE], [1, 0, 0])])
    model = eqx.tree_at(lambda m: m.background, model, jnp.asarray(np.full((1, 2), LB)))
    design = Design.of(scene)
    for k, (orientation, spin) in enumerate((("lengthwise", 0.0), ("crosswise", 90.0))):
        r = model(design.replace(dimmers=[1.0 if j == k else 0.0 for j in range(2)]))
        want = _independent_sum(phot, spin)
        # L_b is per network: with the other network off, only this one's L_b counts
        assert float(r.ugr_sum[0]) == pytest.approx(want, rel=5e-3), orientation
        ugr = 8 * math.log10(0.25 / LB * want)
        assert float(r.ugr[0]) == pytest.approx(ugr, abs=0.05), orientation
