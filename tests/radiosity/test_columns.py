"""Only distinct columns are solved (radiosity ``distinct_columns``, ``lighting.solve_spectral``):
every column still equals a dense solve of its own system, written here with numpy."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import box_room

import lumijax
from lumijax.lighting._spectral import solve_spectral
from lumijax.radiosity import build_operator, mesh_patches, partition, solve_radiosity

from .conftest import quad


@pytest.fixture(scope="module")
def pair():
    """Two facing 1 m squares 0.5 m apart: a small open scene with real form factors."""
    tri = np.concatenate([quad([0, 0, 0], [1, 0, 0], [0, 1, 0]),
                          quad([0, 0, 0.5], [0, 1, 0], [1, 0, 0])])
    grp = np.r_[0, 0, 1, 1]
    p = mesh_patches(tri, group=grp, patch_size=0.25)
    op = build_operator(p, partition(p, 1024), None)
    return p, op, np.asarray(op.todense(), np.float64)


def dense(f, rho, b0):
    """``(I − diag(ρ) F)⁻¹ B₀`` for one column, in float64 (no row correction: open scene)."""
    return np.linalg.solve(np.eye(len(rho)) - rho[:, None] * f, b0)


def test_copies_are_solved_once_and_each_equals_its_own_solve(pair):
    p, op, f = pair
    rng = np.random.default_rng(0)
    n = p.n
    rho_w = np.stack([np.full(n, 0.6), np.full(n, 0.6), rng.uniform(0.1, 0.9, n),
                      np.full(n, 0.6)], axis=1)  # (P, W=4): wavelengths 0, 1, 3 alike
    e = rng.uniform(10.0, 100.0, (n, 2))  # (P, S=2): two sources' direct light
    e[:, 1] = e[:, 0]  # ... and the second a copy of the first
    b0 = rho_w[:, None, :] * e[:, :, None]  # (P, 2, 4)
    sol = solve_radiosity(op, jnp.asarray(rho_w[:, None, :]), jnp.asarray(b0), rtol=1e-11,
                          correct_rows=False)
    # distinct (ρ, B₀) pairs: {w0, w1, w3} and {w2}, for either source (the same light)
    assert sol.stats["columns_solved"] == 2
    got = np.asarray(sol.value)
    assert got.shape == b0.shape
    for s in range(2):
        for w in range(4):
            ref = dense(f, rho_w[:, w], b0[:, s, w])
            np.testing.assert_allclose(got[:, s, w], ref, rtol=1e-8, atol=1e-10)
    assert np.asarray(sol.escaped).shape == (2, 4)
    assert np.all(np.asarray(sol.escaped) > 0.3)  # open: most light leaves two squares


def test_traced_solve_solves_every_column(pair):
    p, op, f = pair
    rho = jnp.full(p.n, 0.5)
    b0 = jnp.ones((p.n, 3))
    sol = jax.jit(lambda r, b: solve_radiosity(op, r, b, rtol=1e-11, correct_rows=False)
                  .value)(rho, b0)
    ref = dense(f, np.full(p.n, 0.5), np.ones(p.n))
    for j in range(3):
        np.testing.assert_allclose(np.asarray(sol)[:, j], ref, rtol=1e-8)


def test_grey_scene_needs_one_column_per_source_whatever_the_spectrum(pair):
    p, op, f = pair
    n, w = p.n, 8
    rho = np.full((n, w), 0.7)  # grey
    e = np.stack([np.linspace(5, 50, n), np.linspace(80, 8, n)])  # (src=2, P)
    s = np.array([np.linspace(0.2, 1.8, w), np.ones(w)])  # a warm and a flat spectrum
    s[0, 3] = 0.0  # a sample where the first spectrum emits nothing
    b, res = solve_spectral(op, rho, e, s, jnp.float64, rtol=1e-11, correct_rows=False)
    assert res.stats["columns_solved"] == 2
    for g in range(2):
        for k in range(w):
            ref = dense(f, rho[:, k], rho[:, k] * e[g] * s[g, k])
            np.testing.assert_allclose(b[:, g, k], ref, rtol=1e-8, atol=1e-12)
    esc = np.asarray(res.escaped)
    assert esc[0, 3] == 0.0 and np.all(esc[1] > 0)


def test_coloured_wavelengths_each_get_their_column(pair):
    p, op, f = pair
    n = p.n
    half = np.arange(n) < n // 2
    rho = np.stack([np.where(half, 0.2, 0.5), np.where(half, 0.8, 0.5),
                    np.where(half, 0.2, 0.5)], axis=1)  # wavelength 2 is wavelength 0 again
    e = np.linspace(1, 9, n)[None]
    b, res = solve_spectral(op, rho, e, np.array([[1.0, 2.0, 3.0]]), jnp.float64,
                            rtol=1e-11, correct_rows=False)
    assert res.stats["columns_solved"] == 2
    for k, sk in enumerate((1.0, 2.0, 3.0)):
        np.testing.assert_allclose(b[:, 0, k], dense(f, rho[:, k], rho[:, k] * e[0] * sk),
                                   rtol=1e-8)


def test_grey_study_reports_one_column_and_matches_its_photometric_solve(write_study):
    # a grey room's lux cannot depend on the wavelengths it is sampled at: the spectral solve
    # (16 samples, one solved column per network) equals the photometric one (ρ the same)
    spectral = write_study(box_room("target_patches = 150\ngather_rays = 32\ncache = false",
                                    grid="nu = 4\nnv = 3"),
                           "spectral.toml")
    photometric = write_study(box_room(
        "target_patches = 150\ngather_rays = 32\ncache = false\nspectral_samples = 0",
        grid="nu = 4\nnv = 3"), "photometric.toml")
    a = lumijax.compute(lumijax.load_study(spectral))
    b = lumijax.compute(lumijax.load_study(photometric))
    assert a.solver["spectral_samples"] == 16
    assert a.solver["columns_solved"] == 2  # two networks, grey walls, one default spectrum
    assert b.solver["columns_solved"] == 2
    ea, eb = a.grids["floor"].illuminance_lux, b.grids["floor"].illuminance_lux
    indirect = a.lighting.point_indirect.sum(axis=0)
    assert np.all(indirect > 0.1 * ea.mean())  # inter-reflection is a real part of it
    np.testing.assert_allclose(ea, eb, rtol=1e-4)
    assert a.to_dict()["solver"]["columns_solved"] == 2
    # a room this small is one LU on the host (radiosity/_lu.py), and results.json says so
    assert a.to_dict()["solver"]["solved_directly"] is True and a.solver["iterations"] == 0
