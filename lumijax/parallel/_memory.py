"""Freed memory handed back to the system after a stage that worked on threads.

glibc's allocator keeps what a thread frees in that thread's own arena, for that thread to
reuse; the stages after the direct light allocate on other threads (the solve, XLA's), which
cannot, so the process' peak grows by what the threaded stages left behind. On the LoD-0
courtyard that was 1–2 GiB of the 4.5–5.7 GiB peak (benchmarks/RESULTS.md, "Session 27").
``malloc_trim`` returns the free pages of every arena; elsewhere (macOS, Windows, musl) this
does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import sys

__all__ = ["release_freed_memory"]


@functools.cache
def _malloc_trim():
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
    except (OSError, AttributeError):  # no glibc (musl has no malloc_trim)
        return None


def release_freed_memory() -> bool:
    """Return the free pages of every allocator arena to the system (glibc's
    ``malloc_trim(0)``); True where that ran."""
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True
