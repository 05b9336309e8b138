"""A small facade for optimiser tests: a 6 × 4 m wall and the ground, four 30° spots on two
networks aimed up at the wall (tilt ≈ 124°: their beams land on it, so each aim is seen in the
grid's light), a 12 × 18 grid on the wall. Point-source spots and the luminous solve
(``spectral_samples = 0``), so the optimiser's light model is exact for this scene."""

from __future__ import annotations

import pytest
from helpers import lamp, material, network, photometry, plane_grid, rectangle, table

from lumijax.photometry import spot, write_ies

START_AIMS = [(124, -90), (128, -95), (120, -88), (126, -92)]


def facade_text(aims=START_AIMS, dimmers=(0.6, 0.9), grid_extra="target_lux = 30",
                optimise='variables = ["dimmers"]', extra="") -> str:
    lums = "".join(lamp(f"s{i}", [1.0 + 1.3 * i, 2.5, 0.3], f"n{i % 2}", "spot",
                        aim={"tilt": t, "pan": p}) for i, (t, p) in enumerate(aims))
    head = (table("solver", precision="float64", target_patches=200, gather_rays=64,
                  spectral_samples=0, cache=False)
            + material("wall", 0.5) + photometry("spot", file="spot.ies")
            + network("n0", dimmers[0], power_w=30) + network("n1", dimmers[1], power_w=50)
            + rectangle([0, 0, 0], [0, 0, 4], [6, 0, 0]) + rectangle([-1, 0, 0], [8, 0, 0], [0, 5, 0]))
    grid = plane_grid("wall", [0, 0.01, 0.05], [0, 0, 3.9], [6, 0, 0], nu=12, nv=18) + grid_extra + "\n"
    opt = "" if optimise is None else "[optimise]\n" + optimise + "\n"
    return head + lums + grid + extra + opt


@pytest.fixture(scope="session")
def facade_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("facade")
    write_ies(spot(3000, beam_deg=30), d / "spot.ies")
    return d


@pytest.fixture(scope="session")
def facade_results(facade_dir):
    """The facade at its start aims and dimmers, computed once for the session."""
    import lumijax

    path = facade_dir / "start.toml"
    path.write_text(facade_text(optimise=None), encoding="utf-8")
    study = lumijax.load_study(path)
    return study, lumijax.compute(study)
