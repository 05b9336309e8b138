"""Which transport is right on the open courtyard? Both operators against Radiance (issue 17).

On a courtyard quarter (one facade of 6 bays and its ground, ≈ 2.5·10⁴ patches, the case of
docs/radiosity.md "Accuracy on the courtyard") the sampled operator differed from the block
operator by ≈ +2.7 % mean / 15 % RMS per patch whatever its ray count. This script asks an
independent program, Radiance (``rtrace -I`` through pyradiance), for the same quantities on the
same mesh and decides between them.

The light is the same for all three by construction: lumijax lights the patches (the study's own
luminaires, direct light with shadows, every network at dimmer 1; ρ 0.3 on surfaces facing up,
0.6 elsewhere, as ``benchmarks/hierarchy.py --accuracy``), and the initial exitance of each patch,
B₀ = ρ E_direct (lm/m²), is handed to Radiance as that patch's own emitter, a ``glow`` of
radiance B₀/π (W/sr/m² read as lm/sr/m²; Radiance is linear, so the units pass through). Two
quantities, both patch-averaged irradiance (lx) on sampled receiver patches:

* **first bounce** ``F B₀``: every patch only glows (black otherwise), ``rtrace -ab 1``;
* **indirect** ``F B`` with ``(I − ρF) B = B₀``: every patch glows *and* reflects, a ``mixfunc``
  of the glow (weight w, radiance B₀/(πw)) and a diffuse ``plastic`` of reflectance ρ/(1 − w),
  whose blend is exactly ``B₀/π + ρE/π``; ``rtrace -ab 14 -aa 0`` (no irradiance cache: pure
  Monte Carlo, converged by rays, ``-lw`` low enough that ρ¹⁴ paths still count).

Each receiver patch is measured at ``--points`` stratified points (1 mm off the surface along
its normal) and averaged, as both operators average over the receiver; the spread of those
points gives Radiance's own standard error, which the RMS figures have removed (subtracted in
quadrature). Receivers are drawn with probability ∝ area, so plain means over them estimate the
area-weighted figures of benchmarks/hierarchy.py.

Stages (each reads the previous one's files in ``--work``)::

    python studies/courtyard/radiance_transport.py solve      # lumijax: both operators (slow:
                                                              # the dense build is ~30 min)
    python studies/courtyard/radiance_transport.py radiance --seed 1   # rtrace, one run; more
    python studies/courtyard/radiance_transport.py radiance --seed 2   # seeds: its noise
    python studies/courtyard/radiance_transport.py rows       # the block kernels' receiver rows
    python studies/courtyard/radiance_transport.py culls      # light the partition's cull drops
    python studies/courtyard/radiance_transport.py visibility # far pairs by 16 shadow rays
    python studies/courtyard/radiance_transport.py fine       # the same B₀ on a finer mesh
    python studies/courtyard/radiance_transport.py box        # a control: an open box
    python studies/courtyard/radiance_transport.py compare    # the tables

The results and what they decide are in docs/radiosity.md ("Accuracy on the courtyard").

Times are whatever the machine gives; on the shared 2-core VM they are contended.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def quarter_study(bays: int, facades: str):
    """The generator's full-scale study cut to ``facades`` × ``bays`` (two floods a facade)."""
    spec = importlib.util.spec_from_file_location("make_courtyard",
                                                  ROOT / "studies/courtyard/make_courtyard.py")
    gen = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = gen
    spec.loader.exec_module(gen)
    from lumijax import load_study

    c = dataclasses.replace(gen.FULL, facades=tuple(facades), bays=bays, floods_per_facade=2,
                            operator_patches=None)
    folder = Path(tempfile.mkdtemp(prefix="lumijax-radiance-transport-"))
    gen.write_study(c, folder / "study.toml", folder / "assets", "radiance_transport")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        study = load_study(folder / "study.toml")
    for w in caught:  # e.g. a coincident face, which would count light twice
        print(f"warning: {w.message}", flush=True)
    return study


def _quarter_mesh(args):
    """The quarter's study, its triangles (float64), their total area (m²) and the patches
    of the solve stage's mesh (``args.patches``), which every later stage must reproduce."""
    from lumijax.lighting._pipeline import auto_patch_size
    from lumijax.radiosity import mesh_patches

    study = quarter_study(args.bays, args.facades)
    tri = np.asarray(study.scene.triangles.vertices, np.float64)
    area = float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                      axis=1).sum())
    p = mesh_patches(tri, group=study.scene.triangles.group,
                     patch_size=auto_patch_size(area, args.patches))
    return study, tri, area, p


