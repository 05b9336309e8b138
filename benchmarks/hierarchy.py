"""How the operator's memory grows with patches: clusters of blocks (H-matrix) against one level.

    python benchmarks/hierarchy.py                                  # courtyard, 4k … 32k patches
    python benchmarks/hierarchy.py --scene hall --patches 4000 16000 64000
    python benchmarks/hierarchy.py --flat-up-to 16000               # one-level builds to compare
    python benchmarks/hierarchy.py --transport sampled --patches 10000 30000 100000 300000
    python benchmarks/hierarchy.py --transport sampled --accuracy 30000 --facades S

With ``--transport sampled`` the ray-sampled operator (``radiosity/_sampled.py``) is built
instead: per patch count its stored MiB, links per patch, the process's peak RSS, the build's
rays/s against Embree's raw first-hit rate on the same scene in the same run (the same kind of
rays: cosine-weighted from patch centroids, same batch size, spread over the scene, on as many
threads as the build: ``_raw_rate``), and the growth exponent. The build's patch lookup is an
XLA kernel compiled for its mesh's size class (``PatchLocator.tables``): a machine's first build
of a class compiles it (~0.2–0.3 s), later ones — and every later process, through the
command line's compilation cache — do not, so each size's compile is timed apart before the
build and printed beside it, with the rate both without and with it. With
``--accuracy N`` one mesh of about N patches is solved with the block operator (hierarchical,
default settings) and with the sampled one at each ``--rays``, lit by the study's own
luminaires (direct light with shadows, every network at dimmer 1, luminous), ρ 0.6 on
facades and 0.3 on the ground, with cosine-weighted rays only and with a quarter of them aimed
at the lit patches (``radiosity/_bright.py``, the proposal a study's pipeline makes); it prints
the inter-reflected irradiance's area-weighted mean difference and RMS per patch (relative to
the field's RMS, as tests/lighting/test_final_gather.py defines it) — over all patches, the
open ones (wholly outside the model) and those not wholly inside it — and beside it the
operator's own noise as a study states it (``radiosity/_noise.py``: 4,096 patches' rays cast
again with another seed, for the sampled solution). ``--final-rays N …`` adds, for each
operator, its radiosity gathered once more with N rays a patch (``radiosity/_sampled_gather.py``,
``[solver] final_gather_rays``) and that gather's own noise. ``--noise-split`` adds,
for each ``--rays``, where the sampled operator's own noise lies by the distance of the pair
and what sharing far hits between coplanar neighbours does (``_noise_split``).

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
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def courtyard_study(bays: int, facades: str = "SENW"):
    spec = importlib.util.spec_from_file_location(
        "make_courtyard", ROOT / "studies" / "courtyard" / "make_courtyard.py")
    gen = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = gen
    spec.loader.exec_module(gen)
    from lumijax import load_study

    c = dataclasses.replace(gen.FULL, facades=tuple(facades), bays=bays, floods_per_facade=2,
                            operator_patches=None)
    folder = Path(tempfile.mkdtemp(prefix="lumijax-hierarchy-"))
    gen.write_study(c, folder / "study.toml", folder / "assets", "benchmark")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the generator's coincident boxes (known, harmless)
        return load_study(folder / "study.toml")


def courtyard_triangles(bays: int, facades: str = "SENW"):
    tri = courtyard_study(bays, facades).scene.triangles
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
    ap.add_argument("--facades", default="SENW", help="courtyard: which facades (S, E, N, W)")
    ap.add_argument("--transport", choices=("blocks", "sampled"), default="blocks")
    ap.add_argument("--rays", type=int, nargs="+", default=[256],
                    help="sampled: rays per patch (the first for the memory sweep)")
    ap.add_argument("--accuracy", type=int, default=None, metavar="N",
                    help="sampled: compare with the block operator on one mesh of ~N patches")
    ap.add_argument("--fine", type=int, default=0, metavar="K",
                    help="with --accuracy: the K open patches where the operators differ most, "
                         "their near light against a fine quadrature (≈ 10 s each)")
    ap.add_argument("--noise-split", action="store_true",
                    help="with --accuracy: where the sampled operator's own noise lies (two "
                         "seeds, split by the distance of the pair) and what sharing the far "
                         "hits between coplanar neighbours would do")
    ap.add_argument("--final-rays", type=int, nargs="+", default=[], metavar="N",
                    help="with --accuracy: each operator's radiosity gathered once more with N "
                         "rays a patch (radiosity/_sampled_gather.py, [solver] "
                         "final_gather_rays)")
    args = ap.parse_args(argv)
    if args.transport == "sampled":
        return sampled_main(args)

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


def _rss_gib() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _raw_rate(caster, p, rays: int, batch: int = 8192, threads: int | None = None,
              spans: int = 16) -> float:
    """Embree's first-hit rate (rays/s) alone on ``threads`` CPUs (as many as the build):
    cosine-weighted rays from the centroids of ``spans`` runs of ``batch`` patches spread over
    the scene (each the count and kind of one batch of the build; one run alone over-weighs the
    patches that come first: the ground's open sky reads 1.3x the scene's mean). The rays of
    ``threads`` runs are made first, in Embree's own terms (float32, re-centred, nudged:
    ``RayCaster.first_hit_local``), then traced at once, timed by the wall clock: Embree's
    rate, not that of lumijax's float64 wrapper (``first_hit``: about half of it)."""
    from lumijax.parallel import local_threads, threaded_map
    from lumijax.radiosity._gather import _cosine_directions, _frames

    threads = local_threads() if threads is None else threads
    k = min(batch, p.n)
    starts = np.unique(np.linspace(0, p.n - k, max(spans, threads)).astype(int))

    def rays_of(a):
        sl = slice(a, a + k)
        frames = _frames(np.asarray(p.normal[sl], np.float64), np.random.default_rng(0))
        dirs = np.einsum("pij,rj->pri", frames, _cosine_directions(rays)).reshape(-1, 3)
        o = np.repeat(p.centroid[sl] + 10 * caster.epsilon * p.normal[sl], rays, axis=0)
        o = o - caster.origin + caster.epsilon * dirs
        return o.astype(np.float32), dirs.astype(np.float32)

    n, wall = 0, 0.0
    for g in range(0, len(starts), threads):
        group = [rays_of(a) for a in starts[g:g + threads]]
        t = time.perf_counter()
        for _ in threaded_map(lambda od: caster.first_hit_local(*od), group, threads):
            pass
        wall += time.perf_counter() - t
        n += sum(len(o) for o, _ in group)
    return n / wall


