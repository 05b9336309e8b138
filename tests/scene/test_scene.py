"""Scene building: group frames, mesh files, and refusing degenerate or impossible geometry."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
import trimesh
from helpers import box, lamp, material, mesh, photometry, point_grid, study_text, table

import lumijax
from lumijax import GeometryError, load_study
from lumijax.config import load_config
from lumijax.scene import Frame, resolve_group_frames, rotation_xyz

# these tests check direct light against closed forms: inter-reflection off
compute = partial(lumijax.compute, indirect=False)

HEAD = study_text(material("m", 0.4), photometry("iso", "isotropic", 1000))


def test_nested_group_frames_compose_parent_first(write_study):
    cfg = load_config(write_study(
        HEAD + table("groups.facade", translate=[10, 0, 0], rotate=[0, 0, 90])
        + table("groups.bay", parent="facade", translate=[2, 0, 0], scale=2)))
    frames = resolve_group_frames(cfg.groups)
    # bay point (1, 0, 0): scale 2 → (2,0,0), + (2,0,0) → (4,0,0) in facade; facade turns it
    # by 90° about z → (0,4,0), then + (10,0,0)
    np.testing.assert_allclose(frames["bay"].points([1.0, 0, 0]), [10, 4, 0], atol=1e-12)
    np.testing.assert_allclose(frames["bay"].rotation, rotation_xyz([0, 0, 90]), atol=1e-12)


def test_luminaire_and_grid_in_a_rotated_group(write_study):
    """A luminaire aimed along its group's +x, in a group turned 90° about z, lights world +y."""
    path = write_study(HEAD + table("groups.g", translate=[5, 5, 0], rotate=[0, 0, 90])
                       + lamp("L", [0, 0, 2], group="g", aim={"tilt": 90})
                       + point_grid("p", [[1, 0, 2]], [[-1, 0, 0]], group="g"))
    study = load_study(path)
    lum = study.scene.luminaires[0]
    np.testing.assert_allclose(lum.position, [5, 5, 2], atol=1e-12)
    np.testing.assert_allclose(lum.axis, [0, 1, 0], atol=1e-12)
    g = study.scene.grids[0]
    np.testing.assert_allclose(g.points[0], [5, 6, 2], atol=1e-12)
    np.testing.assert_allclose(g.normals[0], [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(compute(study)["p"].illuminance_lux[0], 1000 / (4 * np.pi))


def test_aim_at_inside_a_group_points_at_the_world_target(write_study):
    path = write_study(HEAD + table("groups.g", translate=[1, 2, 3], rotate=[20, -30, 75])
                       + lamp("L", [0.5, 0.1, 0.2], aim_at=[3, -1, -4], group="g"))
    sc = load_study(path).scene
    f = resolve_group_frames(load_config(path).groups)["g"]
    want = f.points([3, -1, -4]) - f.points([0.5, 0.1, 0.2])
    np.testing.assert_allclose(sc.luminaires[0].axis, want / np.linalg.norm(want), atol=1e-9)


def test_frame_normals_use_inverse_transpose():
    f = Frame(np.diag([4.0, 1.0, 1.0]), np.zeros(3))
    n = f.normals(np.array([1.0, 1.0, 0.0]) / np.sqrt(2))
    # the plane x + y = c scaled by 4 in x has normal ∝ (1/4, 1, 0)
    np.testing.assert_allclose(n, np.array([0.25, 1, 0]) / np.hypot(0.25, 1), atol=1e-12)


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "glb", "off"])
def test_meshes_in_every_common_format(write_study, tmp_path, ext):
    block = trimesh.creation.box(extents=[1, 1, 1])
    block.apply_translation([0, 0, 0.5])
    block.export(tmp_path / f"block.{ext}")
    study = load_study(write_study(HEAD + mesh(f"block.{ext}", "m") + lamp("L", [0, 0, 3])
                                   + point_grid("p", [[0, 0, 0], [2, 0, 0]])))
    assert len(study.scene.triangles) == 12
    lux = compute(study)["p"].illuminance_lux
    assert lux[0] == 0.0  # under the block
    np.testing.assert_allclose(lux[1], 1000 / (4 * np.pi) * 3 / 13**1.5)


def test_mesh_units_scale_to_metres(write_study, tmp_path):
    trimesh.creation.box(extents=[1000, 1000, 1000]).export(tmp_path / "mm.stl")
    study = load_study(write_study(HEAD + mesh("mm.stl", "m", units="mm")))
    np.testing.assert_allclose(np.ptp(study.scene.triangles.bounds, axis=0), [1, 1, 1])


def test_degenerate_and_nan_triangles_are_refused(write_study, tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)
    (tmp_path / "flat.obj").write_text(
        "".join(f"v {a} {b} {c}\n" for a, b, c in v) + "f 1 2 3\nf 1 2 4\n")
    with pytest.raises(GeometryError, match=r"triangle 1 has zero area") as info:
        load_study(write_study(HEAD + mesh("flat.obj", "m")))
    assert "flat.obj" in str(info.value) and "geometry[0].file" in str(info.value)
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(GeometryError, match="NaN"):
        load_study(write_study(HEAD + mesh("nan.obj", "m"), "nan.toml"))


def test_unreadable_mesh_file(write_study, tmp_path):
    (tmp_path / "junk.stl").write_bytes(b"\x00\x01 not a mesh")
    with pytest.raises(GeometryError) as info:
        load_study(write_study(HEAD + mesh("junk.stl", "m")))
    assert "junk.stl" in str(info.value)


def test_luminaire_inside_a_solid_is_refused(write_study):
    def text(normals):
        return HEAD + box([0, 0, 0], [2, 2, 2], "m", normals) + lamp("buried", [1, 1, 1])
    with pytest.raises(GeometryError, match="inside the closed solid geometry") as info:
        load_study(write_study(text("outward")))
    assert info.value.key == "luminaires[0].position"
    # the same box as a room (inward normals) is where a light belongs
    load_study(write_study(text("inward"), "room.toml"))


def test_lm63_tilt_factor_follows_the_real_world_tilt(write_study, shared_photometry):
    """er_TILT_TEST_SYNTHETIC.ies: factors 1.0/0.9/0.8/1.0 at 0/45/90/180° (read off its header).
    A luminaire with zero aim inside a group turned 90° about x is tilted 90° in the world."""
    t = {"photometry": "t"}
    path = write_study(study_text(
        photometry("t", file=shared_photometry / "er_TILT_TEST_SYNTHETIC.ies"),
        table("groups.turned", rotate=[90, 0, 0]), lamp("straight", [0, 0, 3], **t),
        lamp("half", [0, 0, 3], aim={"tilt": 45}, **t),
        lamp("in-group", [0, 0, 3], group="turned", **t)))

    with pytest.warns(UserWarning):  # the synthetic file's header flux is inconsistent
        lums = load_study(path).scene.luminaires
    assert [round(lum.scale, 6) for lum in lums] == [1.0, 0.9, 0.8]