def _rss_gib() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def solve(args) -> None:
    import jax.numpy as jnp

    from lumijax.direct import direct_illuminance
    from lumijax.radiosity import (
        SampledSettings,
        build_operator,
        build_sampled,
        load_operator,
        partition,
        save_operator,
        solve_radiosity,
    )
    from lumijax.scene._raycast import RayCaster

    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    study, tri, area, p = _quarter_mesh(args)
    caster = RayCaster(tri)
    print(f"{len(tri):,} triangles, {area:,.0f} m², {p.n:,} patches", flush=True)
    geo = work / "patches.npz"
    if geo.exists():
        e_dir = np.load(geo)["e_dir"]
    else:
        t = time.perf_counter()
        e_dir = direct_illuminance(study.scene, p.centroid, p.normal).by_network.sum(axis=0)
        print(f"direct light {time.perf_counter() - t:.1f} s", flush=True)
    rho = np.where(p.normal[:, 2] > 0.5, 0.3, 0.6)
    np.savez(geo, vertices=p.vertices, normal=p.normal, area=p.area, centroid=p.centroid,
             rho=rho, e_dir=e_dir, triangles=tri)
    b0 = jnp.asarray((rho * e_dir)[:, None], jnp.float32)
    rho_j = jnp.asarray(rho, jnp.float32)

    def record(name, op, seconds):
        sol = solve_radiosity(op, rho_j, b0)
        np.savez(work / f"{name}.npz",
                 first=np.asarray(op.matmul(b0), np.float64)[:, 0],
                 indirect=np.asarray(op.matmul(sol.value), np.float64)[:, 0],
                 build_s=seconds, mib=op.nbytes / 2**20, iterations=int(sol.iterations))
        print(f"{name}: {seconds:.1f} s, {op.nbytes / 2**20:.0f} MiB, peak RSS "
              f"{_rss_gib():.2f} GiB", flush=True)

    for n in args.rays:
        name = f"sampled{n}"
        if not (work / f"{name}.npz").exists():
            t = time.perf_counter()
            op = build_sampled(p, tri, SampledSettings(rays_per_patch=n), caster=caster)
            record(name, op, time.perf_counter() - t)
            del op
    if not args.no_blocks and not (work / "blocks.npz").exists():
        path = work / "blocks.lumijax"
        t = time.perf_counter()
        if path.exists():
            op = load_operator(path)
        else:
            op = build_operator(p, partition(p, 1024, occluders=caster), caster,
                                occluder_triangles=tri)
            save_operator(path, op)
        record("blocks", op, time.perf_counter() - t)


def _sample_receivers(area, k, seed=0):
    """``k`` distinct patches drawn ∝ area (systematic sampling of the area's cumulative sum:
    every stratum of 1/k of the area gives one, so the sample is spread over the scene)."""
    rng = np.random.default_rng(seed)
    c = np.cumsum(area) / area.sum()
    u = (np.arange(k) + rng.uniform()) / k
    return np.unique(np.searchsorted(c, u))


def _points_in(vertices, m, seed=1):
    """``m`` stratified points in each triangle (the R2 sequence folded into it)."""
    g = 1.32471795724474602596
    rng = np.random.default_rng(seed)
    k = np.arange(m) + 0.5
    s = rng.uniform(size=(len(vertices), 2))
    u = (k / g + s[:, :1]) % 1.0
    v = (k / g**2 + s[:, 1:]) % 1.0
    fold = u + v > 1.0
    u, v = np.where(fold, 1 - u, u), np.where(fold, 1 - v, v)
    e1, e2 = vertices[:, 1] - vertices[:, 0], vertices[:, 2] - vertices[:, 0]
    return vertices[:, None, 0] + u[..., None] * e1[:, None] + v[..., None] * e2[:, None]


