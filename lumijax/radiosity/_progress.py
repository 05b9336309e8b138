"""Progress from inside a compiled solve.

A large solve batch runs as one XLA program for minutes (the 10⁶-patch courtyard's: 200 s), so
a progress report after each batch says nothing in between. A solver built with
``reporting()`` (``_solvers.py``) calls :func:`report` once per step with its worst column's
residual; the host turns that into the fraction of the way from the start to the tolerance on
a log scale. The solvers see columns scaled to unit maximum, so every solve starts at a
residual of 1, and a Krylov or Jacobi solve converges linearly: equal steps of the log residual
take equal time, which is what makes a time left computed from the fraction honest. The
fraction never moves back (BiCGStab's residual is not monotonic).

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

__all__ = ["report", "listening", "converged_fraction"]

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


def report(residual, tol) -> None:
    """In a traced solver step: tell the listener (if any) this step's worst residual."""
    jax.debug.callback(_tell, residual, tol)


def _tell(residual, tol) -> None:
    with _lock:
        fn, told = _listener
        if fn is None:
            return
        f = converged_fraction(float(np.max(residual)), float(np.max(tol)))
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
