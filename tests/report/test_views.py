"""Views of surfaces, checked by content against closed forms.

Pixels are located with an independent pinhole projection (VTK's view angle is the vertical
field of view); colours are compared with ``lux_to_rgb`` (false colour) or with the documented
exposure and tone formulas written out here (realistic).
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import pinhole_pixel

pytest.importorskip("pyvista")

from lumijax.photometry import lambertian, spot  # noqa: E402
from lumijax.report import (  # noqa: E402
    Camera,
    auto_ev100,
    beam_angle_deg,
    beam_outline,
    ev100,
    exposure_scale,
    lux_to_rgb,
    polar_plot,
    render_falsecolour_view,
    render_realistic,
    tone_map,
)

SIZE = (640, 480)
D65 = np.array([0.95047, 1.0, 1.08883])


class Plate:
    """A flat 10 × 6 m plate at z = 0 facing up, as a structured triangle mesh, with whatever
    per-vertex values a test gives it (the duck type the renderers draw)."""

    def __init__(self, n=41, m=25):
        x, y = np.meshgrid(np.linspace(0, 10, n), np.linspace(0, 6, m), indexing="ij")
        self.points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
        a = (np.arange(n - 1)[:, None] * m + np.arange(m - 1)[None, :]).ravel()
        self.faces = np.concatenate([np.stack([a, a + m, a + m + 1], 1),
                                     np.stack([a, a + m + 1, a + 1], 1)])

    def polydata(self):
        import pyvista as pv

        return pv.PolyData(self.points, faces=np.column_stack(
            [np.full(len(self.faces), 3), self.faces]).ravel())


class UniformPlate(Plate):
    """The plate with one luminance everywhere, neutral (D65) colour."""

    networks = ("n",)

    def __init__(self, lum):
        super().__init__(5, 4)
        self.xyz = np.broadcast_to(lum * D65, (1, len(self.points), 3)).copy()
        self.normals = np.tile([0.0, 0.0, 1.0], (len(self.points), 1))
        self.area = np.full(len(self.faces), 60.0 / len(self.faces))
        self.patch_luminance = np.full((1, len(self.faces)), float(lum))

    def xyz_at(self, d):
        return np.einsum("k,kvc->vc", np.asarray(d, float), self.xyz)

    def luminance_at(self, d):
        return np.asarray(d, float) @ self.xyz[..., 1]

    @property
    def vertex_area(self):
        return np.bincount(self.faces.ravel(), np.repeat(self.area / 3, 3),
                           minlength=len(self.points))


def _camera(**kw):
    # straight down onto the plate's centre, x to the right, y up in the image
    return Camera(name="top", position=(5.0, 3.0, 12.0), target=(5.0, 3.0, 0.0),
                  up=(0.0, 1.0, 0.0), fov_deg=40.0, size=SIZE, **kw)


def test_falsecolour_pixel_matches_the_value_there():
    plate = Plate()
    value = 20.0 + 18.0 * plate.points[:, 0]  # 20 .. 200 cd/m², linear in x
    cam = _camera()
    img, (lo, hi) = render_falsecolour_view(plate, value, cam, scale="linear", clim=(0, 250),
                                            levels=[], frame=False)
    assert (lo, hi) == (0.0, 250.0)
    img = img.astype(float) / 255.0
    for x, y in [(0.7, 1.3), (2.2, 4.1), (5.0, 3.3), (7.9, 0.8), (9.3, 5.2)]:
        row, col = pinhole_pixel(cam, [x, y, 0.0], cam.size)
        expected = lux_to_rgb(20.0 + 18.0 * x, 0.0, 250.0, "linear")
        np.testing.assert_allclose(img[row, col], expected, atol=0.03, err_msg=f"{x, y}")
    # off the plate: the white page
    row, col = pinhole_pixel(cam, [-0.4, 3.0, 0.0], cam.size)
    np.testing.assert_allclose(img[row, col], 1.0, atol=0.01)


def test_falsecolour_log_scale_and_iso_lines():
    plate = Plate()
    value = 10.0 ** (0.2 * plate.points[:, 0])  # 1 .. 100, a decade per 5 m
    cam = _camera()
    img, _ = render_falsecolour_view(plate, value, cam, scale="log", clim=(1, 100), levels=[10],
                                     frame=False)
    img = img.astype(float) / 255.0
    # 10 (the log-middle) has the colour-map's middle colour; the iso-line at x = 5 is black
    row, col = pinhole_pixel(cam, [3.0, 2.0, 0.0], cam.size)
    np.testing.assert_allclose(img[row, col], lux_to_rgb(10 ** 0.6, 1, 100, "log"), atol=0.03)
    row, col = pinhole_pixel(cam, [5.0, 2.0, 0.0], cam.size)
    strip = img[row, col - 2: col + 3]
    assert strip.sum(axis=1).min() < 0.3, strip


def _filmic(x):  # Narkowicz 2015, as documented in docs/report.md
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0, 1)


def _srgb(c):
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def test_exposure_is_the_photographers():
    # a reflected-light meter (K = 12.5, ISO 100) reads EV100 = log2(L * 100 / 12.5)
    assert ev100(1.0) == pytest.approx(3.0)
    assert ev100(100.0) == pytest.approx(np.log2(800.0))
    # the metered luminance lands at 1 / 9.6 of saturation, and one EV is one stop
    assert 50.0 * exposure_scale(ev100(50.0)) == pytest.approx(1 / 9.6)
    assert exposure_scale(4.0) == pytest.approx(exposure_scale(3.0) / 2)
    # the meter reads the area-weighted median, ignoring unlit surfaces
    assert auto_ev100([0.0, 1.0, 2.0, 400.0], [5.0, 1.0, 3.0, 1.0]) == pytest.approx(ev100(2.0))
    # neutral white at the saturation luminance is display white with a linear (clip) camera
    ev = 5.0
    white = tone_map(D65 * 1.2 * 2**ev, ev, "clip")
    np.testing.assert_allclose(white, 1.0, atol=2e-3)
    # a warm lamp (CIE A, 2856 K) looks warm: red > green > blue
    rgb = tone_map(np.array([1.0985, 1.0, 0.3558]) * 10, ev100(10), "filmic")
    assert rgb[0] > rgb[1] > rgb[2]


def test_realistic_view_exposure_tone_and_stops():
    cam = _camera(tone="filmic")
    lum = 40.0
    img, ev = render_realistic(UniformPlate(lum), cam, [1.0])
    assert ev == pytest.approx(ev100(lum))  # metered on the only (uniform) luminance
    row, col = pinhole_pixel(cam, [5.0, 3.0, 0.0], cam.size)
    expected = _srgb(_filmic(np.full(3, lum / (1.2 * 2**ev))))  # neutral: R = G = B
    np.testing.assert_allclose(img[row, col] / 255.0, expected, atol=1.5 / 255)
    # twice the luminance one stop down is the same picture; twice at the same EV is brighter
    img2, _ = render_realistic(UniformPlate(2 * lum), cam, [1.0], ev=ev + 1)
    np.testing.assert_array_equal(img2, img)
    img3, _ = render_realistic(UniformPlate(2 * lum), cam, [1.0], ev=ev)
    assert img3[row, col].mean() > img[row, col].mean() + 10


def test_beam_angles_closed_form():
    # Lambertian: I = I0 cos γ is half the peak at γ = 60°, a 120° beam
    lam = lambertian(1000.0).distribution
    assert beam_angle_deg(lam) == pytest.approx(120.0, abs=0.5)
    peak, rim = beam_outline(lam)
    np.testing.assert_allclose(peak, [0, 0, -1], atol=1e-6)
    np.testing.assert_allclose(np.degrees(np.arccos(rim @ peak)), 60.0, atol=0.5)
    narrow = spot(1000.0, 24.0).distribution
    assert beam_angle_deg(narrow) == pytest.approx(24.0, abs=1.0)
    assert beam_angle_deg(narrow, 90.0) == pytest.approx(24.0, abs=1.0)


def test_polar_plot_is_a_drawn_png():
    png = polar_plot(spot(1000.0, 24.0), "spot 24°")
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    from io import BytesIO

    from PIL import Image

    img = np.asarray(Image.open(BytesIO(png)).convert("RGB"), float)
    # the C0-C180 curve is drawn in its dark blue (#1f4e79)
    blue = np.all(np.abs(img - [0x1F, 0x4E, 0x79]) < 30, axis=-1)
    assert blue.sum() > 100


def test_a_prerendered_polar_plot_is_the_report_s_and_the_same_picture():
    # report._prewarm draws the polar diagrams in the background; the report must get that
    # drawing for the same photometry and name, and it must be what drawing now would give
    import threading

    from lumijax.report._polar import prerender

    p = spot(1000.0, 30.0)
    fresh = polar_plot(p, "spot 30°")
    t = threading.Thread(target=prerender, args=({"spot 30°": p},))
    t.start()
    t.join()
    kept = polar_plot(p, "spot 30°")
    assert kept == fresh
    assert polar_plot(p, "spot 30°") is kept  # the kept bytes, not a new drawing
    assert polar_plot(p, "another name") != kept  # the name is part of the picture