def _scene(path: Path, vertices, b0, rho, reflect: bool, w: float) -> None:
    """One polygon and one material per patch: a glow of B₀/π, or its mix with a plastic."""
    out = []
    for i, (t, b, r) in enumerate(zip(vertices, b0, rho, strict=True)):
        L = b / np.pi
        if reflect:
            out.append(f"void glow g{i} 0 0 4 {L / w:.6g} {L / w:.6g} {L / w:.6g} 0")
            c = r / (1 - w)
            out.append(f"void plastic p{i} 0 0 5 {c:.6g} {c:.6g} {c:.6g} 0 0")
            out.append(f"void mixfunc m{i} 4 g{i} p{i} {w:g} . 0 0")
            mat = f"m{i}"
        else:
            out.append(f"void glow g{i} 0 0 4 {L:.6g} {L:.6g} {L:.6g} 0")
            mat = f"g{i}"
        xyz = " ".join(f"{x:.6f}" for x in t.reshape(-1))
        out.append(f"{mat} polygon t{i} 0 0 9 {xyz}")
    path.write_text("\n".join(out) + "\n", encoding="utf-8")


def _rtrace(octree: Path, pts, nrm, params) -> np.ndarray:
    import pyradiance as pr

    rays = "\n".join(" ".join(f"{x:.6f}" for x in (*p, *n)) for p, n in zip(pts, nrm, strict=True))
    out = pr.rtrace((rays + "\n").encode(), str(octree), params=params, irradiance=True,
                    header=False, outform="a")
    v = np.array([[float(x) for x in line.split()] for line in out.decode().splitlines()
                  if line.strip()])
    return v[:, 0]  # grey: the three channels are equal


def radiance(args) -> None:
    import pyradiance as pr

    work = Path(args.work)
    g = np.load(work / "patches.npz")
    vert, nrm, area, rho, e_dir = g["vertices"], g["normal"], g["area"], g["rho"], g["e_dir"]
    b0 = rho * e_dir
    recv = _sample_receivers(area, args.receivers)
    pts = _points_in(vert[recv], args.points, seed=args.seed) + 1e-3 * nrm[recv, None]
    pts = pts.reshape(-1, 3)
    normals = np.repeat(nrm[recv], args.points, axis=0)
    res = {"receivers": recv, "points": args.points, "seed": args.seed}
    common = ["-aa", "0", "-as", "0", "-lw", "1e-7", "-dr", "0", "-ds", "0", "-dj", "0",
              "-av", "0", "0", "0"]
    # -ab 20 with -lr 50: ρ ≤ 0.6, so paths past 20 bounces carry < 0.6²⁰ ≈ 4·10⁻⁵ of the light
    # (Radiance's default -lr 10 alone cut a closed ρ 0.6 furnace 0.6 % short)
    for kind, reflect, params in (
        ("first", False, ["-ab", "1", "-ad", str(args.ad), *common]),
        ("indirect", True, ["-ab", "20", "-lr", "50", "-ad", str(args.ad_indirect), *common]),
    ):
        if kind not in args.kinds:
            continue
        rad = work / f"{kind}.rad"
        _scene(rad, vert, b0, rho, reflect, args.w)
        octree = work / f"{kind}.oct"
        octree.write_bytes(pr.oconv(str(rad)))
        t = time.perf_counter()
        e = _rtrace(octree, pts, normals, params).reshape(len(recv), args.points)
        res[kind] = e
        res[f"{kind}_params"] = " ".join(params)
        res[f"{kind}_s"] = time.perf_counter() - t
        print(f"{kind}: {len(pts):,} points × -ad {params[params.index('-ad') + 1]} in "
              f"{time.perf_counter() - t:.0f} s", flush=True)
        np.savez(work / f"radiance_{kind}_s{args.seed}.npz", **res)


