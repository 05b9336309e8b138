"""The luminaire schedule against real photometry files (the expected strings and numbers read
by eye from the files), and each network alone in a study whose networks light separate rooms."""

from __future__ import annotations

import helpers as h
import numpy as np
import pytest
from test_report_html import _num, _rows

from lumijax import load_study
from lumijax.report import write_report
from lumijax.report._schedule import luminaire_schedule
from lumijax.results import Results

ERCO_LDT = "lx_Testlamp_Isym2_theta180+_erco_33499000_1xqt32_230w.ldt"
ITALO = "er_ITALO_1_5P5_S05_3.140-3M.IES"


def _lum(name, photometry, network, x, **keys) -> str:
    return h.lamp(name, [x, 1, 2.5], network, photometry, **keys)


@pytest.fixture
def real_study(shared_photometry, write_study):
    text = h.study_text(
        h.table("study", name="Schedule"), h.material("wall", 0.5),
        h.photometry("erco", file=shared_photometry / ERCO_LDT),
        h.photometry("italo", file=shared_photometry / ITALO),
        h.network("wash"), h.network("street", 0.5), h.network("glow"),
        h.box([0, 0, 0], [6, 3, 3]),
        _lum("W1", "erco", "wash", 1, maintenance_factor=0.8),
        _lum("W2", "erco", "wash", 2, maintenance_factor=0.8),
        _lum("W3", "erco", "wash", 3, maintenance_factor=0.9),
        _lum("S1", "italo", "street", 4),
        _lum("S2", "italo", "street", 5, multiplier=2),
        h.area_lamp("panel", [1, 1, 2.9], [1, 0, 0], [0, 1, 0], 3000, "glow",
                    maintenance_factor=0.7))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the files' own header/data notes
        return load_study(write_study(text))


def test_schedule_reads_the_files_keywords(real_study):
    s = luminaire_schedule(real_study)
    rows = {r.name: r for r in s.rows}
    erco, italo, panel = rows["erco"], rows["italo"], rows["panel"]
    # EULUMDAT header lines 1, 10, 9, 27-28, 32 and LORL 41 % x 4350 lm (lines 23, 29)
    assert (erco.manufacturer, erco.catalogue) == ("ERCO GmbH", "33499000")
    assert erco.description == "Trion Ceiling washlight"
    assert erco.lamp == "1 × QT32 230W"
    assert erco.watts == 230.0 and erco.count == 3
    assert erco.flux_lm == pytest.approx(0.41 * 4350, rel=0.01)
    assert erco.maintenance_factors == (0.8, 0.9) and erco.networks == ("wash",)
    assert erco.total_flux_lm == pytest.approx(3 * 0.41 * 4350, rel=0.01)
    assert erco.maintained_flux_lm == pytest.approx(2.5 * 0.41 * 4350, rel=0.01)
    # IES LM-63-2002 keywords [MANUFAC], [LUMCAT], [LAMP]; input watts 76.70
    assert (italo.manufacturer, italo.catalogue) == ("AEC", "22-120-01_02")
    assert italo.lamp == "L-IT1X-5P5-3000-140-3M-70-25"
    assert italo.watts == pytest.approx(76.7) and italo.count == 2
    assert italo.total_flux_lm == pytest.approx(3 * italo.flux_lm)  # multipliers 1 and 2
    assert (panel.flux_lm, panel.maintained_flux_lm, panel.watts) == (3000.0, 2100.0, None)
    assert s.count == 6
    assert s.total_watts == pytest.approx(3 * 230 + 2 * 76.7)
    assert not s.complete_power  # the area source states no power


def test_schedule_in_the_report(real_study, tmp_path):
    nets = {n: {"dimmer": d, "flux_lm": 1.0, "luminaires": []}
            for n, d in (("wash", 1.0), ("street", 0.5), ("glow", 1.0))}
    results = Results("Schedule", {}, nets)
    page = write_report(real_study, results, tmp_path / "r.html", pictures=False).read_text()
    rows = _rows(page, "schedule")
    erco = rows["erco Trion Ceiling washlight"]
    assert erco[0] == "3" and erco[1] == "ERCO GmbH 33499000" and erco[2] == "1 × QT32 230W"
    assert erco[4] == "230" and erco[5] == "0.80, 0.90" and erco[6] == "wash"
    assert _num(rows["Total"][-1].split()[0]) == pytest.approx(843.4, abs=0.5)  # W, to 1 W


def test_each_network_alone(two_rooms, tmp_path):
    study, results = two_rooms
    page = write_report(study, results, tmp_path / "r.html", pictures=False).read_text()
    section = page.split('id="network-pages"', 1)[1].split("</section>", 1)[0]
    left, right = section.split("<h3>", 2)[1:]
    # closed rooms: each network lights its own room's floor, and only that
    assert "floor_left" in left and "Does not reach: floor_right" in left
    assert "floor_right" in right and "Does not reach: floor_left" in right
    rows = _rows(page, "network-pages")
    lux_l = results.grids["floor_left"].illuminance_lux
    avg_full, max_full, avg, mx, share = rows["floor_left"]
    assert _num(avg) == pytest.approx(lux_l.mean(), rel=5e-3)  # dimmer 1: the grid itself
    assert share == "100 %"
    avg_full, max_full, avg, mx, share = rows["floor_right"]
    lux_r = results.grids["floor_right"].illuminance_lux  # at the right's dimmer 0.5
    assert _num(avg) == pytest.approx(lux_r.mean(), rel=5e-3)
    assert _num(avg_full) == pytest.approx(2 * lux_r.mean(), rel=5e-3)
    assert _num(max_full) == pytest.approx(2 * np.max(lux_r), rel=5e-3)
    assert share == "100 %"
