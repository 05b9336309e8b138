"""A task the cluster cancels after a worker died is sent again (with its shared inputs scattered
afresh); one it keeps cancelling ends in a ClusterError, not a bare CancelledError. A task that
never finishes while no worker works on it (the stall of session 25) is found by the watchdog
and sent again, or ends in a ClusterError that says it stalled; a task its worker is running is
waited for, however long. A stand-in client, so the cancellations and stalls land where the test
puts them; its scheduler is a stand-in too, read by the watchdog's real probe."""

from __future__ import annotations

import sys
import time
from concurrent.futures import CancelledError
from types import SimpleNamespace

import pytest

from lumijax.errors import LumijaxWarning
from lumijax.parallel import ClusterError, DaskExecutor
from lumijax.parallel._executor import _scheduler_probe

RUNS_FOR = 40  # polls a "long" (or "queued-busy") task stays pending before it finishes

# What becomes of one sending of a task (_Client's ``fates``), and how the stand-in scheduler
# shows it while it is pending: "done" (finished at once), "cancelled" (the cluster cancelled
# it), "long" (processing on a worker that executes it, RUNS_FOR polls), "queued-busy" (queued
# while a worker executes another task, RUNS_FOR polls); pending for ever: "unknown" (the
# scheduler does not know its key), "released", "memory" (finished at the scheduler, never
# reported), "idle" (processing on a worker that executes nothing), "queued-idle" (queued while
# no worker executes anything).
_PENDING_STATE = {"long": "processing", "queued-busy": "queued", "released": "released",
                  "memory": "memory", "idle": "processing", "queued-idle": "queued"}


class _Future:
    def __init__(self, key: str, value, fate: str) -> None:
        self.key, self.value, self.fate = key, value, fate
        self.polls, self.gone = 0, False

    @property
    def status(self) -> str:
        if self.fate == "cancelled":
            return "cancelled"
        if self.fate == "done" or (self.fate in ("long", "queued-busy")
                                   and self.polls >= RUNS_FOR):
            return "finished"
        return "pending"

    def result(self, timeout=None):
        if self.fate == "cancelled":
            raise CancelledError("already forgotten")
        if self.status == "pending":
            # the session-25 hang: a wait without a limit on a task that never finishes
            assert timeout is not None, f"waited on pending {self.key} without a time limit"
            assert self.polls < 2000, f"waited on {self.key} for ever: never found stalled"
            time.sleep(timeout)
            self.polls += 1
            if self.status == "pending":
                raise TimeoutError
        return self.value

    def release(self) -> None:
        self.gone = True

    def cancel(self) -> None:
        self.gone = True


class _Client:
    """Runs each task at once; the first ``cancel`` submissions of item 1 come back cancelled
    (with ``wave``, every item from 1 on in those submissions: a lost scattered input);
    ``fates`` gives an item's fate at each of its sendings in turn (then "done")."""

    class scheduler:  # noqa: N801 - the attribute distributed.Client has
        address = "tcp://stand-in:8786"

    def __init__(self, cancel: int, wave: bool, fates: dict[int, list[str]]) -> None:
        self.cancel, self.wave, self.scattered, self.sent = cancel, wave, 0, []
        self.fates = {item: list(f) for item, f in fates.items()}
        self.futures: list[_Future] = []
        self.probes = 0
        self.refuse: Exception | None = None  # what run_on_scheduler raises instead

    def register_plugin(self, plugin, name) -> None:
        pass

    def scatter(self, value, broadcast, hash):
        self.scattered += 1
        return value

    def run_on_scheduler(self, function, *args, callback_timeout=None):
        self.probes += 1
        if self.refuse is not None:
            raise self.refuse
        return function(*args, dask_scheduler=self._scheduler())

    def _scheduler(self) -> SimpleNamespace:
        """The scheduler's view of the futures not yet released or cancelled: worker a
        executes what is running ("long" tasks, and the other task a "queued-busy" one waits
        behind), worker b nothing."""
        pending = [f for f in self.futures if not f.gone and f.status == "pending"]
        running = sum(f.fate in ("long", "queued-busy") for f in pending)
        a = SimpleNamespace(address="tcp://a:1", metrics={"task_counts": {"executing": running}})
        b = SimpleNamespace(address="tcp://b:1", metrics={"task_counts": {"memory": 2}})
        tasks = {}
        for f in self.futures:
            if f.gone or f.fate in ("unknown", "cancelled"):
                continue
            state = _PENDING_STATE.get(f.fate, "memory") if f.status == "pending" else "memory"
            on = {"long": a, "idle": b}.get(f.fate) if state == "processing" else None
            tasks[f.key] = SimpleNamespace(state=state, processing_on=on)
        return SimpleNamespace(tasks=tasks, workers={w.address: w for w in (a, b)})