def rows(args) -> None:
    """The block operator's first bounce at the Radiance receivers only: their rows of
    ``G = A F`` from the build's own dense-block function (``_pair_block``: far kernel × one
    centroid shadow ray, near pairs by the contour integral, receiver quadrature and 4–16 rays,
    symmetrised), so the comparison does not wait for the whole P² operator. It differs from a
    built operator only by the partition's culls and the low-rank far field (tolerance 10⁻³)."""
    from lumijax.kernels import triangle_spread
    from lumijax.radiosity import FormFactorSettings, partition
    from lumijax.radiosity._build import _pair_block
    from lumijax.scene._raycast import RayCaster

    work = Path(args.work)
    g = np.load(work / "patches.npz")
    study, tri, area, p = _quarter_mesh(args)
    assert np.array_equal(p.centroid, g["centroid"]), "not the mesh of the solve stage"
    b0 = g["rho"] * g["e_dir"]
    caster = RayCaster(tri)
    recv = next(np.load(f)["receivers"] for f in sorted(work.glob("radiance_first_s*.npz")))
    counters = dict(rays=0, ray_time=0.0, near_pairs=0)
    diam, spread = p.diameter, triangle_spread(p.vertices)
    allp = np.arange(p.n)
    # the partition the block build uses (benchmarks/hierarchy.py: max_block 1024): which
    # block pairs it keeps, so the light each receiver gets from a culled pair can be told
    part = partition(p, 1024, occluders=caster)
    block = np.empty(p.n, np.int64)
    for b in range(part.n_blocks):
        block[part.members[part.offsets[b]:part.offsets[b + 1]]] = b
    kept = np.zeros((part.n_blocks,) * 2, bool)
    kept[part.pairs[:, 0], part.pairs[:, 1]] = True
    kept |= kept.T
    first = np.zeros(len(recv))
    by_block = np.zeros((len(recv), part.n_blocks))
    t = time.perf_counter()
    for k in range(0, len(recv), 8):
        ia = recv[k:k + 8]
        gg = _pair_block(p, ia, allp, False, FormFactorSettings(), caster, counters, diam,
                         spread)
        first[k:k + 8] = gg @ b0 / p.area[ia]
        for b in range(part.n_blocks):
            m = block == b
            by_block[k:k + 8, b] = gg[:, m] @ b0[m] / p.area[ia]
    culled = ~kept[block[recv]]  # (receivers, blocks): the pair is not in the operator
    np.savez(work / "rows.npz", receivers=recv, first=first, by_block=by_block, culled=culled,
             seconds=time.perf_counter() - t)
    lost = np.sum(by_block * culled)
    print(f"partition: {part.n_blocks} blocks, {len(part.pairs)} pairs kept, stats "
          f"{dict(part.stats)}; light from culled pairs at the receivers: "
          f"{lost / first.sum():.2%} of their first bounce", flush=True)
    print(f"block rows of {len(recv)} receivers: {time.perf_counter() - t:.0f} s, "
          f"{counters['rays']:,} rays, {counters['near_pairs']:,} near pairs", flush=True)


def culls(args) -> None:
    """How much of the receivers' first bounce the partition's occlusion cull drops, at its
    default and at stricter settings (the blocks do not depend on the cull, so ``rows``'s
    per-block light is reused): ``--cull samples,min_facing`` pairs."""
    from lumijax.radiosity import partition
    from lumijax.scene._raycast import RayCaster

    work = Path(args.work)
    r = np.load(work / "rows.npz")
    recv, by_block, first = r["receivers"], r["by_block"], r["first"]
    study, tri, area, p = _quarter_mesh(args)
    caster = RayCaster(tri)
    print("| samples | min_facing | pairs kept | culled (occlusion) | rays | receivers' first "
          "bounce lost | receivers losing > 10 % |")
    print("|---|---|---|---|---|---|---|")
    for spec in args.cull:
        samples, min_facing = (int(x) for x in spec.split(","))
        part = partition(p, 1024, occluders=caster, samples=samples, min_facing=min_facing)
        block = np.empty(p.n, np.int64)
        for b in range(part.n_blocks):
            block[part.members[part.offsets[b]:part.offsets[b + 1]]] = b
        kept = np.zeros((part.n_blocks,) * 2, bool)
        kept[part.pairs[:, 0], part.pairs[:, 1]] = True
        kept |= kept.T
        lost = np.sum(by_block * ~kept[block[recv]], axis=1)
        st = part.stats
        print(f"| {samples} | {min_facing} | {len(part.pairs)} | {st['culled_occluded']} | "
              f"{st['occlusion_rays']:,} | {lost.sum() / first.sum():.2%} | "
              f"{int(np.sum(lost > 0.1 * first))} |", flush=True)


