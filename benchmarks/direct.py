"""Benchmark: direct illuminance with shadows, luminaires × grid points in a 10⁵-triangle scene.

    python benchmarks/direct.py                      # the issue's table: 100/1000/3000 × 1e4/1e5
    python benchmarks/direct.py --lums 100 --points 10000   # one case

For each case it prints wall time, (luminaire, point) pairs per second through the JAX kernel,
shadow rays per second, and the ratio of that ray rate to Embree's raw occlusion rate on the
same scene measured in the same run (random segments of the same lengths). Results, with the
machine they ran on, are recorded in benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import platform
import resource
import time

import numpy as np
import trimesh

from lumijax.direct import direct_illuminance
from lumijax.photometry import flood, linear_washer, spot
from lumijax.scene import Grid, Luminaire, Network, Scene, Triangles


def courtyard_triangles(target: int = 100_000, seed: int = 0) -> np.ndarray:
    """A 60 × 60 m courtyard: ground, four 15 m facades, and ornaments (small boxes) on them
    until the scene has about ``target`` triangles."""
    rng = np.random.default_rng(seed)
    parts = [trimesh.creation.box(extents=[60, 60, 0.2], transform=trimesh.transformations
                                  .translation_matrix([0, 0, -0.1]))]
    for ang in range(4):
        wall = trimesh.creation.box(extents=[60, 1, 15])
        wall.apply_translation([0, 30.5, 7.5])
        wall.apply_transform(trimesh.transformations.rotation_matrix(ang * np.pi / 2, [0, 0, 1]))
        parts.append(wall)
    n_boxes = max(0, (target - 12 * len(parts)) // 12)
    base = trimesh.creation.box(extents=[0.3, 0.3, 0.4])
    verts = []
    for k in range(n_boxes):
        ang = (k % 4) * np.pi / 2
        x, z = rng.uniform(-29, 29), rng.uniform(0.5, 14.5)
        c, s = np.cos(ang), np.sin(ang)
        off = np.array([x * c - 29.85 * s, x * s + 29.85 * c, z])
        verts.append(base.triangles + off)
    tri = np.concatenate([p.triangles for p in parts] + ([np.concatenate(verts)] if verts else []))
    return tri


def make_scene(n_lum: int, n_points: int, tri: np.ndarray) -> Scene:
    rng = np.random.default_rng(1)
    phots = {
        "washer": linear_washer(2400.0, 1.2, 24.0, 110.0, offset_deg=8.0),
        "spot": spot(700.0, 10.0, 18.0),
        "flood": flood(6000.0, 40.0, 24.0),
    }
    names = list(phots)
    lums = []
    for i in range(n_lum):
        kind = names[i % 3]
        ang = rng.integers(4) * np.pi / 2
        c, s = np.cos(ang), np.sin(ang)
        x = rng.uniform(-28, 28)
        if kind == "washer":  # under the cornice, washing the facade down
            local, tilt, spin = np.array([x, 29.0, 14.5]), 0.0, 180.0
        elif kind == "spot":  # on the ground at a facade, aimed up it
            local, tilt, spin = np.array([x, 28.8, 0.2]), 170.0, 0.0
        else:  # from the courtyard at a facade
            local, tilt, spin = np.array([x, rng.uniform(5, 20), 0.5]), 75.0, 0.0
        pos = np.array([local[0] * c - local[1] * s, local[0] * s + local[1] * c, local[2]])
        pan = np.degrees(ang) + 90.0
        lums.append(Luminaire(name=f"L{i}", photometry=kind, position=pos, tilt=tilt, pan=pan,
                              spin=spin, network=f"n{i % 18}"))
    side = int(np.sqrt(n_points))
    u = (np.arange(side) + 0.5) / side * 58 - 29
    gx, gy = np.meshgrid(u, u, indexing="ij")
    pts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, 0.01)], 1)
    grid = Grid("ground", pts, np.tile([0.0, 0, 1], (len(pts), 1)))
    return Scene(
        name="bench", source=None,
        triangles=Triangles(tri, np.zeros(len(tri), int), np.zeros(len(tri), int),
                            np.full(len(tri), -1), np.zeros(1, bool)),
        materials=(), groups=(), photometries=phots, luminaires=tuple(lums), area_sources=(),
        networks=tuple(Network(f"n{k}") for k in range(18)), grids=(grid,),
    )


def raw_embree_rate(scene: Scene, n: int = 2_000_000) -> float:
    """Occlusion rays per second straight through Embree: random luminaire→point segments."""
    rng = np.random.default_rng(2)
    lp = np.array([lum.position for lum in scene.luminaires])
    gp = scene.grids[0].points
    o = lp[rng.integers(len(lp), size=n)]
    t = gp[rng.integers(len(gp), size=n)]
    caster = scene.raycaster
    caster.occluded(o[:1000], t[:1000])  # warm
    t0 = time.perf_counter()
    caster.occluded(o, t)
    return n / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lums", type=int, nargs="*", default=[100, 1000, 3000])
    ap.add_argument("--points", type=int, nargs="*", default=[10_000, 100_000])
    ap.add_argument("--triangles", type=int, default=100_000)
    args = ap.parse_args()

    from rich.console import Console
    from rich.table import Table

    console = Console(width=160)
    t0 = time.perf_counter()
    tri = courtyard_triangles(args.triangles)
    console.print(f"scene: {len(tri):,} triangles (built in {time.perf_counter() - t0:.1f} s); "
                  f"machine: {platform.processor() or platform.machine()}, "
                  f"{__import__('os').cpu_count()} cores, {platform.python_version()}")
    table = Table(title="direct illuminance with shadows", title_justify="left")
    for col in ("luminaires", "points", "pairs", "cold (s)", "warm (s)", "pairs/s", "shadow rays",
                "rays/s", "Embree raw rays/s", "ratio", "peak RSS (GB)"):
        table.add_column(col, justify="right")
    for n_lum in args.lums:
        for n_pts in args.points:
            scene = make_scene(n_lum, n_pts, tri)
            raw = raw_embree_rate(scene)
            grid = scene.grids[0]
            # first call: includes JIT compiles (one per photometry and padded call size);
            # second: steady state, what a session of many runs sees
            t = time.perf_counter()
            direct_illuminance(scene, grid.points, grid.normals)
            cold = time.perf_counter() - t
            t = time.perf_counter()
            res = direct_illuminance(scene, grid.points, grid.normals)
            dt = time.perf_counter() - t
            ray_s = res.timing_s["shadow_rays"]
            rate = res.shadow_rays / ray_s if ray_s else float("nan")
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
            table.add_row(f"{n_lum:,}", f"{len(grid.points):,}",
                          f"{n_lum * len(grid.points):.2e}", f"{cold:.2f}", f"{dt:.2f}",
                          f"{n_lum * len(grid.points) / dt:.2e}", f"{res.shadow_rays:,}",
                          f"{rate:.2e}", f"{raw:.2e}", f"{rate / raw:.2f}", f"{rss:.2f}")
            console.print(f"  {n_lum} × {len(grid.points)}: cold {cold:.2f} s, warm {dt:.2f} s "
                          f"(cull {res.timing_s['cull']:.2f} s, kernel "
                          f"{res.timing_s['kernel']:.2f} s, rays {ray_s:.2f} s, "
                          f"{res.candidate_pairs:,} candidate pairs)")
    console.print(table)


if __name__ == "__main__":
    main()
