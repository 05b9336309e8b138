"""Benchmark of the whole study pipeline at 10⁵ patches and 1,000 luminaires.

    python benchmarks/pipeline.py            # 20 rooms, 1,000 luminaires, ~10⁵ patches
    python benchmarks/pipeline.py --small    # 2 rooms, 100 luminaires, ~10⁴ patches (a check)

The study is generated as a TOML config (public API only: ``load_study`` + ``compute``): R
furnished rooms (6 × 5 × 3 m inward boxes, each its own group, with a table and a cabinet that
cast shadows), 50 Lambertian downlights per room on a 10 × 5 grid, on ``--networks`` dimmer
networks, one workplane grid per room (0.8 m, 0.25 m spacing). The operator cache is off, so
every stage is paid. Prints one table per part:

1. stage times (scene, direct light on grid points and on patches, mesh, partition, operator
   build, spectral set-up, gather rays, the batched solve of every network × wavelength, the
   gather product);
2. dimmer re-evaluation: ``GridResult.at_dimmers`` on every grid plus
   ``LightingSolution.radiosity_at`` on every patch for a new dimmer vector (goal < 50 ms);
3. incremental update: ``LightingSolution.replace_luminaire`` (one of the luminaires moved and
   re-aimed) against a full re-solve with the operator reused (every stage but partition and
   operator build). ``--small`` also checks it against a real full re-solve.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

ROOM = (6.0, 5.0, 3.0)
PER_ROOM = (10, 5)  # downlights per room along x, y


def study_toml(rooms: int, networks: int, target_patches: int, spectral_samples: int) -> str:
    nx, ny = PER_ROOM
    out = [f"""
[study]
name = "pipeline benchmark: {rooms} rooms"
[materials.wall]
reflectance = 0.7
[materials.table]
reflectance = 0.4
[materials.cabinet]
reflectance = 0.3
[photometry.downlight]
kind = "lambertian"
flux_lm = 400
[solver]
target_patches = {target_patches}
spectral_samples = {spectral_samples}
cache = false
"""]
    out += [f"[networks.n{k}]\ndimmer = 1.0\n" for k in range(networks)]
    for r in range(rooms):
        ox, oy = (r % 5) * 6.4, (r // 5) * 5.4
        out.append(f"""
[groups.room{r}]
translate = [{ox}, {oy}, 0]
[[geometry]]
kind = "box"
group = "room{r}"
min = [0, 0, 0]
max = [{ROOM[0]}, {ROOM[1]}, {ROOM[2]}]
normals = "inward"
material = "wall"
[[geometry]]
kind = "box"
group = "room{r}"
min = [1.7, 1.55, 0.725]
max = [3.3, 2.45, 0.775]
material = "table"
[[geometry]]
kind = "box"
group = "room{r}"
min = [5.35, 1.5, 0.0]
max = [5.85, 3.5, 2.0]
material = "cabinet"
[[grids]]
name = "wp{r}"
kind = "plane"
group = "room{r}"
origin = [0.5, 0.5, 0.8]
u = [5.0, 0, 0]
v = [0, 4.0, 0]
spacing = 0.25
""")
        for i in range(nx):
            for j in range(ny):
                net = (r * ny + j) % networks  # rows of each room on different networks
                out.append(f"""[[luminaires]]