def fine(args) -> None:
    """The same emission on a finer mesh: each fine patch takes B₀ of the coarse patch holding
    its centroid (Radiance's glows), is solved with the sampled transport, and the receivers
    get the area mean of their fine patches. What moves between the coarse and the fine
    result is the discretisation of the inter-reflected light (B constant per patch), which
    both operators share and Radiance, reflecting continuously, does not have."""
    import jax.numpy as jnp

    from lumijax.lighting._pipeline import auto_patch_size
    from lumijax.radiosity import (
        PatchLocator,
        SampledSettings,
        build_sampled,
        mesh_patches,
        solve_radiosity,
    )
    from lumijax.scene._raycast import RayCaster

    work = Path(args.work)
    g = np.load(work / "patches.npz")
    study, tri, area, coarse = _quarter_mesh(args)
    group = study.scene.triangles.group
    assert np.array_equal(coarse.centroid, g["centroid"]), "not the mesh of the solve stage"
    fp = mesh_patches(tri, group=group, patch_size=auto_patch_size(area, args.fine_patches))
    parent = PatchLocator(coarse, tri)(fp.centroid, np.asarray(fp.source_triangle))
    b0 = (g["rho"] * g["e_dir"])[parent]
    rho = np.where(fp.normal[:, 2] > 0.5, 0.3, 0.6)
    t = time.perf_counter()
    op = build_sampled(fp, tri, SampledSettings(rays_per_patch=args.rays[0]),
                       caster=RayCaster(tri))
    b0j = jnp.asarray(b0[:, None], jnp.float32)
    sol = solve_radiosity(op, jnp.asarray(rho, jnp.float32), b0j)
    first = np.asarray(op.matmul(b0j), np.float64)[:, 0]
    ind = np.asarray(op.matmul(sol.value), np.float64)[:, 0]
    recv = next(np.load(f)["receivers"] for f in sorted(work.glob("radiance_first_s*.npz")))
    out = {}
    for name, x in (("first", first), ("indirect", ind)):
        num = np.bincount(parent, weights=fp.area * x, minlength=coarse.n)
        den = np.bincount(parent, weights=fp.area, minlength=coarse.n)
        out[name] = np.where(den[recv] > 0, num[recv] / np.maximum(den[recv], 1e-30), np.nan)
    np.savez(work / f"fine{fp.n}.npz", receivers=recv, patches=fp.n, rays=args.rays[0], **out)
    print(f"finer mesh: {fp.n:,} patches, sampled {args.rays[0]} rays, "
          f"{time.perf_counter() - t:.0f} s", flush=True)


def box(args) -> None:
    """A control without contact lines or buried patches: an open-topped 4 × 4 × 3 m box,
    only the floor glowing (B₀ = π lm/m²), ρ 0.6 walls and 0.3 floor, blocks and sampled
    transport against the same Radiance set-up at 100 receivers (all bounces and first)."""
    import jax.numpy as jnp
    import pyradiance as pr
    import trimesh

    from lumijax.radiosity import (
        SampledSettings,
        build_operator,
        build_sampled,
        mesh_patches,
        partition,
        solve_radiosity,
    )
    from lumijax.scene._raycast import RayCaster

    work = Path(args.work) / "box"
    work.mkdir(parents=True, exist_ok=True)
    m = trimesh.creation.box(extents=(4.0, 4.0, 3.0))
    m.apply_translation((0, 0, 1.5))
    m.invert()  # faces point inwards
    tri = np.asarray(m.triangles, np.float64)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    tri = tri[nrm[:, 2] > -0.5]  # drop the ceiling (its normal points down)
    p = mesh_patches(tri, patch_size=0.25)
    up = p.normal[:, 2] > 0.5
    rho = np.where(up, 0.3, 0.6)
    b0 = np.where(up, np.pi, 0.0)
    caster = RayCaster(tri)
    res = {}
    bj, rj = jnp.asarray(b0[:, None], jnp.float32), jnp.asarray(rho, jnp.float32)
    for name, op in (("blocks", build_operator(p, partition(p, 1024, occluders=caster), caster,
                                               occluder_triangles=tri)),
                     ("sampled4096", build_sampled(p, tri, SampledSettings(rays_per_patch=4096),
                                                   caster=caster))):
        sol = solve_radiosity(op, rj, bj)
        res[name] = (np.asarray(op.matmul(bj))[:, 0], np.asarray(op.matmul(sol.value))[:, 0])
    recv = _sample_receivers(p.area, 100)
    pts = (_points_in(p.vertices[recv], 16) + 1e-3 * p.normal[recv, None]).reshape(-1, 3)
    nn = np.repeat(p.normal[recv], 16, axis=0)
    common = ["-aa", "0", "-as", "0", "-lw", "1e-7", "-av", "0", "0", "0"]
    print(f"{p.n:,} patches, {len(recv)} receivers")
    print("| quantity | operator | mean vs Radiance | RMS per patch (raw) |\n|---|---|---|---|")
    for k, (reflect, params) in enumerate(((False, ["-ab", "1", "-ad", "1024", *common]),
                                           (True, ["-ab", "20", "-lr", "50", "-ad", "512",
                                                   *common]))):
        _scene(work / "box.rad", p.vertices, b0, rho, reflect, args.w)
        (work / "box.oct").write_bytes(pr.oconv(str(work / "box.rad")))
        ref = _rtrace(work / "box.oct", pts, nn, params).reshape(len(recv), 16).mean(axis=1)
        for name, v in res.items():
            x = v[k][recv]
            print(f"| {('first', 'all bounces')[k]} | {name} | {np.sum(x - ref) / np.sum(ref):+.2%} "
                  f"| {np.sqrt(np.mean((x - ref) ** 2) / np.mean(ref**2)):.1%} |", flush=True)


