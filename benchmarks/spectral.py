"""Cost of the spectral radiosity solve vs the number of spectral samples, and the samples the
segmentation chooses for the default study.

    python benchmarks/spectral.py [--patch-size 0.25] [--networks 3]

A 6 × 5 × 3 m room (inward box) with a table, meshed and solved with
``lumijax.radiosity.solve_radiosity`` for ``networks × n`` columns, n the number of spectral samples
(each column: per-wavelength reflectance, random direct light).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def default_study_samples(max_samples=16):
    from lumijax.spectral import Spectrum, segment

    lamps = [Spectrum.from_name("A"), Spectrum.from_name("FL11")]
    mats = [
        Spectrum.from_srgb((0.80, 0.74, 0.62), name="stone"),
        Spectrum.grey(0.25, name="paving"),
        Spectrum.grey(0.08, name="glass"),
    ]
    t0 = time.perf_counter()
    s = segment(lamps, mats, max_samples=max_samples)
    return s, time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--patch-size", type=float, default=0.25)
    ap.add_argument("--networks", type=int, default=3)
    ap.add_argument("--samples", type=int, nargs="+", default=[1, 3, 8, 12, 16, 32, 81])
    args = ap.parse_args(argv)

    import jax
    import jax.numpy as jnp
    import trimesh

    from lumijax.radiosity import build_operator, mesh_patches, partition, solve_radiosity

    room = trimesh.creation.box(extents=(6, 5, 3))
    room.apply_translation([3, 2.5, 1.5])
    room.invert()
    table = trimesh.creation.box(extents=(1.6, 0.9, 0.05))
    table.apply_translation([2.5, 2.0, 0.75])
    tri = np.concatenate([room.triangles, table.triangles])
    mat = np.concatenate([np.zeros(len(room.triangles), int), np.ones(len(table.triangles), int)])
    p = mesh_patches(tri, mat, patch_size=args.patch_size)
    part = partition(p, 1024, occluders=tri)
    op = build_operator(p, part, tri)
    print(
        f"machine: {platform.node()} {platform.machine()}, {os.cpu_count()} cores, "
        f"jax {jax.__version__} ({jax.default_backend()})"
    )
    print(f"room: {p.n} patches, {args.networks} networks\n")
    print("| samples n | columns | solve (s) | per column (ms) | operator products |")
    print("|---:|---:|---:|---:|---:|")
    rng = np.random.default_rng(0)
    for n in args.samples:
        rho = jnp.asarray(rng.uniform(0.2, 0.8, (2, n))[p.material][:, None, :], jnp.float32)
        b0 = jnp.asarray(rng.random((p.n, args.networks, n)), jnp.float32)
        sol = solve_radiosity(op, rho, b0)  # compile
        sol.value.block_until_ready()
        reps = 3
        t0 = time.perf_counter()
        for _ in range(reps):
            sol = solve_radiosity(op, rho, b0)
            sol.value.block_until_ready()
        dt = (time.perf_counter() - t0) / reps
        cols = args.networks * n
        print(f"| {n} | {cols} | {dt:.3f} | {1e3 * dt / cols:.2f} | {int(sol.iterations)} |")

    s, dt = default_study_samples()
    print(
        f"\nDefault study (CIE A + FL11 lamps; stone sRGB(0.80, 0.74, 0.62), paving 0.25, "
        f"glass 0.08): segmentation in {dt:.2f} s chose {s.n} samples (nm):"
    )
    print("  " + ", ".join(f"{x:.1f}" for x in s.wavelengths_nm))
    print(
        "  intervals with nodes: "
        + ", ".join(f"{lo:g}–{hi:g} {rule} ×{m}" for lo, hi, rule, m in s.intervals if m)
    )


if __name__ == "__main__":
    main()