def _compile_lookup(p, tri, rays: int) -> float:
    """Seconds to compile the build's patch lookup (``_front_hits``) for the tables of mesh
    ``p``, from a call on a batch of misses; 0 where its size class is compiled already."""
    from lumijax.radiosity import PatchLocator, SampledSettings

    locator, n = PatchLocator(p, tri), SampledSettings().batch * rays
    front = np.zeros((len(tri), 3), np.float32)
    t = time.perf_counter()
    locator.front_hits(np.full(n, -1, np.int32), np.zeros((n, 2), np.float32),
                       np.zeros((n, 3), np.float32), front)
    return time.perf_counter() - t


def sampled_main(args) -> None:
    from lumijax.lighting._pipeline import auto_patch_size
    from lumijax.radiosity import SampledSettings, build_sampled, mesh_patches
    from lumijax.scene._raycast import RayCaster

    study = courtyard_study(args.bays, args.facades) if args.scene == "courtyard" else None
    if study is not None:
        tri, group = study.scene.triangles.vertices, study.scene.triangles.group
    else:
        tri, group = hall_triangles()
    tri = np.asarray(tri, np.float64)
    area = float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                      axis=1).sum())
    caster = RayCaster(tri)
    print(f"machine: {platform.platform()}, {platform.processor() or platform.machine()}; "
          f"scene {args.scene} ({args.facades}, {args.bays} bays): {len(tri):,} triangles, "
          f"{area:,.0f} m²; times on a shared 2-core machine are contended", flush=True)
    if args.accuracy:
        return _accuracy(args, study, tri, group, area, caster)
    rows, last = [], None
    for k, target in enumerate(args.patches):
        p = mesh_patches(tri, group=group, patch_size=auto_patch_size(area, target))
        if k == 0:  # the kernels compile once a process (the command line keeps them on disk)
            t = time.perf_counter()
            build_sampled(p, tri, SampledSettings(rays_per_patch=args.rays[0]), caster=caster)
            print(f"  first build of {p.n:,} patches, compiling the kernels (not in the table): "
                  f"{time.perf_counter() - t:.1f} s", flush=True)
        compile_s = _compile_lookup(p, tri, args.rays[0])
        raw = _raw_rate(caster, p, args.rays[0], SampledSettings().batch)
        t = time.perf_counter()
        op = build_sampled(p, tri, SampledSettings(rays_per_patch=args.rays[0]), caster=caster)
        dt = time.perf_counter() - t
        raw2 = _raw_rate(caster, p, args.rays[0], SampledSettings().batch)  # before and after: contention drifts
        i = op.info
        growth = (np.log(op.nbytes / last[1]) / np.log(p.n / last[0]) if last else float("nan"))
        last = (p.n, op.nbytes)
        rows.append(dict(patches=p.n, rays=i["rays"], build_s=dt, ray_s=i["ray_time_s"],
                         compile_s=compile_s,
                         rate=i["rays"] / dt, raw=0.5 * (raw + raw2), links=i["links_per_patch"],
                         mib=op.nbytes / 2**20, rss=_rss_gib(), growth=growth))
        print(f"  {p.n:,} patches: {dt:.1f} s, {op.nbytes / 2**20:.1f} MiB", flush=True)
        del op
    print("\n| patches | rays | lookup's compile (s) | build (s) | in Embree (thread-s) | "
          "build rays/s | raw Embree rays/s | ratio | ratio with the compile | links per patch | "
          "operator MiB | peak RSS GiB | growth exponent |")
    print("|" + "---|" * 13)
    for r in rows:
        with_compile = r["rays"] / (r["build_s"] + r["compile_s"]) / r["raw"]
        print(f"| {r['patches']:,} | {r['rays'] / 1e6:.1f} M | {r['compile_s']:.2f} | "
              f"{r['build_s']:.1f} | {r['ray_s']:.1f} | {r['rate'] / 1e6:.2f} M | "
              f"{r['raw'] / 1e6:.2f} M | {r['rate'] / r['raw']:.0%} | {with_compile:.0%} | "
              f"{r['links']:.0f} | {r['mib']:.1f} | "
              f"{r['rss']:.2f} | {r['growth']:.2f} |")