def visibility(args) -> None:
    """The block operator's far pairs see each other by one centroid-to-centroid shadow ray
    (all or nothing). For receivers of the Radiance sample, recompute the far part of their row
    of ``F B₀`` with the same kernel and ``--vis-rays`` shadow rays between stratified points
    of the two patches instead, and store the change per receiver (lx): what the first bounce
    of the block operator would gain with the finer visibility."""
    from lumijax.kernels import far_g, triangle_spread
    from lumijax.radiosity._build import _TIE, FormFactorSettings
    from lumijax.scene._raycast import RayCaster

    work = Path(args.work)
    g = np.load(work / "patches.npz")
    vert, nrm, area, cen = g["vertices"], g["normal"], g["area"], g["centroid"]
    b0 = g["rho"] * g["e_dir"]
    caster = RayCaster(g["triangles"])
    s = FormFactorSettings()
    e = np.stack([vert[:, 1] - vert[:, 0], vert[:, 2] - vert[:, 1], vert[:, 0] - vert[:, 2]], 1)
    diam = np.linalg.norm(e, axis=-1).max(axis=1)
    spread = triangle_spread(vert)
    recv = next(np.load(f)["receivers"] for f in sorted(work.glob("radiance_first_s*.npz")))
    recv = recv[:: args.every]
    k = args.vis_rays
    lit = np.flatnonzero(b0 > 0)  # sources that carry nothing need no rays
    pts = _points_in(vert[lit], k, seed=7)  # (sources, k, 3)
    out = np.zeros(len(recv))
    centroid_part = np.zeros(len(recv))
    t = time.perf_counter()
    for n, i in enumerate(recv):
        d = cen[lit] - cen[i]
        d2 = np.einsum("jk,jk->j", d, d)
        a = d @ nrm[i]
        b = -np.einsum("jk,jk->j", d, nrm[lit])
        size = np.maximum(diam[i], diam[lit])
        far = (d2 >= (s.near_ratio * size) ** 2 * (1 + 2 * _TIE)) & (a > 0) & (b > 0)
        j = np.flatnonzero(far)
        if not len(j):
            continue
        gg = far_g(a[j], b[j], nrm[lit[j]] @ nrm[i], d2[j], area[i], area[lit[j]],
                   spread[i], spread[lit[j]])
        vis_c = caster.transmission(np.broadcast_to(cen[i], (len(j), 3)), cen[lit[j]])
        own = _points_in(vert[i][None], k, seed=11 + n)[0]  # the receiver's k points
        o = np.broadcast_to(own[None], (len(j), k, 3)).reshape(-1, 3)
        vis_k = caster.transmission(o, pts[j].reshape(-1, 3)).reshape(len(j), k).mean(axis=1)
        centroid_part[n] = np.sum(gg * vis_c * b0[lit[j]]) / area[i]
        out[n] = np.sum(gg * (vis_k - vis_c) * b0[lit[j]]) / area[i]
        if n % 20 == 19:
            print(f"  {n + 1} / {len(recv)} receivers, {time.perf_counter() - t:.0f} s", flush=True)
    np.savez(work / "visibility.npz", receivers=recv, delta=out, far_centroid=centroid_part,
             rays=k)
    print(f"far-field first bounce, {len(recv)} receivers: centroid rays "
          f"{centroid_part.sum():.4g}, {k} rays {centroid_part.sum() + out.sum():.4g} "
          f"({out.sum() / centroid_part.sum():+.2%})")


