"""False-colour maps, checked by image content.

The map uses a fixed parallel-projection camera (``make_view``), so a world point maps to an exact
pixel. The tests sample pixels at known world positions and compare them with ``lux_to_rgb`` of
the lux there; the white background just outside the grid confirms the mapping independently.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pyvista")
mpimg = pytest.importorskip("matplotlib.image")

from lumijax.errors import GeometryError, OutputError  # noqa: E402
from lumijax.report import falsecolour_map, lux_to_rgb, make_view, nice_levels  # noqa: E402

SIZE = (800, 560)
TOL = 0.035  # per channel, RGB in [0, 1]: one LUT step is ~0.004; anti-aliasing, rounding


def _grid(nu=25, nv=11, lx=12.0, ly=5.0, z=0.85):
    """Cell centres of an lx × ly room grid, point index = i_u * nv + i_v (u along x)."""
    u = (np.arange(nu) + 0.5) * lx / nu
    v = (np.arange(nv) + 0.5) * ly / nv
    U, V = np.meshgrid(u, v, indexing="ij")
    return np.column_stack([U.ravel(), V.ravel(), np.full(U.size, z)]), U.ravel(), V.ravel()


def _load(path):
    img = mpimg.imread(path)
    assert img.dtype == np.float32 and img.shape[:2] == (SIZE[1], SIZE[0])
    return img[..., :3].astype(np.float64)


def _pixel_colour(img, view, world):
    col, row = view.pixel(world)
    return img[int(round(row - 0.5)), int(round(col - 0.5))]


def _is_dark(rgb):
    return rgb.sum() < 0.35  # contour lines are black; viridis' darkest colour sums to ~0.6


def _check_colours(img, view, pts_world, lux, vmin, vmax, scale):
    expected = lux_to_rgb(lux, vmin, vmax, scale)
    got = np.array([_pixel_colour(img, view, p) for p in pts_world])
    err = np.abs(got - expected).max(axis=1)
    assert err.max() < TOL, (err.max(), got[err.argmax()], expected[err.argmax()])


def test_linear_map_colours_lines_and_background(tmp_path):
    pts, U, V = _grid()
    lux = 100.0 + 50.0 * U  # 106.25 .. 693.75 lx, linear along u = x
    path = falsecolour_map(
        pts, lux, tmp_path / "map.png", shape=(25, 11), title="Linear ramp", window_size=SIZE
    )
    assert path == tmp_path / "map.png"
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]  # atomic: no temp leftovers
    img = _load(path)
    view = make_view(pts, None, SIZE)
    vmin, vmax = lux.min(), lux.max()
    levels = nice_levels(vmin, vmax)
    np.testing.assert_allclose(levels, [200, 300, 400, 500, 600])

    # Colours: sample between the iso-lines (x = 2.0 + 2k m + 1 m) at a quarter and three
    # quarters of the depth (labels sit on the lines near mid-depth).
    xs = np.array([1.0, 3.0, 5.0, 7.0, 9.0, 11.0, 11.5])
    sample = np.array([[x, y, 0.85] for x in xs for y in (1.2, 3.8)])
    _check_colours(img, view, sample, 100.0 + 50.0 * sample[:, 0], vmin, vmax, "linear")
    # It is a gradient, not a flat fill: the two ends differ strongly.
    assert (
        np.abs(
            _pixel_colour(img, view, [0.5, 1.2, 0.85]) - _pixel_colour(img, view, [11.5, 1.2, 0.85])
        ).max()
        > 0.5
    )

    # Iso-lines: level L lies at x = (L - 100) / 50; a black pixel within 2 px of it.
    for level in levels:
        x = (level - 100.0) / 50.0
        for y in (1.0, 4.0):
            col, row = view.pixel([x, y, 0.85])
            r, c = int(round(row - 0.5)), int(round(col - 0.5))
            patch = img[r - 1 : r + 2, c - 2 : c + 3]
            assert any(_is_dark(px) for px in patch.reshape(-1, 3)), (level, y)
    # ...and none between the lines.
    col0, row = view.pixel([2.2, 2.0, 0.85])
    col1, _ = view.pixel([3.8, 2.0, 0.85])
    strip = img[int(row), int(col0) : int(col1)]
    assert not any(_is_dark(px) for px in strip)

    # White background just beyond the grid's right edge (between grid and colour bar) and
    # above its top edge: the world->pixel mapping is right, not just self-consistent.
    # (cell centres span x 0.24-11.76 m, y 0.23-4.77 m)
    for world in ([11.76 + 0.3, 2.5, 0.85], [6.0, 4.77 + 0.3, 0.85]):
        np.testing.assert_allclose(_pixel_colour(img, view, world), 1.0, atol=0.02)
    # ... while just inside the edge the colour is the map's.
    _check_colours(
        img, view, np.array([[11.7, 2.5, 0.85]]), np.array([685.0]), vmin, vmax, "linear"
    )


def test_log_scale(tmp_path):
    pts, U, V = _grid(nu=41, nv=9)
    lux = 10.0 ** (1.0 + 2.0 * U / 12.0)  # 10 .. 1000 lx, log-linear along x
    path = falsecolour_map(
        pts, lux, tmp_path / "log.png", shape=(41, 9), title="Log", scale="log", window_size=SIZE
    )
    img = _load(path)
    view = make_view(pts, None, SIZE)
    vmin, vmax = lux.min(), lux.max()
    np.testing.assert_allclose(nice_levels(vmin, vmax, "log"), [20, 50, 100, 200, 500])
    xs = np.array([0.5, 1.3, 3.0, 4.6, 7.0, 8.9, 11.0])
    sample = np.array([[x, y, 0.85] for x in xs for y in (1.0, 4.0)])
    _check_colours(img, view, sample, 10.0 ** (1.0 + 2.0 * sample[:, 0] / 12.0), vmin, vmax, "log")
    # On a log scale, 100 lx (the geometric middle) has the colour-map's middle colour.
    mid = lux_to_rgb(100.0, 10.0, 1000.0, "log")
    np.testing.assert_allclose(mid, lux_to_rgb(0.5, 0.0, 1.0), atol=1e-12)


def test_unstructured_points_on_a_wall(tmp_path):
    rng = np.random.default_rng(1)
    q = np.vstack([[[0, 0], [1, 0], [0, 1], [1, 1]], rng.uniform(0, 1, (150, 2))])
    pts = np.column_stack([q[:, 0] * 6.0, np.full(len(q), 2.0), q[:, 1] * 3.0])  # wall y = 2
    lux = 50.0 + 100.0 * pts[:, 2]  # brighter upwards
    path = falsecolour_map(
        pts, lux, tmp_path / "wall.png", normal=[0, -1, 0], title="Wall", window_size=SIZE
    )
    img = _load(path)
    view = make_view(pts, [0, -1, 0], SIZE)
    np.testing.assert_allclose(view.up, [0, 0, 1], atol=1e-12)  # elevation: z up
    np.testing.assert_allclose(view.right, [1, 0, 0], atol=1e-12)  # seen from -y: x right
    sample = np.array([[x, 2.0, z] for x in (0.7, 2.1, 4.9) for z in (0.3, 1.25, 1.75, 2.7)])
    _check_colours(img, view, sample, 50.0 + 100.0 * sample[:, 2], lux.min(), lux.max(), "linear")


def test_write_is_atomic_on_failure(tmp_path, monkeypatch):
    import pyvista as pv

    pts, U, _ = _grid(nu=5, nv=4)
    target = tmp_path / "map.png"
    target.write_bytes(b"old")

    def broken(self, filename=None, *args, **kwargs):
        with open(filename, "wb") as fh:
            fh.write(b"partial")
        raise OSError("disk full")

    monkeypatch.setattr(pv.Plotter, "screenshot", broken)
    with pytest.raises(OutputError, match="disk full"):
        falsecolour_map(pts, U * 10, target, shape=(5, 4), title="x", window_size=(200, 150))
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]


def test_bad_inputs(tmp_path):
    pts, U, _ = _grid(nu=5, nv=4)
    out = tmp_path / "m.png"
    with pytest.raises(GeometryError, match="shape"):
        falsecolour_map(pts, U, out, shape=(4, 4), title="x")
    with pytest.raises(OutputError, match="NaN"):
        falsecolour_map(pts, np.where(U > 5, np.nan, U), out, shape=(5, 4), title="x")
    with pytest.raises(OutputError, match="folder does not exist"):
        falsecolour_map(pts, U, tmp_path / "no" / "m.png", shape=(5, 4), title="x")
    line = np.column_stack([np.arange(5.0), np.zeros(5), np.zeros(5)])
    with pytest.raises(GeometryError, match="collinear"):
        falsecolour_map(line, np.arange(5.0), out, title="x")
    with pytest.raises(OutputError, match="scale"):
        lux_to_rgb([1.0], 0.0, 1.0, "sqrt")
    with pytest.raises(OutputError, match="vmin > 0"):
        lux_to_rgb([1.0], 0.0, 1.0, "log")
    assert list(tmp_path.iterdir()) == []


def test_lux_to_rgb_ends_and_shape():
    rgb = lux_to_rgb(np.array([[0.0, 50.0, 100.0, 1e9]]), 0.0, 100.0)
    assert rgb.shape == (1, 4, 3)
    np.testing.assert_allclose(rgb[0, 0], rgb[0, 0].clip(0, 1))
    np.testing.assert_allclose(rgb[0, 2], rgb[0, 3])  # clipped above vmax
    # viridis: dark purple at the bottom, yellow at the top
    assert rgb[0, 0, 2] > rgb[0, 0, 1] and rgb[0, 2, 0] > 0.9 and rgb[0, 2, 1] > 0.85


def test_import_lumijax_report_does_not_import_pyvista():
    import subprocess
    import sys

    code = "import sys, lumijax.report, lumijax.spectral; print('pyvista' in sys.modules, 'colour' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]
