"""Cameras against their closed forms (projection radii, solid angles), and the image's UGR
and rough reflection against sums written here."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from lumijax.render import Fisheye, Optics, Perspective, Tracer, emitters_of
from lumijax.scene import AreaSource


def _cam_dir(theta_deg, phi_deg):
    """A direction θ off the axis (+y), at φ counter-clockwise from the image's right (+x)."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.cos(t), math.sin(t) * math.sin(p)])


@pytest.mark.parametrize("projection, radius", [
    ("equidistant", lambda t: t / (math.pi / 2)),
    ("equisolid", lambda t: math.sin(t / 2) / math.sin(math.pi / 4)),
    ("hemispherical", lambda t: math.sin(t)),
])
def test_fisheye_radius(projection, radius):
    cam = Fisheye(position=(0.0, 0.0, 0.0), target=(0.0, 1.0, 0.0), size=(200, 200),
                  projection=projection)
    row, col, inside = cam.pixel(_cam_dir(60.0, 30.0)[None])
    r = radius(math.radians(60.0)) * 100.0  # px from the centre (100, 100)
    assert inside[0]
    assert col[0] == pytest.approx(100.0 + r * math.cos(math.radians(30)), abs=1e-9)
    assert row[0] == pytest.approx(100.0 - r * math.sin(math.radians(30)), abs=1e-9)
    # and the rays through the pixel centres land back on them
    d, ok = cam.rays()
    rr, cc, ins = cam.pixel(d[ok])
    grid_c, grid_r = np.meshgrid(np.arange(200) + 0.5, np.arange(200) + 0.5)
    assert ins.all()
    assert np.allclose(rr, grid_r.ravel()[ok]) and np.allclose(cc, grid_c.ravel()[ok])


@pytest.mark.parametrize("projection", ["equidistant", "equisolid", "hemispherical"])
def test_fisheye_covers_the_hemisphere(projection):
    cam = Fisheye(position=(0.0, 0.0, 0.0), target=(1.0, 0.0, 0.0), size=(300, 300),
                  projection=projection)
    omega = cam.solid_angles()
    assert omega.sum() == pytest.approx(2 * math.pi, rel=1e-2)  # the rim's pixels: ~1 %
    if projection == "equisolid":  # equal area: every pixel the same solid angle
        inside = omega[omega > 0]
        assert np.allclose(inside, 2.0 * (2.0 / 300) ** 2, rtol=1e-4)


def test_perspective_solid_angle_is_the_pyramid():
    cam = Perspective(position=(0.0, 0.0, 0.0), target=(0.0, 1.0, 0.0), size=(160, 90),
                      fov_deg=50.0)
    half_v = math.radians(25.0)
    half_h = math.atan(math.tan(half_v) * 160 / 90)
    pyramid = 4.0 * math.asin(math.sin(half_h) * math.sin(half_v))
    assert cam.solid_angles().sum() == pytest.approx(pyramid, rel=1e-3)