def compare(args) -> None:
    work = Path(args.work)
    runs = {k: [np.load(f) for f in sorted(work.glob(f"radiance_{k}_s*.npz"))]
            for k in ("first", "indirect")}
    runs = {k: v for k, v in runs.items() if v}
    recv = next(iter(runs.values()))[0]["receivers"]
    g = np.load(work / "patches.npz")
    print(f"{len(g['area']):,} patches; {len(recv)} receivers drawn ∝ area")
    for k, v in runs.items():
        print(f"rtrace, {k}: {v[0][k + '_params']}; {len(v)} run(s) of {int(v[0]['points'])} "
              f"points per receiver ({', '.join(str(round(float(r[k + '_s']))) for r in v)} s)")
    names = sorted(f.stem for f in work.glob("*.npz") if f.stem.startswith(("blocks", "sampled")))
    est: dict[str, list] = {k: [(n, np.load(work / f"{n}.npz")[k][recv]) for n in names]
                            for k in runs}
    for f in sorted(work.glob("fine*.npz")):
        z = np.load(f)
        for k in est:
            est[k].append((f"sampled{int(z['rays'])}, {int(z['patches']):,} finer patches, "
                           "same B₀", z[k]))
    if "first" in est and (work / "rows.npz").exists():
        r = np.load(work / "rows.npz")
        est["first"].append(("blocks, receivers' rows", r["first"]))
        if "culled" in r.files:  # what the operator stores: the partition's culls dropped
            lost = np.sum(r["by_block"] * r["culled"], axis=1)
            est["first"].append(("blocks' rows less the block pairs the partition culls",
                                 r["first"] - lost))
        if (work / "visibility.npz").exists():
            v = np.load(work / "visibility.npz")
            x = np.full(len(recv), np.nan)
            sub = np.searchsorted(recv, v["receivers"])
            x[sub] = r["first"][sub] + v["delta"]
            est["first"].append((f"blocks' rows, far pairs by {int(v['rays'])} shadow rays", x))
            for n, y in list(est["first"]):
                if not n.startswith("blocks"):
                    z = np.full(len(recv), np.nan)
                    z[sub] = y[sub]
                    est["first"].append((f"{n} (the same receivers)", z))
    print("\n| quantity | operator | receivers | mean vs Radiance | RMS per patch vs Radiance | "
          "the same, Radiance's noise removed | Radiance's own: mean ± (1σ) | RMS noise |")
    print("|---|---|---|---|---|---|---|---|")
    for kind, v in runs.items():
        # each run: its own stratified points (seed) and rays; a patch's runs are independent
        m = np.stack([r[kind].mean(axis=1) for r in v])
        assert all(np.array_equal(r["receivers"], recv) for r in v)
        ref = m.mean(axis=0)
        if len(v) > 1:  # Radiance's error in a patch mean: the runs' spread
            se2 = m.var(axis=0, ddof=1) / len(v)
        else:  # one run: two interleaved halves of its points (an upper bound: each half
            # samples the patch worse than the whole)
            e = v[0][kind]
            se2 = ((e[:, 0::2].mean(axis=1) - e[:, 1::2].mean(axis=1)) / 2) ** 2
        for name, x in est[kind]:
            ok = np.isfinite(x)
            xo, ro, so = x[ok], ref[ok], se2[ok]
            noise = np.mean(so) / np.mean(ro**2)
            raw = np.mean((xo - ro) ** 2) / np.mean(ro**2)
            print(f"| {kind} | {name} | {ok.sum()} | {np.sum(xo - ro) / np.sum(ro):+.2%} | "
                  f"{np.sqrt(raw):.1%} | {np.sqrt(max(raw - noise, 0)):.1%} | "
                  f"±{np.sqrt(np.sum(so)) / np.sum(ro):.2%} | {np.sqrt(noise):.1%} |")
    _by_kind_of_receiver(work, runs, est, recv)
    if len(names) > 1:
        print("\n| quantity | operator | mean vs blocks (all patches, area-weighted) | RMS |")
        print("|---|---|---|---|")
        a = g["area"]
        for kind in ("first", "indirect"):
            y = np.load(work / "blocks.npz")[kind] if (work / "blocks.npz").exists() else None
            if y is None:
                break
            for name in names:
                if name == "blocks":
                    continue
                x = np.load(work / f"{name}.npz")[kind]
                print(f"| {kind} | {name} | {np.sum(a * (x - y)) / np.sum(a * y):+.2%} | "
                      f"{np.sqrt(np.sum(a * (x - y) ** 2) / np.sum(a * y**2)):.1%} |")


