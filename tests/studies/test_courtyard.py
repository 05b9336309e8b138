"""The courtyard generator (studies/courtyard/make_courtyard.py) and the bundled default study."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from lumijax import load_study
from lumijax.cli import default_study_path

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def gen():
    spec = importlib.util.spec_from_file_location(
        "make_courtyard", ROOT / "studies" / "courtyard" / "make_courtyard.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up while the class is built
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def tiny(gen, tmp_path_factory):
    """Two facades of two bays, one flood per facade and one path light per path."""
    c = gen.Courtyard(facades=("S", "E"), bays=2, floods_per_facade=1, paths_per_path=1,
                      target_patches=200, optimise=False)
    folder = tmp_path_factory.mktemp("courtyard")
    gen.write_study(c, folder / "study.toml", folder / "assets", "test")
    return c, load_study(folder / "study.toml")


def test_counts_follow_the_bays(tiny):
    c, study = tiny
    sc = study.scene
    by_phot = Counter(lum.photometry for lum in sc.luminaires)
    storeys, facades, bays = 3, 2, 2
    assert by_phot["column"] == facades * bays * 2 * storeys  # two columns per bay and storey
    assert by_phot["washer"] == facades * bays * 3 * storeys  # three bars under each cornice
    assert by_phot["window"] == facades * bays * storeys
    assert by_phot["flood"] == 2 and by_phot["path"] == 2
    assert len(sc.luminaires) == c.luminaire_count() == 76
    assert {n.name for n in sc.networks} == {
        "S-wash", "S-attic", "S-columns", "S-windows", "E-wash", "E-attic", "E-columns",
        "E-windows", "floods", "paths"}


def test_four_facades_make_eighteen_networks(gen):
    c = gen.FULL
    nets = c.networks()
    assert len(nets) == len(set(nets)) == 18
    # the paper's ~3,000 fittings: 4 facades × 40 bays × 18 per bay + 96 floods + 24 path lights
    assert c.luminaire_count() == 4 * 40 * 18 + 96 + 24 == 3000


def test_column_spots_hit_their_columns(tiny):
    """Each column spot's beam axis (from aim_at) meets a column face just in front of it."""
    c, study = tiny
    sc = study.scene
    spots = [lum for lum in sc.luminaires if lum.photometry == "column"]
    pos = np.array([lum.position for lum in spots])
    axis = np.array([lum.axis for lum in spots])
    tri, dist = sc.raycaster.first_hit(pos, axis)
    assert np.all(tri >= 0)
    hit = pos + dist[:, None] * axis
    n = sc.triangles.normals[tri]
    # the column front is 0.35 m in front of the spot, horizontally; the face is vertical
    # and faces the spot; the hit is on the storey's shaft, below its cornice
    horizontal = np.linalg.norm((hit - pos)[:, :2], axis=1)
    assert np.all((horizontal > 0.3) & (horizontal < 0.5))
    assert np.all(np.abs(n[:, 2]) < 1e-9)
    assert np.all(np.einsum("ij,ij->i", n, axis) < 0)
    assert np.all(hit[:, 2] - pos[:, 2] > 1.0)
    tops = np.array([z1 - h for (_, z1), h in zip(c.levels, c.cornice_height, strict=True)])
    assert np.all(hit[:, 2] < tops.max())


def test_washers_light_the_wall_below_them(tiny):
    """The bars hang under the cornices and their beam axis leans towards the wall."""
    _, study = tiny
    sc = study.scene
    washers = [lum for lum in sc.luminaires if lum.photometry == "washer"]
    assert all(lum.axis[2] < -0.99 for lum in washers)  # top-down
    pos = np.array([lum.position for lum in washers])
    # the wall is hit when the beam's main lobe (8° towards the wall) is followed: cast
    # from each bar to its facade, 0.55 m behind, horizontally
    tri, dist = sc.raycaster.first_hit(pos, np.array([_towards_wall(p) for p in pos]))
    assert np.all(tri >= 0) and np.all(dist < 0.6)


def _towards_wall(p):
    # S facade: wall at y = 0 (look −y); E facade: wall at x = L (look +x)
    return np.array([0.0, -1.0, 0.0]) if p[1] < 1.0 else np.array([1.0, 0.0, 0.0])


