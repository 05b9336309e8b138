"""CandelaDistribution: directions per type, continuity, gradients, jit/vmap, closed forms."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.errors import LumijaxWarning
from lumijax.photometry import (
    CandelaDistribution,
    flood,
    isotropic,
    lambertian,
    linear_washer,
    read_photometry,
    spot,
    write_ies,
)

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "photometry"


def _random_table(ptype, seed=0):
    rng = np.random.default_rng(seed)
    if ptype == "C":
        h = np.concatenate([[0.0], np.sort(rng.uniform(5, 355, 9)), [360.0]])
        v = np.concatenate([[0.0], np.sort(rng.uniform(3, 177, 12)), [180.0]])
    else:  # non-uniform, reaching the poles of the A/B angle systems
        h = np.concatenate([[-90.0], np.sort(rng.uniform(-85, 85, 10)), [90.0]])
        v = np.concatenate([[-90.0], np.sort(rng.uniform(-85, 85, 11)), [90.0]])
    cd = rng.uniform(10.0, 1000.0, size=(h.size, v.size))
    return CandelaDistribution(ptype, h, v, cd)


def _unit(x):
    x = np.asarray(x, dtype=np.float64)
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _near_pole_dirs(ptype, eps=1e-3, n=12, seed=1):
    """Directions an angle ``eps`` (rad) from each pole of the type's angle system."""
    az = np.random.default_rng(seed).uniform(0, 2 * np.pi, n)
    s, c = math.sin(eps), math.cos(eps)
    ring = np.stack([s * np.cos(az), s * np.sin(az)], axis=-1)
    out = []
    for sign in (1.0, -1.0):
        if ptype == "C":  # poles ∓z
            out.append(np.column_stack([ring, np.full(n, -sign * c)]))
        elif ptype == "B":  # poles ±y
            out.append(np.column_stack([ring[:, 0], np.full(n, sign * c), ring[:, 1]]))
        else:  # poles ±x
            out.append(np.column_stack([np.full(n, sign * c), ring]))
    return np.concatenate(out)


@pytest.mark.parametrize("ptype", ["C", "B", "A"])
def test_direction_maps_follow_conventions(ptype):
    dist = _random_table(ptype)
    h, v = 30.0, 20.0
    d = np.asarray(dist.direction(h, v))
    H, V = math.radians(h), math.radians(v)
    expected = {
        "C": (math.sin(V) * math.cos(H), math.sin(V) * math.sin(H), -math.cos(V)),
        "B": (math.cos(H) * math.sin(V), math.sin(H), -math.cos(H) * math.cos(V)),
        "A": (math.sin(V), math.cos(V) * math.sin(H), -math.cos(V) * math.cos(H)),
    }[ptype]
    np.testing.assert_allclose(d, expected, atol=1e-6)
    # At a grid node the intensity is the tabulated value.
    i, j = 3, 4
    node = dist.direction(dist.h_deg[i], dist.v_deg[j])
    assert float(dist.intensity(node)) == pytest.approx(float(dist.candela[i, j]), rel=1e-4)


@pytest.mark.parametrize("ptype", ["C", "B", "A"])
def test_gradient_matches_finite_differences(x64, ptype):
    dist = _random_table(ptype)
    rng = np.random.default_rng(2)
    dirs = np.concatenate([_unit(rng.normal(size=(40, 3))), _near_pole_dirs(ptype)])
    if ptype != "C":  # stay inside the tabulated azimuth range (front hemisphere)
        dirs = dirs[dirs[:, 2] < -0.05]
    f = jax.jit(lambda x: dist.intensity(x))
    grad = np.asarray(jax.vmap(jax.grad(f))(jnp.asarray(dirs)))
    step = 1e-7
    fd = np.zeros_like(dirs)
    for k in range(3):
        e = np.zeros(3)
        e[k] = step
        fd[:, k] = (np.asarray(f(jnp.asarray(dirs + e))) - np.asarray(f(jnp.asarray(dirs - e)))) / (
            2 * step
        )
    assert np.all(np.isfinite(grad))
    np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("ptype", ["C", "B", "A"])
