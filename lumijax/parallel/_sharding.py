"""The radiosity solve across devices with JAX's own sharding (``jax.sharding``).

The transport operator is a pytree of stacked blocks ``(pairs, rows, columns)`` (and low-rank
factors ``(pairs, rows, rank)``). :func:`shard_rows` places every such array with its **row
axis** (axis 1, the receiving patches of each block) split over a one-dimensional device mesh,
so each device holds ``1/D`` of every block; index vectors follow their rows, and small
arrays (areas, block ids) are replicated. The solve itself is unchanged: ``solve_radiosity``
is a ``jit`` of the operator, and XLA's SPMD partitioner turns each block product into local
products plus one all-reduce of the ``(patches, columns)`` result per Krylov step. Padded
block sizes are multiples of 8 (the √2 ladder of ``radiosity._build``), so 2, 4 or 8 devices
split every block evenly; an axis that does not divide is replicated, never padded.

Several hosts: call :func:`initialize` (``jax.distributed.initialize``) on every process
before anything else touches JAX, give every process the same operator (from the shared cache:
``cached_operator`` is keyed by content), then :func:`shard_rows` on ``device_mesh()`` spans
every host's devices: each process supplies only the shards its own devices hold
(``jax.make_array_from_callback``). docs/parallel.md has the recipe.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

__all__ = ["ROWS", "device_mesh", "shard_rows", "shard_columns", "initialize",
           "bytes_per_device"]

ROWS = "rows"
"""Name of the mesh axis the operator's rows are split over."""


def device_mesh(devices: Sequence | None = None, axis: str = ROWS) -> Mesh:
    """A one-dimensional mesh over ``devices`` (default every device of every process)."""
    devs = np.asarray(jax.devices() if devices is None else list(devices), dtype=object)
    return Mesh(devs.reshape(-1), (axis,))


def _place(x, sharding: NamedSharding):
    host = np.asarray(x)
    # from host data on every process: multi-host safe (each one fills its own devices)
    return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])


def shard_rows(tree: Any, mesh: Mesh, *, min_rank: int = 2) -> Any:
    """``tree`` with every array of at least ``min_rank`` axes split along axis 1 over
    ``mesh`` (when the axis divides by the mesh size), every other array replicated."""
    (axis,) = mesh.axis_names
    n = mesh.devices.size
    split = NamedSharding(mesh, PartitionSpec(None, axis))
    whole = NamedSharding(mesh, PartitionSpec())

    def place(x):
        if not isinstance(x, jax.Array | np.ndarray):
            return x
        ok = x.ndim >= min_rank and x.shape[1] % n == 0
        return _place(x, split if ok else whole)

    return jax.tree_util.tree_map(place, tree)


def shard_columns(b: Any, mesh: Mesh) -> jax.Array:
    """A right-hand side ``(patches, columns)`` split by columns (networks × wavelengths) over
    ``mesh`` when they divide, else replicated: a solve of many columns spreads its vectors."""
    (axis,) = mesh.axis_names
    host = np.asarray(b)
    ok = host.ndim == 2 and host.shape[1] % mesh.devices.size == 0
    return _place(host, NamedSharding(mesh, PartitionSpec(None, axis) if ok else PartitionSpec()))


def bytes_per_device(tree: Any) -> dict[str, int]:
    """Bytes of ``tree``'s arrays held on each device (by device id): what a sharded
    operator costs each one."""
    out: dict[str, int] = {}
    for leaf in jax.tree_util.tree_leaves(tree):
        if isinstance(leaf, jax.Array):
            for shard in leaf.addressable_shards:
                key = str(shard.device.id)
                out[key] = out.get(key, 0) + int(shard.data.nbytes)
    return out


def initialize(coordinator: str | None = None, processes: int | None = None,
               process: int | None = None) -> None:
    """``jax.distributed.initialize`` for a multi-host solve (each host one process; on a
    SLURM or TPU cluster the arguments may be omitted: JAX reads them from the environment)."""
    jax.distributed.initialize(coordinator_address=coordinator, num_processes=processes,
                               process_id=process)
