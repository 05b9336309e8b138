"""The traced view pass against closed forms: a Lambertian wall's L = B/π, a linear radiosity
field reproduced exactly by the interpolation, a luminaire's mirror image at the pixel of its
mirror point with luminance ρ_s L, and a room through clear glass equal to the room seen
directly × τ(θ) pixel by pixel. Scenes are built from arrays (no radiosity solve): the tracer
is what is tested."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import pinhole_pixel

from lumijax.photometry import lambertian
from lumijax.render import Optics, Perspective, Tracer, emitters_of
from lumijax.scene import Luminaire


def _grid(origin, u, v, n: int = 4):
    """A rectangle origin + s u + t v cut into 2 n² triangles: (points, faces)."""
    s, t = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1), indexing="ij")
    pts = (np.asarray(origin, float) + s.reshape(-1, 1) * np.asarray(u, float)
           + t.reshape(-1, 1) * np.asarray(v, float))
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                            np.stack([a, c, d], -1).reshape(-1, 3)])
    return pts, faces


def _merge(*parts):
    pts, faces, off = [], [], 0
    for p, f in parts:
        pts.append(p)
        faces.append(f + off)
        off += len(p)
    return np.concatenate(pts), np.concatenate(faces)


def _normals(points, faces):
    n = np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]]
                 - points[faces[:, 0]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _grey(y):
    """XYZ with luminance ``y`` and the chromaticity of the (arbitrary) white (1, 1, 1)."""
    return np.repeat(np.asarray(y, float)[..., None], 3, axis=-1)


CAM = Perspective(position=(0.0, 0.0, 1.0), target=(0.0, 5.0, 1.0), up=(0.0, 0.0, 1.0),
                  size=(64, 48), fov_deg=40.0)


def _wall():
    """A 6 m × 4 m wall at y = 5 facing −y (toward the camera), 32 triangles."""
    return _grid((-3.0, 5.0, -1.0), (6.0, 0.0, 0.0), (0.0, 0.0, 4.0))


def test_lambertian_wall_shows_b_over_pi():
    pts, faces = _wall()
    n = _normals(pts, faces)
    assert np.allclose(n, [0.0, -1.0, 0.0])
    b = 37.0  # lm/m²
    tracer = Tracer(pts, faces, n, _grey(np.full((1, len(pts)), b / math.pi)),
                    np.zeros(len(faces), int), Optics.lambertian(1))
    img = tracer.render(CAM, [1.0])
    assert np.allclose(img.luminance, b / math.pi, rtol=1e-12)


def test_linear_field_is_reproduced_exactly():
    pts, faces = _wall()

    def field(p):  # cd/m², linear in position
        return 3.0 + 0.7 * p[..., 0] + 1.9 * p[..., 2]

    tracer = Tracer(pts, faces, _normals(pts, faces), _grey(field(pts)[None]),
                    np.zeros(len(faces), int), Optics.lambertian(1))
    img = tracer.render(CAM, [1.0])
    d, _ = CAM.rays()
    # the ray from the eye meets the plane y = 5 at t = 5 / d_y
    hit = np.asarray(CAM.position) + (5.0 / d[:, 1])[:, None] * d
    expect = field(hit).reshape(CAM.size[1], CAM.size[0])
    assert np.all(np.abs(hit[:, 2] - 1.0) < 2.0)  # every pixel sees the wall
    assert np.allclose(img.luminance, expect, rtol=1e-5, atol=1e-5)
    # flat shading per triangle would be off by up to half a triangle's gradient
    assert np.ptp(img.luminance) > 1.0


def _downlight(height: float, flux: float, diameter: float):
    phot = lambertian(flux, diameter)
    lum = Luminaire(name="L1", photometry="down", position=np.array([0.0, 0.0, height]),
                    tilt=0.0, pan=0.0, spin=0.0, network="n")
    return SimpleNamespace(luminaires=(lum,), photometries={"down": phot},
                           network_names=("n",), area_sources=())


@pytest.mark.parametrize("rho_s", [0.85, 0.3])
def test_luminaire_in_a_mirror_floor(rho_s):
    flux, diameter, height = 2000.0, 0.4, 3.0
    floor = _grid((-20.0, -20.0, 0.0), (40.0, 0.0, 0.0), (0.0, 40.0, 0.0), n=2)
    pts, faces = floor
    n = _normals(pts, faces)
    assert np.allclose(n, [0.0, 0.0, 1.0])
    optics = Optics.lambertian(1)
    optics.specular[0] = rho_s
    optics.roughness[0] = 1e-4  # a mirror
    scene = _downlight(height, flux, diameter)
    tracer = Tracer(pts, faces, n, np.zeros((1, len(pts), 3)), np.zeros(len(faces), int),
                    optics, emitters_of(scene), depth=1)
    cam = Perspective(position=(4.0, 1.0, 1.6), target=(0.0, 0.0, -height),
                      up=(0.0, 0.0, 1.0), size=(160, 120), fov_deg=30.0)
    img = tracer.render(cam, [1.0])
    lum = img.luminance
    # the mirror image of the opening is the disk at z = −3: at the frame's centre
    row, col = pinhole_pixel(cam, (0.0, 0.0, -height), cam.size)
    source = flux / (math.pi * math.pi * (diameter / 2) ** 2)  # Φ/(πA), every direction
    # the built-in Lambertian table is within 3·10⁻⁶ of Φ/π cos γ
    assert lum[row, col] == pytest.approx(rho_s * source, rel=1e-5)
    # ... and nowhere far from it: the image's apparent radius is 0.2 m at ~7.2 m
    far = pinhole_pixel(cam, (0.0, 1.0, -height), cam.size)
    assert lum[far] == 0.0
    seen = lum > 0
    rows, cols = np.nonzero(seen)
    assert abs(rows.mean() - row) < 1.0 and abs(cols.mean() - col) < 1.0


def test_luminaire_seen_directly_at_its_luminance():
    flux, diameter = 1500.0, 0.3
    scene = _downlight(3.0, flux, diameter)
    pts, faces = _grid((-20.0, -20.0, 0.0), (40.0, 0.0, 0.0), (0.0, 40.0, 0.0), n=1)
    tracer = Tracer(pts, faces, _normals(pts, faces), np.zeros((1, len(pts), 3)),
                    np.zeros(len(faces), int), Optics.lambertian(1), emitters_of(scene))
    # from below at 40° off the axis: a Lambertian opening's L = I/A_p = Φ/(πA) still
    cam = Perspective(position=(1.5, 0.0, 3.0 - 1.5 / math.tan(math.radians(40))),
                      target=(0.0, 0.0, 3.0), size=(80, 80), fov_deg=10.0)
    img = tracer.render(cam, [0.6])
    row, col = pinhole_pixel(cam, (0.0, 0.0, 3.0), cam.size)
    assert img.luminance[row, col] == pytest.approx(
        0.6 * flux / (math.pi * math.pi * (diameter / 2) ** 2), rel=2e-3)
    # from above, the back of a downlight is dark
    top = Perspective(position=(1.0, 0.0, 5.0), target=(0.0, 0.0, 3.0), size=(40, 40),
                      fov_deg=10.0)
    assert tracer.render(top, [1.0]).luminance.max() == 0.0


def _pane(cos_theta, tau0, n=1.52):
    """τ(θ) of a thin absorbing pane of normal transmittance τ0, written here from Fresnel's
    equations (Snell's law, the r_s and r_p amplitudes), Beer's law along the refracted path
    and the incoherent sum of the slab's inter-reflections; the internal transmissivity found
    by bisection on τ(0) = τ0."""
    theta = np.arccos(np.clip(cos_theta, -1, 1))
    theta_t = np.arcsin(np.sin(theta) / n)
    safe = np.where(theta > 1e-9, theta, 1e-9)
    st = np.where(theta > 1e-9, theta_t, 1e-9 / n)
    r_s = (np.sin(safe - st) / np.sin(safe + st)) ** 2
    r_p = (np.tan(safe - st) / np.tan(safe + st)) ** 2

    def slab(r, t):  # Σ (1−r)² t (r t)^{2k}
        return (1 - r) ** 2 * t / (1 - (r * t) ** 2)

    r0 = ((n - 1) / (n + 1)) ** 2
    lo, hi = 0.0, 1.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slab(r0, mid) < tau0 else (lo, mid)
    t = lo ** (1.0 / np.cos(theta_t))
    return 0.5 * (slab(r_s, t) + slab(r_p, t))


def test_room_through_a_window_is_the_room_times_tau():
    tau = 0.72
    wall = _wall()
    # a pane at 27° to the wall, so that the view's rays meet it at 0–50°
    pane = _grid((-3.0, 0.5, -2.0), (6.0, 3.0, 0.0), (0.0, 0.0, 6.0), n=2)
    pane_normal = np.array([3.0, -6.0, 0.0]) / math.sqrt(45.0)

    def field(p):
        return 10.0 + 2.0 * p[..., 0] + 3.0 * p[..., 2]

    pts, faces = _merge(wall, pane)
    n = _normals(pts, faces)
    material = np.r_[np.zeros(len(wall[1]), int), np.ones(len(pane[1]), int)]
    vx = _grey(np.where(np.arange(len(pts)) < len(wall[0]), field(pts), 0.0)[None])
    optics = Optics.lambertian(2)
    optics.transmittance[1] = tau
    optics.tau[1] = tau
    optics.clear[1] = True
    direct = Tracer(*wall, _normals(*wall), vx[:, : len(wall[0])],
                    np.zeros(len(wall[1]), int), Optics.lambertian(1))
    through = Tracer(pts, faces, n, vx, material, optics, depth=1)
    cam = Perspective(position=(0.4, 0.0, 1.0), target=(-0.3, 5.0, 1.2), size=(48, 32),
                      fov_deg=36.0)
    a = direct.render(cam, [1.0]).luminance
    b = through.render(cam, [1.0]).luminance
    d, _ = cam.rays()
    factor = _pane(np.abs(d @ pane_normal), tau).reshape(a.shape)
    assert _pane(1.0, tau) == pytest.approx(tau, rel=1e-12)
    assert np.all(a > 0)
    # (hit points are Embree's float32: the two paths meet the wall a few µm apart)
    assert np.allclose(b, a * factor, rtol=1e-5)
    assert factor.min() < 0.985 * factor.max()  # the view spans angles where τ(θ) differs


def test_two_sided_diffuser_shows_each_side_and_opaque_backs_are_passed():
    """A diffusely transmitting panel modelled as two back-to-back triangle layers shows, from
    each side, the radiosity of the side facing the eye; an opaque wall seen from behind is
    passed through (the raster's culled back faces), so the wall behind it shows."""
    front = _grid((-3.0, 2.0, -1.0), (6.0, 0.0, 0.0), (0.0, 0.0, 4.0), n=1)  # facing −y
    back = (front[0], front[1][:, [0, 2, 1]])  # the same triangles facing +y
    far = _grid((-30.0, 9.0, -30.0), (60.0, 0.0, 0.0), (0.0, 0.0, 60.0), n=1)  # facing −y
    pts, faces = _merge(front, back, far)
    n = _normals(pts, faces)
    sizes = [len(front[0]), len(back[0]), len(far[0])]
    lum = np.repeat([5.0, 2.0, 0.7], sizes)
    material = np.repeat([1, 1, 0], [len(front[1]), len(back[1]), len(far[1])])
    optics = Optics.lambertian(2)
    optics.transmittance[1] = 0.4
    optics.tau[1] = 0.4
    optics.diffuse[1] = True
    tracer = Tracer(pts, faces, n, _grey(lum[None]), material, optics)
    ahead = dict(target=(0.0, 2.0, 1.0), size=(16, 12), fov_deg=20.0)
    assert np.allclose(tracer.render(Perspective(position=(0.0, -3.0, 1.0), **ahead),
                                     [1.0]).luminance, 5.0)
    assert np.allclose(tracer.render(Perspective(position=(0.0, 6.0, 1.0), **ahead),
                                     [1.0]).luminance, 2.0)
    # opaque, one layer, and a wall at y = −5 facing it (+y): a back face is passed, as the
    # raster culls it
    one = (front[0], front[1])
    near = _grid((-30.0, -5.0, -30.0), (0.0, 0.0, 60.0), (60.0, 0.0, 0.0), n=1)  # facing +y
    pts1, faces1 = _merge(one, near)
    n1 = _normals(pts1, faces1)
    assert np.allclose(n1[len(one[1]):], [0.0, 1.0, 0.0])
    lum1 = np.repeat([5.0, 3.0], [len(one[0]), len(near[0])])
    opaque = Tracer(pts1, faces1, n1, _grey(lum1[None]), np.zeros(len(faces1), int),
                    Optics.lambertian(1))
    back_view = Perspective(position=(0.0, 5.0, 1.0), target=(0.0, -5.0, 1.0), size=(16, 12),
                            fov_deg=20.0)
    assert np.allclose(opaque.render(back_view, [1.0]).luminance, 3.0)  # panel's back passed
    outside = Perspective(position=(0.0, -8.0, 1.0), **ahead)  # behind the near wall
    assert np.allclose(opaque.render(outside, [1.0]).luminance, 5.0)