def test_continuous_at_poles_and_finite_gradient_there(x64, ptype):
    dist = _random_table(ptype)
    near = _near_pole_dirs(ptype, eps=1e-9, n=50)
    if ptype != "C":
        # The A/B tables cover azimuths −90…90 only (the front hemisphere); behind it is zero.
        near[:, 2] = -np.abs(near[:, 2])
    vals = np.asarray(dist.intensity(jnp.asarray(near)))
    for half in (vals[:50], vals[50:]):
        assert np.ptp(half) < 1e-5 * np.max(vals)
    pole = {"C": [0.0, 0.0, -1.0], "B": [0.0, 1.0, 0.0], "A": [1.0, 0.0, 0.0]}[ptype]
    at_pole = float(dist.intensity(jnp.asarray(pole)))
    assert at_pole == pytest.approx(vals[0], rel=1e-6)
    g = jax.grad(lambda x: dist.intensity(x))(jnp.asarray(pole))
    assert np.all(np.isfinite(np.asarray(g)))


def test_seam_continuity_and_zero_outside():
    dist = _random_table("C")
    a = dist.intensity(dist.direction(359.9999, 50.0))
    b = dist.intensity(dist.direction(0.0001, 50.0))
    assert float(a) == pytest.approx(float(b), rel=1e-4)
    down = CandelaDistribution("C", [0, 360], [0, 45, 90], np.ones((2, 3)))
    assert float(down.intensity(jnp.array([0.0, 0.0, 1.0]))) == 0.0
    assert float(down.intensity(jnp.array([1.0, 0.0, -1.0]))) == pytest.approx(1.0)


def test_jit_vmap_and_dtype(x64):
    dist = _random_table("C")
    d64 = jnp.asarray(_unit(np.random.default_rng(3).normal(size=(7, 5, 3))))
    out = jax.jit(lambda m, x: m.intensity(x))(dist, d64)
    assert out.shape == (7, 5) and out.dtype == jnp.float64
    assert dist.intensity(d64.astype(jnp.float32)).dtype == jnp.float32
    np.testing.assert_allclose(jax.vmap(dist.intensity)(d64), out)
    # vmap over a batch of distributions of one shape (e.g. dimmed copies)
    stack = jnp.stack([dist.candela, 2.0 * dist.candela])
    batched = jax.vmap(lambda cd: eqx.tree_at(lambda m: m.candela, dist, cd).intensity(d64))(stack)
    np.testing.assert_allclose(batched[1], 2.0 * out)
    # flux is traceable and differentiable in the table
    g = jax.grad(lambda cd: eqx.tree_at(lambda m: m.candela, dist, cd).flux())(dist.candela)
    assert float(jnp.sum(g * dist.candela)) == pytest.approx(float(dist.flux()), rel=1e-10)


def test_closed_forms():
    iso = isotropic(1234.0)
    assert float(iso.distribution.flux()) == pytest.approx(1234.0, rel=1e-6)
    d = jnp.asarray(_unit(np.random.default_rng(4).normal(size=(100, 3))))
    np.testing.assert_allclose(iso.distribution.intensity(d), 1234.0 / (4 * math.pi), rtol=1e-6)

    lam = lambertian(1000.0)
    assert lam.integrated_lm == pytest.approx(1000.0, rel=1e-12)
    gam = np.linspace(0.0, 89.9, 37)
    vals = np.asarray(lam.distribution.intensity(lam.distribution.direction(17.0, gam)))
    np.testing.assert_allclose(vals, 1000.0 / math.pi * np.cos(np.radians(gam)), atol=1e-3)
    up = lam.distribution.intensity(jnp.array([0.3, 0.0, 0.5]))
    assert float(up) == 0.0


def _half_peak_angle(dist, c_deg):
    """γ (deg) where the intensity in plane C first falls to half its axial value."""
    g = np.linspace(0.0, 180.0, 180001)
    vals = np.asarray(dist.intensity(dist.direction(c_deg, g)))
    return float(np.interp(0.5 * vals[0], vals[::-1], g[::-1]))


