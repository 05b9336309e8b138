"""The parallel stages on a two-process Dask cluster give the local run's results; a worker
killed mid-build costs nothing but time, and the cache never holds a partial operator."""

from __future__ import annotations

import os
import signal
import threading
import time
import warnings

import numpy as np
import pytest
import trimesh
from conftest import ROOM

import lumijax
from lumijax.parallel import ClusterError, Executor, connect
from lumijax.radiosity import PartitionSettings, build_operator, cached_operator, partition


def _compute(study, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the room's row-sum note is not what is tested here
        return lumijax.compute(study, **kw)


def _built(client) -> dict:
    """Each worker's count of Embree scenes built (lumijax.parallel._shared.BUILT)."""
    def count():
        from lumijax.parallel._shared import BUILT

        return BUILT.get("raycaster", 0)

    return client.run(count)


def test_a_study_on_the_cluster_equals_the_local_run(client, write_study):
    study = lumijax.load_study(write_study(ROOM))
    local = _compute(study)
    ex = connect(client)
    before = _built(client)
    remote = _compute(study, scheduler=ex)
    # every parallel stage went to the workers ...
    assert ex.submitted["_direct_task"] >= 2 and ex.submitted["_near_task"] >= 2
    assert ex.submitted["_fine_chunk"] >= 1
    assert local.lighting.fine is not None  # (the two-level solve: a final gather ran)
    # ... each worker built the scene's Embree scene at most once, not once per task
    after = _built(client)
    assert all(after[w] - before.get(w, 0) <= 1 for w in after)
    assert sum(ex.submitted.values()) > 2 * len(after)
    # and the light is the local run's: the blocks, rays and the gather's rays are the same
    # computations (bitwise); direct light differs only by the order its sources are summed
    a, b = local.lighting, remote.lighting
    np.testing.assert_array_equal(a.transport.todense(), b.transport.todense())
    np.testing.assert_array_equal(a.fine.gather.weight, b.fine.gather.weight)
    np.testing.assert_allclose(b.point_direct, a.point_direct, rtol=1e-12, atol=0)
    np.testing.assert_allclose(b.fine.patch_direct, a.fine.patch_direct, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(b.coarse.radiosity, a.coarse.radiosity, rtol=1e-12, atol=1e-12)
    for name, g in local.grids.items():
        r = remote.grids[name]
        scale = np.abs(g.by_network_lux).max()
        assert np.abs(r.by_network_lux - g.by_network_lux).max() <= 1e-12 * scale
        assert np.abs(r.direct_by_network_lux - g.direct_by_network_lux).max() <= 1e-12 * scale


def _kill_a_busy_worker(client, stop: threading.Event, killed: list) -> None:
    """SIGKILL the first worker seen running a build task (the nanny starts a new one)."""
    pids = client.run(os.getpid)
    while not stop.is_set():
        busy = [w for w, keys in client.processing().items()
                if any("_on_worker" in str(k) for k in keys)]
        if busy:
            os.kill(pids[busy[0]], signal.SIGKILL)
            killed.append(busy[0])
            return
        time.sleep(0.005)


def test_a_worker_killed_mid_build_leaves_a_whole_operator_in_the_cache(client, write_study,
                                                                         tmp_path):
    study = lumijax.load_study(write_study(ROOM))
    cache = tmp_path / "cache"
    sc = study.scene
    tri = sc.triangles
    from lumijax.radiosity import mesh_patches

    # 0.8 m: ~580 patches, ~680 block pairs in 16 tasks, enough for the kill to land mid-build
    # (0.5 m: ~1,300 patches and 3,040 pairs built twice made this the suite's slowest test)
    patches = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=0.8)
    settings = PartitionSettings(max_block=16)
    part = partition(patches, max_block=16, occluders=sc.raycaster)
    local = build_operator(patches, part, sc.raycaster, occluder_triangles=tri.vertices)
    ex = connect(client)
    ex.tasks_per_worker = 8  # many small tasks: the kill lands while some are running
    stop, killed = threading.Event(), []
    killer = threading.Thread(target=_kill_a_busy_worker, args=(client, stop, killed))
    from lumijax.parallel import use_executor

    with use_executor(ex):
        killer.start()
        try:
            op, hit = cached_operator(patches, tri.vertices, cache_dir=cache,
                                      caster=sc.raycaster, partition_settings=settings)
        finally:
            stop.set()
            killer.join()
    assert killed, "no worker was running a build task to kill"
    assert hit is False
    # the scheduler ran the dead worker's tasks again elsewhere: the operator is the local one
    np.testing.assert_array_equal(op.todense(), local.todense())
    # and what the cache holds is that whole operator (read back, no temporaries)
    files = sorted(p.name for p in cache.iterdir())
    assert len(files) == 1 and files[0].startswith("transport-") and files[0].endswith(".lmjop")
    again, hit = cached_operator(patches, tri.vertices, cache_dir=cache, caster=sc.raycaster,
                                 partition_settings=settings)
    assert hit is True
    np.testing.assert_array_equal(again.todense(), local.todense())
    client.wait_for_workers(2, timeout=60)  # the nanny's new worker, for the next test


class _DiesAfter(Executor):
    """A cluster that loses the job after ``n`` results (every worker gone)."""

    def __init__(self, n: int) -> None:
        self.n = n

    @property
    def workers(self) -> int:
        return 2

    @property
    def distributed(self) -> bool:
        return True

    def map(self, fn, items, *, shared=None):
        for k, item in enumerate(items):
            if k == self.n:
                raise ClusterError("the Dask cluster at tcp://test:8786 lost a task",
                                   key="scheduler")
            yield fn(item, **(shared or {}))


def test_a_lost_cluster_fails_clearly_and_caches_nothing(write_study, tmp_path):
    study = lumijax.load_study(write_study(ROOM))
    sc = study.scene
    tri = sc.triangles
    from lumijax.parallel import use_executor
    from lumijax.radiosity import mesh_patches

    patches = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=0.8)
    cache = tmp_path / "cache"
    with use_executor(_DiesAfter(2)), pytest.raises(ClusterError) as e:
        cached_operator(patches, tri.vertices, cache_dir=cache, caster=sc.raycaster,
                        partition_settings=PartitionSettings(max_block=16))
    assert isinstance(e.value, lumijax.LumijaxError) and e.value.key == "scheduler"
    assert not cache.exists() or list(cache.iterdir()) == []  # no operator file, whole or partial, no temporary


