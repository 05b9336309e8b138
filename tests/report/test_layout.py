"""Nothing covers a picture: the false-colour view's title, note and colour bar lie outside the
scene at every aspect ratio, and an iso-lux map's rulers run over all of its data.

The scene's box is found by content: the bare render (``frame=False``) is looked for, pixel for
pixel, inside the framed picture; text and bar pixels are then located by colour."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pyvista")

from test_views import Plate, _camera  # noqa: E402

from lumijax.report import falsecolour_map, make_view, render_falsecolour_view  # noqa: E402

LONG = "Luminance — a camera with a name far too long for a narrow picture, going on and on"


def _find(big: np.ndarray, small: np.ndarray) -> tuple[int, int]:
    """The one (row, col) where ``small`` sits inside ``big``, pixel for pixel."""
    h, w = small.shape[:2]
    r0, c0 = h // 2, w // 2
    patch = small[r0:r0 + 6, c0:c0 + 6]
    win = np.lib.stride_tricks.sliding_window_view(big, patch.shape)[..., 0, :, :, :]
    hits = np.argwhere(np.all(win == patch, axis=(-3, -2, -1)))
    found = [(r - r0, c - c0) for r, c in hits
             if r >= r0 and c >= c0 and np.array_equal(big[r - r0:r - r0 + h, c - c0:c - c0 + w],
                                                        small)]
    assert len(found) == 1, f"the scene is not in the picture unchanged ({len(found)} places)"
    return found[0]


def _bands(mask_rows: np.ndarray) -> list[tuple[int, int]]:
    """Runs of consecutive True rows: (first, last)."""
    rows = np.flatnonzero(mask_rows)
    if rows.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(rows) > 1)
    starts = np.concatenate([[rows[0]], rows[cuts + 1]])
    ends = np.concatenate([rows[cuts], [rows[-1]]])
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


@pytest.mark.parametrize("size", [(480, 360), (240, 420), (640, 180)])
def test_titles_and_bar_stay_off_the_scene(size):
    plate = Plate(21, 13)
    value = 20.0 + 18.0 * plate.points[:, 0]
    cam = _camera().replace(size=size)
    bare, clim = render_falsecolour_view(plate, value, cam, scale="log", frame=False)
    framed, clim2 = render_falsecolour_view(plate, value, cam, scale="log", title=LONG)
    assert clim2 == clim and bare.shape[:2] == (size[1], size[0])
    r, c = _find(framed, bare)  # nothing is drawn over the scene
    h, w = bare.shape[:2]
    img = framed.astype(float) / 255
    outside = np.ones(img.shape[:2], bool)
    outside[r:r + h, c:c + w] = False
    grey = np.ptp(img, axis=-1) < 0.08
    text = grey & (img.mean(axis=-1) < 0.55) & outside
    # the title and the note: two separate lines of text above the scene
    header = text[:r]
    bands = _bands(header.any(axis=1))
    assert len(bands) >= 2, bands
    assert header.sum() > 100
    # nothing cut at the picture's right edge: the long title was fitted
    assert not text[:r, -2:].any()
    # the colour bar: viridis' ends (dark purple, yellow) right of the scene, below the header
    purple = np.all(np.abs(img - [0.267, 0.005, 0.329]) < 0.06, axis=-1) & outside
    yellow = np.all(np.abs(img - [0.993, 0.906, 0.144]) < 0.06, axis=-1) & outside
    assert purple.sum() > 20 and yellow.sum() > 20
    bar = np.argwhere(purple | yellow)
    assert bar[:, 1].min() >= c + w and bar[:, 0].min() > max(b[1] for b in bands)
    # and the bar's labels do not sit on the bar itself
    b0, b1 = bar[:, 1].min(), bar[:, 1].max()
    rows = slice(bar[:, 0].min() + 3, bar[:, 0].max() - 3)
    assert not text[rows, b0 + 2:b1 - 1].any()


@pytest.mark.parametrize("size", [(800, 560), (500, 700)])
def test_map_rulers_cover_the_data(tmp_path, size):
    # a grid whose edges fall between round metres: 0.37 .. 12.67 m by 1.13 .. 6.23 m
    nu, nv = 25, 11
    u = 0.37 + (np.arange(nu) + 0.5) * 12.3 / nu
    v = 1.13 + (np.arange(nv) + 0.5) * 5.1 / nv
    U, V = np.meshgrid(u, v, indexing="ij")
    pts = np.column_stack([U.ravel(), V.ravel(), np.full(U.size, 0.85)])
    path = falsecolour_map(pts, 100 + 50 * U.ravel(), tmp_path / "m.png", shape=(nu, nv),
                           title="ramp", window_size=size, levels=[])
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB"), float) / 255
    view = make_view(pts, None, size)
    (c_lo, r_hi), (c_hi, r_lo) = view.pixel([u.min(), v.min(), 0.85]), view.pixel(
        [u.max(), v.max(), 0.85])
    dark = img.sum(axis=-1) < 0.5
    # the horizontal ruler: the longest run of dark pixels in a row below the grid
    below = dark[int(r_hi) + 3:int(r_hi) + 40]
    row = below[np.argmax(below.sum(axis=1))]
    cols = np.flatnonzero(row)
    assert cols.min() <= c_lo and cols.max() >= c_hi - 1
    # the vertical ruler: the longest column of dark pixels left of the grid
    left = dark[:, int(c_lo) - 40:int(c_lo) - 3]
    col = left[:, np.argmax(left.sum(axis=0))]
    rows = np.flatnonzero(col)
    assert rows.min() <= r_lo + 1 and rows.max() >= r_hi - 1


def test_map_draws_the_luminaires_over_it(tmp_path):
    size = (800, 560)
    nu, nv = 25, 11
    U, V = np.meshgrid((np.arange(nu) + 0.5) * 12.3 / nu, (np.arange(nv) + 0.5) * 5.1 / nv,
                       indexing="ij")
    pts = np.column_stack([U.ravel(), V.ravel(), np.full(U.size, 0.85)])
    down, slanted, away = ((3.0, 2.5, 2.8), (0, 0, -1.0)), ((8.0, 1.0, 2.8), (0.6, 0.6, -0.5)), (
        (30.0, 1.0, 2.8), (0, 0, -1.0))
    path = falsecolour_map(pts, 100 + 50 * U.ravel(), tmp_path / "m.png", shape=(nu, nv),
                           title="ramp", window_size=size, levels=[],
                           luminaires=[down, slanted, away])
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB"), float) / 255
    view = make_view(pts, None, size)

    def dark(col, row):
        return img[int(round(row - 0.5)), int(round(col - 0.5))].sum() < 0.3

    for pos, _ in (down, slanted):  # a dot where each stands, seen from above
        assert dark(*view.pixel(pos))
    # the slanted one's aim runs up and to the right in the plan (its x, y components), the
    # downlight has none
    c, r = view.pixel(slanted[0])
    step = np.array([1.0, -1.0]) / np.sqrt(2)  # image rows grow downwards
    assert dark(*(np.array([c, r]) + 15 * step)) and not dark(*(np.array([c, r]) - 15 * step))
    c, r = view.pixel(down[0])
    assert not any(dark(c + dx, r + dy) for dx, dy in ((15, 0), (-15, 0), (0, 15), (0, -15)))
    # two marks on the grid, not three: the one 30 m away is not on the drawing
    from scipy import ndimage

    (c0, r1), (c1, r0) = view.pixel(pts.min(axis=0)), view.pixel(pts.max(axis=0))
    inside = img[int(r0) + 2:int(r1) - 2, int(c0) + 2:int(c1) - 2].sum(axis=-1) < 0.3
    assert ndimage.label(inside)[1] == 2


def test_iso_lux_lines_follow_the_smoothed_field_on_noisy_grids():
    from lumijax.report._falsecolour import contour_field

    nu, nv = 40, 20
    U, _ = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    clean = (100 + 400 * U).ravel()
    noisy = clean + np.random.default_rng(1).normal(0, 15, clean.shape)  # ~ 1.5 cells of slope

    def rows_crossing_once(field, level=300.0):
        f = np.asarray(field).reshape(nu, nv) - level
        return np.mean((np.diff(np.sign(f), axis=0) != 0).sum(axis=0) == 1)

    # a clean field is contoured as it is; a noisy one breaks the 300 lx line into wiggles and
    # rings (rows crossing it more than once) until it is smoothed
    assert np.array_equal(contour_field(clean, (nu, nv)), clean)
    assert rows_crossing_once(noisy) < 0.8
    assert rows_crossing_once(contour_field(noisy, (nu, nv))) == 1.0
    # the 1-2-1 filter keeps a linear ramp inside the grid: the line stays where it was
    smooth = contour_field(noisy, (nu, nv)).reshape(nu, nv)
    assert np.abs(smooth - noisy.reshape(nu, nv)).mean() < 15
    assert np.abs(smooth[1:-1].mean(axis=1) - clean.reshape(nu, nv)[1:-1].mean(axis=1)).max() < 8
    assert np.array_equal(contour_field(noisy, None), noisy)  # unstructured: as computed
