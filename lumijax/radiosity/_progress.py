"""Progress from inside a compiled solve.

A large solve batch runs as one XLA program for minutes (the 10⁶-patch courtyard's: 200 s), so
a progress report after each batch says nothing in between. A solver built with
``reporting()`` (``_solvers.py``) calls :func:`report` after every step with its worst
column's residual, the steps so far and the steps' worth of work still due once it has
converged (the final true residual's products). The host turns that into the fraction of the
batch done:

* the solvers see columns scaled to unit maximum, so every solve starts at a residual of 1,
  and ``f = log r / log tol`` is how far the residual has come (:func:`converged_fraction`);
* a Krylov or Jacobi solve converges linearly, so k steps that came ``f`` of the way predict
  ``k / f`` steps in all, and the batch is ``k / (k / f + tail)`` done
  (:func:`batch_fraction`): equal steps take equal time, so a time left computed from it holds.

The fraction told never moves back (BiCGStab's residual is not monotonic).

The listener is one per process (:func:`listening`); the callback that reaches it is a
``jax.debug.callback`` of this module's :func:`_tell`, the same function in every program, so
that a new listener does not mean a new compile.
"""

from __future__ import annotations

import contextlib
import math
import threading
from collections.abc import Callable, Iterator

import jax
import numpy as np

__all__ = ["report", "listening", "converged_fraction", "batch_fraction"]

_lock = threading.Lock()
_listener: list = [None, 0.0]  # (called with a fraction 0…1, the fraction told so far)


def converged_fraction(residual: float, tol: float) -> float:
    """How far a solve that started at residual 1 has come towards ``tol`` (0…1), on a log
    scale: ``log(residual) / log(tol)``."""
    if not residual > 0.0 or not math.isfinite(residual):
        return 1.0 if residual == 0.0 else 0.0
    if not 0.0 < tol < 1.0:
        return 1.0 if residual <= tol else 0.0
    return min(max(math.log(residual) / math.log(tol), 0.0), 1.0)


def batch_fraction(residual: float, tol: float, steps: int, tail: float) -> float:
    """The share of a solve done after ``steps`` steps that brought the residual from 1 to
    ``residual``, with ``tail`` steps' worth of work due after convergence (module
    docstring)."""
    f = converged_fraction(residual, tol)
    if steps <= 0 or f <= 0.0:
        return 0.0
    return steps / (steps / f + max(tail, 0.0))


def report(residual, tol, steps, tail: float) -> None:
    """In a traced solver step: tell the listener (if any) this step's worst residual, the
    steps taken (traced) and the steps' worth of work due after convergence."""
    jax.debug.callback(_tell, residual, tol, steps, np.float32(tail))


def _tell(residual, tol, steps, tail) -> None:
    with _lock:
        fn, told = _listener
        if fn is None:
            return
        f = batch_fraction(float(np.max(residual)), float(np.max(tol)), int(np.max(steps)),
                           float(tail))
        if f <= told:
            return
        _listener[1] = f
    fn(f)


@contextlib.contextmanager
def listening(fn: Callable[[float], None]) -> Iterator[bool]:
    """Pass the reporting solves' fractions to ``fn`` while inside; yields whether it listens
    (False when another solve of this process already does: its reports stay its own)."""
    with _lock:
        taken = _listener[0] is not None
        if not taken:
            _listener[0], _listener[1] = fn, 0.0
    try:
        yield not taken
    finally:
        if not taken:
            with _lock:
                _listener[0], _listener[1] = None, 0.0
