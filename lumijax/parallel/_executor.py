"""Where the embarrassingly parallel stages run: here (a loop), or on a Dask cluster.

An :class:`Executor` maps a module-level function over batches (luminaire batches of direct
light, block pairs of the transport build, patch chunks of the final gather) and yields the
results **in item order**, lazily: the caller consumes one batch's result before the next is
asked for, so the local loop keeps the memory it had, and on a cluster the results wait on the
workers, not on the driver. Values every task needs (the scene, the patches) are given as
``shared``: the local loop passes them as they are; Dask ships each object once per executor and
worker (``Client.scatter(broadcast=True)``), and a value that rebuilds heavy state when
unpickled (an Embree scene: ``RayCaster``) does so once per worker (:func:`worker_cached`).

The stage that calls ``map`` does not know which executor it has: it asks
:func:`current_executor` (the local loop unless :func:`use_executor` set another, as
``compute(..., scheduler=...)`` does).
"""

from __future__ import annotations

import abc
import collections
import contextlib
import contextvars
import os
import re
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any, final

from ..errors import LumijaxError

__all__ = ["ClusterError", "Executor", "LocalExecutor", "DaskExecutor", "connect",
           "current_executor", "use_executor", "executor_scope", "batches",
           "local_threads", "threaded_map", "CONNECT_TIMEOUT_S"]

CONNECT_TIMEOUT_S = 5.0
"""Seconds a scheduler address is given to answer before the run is refused."""


class ClusterError(LumijaxError):
    """The Dask scheduler cannot be reached, or the cluster lost a task on every worker it
    tried (``key`` names the setting: ``--scheduler`` / ``scheduler``)."""


class Executor(abc.ABC):
    """Runs ``fn(item, **shared)`` for every item; results in item order."""

    @property
    @abc.abstractmethod
    def workers(self) -> int:
        """Worker processes that run tasks at the same time (1: the local loop)."""

    @property
    @abc.abstractmethod
    def distributed(self) -> bool:
        """Whether tasks leave this process (stages batch only then)."""

    def parts(self) -> int:
        """How many batches a stage should cut its work into (4 per worker)."""
        return 4 * self.workers

    @abc.abstractmethod
    def map(self, fn: Callable[..., Any], items: Iterable[Any], *,
            shared: Mapping[str, Any] | None = None) -> Iterator[Any]:
        """``fn(item, **shared)`` of each item, yielded in item order.

        ``fn`` must be a module-level function (it is pickled by reference on a cluster);
        ``shared`` values are sent once, not once per item.
        """


@final
class LocalExecutor(Executor):
    """The loop in this process: ``fn`` runs when its result is asked for."""

    @property
    def workers(self) -> int:
        return 1

    @property
    def distributed(self) -> bool:
        return False

    def map(self, fn, items, *, shared=None):
        kw = dict(shared or {})
        return (fn(item, **kw) for item in items)


LOCAL = LocalExecutor()

_CURRENT: contextvars.ContextVar[Executor] = contextvars.ContextVar("lumijax_executor",
                                                                    default=LOCAL)


def current_executor() -> Executor:
    """The executor the stages map over now (:func:`use_executor`; default the local loop)."""
    return _CURRENT.get()


@contextlib.contextmanager
def use_executor(executor: Executor) -> Iterator[Executor]:
    """Run the stages inside the ``with`` block on ``executor``."""
    token = _CURRENT.set(executor)
    try:
        yield executor
    finally:
        _CURRENT.reset(token)


@contextlib.contextmanager
def executor_scope(scheduler: Any = None) -> Iterator[Executor]:
    """:func:`use_executor` of :func:`connect` (``scheduler``), closing what it opened; None
    keeps the current executor (the local loop by default)."""
    if scheduler is None:
        yield current_executor()
        return
    ex = connect(scheduler)
    try:
        with use_executor(ex):
            yield ex
    finally:
        if ex is not scheduler and isinstance(ex, DaskExecutor):
            ex.close()


