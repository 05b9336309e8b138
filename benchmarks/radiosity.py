"""Benchmark of the radiosity core: mesh, partition, operator build, multi-column solve.

    python benchmarks/radiosity.py [--patches N] [--rooms R] [--networks 18] [--wavelengths 8]
    python benchmarks/radiosity.py --compare-methods    # evidence for the form-factor method
    python benchmarks/radiosity.py --hall --patches 30000 [--compare-dense]   # low-rank far field

The --hall scene is one empty 40 × 40 × 10 m hall (the case where nothing culls block pairs and
low-rank far blocks pay off). Every run also reports the on-disk cache: miss (build + write)
and hit (verify + load) times.

The scene is R furnished rooms (6 × 5 × 3 m, inward boxes, each its own group, with a table and
a cabinet inside to cast shadows), meshed to about N patches in all. Prints one table; the
results recorded in docs/radiosity.md come from this script.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np


def build_scene(rooms: int):
    import trimesh

    tris, groups, mats = [], [], []
    for r in range(rooms):
        off = np.array([(r % 5) * 6.4, (r // 5) * 5.4, 0.0])
        room = trimesh.creation.box(extents=(6, 5, 3))
        room.apply_translation(off + [3, 2.5, 1.5])
        room.invert()
        table = trimesh.creation.box(extents=(1.6, 0.9, 0.05))
        table.apply_translation(off + [2.5, 2.0, 0.75])
        cabinet = trimesh.creation.box(extents=(0.5, 2.0, 2.0))
        cabinet.apply_translation(off + [5.6, 2.5, 1.0])
        for k, m in enumerate((room, table, cabinet)):
            tris.append(m.triangles)
            groups.append(np.full(len(m.triangles), r))
            mats.append(np.full(len(m.triangles), k))
    return np.concatenate(tris), np.concatenate(groups), np.concatenate(mats)


def patch_size_for(tri, target: int) -> float:
    from lumijax.radiosity import mesh_patches

    lo, hi = 0.01, 5.0
    for _ in range(30):
        mid = np.sqrt(lo * hi)
        n = mesh_patches(tri, patch_size=mid).n
        lo, hi = (mid, hi) if n > target else (lo, mid)
    return hi


def embree_raw_rate(caster, tri, n=2_000_000, seed=0):
    """Occlusion rays/s of the bare Embree call on this scene (segments between random points)."""
    rng = np.random.default_rng(seed)
    lo, hi = tri.reshape(-1, 3).min(0), tri.reshape(-1, 3).max(0)
    o = rng.uniform(lo, hi, (n, 3)) - caster.origin
    t = rng.uniform(lo, hi, (n, 3)) - caster.origin
    d = t - o
    length = np.linalg.norm(d, axis=1)
    d = (d / length[:, None]).astype(np.float32)
    o, length = o.astype(np.float32), length.astype(np.float32)
    t0 = time.perf_counter()
    caster._scene.run(o, d, dists=length, query="OCCLUDED")
    return n / (time.perf_counter() - t0)


def build_hall():
    import trimesh

    m = trimesh.creation.box(extents=(40, 40, 10))
    m.apply_translation([20, 20, 5])
    m.invert()
    tri = m.triangles
    return tri, np.zeros(len(tri), int), np.zeros(len(tri), int)


def cache_rows(p, tri, max_block, settings=None):
    """Miss (partition + build + write) and hit (read + verify) times of cached_operator."""
    import tempfile

    from lumijax.radiosity import PartitionSettings, cached_operator

    with tempfile.TemporaryDirectory() as d:
        ps = PartitionSettings(max_block=max_block)
        t0 = time.perf_counter()
        op, hit = cached_operator(p, tri, settings, cache_dir=d, partition_settings=ps)
        t_miss = time.perf_counter() - t0
        size = sum(f.stat().st_size for f in __import__("pathlib").Path(d).iterdir())
        t0 = time.perf_counter()
        op2, hit2 = cached_operator(p, tri, settings, cache_dir=d, partition_settings=ps)
        t_hit = time.perf_counter() - t0
    assert not hit and hit2
    return op2, [("cache", f"miss {t_miss:.1f} s (partition + build + write), hit {t_hit:.2f} s "
                  f"(read + SHA-256 + load, no rays), file {size / 2**20:,.1f} MiB")]


def hall(args):
    import jax.numpy as jnp

    from lumijax.radiosity import (
        FormFactorSettings,
        build_operator,
        mesh_patches,
        partition,
        solve_radiosity,
    )

    tri, group, mat = build_hall()
    ps = args.patch_size or patch_size_for(tri, args.patches)
    p = mesh_patches(tri, mat, group, patch_size=ps)
    part = partition(p, args.max_block, occluders=tri)
    settings = FormFactorSettings(lowrank_eta=args.eta, lowrank_tol=args.tol)
    t0 = time.perf_counter()
    op, rows = cache_rows(p, tri, args.max_block, settings)
    info = op.info
    rows = [("scene", f"one 40 × 40 × 10 m hall, {p.n} patches (patch size {ps:.3f} m), "
             f"{part.n_blocks} blocks, {len(part.pairs)} visible pairs")] + rows
    ranks = f"rank mean {info['lowrank_rank_mean']:.1f}, max {info['lowrank_rank_max']}"
    rows += [
        ("low-rank pairs", f"{info['lowrank_pairs']} of {info['visible_pairs']} pairs "
         f"({info['lowrank_candidates']} well separated at η = {args.eta}, "
         f"{info['lowrank_mixed_visibility']} possibly shadowed, {info['lowrank_rank_cap']} "
         f"over the rank cap), {ranks}, tol {args.tol}"),
        ("compressed build", f"{info['build_time_s']:.1f} s (ACA {info['lowrank_time_s']:.1f} s)"),
        ("operator bytes", f"{op.nbytes / 2**20:,.1f} MiB (dense part {op.dense_nbytes / 2**20:,.1f},"
         f" low-rank part {op.lowrank_nbytes / 2**20:,.1f}); the compressed pairs would take "
         f"{info['lowrank_entries'] / 2 * 4 / 2**20:,.1f} MiB dense (float32, unpadded)"),
    ]
    rng = np.random.default_rng(0)
    cols = args.networks * args.wavelengths
    x = jnp.asarray(rng.random((p.n, cols)), jnp.float32)

    def timed(o):
        o.matmul(x).block_until_ready()
        t0 = time.perf_counter()
        for _ in range(3):
            y = o.matmul(x).block_until_ready()
        return y, (time.perf_counter() - t0) / 3

    y, t_mv = timed(op)
    rows.append(("one product F·X", f"{t_mv * 1e3:.0f} ms ({cols} columns), compressed"))
    rho = 0.5
    sol = solve_radiosity(op, jnp.full(p.n, rho, jnp.float32), jnp.ones((p.n, 1), jnp.float32))
    v = np.asarray(sol.value)
    rows.append(("furnace ρ = 0.5", f"B/B_exact − 1: mean {v.mean() / 2 - 1:+.2e}, range "
                 f"[{v.min() / 2 - 1:+.2e}, {v.max() / 2 - 1:+.2e}] (compressed)"))
    if args.compare_dense:
        t0 = time.perf_counter()
        dense = build_operator(p, part, tri, FormFactorSettings(lowrank=False))
        t_dense = time.perf_counter() - t0
        yd, t_mvd = timed(dense)
        err = float(jnp.linalg.norm(y - yd) / jnp.linalg.norm(yd))
        solr = solve_radiosity(dense, jnp.full(p.n, rho, jnp.float32),
                               jnp.ones((p.n, 1), jnp.float32))
        dv = float(np.abs(v - np.asarray(solr.value)).max() / 2)
        rows += [
            ("dense build", f"{t_dense:.1f} s, {dense.nbytes / 2**20:,.1f} MiB"),
            ("dense product F·X", f"{t_mvd * 1e3:.0f} ms"),
            ("accuracy", f"‖F·X − F_dense·X‖/‖F_dense·X‖ = {err:.1e} (random X ≥ 0); furnace "
             f"solution max |ΔB|/B = {dv:.1e}"),
        ]
    rows.append(("peak RSS", f"{_rss_gib():.1f} GiB"))
    _table(rows)


def copy_bandwidth(nbytes=1 << 29):
    a = np.ones(nbytes // 8)
    b = np.empty_like(a)
    np.copyto(b, a)
    t0 = time.perf_counter()
    for _ in range(3):
        np.copyto(b, a)
    return 3 * 2 * a.nbytes / (time.perf_counter() - t0)  # read + write


def run(args):
    import jax
    import jax.numpy as jnp

    from lumijax.radiosity import build_operator, mesh_patches, partition, solve_radiosity
    from lumijax.scene._raycast import RayCaster

    rows = [("machine", f"{platform.node()} {platform.machine()}, {_nproc()} cores, jax {jax.__version__}")]
    rooms = args.rooms or max(1, round(args.patches / 5000))
    tri, group, mat = build_scene(rooms)
    ps = args.patch_size or patch_size_for(tri, args.patches)
    t0 = time.perf_counter()
    p = mesh_patches(tri, mat, group, patch_size=ps)
    t_mesh = time.perf_counter() - t0
    caster = RayCaster(tri)
    raw = embree_raw_rate(caster, tri)
    t0 = time.perf_counter()
    part = partition(p, args.max_block, occluders=caster)
    t_part = time.perf_counter() - t0
    t0 = time.perf_counter()
    op = build_operator(p, part, caster, occluder_triangles=tri)
    t_build = time.perf_counter() - t0
    info = op.info
    cache = cache_rows(p, tri, args.max_block)[1] if args.cache else []
    rays = info["rays"] + part.stats["occlusion_rays"]
    ray_rate = info["rays"] / max(info["ray_time_s"], 1e-9)
    rows += [
        ("scene", f"{rooms} rooms, {len(tri)} triangles, patch size {ps:.3f} m"),
        ("patches", f"{p.n}"),
        ("blocks", f"{part.n_blocks} (sizes {part.sizes.min()}–{part.sizes.max()})"),
        ("block pairs", f"{part.stats['candidate_pairs']} candidates, {part.stats['culled_facing']} "
         f"culled facing, {part.stats['culled_occluded']} culled occluded, "
         f"{part.stats['visible_pairs']} visible"),
        ("non-zeros of F", f"{info['nonzeros']:,} ({info['nonzeros'] / p.n**2:.1%} of dense)"),
        ("operator bytes", f"{op.nbytes / 2**20:,.1f} MiB (symmetric G = AF, upper blocks, padded)"),
        ("mesh / partition time", f"{t_mesh:.2f} s / {t_part:.2f} s"),
        ("operator build time", f"{t_build:.1f} s (rays {info['ray_time_s']:.1f} s, "
         f"near pairs {info['near_pairs']:,})"),
        ("rays cast", f"{rays:,} ({part.stats['occlusion_rays']:,} for block culling)"),
        ("rays/s in build", f"{ray_rate / 1e6:.2f} M/s = {ray_rate / raw:.0%} of raw Embree "
         f"({raw / 1e6:.2f} M/s, same scene, same run)"),
    ]
    # Solve: networks × wavelengths columns, ρ per material per wavelength.
    rng = np.random.default_rng(0)
    nw, nn = args.wavelengths, args.networks
    rho_mat = rng.uniform(0.3, args.rho_max, (3, nw))
    rho = jnp.asarray(rho_mat[p.material][:, None, :], jnp.float32)
    b0 = jnp.asarray(rng.random((p.n, nn, nw)) * (rng.random((p.n, 1, 1)) < 0.2), jnp.float32)
    t0 = time.perf_counter()
    sol = solve_radiosity(op, rho, b0, method=args.method)
    sol.value.block_until_ready()
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    sol = solve_radiosity(op, rho, b0, method=args.method)
    sol.value.block_until_ready()
    t_solve = time.perf_counter() - t0
    its = int(sol.iterations)
    x = jnp.asarray(rng.random((p.n, nn * nw)), jnp.float32)
    op.matmul(x).block_until_ready()
    t0 = time.perf_counter()
    for _ in range(3):
        op.matmul(x).block_until_ready()
    t_mv = (time.perf_counter() - t0) / 3
    bw = copy_bandwidth()
    cols = nn * nw
    # each stored entry is used once (diagonal blocks) or twice (both directions): 2 flops/column
    uses = sum(int(np.prod(b.blocks.shape)) * (1 if b.diagonal else 2) for b in op.buckets)
    flops = 2 * uses * cols
    # traffic: the blocks once, plus gathered right-hand sides and scattered results (float32)
    gathered = sum(
        b.blocks.shape[0] * (b.blocks.shape[1] + b.blocks.shape[2]) * (1 if b.diagonal else 2)
        for b in op.buckets
    )
    traffic = op.nbytes + 2 * gathered * cols * 4
    rows += [
        ("solve", f"{nn} networks × {nw} wavelengths = {nn * nw} columns, {args.method}, "
         f"ρ ≤ {args.rho_max}"),
        ("solve time", f"{t_solve:.2f} s ({t_first:.2f} s with compilation), {its} operator "
         f"products, residual {float(sol.residual):.1e}"),
        ("one product F·X", f"{t_mv * 1e3:.0f} ms, {flops / t_mv / 1e9:.0f} GFLOP/s "
         f"({cols} columns: compute-bound, {flops / op.nbytes:.0f} flop per stored byte)"),
        ("memory bandwidth", f"{traffic / t_mv / 1e9:.1f} GB/s (blocks {op.nbytes / t_mv / 1e9:.1f} "
         f"GB/s + gathered/scattered columns) vs numpy copy {bw / 1e9:.1f} GB/s"),
        ("peak RSS", f"{_rss_gib():.1f} GiB"),
    ] + cache
    _table(rows)


def compare_methods():
    """Analytic contour + quadrature (ours) versus ray-sampled hemispheres, parallel squares."""
    from lumijax.radiosity import build_operator, mesh_patches, partition
    from lumijax.scene._raycast import RayCaster

    ref = 0.1998248957
    o = np.zeros(3)
    t1 = np.array([[o, [1, 0, 0], [1, 1, 0]], [o, [1, 1, 0], [0, 1, 0]]], float)
    t2 = np.array([[[0, 0, 1], [0, 1, 1], [1, 1, 1]], [[0, 0, 1], [1, 1, 1], [1, 0, 1]]], float)
    tri = np.concatenate([t1, t2])
    grp = np.array([0, 0, 1, 1])
    rows = []
    for ps in (0.2, 0.1):
        p = mesh_patches(tri, group=grp, patch_size=ps)
        m1, m2 = p.group == 0, p.group == 1
        t0 = time.perf_counter()
        f = build_operator(p, partition(p, 4096), None).todense()
        dt = time.perf_counter() - t0
        g = p.area[:, None] * f
        f12 = g[np.ix_(m1, m2)].sum() / p.area[m1].sum()
        rows.append((f"analytic, patch {ps} m ({p.n} patches)",
                     f"F12 err {100 * (f12 / ref - 1):+.3f} %, reciprocity exact, {dt:.2f} s"))
        caster = RayCaster(p.vertices)
        rng = np.random.default_rng(0)
        for n in (256, 4096):
            t0 = time.perf_counter()
            # n cosine-distributed rays from random points of each patch of surface 1 (and 2)
            est = np.zeros((p.n, p.n))
            for i in np.flatnonzero(m1 | m2):
                u, v = rng.random((2, n))
                flip = u + v > 1
                u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
                vv = p.vertices[i]
                pts = vv[0] + u[:, None] * (vv[1] - vv[0]) + v[:, None] * (vv[2] - vv[0])
                r1, r2 = rng.random((2, n))
                loc = np.stack([np.sqrt(r1) * np.cos(2 * np.pi * r2),
                                np.sqrt(r1) * np.sin(2 * np.pi * r2), np.sqrt(1 - r1)], 1)
                nz = p.normal[i]
                a = np.array([1.0, 0, 0]) if abs(nz[0]) < 0.9 else np.array([0, 1.0, 0])
                tx = np.cross(nz, a)
                tx /= np.linalg.norm(tx)
                ty = np.cross(nz, tx)
                d = loc[:, :1] * tx + loc[:, 1:2] * ty + loc[:, 2:] * nz
                hit, _ = caster.first_hit(pts, d)
                est[i] = np.bincount(hit[hit >= 0], minlength=p.n) / n
            dt = time.perf_counter() - t0
            g = p.area[:, None] * est
            f12 = g[np.ix_(m1, m2)].sum() / p.area[m1].sum()
            nz_ = g[np.ix_(m1, m2)] > 0
            recip = np.abs(g[np.ix_(m1, m2)] - g[np.ix_(m2, m1)].T)[nz_] / g[np.ix_(m1, m2)][nz_]
            rel = np.abs(est - f)[np.ix_(m1, m2)].sum() / f[np.ix_(m1, m2)].sum()
            rows.append((f"hemisphere {n} rays/patch, {ps} m",
                         f"F12 err {100 * (f12 / ref - 1):+.3f} %, per-pair L1 error {rel:.0%}, "
                         f"reciprocity median {np.median(recip):.0%}, {dt:.2f} s"))
    _table(rows)


def _nproc():
    import os

    return os.cpu_count()


def _rss_gib():
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _table(rows):
    try:
        from rich.console import Console
        from rich.table import Table

        t = Table(show_header=False)
        for k, v in rows:
            t.add_row(k, v)
        Console(width=140).print(t)
    except ImportError:
        for k, v in rows:
            print(f"{k:24s} {v}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--patches", type=int, default=10_000)
    ap.add_argument("--rooms", type=int, default=0, help="default: one per ~5000 patches")
    ap.add_argument("--patch-size", type=float, default=0.0)
    ap.add_argument("--max-block", type=int, default=1024)
    ap.add_argument("--networks", type=int, default=18)
    ap.add_argument("--wavelengths", type=int, default=8)
    ap.add_argument("--rho-max", type=float, default=0.8)
    ap.add_argument("--method", default="bicgstab")
    ap.add_argument("--compare-methods", action="store_true")
    ap.add_argument("--cache", action="store_true", help="rooms: also time cache miss/hit "
                    "(a second build)")
    ap.add_argument("--hall", action="store_true", help="one 40 × 40 × 10 m hall")
    ap.add_argument("--compare-dense", action="store_true", help="--hall: also build dense")
    ap.add_argument("--eta", type=float, default=1.5)
    ap.add_argument("--tol", type=float, default=1e-3)
    args = ap.parse_args()
    if args.compare_methods:
        compare_methods()
    elif args.hall:
        hall(args)
    else:
        run(args)


if __name__ == "__main__":
    main()
