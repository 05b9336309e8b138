"""Sensor illuminance against closed forms derived here, and the inter-reflected part against
an independent quadrature over the patches."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax import compute
from lumijax._study import Study  # noqa: I001
from lumijax.compliance import sensor_light
from lumijax.config import parse_config
from lumijax.direct import SensorResponse
from lumijax.scene import build_scene

FLUX = 4 * np.pi * 100.0  # an isotropic lamp of I = 100 cd


def _study(text: str) -> Study:
    cfg = parse_config(text)
    return Study(cfg, build_scene(cfg))


def _lamp(position, kind="isotropic", aim=""):
    return (f'[photometry.p]\nkind = "{kind}"\nflux_lm = {FLUX}\n[[luminaires]]\nname = "L"\n'
            f'photometry = "p"\nposition = {[float(x) for x in position]}\nnetwork = "n"\n{aim}\n')


def _surface_integral(u, kind, axis=(0.0, 0.0, 1.0), facing=None, n=4000):
    """Mean of max(m·u, 0) over the sensor's lit surface (normals m), by the midpoint rule:
    the definition of the sensor's reading per unit normal illuminance, computed without the
    formula under test."""
    t = (np.arange(n) + 0.5) / n
    if kind in ("cylindrical", "semicylindrical"):
        lo, hi = (0.0, 2 * np.pi) if kind == "cylindrical" else (-np.pi / 2, np.pi / 2)
        phi = lo + (hi - lo) * t
        f = facing if facing is not None else np.array([1.0, 0, 0])
        g = np.cross(np.asarray(axis), f)
        m = np.cos(phi)[:, None] * f + np.sin(phi)[:, None] * g
        return float(np.mean(np.maximum(m @ u, 0.0)))
    # hemisphere about +z: area element sin θ dθ dφ over θ ∈ [0, π/2]
    th = 0.5 * np.pi * t[::4, None]
    ph = 2 * np.pi * ((np.arange(400) + 0.5) / 400)[None, :]
    m = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph),
                  np.cos(th) * np.ones_like(ph)], axis=-1)
    w = np.sin(th) * np.ones_like(ph)
    return float(np.sum(np.maximum(m @ u, 0.0) * w) / np.sum(w))


@pytest.mark.parametrize("kind", ["cylindrical", "semicylindrical", "hemispherical"])
def test_point_source_closed_forms(kind):
    src = np.array([0.3, -0.2, 2.5])
    pts = np.array([[2.0, 1.0, 0.8], [-1.0, 0.5, 1.2], [0.3, -0.2, 0.0], [4.0, -3.0, 2.4],
                    [1.0, 0.0, 3.5]])
    facing = np.array([1.0, 0.0, 0.0])
    study = _study(_lamp(src) + '[[grids]]\nname = "g"\nkind = "points"\npoints = [[0, 0, 0]]\n')
    res = compute(study)
    resp = SensorResponse.uniform(kind, len(pts), facing=facing)
    e = np.asarray(sensor_light(res.lighting, pts, resp).by_network)[0]
    d = src - pts
    r = np.linalg.norm(d, axis=1)
    u = d / r[:, None]
    sin_e = np.sqrt(1 - u[:, 2] ** 2)
    if kind == "cylindrical":  # EN 13201-3 / EN 12464-1: Ez = I sin ε / (π d²)
        expect = 100 * sin_e / (np.pi * r**2)
    elif kind == "semicylindrical":  # Esc = I sin ε (1 + cos α) / (π d²)
        cos_a = np.where(sin_e > 0, u[:, 0] / np.where(sin_e > 0, sin_e, 1), 0)
        expect = 100 * sin_e * (1 + cos_a) / (np.pi * r**2)
    else:  # Ehs = I (1 + cos ε) / (4 d²)
        expect = 100 * (1 + u[:, 2]) / (4 * r**2)
    # and the same from the sensor's surface itself: E⊥ × mean of max(m·u, 0)
    surface = np.array([100 / r[i]**2 * _surface_integral(u[i], kind, facing=facing)
                        for i in range(len(pts))])
    np.testing.assert_allclose(expect, surface, rtol=2e-3, atol=1e-9)
    np.testing.assert_allclose(e, expect, rtol=1e-5, atol=1e-9)


def test_tilted_lambertian_and_shadow():
    """A Lambertian lamp (I = I0 cos γ, I0 = Φ/π) aimed 90° sideways, and a wall that hides one
    sensor: the response multiplies the distribution and the shadow ray still applies."""
    src = np.array([0.0, 0.0, 2.0])
    text = _lamp(src, "lambertian", "aim = { tilt = 90.0, pan = 0.0 }") + (
        '[materials.m]\nreflectance = 0.0\n[[geometry]]\nkind = "rectangle"\n'
        'origin = [-2, 1, 0]\nu = [4, 0, 0]\nv = [0, 0, 4]\nmaterial = "m"\n'
        '[solver]\nindirect = false\n'
        '[[grids]]\nname = "g"\nkind = "points"\npoints = [[0, 0, 0]]\n')
    study = _study(text)
    res = compute(study)
    axis = study.scene.luminaires[0].axis
    pts = np.array([[3.0, 0.5, 1.0], [2.0, -1.0, 2.0], [1.0, 3.0, 2.0]])
    e = np.asarray(sensor_light(res.lighting, pts, SensorResponse.uniform(
        "cylindrical", 3)).by_network)[0]
    d = pts - src
    r = np.linalg.norm(d, axis=1)
    w = d / r[:, None]
    intensity = FLUX / np.pi * np.maximum(w @ axis, 0)
    expect = intensity * np.sqrt(1 - w[:, 2] ** 2) / (np.pi * r**2)
    expect[2] = 0.0  # behind the wall at y = 1
    np.testing.assert_allclose(e, expect, rtol=1e-4, atol=1e-9)
    assert expect[0] > 0 and expect[1] > 0


def test_inter_reflected_part_against_quadrature(office):
    """Cylindrical and hemispherical sensors in the closed grey office (conftest): the gathered
    part against ``Σ_j B_j/π ∫_patch R(u) dω`` by a midpoint rule over each patch (an empty
    box: every patch is visible from an interior point), which shares nothing with the ray
    gather."""
    sol = office[1].lighting
    pts = np.array([[2.0, 1.5, 1.2], [4.6, 0.8, 1.6]])
    patches = sol.coarse.patches
    b = np.asarray(sol.coarse.radiosity, np.float64)[0]
    for kind in ("cylindrical", "hemispherical"):
        resp = SensorResponse.uniform(kind, len(pts))
        got = np.asarray(sensor_light(sol, pts, resp, rays=2048).indirect)[0]
        expect = _quadrature(pts, resp, patches, b, np.asarray(patches.vertices, np.float64))
        np.testing.assert_allclose(got, expect, rtol=0.03)


def _quadrature(pts, resp, patches, b, verts):
    """E = Σ_j (B_j/π) Σ_pieces R(u) a cos θ_j / d² over 5×5 pieces per patch triangle."""
    out = np.zeros(len(pts))
    tri = verts  # (patches, 3, 3)
    n = 5
    bary = []
    for i in range(n):
        for j in range(n - i):
            bary.append(((i + 1 / 3) / n, (j + 1 / 3) / n))
            if i + j < n - 1:
                bary.append(((i + 2 / 3) / n, (j + 2 / 3) / n))
    ab = np.array(bary)
    bc = np.column_stack([1 - ab.sum(1), ab])
    q = np.einsum("kb,tbc->tkc", bc, tri)  # (patches, n², 3)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    nrm = np.asarray(patches.normal, np.float64)
    for p in range(len(pts)):
        d = q - pts[p]  # point → piece
        r2 = np.einsum("tkc,tkc->tk", d, d)
        u = d / np.sqrt(r2)[..., None]
        cos_j = np.maximum(-np.einsum("tkc,tc->tk", u, nrm), 0)
        rr = resp.factor(-u.reshape(-1, 3), np.full(u.size // 3, p)).reshape(r2.shape)
        out[p] = np.sum(b[:, None] / np.pi * rr * (area[:, None] / len(bc)) * cos_j / r2)
    return out
