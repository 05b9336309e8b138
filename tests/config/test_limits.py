"""Inputs that used to end in a traceback or a NaN: each is now one error naming its key.

Grid point counts that overflow, lux goals whose squares overflow, an optimiser with nothing to
move, aims without a photometric luminaire, and a non-finite number on its way to results.json.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import box, lamp, material, network, photometry, plane_grid, study_text

from lumijax import ConfigError, SolveError
from lumijax.config import parse_config
from lumijax.config._schema import MAX_GRID_POINTS

ROOM = study_text(
    material("wall", 0.5), photometry("iso", "isotropic", 1000), network("main"),
    box([0, 0, 0], [4, 3, 3]), lamp("L0", [2, 1.5, 2.5], "main"),
    plane_grid("floor", [0, 0, 0.01], [4, 0, 0], [0, 3, 0]))


def _error(text: str) -> ConfigError:
    with pytest.raises(ConfigError) as e:
        parse_config(text, source="study.toml")
    return e.value


@pytest.mark.parametrize("spacing", ["1e-300", "1e-320", "0.0003"])
def test_a_grid_spacing_too_fine_is_refused_without_overflow(spacing):
    # 4 m × 3 m at 0.3 mm: 13,333 × 10,000 = 1.33e8 points by hand, over the 1e8 limit
    err = _error(ROOM + f"spacing = {spacing}\n")
    assert err.key == "grids[0].spacing" and err.line == 25
    assert "1e+08" in err.message and "coarser spacing" in err.message


def test_the_limit_is_the_point_count_not_the_spacing():
    # 0.4 mm: 10,000 × 7,500 = 7.5e7 points, under the limit (config only: not built here)
    cfg = parse_config(ROOM + "spacing = 0.0004\n")
    assert cfg.grids[0].spacing == 0.0004
    assert 10_000 * 7_500 <= MAX_GRID_POINTS < 13_333 * 10_000


def test_nu_times_nv_over_the_limit_names_nv():
    err = _error(ROOM + "nu = 100000\nnv = 1001\n")
    assert err.key == "grids[0].nv" and "1e+08" in err.message


@pytest.mark.parametrize("line,key,words", [
    ("target_lux = 1e308", "grids[0].target_lux", "1e+09 lx"),
    ("target_lux = nan", "grids[0].target_lux", "finite"),
    ("target_lux = inf", "grids[0].target_lux", "finite"),
    ("min_lux = 2e9", "grids[0].min_lux", "1e+09 lx"),
    ("max_lux = 1e300", "grids[0].max_lux", "1e+09 lx"),
    ("target_weight = 1e300", "grids[0].target_weight", "largest accepted"),
])
def test_goals_whose_squares_overflow_are_refused(line, key, words):
    err = _error(ROOM + f"nu = 4\nnv = 3\n{line}\n[optimise]\n")
    assert err.key == key and words in err.message


def test_huge_flux_and_multiplier_are_refused():
    assert _error(ROOM.replace("flux_lm = 1000", "flux_lm = 1e300") + "nu = 4\nnv = 3\n"
                  ).key == "photometry.iso.flux_lm"
    assert _error(ROOM.replace('network = "main"', 'network = "main"\nmultiplier = 1e300')
                  + "nu = 4\nnv = 3\n").key == "luminaires[0].multiplier"


@pytest.mark.parametrize("optimise,key,words", [
    ("dimmer_min = 1.0", "optimise.dimmer_min", "pins every dimmer"),
    ('variables = ["aims"]\ntilt_range_deg = [0, 0]\npan_range_deg = [0, 0]',
     "optimise.variables", "every aim range"),
    ('variables = ["aims"]\ntilt_range_deg = [5, 5]\npan_range_deg = [0, 0]',
     "optimise.variables", "single angle"),
])
def test_an_optimiser_with_nothing_to_move_is_refused(optimise, key, words):
    err = _error(ROOM + f"nu = 4\nnv = 3\ntarget_lux = 100\n[optimise]\n{optimise}\n")
    assert err.key == key and words in err.message


def test_a_luminaire_own_aim_range_frees_the_fit():
    text = ROOM.replace('network = "main"', 'network = "main"\naim_range_deg = { tilt = [0, 9] }')
    cfg = parse_config(text + 'nu = 4\nnv = 3\ntarget_lux = 100\n[optimise]\nvariables = ["aims"]'
                              '\ntilt_range_deg = [0, 0]\npan_range_deg = [0, 0]\n')
    assert cfg.optimise.variables == ["aims"]


@pytest.mark.parametrize("variables", ['["dimmers", "aims"]', '["dimmers", "levels"]'])
def test_aims_and_levels_need_a_photometric_luminaire(variables):
    area = ROOM.replace('photometry = "iso"\nposition = [2, 1.5, 2.5]',
                        'kind = "area"\norigin = [1, 1, 2.9]\nu = [0.5, 0, 0]\nv = [0, -0.5, 0]'
                        '\nflux_lm = 1000')
    err = _error(area + f"nu = 4\nnv = 3\ntarget_lux = 100\n[optimise]\nvariables = {variables}\n")
    assert err.key == "optimise.variables" and "photometric" in err.message


def test_minimise_in_a_box_of_one_point_returns_it():
    import jax.numpy as jnp

    from lumijax.optimise._solvers import SOLVERS, minimise

    def residuals(x, args):
        return x - args  # ½‖x − a‖² at x = (1, 1), a = (0, 3): ½ (1 + 4) = 2.5

    for solver in SOLVERS:
        run = minimise(residuals, jnp.array([0.0, 3.0]), np.ones(2), np.ones(2), np.ones(2),
                       solver=solver)
        assert run.history == [2.5] and run.iterations == 0 and run.converged, solver
        np.testing.assert_array_equal(run.x, [1.0, 1.0])


def test_results_json_never_holds_a_non_finite_number():
    from lumijax.results import GridResult

    lux = np.array([[1.0, math.inf, 3.0]])
    g = GridResult(name="floor", points=np.zeros((3, 3)), normals=np.zeros((3, 3)),
                   networks=("main",), by_network_lux=lux, dimmers=np.ones(1))
    with pytest.raises(SolveError) as e:
        g.to_dict()
    assert "grids.floor.by_network_lux" in e.value.key
    assert "1 of 3 values are not finite" in e.value.message and "[0, 1]" in e.value.message


def test_the_api_refuses_aims_without_photometric_luminaires(write_study):
    # [optimise] overrides passed to lumijax.optimise skip the config's check: the fit itself
    # refuses (it used to end in lineax's non-finite linear solve)
    import lumijax

    text = ROOM.replace('photometry = "iso"\nposition = [2, 1.5, 2.5]',
                        'kind = "area"\norigin = [1, 1, 2.9]\nu = [0.5, 0, 0]\nv = [0, -0.5, 0]'
                        '\nflux_lm = 1000')
    study = lumijax.load_study(write_study("[solver]\nindirect = false\ncache = false\n" + text
                                           + "nu = 4\nnv = 3\ntarget_lux = 100\n[optimise]\n"))
    results = lumijax.compute(study)
    with pytest.raises(ConfigError) as e:
        lumijax.optimise(study, results, variables=["dimmers", "aims"])
    assert e.value.key == "optimise.variables" and "photometric" in e.value.message
