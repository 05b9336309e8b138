"""The desktop dimmer viewer, off-screen: a slider at zero darkens exactly its network's room.

The two rooms are closed boxes, each lit by its own network, so after setting the left dimmer to
0 the left room must be black and the right room unchanged, to the last bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import pinhole_pixel

pytest.importorskip("pyvista")

from lumijax.view import build_viewer  # noqa: E402


@pytest.fixture(scope="module")
def viewer(two_rooms):
    study, results = two_rooms
    v = build_viewer(study, results, off_screen=True, window_size=(640, 400))
    yield v
    v.plotter.close()


def test_slider_at_zero_darkens_exactly_its_network(viewer):
    left = viewer.surface.points[:, 0] < 4.0
    assert viewer.networks == ("left", "right")
    before = viewer.colours().copy()
    glow0 = np.asarray(viewer.fittings.point_data["rgb"]).reshape(2, -1, 3).copy()  # L1, R1
    img0 = viewer.screenshot()
    assert before[left].max() > 100 and before[~left].max() > 50  # both rooms lit
    viewer.set_dimmer("left", 0.0)
    after = viewer.colours()
    assert after[left].max() == 0  # black: its light was all the left room had
    np.testing.assert_array_equal(after[~left], before[~left])
    glow1 = np.asarray(viewer.fittings.point_data["rgb"]).reshape(2, -1, 3)
    assert glow1[0].max() < glow0[0].max() - 100  # the left fitting went out
    np.testing.assert_array_equal(glow1[1], glow0[1])
    # the picture: a floor point of each room, found by an independent projection
    img1 = viewer.screenshot()
    size = (img0.shape[1], img0.shape[0])
    rl, cl = pinhole_pixel(viewer.camera, [1.0, 2.2, 0.0], size)
    rr, cr = pinhole_pixel(viewer.camera, [6.5, 2.2, 0.0], size)
    assert img0[rl, cl].max() > 20 and img1[rl, cl].max() == 0
    np.testing.assert_array_equal(img1[rr, cr], img0[rr, cr])
    # back up: the picture is the same as before (the exposure never moved)
    viewer.set_dimmer("left", 1.0)
    np.testing.assert_array_equal(viewer.colours(), before)


def test_dimming_is_superposition(viewer):
    viewer.set_dimmer("left", 0.3)
    viewer.set_dimmer("right", 0.8)
    lum = viewer.surface.luminance_at(viewer.dimmers)
    full = [viewer.surface.luminance_at(np.eye(2)[k]) for k in range(2)]
    np.testing.assert_allclose(lum, 0.3 * full[0] + 0.8 * full[1], rtol=1e-12)
    with pytest.raises(KeyError, match="networks: left, right"):
        viewer.set_dimmer("nope", 1.0)


def test_false_colour_toggle(viewer):
    from lumijax.report import lux_to_rgb

    viewer.set_dimmer("left", 1.0)
    viewer.set_mode("falsecolour")
    rgb = viewer.colours() / 255.0
    lum = viewer.surface.luminance_at(viewer.dimmers)
    np.testing.assert_allclose(rgb, lux_to_rgb(lum, *viewer.clim, "log"), atol=0.5 / 255)
    img = viewer.screenshot()
    assert viewer.bar.GetVisibility() and not viewer.actor.GetVisibility()
    viewer.set_mode("realistic")
    assert not np.array_equal(img, viewer.screenshot())
    with pytest.raises(ValueError):
        viewer.set_mode("x-ray")
