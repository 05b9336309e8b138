"""The verdict of the office (tests/compliance/conftest.py), checked by hand from the per-network
light the results hold: maintenance factors, Ēm/U0, the surrounding's rule, modelling,
energy, obtrusive light; superposition in ``results.at``, finite differences, results.json."""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.compliance import compliance_model

MF_A = 0.9 * 0.87  # llmf × LMF(type D, clean, 1 year) of CIE 97:2005's table
MF_B = 0.7


def _row(comp, area, quantity, when=""):
    rows = [r for r in comp.rows if r["area"] == area and r["quantity"] == quantity
            and r["when"] == when]
    assert rows, f"no row {area}.{quantity} {when}"
    return rows[0]


def test_maintained_and_initial_illuminance(office):
    study, res = office
    comp = res.compliance
    desk = res.grids["desk"].by_network_lux
    maintained = 1.0 * MF_A * desk[0] + 0.6 * MF_B * desk[1]
    initial = 1.0 * desk[0] + 0.6 * desk[1]
    em = _row(comp, "office", "Em")
    assert em["value"] == pytest.approx(maintained.mean(), rel=1e-5)
    assert em["initial"] == pytest.approx(initial.mean(), rel=1e-5)
    assert em["limit"] == 500 and em["source"] == "EN 12464-1 34.2"
    assert em["passed"] == bool(maintained.mean() >= 500)
    assert em["margin"] == pytest.approx(maintained.mean() - 500, rel=1e-5)
    u0 = _row(comp, "office", "U0")
    assert u0["value"] == pytest.approx(maintained.min() / maintained.mean(), rel=1e-5)
    # the immediate surrounding of a 500 lx task: 300 lx and U0 0.40 (EN 12464-1:2011 Table 1)
    sur = _row(comp, "office.surrounding", "Em")
    assert sur["limit"] == 300
    assert _row(comp, "office.surrounding", "U0")["limit"] == 0.40
    assert comp.to_dict()["maintenance_factor"] == pytest.approx({"a": MF_A, "b": MF_B})


def test_cylindrical_grid_and_modelling(office):
    """The sensor grid holds Ez, not the planar light: its direct part against
    Ez = I sin ε / (π d²) of the two Lambertian downlights (I = Φ cos γ / π), no occluder."""
    study, res = office
    ez = res.grids["desk_ez"]
    pts = ez.points
    for k, pos in enumerate(([2, 2, 2.95], [4, 2, 2.95])):
        d = pts - pos
        r = np.linalg.norm(d, axis=1)
        cos_g = -d[:, 2] / r
        sin_e = np.sqrt(1 - cos_g**2)
        expect = 3000 / np.pi * cos_g * sin_e / (np.pi * r**2)
        np.testing.assert_allclose(ez.direct_by_network_lux[k], expect, rtol=1e-4)
    assert np.all(ez.by_network_lux > ez.direct_by_network_lux)  # inter-reflected light
    m = _row(res.compliance, "office", "modelling Ez/Eh")
    w = np.array([MF_A, 0.6 * MF_B])
    assert m["value"] == pytest.approx((w @ ez.by_network_lux).mean()
                                       / (w @ res.grids["desk"].by_network_lux).mean(), rel=1e-5)
    # UGR_L: the worst UGR of the area's observer (lumijax.glare) at the maintained dimmers
    ugr = _row(res.compliance, "office", "UGR_L")
    r = res.glare.model.ratings(res.design.replace(dimmers=jnp.asarray(w)))
    assert ugr["value"] == pytest.approx(float(np.max(np.asarray(r.ugr))), abs=1e-4)
    assert ugr["limit"] == 19
    assert _row(res.compliance, "office", "Ra")["value"] == pytest.approx(64, abs=1.5)  # F2


def test_energy_by_hand(office):
    study, res = office
    # network a: 25 W, linear, dimmer 1; b: table at 0.6 → 0.45 + 0.1/0.5 × 0.55 = 0.56, with
    # 0.5 W standby: 0.5 + 24.5 × 0.56
    p = 25.0 + 0.5 + 24.5 * 0.56
    area = 3.0 * 2.0
    w = _row(res.compliance, "installation", "power density")
    assert w["value"] == pytest.approx(p / area, rel=1e-6) and w["status"] == "reported"
    leni = p * (2250 * 0.9 + 250 * 0.9) / 1000 / area
    row = _row(res.compliance, "installation", "LENI")
    assert row["value"] == pytest.approx(leni, rel=1e-6)
    assert row["passed"] == bool(leni <= 10)


