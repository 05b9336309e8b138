"""State a worker process builds once and keeps: an Embree scene per triangle set.

A task that needs a ray caster gets the scene's triangles (shared, sent once per worker) and
asks :func:`worker_cached` for the caster built on them: the first task on a worker builds it,
every later task there reuses it. Keys are content digests (:func:`digest`), so two stages that
send the same triangles share one caster.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any

import numpy as np

__all__ = ["worker_cached", "digest", "WORKER_CACHE_SIZE"]

WORKER_CACHE_SIZE = 4
"""Objects a worker keeps (least recently used first out): a study needs one caster."""

_CACHE: OrderedDict[Hashable, Any] = OrderedDict()
_LOCK = threading.Lock()  # a worker may run several task threads
#: Objects built in this process by the first item of their key (tests: an Embree scene once
#: per worker, not once per task).
BUILT: dict[Hashable, int] = {}


def worker_cached(key: Hashable, build: Callable[[], Any]) -> Any:
    """``build()`` the first time this process sees ``key``, the same object afterwards."""
    with _LOCK:
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key]
    value = build()
    with _LOCK:
        if key not in _CACHE:
            kind = key[0] if isinstance(key, tuple) else key
            BUILT[kind] = BUILT.get(kind, 0) + 1
        value = _CACHE.setdefault(key, value)
        while len(_CACHE) > WORKER_CACHE_SIZE:
            _CACHE.popitem(last=False)
    return value


def digest(a: np.ndarray) -> str:
    """Content digest of an array (shape, dtype and bytes): a worker cache key."""
    a = np.ascontiguousarray(a)
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{a.dtype.str}{a.shape}".encode())
    h.update(memoryview(a).cast("B"))
    return h.hexdigest()