def _box(lo, hi):
    """Inward-facing triangles of an axis-aligned box."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    c = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)])
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tri = np.array([[c[q[0]], c[q[i]], c[q[i + 1]]] for q in quads for i in (1, 2)])
    centre = 0.5 * (np.asarray(lo) + np.asarray(hi))
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", n, centre - tri[:, 0]) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return tri


def _tracer_of(tri, vertex_lum, optics, scene=None, **kw):
    pts = tri.reshape(-1, 3)
    faces = np.arange(len(pts)).reshape(-1, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    xyz = np.repeat(np.broadcast_to(vertex_lum, (len(pts),))[None, :, None], 3, axis=2)
    return Tracer(pts, faces, n, xyz, np.zeros(len(tri), int), optics,
                  None if scene is None else emitters_of(scene), **kw)


def test_image_ugr_of_one_source_in_a_uniform_room():
    from lumijax.glare import position_index

    lw = 20.0  # cd/m² of every wall
    tri = _box((-5.0, -5.0, -5.0), (5.0, 5.0, 5.0))
    # a square Lambertian panel 0.6 m, 3 m ahead and 1 m up, facing the eye
    side, centre = 0.6, np.array([0.0, 3.0, 1.0])
    lum_src, flux = 4000.0, 4000.0 * math.pi * side * side
    panel = AreaSource(name="P", origin=centre + [-side / 2, 0.0, -side / 2],
                       u=np.array([side, 0.0, 0.0]), v=np.array([0.0, 0.0, side]),
                       flux_lm=flux, network="n")
    assert np.allclose(panel.normal, [0.0, -1.0, 0.0])
    scene = SimpleNamespace(luminaires=(), photometries={}, network_names=("n",),
                            area_sources=(panel,))
    tracer = _tracer_of(tri, lw, Optics.lambertian(1), scene)
    cam = Fisheye(position=(0.0, 0.0, 0.0), target=(0.0, 1.0, 0.0), size=(400, 400))
    img = tracer.render(cam, [1.0])
    ugr, lb = img.ugr()
    d = centre / np.linalg.norm(centre)
    omega = side * side * d[1] / float(centre @ centre)  # A cos / r², a small source
    p = float(position_index(d[None], np.array([0.0, 1.0, 0.0]))[0])
    lb_expect = lw * (1.0 - omega * d[1] / math.pi)  # the hemisphere less the panel's part
    expect = 8.0 * math.log10(0.25 / lb_expect * lum_src ** 2 * omega / p ** 2)
    assert lb == pytest.approx(lb_expect, rel=1e-2)
    assert ugr == pytest.approx(expect, abs=0.3)


def _ward_albedo(theta_i: float, alpha: float, n: int = 600) -> float:
    """∫ f_Ward cos θ_o dω_o over the hemisphere by the midpoint rule, for the isotropic Ward
    BRDF ``exp(−tan²δ/α²) / (4πα² √(cos θ_i cos θ_o))`` (ρ_s = 1) as docs/render.md states it."""
    i = np.array([math.sin(theta_i), 0.0, math.cos(theta_i)])
    t = (np.arange(n) + 0.5) * (math.pi / 2) / n
    p = (np.arange(2 * n) + 0.5) * math.pi / n
    tt, pp = np.meshgrid(t, p, indexing="ij")
    o = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1)
    h = o + i
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    tan2 = (1.0 - h[..., 2] ** 2) / h[..., 2] ** 2
    f = np.exp(-tan2 / alpha ** 2) / (4 * math.pi * alpha ** 2 * np.sqrt(i[2] * o[..., 2]))
    return float(np.sum(f * o[..., 2] * np.sin(tt)) * (math.pi / 2 / n) * (math.pi / n))


def test_rough_floor_reflects_the_ward_lobe_of_a_uniform_sky():
    """A glossy floor (Ward α = 0.1) under a uniform emitting ceiling of luminance L: each
    pixel is ρ_s L times the lobe's directional albedo at its incidence, integrated here by
    quadrature (it falls roughly as cos θ_i for this normalisation: 0.97 at 0°, 0.69 at 45°)."""
    big, alpha, rho_s, sky_l = 400.0, 0.1, 0.4, 100.0
    tri = np.array([[[-big, -big, 0.0], [big, -big, 0.0], [big, big, 0.0]],
                    [[-big, -big, 0.0], [big, big, 0.0], [-big, big, 0.0]]])
    sky = AreaSource(name="S", origin=np.array([-big, -big, 3.0]),
                     u=np.array([0.0, 2 * big, 0.0]), v=np.array([2 * big, 0.0, 0.0]),
                     flux_lm=math.pi * sky_l * (2 * big) ** 2, network="n")
    assert np.allclose(sky.normal, [0.0, 0.0, -1.0])
    scene = SimpleNamespace(luminaires=(), photometries={}, network_names=("n",),
                            area_sources=(sky,))
    optics = Optics.lambertian(1)
    optics.specular[0] = rho_s
    optics.roughness[0] = alpha
    # Ward's own albedo is what is checked: its lobe named (the tracer's default is "wgmd")
    tracer = _tracer_of(tri, 0.0, optics, scene, depth=1, lobe_rays=8, lobe="ward")
    cam = Perspective(position=(0.0, 0.0, 1.5), target=(0.0, 1.5, 0.0), size=(60, 60),
                      fov_deg=20.0)
    lum = tracer.render(cam, [1.0]).luminance
    d, _ = cam.rays()
    theta = np.arccos(-d[:, 2])
    table_t = np.linspace(theta.min(), theta.max(), 9)
    table = [_ward_albedo(t, alpha) for t in table_t]
    expect = rho_s * sky_l * np.interp(theta, table_t, table)
    assert lum.mean() == pytest.approx(expect.mean(), rel=0.02)
    assert lum.std() > 0  # sampled, not a mirror
