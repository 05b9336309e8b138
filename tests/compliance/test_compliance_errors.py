"""Bad [compliance] input: one ConfigError naming the key and what was expected."""

from __future__ import annotations

import pytest
from conftest import OFFICE

from lumijax.config import parse_config
from lumijax.errors import ConfigError


@pytest.mark.parametrize(("old", "new", "key", "words"), [
    ('zone = "E2"', 'zone = "E7"', "compliance.obtrusive.zone", "unknown environmental zone"),
    ('curfew = "22:00"\n', "", "compliance.obtrusive", "need 'curfew'"),
    ('curfew = "22:00"', 'curfew = "25:00"', "compliance.obtrusive.curfew", "HH:MM"),
    ("hours_day = 2250", "hours_day = -5", "compliance.energy.hours_day", "greater than"),
    ("hours_night = 250", "hours_night = 7000", "compliance.energy", "8760"),
    ("power = [0.1, 0.45, 1]", "power = [0.1, 0.6, 0.5]", "compliance.energy.dimming.b",
     "monotonic"),
    ("levels = [0, 0.5, 1]", "levels = [0, 0.5, 0.5]", "compliance.energy.dimming.b",
     "must increase"),
    ('grid = "desk"\ncylindrical', 'grid = "nowhere"\ncylindrical', "compliance.areas[0].grid",
     "unknown grid 'nowhere'"),
    ("[compliance.maintenance.networks.b]", "[compliance.maintenance.networks.zz]",
     "compliance.maintenance.networks.zz", "unknown network 'zz'"),
    ("watts = { down = 25 }", "watts = { up = 25 }", "compliance.energy.watts.up",
     "unknown photometry 'up'"),
    ('cylindrical = "desk_ez"', 'cylindrical = "desk"', "compliance.areas[0].cylindrical",
     "expected sensor"),
    ('facades = ["wall_s"]', 'facades = ["desk"]', "compliance.obtrusive.facades[0]",
     "expected surface"),
    ("llmf = 0.9", "llmf = 0.9\nmf = 0.8", "compliance.maintenance", "not both"),
    ('environment = "clean"', 'environment = "sooty"', "compliance.maintenance.environment",
     "clean"),
])
def test_bad_compliance_input(old, new, key, words):
    assert OFFICE.count(old) == 1
    with pytest.raises(ConfigError) as e:
        parse_config(OFFICE.replace(old, new), source="office.toml")
    assert e.value.key == key, e.value
    assert words in e.value.message, e.value.message
    assert e.value.line is not None or key.count(".") <= 1


def test_cli_prints_the_verdict(office, tmp_path, capsys, monkeypatch):
    """``lumijax run`` prints the verdict of what it computed, says "not compliant", exits 0
    and writes the verdict to results.json (compute replaced by the session's office: the
    printing is under test here, the computing in test_verdict)."""
    import json

    import lumijax._study
    from lumijax.cli import main

    monkeypatch.setattr(lumijax._study, "compute", lambda study, **kw: office[1])
    cfg = tmp_path / "office.toml"
    cfg.write_text(OFFICE)
    assert main(["run", str(cfg), "--out", str(tmp_path / "out"), "--no-report",
                 "--no-images"]) == 0
    text = capsys.readouterr().out
    assert "EN 12464-1" in text and "CIE 150" in text
    assert "not compliant: " in text and "office.Em" in text
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert doc["compliance"]["compliant"] is False
    assert len(doc["compliance"]["criteria"]) == len(office[1].compliance.rows)
