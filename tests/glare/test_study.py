"""A lit room with an observer, computed once: the background from the radiosity against the
integrating-sphere estimate and the grids' own gather, a luminaire hidden by a column, the
superposition of Results.at, results.json and the command line's table."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _glare import I0, RHO

import lumijax


@pytest.fixture
def results(glare_room):
    """The lit room of tests/glare/_glare.py, computed once a session (conftest.py)."""
    return glare_room


def test_background_is_the_inter_reflected_light_at_the_eye(results):
    g = results.glare
    lb = g.ratings.background_cdm2[0]
    # the grids' gather at the eye, on the plane across the line of sight (other rays)
    grid = results.grids["eye"]
    indirect = float(grid.illuminance_lux[0] - grid.at_dimmers_direct(grid.dimmers)[0])
    assert lb * math.pi == pytest.approx(indirect, rel=0.05)
    # integrating sphere: E_ind = ρ Φ / (A (1 − ρ)), the room's mean inter-reflected light
    area = 2 * (6 * 4 + 6 * 3 + 4 * 3) + 4 * (0.5 * 2) + 0.5 * 1  # room + column
    phi = 2 * 4 * math.pi * I0
    assert lb == pytest.approx(RHO * phi / (area * (1 - RHO)) / math.pi, rel=0.25)
    # a closed room: the eye sees surfaces everywhere, so L_av = L_b
    assert g.ratings.environment_cdm2[0] == pytest.approx(lb, rel=1e-6)


def test_a_luminaire_behind_the_column_does_not_glare(results):
    ugr_terms, veil = results.glare._contributions
    names = results.glare.model.names
    assert ugr_terms[0, names.index("A")] > 0 and veil[0, names.index("A")] > 0
    assert ugr_terms[0, names.index("B")] == 0 and veil[0, names.index("B")] == 0
    top = results.glare.to_dict()["desk"]["top_luminaires"]["ugr"]
    assert [t["name"] for t in top] == ["A"] and top[0]["share"] == pytest.approx(1.0)


def test_results_at_new_dimmers_superposes(results):
    """Dimming every network by α scales L by α and L_b by α: UGR changes by 8 log10 α."""
    before = results.glare.ratings.ugr[0]
    after = results.at(results.design.replace(dimmers=[0.25, 0.25])).glare.ratings.ugr[0]
    assert after - before == pytest.approx(8 * math.log10(0.25), abs=0.02)


def test_results_json_and_the_run_table(results):
    from rich.console import Console

    from lumijax.cli import _glare_table

    data = json.loads(json.dumps(results.to_dict()))  # JSON-clean (no NaN)
    desk = data["glare"]["desk"]
    assert len(desk["directions"]) == 2
    looking_away = desk["directions"][1]
    assert looking_away["azimuth_deg"] == 180 and "no_source_seen" in looking_away["flags"]
    assert desk["worst"]["ugr"]["direction"] == 0
    assert desk["eye"] == [0.5, 2.0, 1.2]
    console = Console(record=True, width=120)
    _glare_table(results.glare, console)
    text = console.export_text()
    assert "desk" in text and f"{desk['worst']['ugr']['value']:.1f}" in text


def test_unshadowed_compute_has_no_background_and_writes_null(results):
    study = lumijax.load_study(results.lighting.scene.source)
    dry = lumijax.compute(study, shadows=False)
    desk = dry.glare.to_dict()["desk"]["directions"][0]
    assert desk["ugr"] is None and "no_background" in desk["flags"]
    names = dry.glare.model.names
    assert np.asarray(dry.glare._contributions[0])[0, names.index("B")] > 0  # nothing hides


def test_report_section_has_the_table_and_a_fisheye(results):
    from lumijax.report._glare import glare_sections

    (section,) = glare_sections(None, results, pictures=True)
    worst = results.glare.to_dict()["desk"]["worst"]["ugr"]["value"]
    assert section.id == "glare" and "<td>desk</td>" in section.html
    assert f"<td>{worst:.1f}</td>" in section.html
    assert section.html.count('<img src="data:image/png;base64,') == 2  # one per observer
    seen = results.glare.seen_sources(0)
    assert [s["name"] for s in seen] == ["A"]
    # a Lambertian-free square of 1000 cd: L = I / (A cos γ) toward the eye
    d = np.subtract([3, 2, 2.8], [0.5, 2, 1.2])
    cos_g = 1.6 / np.linalg.norm(d)
    assert seen[0]["luminance_cdm2"] == pytest.approx(I0 / (0.04 * cos_g), rel=1e-3)


def test_threshold_increment_from_a_road_grid(results):
    """TI with L_av = ρ Ē / π of the floor grid (ρ of the floor's own material, found under
    the grid by a ray): this bright floor is above 5 cd/m², where CIE 140 gives
    TI = 95 L_v / L_av^1.05 instead of 65 L_v / L_av^0.8."""
    g = results.glare
    v = int(g.views_of(1)[0])
    lav = RHO * float(results.grids["floor"].illuminance_lux.mean()) / math.pi
    assert g.ratings.road_cdm2[v] == pytest.approx(lav, rel=1e-6)
    assert lav > 5.0
    want = 95 * g.ratings.veiling_cdm2[v] / lav ** 1.05
    assert g.ratings.ti[v] == pytest.approx(want, rel=1e-6) and want > 0
    assert g.to_dict()["driver"]["worst"]["ti"]["value"] == pytest.approx(want, rel=1e-6)