def _client(cancel: int = 0, wave: bool = False,
            fates: dict[int, list[str]] | None = None) -> _Client:
    c = _Client(cancel, wave, fates or {})

    def map_(task, items, *, fn, x64, pure, **shared):
        out = []
        lost_round = c.cancel > 0 and 1 in items
        for item in items:
            c.sent.append(item)
            lost = lost_round and (item == 1 or (c.wave and item > 1))
            planned = c.fates.get(item)
            fate = "cancelled" if lost else planned.pop(0) if planned else "done"
            out.append(_Future(f"task-{len(c.futures)}", fn(item, **shared), fate))
            c.futures.append(out[-1])
        c.cancel -= lost_round
        return out

    c.map = map_  # type: ignore[method-assign]
    return c


def _square_plus(item, *, offset):
    return item * item + offset


def _executor(client: _Client) -> DaskExecutor:
    ex = DaskExecutor(client)
    ex.poll_s, ex.stall_s = 0.005, 0.02
    return ex


def test_a_cancelled_task_is_sent_again_and_the_results_keep_their_order():
    client = _client(cancel=2)
    ex = DaskExecutor(client)
    out = list(ex.map(_square_plus, [0, 1, 2, 3], shared={"offset": 10}))
    assert out == [10, 11, 14, 19]
    assert client.sent == [0, 1, 2, 3, 1, 1]  # item 1 twice more, nothing else again
    assert client.scattered == 3  # the shared input scattered afresh for each resubmission
    assert ex.resent == {"_square_plus": 2}
    assert client.probes == 0  # nothing pending: the scheduler is never asked


def test_a_lost_input_cancelling_every_later_task_is_one_round_of_resending():
    # what a killed worker does when it held the only copy of the scattered inputs: every task
    # not yet finished is cancelled, and all of them are sent again together, once
    client = _client(cancel=1, wave=True)
    ex = DaskExecutor(client)
    ex.max_resubmits = 1
    out = list(ex.map(_square_plus, [0, 1, 2, 3, 4], shared={"offset": 1}))
    assert out == [1, 2, 5, 10, 17]
    assert client.sent == [0, 1, 2, 3, 4, 1, 2, 3, 4]
    assert client.scattered == 2


def test_a_task_cancelled_past_the_limit_is_a_cluster_error():
    client = _client(cancel=10)
    ex = DaskExecutor(client)
    ex.max_resubmits = 2
    with pytest.raises(ClusterError, match="lost a task.*CancelledError"):
        list(ex.map(_square_plus, [0, 1, 2], shared={"offset": 0}))
    assert client.sent.count(1) == 3


@pytest.mark.parametrize("fate", ["unknown", "released", "memory", "idle", "queued-idle"])
def test_a_stalled_task_is_sent_again_and_the_results_keep_their_order(fate):
    # item 1 never finishes and no worker runs it; item 3, pending then (its worker idle: no
    # task runs anywhere, as a "queued-idle" stall needs), goes with it
    client = _client(fates={1: [fate], 3: ["idle"]})
    ex = _executor(client)
    out = list(ex.map(_square_plus, [0, 1, 2, 3], shared={"offset": 10}))
    assert out == [10, 11, 14, 19]
    assert client.sent == [0, 1, 2, 3, 1, 3]  # one round: the stalled task and the unfinished
    assert client.scattered == 2  # the shared input scattered afresh for the round
    assert ex.resent == {"_square_plus": 2}
    stalled = client.futures[1]
    assert stalled.gone and stalled.polls >= 2  # cancelled, after two polls at least