def _inside(p, caster, points: int = 16, rays: int = 32) -> np.ndarray:
    """The share of each patch's points (``points`` R2 points a patch) that lie inside the model:
    at least a quarter of the point's ``rays`` cosine-weighted rays meet a triangle's back
    (in the open a point sees fronts only; inside a column's half prism or under its foot it
    sees the backs of the faces around it). On the quarter the points split cleanly: 0–6 % of
    their rays or ≥ 50 %."""
    g = 1.32471795724474602596  # R2's points on the triangle, Fibonacci's on the hemisphere
    u = np.stack([(0.5 + np.arange(points) / g) % 1, (0.5 + np.arange(points) / g**2) % 1])
    v = p.vertices
    at = v[:, None, 0] + np.sqrt(u[0])[None, :, None] * (
        (1 - u[1])[None, :, None] * (v[:, None, 1] - v[:, None, 0])
        + u[1][None, :, None] * (v[:, None, 2] - v[:, None, 0]))
    k = np.arange(rays) + 0.5
    r, phi = np.sqrt(k / rays), k * np.pi * (3 - np.sqrt(5))
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - r * r)], 1)
    n = p.normal
    tx = np.cross(n, [0.0, 0.0, 1.0])
    flat = np.linalg.norm(tx, axis=1) < 1e-6
    tx[flat] = np.cross(n[flat], [1.0, 0.0, 0.0])
    tx /= np.linalg.norm(tx, axis=1, keepdims=True)
    dirs = (local[None, :, 0, None] * tx[:, None] + local[None, :, 1, None] * np.cross(n, tx)[:, None]
            + local[None, :, 2, None] * n[:, None]).reshape(-1, 3)
    tri = caster.triangles
    face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    inside = np.zeros((p.n, points), bool)
    for m in range(points):
        hit, _ = caster.first_hit(np.repeat(at[:, m] + 1e-4 * n, rays, axis=0), dirs)
        back = (hit >= 0) & (np.einsum("ij,ij->i", dirs, face[np.maximum(hit, 0)]) > 0)
        inside[:, m] = back.reshape(p.n, rays).mean(axis=1) >= 0.25
    return inside.mean(axis=1)


