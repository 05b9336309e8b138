"""One two-process Dask ``LocalCluster`` for the parallel tests (a module's worth of tests share
it: starting worker processes is the slow part), and the small study they light.

The workers are real processes (``processes=True``): everything a task needs crosses a pickle,
as on a remote cluster. They share the test session's JAX compilation cache folder
(``LUMIJAX_JAX_CACHE``, set by the top conftest and inherited), so they load the kernels this
process compiled instead of compiling them again.
"""

from __future__ import annotations

import helpers as h
import pytest

distributed = pytest.importorskip("distributed")

# A closed 4 × 3 × 3 m room (ρ 0.5) with a box on the floor (shadows and a shadowed block
# pair), two networks, an area source, and two levels of patches (the final gather runs).
ROOM = h.box_room(
    "target_patches = 160\noperator_patches = 50\nmax_block = 16\ngather_rays = 16\n"
    "spectral_samples = 0\ncache = false",
    extra=h.box((1.5, 1.0, 0.0), (2.5, 2.0, 1.2), normals="outward")
    + h.area_lamp("panel", (1.6, 0.4, 2.99), (0, 0.6, 0), (0.6, 0, 0), 1500.0, network="b"))


@pytest.fixture(scope="module")
def client():
    from lumijax._jit_cache import enable_compilation_cache

    enable_compilation_cache()  # what this process compiles, the workers load
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, memory_limit="700MiB") as cluster, \
            distributed.Client(cluster) as c:
        c.wait_for_workers(2, timeout=60)
        yield c
