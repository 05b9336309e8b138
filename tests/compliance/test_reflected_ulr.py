"""The upward light ratio with the inter-reflected light that leaves toward the sky, against
closed forms: a floodlit horizontal plane in an open scene sends ρ·Φ_incident up, and a floor
beside a tall wall sees the sky over 1 − ½(1 − x/√(x² + H²)) of its cosine-weighted hemisphere
(the view factor of a strip, written here)."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.compliance import sky_fraction
from lumijax.config import parse_config
from lumijax.radiosity import Patches
from lumijax.scene import build_scene

RHO, A, H, PHI = 0.5, 2.0, 2.0, 1000.0  # reflectance, half side (m), height (m), flux (lm)

PLANE = f"""[study]
name = "floodlit plane"
[solver]
target_patches = 400
spectral_samples = 0
cache = false
gather_rays = 64
[materials.ground]
reflectance = {RHO}
[photometry.iso]
kind = "isotropic"
flux_lm = {PHI}
[networks.n]
[[luminaires]]
name = "lamp"
photometry = "iso"
network = "n"
position = [0, 0, {H}]
[[geometry]]
kind = "rectangle"
name = "ground"
origin = [{-A}, {-A}, 0]
u = [{2 * A}, 0, 0]
v = [0, {2 * A}, 0]
material = "ground"
[[grids]]
name = "probe"
kind = "points"
points = [[0, 0, 0.01]]
normals = [0, 0, 1]
[compliance.obtrusive]
zone = "E4"
reflected_ulr = "judge"
"""


@pytest.fixture(scope="module")
def plane(tmp_path_factory):
    from lumijax import compute, load_study

    path = tmp_path_factory.mktemp("plane") / "plane.toml"
    path.write_text(PLANE)
    study = load_study(path)
    with pytest.warns(Warning):  # "the scene is open": the point of the test
        return study, compute(study)


def _row(results, quantity):
    (row,) = [r for r in results.compliance.rows if r["quantity"] == quantity]
    return row


def test_floodlit_plane_reflects_rho_times_incident_flux_upward(plane):
    """Isotropic lamp h above the centre of a 2a square: the square subtends
    Ω = 4 atan(a² / (h √(h² + 2a²))) = 2π/3 sr here, so Φ_inc = Φ Ω / 4π = Φ/6; the direct ULR
    is ½ and the total ½ + ρ Φ_inc / Φ."""
    _, res = plane
    omega = 4 * np.arctan(A * A / (H * np.sqrt(H * H + 2 * A * A)))
    assert omega == pytest.approx(2 * np.pi / 3)
    expect = 0.5 + RHO * omega / (4 * np.pi)
    assert _row(res, "ULR")["value"] == pytest.approx(0.5, abs=2e-3)
    row = _row(res, "ULR incl. reflected")
    assert row["value"] == pytest.approx(expect, rel=5e-3)
    assert row["limit"] == pytest.approx(0.15) and row["status"] == "fail"  # judged (E4)


def test_reflected_ulr_superposes_with_the_dimmer(plane):
    """Direct and reflected upward flux and the total flux all scale with the dimmer: the ratio
    is the same at any dimmer level."""
    _, res = plane
    model = res.compliance.model
    q = [float(model.quantities(jnp.asarray([d]))["installation.ULR incl. reflected"])
         for d in (0.3, 1.0)]
    assert q[0] == pytest.approx(q[1], rel=1e-6)
    assert float(model.ulr_reflected[0]) == pytest.approx(
        RHO * PHI * (4 * np.arctan(A * A / (H * np.sqrt(H * H + 2 * A * A)))) / (4 * np.pi),
        rel=5e-3)


def test_report_mode_has_no_limit_and_off_leaves_it_out(plane):
    from lumijax.compliance import Compliance, compliance_model

    study, res = plane
    comp = study.config.compliance
    for mode, expect in (("report", ["reported"]), ("off", []), ("judge", ["fail"])):
        ob = comp.obtrusive.model_copy(update={"reflected_ulr": mode})
        cfg = study.config.model_copy(update={"compliance": comp.model_copy(
            update={"obtrusive": ob})})
        model = compliance_model(dataclasses.replace(study, config=cfg), res)
        rows = Compliance.judge(model, res.design.dimmers).rows
        assert [r["status"] for r in rows if r["quantity"] == "ULR incl. reflected"] == expect


def test_sky_fraction_beside_a_wall():
    """Floor points x from a long wall of height H: the wall covers ½(1 − x/√(x² + H²)) of
    the cosine-weighted hemisphere (2-D strip view factor); the rest is sky, all of it upward."""
    h = 3.0
    sc = build_scene(parse_config(f"""
