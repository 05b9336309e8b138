"""Shared test set-up: float64 JAX, the shared photometry folder, small study builders, and a
small computed study (two closed rooms, one per network) for the report and viewer tests.

Light cannot pass between the two rooms (closed boxes, shadow rays), so each network lights
exactly its own room: an independent fact the pictures must show.
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
import textwrap
import warnings
from pathlib import Path

import helpers as h
import jax
import pytest
from helpers import box_room

jax.config.update("jax_enable_x64", True)
# JAX's compilation cache (lumijax/_jit_cache.py) in a temporary folder, never the user's; the
# process that makes it (xdist's controller, whose workers inherit it) removes it at exit
if "LUMIJAX_JAX_CACHE" not in os.environ:
    os.environ["LUMIJAX_JAX_CACHE"] = tempfile.mkdtemp(prefix="lumijax-test-jax-cache-")
    atexit.register(shutil.rmtree, os.environ["LUMIJAX_JAX_CACHE"], ignore_errors=True)
# both xdist workers share one persistent compilation cache, so a program one compiled the other
# loads (the command line's cache, lumijax/_jit_cache.py, in the suite's temporary folder)
from lumijax._jit_cache import enable_compilation_cache  # noqa: E402

enable_compilation_cache()


def pytest_xdist_auto_num_workers(config) -> int:
    """``-n auto``: one worker more than the CPUs (``--maxprocesses`` still caps it). Workers
    wait on subprocesses (the demo, the sharded solve, the Dask cluster) and on the disk; a
    third worker on two cores kept them busy, 197 % of CPU, and took the suite from 10:24 to
    9:43 (benchmarks/RESULTS.md, session 18)."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (cpus or 1) + 1


REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
PHOTOMETRY = SHARED / "photometry"


@pytest.fixture
def shared_photometry() -> Path:
    """The real IES/EULUMDAT files beside the repo; skip where a user's clone has none."""
    if not PHOTOMETRY.is_dir():
        pytest.skip("../shared/photometry is not present (only in the project's workspace)")
    return PHOTOMETRY


@pytest.fixture
def write_study(tmp_path):
    """Write a TOML study (dedented) into tmp_path and return its path."""

    def write(text: str, name: str = "study.toml") -> Path:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text), encoding="utf-8")
        return path

    return write


TWO_ROOMS = h.study_text(
    h.table("study", name="Two rooms",
            description="Two closed rooms side by side, each on its own dimmer."),
    h.table("solver", target_patches=400, gather_rays=64, spectral_samples=4, cache=False),
    h.material("wall", srgb=[0.7, 0.6, 0.5]), h.photometry("iso", "isotropic", 1000),
    h.network("left", 1.0), h.network("right", 0.5),
    h.box([0, 0, 0], [3, 3, 2.5]), h.box([5, 0, 0], [8, 3, 2.5]),
    h.lamp("L1", [1.5, 1.5, 2.0], "left", spectrum="A"),
    h.lamp("R1", [6.5, 1.5, 2.0], "right", spectrum="D65"),
    h.plane_grid("floor_left", [0, 0, 0.01], [3, 0, 0], [0, 3, 0], nu=6, nv=6, target_lux=50),
    h.plane_grid("floor_right", [5, 0, 0.01], [3, 0, 0], [0, 3, 0], nu=6, nv=6, target_lux=500))


@pytest.fixture(scope="session")
def two_rooms(tmp_path_factory):
    """``(study, results)`` of the two-room study, computed once per session."""
    from lumijax import compute, load_study

    path = tmp_path_factory.mktemp("two_rooms") / "study.toml"
    path.write_text(textwrap.dedent(TWO_ROOMS), encoding="utf-8")
    study = load_study(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = compute(study)
    return study, results


BOX_ROOM = box_room(
    "indirect = false  # tests/cli checks network b against a direct-only closed form",
    name="cli room", grid="nu = 8\nnv = 6\ntarget_lux = 100")


@pytest.fixture
def box_room() -> str:
    """A 4 × 3 × 3 m closed grey room (ρ 0.5), two isotropic 2000 lm lamps on networks a
    (dimmer 0.5) and b, a floor grid; direct light only, so network b has a closed form."""
    return BOX_ROOM
