"""The courtyard study at scale, stage by stage: time and peak memory of each step of a run.

    python benchmarks/courtyard.py                        # full scale: 4 × 40 bays, 3,000 lights
    python benchmarks/courtyard.py --bays 10 --target-patches 20000   # a quarter, to extrapolate
    python benchmarks/courtyard.py --operator-patches 0   # one level (the dense P² operator)

Generates the study (studies/courtyard/make_courtyard.py) into a temporary folder, then runs the
stages of ``lumijax.compute`` one after the other in this process, as ``solve_lighting`` does:
load (config + scene), direct light on the grid points, mesh, partition, operator build, direct
light on the patches, spectral setup + gather rays, the batched solve of every network, and
writing results. With ``--operator-patches`` (default: the full study's, two levels,
docs/radiosity.md) the operator and the solve run on coarse elements and the fine stages follow:
direct light on the fine patches (the elements get its area means), the coarse solve, then the
fine gather rays and the reflection onto the fine patches, and patches.vtp of the fine level.
A sampling thread reads the process RSS every 20 ms, so each stage reports its
own peak (not only the process high-water mark); the table prints the peak and its rise over
the RSS at the stage's start. Without a cache: every run builds the operator.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import os
import platform
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


class _Sampler(threading.Thread):
    def __init__(self):
        super().__init__(daemon=True)
        self.peak = _rss()
        self.running = True

    def run(self):
        while self.running:
            self.peak = max(self.peak, _rss())
            time.sleep(0.02)


def _generator():
    spec = importlib.util.spec_from_file_location(
        "make_courtyard", ROOT / "studies" / "courtyard" / "make_courtyard.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--facades", default="SENW")
    p.add_argument("--bays", type=int, default=40)
    p.add_argument("--floods", type=int, default=24)
    p.add_argument("--lod", type=int, default=0)
    p.add_argument("--target-patches", type=int, default=140_000)  # configs/courtyard.toml
    p.add_argument("--spectral-samples", type=int, default=8)
    p.add_argument("--gather-rays", type=int, default=256)
    p.add_argument("--max-block", type=int, default=1024)
    p.add_argument("--operator-patches", type=int, default=None,
                   help="elements of the two-level operator (default: the study's; 0: one level)")
    p.add_argument("--stop-after", default=None, help="stage name to stop after")
    args = p.parse_args(argv)

    gen = _generator()
    c = dataclasses.replace(
        gen.FULL, facades=tuple(args.facades), bays=args.bays, floods_per_facade=args.floods,
        lod=args.lod, target_patches=args.target_patches,
        spectral_samples=args.spectral_samples, gather_rays=args.gather_rays,
        operator_patches=(gen.FULL.operator_patches if args.operator_patches is None
                          else args.operator_patches or None))
    folder = Path(tempfile.mkdtemp(prefix="lumijax-courtyard-"))
    gen.write_study(c, folder / "study.toml", folder / "assets", "benchmark")

    from lumijax import load_study
    from lumijax.direct import direct_illuminance
    from lumijax.lighting import LightingSolution
    from lumijax.lighting._pipeline import _emission_groups, _grouped_scene, auto_patch_size
    from lumijax.lighting._solution import shoot
    from lumijax.lighting._spectral import SpectralSetup
    from lumijax.radiosity import build_operator, mesh_patches, partition
    from lumijax.radiosity._final_gather import (
        build_fine_gather,
        element_direct,
        fine_reflectance,
        reflect_onto_fine,
    )
    from lumijax.radiosity._gather import build_gather

    sampler = _Sampler()
    sampler.start()
    rows: list[tuple[str, float, int, int, str]] = []
    st: dict = {}

    def stage(name, fn, note=lambda r: ""):
        base = _rss()
        sampler.peak = base
        t = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t
        time.sleep(0.05)
        rows.append((name, dt, sampler.peak, sampler.peak - base, note(out)))
        print(f"  {name}: {dt:.1f} s, peak RSS {sampler.peak / 2**30:.2f} GiB "
              f"(+{(sampler.peak - base) / 2**30:.2f}) {note(out)}", flush=True)
        if args.stop_after == name:
            _table(rows, c, st)
            sys.exit(0)
        return out

    study = stage("load (config + scene)", lambda: load_study(folder / "study.toml"),
                  lambda s: f"{len(s.scene.triangles):,} triangles, "
                            f"{len(s.scene.luminaires):,} luminaires, "
                            f"{len(s.scene.networks)} networks")
    sc = study.scene
    points = np.concatenate([g.points for g in sc.grids])
    normals = np.concatenate([g.normals for g in sc.grids])
    group_of, groups = _emission_groups(sc)
    gscene = _grouped_scene(sc, group_of, len(groups))
    st.update(luminaires=len(sc.luminaires), networks=len(sc.networks),
              groups=len(groups), points=len(points), triangles=len(sc.triangles))
    dpts = stage("direct light, grid points",
                 lambda: direct_illuminance(gscene, points, normals),
                 lambda d: f"{len(points):,} points, {d.shadow_rays:,} shadow rays")
    tri = sc.triangles
    size = auto_patch_size(float(tri.areas.sum()), c.target_patches)
    patches = stage("mesh", lambda: mesh_patches(tri.vertices, tri.material, tri.group,
                                                 patch_size=size),
                    lambda pt: f"{pt.n:,} patches of ~{size:.2f} m")
    st["patches"] = patches.n
    fine = None
    if c.operator_patches:
        esize = auto_patch_size(float(tri.areas.sum()), c.operator_patches)
        fine = patches
        patches = stage("mesh elements", lambda: mesh_patches(
            tri.vertices, tri.material, tri.group, patch_size=esize),
            lambda pt: f"{pt.n:,} elements of ~{esize:.2f} m (operator_patches "
                       f"{c.operator_patches:,})")
        st["elements"] = patches.n
    caster = sc.raycaster
    part = stage("partition", lambda: partition(patches, max_block=args.max_block,
                                                occluders=caster),
                 lambda pa: _part_note(pa))
    op = stage("operator build", lambda: build_operator(patches, part, caster,
                                                        dtype=np.float32),
               lambda o: f"{o.nbytes / 2**30:.2f} GiB stored ({o.lowrank_nbytes / 2**30:.2f} low "
                         f"rank); {o.info['near_pairs']:,} near patch pairs, "
                         f"{o.info['lowrank_pairs']}/{o.info['lowrank_candidates']} block pairs "
                         f"low rank, {o.info['rays']:,} rays ({o.info['ray_time_s']:.0f} s)")
    st["operator_bytes"] = op.nbytes
    if fine is None:
        dpatch = stage("direct light, patches",
                       lambda: direct_illuminance(gscene, patches.centroid, patches.normal),
                       lambda d: f"{d.shadow_rays:,} shadow rays")
    else:
        dfine, dpatch = stage("direct light, fine patches (+ element means)",
                              lambda: element_direct(gscene, fine, patches),
                              lambda d: f"{fine.n:,} patches, {d[1].shadow_rays:,} shadow rays")
    spectral = stage("spectral setup", lambda: SpectralSetup.build(sc, patches.material,
                                                                   c.spectral_samples),
                     lambda s: f"{s.n} samples")
    gather = stage("gather rays", lambda: build_gather(points, normals, patches, caster,
                                                       rays=c.gather_rays),
                   lambda g: f"{c.gather_rays} rays/point")
    k = len(sc.networks)
    rho = np.array([m.luminous_reflectance for m in sc.materials])[patches.material]
    blank = LightingSolution(
        scene=sc, points=points, normals=normals, patches=patches, transport=op,
        gather=gather, spectral=spectral, rho=rho, patch_direct=np.zeros((k, patches.n)),
        radiosity=np.zeros((k, patches.n)), radiosity_xyz=None, point_direct=dpts.by_network,
        point_indirect=np.zeros_like(dpts.by_network), point_xyz=None,
    )
    shot = stage("solve (all networks) + gather",
                 lambda: shoot(blank, dpatch.by_network, [g[1] for g in groups],
                               dpts.by_network),
                 lambda s: f"{len(groups)} emission groups × {spectral.n} λ = "
                           f"{len(groups) * max(spectral.n, 1)} columns, "
                           f"{int(s.result.iterations)} iterations")
    lighting, b_elements = None, shot.value
    if fine is not None:
        fg = stage("fine gather rays", lambda: build_fine_gather(fine, patches, caster,
                                                                rays=c.gather_rays),
                   lambda g: f"{fine.n:,} patches × {c.gather_rays} rays, {len(g.weight):,} "
                             f"links ({(g.point.nbytes + g.patch.nbytes + g.weight.nbytes) / 2**20:.0f} MiB)")
        frho = fine_reflectance(spectral, patches, fine)
        weights = [spectral.weights(g[1]) for g in groups]
        fb, fxyz, find = stage("fine reflect (gather B of the elements)",
                               lambda: reflect_onto_fine(fg, frho, dfine.by_network, weights,
                                                         b_elements),
                               lambda r: f"{r[0].shape[0]} groups × {fine.n:,} patches")
        lighting = dataclasses.replace(
            blank, patch_direct=dpatch.by_network, radiosity=shot.radiosity,
            radiosity_xyz=shot.radiosity_xyz, fine_patches=fine, fine_gather=fg, fine_rho=frho,
            fine_patch_direct=dfine.by_network, fine_patch_indirect=find, fine_radiosity=fb,
            fine_radiosity_xyz=fxyz)
        del fb, fxyz, find
    del shot

    from lumijax import compute, write_results

    out = folder / "out"
    # writing needs Results; compute() from the cache-less operator would redo everything, so
    # time the writer on a direct-only compute of the same grids (same size of output)
    res = compute(study, indirect=False)
    stage("write results", lambda: write_results(res, out, images=True),
          lambda paths: f"{len(paths)} files")
    if lighting is not None:
        from lumijax.report._vtk import write_patches_vtp

        k = len(groups)
        stage("write patches.vtp (fine)",
              lambda: write_patches_vtp(lighting, np.ones(k), out / "patches.vtp"),
              lambda path: f"{path.stat().st_size / 2**20:.0f} MiB")
    sampler.running = False
    _table(rows, c, st)


def _part_note(pa) -> str:
    return (f"{pa.n_blocks} blocks, {len(pa.pairs)} visible block pairs of "
            f"{pa.stats.get('candidate_pairs', '?')}")


def _table(rows, c, st) -> None:
    print()
    print(f"machine: {platform.platform()}, {os.cpu_count()} cores; "
          f"load average {os.getloadavg()[0]:.1f} at the end")
    print(f"study: {len(c.facades)} facades × {c.bays} bays, lod {c.lod}; " +
          ", ".join(f"{k} {v:,}" for k, v in st.items()))
    print("| stage | time (s) | peak RSS (GiB) | rise (GiB) | notes |")
    print("|---|---|---|---|---|")
    for name, dt, peak, rise, note in rows:
        print(f"| {name} | {dt:.1f} | {peak / 2**30:.2f} | {rise / 2**30:.2f} | {note} |")
    print(f"| **total** | {sum(r[1] for r in rows):.1f} | "
          f"{max(r[2] for r in rows) / 2**30:.2f} | | |")


if __name__ == "__main__":
    main()