def batches(n: int, parts: int) -> list[range]:
    """``range(n)`` cut into at most ``parts`` contiguous, nearly equal, non-empty batches."""
    parts = max(1, min(int(parts), n))
    edges = [round(k * n / parts) for k in range(parts + 1)]
    return [range(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def local_threads() -> int:
    """The CPUs this process may run on (its affinity mask, not the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def threaded_map(fn: Callable[[Any], Any], items: Iterable[Any],
                 threads: int | None = None) -> Iterator[Any]:
    """``fn(item)`` of each item in item order, up to ``threads`` (default
    :func:`local_threads`) running at once in this process.

    For work whose heavy calls release the GIL (Embree's ray queries, NumPy's loops over large
    arrays): one batch's rays are traced while another's hits are sorted. One item more than
    ``threads`` is submitted, so every thread stays busy while the caller consumes a result;
    memory stays that of ``threads + 1`` batches. ``threads=1`` is the plain loop, no thread
    started. The items run in the caller's precision: JAX's x64 switch is a context of each
    thread (a float64 study turns it on in a ``with`` block), so it is carried into the
    threads, as :class:`DaskExecutor` carries it to its workers."""
    threads = local_threads() if threads is None else int(threads)
    if threads <= 1:
        yield from (fn(item) for item in items)
        return
    from concurrent.futures import ThreadPoolExecutor

    import jax

    x64 = bool(jax.config.jax_enable_x64)

    def run(item):
        with jax.enable_x64(x64):
            return fn(item)

    pending: collections.deque = collections.deque()
    it = iter(items)
    with ThreadPoolExecutor(threads, thread_name_prefix="lumijax") as pool:
        try:
            for item in it:
                pending.append(pool.submit(run, item))
                if len(pending) > threads:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:  # an error or an abandoned generator: drop what has not started
            for f in pending:
                f.cancel()


_ADDRESS = re.compile(r"^(tcp|tls|inproc|ucx|ws|wss)://[^\s/:]+(:\d+)?$|^[^\s/:]+:\d+$")


@final
class DaskExecutor(Executor):
    """Tasks on a ``distributed.Client``'s cluster.

    A worker that dies mid-task has its task re-run on another by the scheduler (up to
    ``distributed.scheduler.allowed-failures`` times, 3 by default); a task that exhausts
    them, or a cluster that goes away, raises :class:`ClusterError`. A task the cluster
    cancels instead (``FutureCancelledError``, seen under load after a worker was killed) is
    sent again with its shared inputs scattered afresh, together with every task of the
    ``map`` not yet finished (they need the same inputs), up to ``max_resubmits`` rounds per
    ``map``, then raises :class:`ClusterError`. Errors a task raises
    itself (a ``LumijaxError`` about the input) pass through unchanged.

    A task that never finishes while no worker works on it (seen once: the driver waited
    minutes on a task with both workers idle) is found by a watchdog, not waited on for ever.
    While the driver waits on a task, every ``poll_s`` seconds it asks the scheduler (one
    query, :func:`_scheduler_probe`) for the task's state and whether the worker running it
    reports, in its heartbeat, a task executing or data arriving. The task is *stalled* when
    it is not ``processing`` on a worker that is working (nor ``waiting`` / ``queued`` while
    some worker works: its turn will come) at two or more polls in a row spanning at least
    ``stall_s`` seconds: the scheduler has forgotten it, or finished it without telling us,
    or its worker sits idle with it. A stalled task is sent again like a cancelled one (one
    round of ``max_resubmits``, with every task of the ``map`` not yet finished), and past
    the limit :class:`ClusterError` names the task and how long it waited. A long task is
    never resent: while its worker executes, each poll sees progress, whatever its length.

    Parameters
    ----------
    client
        A connected ``distributed.Client``.
    owned
        Close the client with :meth:`close` (a client :func:`connect` made).
    tasks_per_worker
        Batches a stage is cut into per worker: more balances uneven tasks and loses less
        work to a dead worker; fewer costs less per-task overhead (≈ 1–3 ms each).

    Attributes
    ----------
    max_resubmits
        Rounds of resending one ``map`` may make (cancelled or stalled tasks), 3.
    poll_s
        Seconds the driver waits on a task before asking the scheduler about it, 10: one
        small query per 10 s of waiting costs the scheduler nothing next to tasks of seconds
        to minutes, and a stall is found within ``stall_s + poll_s``.
    stall_s
        Seconds a task must show no progress, over two polls or more, before it is resent,
        60: far past the moments a live task can look idle — a worker's heartbeat (what the
        scheduler knows of its work) is at most a few seconds old, and a nanny restarts a
        killed worker (imports, JAX) in tens of seconds — yet minutes before anyone would
        take the wait for a hang.
    """

    def __init__(self, client, *, owned: bool = False, tasks_per_worker: int = 4) -> None:
        self.client = client
        self.owned = owned
        self.tasks_per_worker = int(tasks_per_worker)
        #: tasks sent so far, by function name (a study refused before its build sends no
        #: ``_near_task``)
        self.submitted: collections.Counter[str] = collections.Counter()
        self._shared: dict[int, tuple[Any, Any]] = {}  # id → (object kept alive, its future)
        self._x64: bool | None = None  # the precision the workers were last set to
        #: rounds of resending one ``map`` may make after the cluster cancelled or stalled its
        #: tasks
        self.max_resubmits = 3
        self.poll_s = 10.0
        self.stall_s = 60.0
        #: tasks sent again (cancelled or stalled), by function name
        self.resent: collections.Counter[str] = collections.Counter()
        self._probe_off = False  # the watchdog's probe failed at the scheduler: wait, as before

    @property
    def address(self) -> str:
        return str(self.client.scheduler.address)

    @property
    def workers(self) -> int:
        return max(1, len(self.client.scheduler_info(n_workers=-1)["workers"]))

    @property
    def distributed(self) -> bool:
        return True

    def parts(self) -> int:
        return self.workers * self.tasks_per_worker

    def _share(self, value):
        # one copy per worker per object: the same scene or patches object is sent once for
        # every stage that maps over it (keyed by identity; the object is kept alive here)
        got = self._shared.get(id(value))
        if got is not None and got[0] is value:
            return got[1]
        if len(self._shared) >= 8:
            self._shared.pop(next(iter(self._shared)))
        future = self.client.scatter(value, broadcast=True, hash=False)
        self._shared[id(value)] = (value, future)
        return future

    def map(self, fn, items, *, shared=None):
        import jax

        items = list(items)
        x64 = bool(jax.config.jax_enable_x64)

        def submit(batch: list) -> list:
            kw = {k: self._share(v) for k, v in (shared or {}).items()}
            return self.client.map(_on_worker, batch, fn=fn, x64=x64, pure=False, **kw)

        try:
            if x64 != self._x64:
                # shared JAX arrays (photometry tables) are rebuilt when they reach a worker,
                # before any task runs: in the worker's global precision, which must be ours
                self.client.register_plugin(_precision_plugin(x64), name="lumijax-precision")
                self._shared.clear()
                self._x64 = x64
            futures = submit(items)
        except (OSError, TimeoutError) as e:
            raise self._lost(e) from None
        self.submitted[fn.__name__] += len(futures)
        return self._results(futures, items, submit, fn.__name__)

    def _results(self, futures, items, submit, name: str) -> Iterator[Any]:
        from concurrent.futures import CancelledError

        from distributed import KilledWorker

        resubmitted = 0

        def resend(k: int, e: BaseException) -> None:
            # a worker died holding the only copy of a scattered input (the scheduler's memory
            # manager keeps one replica of a broadcast value once no task waits on it), so
            # every task needing it was cancelled, not only this one; or the cluster stalled,
            # and what it forgot of task k it may have forgotten of the others: all that have
            # not finished are sent again at once, with the inputs scattered afresh, as one
            # round
            nonlocal resubmitted
            if resubmitted >= self.max_resubmits:
                raise self._lost(e) from None
            resubmitted += 1
            self._shared.clear()
            again = [k] + [j for j in range(k + 1, len(futures))
                           if futures[j].status != "finished"]
            for j in again:
                futures[j].cancel()
            try:
                for j, f in zip(again, submit([items[j] for j in again])):
                    futures[j] = f
            except (OSError, TimeoutError) as e2:
                raise self._lost(e2) from None
            self.resent[name] += len(again)

        try:
            for k in range(len(futures)):
                watch = _Watch(name)
                while True:
                    future = futures[k]
                    # a finished task's result is fetched without a limit: a large one may take
                    # longer than a poll to arrive, and cutting it off would fetch it for ever
                    timeout = None if future.status == "finished" else self.poll_s
                    try:
                        out = future.result(timeout=timeout)
                        break
                    except CancelledError as e:
                        resend(k, e)
                        watch = _Watch(name, watch.sends + 1)
                    except TimeoutError as e:
                        if timeout is None:
                            raise self._lost(e) from None
                        stalled = self._watch(future, watch)
                        if stalled is not None:
                            resend(k, stalled)
                            watch = _Watch(name, watch.sends + 1)
                    except (KilledWorker, OSError) as e:
                        raise self._lost(e) from None
                futures[k].release()
                futures[k] = None  # the worker may forget a result once it is here
                yield out
        finally:
            for f in futures:
                if f is not None:
                    f.cancel()

    def _watch(self, future, watch: _Watch) -> _Stalled | None:
        """After a poll's wait: the stall of ``future`` once it has shown no progress at two
        polls or more spanning ``stall_s`` seconds, else None."""
        import time

        now = time.monotonic()
        why = self._no_progress(future.key)
        if why is None:
            watch.quiet_since, watch.quiet_polls = None, 0
            return None
        if watch.quiet_since is None:
            watch.quiet_since = now
        watch.quiet_polls += 1
        if watch.quiet_polls < 2 or now - watch.quiet_since < self.stall_s:
            return None
        return _Stalled(
            f"stalled on task {watch.name} (key {future.key!r}, sent {watch.sends} time"
            f"{'s' if watch.sends > 1 else ''}): waited {now - watch.start:.0f} s for it, and "
            f"no worker was running it for the last {now - watch.quiet_since:.0f} s ({why}; "
            "expected it processing on a working worker, or waiting for one while others work)")

    def _no_progress(self, key) -> str | None:
        """Why the scheduler shows task ``key`` making no progress now, or None if it does (or
        the scheduler will not say: the watchdog never resends on ignorance)."""
        if self._probe_off:
            return None
        try:
            # the limit keeps a scheduler that no longer answers from hanging the watchdog
            # (callback_timeout is Client.sync's: run_on_scheduler passes it on)
            facts = self.client.run_on_scheduler(_scheduler_probe(), key,
                                                 callback_timeout=self.poll_s)
        except (OSError, TimeoutError) as e:
            return f"the scheduler did not answer within {self.poll_s:g} s: {type(e).__name__}"
        except Exception as e:  # noqa: BLE001 - the probe failed there: a scheduler it cannot read
            import warnings

            from ..errors import LumijaxWarning

            self._probe_off = True
            warnings.warn(f"the scheduler at {self.address} would not report on a task's "
                          f"progress ({type(e).__name__}: {e}); a task it stalls will be "
                          "waited on, not resent", LumijaxWarning, stacklevel=2)
            return None
        return _why_idle(facts)

    def _lost(self, e: BaseException) -> ClusterError:
        if isinstance(e, _Stalled):
            return ClusterError(
                f"the Dask cluster at {self.address} {e}; no partial result was kept. Check "
                "the scheduler's and workers' logs, or run without --scheduler",
                key="scheduler")
        return ClusterError(
            f"the Dask cluster at {self.address} lost a task ({type(e).__name__}: {e}); "
            "no partial result was kept. Check the workers' memory and logs, or run without "
            "--scheduler", key="scheduler")

    def close(self) -> None:
        """Forget the shared values; close the client if this executor opened it."""
        self._shared.clear()
        if self.owned:
            self.client.close()


class _Stalled(Exception):
    """A task the watchdog found making no progress (becomes a ClusterError past the limit)."""


class _Watch:
    """The wait on one sending of one task: since when, and since when without progress."""

    def __init__(self, name: str, sends: int = 1) -> None:
        import time

        self.name, self.sends = name, sends
        self.start = time.monotonic()
        self.quiet_since: float | None = None
        self.quiet_polls = 0


#: scheduler states of a task that will move without help: running on a worker, or waiting
#: for its inputs or for a thread (queued)
_LIVE_STATES = ("processing", "waiting", "queued")


def _why_idle(facts: Mapping[str, Any]) -> str | None:
    """Why the facts of :func:`_scheduler_probe` show no progress, or None if they do."""
    state = facts.get("state")
    if state in _LIVE_STATES and facts.get("working"):
        return None
    if state is None:
        return "the scheduler does not know its key"
    if state == "processing":
        return f"processing on {facts.get('worker')}, which runs nothing"
    if state in _LIVE_STATES:
        return f"{state!r} while none of {facts.get('workers', 0)} workers runs anything"
    return f"{state!r} at the scheduler, yet its result never came"


def _scheduler_probe() -> Callable[..., dict[str, Any]]:
    """The function ``run_on_scheduler`` runs for the watchdog: the task's state, and whether
    the worker processing it (or, for a task not yet placed, any worker) reports in its last
    heartbeat a task executing or data arriving.

    One round trip, a dictionary look-up at the scheduler. ``Client.processing`` or
    ``who_has`` cannot say whether the worker holding a task does anything (a worker that
    lost the task still shows it processing), and ``scheduler_info`` ships every worker's
    metrics. Made inside a function so that cloudpickle sends it by value: the scheduler needs
    no lumijax. A version of ``distributed`` without the heartbeat counts it reads makes it
    report "working" (wait), and one without the attributes it needs makes it fail (the
    watchdog stands down, with a warning): never a false stall.
    """
    def probe(key, dask_scheduler=None) -> dict[str, Any]:
        # a thread running a task (a cancelled one holds its thread until it returns), or a
        # task's input on its way from another worker
        busy = ("executing", "long-running", "cancelled", "resumed", "flight")

        def working(ws) -> bool:
            metrics = getattr(ws, "metrics", None)
            if metrics is None:  # a version without heartbeat metrics: cannot tell, so wait
                return True
            if not metrics:  # no heartbeat yet (a worker just started): idle for now
                return False
            counts = metrics.get("task_counts")
            if counts is None:  # a version without the worker's task counts: cannot tell
                return True
            return any(counts.get(s, 0) for s in busy)

        ts = dask_scheduler.tasks.get(key)
        state = None if ts is None else str(ts.state)
        ws = getattr(ts, "processing_on", None) if state == "processing" else None
        workers = list(dask_scheduler.workers.values())
        return {"state": state, "worker": getattr(ws, "address", None),
                "working": working(ws) if ws is not None else any(map(working, workers)),
                "workers": len(workers)}

    return probe


def _precision_plugin(x64: bool):
    """A worker plugin setting JAX's x64 mode on every worker, present and future (a worker
    started after one died gets it too)."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class Precision(WorkerPlugin):
        def __init__(self, x64: bool) -> None:
            self.x64 = x64

        def setup(self, worker) -> None:
            import jax

            jax.config.update("jax_enable_x64", self.x64)

    return Precision(x64)