[materials.m]
reflectance = 0.5
[[geometry]]
kind = "rectangle"
origin = [-500, 0, 0]
u = [1000, 0, 0]
v = [0, 0, {h}]
material = "m"
"""))
    x = np.array([0.5, 1.0, 3.0, 8.0])
    n = len(x)
    c = np.stack([np.zeros(n), x, np.full(n, 1e-3)], axis=1)
    patches = Patches(centroid=c, normal=np.tile([0.0, 0.0, 1.0], (n, 1)), area=np.ones(n),
                      vertices=np.repeat(c[:, None], 3, axis=1), material=np.zeros(n, int),
                      group=np.full(n, -1), source_triangle=np.zeros(n, int))
    f = sky_fraction(patches, sc.raycaster, rays=4096)
    expect = 1 - 0.5 * (1 - x / np.sqrt(x * x + h * h))
    np.testing.assert_allclose(f, expect, atol=0.01)
    # a patch facing down sees no sky above it; one facing sideways sees half
    down = Patches(centroid=np.array([[0, 50, 1.0], [0, 50, 1.0]]),
                   normal=np.array([[0, 0, -1.0], [0, 1.0, 0]]), area=np.ones(2),
                   vertices=np.zeros((2, 3, 3)), material=np.zeros(2, int),
                   group=np.full(2, -1), source_triangle=np.zeros(2, int))
    np.testing.assert_allclose(sky_fraction(down, sc.raycaster, rays=4096), [0.0, 0.5],
                               atol=0.01)


@pytest.mark.parametrize(("old", "new", "key", "words"), [
    ('reflected_ulr = "judge"', 'reflected_ulr = "maybe"', "compliance.obtrusive.reflected_ulr",
     "'report', 'judge' or 'off'"),
    ('reflected_ulr = "judge"', "ulr_max = 1.5", "compliance.obtrusive.ulr_max",
     "less than or equal to 1"),
])
def test_bad_reflected_ulr_input(old, new, key, words):
    from lumijax.errors import ConfigError

    with pytest.raises(ConfigError) as e:
        parse_config(PLANE.replace(old, new), source="plane.toml")
    assert e.value.key == key, e.value
    assert words in e.value.message, e.value.message
    assert e.value.line is not None


def test_ulr_max_replaces_the_zone_limit(plane):
    from lumijax.compliance import Compliance, compliance_model

    study, res = plane
    comp = study.config.compliance
    ob = comp.obtrusive.model_copy(update={"ulr_max": 0.6})
    cfg = study.config.model_copy(update={"compliance": comp.model_copy(update={"obtrusive": ob})})
    rows = Compliance.judge(compliance_model(dataclasses.replace(study, config=cfg), res),
                            res.design.dimmers).rows
    ulr = {r["quantity"]: r for r in rows if r["quantity"].startswith("ULR")}
    assert ulr["ULR"]["limit"] == ulr["ULR incl. reflected"]["limit"] == 0.6
    assert ulr["ULR"]["source"] == "given"
    assert ulr["ULR incl. reflected"]["status"] == "pass"  # 0.583 ≤ 0.6