def test_obtrusive_by_hand(office):
    study, res = office
    comp = res.compliance
    desk = res.grids["desk"].by_network_lux
    pre = (np.array([MF_A, 0.6 * MF_B]) @ desk).max()
    post = (np.array([0.2 * MF_A, 0.6 * MF_B]) @ desk).max()
    assert _row(comp, "desk", "Ev", "before curfew")["value"] == pytest.approx(pre, rel=1e-5)
    assert _row(comp, "desk", "Ev", "after curfew")["value"] == pytest.approx(post, rel=1e-5)
    assert _row(comp, "desk", "Ev", "before curfew")["limit"] == 5.0  # E2
    # intensity toward the corner (0.1, 0.1, 0.1): Lambertian I = Φ cos γ / π
    ints = []
    for pos in ([2, 2, 2.95], [4, 2, 2.95]):
        d = np.array([0.1, 0.1, 0.1]) - pos
        ints.append(3000 / np.pi * (-d[2] / np.linalg.norm(d)))
    i_pre = max(MF_A * ints[0], 0.6 * MF_B * ints[1])
    assert _row(comp, "corner", "I", "before curfew")["value"] == pytest.approx(i_pre, rel=1e-4)
    assert _row(comp, "installation", "ULR")["value"] == pytest.approx(0.0, abs=1e-6)
    # facade luminance: ρ/π × the area-weighted mean of the walls' maintained illuminance
    from lumijax.scene._standard_grids import surface_samples

    s = surface_samples(study.scene.triangles, 0, 0.01, 1.5)
    e = np.array([MF_A, 0.6 * MF_B]) @ res.grids["wall_s"].by_network_lux
    lb = 0.5 / np.pi * np.sum(s.area_m2 * e) / s.area_m2.sum()
    assert _row(comp, "wall_s", "Lb", "before curfew")["value"] == pytest.approx(lb, rel=1e-5)
    assert s.area_m2.sum() == pytest.approx(2 * (6 * 4 + 6 * 3 + 4 * 3))


def test_at_other_dimmers_and_json(office):
    study, res = office
    other = res.at(res.design.replace(dimmers=[0.5, 0.9]))
    desk = res.grids["desk"].by_network_lux
    em = (0.5 * MF_A * desk[0] + 0.9 * MF_B * desk[1]).mean()
    assert _row(other.compliance, "office", "Em")["value"] == pytest.approx(em, rel=1e-5)
    doc = json.loads(json.dumps(other.to_dict()))
    entry = doc["compliance"]
    assert entry["compliant"] is other.compliance.compliant
    assert entry["not_computed"] == []
    assert {"value", "initial", "limit", "passed", "margin"} <= set(entry["criteria"][0])


def test_quantities_are_differentiable(office):
    """The Jacobian of every computed quantity against central differences of the same
    function (one compiled evaluation, perturbed per dimmer)."""
    study, res = office
    model = res.compliance.model
    d0 = np.array([0.7, 0.4])
    # one compiled program each (eager ops would compile one by one)
    values = jax.jit(lambda d: model.quantities(d))
    jac = jax.jit(jax.jacfwd(lambda d: model.quantities(d)))(jnp.asarray(d0, jnp.float32))
    assert len(jac) >= 12
    h = 1e-2
    v0 = values(jnp.asarray(d0, jnp.float32))
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        hi, lo = values(jnp.asarray(d0 + e, jnp.float32)), values(jnp.asarray(d0 - e, jnp.float32))
        for key, g in jac.items():
            fd = (float(hi[key]) - float(lo[key])) / (2 * h)
            scale = max(1.0, abs(float(v0[key])))
            assert float(g[k]) == pytest.approx(fd, rel=2e-2, abs=1e-4 * scale), (key, k)


def test_bad_compliance_references(office):
    from dataclasses import replace

    from lumijax.errors import ConfigError

    study, res = office
    comp = study.config.compliance
    area = comp.areas[0].model_copy(update={"reference": "99.9"})
    cfg = study.config.model_copy(update={"compliance": comp.model_copy(
        update={"areas": [area]})})
    with pytest.raises(ConfigError) as e:
        compliance_model(replace(study, config=cfg), res)
    assert e.value.key == "compliance.areas[0].reference" and "34.2" in e.value.message


def test_report_opens_with_the_verdict(office, tmp_path):
    from lumijax.report import write_report

    study, res = office
    path = tmp_path / "report.html"
    write_report(study, res, path, pictures=False)
    text = path.read_text()
    assert text.index('id="compliance"') < text.index('id="summary"')
    assert "not compliant" in text and "34.2" in text