def _lambert(x, nx, tris) -> np.ndarray:
    """Lambert's point-to-polygon factors (K,) from point x (normal nx) to triangles (K, 3, 3)
    in front of it (reference §7), in float64 numpy: written apart from the kernels."""
    r1 = tris - x
    r2 = np.roll(r1, -1, axis=1)
    c = np.cross(r1, r2)
    cn = np.linalg.norm(c, axis=2)
    angle = np.arctan2(cn, np.einsum("kij,kij->ki", r1, r2))
    return np.abs((np.einsum("kij,j->ki", c, nx) / np.maximum(cn, 1e-300) * angle).sum(1)) / (
        2 * np.pi)


def _fine_near(p, caster, i: int, b_near: np.ndarray, cuts=(16, 16)) -> float:
    """The irradiance (lx) patch ``i`` receives from the radiosity ``b_near`` (lm/m², zero
    beyond the near sources) by a fine quadrature independent of both operators: the receiver
    cut into ``cuts[0]``² sub-triangles (their centroids the points), each source into
    ``cuts[1]``² pieces, Lambert's factor from each point to each piece in front of it, times a
    shadow ray to the piece's centroid."""
    from lumijax.radiosity import subdivide_triangles

    points = subdivide_triangles(p.vertices[i][None], cuts[0])[0].mean(axis=1)
    src = np.flatnonzero(b_near > 0)
    pieces = subdivide_triangles(p.vertices[src], cuts[1]).reshape(-1, 3, 3)
    per = cuts[1] ** 2
    b, nj, mid = np.repeat(b_near[src], per), np.repeat(p.normal[src], per, 0), pieces.mean(1)
    total = 0.0
    for x in points:
        ok = ((mid - x) @ p.normal[i] > 0) & (np.einsum("ij,ij->i", x - mid, nj) > 0)
        seen = ~caster.occluded(np.broadcast_to(x + 1e-6 * p.normal[i], (ok.sum(), 3)), mid[ok])
        total += np.sum(b[ok] * _lambert(x, p.normal[i], pieces[ok]) * seen)
    return total / len(points)


