"""The traced pass on a computed study: a room with a polished floor under a downlight, drawn
by the report's realistic view (which traces when a material is specular) and by the
observers' fisheye of the glare section."""

from __future__ import annotations

import math
import textwrap
import warnings

import helpers as h
import numpy as np
import pytest

FLUX, DIAMETER, HEIGHT = 2000.0, 0.3, 2.95
RHO_S = 0.7


def _room() -> str:
    walls = [((0, 0, 0), (4, 0, 0), (0, 3, 0), "polished"),  # floor, facing +z
             ((0, 0, 3), (0, 3, 0), (4, 0, 0), "wall"),  # ceiling, facing −z
             ((0, 0, 0), (0, 0, 3), (4, 0, 0), "wall"),  # y = 0, facing +y
             ((0, 3, 0), (4, 0, 0), (0, 0, 3), "wall"),  # y = 3, facing −y
             ((0, 0, 0), (0, 3, 0), (0, 0, 3), "wall"),  # x = 0, facing +x
             ((4, 0, 0), (0, 0, 3), (0, 3, 0), "wall")]  # x = 4, facing −x
    return h.study_text(
        # direct light only: the pass draws whatever radiosity it is given, and it is quick
        h.table("solver", indirect=False, spectral_samples=4, cache=False),
        h.material("wall", 0.5),
        h.material("polished", 0.1, specular=RHO_S, roughness=0.002),
        h.photometry("down", "lambertian", FLUX, luminous_diameter_m=DIAMETER),
        h.network("n", 1.0),
        *(h.rectangle(o, u, v, m) for o, u, v, m in walls),
        h.lamp("D1", [2.0, 1.5, HEIGHT], photometry="down"),
        h.plane_grid("floor", [0, 0, 0.01], [4, 0, 0], [0, 3, 0], nu=4, nv=3),
        h.observer("desk", [0.6, 0.4, 1.2], look_at=[3.5, 2.6, 0.4]))


@pytest.fixture(scope="module")
def polished(tmp_path_factory):
    from lumijax import compute, load_study

    path = tmp_path_factory.mktemp("polished") / "study.toml"
    path.write_text(textwrap.dedent(_room()), encoding="utf-8")
    study = load_study(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return study, compute(study)


def test_realistic_view_mirrors_the_downlight(polished):
    from lumijax.report._camera import Camera
    from lumijax.report._surfaces import surface_light
    from lumijax.report._views import render_realistic, traced_xyz

    study, results = polished
    surface = surface_light(results)
    cam = Camera(name="c", position=(3.6, 2.7, 1.7), target=(2.0, 1.5, -HEIGHT),
                 fov_deg=40.0, size=(120, 90))
    xyz = traced_xyz(surface, study.scene, cam, results.design.dimmers)
    row, col = h.pinhole_pixel(cam, (2.0, 1.5, -HEIGHT), cam.size)
    source = FLUX / (math.pi * math.pi * (DIAMETER / 2) ** 2)  # Φ/(πA), every direction
    # the floor's own diffuse luminance there is a few cd/m² (ρ_d E/π, E ≈ 100 lx)
    floor = xyz[row, col, 1] - RHO_S * source
    assert 0.0 < floor < 10.0
    # the image is small: a step of a few pixels away there is the floor alone
    assert xyz[row + 6, col, 1] < 10.0
    img, ev = render_realistic(surface, cam, results.design.dimmers, study.scene)
    assert img.shape == (90, 120, 3)
    assert img[row, col].min() > 240 and img[row + 6, col].max() < img[row, col].min()


def test_glare_fisheye_traces_the_whole_scene(polished):
    from lumijax.report._glare import observer_fisheye

    study, results = polished
    image, ugr, lb = observer_fisheye(results, 0, size=96)
    lum = image.luminance
    assert lum.shape == (96, 96)
    seen = lum[image.camera.solid_angles() > 0]
    assert np.median(seen) > 0  # the walls, lit: the whole scene, not the sources only
    assert lum.max() > 1000.0  # the downlight (seen directly or in the floor)
    # L_b from the image against the eye's vertical illuminance without the sources: positive,
    # and no more than all the light the eye receives over π
    assert 0.0 < lb <= image.illuminance() / math.pi + 1e-9
