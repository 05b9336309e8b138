"""The numpy reference of ``benchmarks/small.py`` (``benchmarks/room_reference.py``), whose
figures judge issue 19's accuracy: its shadows and solid angles against closed forms, and the
closure of a closed room's factors (each point's visible parts tile its hemisphere)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "room_reference.py"


@pytest.fixture(scope="module")
def rr():
    spec = importlib.util.spec_from_file_location("room_reference", PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def corner_factor(a: float, b: float, c: float) -> float:
    """Factor from a differential area to a parallel a × b rectangle at distance c, the area's
    normal through one corner (Howell's catalogue, B-3)."""
    x, y = a / c, b / c
    sx, sy = math.sqrt(1 + x * x), math.sqrt(1 + y * y)
    return (x / sx * math.atan(y / sx) + y / sy * math.atan(x / sy)) / (2 * math.pi)


def corner_solid_angle(a: float, b: float, c: float) -> float:
    """Solid angle of an a × b rectangle from a point at distance c over one corner."""
    return math.atan(a * b / (c * math.sqrt(a * a + b * b + c * c)))


def square(x0, x1, y0, y1, z):
    """A horizontal rectangle facing down, corners counter-clockwise about −z."""
    return np.array([[[x0, y0, z], [x0, y1, z], [x1, y1, z], [x1, y0, z]]], float)


def test_a_plate_hides_the_exact_part(rr):
    # a point at the origin facing up, a 2 × 2 m ceiling square 2 m above centred on it, and a
    # thin plate 1 m up over x > 0 by exactly the part it hides: the cone through the plate
    # meets the ceiling at x > 0, so the visible part is the half x < 0
    x, n = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    ceiling = square(-1, 1, -1, 1, 2.0)
    whole = rr.point_to_squares(x, n, ceiling)[0, 0]
    assert whole == pytest.approx(4 * corner_factor(1, 1, 2), rel=1e-12)
    m = rr.cone_planes(x, (0.0, -5.0, 1.0), (5.0, 5.0, 1.01))
    a, b, valid = rr.clip_to_cone(ceiling, x, m)
    hidden = np.where(valid, rr.contour(a - x[:, None], b - x[:, None], n[:, None]), 0).sum()
    assert hidden == pytest.approx(2 * corner_factor(1, 1, 2), rel=1e-12)
    # a plate over one quadrant only (its corner on the axis): a quarter hidden
    m = rr.cone_planes(x, (0.0, 0.0, 1.0), (5.0, 5.0, 1.01))
    a, b, valid = rr.clip_to_cone(ceiling, x, m)
    hidden = np.where(valid, rr.contour(a - x[:, None], b - x[:, None], n[:, None]), 0).sum()
    assert hidden == pytest.approx(corner_factor(1, 1, 2), rel=1e-12)


def test_solid_angle_of_a_rectangle_and_its_lit_part(rr):
    eye = np.array([[0.0, 0.0, 3.0]])
    floor = square(0, 2, 0, 1, 0.0)
    a, b = floor, np.roll(floor, -1, axis=1)
    omega = rr.solid_angle(eye, floor.mean(axis=1), a, b, np.ones((1, 4), bool))[0]
    assert omega == pytest.approx(corner_solid_angle(2, 1, 3), rel=1e-12)
    # a plate at 1.5 m over x ∈ [0.5, 1] (y wide) shades x ∈ [1, 2] of the floor
    m = rr.cone_planes(eye, (0.5, -5.0, 1.5), (1.0, 5.0, 1.51))
    a, b, valid = rr.clip_to_cone(floor, eye, m)
    shaded = rr.solid_angle(eye, floor.mean(axis=1), a, b, valid)[0]
    assert shaded == pytest.approx(
        corner_solid_angle(2, 1, 3) - corner_solid_angle(1, 1, 3), rel=1e-9)


def test_a_furnished_room_s_factors_close(rr):
    """Every Gauss point's factors over a closed room with a table sum to 1: a shadow missed,
    counted twice or counted from behind shows there (the table's top seen from below once
    counted +0.9)."""
    case = SimpleNamespace(room=(3.0, 2.0, 2.5), obstacles=[((0.8, 0.6, 0.7), (2.0, 1.4, 0.75))])
    corners, normals, _, on_box, grids, box = rr._scene_squares(case, 0.5)
    pts = rr.gauss_points(corners)[0].reshape(-1, 3)
    nrm = np.repeat(normals, 9, axis=0)
    f = rr.point_to_squares(pts, nrm, corners)
    room = ~np.repeat(on_box, 9)
    assert np.abs(f[room].sum(axis=1) - 1).max() > 0.05  # without shadows: the table counts twice
    sub = f[room]
    rr._box_shadows(sub, pts[room], nrm[room], corners, grids, box)
    f[room] = sub
    assert np.abs(f.sum(axis=1) - 1).max() < 1e-12
