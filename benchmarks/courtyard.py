"""The courtyard study at scale, stage by stage: time and peak memory of each step of a run.

    python benchmarks/courtyard.py                        # full scale: 4 × 40 bays, 3,000 lights
    python benchmarks/courtyard.py --bays 10 --target-patches 20000   # a quarter, to extrapolate
    python benchmarks/courtyard.py --operator-patches 0   # one level (the dense P² operator)
    python benchmarks/courtyard.py --operator-patches 0 --transport sampled
                                       # one level, ray-sampled form factors (docs/radiosity.md):
                                       # 200,114 patches at LoD 0 (the default target 140,000;
                                       # the columns' slivers add the rest), 256 rays a patch
    python benchmarks/courtyard.py --operator-patches 0 --transport sampled --lod 3 \
        --spectral-samples 16 --memory-gib 16   # issue 17's LoD-3 target: 1,080,114 patches,
                                       # 288 columns solved in batches sized from 16 GiB

Generates the study (studies/courtyard/make_courtyard.py) into a temporary folder, then runs the
stages of ``lumijax.compute`` one after the other in this process: load (config + scene), then
the pipeline's own stage functions (``lumijax.lighting._stages``, in ``solve_lighting``'s
order): direct light on the grid points, mesh, memory bound + partition + operator build,
direct light on the patches, spectral setup, gather rays, the batched solve of every network,
and writing results. With ``--operator-patches`` (default: the full study's, two levels,
docs/radiosity.md) the operator and the solve run on coarse elements and the fine stages follow:
direct light on the fine patches (the elements get its area means), the coarse solve, then the
fine gather rays and the reflection onto the fine patches, and patches.vtp of the fine level.
With ``--progress``, each stage that reports progress (direct light, gather rays, the solve's
columns, a sampled transport's final gather on the patches) is checked against the progress bar's rule (``lumijax.cli._time_left``: the stage's
rate since its first chunk was done): the time left it would have shown at 25/50/75/90 % of the
stage, beside the time the stage then really took.
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
    p.add_argument("--transport", choices=("blocks", "sampled"), default="blocks")
    p.add_argument("--rays-per-patch", type=lambda v: v if v == "auto" else int(v), default=256,
                   help="sampled transport: rays a patch, or auto (the operator at 256 and a "
                        "final gather of as many as ≈ 3 %% noise per patch needs)")
    p.add_argument("--final-gather-rays", type=int, default=None,
                   help="sampled transport: rays a patch of its final gather (none by default)")
    p.add_argument("--aimed-share", type=float, default=0.25,
                   help="sampled transport: the share of rays aimed at the lit patches")
    p.add_argument("--stop-after", default=None, help="stage name to stop after")
    p.add_argument("--progress", action="store_true",
                   help="check the progress bar's time left against each stage's real end")
    p.add_argument("--memory-gib", type=float, default=None,
                   help="the memory the run may take (LUMIJAX_MEMORY_BYTES): the refusals and "
                        "the solve's column batches are sized from it")
    args = p.parse_args(argv)
    if args.memory_gib is not None:
        os.environ["LUMIJAX_MEMORY_BYTES"] = str(int(args.memory_gib * 2**30))

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
    from lumijax.lighting import SolverSettings, _stages as stg

    sampler = _Sampler()
    sampler.start()
    rows: list[tuple[str, float, int, int, str]] = []
    st: dict = {}

    events: list[tuple[float, int, int]] = []
    final_events: list[tuple[float, int, int]] = []  # a sampled final gather's, apart

    def stage(name, fn, note=lambda r: ""):
        base = _rss()
        sampler.peak = base
        events.clear()
        t = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t
        time.sleep(0.05)
        rows.append((name, dt, sampler.peak, sampler.peak - base, note(out)))
        print(f"  {name}: {dt:.1f} s, peak RSS {sampler.peak / 2**30:.2f} GiB "
              f"(+{(sampler.peak - base) / 2**30:.2f}) {note(out)}", flush=True)
        if args.progress and events:  # the solve's bar ends where the final gather's begins
            end = (final_events[0][0] if final_events and final_events[0][0] > t
                   else t + dt)
            print(f"    {_progress_truth(events, end)}", flush=True)
            print(f"    reports (s into the stage: done/total): {_timeline(events, t)}",
                  flush=True)
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
    settings = SolverSettings(target_patches=c.target_patches, max_block=args.max_block,
                              gather_rays=c.gather_rays, spectral_samples=c.spectral_samples,
                              operator_patches=c.operator_patches, transport=args.transport,
                              rays_per_patch=args.rays_per_patch,
                              aimed_share=args.aimed_share,
                              final_gather_rays=args.final_gather_rays)
    def quiet(done, total):  # the stages' progress, kept for --progress
        events.append((time.perf_counter(), done, total))

    emission = stg.group_emission(sc)
    st.update(luminaires=len(sc.luminaires), networks=len(sc.networks),
              groups=len(emission.spectra), points=len(points), triangles=len(sc.triangles))
    direct = stage("direct light, grid points",
                   lambda: stg.light_points(emission, points, normals, quiet),
                   lambda d: f"{len(points):,} points, {d.shadow_rays:,} shadow rays")
    meshed = stage("mesh", lambda: stg.mesh(sc, emission, settings),
                   lambda m: f"{(m.fine or m.patches).n:,} patches of ~{m.patch_size_m:.2f} m"
                             + ("" if m.fine is None else f", {m.patches.n:,} elements of "
                                f"~{m.element_size_m:.2f} m (operator_patches "
                                f"{c.operator_patches:,})"))
    st["patches"] = (meshed.fine or meshed.patches).n
    if meshed.fine is not None:
        st["elements"] = meshed.patches.n
    def _sampled_note(tr):
        i = tr.operator.info
        return (f"{tr.operator.nbytes / 2**30:.2f} GiB stored, {i['links_per_patch']:.0f} links "
                f"per patch; {i['rays']:,} rays ({i['ray_time_s']:.0f} s in Embree, build "
                f"{i['rays_per_s'] / 1e6:.2f} M rays/s)"
                + ("" if tr.final is None else
                   f"; final gather {tr.final.rays_per_patch:,} rays a patch"))

    def light():
        return stage("direct light, patches" if meshed.fine is None else
                     "direct light, fine patches (+ element means)",
                     lambda: stg.light_patches(direct, emission, meshed, quiet),
                     lambda d: f"{d.shadow_rays - direct.shadow_rays:,} shadow rays")

    def build(direct=None):
        return stage(
            "memory bound + partition + operator build",
            lambda: stg.build_transport(sc, meshed, settings, direct=direct),
            _sampled_note if args.transport == "sampled" else
            lambda tr: f"bound {tr.bound_s:.1f} s, partition {tr.partition_s:.1f} s; "
                       f"{tr.operator.nbytes / 2**30:.2f} GiB stored "
                       f"({tr.operator.lowrank_nbytes / 2**30:.2f} low rank); "
                       f"{tr.operator.info['near_pairs']:,} near patch pairs, "
                       f"{tr.operator.info['lowrank_pairs']}/{tr.operator.info['lowrank_candidates']}"
                       f" block pairs low rank, {tr.operator.info['rays']:,} rays "
                       f"({tr.operator.info['ray_time_s']:.0f} s)")

    # the pipeline's order (lighting/_pipeline.py): the sampled transport aims rays where the
    # direct light lies, so it comes after that light; the blocks come first
    if args.transport == "sampled":
        direct = light()
        transport = build(direct)
    else:
        transport = build()
        direct = light()
    st["operator_bytes"] = transport.operator.nbytes
    sampling = stage("spectral setup", lambda: stg.sample_spectra(sc, meshed, settings),
                     lambda s: f"{s.spectral.n} samples")
    rays = stage("gather rays", lambda: stg.cast_gather_rays(points, normals, meshed, sc,
                                                            settings, quiet),
                 lambda g: f"{c.gather_rays} rays/point")
    from lumijax.radiosity._estimate import available_memory_bytes, solve_column_batch

    cols = len(emission.spectra) * max(sampling.spectral.n, 1)
    per = solve_column_batch(meshed.patches.n, cols,
                             np.dtype(transport.operator.area.dtype).itemsize)
    print(f"  solve: {cols} columns, at most {per} a batch "
          f"({available_memory_bytes() / 2**30:.1f} GiB available)", flush=True)
    def gathering(done, total):
        final_events.append((time.perf_counter(), done, total))

    radiosity = stage("solve (all networks) + gather",
                      lambda: stg.solve(sc, points, normals, emission, direct, meshed,
                                        transport, sampling, rays, settings, quiet, gathering),
                      lambda r: f"{len(emission.spectra)} emission groups × "
                                f"{sampling.spectral.n} λ, "
                                f"{r.stats()['columns_solved']} columns solved, "
                                f"{r.stats()['iterations']} iterations; "
                                + ", ".join(f"{k} {v:.1f} s" for k, v in r.shot.timing_s.items()))
    if args.progress and final_events:  # it ends with its last report (all patches done)
        print(f"    final gather on patches: "
              f"{_progress_truth(final_events, final_events[-1][0])}",
              flush=True)
    if args.transport == "sampled":  # the error beside the figures, measured at this scale
        stage("own noise (4,096 patches' rays cast again)",
              lambda: stg.transport_noise(sc, meshed, transport, radiosity, rays, sampling),
              lambda n: f"{n.rms:.2%} RMS per patch of the inter-reflected light at "
                        f"{n.rays_per_patch} rays ({n.patches:,} patches, mean {n.mean:+.2%}); "
                        + ("" if n.points_rms is None else
                           f"grid points {n.points_rms:.2%} (first order)"))
    lighting = None
    if meshed.fine is not None:
        gathered = stage("final gather (fine gather rays + reflect)",
                         lambda: stg.gather_fine(sc, emission, direct, meshed, sampling,
                                                 radiosity, settings),
                         lambda g: f"rays {g.fine.timing_s['fine_gather_rays']:.1f} s, "
                                   f"{len(g.fine.gather.weight):,} links, reflect "
                                   f"{g.fine.timing_s['fine_reflect']:.1f} s")
        lighting = stg.assemble(sc, points, normals, emission, direct, meshed, transport,
                                sampling, rays, radiosity, gathered, settings)
        del gathered
    radiosity = None  # the solve's arrays freed before writing

    from lumijax import compute, write_results

    out = folder / "out"
    # writing needs Results; compute() from the cache-less operator would redo everything, so
    # time the writer on a direct-only compute of the same grids (same size of output)
    res = compute(study, indirect=False)
    stage("write results", lambda: write_results(res, out, images=True),
          lambda paths: f"{len(paths)} files")
    if lighting is not None:
        from lumijax.report._vtk import write_patches_vtp

        k = len(sc.networks)
        stage("write patches.vtp (fine)",
              lambda: write_patches_vtp(lighting, np.ones(k), out / "patches.vtp"),
              lambda path: f"{path.stat().st_size / 2**20:.0f} MiB")
    sampler.running = False
    _table(rows, c, st)


def _progress_truth(events, end: float) -> str:
    """What the progress bar's time left said at 25/50/75/90 % of a stage against the time
    the stage really had left (s): the bar's task starts at the stage's first report."""
    from lumijax.cli import _time_left

    t0, out = events[0][0], []
    first = next(((t - t0, d) for t, d, _ in events if d > 0), None)
    for frac in (0.25, 0.5, 0.75, 0.9):
        at = next(((t, d, n) for t, d, n in events if n and d >= frac * n), None)
        if at is None or at[0] <= t0:
            continue
        left = _time_left(at[0] - t0, at[1], at[2], first)
        if left is not None:
            out.append(f"{frac:.0%}: {left:.1f} s left shown, {end - at[0]:.1f} s taken")
    return ("time left " + "; ".join(out)) if out else (
        f"time left: {len(events)} report(s), too few to check")


def _timeline(events, start: float, most: int = 40) -> str:
    """The stage's progress reports as ``time:done/total``, at most ``most`` of them evenly
    picked (the first and the last kept)."""
    pick = np.unique(np.linspace(0, len(events) - 1, min(most, len(events))).round().astype(int))
    return " ".join(f"{events[k][0] - start:.1f}:{events[k][1]}/{events[k][2]}" for k in pick)


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