name = "L{r}-{i}-{j}"
photometry = "downlight"
network = "n{net}"
group = "room{r}"
position = [{(i + 0.5) * ROOM[0] / nx:.3f}, {(j + 0.5) * ROOM[1] / ny:.3f}, 2.95]
""")
    return "".join(out)


def _rss_gib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _table(title, header, rows):
    print(f"\n{title}\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for r in rows:
        print("| " + " | ".join(str(x) for x in r) + " |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--small", action="store_true", help="2 rooms, 100 luminaires, ~10⁴ patches")
    ap.add_argument("--rooms", type=int, default=None)
    ap.add_argument("--patches", type=int, default=None, help="[solver] target_patches")
    ap.add_argument("--networks", type=int, default=8)
    ap.add_argument("--spectral-samples", type=int, default=16)
    args = ap.parse_args(argv)
    rooms = args.rooms or (2 if args.small else 20)
    target = args.patches or (10_000 if args.small else 100_000)

    import lumijax

    folder = Path(tempfile.mkdtemp(prefix="lumijax-pipeline-"))
    path = folder / "study.toml"
    path.write_text(study_toml(rooms, args.networks, target, args.spectral_samples))
    t0 = time.perf_counter()
    study = lumijax.load_study(path)
    t_scene = time.perf_counter() - t0
    sc = study.scene
    t0 = time.perf_counter()
    res = lumijax.compute(study)
    t_total = time.perf_counter() - t0
    sol = res.lighting
    tm = res.timing_s
    n_lum, n_pts = len(sc.luminaires), len(sol.points)
    cols = len(sc.networks) * max(sol.spectral.n, 1)
    print(f"machine: {platform.platform()}, nproc {_nproc()}; lumijax {lumijax.__version__}")
    print(f"{rooms} rooms, {len(sc.triangles)} triangles, {n_lum} luminaires on "
          f"{len(sc.networks)} networks, {sol.coarse.patches.n} patches, {n_pts} grid points, "
          f"{cols} solve columns ({len(sc.networks)} networks × {sol.spectral.n} wavelengths)")
    rows = [
        ("scene (parse TOML + build)", f"{t_scene:.2f}", f"{n_lum} luminaires"),
        ("direct light, grid points", f"{tm['direct_points']:.2f}", f"{n_pts} points"),
        ("mesh", f"{tm['mesh']:.2f}", f"{sol.coarse.patches.n} patches"),
        ("partition (block culling rays)", f"{tm.get('partition', float('nan')):.2f}", ""),
        ("operator build", f"{tm['operator']:.2f}",
         f"{sol.transport.info['nonzeros'] / 1e6:.0f} M non-zeros, "
         f"{sol.stats['operator_bytes'] / 2**20:.0f} MiB"),
        ("direct light, patches", f"{tm['direct_patches']:.2f}",
         f"{sol.stats['shadow_rays'] / 1e6:.1f} M shadow rays in all"),
        ("spectral set-up", f"{tm['spectral_sampling']:.2f}", ""),
        ("gather rays", f"{tm['gather_rays']:.2f}", f"{n_pts} × 512 rays"),
        ("solve, all networks at once", f"{tm['solve']:.2f}",
         f"{cols} columns, {res.solver['iterations']} products; "
         f"{tm['solve'] / len(sc.networks):.2f} s per network"),
        ("gather product + XYZ", f"{tm['gather']:.2f}", ""),
        ("total (compute)", f"{t_total:.2f}", f"peak RSS {_rss_gib():.1f} GiB"),
    ]
    _table("Stages", ["stage", "s", "notes"], rows)

    # 2. dimmer re-evaluation: every grid and every patch at a new dimmer vector
    rng = np.random.default_rng(0)
    times = []
    for _ in range(30):
        d = rng.uniform(0, 1, len(sc.networks))
        t0 = time.perf_counter()
        for g in res.grids.values():
            g.at_dimmers(d)
        sol.radiosity_at(d)
        times.append(time.perf_counter() - t0)
    t_dim = float(np.median(times))
    _table("Dimmer re-evaluation (median of 30)", ["values", "ms", "goal ms", "ratio to goal"],
           [(f"{sol.coarse.patches.n} patches + {n_pts} points", f"{1e3 * t_dim:.2f}", "50",
             f"{t_dim / 0.05:.3f}")])

    # 3. incremental update of one luminaire vs a full re-solve with the operator reused
    full = sum(tm[k] for k in ("direct_points", "mesh", "direct_patches", "spectral_sampling",
                               "gather_rays", "solve", "gather"))
    out = []
    new_sol = None
    for i in (n_lum // 2, n_lum // 3):
        lum = sc.luminaires[i]
        moved = dataclasses.replace(lum, position=lum.position + np.array([0.3, -0.2, 0.0]))
        t0 = time.perf_counter()
        new_sol = sol.replace_luminaire(i, moved)
        dt = time.perf_counter() - t0
        out.append((f"replace_luminaire({i}) ({'first call, compiles' if not out else 'again'})",
                    f"{dt:.2f}", f"{full:.2f}", f"{full / dt:.1f}×"))
    _table("Incremental update (one of the luminaires moved 0.36 m)",
           ["update", "s", "full re-solve s (operator reused)", "speed-up"], out)
    if args.small:
        study2 = dataclasses.replace(study, scene=new_sol.scene)
        ref = lumijax.compute(study2).lighting
        err = np.max(np.abs(new_sol.point_total - ref.point_total)) / np.max(ref.point_total)
        print(f"\nincremental vs full re-solve: max |ΔE| / max E = {err:.2e}")
    return 0


def _nproc() -> int:
    import os

    return os.cpu_count() or 0


if __name__ == "__main__":
    raise SystemExit(main())