def test_corner_cornices_meet_without_coincident_faces(gen, tmp_path):
    """At each court corner the two facades' cornice boxes make one L: no face lies on another
    facing the same way (the load's warning: light counted twice), and no hole is left."""
    import warnings

    from lumijax.errors import LumijaxWarning

    c = gen.Courtyard(bays=1, floods_per_facade=1, paths_per_path=1, target_patches=200,
                      optimise=False)
    gen.write_study(c, tmp_path / "study.toml", tmp_path / "assets", "test")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        study = load_study(tmp_path / "study.toml")
    twice = [str(w.message) for w in caught
             if issubclass(w.category, LumijaxWarning) and "counted twice" in str(w.message)]
    assert twice == []
    # straight down onto each corner square's three cells (cornice depth d, corner pier p):
    # the corner cell, and the two arms; every storey's cornice top is hit (attic first)
    L, d, p = c.side, c.cornice_depth, c.corner
    cells = []
    for cx, cy, sx, sy in ((0, 0, 1, 1), (L, 0, -1, 1), (L, L, -1, -1), (0, L, 1, -1)):
        for u, v in ((d / 2, d / 2), ((d + p) / 2, d / 2), (d / 2, (d + p) / 2)):
            cells.append((cx + sx * u, cy + sy * v))
    pos = np.array([(x, y, c.levels[-1][1] + 1.0) for x, y in cells])
    tri, dist = study.scene.raycaster.first_hit(pos, np.tile([0.0, 0.0, -1.0], (len(pos), 1)))
    assert np.all(tri >= 0)
    np.testing.assert_allclose(dist, 1.0, atol=1e-6)


def test_level_of_detail_keeps_the_wall_and_rounds_the_columns(gen):
    """Finer levels add triangles; the flat surfaces keep their area, and the columns' area is
    that of half n-gon prisms (n·r·sin(π/n) per half perimeter), tending to π·r per half."""
    c = gen.FULL
    flat, counts = [], []
    for lod, sides in enumerate((8, 16, 24, 32)):
        stone, _ = gen.bay_triangles(dataclasses.replace(c, lod=lod))
        a = 0.5 * np.linalg.norm(np.cross(stone[:, 1] - stone[:, 0], stone[:, 2] - stone[:, 0]),
                                 axis=1)
        columns = sum(2 * (sides // 2) * 2 * r * math.sin(math.pi / sides) * (z1 - h - z0)
                      for r, (z0, z1), h in zip(c.column_radius, c.levels, c.cornice_height,
                                                strict=True))
        flat.append(a.sum() - columns)
        counts.append(len(stone))
    assert counts == sorted(counts) and counts[-1] * 4 * 40 > 9e5  # ~10⁶ at full scale
    # wall: bay × shaft height per storey, less the window, plus the four reveals
    expected = 0.0
    for s, ((z0, z1), h) in enumerate(zip(c.levels, c.cornice_height, strict=True)):
        x0, x1, wz0, wz1 = c.windows(s)
        w, hw = x1 - x0, wz1 - wz0
        expected += c.bay_width * (z1 - h - z0) - w * hw + 2 * c.recess * (w + hw)
    np.testing.assert_allclose(flat, expected, rtol=1e-9)


def test_bundled_default_study_is_the_courtyard_corner():
    study = load_study(default_study_path())
    sc = study.scene
    assert 200 <= len(sc.luminaires) <= 400
    assert len(sc.networks) == 10
    assert {g.name for g in sc.grids} == {"S-wall", "S-columns", "E-wall", "E-columns",
                                          "court", "paths-eye"}
    data = default_study_path().parent
    for f in study.config.photometry.values():
        if hasattr(f, "file"):
            assert f.file.is_relative_to(data)  # shipped with the package
    assert study.config.optimise is not None and study.config.optimise.variables == ["dimmers"]
    # glare is judged by the visitors' GR (EN 12464-2's GR_L 50 for walkways), not by a vertical
    # illuminance at eye height: a constrained design with one GR ceiling for every observer
    opt = study.config.optimise
    assert opt.objective == "power"
    assert [(c.criterion, c.observer, c.max) for c in opt.constraints] == [("gr", None, 50.0)]
    assert next(g for g in study.config.grids if g.name == "paths-eye").max_lux is None
    assert len(study.config.observers) == 4
