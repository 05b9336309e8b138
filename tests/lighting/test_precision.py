"""Precision is a setting carried by the arrays: computing or fitting a float64 study leaves
JAX's process-wide x64 switch as the caller set it (docs/conventions.md, "Precision")."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from helpers import box_room

STUDY = box_room('precision = "float64"\ntarget_patches = 60\ncache = false', name="precision room",
                 grid="nu = 4\nnv = 3\ntarget_lux = 100", extra="[optimise]\nmax_steps = 20\n")

# A fresh interpreter with x64 off (the test process has it on: tests/conftest.py). It computes
# and fits in the scope, then does what compute and optimise did before (switch x64 on for the
# process) and computes and fits again: the two must agree to the last bit.
CHILD = textwrap.dedent("""
    import json, sys
    import jax
    import lumijax
    study = lumijax.load_study(sys.argv[1])
    res = lumijax.compute(study)
    flags = [jax.config.read("jax_enable_x64")]
    fit = lumijax.optimise(study, res)
    flags.append(jax.config.read("jax_enable_x64"))
    dtype = str(res.lighting.transport.area.dtype)
    jax.config.update("jax_enable_x64", True)
    res_global = lumijax.compute(study)
    fit_global = lumijax.optimise(study, res_global)
    print(json.dumps({
        "flags": flags, "dtype": dtype,
        "lux": [res["floor"].illuminance_lux.tolist(),
                res_global["floor"].illuminance_lux.tolist()],
        "fitted": [fit.design.dimmer_of(), fit_global.design.dimmer_of()],
    }))
""")


@pytest.mark.slow  # a fresh interpreter computes and fits twice: ~20 s of CPU
def test_float64_study_leaves_x64_alone_and_matches_the_global_switch(write_study):
    path = write_study(STUDY)
    env = dict(os.environ, JAX_ENABLE_X64="0", JAX_PLATFORMS="cpu")
    out = subprocess.run([sys.executable, "-c", CHILD, str(path)], capture_output=True,
                         text=True, env=env, timeout=300, check=False)
    assert out.returncode == 0, out.stderr[-3000:]
    child = json.loads(out.stdout.strip().splitlines()[-1])
    assert child["flags"] == [False, False]  # neither compute nor optimise switched x64 on
    assert child["dtype"] == "float64"  # the operator was still built in float64
    scoped, switched = child["lux"]
    assert np.all(np.asarray(scoped) > 0)
    assert scoped == switched  # bit for bit
    assert child["fitted"][0] == child["fitted"][1]
