"""Memory known before building: the operator bound against the built operator's bytes, the
refusal before any form factor (naming the settings that fit), and progress on large grids."""

from __future__ import annotations

import types
import warnings

import numpy as np
import pytest
from helpers import box_room

import lumijax
from lumijax import SolveError
from lumijax._study import check_memory
from lumijax.cli import main
from lumijax.radiosity import FormFactorSettings, build_operator, mesh_patches, partition
from lumijax.radiosity._estimate import (
    OperatorEstimate,
    bound_operator_memory,
    check_operator_memory,
    estimate_before_partition,
    estimate_from_partition,
)
from lumijax.scene import RayCaster
from lumijax.scene._geometry import box_triangles

ROOM = box_room("target_patches = 300\nmax_block = 64\ngather_rays = 16\nspectral_samples = 0\n"
                "cache = false", networks=("a",), dimmer_a=None)


def _scene(boxes, size):
    tri = np.concatenate([box_triangles(lo, hi, inward=True) for lo, hi in boxes])
    group = np.repeat(np.arange(len(boxes)), 12)
    p = mesh_patches(tri, np.zeros(len(tri), int), group, patch_size=size)
    return p, tri


@pytest.mark.parametrize("boxes,size", [
    ([((0, 0, 0), (4, 3, 3))], 0.7),                          # one room: every block pair
    ([((0, 0, 0), (3, 3, 2.5)), ((5, 0, 0), (8, 3, 2.5))], 0.8),  # two closed rooms: culled
])
def test_the_bound_is_the_dense_operator_to_the_byte_and_an_upper_bound_compressed(boxes, size):
    p, tri = _scene(boxes, size)
    caster = RayCaster(tri)
    part = partition(p, max_block=32, occluders=caster)
    est = estimate_from_partition(part)
    dense = build_operator(p, part, caster, FormFactorSettings(lowrank=False),
                           occluder_triangles=tri)
    assert est.stored_bytes == dense.nbytes  # independent: the arrays the build allocated
    compressed = build_operator(p, part, caster, occluder_triangles=tri)
    assert compressed.nbytes <= est.stored_bytes <= 2 * compressed.nbytes
    _, counts = np.unique(p.group, return_counts=True)
    before = estimate_before_partition(counts, max_block=32)
    assert before.blocks == part.n_blocks and before.stored_bytes >= est.stored_bytes
    if len(boxes) == 2:  # the rooms cannot see each other: the partition bound is tighter
        assert est.stored_bytes < before.stored_bytes


def test_two_million_patches_are_refused_at_once_by_hand_count():
    # one group of 2e6 patches, 1024 per block: ⌈2e6/1024⌉ = 1954 blocks of 1023-1024 patches,
    # each padded to 1024; 1954·1955/2 pairs of 1024² float32 numbers ≈ 7.3 TiB
    fake = types.SimpleNamespace(group=np.full(2_000_000, -1))  # partitioning it would fail
    hand = 1954 * 1955 / 2 * 1024**2 * 4
    est = estimate_before_partition([2_000_000])
    assert est.blocks == 1954 and hand <= est.stored_bytes <= 1.01 * hand
    with pytest.raises(SolveError) as e:
        bound_operator_memory(fake, triangles=2_000_000, available=24 * 2**30)
    assert e.value.key == "solver"
    assert "2,000,000 patches" in e.value.message and "24.0 GiB" in e.value.message
    assert "simplify the geometry" in e.value.message  # no patch setting can fit


def test_the_refusal_names_a_setting_and_that_setting_fits():
    est = OperatorEstimate(patches=40_000, blocks=40, pairs=820, stored_bytes=8 * 2**30,
                           peak_bytes=9 * 2**30, visible_only=True)
    with pytest.raises(SolveError) as e:
        check_operator_memory(est, available=2**30, triangles=5_000, two_levels=False,
                              patch_size=0.1)
    # square law: 40,000 × √(1/9) × 0.9 = 12,000 patches, edge 0.1 m × √(40,000/12,000)
    assert "operator_patches = 12,000" in e.value.message
    assert "target_patches = 12,000 (patch_size ≥ 0.183 m)" in e.value.message