def test_a_task_that_keeps_stalling_is_a_cluster_error_that_says_so():
    client = _client(fates={1: ["unknown"] * 10})
    ex = _executor(client)
    ex.max_resubmits = 2
    t = time.perf_counter()
    with pytest.raises(ClusterError) as e:
        list(ex.map(_square_plus, [0, 1, 2], shared={"offset": 0}))
    assert client.sent.count(1) == 3  # sent, then resent max_resubmits times
    message = e.value.message
    assert "tcp://stand-in:8786" in message and e.value.key == "scheduler"
    assert "stalled on task _square_plus (key 'task-" in message
    assert "sent 3 times): waited " in message and "no worker was running it" in message
    assert "the scheduler does not know its key" in message
    waited = float(message.split("): waited ")[1].split(" s")[0])
    assert 0 <= waited <= time.perf_counter() - t + 1
    # each sending waited stall_s at least before it was given up
    assert time.perf_counter() - t >= 3 * ex.stall_s


@pytest.mark.parametrize("fate", ["long", "queued-busy"])
def test_a_long_task_its_worker_runs_is_waited_for_not_resent(fate):
    # pending for RUNS_FOR polls, ten times stall_s: the scheduler shows it processing on a
    # worker that executes it (or queued while a worker executes another), so it is not stalled
    client = _client(fates={1: [fate]})
    ex = _executor(client)
    t = time.perf_counter()
    out = list(ex.map(_square_plus, [0, 1, 2], shared={"offset": 1}))
    assert out == [1, 2, 5]
    assert client.sent == [0, 1, 2] and ex.resent == {}
    assert client.futures[1].polls == RUNS_FOR and client.probes >= RUNS_FOR - 1
    assert time.perf_counter() - t >= 5 * ex.stall_s


def test_a_scheduler_that_will_not_report_leaves_the_task_waited_on():
    # the probe failed at the scheduler (one whose state it cannot read): the watchdog cannot
    # tell a stall from a long task, so it never resends; it says once that it stood down
    client = _client(fates={1: ["long"]})
    client.refuse = AttributeError("'Scheduler' object has no attribute 'tasks'")
    ex = _executor(client)
    with pytest.warns(LumijaxWarning, match="would not report on a task's progress.*AttributeE"):
        out = list(ex.map(_square_plus, [0, 1, 2], shared={"offset": 1}))
    assert out == [1, 2, 5] and client.sent == [0, 1, 2]
    assert client.probes == 1  # asked once, not at every poll


def test_a_scheduler_that_does_not_answer_counts_as_a_stall():
    client = _client(fates={1: ["long"] * 2})
    client.refuse = TimeoutError()
    ex = _executor(client)
    ex.max_resubmits = 1
    with pytest.raises(ClusterError, match=r"stalled.*the scheduler did not answer within"):
        list(ex.map(_square_plus, [0, 1, 2], shared={"offset": 1}))
    assert client.sent == [0, 1, 2, 1]  # item 2 had finished: not sent again


def test_the_probe_is_sent_by_value_so_the_scheduler_needs_no_lumijax(monkeypatch):
    from distributed.protocol import pickle

    blob = pickle.dumps(_scheduler_probe())
    for name in [m for m in sys.modules if m == "lumijax" or m.startswith("lumijax.")]:
        monkeypatch.setitem(sys.modules, name, None)  # importing it now fails
    probe = pickle.loads(blob)
    busy = SimpleNamespace(address="tcp://w:1", metrics={"task_counts": {"executing": 1}})
    tasks = {"k": SimpleNamespace(state="processing", processing_on=busy)}
    assert probe("k", dask_scheduler=SimpleNamespace(tasks=tasks, workers={"w": busy})) == {
        "state": "processing", "worker": "tcp://w:1", "working": True, "workers": 1}
    assert probe("gone", dask_scheduler=SimpleNamespace(tasks=tasks, workers={}))["state"] is None
