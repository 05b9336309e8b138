"""The glare tests' one computed room (tests/glare/_glare.py), computed once a session (once a
worker under xdist) for every module that asks for it: the radiosity is most of the area's time."""

from __future__ import annotations

import math

import pytest
from _glare import I0, rect, room_text, write_with_opening

import lumijax
from lumijax.photometry import isotropic


@pytest.fixture(scope="session")
def glare_room(tmp_path_factory):
    """Results of the lit room of _glare.room_text, with its cache in a temporary folder."""
    d = tmp_path_factory.mktemp("glare_room")
    write_with_opening(d / "sq.ies", isotropic(4 * math.pi * I0), rect(0.2))
    (d / "study.toml").write_text(room_text("sq.ies"))
    return lumijax.compute(lumijax.load_study(d / "study.toml"), cache_dir=d / "cache")
