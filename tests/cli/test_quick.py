"""The iterate loop: ``lumijax run --quick`` / ``--no-images``, the compilation cache the command
line turns on, and an ``import lumijax`` that loads no drawing library."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import box_room

from lumijax import _jit_cache
from lumijax.cli import main

ROOM = box_room("target_patches = 150\ngather_rays = 32", grid="nu = 4\nnv = 3")

DRAWING = ("pyvista", "vtk", "matplotlib", "trame", "colour")


def test_import_lumijax_loads_no_drawing_library():
    code = ("import sys, lumijax, lumijax.cli; "
            f"print([m for m in {DRAWING!r} if m in sys.modules])")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, env=dict(os.environ, JAX_PLATFORMS="cpu"))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_the_lazy_package_keeps_its_public_names():
    # lumijax's names load on first use; `optimise` must stay the function even once its
    # subpackage is imported (the import system rebinds a package attribute of that name)
    code = ("import sys, lumijax.cli; jax_at_import = 'jax' in sys.modules; "
            "import lumijax.optimise._optimise, lumijax; from lumijax.optimise import optimise; "
            "print(jax_at_import, lumijax.optimise is optimise, callable(lumijax.compute), "
            "lumijax.write_results.__module__, 'optimise' in dir(lumijax))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, env=dict(os.environ, JAX_PLATFORMS="cpu"))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["False", "True", "True", "lumijax.report._write", "True"]


def test_a_lazy_name_that_is_not_there_names_its_package():
    # lumijax and lumijax.report share one PEP 562 loader (lumijax/_lazy.py)
    import lumijax.report

    for package in (lumijax, lumijax.report):
        with pytest.raises(AttributeError, match=f"module '{package.__name__}' has no "
                                                 "attribute 'no_such_name'"):
            package.no_such_name  # noqa: B018
    assert {"write_report", "ResultSet"} <= set(dir(lumijax.report))
    assert {"compute", "optimise", "Results"} <= set(dir(lumijax))
    assert "lazy_names" not in dir(lumijax) and "lazy_names" not in dir(lumijax.report)


def test_quick_writes_the_numbers_only_with_the_photometric_solve(write_study, tmp_path):
    cfg = write_study(ROOM)
    quick, full = tmp_path / "quick", tmp_path / "full"
    assert main(["run", str(cfg), "--out", str(quick), "--quick"]) == 0
    assert main(["run", str(cfg), "--out", str(full), "--no-images", "--no-report"]) == 0
    names = {p.relative_to(quick).as_posix() for p in quick.rglob("*") if p.is_file()}
    assert "results.json" in names and "grids/floor.csv" in names
    assert not any(n.startswith("images/") or n == "report.html" for n in names)
    q = json.loads((quick / "results.json").read_text())
    f = json.loads((full / "results.json").read_text())
    # the photometric solve: one "wavelength" and none named
    assert q["solver"]["spectral_samples"] == 1 and "wavelengths_nm" not in q["solver"]
    assert f["solver"]["spectral_samples"] == 16
    assert "xyz" not in q["grids"]["floor"] and "xyz" in f["grids"]["floor"]
    # a grey room: its lux does not depend on the wavelengths it was solved at
    eq = np.asarray(q["grids"]["floor"]["illuminance_lux"])
    ef = np.asarray(f["grids"]["floor"]["illuminance_lux"])
    np.testing.assert_allclose(eq, ef, rtol=1e-4)
    # the command line turned JAX's compilation cache on, in the tests' folder
    assert _jit_cache._enabled == Path(os.environ["LUMIJAX_JAX_CACHE"]) / _jit_cache._versions()
