"""The luminance of the surfaces an observer sees, against the closed form: a Lambertian wall of
reflectance ρ lit by an isotropic source of intensity I at distance d on its normal has, at the
foot of that normal, E = I / d² and L = ρ E / π (cd/m²); nothing else in the scene, so no
inter-reflection (a plane does not see itself). A second named panel hidden behind the wall is
not seen. The limit on the wall is reported and, as a constraint, linear in the dimmer."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import (
    lamp,
    material,
    observer,
    photometry,
    point_grid,
    rectangle,
    study_text,
    table,
)

import lumijax
from lumijax.errors import ConfigError
from lumijax.optimise._constraints import DesignLight
from lumijax.optimise._surface_constraint import surface_constraints

RHO, FLUX, D = 0.6, 4000.0, 6.0
I_CD = FLUX / (4 * math.pi)  # cd
L_FOOT = RHO * I_CD / D ** 2 / math.pi  # cd/m², the wall's brightest point
E_FLOOR = 5.0  # lx asked at the foot grid point


def _text(limit):
    return study_text(
        table("solver", target_patches=200, spectral_samples=0, gather_rays=64),
        material("wall", RHO),
        photometry("iso", kind="isotropic", flux_lm=FLUX),
        # the wall at y = 0 facing +y (u × v), 2 × 2 m about the foot point (0, 0, 1)
        rectangle([-1, 0, 0], [0, 0, 2], [2, 0, 0], name="wall"),
        # a panel behind it, facing the observer's way but hidden by the wall
        rectangle([-0.5, -1, 0.5], [0, 0, 1], [1, 0, 0], name="panel"),
        lamp("L", [0, D, 1], "n", "iso"),
        observer("eye", [0.3, 3.0, 1.4], direction=[0, -1, 0],
                 max_luminance_cdm2={"wall": limit}),
        # 1 cm in front of the foot point: a floor for the constrained design below
        point_grid("foot", [[0, 0.01, 1]], normals=[0, 1, 0], target_lux=E_FLOOR))


@pytest.fixture(scope="module")
def studied(tmp_path_factory):
    d = tmp_path_factory.mktemp("surfaces")
    (d / "study.toml").write_text(_text(0.9 * L_FOOT))
    study = lumijax.load_study(d / "study.toml")
    return study, lumijax.compute(study, cache_dir=d / "cache")


@pytest.fixture
def lit(studied):
    return studied[1]


def test_wall_luminance_is_rho_e_over_pi_and_the_hidden_panel_is_not_seen(lit):
    got = lit.glare.to_dict()["eye"]["surfaces"]
    assert set(got) == {"wall"}, got  # the panel is behind the wall
    wall = got["wall"]
    # the brightest patch lies within a patch of the foot point: E falls as cos³ (−1.1e-4)
    assert wall["max_luminance_cdm2"] == pytest.approx(L_FOOT, rel=1e-3)
    assert wall["mean_luminance_cdm2"] < wall["max_luminance_cdm2"]
    assert wall["limit_cdm2"] == pytest.approx(0.9 * L_FOOT) and wall["meets"] is False


def test_surface_luminance_follows_the_dimmer_and_differentiates(lit):
    g = lit.glare
    radiosity = jnp.asarray(g.radiosity)

    def brightest(alpha):
        return g.surfaces.maximum(alpha @ radiosity)[0, 0]

    alpha = jnp.asarray([0.4])
    assert float(brightest(alpha)) == pytest.approx(0.4 * L_FOOT, rel=1e-3)
    assert float(jax.grad(brightest)(alpha)[0]) == pytest.approx(L_FOOT, rel=1e-3)
    half = lit.at(lit.design.replace(dimmers=[0.5])).glare.to_dict()["eye"]["surfaces"]["wall"]
    assert half["max_luminance_cdm2"] == pytest.approx(0.5 * L_FOOT, rel=1e-3)
    assert half["meets"] is True


def test_the_limit_is_a_hard_constraint_linear_in_the_dimmer(lit):
    g = lit.glare
    (c,) = surface_constraints(g.surfaces)
    assert c.key == "observers[0].max_luminance_cdm2.wall"
    b = jnp.asarray(0.5 * np.asarray(g.radiosity)[0])
    light = DesignLight(e=jnp.zeros(0), b=b, alpha=jnp.asarray([0.5]), x=jnp.asarray([0.5]))
    assert float(c.value(light, None)) == pytest.approx(0.5 * L_FOOT, rel=1e-3)
    assert float(c.margin(light, None)) > 0  # 0.5 L ≤ 0.9 L
    assert float(c.value(light, 1e-3)) >= float(c.value(light, None))  # conservative
    with pytest.raises(ConfigError, match="no named surface 'roof'"):
        surface_constraints(g.surfaces, surface="roof", bound=10.0, key="optimise.constraints[0]")
    with pytest.raises(ConfigError, match="sees no part of surface 'panel'|no named surface"):
        surface_constraints(g.surfaces, surface="panel", observer="eye", bound=10.0)


def test_unknown_surface_in_a_limit_names_the_key(tmp_path):
    text = _text(10.0).replace('max_luminance_cdm2 = { wall = 10.0 }',
                               'max_luminance_cdm2 = { roof = 10.0 }')
    assert "roof" in text
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(ConfigError, match="no \\[\\[geometry\\]\\] item is named 'roof'") as e:
        lumijax.load_study(tmp_path / "s.toml")
    assert "observers[0].max_luminance_cdm2.roof" in str(e.value)


def test_the_report_lists_the_surface_and_its_unmet_limit(lit):
    from lumijax.report._glare import glare_sections

    (section,) = glare_sections(None, lit, pictures=False)
    assert "surface seen" in section.html
    row = section.html.split("<td>wall</td>")[1].split("</tr>")[0]
    cells = [c.split("</td>")[0] for c in row.split("<td>")[1:]]
    assert float(cells[0]) == pytest.approx(L_FOOT, rel=1e-2)  # max L, 3 digits
    assert float(cells[2]) == pytest.approx(0.9 * L_FOOT, rel=1e-2) and cells[3] == "✗"


def test_a_surface_luminance_constraint_in_the_least_power_design(studied):
    # one network: least power meets the foot point's floor exactly, α = E_FLOOR / E(foot),
    # so the wall's brightest luminance is α L_FOOT = ρ E_FLOOR (5.99 / 6)² / π; the explicit
    # ceiling (1.2 cd/m²) and the observer's own limit (0.9 L_FOOT) are both met
    from lumijax.optimise import optimise

    study, lit = studied
    opt = optimise(study, lit, objective="power",
                   constraints=[{"criterion": "surface_luminance", "surface": "wall",
                                 "max": 1.2}])
    con = opt.constrained
    assert con["verdict"] == "met"
    want = RHO * E_FLOOR * (5.99 / D) ** 2 / math.pi
    assert [r["achieved"] for r in con["constraints"] if "luminance of 'wall'" in r["label"]] \
        == pytest.approx([want, want], rel=2e-3)
    assert all(r["met"] for r in con["constraints"])


def test_a_limit_that_cannot_be_evaluated_warns_naming_the_key(studied):
    from lumijax.errors import LumijaxWarning

    study, _ = studied
    with pytest.warns(LumijaxWarning, match=r"observers\[0\]\.max_luminance_cdm2"):
        r = lumijax.compute(study, shadows=False)
    assert "surfaces" not in r.glare.to_dict()["eye"]


def test_a_surface_behind_a_clear_pane_is_seen(studied, tmp_path):
    """A clear pane across the whole field in front of the eye hides nothing: the same wall
    patches are seen as without it (the field's rays pass panes; a limit bounds the wall's own
    B/π)."""
    from lumijax.glare import build_observers, build_seen_surfaces

    study, lit = studied
    pane = rectangle([-20, 2.9, -20], [40, 0, 0], [0, 0, 40], "glass")  # y = 2.9, facing −y
    text = _text(0.9 * L_FOOT) + material("glass", 0.0, transmittance=0.88, kind="clear") + pane
    (tmp_path / "s.toml").write_text(text)
    glazed = lumijax.load_study(tmp_path / "s.toml")
    names = [g.name for g in glazed.config.geometry]
    patches = lit.lighting.coarse.patches
    wall = lit.glare.surfaces.surfaces.index("wall")
    bare = lit.glare.surfaces.links_of(0, wall)
    seen = build_seen_surfaces(glazed.scene, build_observers(glazed.config, glazed.scene),
                               patches, names)
    assert len(bare) > 10
    assert np.array_equal(np.sort(seen.links_of(0, seen.surfaces.index("wall"))), np.sort(bare))