def test_a_study_too_large_is_refused_before_any_block_is_sent(client, write_study,
                                                              monkeypatch):
    path = write_study(ROOM)
    study = lumijax.load_study(path)
    ex = connect(client)
    # room for the mesh, not for the operator's peak (≈ 213 kB): refused at the build
    monkeypatch.setenv("LUMIJAX_MEMORY_BYTES", "80000")
    t = time.perf_counter()
    with pytest.raises(lumijax.SolveError) as e:
        _compute(study, scheduler=ex)
    assert e.value.key == "solver" and str(path) in str(e.value)
    assert "operator_patches = " in e.value.message  # the setting that would fit
    assert ex.submitted["_near_task"] == 0 and ex.submitted["_fine_chunk"] == 0
    assert time.perf_counter() - t < 30


def test_the_sampled_transport_built_on_the_cluster_is_the_local_build(client):
    """The ray-sampled operator's batches run one task each on the workers, and the links are
    the local build's bit for bit (a batch depends only on its span and the seed); a room with
    a box, so rays are blocked and hit back faces."""
    from lumijax.parallel import use_executor
    from lumijax.radiosity import SampledSettings, bright_patches, build_sampled, mesh_patches
    from lumijax.scene import RayCaster

    room = trimesh.creation.box((4.0, 3.0, 3.0))
    room.invert()  # inward: the inside of the room is lit
    crate = trimesh.creation.box((1.0, 1.0, 1.2))
    crate.apply_translation((0.5, 0.0, -0.9))
    tri = np.concatenate([room.triangles, crate.triangles])
    patches = mesh_patches(tri, patch_size=0.5)
    settings = SampledSettings(rays_per_patch=64, batch=40)  # 1,288 patches: 33 batches
    local = build_sampled(patches, tri, settings, threads=2)
    ex = connect(client)
    with use_executor(ex):
        remote = build_sampled(patches, tri, settings, caster=RayCaster(tri))
    assert ex.submitted["_batch_task"] == -(-patches.n // 40) >= 3
    a, b = local.buckets[0], remote.buckets[0]
    for name in ("weight", "recv", "src"):
        np.testing.assert_array_equal(np.asarray(getattr(a, name)), np.asarray(getattr(b, name)))
    assert remote.info["rays"] == local.info["rays"] == 64 * patches.n
    one_thread = build_sampled(patches, tri, settings, threads=1).buckets[0]
    for name in ("weight", "recv", "src"):  # the local build on two threads is the plain loop's
        np.testing.assert_array_equal(np.asarray(getattr(a, name)),
                                      np.asarray(getattr(one_thread, name)))
    # rays aimed at the lit patches (the floor): the proposal travels with the batches
    bright = bright_patches(np.where(patches.normal[:, 2] > 0.5, patches.area, 0.0), patches)
    local = build_sampled(patches, tri, settings, threads=2, bright=bright).buckets[0]
    with use_executor(ex):
        remote = build_sampled(patches, tri, settings, caster=RayCaster(tri),
                               bright=bright).buckets[0]
    for name in ("weight", "recv", "src"):
        np.testing.assert_array_equal(np.asarray(getattr(local, name)),
                                      np.asarray(getattr(remote, name)))
    assert not np.array_equal(np.asarray(local.weight[:100]), np.asarray(a.weight[:100]))


def test_a_long_task_on_a_live_worker_is_waited_for_not_resent(client, tmp_path):
    """A task three times ``stall_s`` long: the watchdog asks the real scheduler at every poll,
    sees the task processing on a worker that executes it, and never resends it (each item
    runs once: its line in the log)."""
    runs = tmp_path / "runs"

    def slow(item, *, log):  # nested: pickled by value, the workers need not import the tests
        import time

        with open(log, "a") as f:
            f.write(f"{item}\n")
        time.sleep(3.0)
        return 10 * item

    ex = connect(client)
    ex.poll_s, ex.stall_s = 0.2, 1.0
    seen: list = []
    probe = ex._no_progress
    ex._no_progress = lambda key: seen.append(probe(key)) or seen[-1]  # type: ignore[method-assign]
    with warnings.catch_warnings():
        warnings.simplefilter("error", lumijax.LumijaxWarning)  # the probe must not be refused
        out = list(ex.map(slow, [0, 1], shared={"log": str(runs)}))
    assert out == [0, 10]
    assert sorted(runs.read_text().split()) == ["0", "1"] and ex.resent == {}
    # the watchdog did ask (≈ 15 polls in 3 s) and mostly heard "progress": a poll may still
    # read the worker's heartbeat from before the task began (one every 0.5 s)
    assert len(seen) >= 5 and seen.count(None) >= len(seen) // 2, seen
