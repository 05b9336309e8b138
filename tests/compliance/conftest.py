"""One small office for the compliance tests, computed once per session: a closed 6 × 4 × 3 m
room (ρ 0.5), two networks of Lambertian downlights with a lamp spectrum and watts, a desk
area by the EN 12464-1 rule, its surrounding band, cylindrical sensors above it, and a
``[compliance]`` table of every kind."""

from __future__ import annotations

import pytest
from helpers import lamp, material, network, photometry, study_text, table

OFFICE = study_text(
    table("study", name="office"),
    table("solver", target_patches=200, method="jacobi", spectral_samples=0, cache=False,
          gather_rays=256),
    material("wall", 0.5),
    photometry("down", "lambertian", 3000),
    network("a", 1.0), network("b", 0.6),
    table("[[geometry]]", name="room", kind="box", min=[0, 0, 0], max=[6, 4, 3],
          normals="inward", material="wall"),
    lamp("A1", [2, 2, 2.95], "a", "down", spectrum="FL2"),
    lamp("B1", [4, 2, 2.95], "b", "down", spectrum="FL2"),
    table("[[grids]]", name="desk", kind="area", origin=[1.5, 1.0, 0.8], u=[3, 0, 0],
          v=[0, 2, 0]),
    table("[[grids]]", name="surround", kind="area", origin=[1.0, 0.5, 0.8], u=[4, 0, 0],
          v=[0, 3, 0], exclude="desk"),
    table("[[grids]]", name="desk_ez", kind="sensor", sensor="cylindrical", at_grid="desk",
          offset_m=[0, 0, 0.4]),
    table("[[grids]]", name="wall_s", kind="surface", geometry="room", spacing=1.5),
) + """[compliance.maintenance]
luminaire_type = "D"
environment = "clean"
cleaning_interval_years = 1
llmf = 0.9
[compliance.maintenance.networks.b]
mf = 0.7
[compliance.energy]
watts = { down = 25 }
hours_day = 2250
hours_night = 250
occupancy_factor = 0.9
leni_max = 10
[compliance.energy.dimming.b]
curve = "table"
levels = [0, 0.5, 1]
power = [0.1, 0.45, 1]
standby_w = 0.5
[[compliance.areas]]
name = "office"
standard = "EN 12464-1"
reference = "34.2"
grid = "desk"
cylindrical = "desk_ez"
modelling = [0.3, 0.6]
surrounding = "surround"
observers = ["seat"]
[[observers]]
name = "seat"
position = [3.0, 0.6, 1.2]
look_at = [3.0, 4.0, 1.2]
[compliance.obtrusive]
zone = "E2"
curfew = "22:00"
after_curfew = { a = 0.2 }
windows = ["desk"]
facades = ["wall_s"]
sensitive = [{ name = "corner", point = [0.1, 0.1, 0.1] }]
"""


@pytest.fixture(scope="session")
def office(tmp_path_factory):
    """``(study, results)`` of the office (computed once)."""
    from lumijax import compute, load_study

    path = tmp_path_factory.mktemp("office") / "office.toml"
    path.write_text(OFFICE)
    study = load_study(path)
    return study, compute(study)
