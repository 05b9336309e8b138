"""Run by test_sharding.py in a fresh process with two CPU devices
(``XLA_FLAGS=--xla_force_host_platform_device_count=2``): the radiosity solve of one operator,
unsharded and with its rows split over the two devices. Prints one JSON line."""

from __future__ import annotations

import json

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from lumijax.parallel import bytes_per_device, device_mesh, shard_columns, shard_rows  # noqa: E402
from lumijax.radiosity import build_operator, mesh_patches, partition  # noqa: E402
from lumijax.radiosity._solve import solve_radiosity  # noqa: E402
from lumijax.scene._geometry import box_triangles  # noqa: E402


def main() -> None:
    # a room with a pillar: shadowed pairs, several buckets (dense and, far apart, low rank)
    tri = np.concatenate([box_triangles((0, 0, 0), (6, 4, 3), inward=True),
                          box_triangles((2.5, 1.5, 0), (3.5, 2.5, 3), inward=False)])
    patches = mesh_patches(tri, np.zeros(len(tri), int), np.r_[np.zeros(12, int),
                                                               np.ones(12, int)],
                           patch_size=0.8)
    part = partition(patches, max_block=32, occluders=tri)
    op = build_operator(patches, part, tri, dtype=np.float64)
    rng = np.random.default_rng(1)
    rho = np.full(patches.n, 0.6)
    b0 = rng.uniform(0.0, 100.0, (patches.n, 4))  # four columns (networks × wavelengths)
    plain = solve_radiosity(op, rho, b0, rtol=1e-12, correct_rows=False)
    mesh = device_mesh()
    sharded_op = shard_rows(op, mesh)
    sharded = solve_radiosity(sharded_op, rho, shard_columns(b0, mesh), rtol=1e-12,
                              correct_rows=False)
    # an independent solve of the same system: numpy's LU of (I − ρF) on the dense operator
    dense = op.todense()
    per_device = bytes_per_device(sharded_op.buckets)
    total = sum(int(b.nbytes) for b in op.buckets)
    out = dict(
        devices=len(jax.devices()), patches=int(patches.n),
        max_abs_diff=float(np.abs(np.asarray(sharded.value) - np.asarray(plain.value)).max()),
        scale=float(np.abs(np.asarray(plain.value)).max()),
        per_device=per_device, bucket_value_bytes=total,
        shardings=sorted({str(b.recv.sharding.spec) for b in sharded_op.buckets}),
        kinds=sorted({b.kind for b in op.buckets}),
        dense_lu_diff=float(np.abs(np.linalg.solve(
            np.eye(patches.n) - rho[:, None] * dense, b0) - np.asarray(plain.value)).max()),
        iterations=[int(plain.iterations), int(sharded.iterations)],
    )
    print(json.dumps(out))


if __name__ == "__main__":
    main()