def _accuracy(args, study, tri, group, area, caster) -> None:
    import jax.numpy as jnp

    from lumijax.direct import direct_illuminance
    from lumijax.lighting._pipeline import auto_patch_size
    from lumijax.radiosity import (
        SampledGather,
        SampledSettings,
        bright_patches,
        build_operator,
        build_sampled,
        gather_sampled,
        mesh_patches,
        partition,
        row_correction,
        sampled_noise,
        solve_radiosity,
    )

    p = mesh_patches(tri, group=group, patch_size=auto_patch_size(area, args.accuracy))
    t = time.perf_counter()
    by_network = direct_illuminance(study.scene, p.centroid, p.normal).by_network
    e_dir = by_network.sum(axis=0)
    print(f"  {p.n:,} patches; direct light {time.perf_counter() - t:.1f} s", flush=True)
    inside = _inside(p, caster)
    a = p.area
    open_ = inside == 0
    seen = inside < 1  # some of the patch outside the model: a viewer can see that part
    print(f"  patches inside the model (column prisms, feet): {(inside == 1).sum():,} wholly, "
          f"{((inside > 0) & (inside < 1)).sum():,} in part; {np.sum(a * inside) / a.sum():.1%} "
          "of the area", flush=True)
    rho = np.where(p.normal[:, 2] > 0.5, 0.3, 0.6)
    b0 = jnp.asarray((rho * e_dir)[:, None], jnp.float32)
    rho_j = jnp.asarray(rho, jnp.float32)
    t = time.perf_counter()
    dense = build_operator(p, partition(p, args.max_block, occluders=caster), caster,
                           occluder_triangles=tri)
    t_dense = time.perf_counter() - t
    b_dense = solve_radiosity(dense, rho_j, b0).value
    ref = np.asarray(dense.matmul(b_dense), np.float64)[:, 0]
    ref1 = np.asarray(dense.matmul(b0), np.float64)[:, 0]
    print(f"  block operator: {t_dense:.1f} s, {dense.nbytes / 2**20:.0f} MiB, "
          f"{dense.info['shadowed_near_pairs']:,} of {dense.info['near_pairs']:,} near pairs "
          f"shadowed, peak RSS {_rss_gib():.2f} GiB", flush=True)
    if not args.fine:
        del dense

    def cmp(x, y, m=slice(None)):
        return (np.sum((a * (x - y))[m]) / np.sum((a * y)[m]),
                np.sqrt(np.sum((a * (x - y) ** 2)[m]) / np.sum((a * y**2)[m])))

    # the pipeline's proposal: each network's direct flux on the patches (radiosity/_bright.py)
    proposal = bright_patches(by_network * a, p)
    print("\n| rays per patch | rays | build (s) | MiB | links per patch | indirect mean | indirect "
          "RMS per patch | first bounce mean | first bounce RMS | open patches: indirect mean, "
          "RMS | patches not wholly inside: mean, RMS | own noise, estimated "
          "(radiosity/_noise.py) |")
    print("|" + "---|" * 12)
    for n in args.rays:
        for aimed in (None, proposal):
            t = time.perf_counter()
            op = build_sampled(p, tri, SampledSettings(rays_per_patch=n), caster=caster,
                               bright=aimed)
            dt = time.perf_counter() - t
            b = solve_radiosity(op, rho_j, b0).value
            x = np.asarray(op.matmul(b), np.float64)[:, 0]
            m, r = cmp(x, ref)
            m1, r1 = cmp(np.asarray(op.matmul(b0), np.float64)[:, 0], ref1)
            mo, ro = cmp(x, ref, open_)
            mv, rv = cmp(x, ref, seen)
            noise = sampled_noise(op, p, SampledSettings(rays_per_patch=n), np.asarray(b)[:, 0],
                                  caster=caster, bright=aimed)
            kind = "cosine" if aimed is None else f"{op.info['settings']['aimed_rays']} aimed"
            print(f"| {n} | {kind} | {dt:.1f} | {op.nbytes / 2**20:.0f} | "
                  f"{op.info['links_per_patch']:.0f} | {m:+.2%} | {r:.2%} | {m1:+.2%} | "
                  f"{r1:.2%} | {mo:+.2%}, {ro:.2%} | {mv:+.2%}, {rv:.2%} | "
                  f"{noise.rms:.2%} ({noise.seconds:.1f} s) |",
                  flush=True)
            c = np.asarray(row_correction(op.row_sums())[0], np.float64)
            for f in args.final_rays:  # the final gather: another seed, never stored
                fs = SampledGather.of(SampledSettings(rays_per_patch=n), f).settings
                t = time.perf_counter()
                g, _ = gather_sampled(p, caster, fs, np.asarray(b, np.float64), outgoing=c,
                                      bright=aimed)
                dt = time.perf_counter() - t
                m, r = cmp(g[:, 0], ref)
                mo, ro = cmp(g[:, 0], ref, open_)
                mv, rv = cmp(g[:, 0], ref, seen)
                noise = sampled_noise(op, p, SampledSettings(rays_per_patch=n),
                                      np.asarray(b)[:, 0], caster=caster, bright=aimed, final=fs)
                print(f"| {n}, gathered with {f} | {kind} | {dt:.1f} (gather) | — | — | "
                      f"{m:+.2%} | {r:.2%} | — | — | {mo:+.2%}, {ro:.2%} | {mv:+.2%}, {rv:.2%} | "
                      f"{noise.rms:.2%} ({noise.seconds:.1f} s) |", flush=True)
            if args.fine and n == args.rays[-1] and aimed is None:
                last = (op, x, n)
            else:
                del op
    if args.fine:
        _fine_check(p, caster, dense, *last, ref, b_dense, open_, args.fine)
    if args.noise_split:
        b_ref = np.asarray(b_dense, np.float64)[:, 0]
        for n in args.rays:
            _noise_split(p, tri, caster, n, b_ref, ref, rho, np.asarray(b0)[:, 0], open_)
            _points_noise_check(p, tri, caster, n, rho, b0)


