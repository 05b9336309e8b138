"""The radiosity solve with the operator's rows split over two devices (JAX sharding) equals
the unsharded solve and numpy's dense LU of the same system. Run in a fresh process: the device
count is fixed when JAX starts (``XLA_FLAGS``), and this process must keep its own."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).with_name("sharded_solve.py")


def test_the_solve_sharded_over_two_devices_equals_the_unsharded_one():
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2",
               JAX_PLATFORMS="cpu")
    run = subprocess.run([sys.executable, str(SCRIPT)], env=env, capture_output=True, text=True,
                         timeout=600, check=False)
    assert run.returncode == 0, run.stderr[-3000:]
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out["devices"] == 2
    # both solves are the same system, the independent LU too
    assert out["dense_lu_diff"] <= 1e-8 * out["scale"]
    assert out["max_abs_diff"] <= 1e-10 * out["scale"]
    # each device holds half of every block's rows (and of the index vectors that follow
    # them): the operator's memory is split, not copied
    per = out["per_device"]
    assert sorted(per) == ["0", "1"]
    assert abs(per["0"] - per["1"]) <= 0.02 * per["0"]
    assert 0.45 * out["bucket_value_bytes"] <= per["0"] <= 0.6 * out["bucket_value_bytes"]
    assert len(out["shardings"]) == 1 and "None, 'rows'" in out["shardings"][0]
