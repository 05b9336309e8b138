"""``benchmarks/compliance.py --quick`` runs end to end: one room of the generated office
building, its whole compliance table timed against its solve."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "compliance.py"


@pytest.mark.slow  # one whole compute of a 1-room building with glare: ~30 s of CPU alone
def test_quick_benchmark(capsys):
    spec = importlib.util.spec_from_file_location("compliance_benchmark", BENCH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    (row,) = mod.main(["--quick"])
    # one room, two desks: 9 rows per desk (Em, U0, UGR_L, Ra, Ez, modelling ×2, the
    # surrounding's Em and U0); energy: LENI, W/m² and one W/m² per desk; CIE 150: Ev and I
    # before and after curfew, ULR, ULR incl. reflected, Lb
    assert row["criteria"] == 2 * 9 + 2 + 2 + 7
    assert row["luminaires"] == 6 and row["networks"] == 2
    assert row["patches"] > 0 and row["points"] > 0
    for k in ("solve_s", "sensor_grids_s", "model_s", "judge_s", "at_new_dimmers_s"):
        assert math.isfinite(row[k]) and row[k] > 0, k
    out = capsys.readouterr().out
    assert "| office building, 1 room (quick) |" in out and "at / solve" in out