def _inside_share(work: Path) -> np.ndarray:
    """Each patch's share of points inside the model (benchmarks/hierarchy.py's back-face
    probe), kept in ``work``."""
    path = work / "inside.npy"
    if not path.exists():
        from types import SimpleNamespace

        from lumijax.scene._raycast import RayCaster

        spec = importlib.util.spec_from_file_location("hierarchy",
                                                      ROOT / "benchmarks" / "hierarchy.py")
        hierarchy = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(hierarchy)
        g = np.load(work / "patches.npz")
        p = SimpleNamespace(vertices=g["vertices"], normal=g["normal"], n=len(g["area"]))
        np.save(path, hierarchy._inside(p, RayCaster(g["triangles"])))
    return np.load(path)


def _by_kind_of_receiver(work: Path, runs, est, recv) -> None:
    """The table again for the receivers in the open, partly inside the model (behind a
    column's half prism, under its foot) and wholly inside it, where Radiance's points see the
    model's backs and no operator's patch mean means anything to a designer."""
    inside = _inside_share(work)[recv]
    print("\n| quantity | operator | receivers | mean vs Radiance | RMS per patch, Radiance's "
          "noise removed |")
    print("|---|---|---|---|---|")
    for kind, v in runs.items():
        m = np.stack([r[kind].mean(axis=1) for r in v])
        ref = m.mean(axis=0)
        se2 = m.var(axis=0, ddof=1) / len(v) if len(v) > 1 else np.zeros_like(ref)
        for where, mask in (("open", inside == 0), ("partly inside", (inside > 0) & (inside < 1)),
                            ("inside", inside == 1)):
            for name, x in est[kind]:
                ok = mask & np.isfinite(x)
                if not ok.any() or "," in name or "(" in name:
                    continue
                xo, ro = x[ok], ref[ok]
                raw = np.mean((xo - ro) ** 2) / np.mean(ro**2)
                noise = np.mean(se2[ok]) / np.mean(ro**2)
                print(f"| {kind} | {name}, {where} | {ok.sum()} | "
                      f"{np.sum(xo - ro) / np.sum(ro):+.2%} | "
                      f"{np.sqrt(max(raw - noise, 0)):.1%} |")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stage", choices=("solve", "radiance", "rows", "culls", "fine", "box", "visibility",
                                          "compare"))
    ap.add_argument("--work", default="/tmp/lumijax-radiance-transport")
    ap.add_argument("--bays", type=int, default=6)
    ap.add_argument("--facades", default="S")
    ap.add_argument("--patches", type=int, default=16000, help="asked (slivers add ~50 %%)")
    ap.add_argument("--rays", type=int, nargs="*", default=[1024, 4096])
    ap.add_argument("--no-blocks", action="store_true", help="solve: skip the block operator")
    ap.add_argument("--receivers", type=int, default=400)
    ap.add_argument("--points", type=int, default=8, help="Radiance points per receiver")
    ap.add_argument("--ad", type=int, default=1024, help="rtrace -ad, first bounce")
    ap.add_argument("--ad-indirect", type=int, default=256, help="rtrace -ad, all bounces")
    ap.add_argument("--kinds", nargs="+", default=["first", "indirect"])
    ap.add_argument("--fine-patches", type=int, default=36000, help="fine: asked patches")
    ap.add_argument("--cull", nargs="+", default=["256,8", "256,64", "1024,64", "1024,256"],
                    help="culls: samples,min_facing of the partition's occlusion cull")
    ap.add_argument("--vis-rays", type=int, default=16, help="visibility: rays per far pair")
    ap.add_argument("--every", type=int, default=2, help="visibility: every n-th receiver")
    ap.add_argument("--seed", type=int, default=1, help="radiance: the points' seed (one run)")
    ap.add_argument("--w", type=float, default=0.3, help="glow weight of the mixfunc")
    args = ap.parse_args(argv)
    {"solve": solve, "radiance": radiance, "rows": rows, "culls": culls, "fine": fine, "box": box,
     "visibility": visibility,
     "compare": compare}[args.stage](args)


if __name__ == "__main__":
    main()
