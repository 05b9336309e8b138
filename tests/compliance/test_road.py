"""EN 13201-2 road classes (illuminance method) on an EN 13201-3 field: the grid rule against
the standard's own numbers, the verdict against point-source illuminance summed here, and bad
input naming its key."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.config import parse_config
from lumijax.errors import ConfigError
from lumijax.scene._standard_grids import road_counts

S, W, H, PHI = 30.0, 6.0, 8.0, 6000.0  # luminaire spacing, road width, mounting height (m), lm


def road(cls: str = "P3", extra: str = "") -> str:
    return f"""[study]
name = "road"
[solver]
indirect = false
[photometry.iso]
kind = "isotropic"
flux_lm = {PHI}
[networks.street]
[[luminaires]]
name = "pole0"
photometry = "iso"
network = "street"
position = [0, 0, {H}]
[[luminaires]]
name = "pole1"
photometry = "iso"
network = "street"
position = [{S}, 0, {H}]
[[grids]]
name = "carriageway"
kind = "area"
rule = "EN 13201-3"
origin = [0, 0, 0]
u = [{S}, 0, 0]
v = [0, {W}, 0]
[[compliance.areas]]
name = "street"
standard = "EN 13201-2"
road_class = "{cls}"
grid = "carriageway"
{extra}"""


@pytest.mark.parametrize(("s", "w", "expect"), [
    (30.0, 7.0, (10, 5)),   # S ≤ 30 m: N = 10; 7/1.5 = 4.7 → 5 rows
    (25.0, 3.0, (10, 3)),   # at least 3 rows across
    (40.0, 4.6, (14, 4)),   # S > 30 m: D ≤ 3 m → ⌈40/3⌉ = 14
    (36.0, 4.5, (12, 3)),   # D = 3 m exactly, d = 1.5 m exactly
])
def test_en13201_3_point_counts(s, w, expect):
    assert road_counts(s, w) == expect


@pytest.fixture(scope="module")
def street(tmp_path_factory):
    from lumijax import compute, load_study

    path = tmp_path_factory.mktemp("road") / "road.toml"
    path.write_text(road())
    study = load_study(path)
    return study, compute(study)


def _hand_lux():
    """The field's points (D/2, d/2 from the edges) and their illuminance from two isotropic
    lamps, E = Σ I h / r³ with I = Φ / 4π."""
    n, m = 10, 4
    x = (np.arange(n) + 0.5) * S / n
    y = (np.arange(m) + 0.5) * W / m
    xx, yy = np.meshgrid(x, y, indexing="ij")
    e = np.zeros_like(xx)
    for px in (0.0, S):
        r2 = (xx - px) ** 2 + yy ** 2 + H * H
        e += PHI / (4 * np.pi) * H / r2 ** 1.5
    return np.stack([xx.ravel(), yy.ravel()], axis=1), e.ravel()


def test_the_field_grid_and_p3_verdict_by_hand(street):
    study, res = street
    pts, e = _hand_lux()
    grid = res.grids["carriageway"]
    order = np.lexsort((grid.points[:, 1], grid.points[:, 0]))
    np.testing.assert_allclose(grid.points[order, :2], pts, atol=1e-9)
    rows = {r["quantity"]: r for r in res.compliance.rows}
    assert set(rows) == {"Em", "Emin", "Em (uniformity cap)"}
    # EN 13201-2:2015 Table 4, P3: Ē ≥ 7.5 lx, Emin ≥ 1.5 lx; Ē ≤ 1.5 × 7.5 lx
    assert rows["Em"]["value"] == pytest.approx(e.mean(), rel=2e-3)
    assert rows["Emin"]["value"] == pytest.approx(e.min(), rel=2e-3)
    for q, limit, ok in (("Em", 7.5, e.mean() >= 7.5), ("Emin", 1.5, e.min() >= 1.5),
                         ("Em (uniformity cap)", 11.25, e.mean() <= 11.25)):
        assert rows[q]["limit"] == pytest.approx(limit)
        assert rows[q]["passed"] is bool(ok), (q, rows[q])


def test_c_class_judges_u0_and_the_class_can_change(street, tmp_path):
    import dataclasses

    from lumijax.compliance import Compliance, compliance_model

    study, res = street
    _, e = _hand_lux()
    comp = study.config.compliance
    area = comp.areas[0].model_copy(update={"road_class": "C5"})
    cfg = study.config.model_copy(update={"compliance": comp.model_copy(update={"areas": [area]})})
    rows = {r["quantity"]: r for r in Compliance.judge(
        compliance_model(dataclasses.replace(study, config=cfg), res), res.design.dimmers).rows}
    assert set(rows) == {"Em", "U0"}
    # Table 3, C5: Ē ≥ 7.5 lx, U0 ≥ 0.40
    assert rows["Em"]["limit"] == pytest.approx(7.5)
    assert rows["U0"]["limit"] == pytest.approx(0.40)
    assert rows["U0"]["value"] == pytest.approx(e.min() / e.mean(), rel=3e-3)
    assert rows["U0"]["passed"] is bool(e.min() / e.mean() >= 0.40)


@pytest.mark.parametrize(("cls", "extra", "key", "words"), [
    ("M3", "", "compliance.areas[0].road_class", "unknown EN 13201-2 lighting class 'M3'"),
    ("P3", 'ugr_l = 19', "compliance.areas[0]", "not 'ugr_l'"),
])
def test_bad_road_input(cls, extra, key, words):
    with pytest.raises(ConfigError) as e:
        parse_config(road(cls, extra), source="road.toml")
    assert e.value.key == key, e.value
    assert words in e.value.message, e.value.message


def test_road_class_needs_its_standard_and_the_rule_refuses_spacing():
    text = road()
    with pytest.raises(ConfigError) as e:
        parse_config(text.replace('road_class = "P3"\n', ""), source="road.toml")
    assert e.value.key == "compliance.areas[0]" and "needs 'road_class'" in e.value.message
    with pytest.raises(ConfigError) as e:
        parse_config(text.replace('standard = "EN 13201-2"', 'standard = "EN 12464-1"'),
                     source="road.toml")
    assert e.value.key == "compliance.areas[0]" and "belongs to" in e.value.message
    with pytest.raises(ConfigError) as e:
        parse_config(text.replace('rule = "EN 13201-3"', 'rule = "EN 13201-3"\nspacing = 1'),
                     source="road.toml")
    assert e.value.key == "grids[0]" and "'spacing'" in e.value.message
    with pytest.raises(ConfigError) as e:
        parse_config(text.replace('rule = "EN 13201-3"', 'rule = "EN 13201-9"'),
                     source="road.toml")
    assert e.value.key == "grids[0].rule", e.value
