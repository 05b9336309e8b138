"""Past one process: the parallel stages on a Dask cluster, the solve across devices.

* :class:`Executor` (``_executor.py``): the stages that are embarrassingly parallel (direct
  light by luminaire batches, the transport build by block pairs, the final gather by patch
  chunks) map their batches over :func:`current_executor` — the local loop, or a Dask cluster
  when ``compute(..., scheduler=...)`` / ``lumijax run --scheduler`` gives one.
* :func:`worker_cached` (``_shared.py``): what a worker builds once (an Embree scene).
* :func:`shard_rows` (``_sharding.py``): the operator's rows over a JAX device mesh, so the
  unchanged ``jit`` solve runs on several devices (and hosts, through ``jax.distributed``).
* :func:`release_freed_memory` (``_memory.py``): what threads freed, back to the system after
  a threaded stage (glibc keeps it in their arenas, out of the next stage's reach).

This layer sits below the physics (it imports nothing of lumijax but ``errors``); the
per-batch functions live beside the loops they replace. docs/parallel.md.
"""

from ._executor import (
    CONNECT_TIMEOUT_S as CONNECT_TIMEOUT_S,
    ClusterError as ClusterError,
    DaskExecutor as DaskExecutor,
    Executor as Executor,
    LocalExecutor as LocalExecutor,
    batches as batches,
    connect as connect,
    current_executor as current_executor,
    executor_scope as executor_scope,
    local_threads as local_threads,
    threaded_map as threaded_map,
    use_executor as use_executor,
)
from ._memory import release_freed_memory as release_freed_memory
from ._sharding import (
    ROWS as ROWS,
    bytes_per_device as bytes_per_device,
    device_mesh as device_mesh,
    initialize as initialize,
    shard_columns as shard_columns,
    shard_rows as shard_rows,
)
from ._shared import digest as digest, worker_cached as worker_cached