def test_compute_refuses_before_any_form_factor(write_study, monkeypatch):
    path = write_study(ROOM)
    study = lumijax.load_study(path)
    budget = check_memory(study).peak_bytes // 2

    def no_build(*args, **kwargs):
        raise AssertionError("the operator was built")

    monkeypatch.setattr(lumijax.radiosity, "build_operator", no_build)
    monkeypatch.setattr(lumijax.radiosity, "cached_operator", no_build)
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(budget))
    with pytest.raises(SolveError) as e, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lumijax.compute(study)
    assert e.value.key == "solver" and str(path) in str(e.value)
    fit = int(e.value.message.split("target_patches = ")[1].split()[0].replace(",", ""))
    assert fit < 300
    # the setting it names passes the same check
    smaller = write_study(ROOM.replace("target_patches = 300", f"target_patches = {fit}"),
                          "fit.toml")
    assert check_memory(lumijax.load_study(smaller)).peak_bytes <= budget


def test_lumijax_check_refuses_an_operator_that_cannot_fit(write_study, monkeypatch, capsys):
    path = write_study(ROOM)
    assert main(["check", str(path)]) == 0
    assert "transport operator: at most" in capsys.readouterr().out
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", "100000")
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"lumijax: error: {path}: solver: the transport operator of ")
    assert "operator_patches = " in err and "Traceback" not in err


def test_a_large_grid_reports_direct_light_in_chunks(write_study):
    # 500 × 400 = 2e5 points, direct light only: each chunk reports, and every value is the
    # inverse-square law of the isotropic lamp (nothing stands between it and the floor)
    text = ROOM.replace("nu = 8", "nu = 500").replace("nv = 6", "nv = 400").replace(
        "[solver]", "[solver]\nindirect = false")
    study = lumijax.load_study(write_study(text))
    calls = []
    res = lumijax.compute(study, progress=lambda *a: calls.append(a))
    seen = [(d, t) for stage, d, t in calls if stage == "direct light"]
    assert len(seen) >= 3 and all(t == 200_000 for _, t in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen) and seen[-1][0] == 200_000
    g = res.grids["floor"]
    d = g.points - [1, 1.5, 2.5]
    r = np.linalg.norm(d, axis=1)
    np.testing.assert_allclose(g.illuminance_lux, 2000 / (4 * np.pi) * -d[:, 2] / r**3,
                               rtol=1e-5)


def test_the_gather_of_a_large_grid_reports_chunks_and_sees_the_whole_room(monkeypatch):
    from lumijax.lighting import _stages

    monkeypatch.setattr(_stages, "POINT_CHUNK", 4096)
    p, tri = _scene([((0, 0, 0), (4, 3, 3))], 0.5)
    xy = np.stack(np.meshgrid(np.linspace(0.1, 3.9, 120), np.linspace(0.1, 2.9, 100)), -1)
    pts = np.column_stack([xy.reshape(-1, 2), np.full(12_000, 1.0)])
    nrm = np.tile([0.0, 0.0, 1.0], (12_000, 1))
    calls = []
    g = _stages._gather_in_chunks(pts, nrm, p, RayCaster(tri), 16, lambda *a: calls.append(a))
    # the three chunks (4096, 4096, 3808 points) run on threads and end in either order: the
    # count starts at 0, only grows, ends at every point, and between counts whole chunks
    done = [c[0] for c in calls]
    assert done[0] == 0 and done[-1] == 12_000 and done == sorted(done)
    assert set(done) <= {0, 4096, 3808, 8192, 7904, 12_000}
    assert all(c[1] == 12_000 for c in calls)
    assert g.n_points == 12_000 and g.point.max() == 11_999
    # inside a closed box every ray meets a front face: each point's weights sum to 1
    np.testing.assert_allclose(g.coverage, 1.0, atol=1e-12)
