"""``release_freed_memory``: what a worker thread freed goes back to the system (glibc)."""

from __future__ import annotations

import platform
import sys
import threading

import numpy as np
import pytest

from lumijax.parallel import release_freed_memory

glibc = pytest.mark.skipif(not sys.platform.startswith("linux")
                           or platform.libc_ver()[0] != "glibc", reason="glibc's malloc_trim")


def _rss_mib() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


@glibc
def test_what_a_thread_freed_is_returned():
    def work(out):
        blocks = [np.ones(8192) for _ in range(4000)]  # 250 MiB of 64 KiB blocks, in its arena
        out.append(blocks[-1])  # the arena's last block stays: nothing to trim from its top

    out: list = []
    t = threading.Thread(target=work, args=(out,))
    t.start()
    t.join()
    before = _rss_mib()
    assert release_freed_memory()
    assert before - _rss_mib() > 150  # MiB: the freed blocks' pages, not only the top's
