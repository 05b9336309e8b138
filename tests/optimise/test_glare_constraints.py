"""A glare rating as a hard constraint of the least-power design (docs/optimise.md, "Design to a
standard"): a grey room, a wide ceiling spot A in the desk observer's view and an isotropic
square B behind the eye (it only brightens the surroundings), a floor average to meet.

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
from lumijax.optimise import optimise
from lumijax.photometry import LuminousOpening, isotropic, spot, write_ies

jax.config.update("jax_enable_x64", True)

I0 = 1000.0  # cd: the square's intensity (the spot has the same flux, 4π I0 lm)
TARGET_LX = 100.0  # the floor's Eavg floor
POWER_A, POWER_B = 30.0, 60.0  # W at dimmer 1: A is the cheap light
TOL = 1e-3  # [optimise] constraint_tolerance's default, relative


def _room(optimise: str = "") -> str:
    return study_text(
        table("solver", precision="float64", target_patches=60, gather_rays=64,
              spectral_samples=0, cache=False),
        material("wall", 0.5), photometry("sq", file="sq.ies"), photometry("wide", file="wide.ies"),
        box([0, 0, 0], [6, 4, 3]),
        network("a", 1.0, power_w=POWER_A), network("b", 1.0, power_w=POWER_B),
        lamp("A", [3, 2, 2.8], "a", "wide"), lamp("B", [0.2, 2, 2.8], "b", "sq"),
        plane_grid("floor", [0, 0, 0.01], [6, 0, 0], [0, 4, 0], 6, 4) + f"target_lux = {TARGET_LX}\n",
        observer("desk", [0.5, 2, 1.2], direction=[1, 0, 0]),
        "[optimise]\n" + optimise)


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    d = tmp_path_factory.mktemp("glare_room_opt")
    opening = LuminousOpening(0.2, 0.2, 0.0, "rectangle")
    flux = 4 * math.pi * I0
    for name, phot in (("sq", isotropic(flux)), ("wide", spot(flux, beam_deg=100))):
        write_ies(dataclasses.replace(phot, opening=opening), d / f"{name}.ies")
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
    free = optimise(study, results)
    gr_free = _gr(np.asarray(free.design.dimmers), veil, env)
    gr_max = round(gr_free - 3.0, 1)  # a ceiling below the free design's GR: it must bind
    opt = optimise(study, results, constraints=[
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
        optimise(study, results, constraints=[
            {"criterion": "ugr", "observer": "desks", "max": 19}])
    assert e.value.key == "optimise.constraints[0].observer"
    with pytest.raises(ConfigError, match="not 'grid'") as e:
        optimise(study, results, constraints=[
            {"criterion": "ugr", "grid": "floor", "max": 19}])
    assert "constraints" in e.value.key
    with pytest.raises(ConfigError, match="has no road") as e:
        optimise(study, results, constraints=[
            {"criterion": "ti", "observer": "desk", "max": 10}])
    assert e.value.key == "optimise.constraints[0].observer"
    without = dataclasses.replace(results, glare=None)  # as a study without observers
    with pytest.raises(ConfigError, match="no \\[\\[observers\\]\\]") as e:
        optimise(study, without, constraints=[{"criterion": "gr", "max": 45}])
    assert e.value.key == "optimise.constraints[0].criterion"



def test_glare_constraint_differentiates_through_aims_and_levels(room):
    """The constraint reads aims and levels from the variables: its gradient (reverse mode,
    compiled) against central differences, the spot A tilted towards the eye so its intensity
    and projected area toward it move with the aim."""
    import equinox as eqx
    import jax.numpy as jnp

    from lumijax.design import traverse
    from lumijax.optimise._constraints import DesignLight
    from lumijax.optimise._glare_constraint import GlareConstraint

    _, results = room
    start = results.design.replace(tilt_deg=[45.0, 10.0], pan_deg=[170.0, 0.0])
    params = traverse(start, ("dimmers", "aims", "levels"), luminaires=(0, 1),
                      aim_bounds_deg=[((0, 180), (-180, 180))] * 2)
    cs = [GlareConstraint(label=r, key="k", unit="", sense=-1, bound=jnp.asarray(20.0),
                          model=results.glare.model, params=params, rating=r, observer=0,
                          views=(0,), ref=20.0) for r in ("ugr", "gr")]

    def f(x):
        light = DesignLight(jnp.zeros(1), None, x[:2], x)
        return jnp.stack([c.value(light, None) for c in cs])

    x0 = jnp.asarray(params.x0) * jnp.asarray([0.7, 0.9, 1, 1, 1, 1, 1.2, 1])
    jac = np.asarray(eqx.filter_jit(jax.jacrev(f))(x0))
    fj, h = eqx.filter_jit(f), 1e-6
    fd = np.stack([(fj(x0.at[i].add(h)) - fj(x0.at[i].add(-h))) / (2 * h)
                   for i in range(x0.size)], axis=1)
    assert np.abs(fd[:, [0, 2, 4, 6]]).min() > 0.1  # A's dimmer, tilt, pan, level all count
    np.testing.assert_allclose(jac, fd, rtol=1e-5, atol=1e-6)


def test_superposed_glare_ceilings_batched_equal_their_own_values(room):
    """The ceilings rated by superposition are evaluated as one batch
    (``GlareConstraint.values_of``): UGR and GR of views (0,), (0, 0), (0, 0, 0) (rows of 1, 2
    and 3 entries: the padding and ``t = ε / ln n`` per row) against each constraint's own
    ``value``, smooth and exact, and their derivatives in the dimmers."""
    import jax.numpy as jnp

    from lumijax.design import traverse
    from lumijax.optimise._constraints import DesignLight, constraint_values
    from lumijax.optimise._glare_constraint import GlareConstraint

    _, results = room
    model = results.glare.model
    params = traverse(results.design, ("dimmers",))
    sup = model.at_aims(params.start)
    cs = tuple(GlareConstraint(label=r, key="k", unit="", sense=-1, bound=jnp.asarray(20.0),
                               model=model, params=params, rating=r, observer=0, views=v,
                               ref=20.0, superposed=sup)
               for r in ("ugr", "gr") for v in ((0,), (0, 0), (0, 0, 0)))

    def light(alpha):
        return DesignLight(jnp.zeros(1), None, alpha, alpha)

    for smooth in (1e-2, None):
        f = jax.jit(lambda a, s=smooth: constraint_values(cs, light(a), s))
        g = jax.jit(lambda a, s=smooth: jnp.stack([c.value(light(a), s) for c in cs]))
        alpha = jnp.asarray([0.7, 0.4])
        np.testing.assert_allclose(np.asarray(f(alpha)), np.asarray(g(alpha)), rtol=1e-12)
        np.testing.assert_allclose(np.asarray(jax.jit(jax.jacrev(f))(alpha)),
                                   np.asarray(jax.jit(jax.jacrev(g))(alpha)), rtol=1e-10,
                                   atol=1e-12)