def _on_worker(item, *, fn, x64: bool, **shared):
    """A task as the driver would run it: in its precision (x64 on or off), with JAX's
    persistent compilation cache on (a worker loads the kernels another process compiled)."""
    import jax

    from .._jit_cache import enable_compilation_cache
    from ._shared import worker_cached

    worker_cached(("jax compilation cache",), lambda: enable_compilation_cache() or True)
    with jax.enable_x64(x64):
        return fn(item, **shared)


def connect(scheduler: Any, *, timeout_s: float = CONNECT_TIMEOUT_S) -> Executor:
    """An executor for ``scheduler``: an :class:`Executor` as it is, a ``distributed.Client``
    (not closed after), or an address such as ``tcp://HOST:8786`` (connected within
    ``timeout_s`` seconds, else :class:`ClusterError`)."""
    if isinstance(scheduler, Executor):
        return scheduler
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - the cluster extra not installed
        raise ClusterError("running on a Dask cluster needs the 'cluster' extra: "
                           "pip install 'lumijax[cluster]'", key="scheduler") from None
    if isinstance(scheduler, Client):
        return DaskExecutor(scheduler)
    address = str(scheduler)
    if not _ADDRESS.match(address):
        raise ClusterError(f"{address!r} is not a scheduler address; expected tcp://HOST:PORT "
                           "(e.g. tcp://10.0.0.5:8786)", key="scheduler")
    try:
        client = Client(address, timeout=f"{timeout_s}s", set_as_default=False)
    except (OSError, TimeoutError) as e:
        raise ClusterError(f"no Dask scheduler answered at {address} within {timeout_s:g} s "
                           f"({type(e).__name__}); start one (dask scheduler) or check the "
                           "address and the firewall", key="scheduler") from None
    return DaskExecutor(client, owned=True)


