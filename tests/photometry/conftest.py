"""Shared fixtures of the photometry tests."""

from __future__ import annotations

from pathlib import Path

import jax
import pytest

# The real photometric files live beside the repository, not in it (see PROVENANCE.md there).
SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "photometry"


@pytest.fixture(scope="session")
def shared() -> Path:
    if not SHARED.is_dir():
        pytest.skip(f"the shared photometry folder {SHARED} is not available")
    return SHARED


@pytest.fixture
def x64():
    """Run one test in float64 and restore the global setting afterwards."""
    prev = jax.config.read("jax_enable_x64")
    jax.config.update("jax_enable_x64", True)
    try:
        yield
    finally:
        jax.config.update("jax_enable_x64", prev)
