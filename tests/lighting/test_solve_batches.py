"""A study's solve in source batches (``lighting._solution.shoot``) and the progress of its
stages (``solve_lighting``'s ``progress``, the command line's bar)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import box_room

import lumijax
from lumijax.cli import _time_left
from lumijax.radiosity._estimate import SOLVE_SHARE, solve_column_bytes

STUDY = box_room('precision = "float64"\ntarget_patches = 60\ncache = false',
                 grid="nu = 4\nnv = 3")


def _compute(path):
    seen: list[tuple[str, int, int]] = []
    res = lumijax.compute(lumijax.load_study(path),
                          progress=lambda stage, d, t: seen.append((stage, d, t)))
    return res.lighting, seen


def test_source_batches_give_the_one_batch_solve(write_study, monkeypatch):
    path = write_study(STUDY)
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(10**12))
    whole, seen = _compute(path)
    w = whole.spectral.n
    solve = [(d, t) for s, d, t in seen if s == "solving inter-reflections"]
    assert solve == [(0, 2 * w), (2 * w, 2 * w)]  # one batch: 2 sources × w wavelengths
    # a budget of one source's columns a batch: 2 batches, as the solve's memory share decides
    per = solve_column_bytes(whole.coarse.patches.n, 8)
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(int((w + 0.5) * per / SOLVE_SHARE)))
    parts, seen = _compute(path)
    solve = [(d, t) for s, d, t in seen if s == "solving inter-reflections"]
    assert solve == [(0, 2 * w), (w, 2 * w), (2 * w, 2 * w)]
    assert np.all(whole.point_indirect > 1.0)  # a closed grey room: real inter-reflection
    np.testing.assert_allclose(parts.point_indirect, whole.point_indirect, rtol=1e-12)
    np.testing.assert_allclose(parts.coarse.radiosity, whole.coarse.radiosity, rtol=1e-12)
    assert parts.stats["columns_solved"] == whole.stats["columns_solved"] == 2  # grey: 1 each


def test_patch_stage_reports_patches(write_study, monkeypatch):
    from lumijax.lighting import _stages

    monkeypatch.setattr(_stages, "POINT_CHUNK", 40)  # a large study's chunks, on a small one
    lighting, seen = _compute(write_study(box_room(  # three luminaires: a chunk's steps
        'precision = "float64"\ntarget_patches = 60\ncache = false', networks=("a", "b", "c"),
        grid="nu = 4\nnv = 3")))
    n = lighting.coarse.patches.n
    stage = [(d, t) for s, d, t in seen if s == "direct light on patches"]
    # the chunks' points counted by how far each has come (luminaires lit), whichever thread
    # reports: from 0 to every patch, never back, and past each chunk's share on the way
    done = [d for d, t in stage]
    assert n > 80 and {t for _, t in stage} == {n}
    assert done[0] == 0 and done[-1] == n and done == sorted(done)
    assert len(done) > -(-n // 40) + 1 and set(done) & set(range(1, 40))


def test_near_stage_reports_samples(write_study):
    """The light of luminaires on the patches near them (radiosity/_patch_samples.py) is its
    own stage: from 0 to every near sample, never back."""
    from lumijax.radiosity import near_samples

    lighting, seen = _compute(write_study(box_room(
        'precision = "float64"\ntarget_patches = 60\ncache = false', networks=("a", "b", "c"),
        grid="nu = 4\nnv = 3")))
    positions = np.array([lum.position for lum in lighting.scene.luminaires])
    total = len(near_samples(lighting.coarse.patches, positions).points)
    stage = [(d, t) for s, d, t in seen if s == "direct light near luminaires"]
    done = [d for d, t in stage]
    assert total > 0 and {t for _, t in stage} == {total}
    assert done[0] == 0 and done[-1] == total and done == sorted(done) and len(done) > 2


def test_chunks_on_threads_are_the_chunks_one_after_another(write_study, monkeypatch):
    """The patch stage's chunks of direct light and the grid's gather chunks run on threads;
    each is computed as it would be alone, so the study's numbers are the same bit for bit."""
    from lumijax.lighting import _stages
    from lumijax.parallel import _executor

    monkeypatch.setattr(_stages, "POINT_CHUNK", 40)
    study = write_study(box_room('precision = "float64"\ntarget_patches = 60\ncache = false',
                                 grid="nu = 12\nnv = 9"))
    runs = []
    for threads in (1, 2):
        monkeypatch.setattr(_executor, "local_threads", lambda n=threads: n)
        runs.append(_compute(study)[0])
    one, two = runs
    assert one.coarse.patches.n > 80 and one.points.shape[0] > 40  # several chunks each
    np.testing.assert_array_equal(two.coarse.radiosity, one.coarse.radiosity)
    np.testing.assert_array_equal(two.point_indirect, one.point_indirect)
    np.testing.assert_array_equal(two.point_direct, one.point_direct)


def test_direct_light_reports_luminaires_not_photometries(write_study):
    # three luminaires of one photometry: the old unit (photometries) gave one step of one
    path = write_study(box_room('precision = "float64"\ntarget_patches = 60\ncache = false',
                                networks=("a", "b", "c"), grid="nu = 4\nnv = 3"))
    _, seen = _compute(path)
    stage = [(d, t) for s, d, t in seen if s == "direct light"]
    assert stage and stage[-1] == (3, 3) and {t for _, t in stage} == {3}
    assert [d for d, _ in stage] == sorted(d for d, _ in stage)


@pytest.mark.parametrize(("elapsed", "done", "total", "left"), [
    (10.0, 1, 4, 30.0), (60.0, 3, 3, 0.0), (5.0, 0, 9, None), (5.0, 2, None, None)])
def test_time_left_is_the_rate_so_far(elapsed, done, total, left):
    assert _time_left(elapsed, done, total) == left


@pytest.mark.parametrize(("elapsed", "done", "first", "left"), [
    # the first of 4 chunks took 10 s (compiling), the second 1 s: 2 s left, not 10
    (11.0, 2, (10.0, 1), 2.0),
    # nothing done since the first report: the rate so far, first chunk included
    (10.0, 1, (10.0, 1), 30.0),
    # done, whatever the first chunk cost
    (12.0, 4, (10.0, 1), 0.0)])
def test_time_left_leaves_out_the_first_chunk_once_there_is_a_second(elapsed, done, first, left):
    assert _time_left(elapsed, done, 4, first) == left


def test_uneven_sources_make_equal_batches_and_equal_shares(write_study, monkeypatch):
    """Three sources at most two a batch: batches of 1 and 2 (as equal as three allow), each
    half of the bar, and the one-batch answer."""
    path = write_study(box_room('precision = "float64"\ntarget_patches = 60\ncache = false',
                                networks=("a", "b", "c"), grid="nu = 4\nnv = 3"))
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(10**12))
    whole, _ = _compute(path)
    w = whole.spectral.n
    per = solve_column_bytes(whole.coarse.patches.n, 8)
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", str(int((2 * w + 0.5) * per / SOLVE_SHARE)))
    parts, seen = _compute(path)
    solve = [(d, t) for s, d, t in seen if s == "solving inter-reflections"]
    assert solve == [(0, 3 * w), (3 * w // 2, 3 * w), (3 * w, 3 * w)]
    np.testing.assert_allclose(parts.point_indirect, whole.point_indirect, rtol=1e-12)
