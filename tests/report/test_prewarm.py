"""The drawing libraries' background import (``report._prewarm``): it loads what the first
picture needs, in its own thread, and is off when asked. Each case runs in a fresh interpreter (the test process has them loaded)."""

from __future__ import annotations

import os
import subprocess
import sys

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
