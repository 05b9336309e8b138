"""The patch count from ``[solver] accuracy`` (docs/radiosity.md, "Patch count against an
accuracy target"): the lengths it reads off the scene against closed forms, and an explicit
``target_patches`` or ``patch_size`` meshing exactly as before the rule."""

from __future__ import annotations

import helpers as h
import numpy as np
import pytest

from lumijax import load_study
from lumijax._study import check_memory, solver_settings
from lumijax.lighting._settings import (
    AUTO_PATCH_CAP,
    PATCH_SIZE_PER_PATH,
    PATCH_SIZE_PER_SOURCE_DISTANCE,
    accuracy_patch_size,
    auto_patch_size,
    mean_free_path,
    source_distance,
)
from lumijax.lighting._stages import patch_size_of


def _room(write_study, hi, lamps, solver=None, scale=1.0, photometry="iso"):
    parts = [h.material("wall", 0.5), h.photometry("iso", "isotropic", 1000),
             h.photometry("down", "lambertian", 1000), h.network("n"),
             h.box([0, 0, 0], [scale * x for x in hi])]
    parts += [h.lamp(f"L{i}", [scale * x for x in p], "n", photometry)
              for i, p in enumerate(lamps)]
    parts.append(h.point_grid("p", [[scale * hi[0] / 2, scale * hi[1] / 2, scale * 0.8]]))
    if solver:
        parts.append(h.table("solver", **solver))
    return load_study(write_study(h.study_text(*parts)))


def test_mean_free_path_of_a_box_is_cauchys_4v_over_s(write_study):
    # Cauchy: the mean chord of a convex body under cosine-weighted (isotropic) entry is 4V/S
    study = _room(write_study, (4.0, 3.0, 2.5), [(2, 1.5, 2)])
    v, s = 4 * 3 * 2.5, 2 * (12 + 10 + 7.5)
    tri = study.scene.triangles
    assert mean_free_path(tri.vertices, study.scene.raycaster) == pytest.approx(4 * v / s,
                                                                                 rel=0.04)


def test_source_distance_is_the_nearest_lit_plane(write_study):
    # an isotropic lamp 0.2 m under the ceiling lights it: 0.2 m (the plane, not the hit)
    study = _room(write_study, (6.0, 5.0, 3.0), [(2.0, 2.5, 2.8), (4.0, 2.5, 1.5)])
    assert source_distance(study.scene) == pytest.approx(0.2, rel=1e-5)
    # a Lambertian downlight sends nothing up: 1 cm under the ceiling, the nearest surface it
    # lights is a wall 2 m away, not the ceiling
    study = _room(write_study, (6.0, 5.0, 3.0), [(2.0, 2.5, 2.99)], photometry="down")
    assert source_distance(study.scene) == pytest.approx(2.0, rel=1e-5)


def test_the_rule_and_its_cap_in_closed_form():
    area, path = 96.0, 2.0
    h1 = accuracy_patch_size(area, path, 0.01)
    assert h1 == pytest.approx(PATCH_SIZE_PER_PATH * path)
    # the error of piecewise-constant radiosity goes like h²: four times the accuracy, twice h
    assert accuracy_patch_size(area, path, 0.04) == pytest.approx(2 * h1)
    assert accuracy_patch_size(area, path, 0.01, 0.5) == pytest.approx(
        min(PATCH_SIZE_PER_PATH * path, PATCH_SIZE_PER_SOURCE_DISTANCE * 0.5))
    cap = auto_patch_size(area, AUTO_PATCH_CAP)
    assert accuracy_patch_size(area, path, 1e-4) == cap  # never more than the cap's patches
    assert accuracy_patch_size(area, path, 0.01, 1e-3) == cap
    assert accuracy_patch_size(area, None, 0.01) == cap  # nothing to inter-reflect between


def test_default_cube_meshes_by_the_rule_at_any_scale(write_study):
    """The 4 m cube of benchmarks/small.py: mean free path 2a/3, so the edge is 0.19 · 2.67 m
    and each face's two triangles (diagonal 4√2 m) are cut 12 × 12: 1,728 patches; the same
    count for a 4 mm cube (the rule reads ratios of lengths, no metres)."""
    for scale in (1.0, 1e-3):
        study = _room(write_study, (4.0, 4.0, 4.0), [(2, 2, 2)], scale=scale)
        settings = solver_settings(study)
        assert settings.target_patches is None and settings.accuracy == 0.01
        size = patch_size_of(study.scene, settings)
        assert size == pytest.approx(PATCH_SIZE_PER_PATH * 8 / 3 * scale, rel=0.03)
        assert check_memory(study).patches == 1728


@pytest.mark.parametrize("solver", [{"target_patches": 4000}, {"patch_size": 0.3},
                                    {"target_patches": 700, "accuracy": 0.001}])
def test_explicit_settings_mesh_as_before(write_study, solver):
    study = _room(write_study, (4.0, 4.0, 4.0), [(2, 2, 2)], solver=solver)
    area = float(study.scene.triangles.areas.sum())
    expect = solver.get("patch_size") or auto_patch_size(area, solver["target_patches"])
    assert patch_size_of(study.scene, solver_settings(study)) == expect


def test_accuracy_is_checked_by_the_config(write_study):
    from lumijax import ConfigError

    with pytest.raises(ConfigError, match="accuracy"):
        _room(write_study, (4.0, 4.0, 4.0), [(2, 2, 2)], solver={"accuracy": 0.0})


def test_office_lamps_near_the_ceiling_hit_the_cap(write_study):
    # twenty lamps 0.2 m under a 3 m ceiling (the office of benchmarks/small.py): the source
    # term asks for 0.3 m patches, finer than the cap allows: the cap's 4,000
    lamps = [(0.8 + 1.6 * i, 0.75 + 1.5 * j, 2.8) for j in range(4) for i in range(5)]
    study = _room(write_study, (8.0, 6.0, 3.0), lamps)
    area = float(study.scene.triangles.areas.sum())
    assert patch_size_of(study.scene, solver_settings(study)) == auto_patch_size(
        area, AUTO_PATCH_CAP)
    assert np.isclose(source_distance(study.scene), 0.2, rtol=1e-5)


def test_block_size_follows_the_patch_count_unless_given():
    # lighting._settings.block_size: a study whose solve is one dense block partitions in
    # blocks of 384, a larger one of 1,024; a [solver] max_block the user gives always wins
    from lumijax.config import parse_config
    from lumijax.lighting._settings import block_size
    from lumijax.radiosity._operator import DENSE_PATCHES

    assert block_size(None, 1728) == 384 and block_size(None, DENSE_PATCHES) == 384
    assert block_size(None, DENSE_PATCHES + 1) == 1024
    assert block_size(64, 1728) == 64 and block_size(2048, 100_000) == 2048
    assert parse_config("[study]\nname = 'x'\n").solver.max_block is None
