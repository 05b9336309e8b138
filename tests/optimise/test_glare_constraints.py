"""A glare rating as a hard constraint of the least-power design (docs/optimise.md, "Design to a
standard"): a grey room, a ceiling square A in the desk observer's view and a square B behind
the eye (it only brightens the surroundings), a floor average to meet.

Without a ceiling on GR the cheaper A alone lights the floor; with ``GR ≤ G`` B must raise the
environment luminance. Checked against a search over the two dimmers written here, on the
superposed floor light and the CIE 112 formula fed with each network's veiling and
environment luminance at dimmer 1, and against the rating the results compute at the design.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import numpy as np
import pytest
from helpers import (
    box,
    lamp,
    material,
    network,
    observer,
    photometry,
    plane_grid,
    study_text,
    table,
)

import lumijax
from lumijax.errors import ConfigError
from lumijax.photometry import LuminousOpening, isotropic, write_ies

jax.config.update("jax_enable_x64", True)

I0 = 1000.0  # cd, each square
TARGET_LX = 100.0  # the floor's Eavg floor
POWER_A, POWER_B = 30.0, 60.0  # W at dimmer 1: A is the cheap light
TOL = 1e-3  # [optimise] constraint_tolerance's default, relative


def _room(optimise: str = "") -> str:
    return study_text(
        table("solver", precision="float64", target_patches=60, gather_rays=64,
              spectral_samples=0, cache=False),
        material("wall", 0.5), photometry("sq", file="sq.ies"), box([0, 0, 0], [6, 4, 3]),
        network("a", 1.0, power_w=POWER_A), network("b", 1.0, power_w=POWER_B),
        lamp("A", [3, 2, 2.8], "a", "sq"), lamp("B", [0.2, 2, 2.8], "b", "sq"),
        plane_grid("floor", [0, 0, 0.01], [6, 0, 0], [0, 4, 0], 6, 4) + f"target_lux = {TARGET_LX}\n",
        observer("desk", [0.5, 2, 1.2], direction=[1, 0, 0]),
        "[optimise]\n" + optimise)


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    d = tmp_path_factory.mktemp("glare_room_opt")
    sq = isotropic(4 * math.pi * I0)
    write_ies(dataclasses.replace(sq, opening=LuminousOpening(0.2, 0.2, 0.0, "rectangle")),
              d / "sq.ies")
    (d / "study.toml").write_text(_room('objective = "power"\nvariables = ["dimmers"]\n'))
    study = lumijax.load_study(d / "study.toml")
    return study, lumijax.compute(study)


def _per_network(results):
    """Floor Eavg (lx), the luminaires' veiling luminance L_vl and the environment's L_av
    (cd/m²) of each network at dimmer 1, from the results at the two unit designs."""
    d = results.design
    eavg, veil, env = [], [], []
    for unit in ([1.0, 0.0], [0.0, 1.0]):
        r = results.at(d.replace(dimmers=unit))
        eavg.append(float(np.mean(r.grids["floor"].illuminance_lux)))
        g = r.glare.ratings
        veil.append(float(g.veiling_cdm2[0]))
        env.append(float(g.environment_cdm2[0]))
    return np.array(eavg), np.array(veil), np.array(env)


def _gr(alpha, veil, env):
    """CIE 112: 27 + 24 log10(L_vl / (0.035 L_av)^0.9), each luminance linear in the dimmers."""
    return 27 + 24 * np.log10(alpha @ veil / (0.035 * (alpha @ env)) ** 0.9)


def _search(eavg, veil, env, gr_max, n=801):
    """The least power over a grid of dimmers meeting Eavg ≥ target and GR ≤ gr_max: for each
    α_B the least α_A meeting the floor (closed form: Eavg is linear), then GR checked."""
    best = math.inf
    for b in np.linspace(0, 1, n):
        a = (TARGET_LX - b * eavg[1]) / eavg[0]
        a = max(a, 0.0)
        if a > 1:
            continue
        alpha = np.array([a, b])
        if gr_max is None or a == 0 or _gr(alpha, veil, env) <= gr_max:
            best = min(best, a * POWER_A + b * POWER_B)
    return best


def test_gr_ceiling_binds_and_is_met(room):
    study, results = room
    eavg, veil, env = _per_network(results)
    assert veil[1] == 0.0 and veil[0] > 0  # B is behind the eye: no veil, only surroundings
    free = lumijax.optimise(study, results)
    gr_free = _gr(np.asarray(free.design.dimmers), veil, env)
    gr_max = round(gr_free - 3.0, 1)  # a ceiling below the free design's GR: it must bind
    opt = lumijax.optimise(study, results, constraints=[
        {"criterion": "gr", "observer": "desk", "max": gr_max}])
    rec = opt.constrained
    assert rec["verdict"] == "met", rec
    p_free, p = free.constrained["objective_end"], rec["objective_end"]
    assert p > p_free * 1.05  # the ceiling costs power: it is active
    row = next(r for r in rec["constraints"] if r["criterion"] == "gr")
    assert row["active"] and row["label"] == "observer 'desk': GR"
    # the design's GR, by the formula here and as the results compute it at the design
    alpha = np.asarray(opt.design.dimmers)
    gr_hand = _gr(alpha, veil, env)
    gr_results = results.at(opt.design).glare.summary()[0]["gr"]
    assert gr_results == pytest.approx(gr_hand, abs=1e-6)
    assert row["achieved"] == pytest.approx(gr_hand, abs=1e-6)
    assert gr_hand <= gr_max * (1 + TOL)
    assert gr_hand == pytest.approx(gr_max, abs=0.05)  # active: on the ceiling
    # the least power, against the search (its grid step 1/800 costs ≤ 0.1 W)
    assert p == pytest.approx(_search(eavg, veil, env, gr_max), abs=0.15)
    assert p_free == pytest.approx(_search(eavg, veil, env, None), abs=0.15)


def test_glare_constraint_names_its_key(room):
    study, results = room
    with pytest.raises(ConfigError, match="no observer named 'desks'") as e:
        lumijax.optimise(study, results, constraints=[
            {"criterion": "ugr", "observer": "desks", "max": 19}])
    assert e.value.key == "optimise.constraints[0].observer"
    with pytest.raises(ConfigError, match="not 'grid'") as e:
        lumijax.optimise(study, results, constraints=[
            {"criterion": "ugr", "grid": "floor", "max": 19}])
    assert "constraints" in e.value.key
    with pytest.raises(ConfigError, match="has no road") as e:
        lumijax.optimise(study, results, constraints=[
            {"criterion": "ti", "observer": "desk", "max": 10}])
    assert e.value.key == "optimise.constraints[0].observer"
    without = dataclasses.replace(results, glare=None)  # as a study without observers
    with pytest.raises(ConfigError, match="no \\[\\[observers\\]\\]") as e:
        lumijax.optimise(study, without, constraints=[{"criterion": "gr", "max": 45}])
    assert e.value.key == "optimise.constraints[0].criterion"

