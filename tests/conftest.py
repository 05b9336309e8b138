"""Shared test set-up: float64 JAX, the shared photometry folder, small study builders."""

from __future__ import annotations

import textwrap
from pathlib import Path

import jax
import pytest

jax.config.update("jax_enable_x64", True)

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
