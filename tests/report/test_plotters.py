"""A picture drawn in a lent plotter (``report._plotters``: kept from an earlier picture of its
size) is the picture a new plotter draws, pixel for pixel: every map, view and false-colour
view of a sequence that mixes sizes, scales, iso-lines, luminaires and camera kinds (parallel
maps and perspective views in one plotter) is drawn twice, once in new plotters, once lent."""

from __future__ import annotations

import numpy as np
import pytest
from test_views import Plate, UniformPlate, _camera

pv = pytest.importorskip("pyvista")

from lumijax.report import (  # noqa: E402
    _plotters,  # noqa: E402
    render_falsecolour_view,
    render_realistic,
)
from lumijax.report._falsecolour import falsecolour_map  # noqa: E402

SMALL = (320, 240)


def _map(tmp_path, name, *, log=False, levels=None, luminaires=(), size=SMALL, shape=True):
    u, v = np.meshgrid(np.linspace(0, 10, 21), np.linspace(0, 6, 13), indexing="ij")
    p = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)])
    e = 30.0 + 25.0 * np.sin(0.6 * u.ravel()) * np.cos(0.8 * v.ravel()) + (5.0 if log else 0)
    path = falsecolour_map(p, e, tmp_path / f"{name}.png", shape=u.shape if shape else None,
                           title=name, scale="log" if log else "linear", levels=levels,
                           window_size=size, luminaires=luminaires)
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"))


def _sequence(tmp_path):
    plate = Plate()
    value = 20.0 + 18.0 * plate.points[:, 0]
    cam = _camera().replace(size=SMALL)
    lums = [((5.0, 3.0, 4.0), (0.3, 0.0, -0.95)), ((2.0, 1.0, 4.0), (0.0, 0.0, -1.0))]
    return [
        _map(tmp_path, "a"),
        render_falsecolour_view(plate, value, cam, levels=[100.0], frame=False)[0],
        _map(tmp_path, "b", log=True, luminaires=lums),
        render_realistic(UniformPlate(40.0), cam, [1.0])[0],
        _map(tmp_path, "c", levels=[], shape=False),
        _map(tmp_path, "d", size=(400, 300)),
        render_falsecolour_view(plate, value, cam, scale="log", clim=(10, 300), levels=[],
                                frame=False)[0],
        _map(tmp_path, "e", luminaires=lums),
    ]


def test_a_lent_plotter_draws_what_a_new_one_draws(tmp_path, monkeypatch):
    _plotters.close_all()
    monkeypatch.setenv("LUMIJAX_REUSE_PLOTTERS", "0")
    (tmp_path / "new").mkdir()
    fresh = _sequence(tmp_path / "new")
    assert not _plotters._kept  # reuse off: nothing kept
    monkeypatch.setenv("LUMIJAX_REUSE_PLOTTERS", "1")
    (tmp_path / "lent").mkdir()
    lent = _sequence(tmp_path / "lent")
    assert set(_plotters._kept) == {SMALL, (400, 300)}  # one window per size, reused
    for i, (a, b) in enumerate(zip(fresh, lent, strict=True)):
        assert a.shape == b.shape, i
        np.testing.assert_array_equal(a, b, err_msg=f"picture {i}")
    _plotters.close_all()
    assert not _plotters._kept


def test_a_picture_that_fails_does_not_keep_its_plotter():
    _plotters.close_all()
    with pytest.raises(RuntimeError), _plotters.plotter(SMALL) as pl:
        pl.add_mesh(pv.Sphere())
        raise RuntimeError("drawing failed")
    assert not _plotters._kept
