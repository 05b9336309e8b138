"""``lumijax run --timings``: the table accounts for the run's wall time, stage by stage, and
agrees with results.json's ``timing_s`` (docs/results.md)."""

from __future__ import annotations

import json
import os
import re
import time
from pathlib import Path

import helpers as h

from lumijax.cli import main


def _age() -> float:
    """This process's age (s) from /proc, read independently of the CLI's own reading."""
    start_ticks = int(Path("/proc/self/stat").read_text().split(")")[-1].split()[19])
    return float(Path("/proc/uptime").read_text().split()[0]) - start_ticks / os.sysconf(
        "SC_CLK_TCK")


def _rows(printed: str) -> dict[str, float]:
    rows = {}
    for line in printed.splitlines():
        cells = [c.strip() for c in line.split("│")]
        if len(cells) == 5 and re.fullmatch(r"-?\d+\.\d\d", cells[2]):
            rows[cells[1]] = float(cells[2])
    return rows


def test_timings_account_for_the_run_and_match_results_json(write_study, tmp_path, capsys):
    cfg = write_study(h.box_room("target_patches = 150\ngather_rays = 16\ncache = false",
                                 name="timed room"))
    out = tmp_path / "out"
    before = _age()
    t0 = time.perf_counter()
    assert main(["run", str(cfg), "--out", str(out), "--no-images", "--no-report",
                 "--timings"]) == 0
    wall = time.perf_counter() - t0
    after = _age()
    rows = _rows(capsys.readouterr().out)
    timing = json.loads((out / "results.json").read_text())["timing_s"]
    # every stage of the pipeline ran (inter-reflection on), each row the sum of its keys
    for label, keys in [("config", ["config"]), ("scene", ["scene"]), ("meshing", ["mesh"]),
                        ("direct light", ["direct_points", "direct_patches"]),
                        ("operator", ["memory_bound", "partition", "operator"]),
                        ("solve", ["solve"]),
                        ("gather", ["gather_rays", "gather"])]:
        assert abs(rows[label] - sum(timing[k] for k in keys)) <= 0.005 + 1e-9, label
    # results.json: the stages are disjoint parts of the pipeline, the pipeline part of compute
    stages = ("emission", "direct_points", "mesh", "memory_bound", "partition", "operator",
              "direct_patches", "spectral_sampling", "gather_rays", "solve_and_gather")
    assert sum(timing[k] for k in stages) <= timing["lighting"] <= timing["total"]
    assert timing["solve"] + timing["gather"] <= timing["solve_and_gather"]
    assert abs(timing["load"] - timing["config"] - timing["scene"]) < 1e-3
    # the table: no negative share, rows adding up to the total, which this test's own clocks
    # bound (the start-up row is the process's age when the run began: /proc's 10 ms ticks)
    total = rows.pop("total")
    assert min(rows.values()) >= 0.0
    assert abs(sum(rows.values()) - total) <= 0.005 * (len(rows) + 1)
    assert before - 0.03 <= rows["start-up + import"] <= before + wall + 0.03
    assert total <= after + 0.03 and total - rows["start-up + import"] <= wall + 0.01
