"""The drawing libraries' background import (``report._prewarm``): it loads what the first
picture needs, in its own thread, and is off when asked. Each case runs in a fresh interpreter (the test process has them loaded)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("pyvista")

_CHECK = """
import sys, threading
from lumijax.report import _prewarm
t = _prewarm.start()
if t is None:
    print("off", "pyvista.plotting" in sys.modules)
else:
    assert t.daemon and t is not threading.main_thread()
    t.join(120)
    missing = [m for m in _prewarm.MODULES if m not in sys.modules]
    print("on", missing)
"""


def _run(env_value):
    env = dict(os.environ)
    env.pop("LUMIJAX_PREWARM", None)
    if env_value is not None:
        env["LUMIJAX_PREWARM"] = env_value
    out = subprocess.run([sys.executable, "-c", _CHECK], env=env, capture_output=True,
                         text=True, timeout=180, check=True)
    return out.stdout.split("\n")[-2]


def test_prewarm_imports_the_drawing_libraries_in_a_thread():
    assert _run(None) == "on []"


def test_prewarm_is_off_when_asked():
    assert _run("off") == "off False"


def test_prefetched_curves_are_the_reports_and_are_kept():
    """``_polar.prefetch`` in another thread figures the curves the report then finds kept: the
    same object, equal to a direct lookup of the distribution, keyed by JAX's x64 mode (a
    float32 lookup is not served to a float64 caller)."""
    import threading

    import jax

    from lumijax.photometry import spot
    from lumijax.report import _polar

    p = spot(1000.0, 24.0)
    t = threading.Thread(target=_polar.prefetch, args=({"spot": p},))
    t.start()
    t.join()
    x64 = bool(jax.config.read("jax_enable_x64"))
    kept = _polar._CURVES[(id(p.distribution), x64)][1]
    assert _polar._main_curves(p.distribution) is kept
    gamma = np.radians(_polar._GAMMA)
    for c in _polar._MAIN_PLANES:
        d = np.stack([np.sin(gamma) * np.cos(np.radians(c)),
                      np.sin(gamma) * np.sin(np.radians(c)), -np.cos(gamma)], axis=-1)
        np.testing.assert_array_equal(kept[c], _polar.intensity_np(p.distribution, d))
    with jax.enable_x64(not x64):
        other = _polar._main_curves(p.distribution)
    assert other is not kept
    assert _polar.beam_angle_deg(p.distribution, 0) == pytest.approx(24.0, abs=0.6)
