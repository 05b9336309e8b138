"""Clear glass: the thin pane's τ(θ), direct light behind a pane, form factors through a pane.

The reference τ(θ) here is written independently of ``lumijax.scene._glass``: the beams of a
slab summed one by one (transmitted after 0, 2, 4, … internal reflections) for each
polarisation, and the internal transmissivity found by bisection on τ(0), not by the closed
form the code uses."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import lamp, material, network, photometry, point_grid, rectangle, study_text

from lumijax import LumijaxError, compute, load_study
from lumijax.scene import GlazedCaster, RayCaster, glass_transmittance

N = 1.52


def _beams(cos_i: float, t_n: float, n: float = N) -> float:
    """τ(θ) of a slab as a sum over its beams (Fresnel at each surface), polarisations averaged."""
    sin_t = np.sqrt(1 - cos_i**2) / n
    cos_t = np.sqrt(1 - sin_t**2)
    t = t_n ** (1 / cos_t)  # Beer–Lambert over the slanted path
    total = 0.0
    for r in (((cos_i - n * cos_t) / (cos_i + n * cos_t)) ** 2,
              ((n * cos_i - cos_t) / (n * cos_i + cos_t)) ** 2):
        total += 0.5 * sum((1 - r) * t * (r * t) ** (2 * k) * (1 - r) for k in range(200))
    return total


def _t_of(tau0: float) -> float:
    lo, hi = 0.0, 1.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _beams(1.0, mid) < tau0 else (lo, mid)
    return 0.5 * (lo + hi)


def test_thin_pane_against_the_beam_sum():
    # no absorption: (1 − r₀)/(1 + r₀) with r₀ = (0.52/2.52)² by hand
    assert glass_transmittance(1.0, 0.9183180) == pytest.approx(0.9183180, abs=2e-6)
    assert _beams(1.0, 1.0) == pytest.approx(0.9183180, abs=1e-6)
    for tau0 in (0.88, 0.6, 0.3):
        t_n = _t_of(tau0)
        # Radiance's documented conversion of a normal transmittance to its glass transmissivity
        radiance = (np.sqrt(0.8402528435 + 0.0072522239 * tau0**2) - 0.9166530661) / (
            0.0036261119 * tau0)
        assert t_n == pytest.approx(radiance, rel=1e-6)
        for deg in (0, 30, 60, 75, 85, 89.5):
            c = np.cos(np.radians(deg))
            assert glass_transmittance(c, tau0) == pytest.approx(_beams(c, t_n), rel=1e-9)
            assert glass_transmittance(-c, tau0) == pytest.approx(_beams(c, t_n), rel=1e-9)
    assert glass_transmittance(0.0, 0.88) == pytest.approx(0.0, abs=1e-12)  # grazing


def _study(tmp_path, pane: str | None, pts):
    parts = [material("pane", 0.05, **({} if pane is None else
                                       {"transmittance": 0.8, "kind": pane})),
             photometry("iso", "isotropic", 1000.0), network("n"), lamp("L", [0, 0, 3]),
             point_grid("g", pts, [0, 0, 1])]
    if pane is not None:  # a horizontal pane between the lamp and the points, facing the lamp
        parts.insert(1, rectangle([-10, -10, 1.5], [20, 0, 0], [0, 20, 0], "pane"))
    (tmp_path / "s.toml").write_text(study_text(*parts), encoding="utf-8")
    return load_study(tmp_path / "s.toml")


def test_direct_light_behind_a_pane_is_attenuated_by_tau_theta(tmp_path):
    pts = [[x, 0.0, 0.0] for x in (0.0, 1.0, 2.5, 5.0)]
    bare = compute(_study(tmp_path, None, pts), indirect=False).grids["g"].by_network_lux[0]
    # bare: the inverse-square law of a 1000 lm isotropic lamp 3 m up, by hand
    x = np.array(pts)[:, 0]
    d2, cos = 9 + x**2, 3 / np.sqrt(9 + x**2)
    np.testing.assert_allclose(bare, 1000 / (4 * np.pi) * cos / d2, rtol=1e-9)
    glazed = compute(_study(tmp_path, "clear", pts), indirect=False).grids["g"]
    want = bare * np.array([_beams(c, _t_of(0.8)) for c in cos])
    np.testing.assert_allclose(glazed.by_network_lux[0], want, rtol=1e-6)


def test_a_glazed_caster_is_only_used_with_clear_glass(tmp_path):
    pts = [[0.0, 0.0, 0.0]]
    assert type(_study(tmp_path, None, pts).scene.raycaster) is RayCaster
    assert type(_study(tmp_path, "diffuse", pts).scene.raycaster) is RayCaster
    caster = _study(tmp_path, "clear", pts).scene.raycaster
    assert isinstance(caster, GlazedCaster)
    # a yes/no ray sees the pane as clear; first hits still stop at it
    assert not caster.occluded(np.array([[0, 0, 3.0]]), np.array([[0, 0, 0.0]]))[0]
    tri, dist = caster.first_hit(np.array([[0, 0, 3.0]]), np.array([[0, 0, -1.0]]))
    assert tri[0] >= 0 and dist[0] == pytest.approx(1.5, abs=1e-4)


def test_two_panes_and_an_opaque_wall_along_one_ray():
    sq = np.array([[[-5, -5, 0], [5, -5, 0], [5, 5, 0]], [[-5, -5, 0], [5, 5, 0], [-5, 5, 0]]],
                  float)
    tri = np.concatenate([sq + [0, 0, 1.0], sq + [0, 0, 2.0], sq + [0, 0, 4.0]])
    tau = np.array([0.8, 0.8, 0.5, 0.5, 0.0, 0.0])  # two panes, then an opaque sheet at z = 4
    caster = GlazedCaster(tri, tau)
    o = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    t = np.array([[0.0, 0.0, 3.0], [3.0, 0.0, 3.0], [0.0, 0.0, 5.0]])
    got = caster.transmission(o, t)
    c = 1 / np.sqrt(2)
    want = [_beams(1.0, _t_of(0.8)) * _beams(1.0, _t_of(0.5)),
            _beams(c, _t_of(0.8)) * _beams(c, _t_of(0.5)), 0.0]
    np.testing.assert_allclose(got, want, rtol=1e-6)
    # a gather ray passes both panes and stops at the sheet, 4 m on, carrying τ₁ τ₂
    tri_hit, dist, carried = caster.first_hit_through(o[:1], np.array([[0.0, 0.0, 1.0]]))
    assert tri_hit[0] in (4, 5) and dist[0] == pytest.approx(4.0, abs=1e-4)
    assert carried[0] == pytest.approx(want[0], rel=1e-6)
    tri_hit, _, carried = caster.first_hit_through(o[:1], np.array([[0.0, 0.0, -1.0]]))
    assert tri_hit[0] == -1  # nothing below


def test_form_factors_through_a_pane_carry_tau_theta():
    """Two 1 m plates 3 m apart (every pair far: one centroid ray each) with a pane between:
    each entry of A F is the bare entry × τ of its own ray's incidence on the pane."""
    from lumijax.radiosity import FormFactorSettings, build_operator, mesh_patches, partition

    quad = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    top = quad[:, ::-1] + [0, 0, 3.0]  # reversed: facing down
    pane = np.array([[[-2, -2, 1.5], [3, -2, 1.5], [3, 3, 1.5]],
                     [[-2, -2, 1.5], [3, 3, 1.5], [-2, 3, 1.5]]])
    plates = np.concatenate([quad, top])
    patches = mesh_patches(plates, patch_size=0.5)
    settings = FormFactorSettings(lowrank=False)

    def dense(caster):
        part = partition(patches, occluders=caster)
        op = build_operator(patches, part, caster, settings, dtype=np.float64)
        f = np.asarray(op.matmul(jnp.eye(patches.n, dtype=jnp.float64)))
        return patches.area[:, None] * f

    everything = np.concatenate([plates, pane])
    bare = dense(RayCaster(everything[:4]))
    glazed = dense(GlazedCaster(everything, [0, 0, 0, 0, 0.7, 0.7]))
    d = patches.centroid[None] - patches.centroid[:, None]
    cos = np.abs(d[..., 2]) / np.maximum(np.linalg.norm(d, axis=-1), 1e-12)
    t_n = _t_of(0.7)
    want = bare * np.vectorize(lambda c: _beams(c, t_n) if c > 0 else 0.0)(cos)
    assert bare.sum() > 0.05  # the plates see each other (2 A F₁₂, F₁₂ ≈ 0.03)
    np.testing.assert_allclose(glazed, want, rtol=1e-6, atol=1e-12)


def test_clear_glass_above_the_fresnel_limit_is_refused(tmp_path):
    (tmp_path / "s.toml").write_text(study_text(
        material("pane", 0.02, transmittance=0.95, kind="clear")), encoding="utf-8")
    with pytest.raises(LumijaxError) as e:
        load_study(tmp_path / "s.toml")
    assert e.value.key == "materials.pane.transmittance"
    assert "0.9183" in e.value.message and "0.95" in e.value.message