@pytest.mark.parametrize("beam, field", [(30.0, None), (10.0, 40.0), (60.0, 90.0)])
def test_spot_flux_and_beam(beam, field):
    p = spot(800.0, beam, field)
    assert p.integrated_lm == pytest.approx(800.0, rel=1e-9)
    assert float(p.distribution.flux()) == pytest.approx(800.0, rel=1e-5)
    assert 2 * _half_peak_angle(p.distribution, 33.0) == pytest.approx(beam, abs=0.01)
    if field is not None:
        d = p.distribution
        ten = float(d.intensity(d.direction(0.0, field / 2))) / float(
            d.intensity(d.direction(0, 0))
        )
        assert ten == pytest.approx(0.1, rel=1e-4)


def test_flood_and_washer_flux_and_beams():
    f = flood(5000.0, 60.0, 30.0)
    assert f.integrated_lm == pytest.approx(5000.0, rel=1e-9)
    assert 2 * _half_peak_angle(f.distribution, 0.0) == pytest.approx(
        30.0, abs=0.01
    )  # C0: vertical
    assert 2 * _half_peak_angle(f.distribution, 90.0) == pytest.approx(60.0, abs=0.01)
    w = linear_washer(2000.0, 1.2, 40.0, 120.0)
    assert w.integrated_lm == pytest.approx(2000.0, rel=1e-9)
    assert w.opening.length_m == 1.2 and w.opening.shape == "rectangle"
    assert 2 * _half_peak_angle(w.distribution, 90.0) == pytest.approx(40.0, abs=0.01)
    assert 2 * _half_peak_angle(w.distribution, 0.0) == pytest.approx(120.0, abs=0.01)
    off = linear_washer(2000.0, 1.2, 40.0, 120.0, offset_deg=25.0)
    assert off.integrated_lm == pytest.approx(2000.0, rel=1e-9)
    d = off.distribution
    assert float(d.intensity(d.direction(90.0, 25.0))) == pytest.approx(d.peak_cd, rel=1e-3)


@pytest.mark.parametrize(
    "make",
    [
        lambda: spot(1500.0, 24.0),
        lambda: flood(3000.0, 70.0, 40.0),
        lambda: linear_washer(1000.0, 0.6, 30.0, offset_deg=15.0),
    ],
)
def test_write_read_round_trip(tmp_path, make):
    p = make()
    out = write_ies(p, tmp_path / "out.ies")
    assert not list(tmp_path.glob(".*tmp"))  # atomic write leaves no temporary behind
    text = out.read_bytes().decode("latin-1")
    assert text.startswith("IES:LM-63-2019\r\n")
    for key in ("[TEST]", "[TESTLAB]", "[ISSUEDATE]", "[MANUFAC]", "[LUMCAT]", "[LUMINAIRE]"):
        assert key in text
    q = read_photometry(out)
    assert q.version == "2019" and q.rated_lm is None
    assert q.opening == p.opening
    np.testing.assert_allclose(q.distribution.h_deg, p.distribution.h_deg)
    np.testing.assert_allclose(q.distribution.v_deg, p.distribution.v_deg)
    np.testing.assert_allclose(q.distribution.candela, p.distribution.candela, rtol=1e-6)
    assert q.integrated_lm == pytest.approx(p.integrated_lm, rel=1e-6)


def test_round_trip_of_real_files(tmp_path):
    if not SHARED.is_dir():
        pytest.skip("shared photometry folder absent")
    for name in ("ew_flood_2.1.IES", "er_TILT_TEST_SYNTHETIC.ies", "er_road_luminaire.ldt"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LumijaxWarning)
            p = read_photometry(SHARED / name)
            q = read_photometry(write_ies(p, tmp_path / (name + ".ies")))
        assert q.distribution.photometric_type == p.distribution.photometric_type
        np.testing.assert_allclose(q.distribution.candela, p.distribution.candela, rtol=1e-6)
        assert q.tilt == p.tilt
        assert q.opening.shape == p.opening.shape
