"""The transport build on a Dask cluster: 1 and 2 local worker processes against the loop.

    python benchmarks/cluster.py [--patches 3000] [--rooms 4] [--workers 1 2]

The scene is benchmarks/radiosity.py's furnished rooms (tables and cabinets cast shadows), at
about N patches. For each worker count a ``LocalCluster`` (processes, one thread each) builds
the operator twice: the first run pays the workers' start (imports, Embree scene, JAX
compilation, most of it loaded from the persistent cache), the second is the one timed. The
serial part (the far-field walk and the bucket assembly, on the driver) is reported from the
build's own counters; the per-task overhead from a map of empty tasks. docs/parallel.md fits
its model to these figures. Prints one table and a JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))


def _noop(item, **_):
    return item


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--patches", type=int, default=3000)
    ap.add_argument("--rooms", type=int, default=4)
    ap.add_argument("--max-block", type=int, default=128)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()

    from distributed import Client, LocalCluster
    from radiosity import build_scene, patch_size_for

    from lumijax._jit_cache import enable_compilation_cache
    from lumijax.parallel import connect, use_executor
    from lumijax.radiosity import build_operator, mesh_patches, partition
    from lumijax.scene import RayCaster

    enable_compilation_cache()
    tri, groups, mats = build_scene(args.rooms)
    size = patch_size_for(tri, args.patches)
    patches = mesh_patches(tri, mats, groups, patch_size=size)
    caster = RayCaster(tri)
    part = partition(patches, max_block=args.max_block, occluders=caster)
    build_operator(patches, part, caster, occluder_triangles=tri)  # compile here first
    t = time.perf_counter()
    local = build_operator(patches, part, caster, occluder_triangles=tri)
    rows = [dict(workers=0, seconds=time.perf_counter() - t, tasks=0)]
    info = local.info
    dense = local.todense()
    for n in args.workers:
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            ex = connect(client)
            with use_executor(ex):
                t = time.perf_counter()
                build_operator(patches, part, caster, occluder_triangles=tri)
                cold = time.perf_counter() - t
                t = time.perf_counter()
                op = build_operator(patches, part, caster, occluder_triangles=tri)
                warm = time.perf_counter() - t
            t = time.perf_counter()
            list(ex.map(_noop, range(200)))
            overhead = (time.perf_counter() - t) / 200
            rows.append(dict(workers=n, seconds=warm, cold_s=cold,
                             tasks=ex.submitted["_near_task"] // 2, task_overhead_s=overhead,
                             max_abs_diff=float(np.abs(op.todense() - dense).max())))
    t1 = next(r["seconds"] for r in rows if r["workers"] == 1) if 1 in args.workers else None
    print(f"{patches.n} patches, {part.n_blocks} blocks, {len(part.pairs)} visible pairs, "
          f"{info['near_pairs']} near patch pairs, {info['rays']} rays; serial far-field walk "
          f"{info['lowrank_time_s']:.2f} s of {info['build_time_s']:.2f} s (loop)")
    print(f"{'workers':>8} {'build s':>9} {'cold s':>8} {'tasks':>6} {'task ms':>8} "
          f"{'speed-up':>9} {'efficiency':>10} {'max |ΔG|':>9}")
    for r in rows:
        su = "" if not t1 or not r["workers"] else f"{t1 / r['seconds']:.2f}"
        eff = "" if not t1 or not r["workers"] else f"{t1 / r['seconds'] / r['workers']:.2f}"
        print(f"{r['workers'] or 'loop':>8} {r['seconds']:9.2f} {r.get('cold_s', 0):8.2f} "
              f"{r['tasks']:6d} {1e3 * r.get('task_overhead_s', 0):8.1f} {su:>9} {eff:>10} "
              f"{r.get('max_abs_diff', 0):9.1e}")
    print(json.dumps(dict(patches=int(patches.n), blocks=int(part.n_blocks),
                          pairs=int(len(part.pairs)), serial_s=float(info["lowrank_time_s"]),
                          rows=rows, cpu=platform.processor() or platform.machine(),
                          cores=os.cpu_count(), load=os.getloadavg()[0])))


if __name__ == "__main__":
    main()
