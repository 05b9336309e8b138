"""The upward light ratio from a luminaire's own photometry against closed forms and an
independent integration written here; intensity toward a point by hand."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.compliance import intensity_toward, upward_flux
from lumijax.config import parse_config
from lumijax.scene import build_scene


def _scene(lums: str, phot: str = 'kind = "lambertian"\nflux_lm = 1000\n', extra: str = ""):
    return build_scene(parse_config(f"[photometry.p]\n{phot}\n{lums}\n{extra}"))


def _lum(name, tilt, pan=0.0, pos=(0, 0, 5)):
    return (f'[[luminaires]]\nname = "{name}"\nphotometry = "p"\nposition = {list(pos)}\n'
            f'network = "n"\naim = {{ tilt = {tilt}, pan = {pan} }}\n')


@pytest.mark.parametrize("tilt", [0.0, 30.0, 90.0, 135.0])
def test_ulr_of_a_tilted_lambertian(tilt):
    """A Lambertian emitter tilted t from straight down sends (1 − cos t)/2 of its flux above
    the horizontal (the sky view factor of a plane tilted t from facing down)."""
    sc = _scene(_lum("L", tilt))
    up, tot = upward_flux(sc)
    assert tot[0] == pytest.approx(1000.0, rel=2e-3)
    assert up[0] / tot[0] == pytest.approx((1 - np.cos(np.radians(tilt))) / 2, abs=2e-3)


def test_ulr_of_a_table_photometry_against_a_product_rule(tmp_path):
    """An IES file with light up to 120° from nadir, aimed 20° up: upward flux against a
    Gauss–Legendre × trapezoid rule in the luminaire's own (C, γ) frame written here, which
    keeps the cells above the world horizon by the direction's own z."""
    from lumijax.photometry import read_photometry

    gam = np.arange(0, 181, 5.0)
    cd = np.where(gam <= 120, 400 * np.cos(np.radians(gam) / 1.5) ** 2, 0.0)
    text = (f"IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 {len(gam)} 1 1 2 0.1 0.1 0\n1 1 30\n"
            + " ".join(f"{g:g}" for g in gam) + "\n0\n" + " ".join(f"{c:.4f}" for c in cd) + "\n")
    path = tmp_path / "up.ies"
    path.write_text(text)
    dist = read_photometry(path).distribution
    sc = build_scene(parse_config(
        f'[photometry.p]\nfile = "{path}"\n' + _lum("L", 110.0, pan=30.0)))
    up, tot = upward_flux(sc)
    lum = sc.luminaires[0]
    # independent: nodes in the luminaire frame, γ by Gauss–Legendre, C uniform
    xg, wg = np.polynomial.legendre.leggauss(400)
    g = 0.5 * np.pi * (xg + 1)
    wgam = 0.5 * np.pi * wg
    c = (np.arange(720) + 0.5) * 2 * np.pi / 720
    gg, cc = np.meshgrid(g, c, indexing="ij")
    local = np.stack([np.sin(gg) * np.cos(cc), np.sin(gg) * np.sin(cc), -np.cos(gg)], axis=-1)
    intensity = np.interp(np.degrees(gg), gam, cd)  # rotationally symmetric: I(γ) only
    dw = (wgam * np.sin(g))[:, None] * (2 * np.pi / 720)
    world = local @ lum.rotation.T
    expect_up = np.sum(intensity * dw * (world[..., 2] > 0))
    expect_tot = np.sum(intensity * dw)
    assert tot[0] == pytest.approx(expect_tot, rel=5e-3)
    assert up[0] == pytest.approx(expect_up, rel=1e-2)
    assert 0.2 < up[0] / tot[0] < 0.9  # a real split, not a trivial 0 or 1
    del dist


def test_intensity_toward_a_point_with_a_wall():
    sc = _scene(_lum("L", 0.0, pos=(0, 0, 4)) + _lum("M", 0.0, pos=(5, 0, 4)), extra=(
        '[materials.m]\nreflectance = 0.2\n[[geometry]]\nkind = "rectangle"\n'
        'origin = [3.5, -2, 0]\nu = [0, 4, 0]\nv = [0, 0, 6]\nmaterial = "m"\n'))
    p = np.array([2.0, 1.0, 0.0])
    i = intensity_toward(sc, p)
    d = p - [0, 0, 4]
    assert i[0] == pytest.approx(1000 / np.pi * 4 / np.linalg.norm(d), rel=1e-4)
    assert i[1] == 0.0  # behind the wall at x = 3.5
