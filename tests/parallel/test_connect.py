"""A scheduler address that does not answer, or is no address, is a clear error in seconds
(Python API and command line); the executors and the threaded map keep item order; batches
cover their range once."""

from __future__ import annotations

import socket
import threading
import time

import pytest
from helpers import box_room

import lumijax
from lumijax.cli import main
from lumijax.parallel import (
    CONNECT_TIMEOUT_S,
    ClusterError,
    LocalExecutor,
    batches,
    connect,
    threaded_map,
)


def _closed_port() -> int:
    """A local port nothing listens on (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_scheduler_that_does_not_answer_is_refused_within_the_timeout():
    address = f"tcp://127.0.0.1:{_closed_port()}"
    t = time.perf_counter()
    with pytest.raises(ClusterError) as e:
        connect(address, timeout_s=2.0)
    assert time.perf_counter() - t < 2.0 + 8.0  # the timeout, not a hang
    assert address in e.value.message and e.value.key == "scheduler"
    assert isinstance(e.value, lumijax.LumijaxError)


@pytest.mark.parametrize("bad", ["localhost", "http://host:8786/x", "tcp://"])
def test_a_malformed_address_names_the_expected_form(bad):
    with pytest.raises(ClusterError, match="tcp://HOST:PORT"):
        connect(bad)


def test_the_command_line_refuses_an_unreachable_scheduler_without_a_traceback(
        write_study, tmp_path, capsys):
    cfg = write_study(box_room("target_patches = 50"))
    address = f"tcp://127.0.0.1:{_closed_port()}"
    t = time.perf_counter()
    assert main(["run", str(cfg), "--out", str(tmp_path / "out"), "--scheduler", address]) == 1
    assert time.perf_counter() - t < CONNECT_TIMEOUT_S + 10.0
    err = capsys.readouterr().err
    assert f"no Dask scheduler answered at {address}" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_the_local_executor_maps_lazily_in_order():
    seen = []

    def f(x, *, k):
        seen.append(x)
        return x * k

    out = LocalExecutor().map(f, [3, 1, 2], shared={"k": 10})
    assert seen == []  # nothing runs before its result is asked for
    assert next(out) == 30 and seen == [3]
    assert list(out) == [10, 20]


def test_the_threaded_map_runs_items_at_once_yet_yields_them_in_order():
    both = threading.Barrier(2, timeout=10)  # passed only if two items run at the same time
    names = set()

    def f(x):
        if x < 2:
            both.wait()
        time.sleep(0.02 * (5 - x))  # later items finish first
        names.add(threading.current_thread().name)
        return x * x

    assert list(threaded_map(f, range(5), threads=2)) == [0, 1, 4, 9, 16]
    assert len(names) == 2 and all(n.startswith("lumijax") for n in names)
    assert list(threaded_map(f, [3, 4], threads=1)) == [9, 16]  # the plain loop: no barrier


def test_an_error_in_a_threaded_item_reaches_the_caller_and_stops_the_rest():
    ran = []

    def f(x):
        ran.append(x)
        if x == 1:
            raise ValueError("item 1")
        time.sleep(0.05)
        return x

    out = threaded_map(f, range(100), threads=2)
    assert next(out) == 0
    with pytest.raises(ValueError, match="item 1"):
        next(out)
    assert len(ran) < 10  # in flight at most three (threads + 1); the rest never started


@pytest.mark.parametrize("n,parts", [(10, 3), (3, 8), (1, 1), (0, 4), (1000, 7)])
def test_batches_cover_the_range_once_in_nearly_equal_parts(n, parts):
    got = batches(n, parts)
    assert [i for r in got for i in r] == list(range(n))
    assert len(got) == min(n, parts)
    if got:
        sizes = [len(r) for r in got]
        assert max(sizes) - min(sizes) <= 1


def test_threaded_items_run_in_the_caller_s_precision():
    # a float64 study turns x64 on in a with block, a context of its own thread: the items on
    # other threads must see it too, or their kernels quietly run in float32
    import jax
    import jax.numpy as jnp

    before = bool(jax.config.jax_enable_x64)
    try:
        for global_x64, local_x64 in ((False, True), (True, False)):
            jax.config.update("jax_enable_x64", global_x64)
            with jax.enable_x64(local_x64):
                got = set(threaded_map(lambda _: jnp.zeros(1).dtype.itemsize, range(6),
                                       threads=2))
            assert got == {8 if local_x64 else 4}
    finally:
        jax.config.update("jax_enable_x64", before)
