"""A task the cluster cancels after a worker died is sent again (with its shared inputs scattered
afresh); one it keeps cancelling ends in a ClusterError, not a bare CancelledError. A stand-in
client, so the cancellations land where the test puts them."""

from __future__ import annotations

from concurrent.futures import CancelledError

import pytest

from lumijax.parallel import ClusterError, DaskExecutor


class _Future:
    def __init__(self, value, cancelled: bool) -> None:
        self.value, self.cancelled = value, cancelled

    @property
    def status(self) -> str:
        return "cancelled" if self.cancelled else "finished"

    def result(self):
        if self.cancelled:
            raise CancelledError("already forgotten")
        return self.value

    def release(self) -> None:
        pass

    def cancel(self) -> None:
        pass


class _Client:
    """Runs each task at once; the first ``cancel`` submissions of item 1 come back cancelled
    (with ``wave``, every item from 1 on in those submissions: a lost scattered input)."""

    class scheduler:  # noqa: N801 - the attribute distributed.Client has
        address = "tcp://stand-in:8786"

    def __init__(self, cancel: int, wave: bool) -> None:
        self.cancel, self.wave, self.scattered, self.sent = cancel, wave, 0, []

    def register_plugin(self, plugin, name) -> None:
        pass

    def scatter(self, value, broadcast, hash):
        self.scattered += 1
        return value


def _client(cancel: int, wave: bool = False) -> _Client:
    c = _Client(cancel, wave)

    def map_(task, items, *, fn, x64, pure, **shared):
        out = []
        lost_round = c.cancel > 0 and 1 in items
        for item in items:
            c.sent.append(item)
            lost = lost_round and (item == 1 or (c.wave and item > 1))
            out.append(_Future(fn(item, **shared), lost))
        c.cancel -= lost_round
        return out

    c.map = map_  # type: ignore[method-assign]
    return c


def _square_plus(item, *, offset):
    return item * item + offset


def test_a_cancelled_task_is_sent_again_and_the_results_keep_their_order():
    client = _client(cancel=2)
    ex = DaskExecutor(client)
    out = list(ex.map(_square_plus, [0, 1, 2, 3], shared={"offset": 10}))
    assert out == [10, 11, 14, 19]
    assert client.sent == [0, 1, 2, 3, 1, 1]  # item 1 twice more, nothing else again
    assert client.scattered == 3  # the shared input scattered afresh for each resubmission


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
