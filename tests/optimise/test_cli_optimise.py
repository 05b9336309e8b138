"""``lumijax run`` with ``[optimise]``: results.json's "optimisation", optimised.toml that loads
and holds the fitted dimmers, and ``--no-optimise``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import lumijax
from lumijax.cli import main

from .conftest import facade_text


def test_run_optimises_and_writes_the_optimised_config(facade_dir, capsys):
    path = facade_dir / "cli.toml"
    path.write_text(facade_text(grid_extra="target_lux = 20"), "utf-8")
    out = facade_dir / "cli-out"
    assert main(["run", str(path), "--out", str(out), "--no-images", "--no-report"]) == 0
    printed = capsys.readouterr().out
    assert "optimisation (lbfgsb" in printed and "dimmers: n0" in printed
    data = json.loads((out / "results.json").read_text())
    opt = data["optimisation"]
    assert opt["solver"] == "lbfgsb" and opt["variables"] == ["dimmers"]
    assert len(opt["objective_history"]) == opt["iterations"] + 1
    assert opt["objective_history"][-1] < opt["objective_history"][0]
    # the grids hold the optimised design: the written lux are the by-network lux at the
    # optimised dimmers
    g = data["grids"]["wall"]
    alpha = [opt["dimmers"]["n0"], opt["dimmers"]["n1"]]
    np.testing.assert_allclose(
        g["illuminance_lux"],
        alpha[0] * np.array(g["by_network_lux"]["n0"]) + alpha[1] * np.array(
            g["by_network_lux"]["n1"]), rtol=1e-9)
    assert opt["after"]["wall"]["avg"] == pytest.approx(g["stats"]["avg"])
    # optimised.toml loads from the output folder (paths re-anchored) with those dimmers
    again = lumijax.load_study(out / "optimised.toml")
    assert again.scene.dimmers == pytest.approx(alpha, abs=1e-6)
    assert again.config.optimise is not None


def test_no_optimise_skips_the_step(facade_dir):
    path = facade_dir / "cli2.toml"
    path.write_text(facade_text(grid_extra="target_lux = 20"), "utf-8")
    out = facade_dir / "cli2-out"
    assert main(["run", str(path), "--out", str(out), "--no-images", "--no-report",
                 "--no-optimise"]) == 0
    assert "optimisation" not in json.loads((out / "results.json").read_text())
    assert not (out / "optimised.toml").exists()