def _links(op, p):
    """The sampled operator's F as a SciPy CSR matrix (float64)."""
    import scipy.sparse as sparse

    r, c, w = op.buckets[0].links()
    keep = (r < p.n) & (c < p.n)  # not the padding
    area = np.asarray(p.area, np.float64)
    return sparse.csr_matrix((w[keep] / area[r[keep]], (r[keep], c[keep])), shape=(p.n, p.n))


def _noise_split(p, tri, caster, rays, b, ref, rho, b0, open_) -> None:
    """Where the sampled operator's own noise lies on the open patches, and one remedy tried.

    Own noise: two seeds' difference of one product F·B (B the block solution's radiosity) ÷ √2,
    RMS per patch relative to the field's RMS, split by the pair's centroid distance (what an
    exact near field within d would leave is the far part). Sharing: each patch's hits beyond
    ``d`` replaced by the area-weighted mean of its coplanar neighbours' within 0.5 m (the far
    field, seen from points 0.5 m apart, differing little), solved and compared with the block
    operator as in the table above."""
    import scipy.sparse as sparse
    from scipy.spatial import cKDTree

    from lumijax.radiosity import SampledSettings, build_sampled

    a = np.asarray(p.area, np.float64)
    f = [_links(build_sampled(p, tri, SampledSettings(rays_per_patch=rays, seed=s),
                              caster=caster), p) for s in (0, 1)]

    def rms(x, m=open_):
        return np.sqrt(np.sum((a * x**2)[m]) / np.sum((a * ref**2)[m]))

    def far(m, d):
        m = m.tocoo()
        beyond = np.linalg.norm(c[m.row] - c[m.col], axis=1) > d
        return sparse.csr_matrix((m.data * beyond, (m.row, m.col)), shape=m.shape)

    c = np.asarray(p.centroid, np.float64)
    noise = (f[0] - f[1]) @ b / np.sqrt(2)
    print(f"\n{rays} cosine rays, own noise of one product F·B on the open patches: "
          f"{rms(noise):.2%}")
    print("| pairs nearer than d (m) | their share of F·B | noise left beyond d | noise within d |")
    print("|" + "---|" * 4)
    for d in (0.5, 1.0, 2.0, 4.0, 8.0):
        fn = [far(m, d) for m in f]
        beyond = (fn[0] - fn[1]) @ b / np.sqrt(2)
        share = 1 - np.sum(a * (fn[0] @ b)) / np.sum(a * (f[0] @ b))
        print(f"| {d} | {share:.1%} | {rms(beyond):.2%} | {rms(noise - beyond):.2%} |")
    nrm = np.asarray(p.normal, np.float64)
    i, k = cKDTree(c).query_pairs(0.5, output_type="ndarray").T
    same = ((np.einsum("ij,ij->i", nrm[i], nrm[k]) > 0.9999)
            & (np.abs(np.einsum("ij,ij->i", nrm[i], c[k] - c[i])) < 1e-3))
    i, k = np.r_[i[same], k[same], np.arange(p.n)], np.r_[k[same], i[same], np.arange(p.n)]
    share = sparse.csr_matrix((a[k], (i, k)), shape=(p.n, p.n))
    share = sparse.diags(1 / np.asarray(share.sum(axis=1)).ravel()) @ share

    def indirect(m):
        x = b0.copy()
        for _ in range(500):
            y = b0 + rho * (m @ x)
            if np.abs(y - x).max() <= 1e-7 * np.abs(y).max():
                break
            x = y
        return m @ y

    def cmp(x, m=open_):
        return (np.sum((a * (x - ref))[m]) / np.sum((a * ref)[m]), rms(x - ref, m))

    print(f"\n| sampled, {rays} rays (seed 0) | all patches: mean, RMS | open: mean, RMS |")
    print("|---|---|---|")
    rows = [("as built", f[0])] + [
        (f"far hits (> {d} m) shared, {share.getnnz(axis=1).mean():.0f} neighbours", None)
        for d in (1.0, 2.0, 4.0)]
    for (label, m), d in zip(rows, (None, 1.0, 2.0, 4.0), strict=True):
        if m is None:
            fd = far(f[0], d)
            m = f[0] - fd + share @ fd
        x = indirect(m)
        (ma, ra), (mo, ro) = cmp(x, slice(None)), cmp(x)
        print(f"| {label} | {ma:+.2%}, {ra:.2%} | {mo:+.2%}, {ro:.2%} |", flush=True)


