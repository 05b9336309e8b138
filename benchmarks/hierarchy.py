"""How the operator's memory grows with patches: clusters of blocks (H-matrix) against one level.

    python benchmarks/hierarchy.py                                  # courtyard, 4k … 32k patches
    python benchmarks/hierarchy.py --scene hall --patches 4000 16000 64000
    python benchmarks/hierarchy.py --flat-up-to 16000               # one-level builds to compare

Scenes: ``courtyard`` is the study generator's courtyard (studies/courtyard/make_courtyard.py;
4 facades × ``--bays`` bays with reveals, columns and cornices: far pairs are self-shadowed, so
the hull test proves few of them clear and most are compressed with shadow rays and the exact
check); ``hall`` is one empty 40 × 40 × 10 m hall (every far pair provably clear: no ray).

For each patch count: mesh, partition (``--max-block``), then ``build_operator`` with the
defaults (``hierarchical=True``) and, up to ``--flat-up-to`` patches, with
``hierarchical=False`` (low rank only for single block pairs, the previous scheme). Prints, per
build: time, rays, near-field (dense) and far-field (low-rank) MiB, the growth exponent of the
total against the previous size (1 = linear, 2 = quadratic), and where both were built the
relative difference of one product F·X (X random, 8 columns) between them. The memory is the
operator's stored arrays (padding included), not the process RSS.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def courtyard_triangles(bays: int):
    spec = importlib.util.spec_from_file_location(
        "make_courtyard", ROOT / "studies" / "courtyard" / "make_courtyard.py")
    gen = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = gen
    spec.loader.exec_module(gen)
    from lumijax import load_study

    c = dataclasses.replace(gen.FULL, facades=tuple("SENW"), bays=bays, floods_per_facade=2,
                            operator_patches=None)
    folder = Path(tempfile.mkdtemp(prefix="lumijax-hierarchy-"))
    gen.write_study(c, folder / "study.toml", folder / "assets", "benchmark")
    tri = load_study(folder / "study.toml").scene.triangles
    return tri.vertices, tri.group


def hall_triangles():
    import trimesh

    m = trimesh.creation.box(extents=(40, 40, 10))
    m.invert()
    return m.triangles, np.zeros(len(m.triangles), int)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=("courtyard", "hall"), default="courtyard")
    ap.add_argument("--bays", type=int, default=10, help="courtyard: bays per facade")
    ap.add_argument("--patches", type=int, nargs="+", default=[4000, 8000, 16000, 32000])
    ap.add_argument("--max-block", type=int, default=1024)
    ap.add_argument("--flat-up-to", type=int, default=16000)
    args = ap.parse_args(argv)

    import jax.numpy as jnp

    from lumijax.lighting._pipeline import auto_patch_size
    from lumijax.radiosity import FormFactorSettings, build_operator, mesh_patches, partition
    from lumijax.scene._raycast import RayCaster

    tri, group = courtyard_triangles(args.bays) if args.scene == "courtyard" else hall_triangles()
    tri = np.asarray(tri, np.float64)
    area = float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                      axis=1).sum())
    caster = RayCaster(tri)
    print(f"machine: {platform.platform()}, {platform.processor() or platform.machine()}; "
          f"scene {args.scene}: {len(tri):,} triangles, {area:,.0f} m²", flush=True)
    rows, last = [], {}
    for target in args.patches:
        p = mesh_patches(tri, group=group, patch_size=auto_patch_size(area, target))
        t = time.perf_counter()
        part = partition(p, args.max_block, occluders=caster)
        t_part = time.perf_counter() - t
        x = jnp.asarray(np.random.default_rng(0).random((p.n, 8)), jnp.float32)
        products = {}
        for mode in ("clusters", "blocks"):
            if mode == "blocks" and p.n > args.flat_up_to:
                continue
            s = FormFactorSettings(hierarchical=mode == "clusters")
            t = time.perf_counter()
            op = build_operator(p, part, caster, s, occluder_triangles=tri)
            dt = time.perf_counter() - t
            products[mode] = np.asarray(op.matmul(x), np.float64)
            total = op.nbytes
            growth = (np.log(total / last[mode][1]) / np.log(p.n / last[mode][0])
                      if mode in last else float("nan"))
            last[mode] = (p.n, total)
            i = op.info
            rows.append(dict(
                patches=p.n, blocks=part.n_blocks, pairs=len(part.pairs), mode=mode,
                partition_s=t_part, build_s=dt, rays=i["rays"],
                far_leaves=i["lowrank_pairs"], cluster_leaves=i["lowrank_cluster_pairs"],
                covered=i["lowrank_block_pairs"], rank_mean=i["lowrank_rank_mean"],
                rank_max=i["lowrank_rank_max"], near_mib=op.dense_nbytes / 2**20,
                far_mib=op.lowrank_nbytes / 2**20, total_mib=total / 2**20, growth=growth,
                diff=float("nan")))
            print(f"  {p.n:,} patches, {mode}: {dt:.1f} s, {total / 2**20:.1f} MiB", flush=True)
            del op
        if len(products) == 2:
            a, b = products["clusters"], products["blocks"]
            rows[-2]["diff"] = float(np.linalg.norm(a - b) / np.linalg.norm(b))
        if target != args.patches[-1]:
            _table(rows)  # so far: a run cut short keeps its rows

    _table(rows)


def _table(rows) -> None:
    print("\n| patches | blocks | visible block pairs | far field | build (s) | rays | far leaves "
          "(of clusters) | block pairs low rank | rank mean / max | near MiB | far MiB | total MiB "
          "| growth exponent | ‖ΔFX‖/‖FX‖ vs blocks |")
    print("|" + "---|" * 14)
    for r in rows:
        print(f"| {r['patches']:,} | {r['blocks']} | {r['pairs']:,} | {r['mode']} | "
              f"{r['build_s']:.1f} | {r['rays'] / 1e6:.1f} M | {r['far_leaves']} "
              f"({r['cluster_leaves']}) | {r['covered']:,} | {r['rank_mean']:.1f} / "
              f"{r['rank_max']} | {r['near_mib']:.1f} | {r['far_mib']:.1f} | "
              f"{r['total_mib']:.1f} | {r['growth']:.2f} | {r['diff']:.1e} |")


if __name__ == "__main__":
    main()