def _points_noise_check(p, tri, caster, rays, rho, b0, points: int = 600) -> None:
    """The grid points' noise as a study states it (``radiosity/_noise.py``, first order)
    against its definition: two operators of different seeds, each solved and gathered onto
    ``points`` points 0.8 m over the ground (by one gather of 512 rays)."""
    import jax.numpy as jnp

    from lumijax.radiosity import (
        SampledSettings,
        build_gather,
        build_sampled,
        sampled_noise,
        solve_radiosity,
    )

    c, nrm = np.asarray(p.centroid), np.asarray(p.normal)
    ground = np.flatnonzero((nrm[:, 2] > 0.99) & (c[:, 2] < 0.01))
    at = c[ground[np.linspace(0, len(ground) - 1, points).astype(int)]] + [0.0, 0.0, 0.8]
    g = build_gather(at, np.tile([0.0, 0.0, 1.0], (len(at), 1)), p, caster, rays=512)
    e, first = [], None
    for seed in (0, 1):
        op = build_sampled(p, tri, SampledSettings(rays_per_patch=rays, seed=seed),
                           caster=caster)
        b = np.asarray(solve_radiosity(op, jnp.asarray(rho, jnp.float32), b0).value,
                       np.float64)[:, 0]
        e.append(np.asarray(g(jnp.asarray(b[:, None], jnp.float32)), np.float64)[:, 0])
        first = first or (op, b)
    whole = np.sqrt(np.mean((e[0] - e[1]) ** 2) / 2 / np.mean(e[0] ** 2))
    est = sampled_noise(first[0], p, SampledSettings(rays_per_patch=rays), first[1],
                        caster=caster, gather=g, rho=rho)
    print(f"\n{rays} cosine rays, {len(at)} points 0.8 m over the ground: their noise from two "
          f"whole solves {whole:.3%}, estimated (first order) {est.points_rms:.3%}; the "
          f"patches' {est.rms:.2%}", flush=True)


def _fine_check(p, caster, dense, sampled, x, rays, ref, b, open_, k: int) -> None:
    """Both operators' near light on the ``k`` open patches where they differ most, against
    :func:`_fine_near` (the block solution's radiosity on the sources within 1.5 m of any of
    them, zero beyond: the same light for all three)."""
    import jax.numpy as jnp

    worst = np.argsort(-np.where(open_, p.area * (x - ref) ** 2, 0.0))[:k]
    gap = np.linalg.norm(p.centroid[:, None] - p.centroid[worst][None], axis=2).min(axis=1)
    b_near = np.where(gap < 1.5, np.asarray(b, np.float64)[:, 0], 0.0)
    column = jnp.asarray(b_near[:, None], jnp.float32)
    near_block = np.asarray(dense.matmul(column), np.float64)[:, 0]
    near_sampled = np.asarray(sampled.matmul(column), np.float64)[:, 0]
    print(f"\n| patch | centroid (m) | normal | fine (lx) | block | sampled, {rays} cosine rays |")
    print("|" + "---|" * 6)
    rel = []
    for i in worst:
        t = time.perf_counter()
        f = _fine_near(p, caster, int(i), b_near)
        rel.append((near_block[i] / f - 1, near_sampled[i] / f - 1))
        print(f"| {i} | {np.round(p.centroid[i], 2)} | {np.round(p.normal[i], 2)} | {f:.2f} | "
              f"{rel[-1][0]:+.1%} | {rel[-1][1]:+.1%} | ({time.perf_counter() - t:.0f} s)",
              flush=True)
    rel = np.array(rel)
    print(f"block {rel[:, 0].min():+.1%} … {rel[:, 0].max():+.1%} (mean {rel[:, 0].mean():+.1%}); "
          f"sampled {rel[:, 1].min():+.1%} … {rel[:, 1].max():+.1%} (mean {rel[:, 1].mean():+.1%})")


if __name__ == "__main__":
    main()
