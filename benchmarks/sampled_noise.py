"""Where the sampled transport's per-patch noise comes from, and what reduces it (issue 17).

    python benchmarks/sampled_noise.py [--patch-size 0.35] [--rays 256 1024 4096]

The room of ``tests/radiosity/test_sampled.py``: 4 × 3 × 2.8 m, a desk and a partition, a
downlight 0.2 m under the ceiling lighting the upward faces (a peaky first bounce), ρ 0.3 up
and 0.7 elsewhere. The reference is the block operator on the same mesh (exact contour
integrals, visibility by rays: docs/radiosity.md). For each number of rays a patch it prints
the inter-reflected irradiance's mean and RMS per patch against it (area-weighted, relative to
the field's RMS, as docs/radiosity.md, "Two levels") for

* ``sampled``: the sampled operator as built;
* ``reciprocal``: ``(G + Gᵀ)/2`` (``G = A F``: the two estimates of each pair averaged), each
  row rescaled to the sampled row's sum so that a closed room stays closed;
* ``balanced``: the same made symmetric *and* of those row sums (``s_i s_j S_ij``, symmetric
  Sinkhorn scaling);
* ``aimed``: a quarter of each patch's rays aimed at the directly lit patches (the proposal ∝
  the downlight's flux on each patch, ``radiosity/_bright.py``), two seeds;

the sampled operator's own noise (two seeds' difference ÷ √2), and, once, where the error of
one product ``F̂ B − F B`` (B the reference's radiosity) comes from: pairs nearer than r
against the rest — what an exact near field could remove.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def furnished_room():
    """The test's room (``tests/radiosity/test_sampled.py``), its triangles (T, 3, 3), m."""
    sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # the test module imports ``helpers``
    from tests.radiosity.test_sampled import _furnished_triangles

    return _furnished_triangles()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--patch-size", type=float, default=0.35)
    ap.add_argument("--rays", type=int, nargs="+", default=[256, 1024, 4096])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    import jax.numpy as jnp
    import scipy.sparse as sp

    from lumijax.radiosity import (
        SampledSettings,
        bright_patches,
        build_operator,
        build_sampled,
        mesh_patches,
        partition,
        solve_radiosity,
    )
    from lumijax.radiosity._operator import SampledBucket, TransportOperator

    tri = furnished_room()
    p = mesh_patches(tri, patch_size=args.patch_size)
    t = time.perf_counter()
    block = build_operator(p, partition(p, 512, occluders=tri), tri)
    block_s = time.perf_counter() - t
    d = np.array([1.0, 0.5, 1.2]) - p.centroid
    r2 = np.sum(d * d, axis=1)
    cos = np.clip(np.einsum("ij,ij->i", d, p.normal) / np.sqrt(r2), 0, None)
    e_dir = 300.0 * cos * np.clip(-d[:, 2] / np.sqrt(r2), 0, None) / r2  # lx
    rho = np.where(p.normal[:, 2] > 0.5, 0.3, 0.7)
    b0 = jnp.asarray((rho * e_dir)[:, None], jnp.float32)
    a = p.area
    proposal = bright_patches(e_dir * a, p)  # what a study's pipeline aims at: the direct flux

    def solved(op):
        b = solve_radiosity(op, jnp.asarray(rho, jnp.float32), b0).value
        return np.asarray(b)[:, 0], np.asarray(op.matmul(b))[:, 0]

    b_ref, e_ref = solved(block)

    def score(e):
        mean = np.sum(a * (e - e_ref)) / np.sum(a * e_ref)
        rms = np.sqrt(np.sum(a * (e - e_ref) ** 2) / np.sum(a * e_ref**2))
        return mean, rms

    def from_links(like, g):
        g = g.tocoo()
        bucket = SampledBucket.from_links(g.row, g.col, g.data, p.n)
        return TransportOperator((bucket,), like.area, like.block_of, like.n_patches, 1,
                                 like.info)

    print(f"machine: {platform.platform()}, {os.cpu_count()} cores; room of "
          f"tests/radiosity/test_sampled.py at {args.patch_size} m: {p.n:,} patches; "
          f"block operator {block_s:.1f} s")
    print("| rays a patch | links a patch | variant | build (s) | indirect: mean | "
          "indirect: RMS per patch |")
    print("|---|---|---|---|---|---|")
    last = None
    for n_rays in args.rays:
        t = time.perf_counter()
        op = build_sampled(p, tri, SampledSettings(rays_per_patch=n_rays, seed=args.seed))
        build_s = time.perf_counter() - t
        r, c, w = op.buckets[0].links()
        g = sp.coo_matrix((w, (r, c)), shape=(p.n + 1, p.n + 1)).tocsr()[:p.n, :p.n]
        rows = np.asarray(g.sum(1)).ravel()
        s = ((g + g.T) * 0.5).tocsr()
        srows = np.asarray(s.sum(1)).ravel()
        recip = sp.diags(rows / np.where(srows > 0, srows, 1.0)) @ s
        k = np.ones(p.n)
        for _ in range(60):  # symmetric Sinkhorn: k_i Σ_j S_ij k_j = rows_i
            k = np.sqrt(k * rows / np.maximum(s @ k, 1e-30))
        balanced = sp.diags(k) @ s @ sp.diags(k)
        for name, o in (("sampled", op), ("reciprocal", from_links(op, recip)),
                        ("balanced", from_links(op, balanced))):
            e = solved(o)[1]
            mean, rms = score(e)
            links = (g if name == "sampled" else s).nnz / p.n
            print(f"| {n_rays:,} | {links:,.0f} | {name} | {build_s:.1f} | {mean:+.2%} | "
                  f"{rms:.2%} |", flush=True)
            if name == "sampled":
                plain = e
        # the sampled operator's own noise: two seeds' difference ÷ √2 (what is left of the
        # RMS above is a difference between the two operators, not noise)
        other = solved(build_sampled(p, tri, SampledSettings(rays_per_patch=n_rays,
                                                             seed=args.seed + 1)))[1]
        noise = np.sqrt(np.sum(a * (other - plain) ** 2) / np.sum(a * e_ref**2)) / np.sqrt(2)
        print(f"| {n_rays:,} | | own noise (seeds {args.seed}, {args.seed + 1}: difference "
              f"÷ √2) | | | {noise:.2%} |", flush=True)
        # a quarter of the rays aimed at the lit patches (radiosity/_bright.py), two seeds
        for seed in (args.seed, args.seed + 1):
            t = time.perf_counter()
            aimed = build_sampled(p, tri, SampledSettings(rays_per_patch=n_rays, seed=seed),
                                  bright=proposal)
            build_s = time.perf_counter() - t
            mean, rms = score(solved(aimed)[1])
            links = int(aimed.info["links"]) / p.n
            print(f"| {n_rays:,} | {links:,.0f} | aimed ({aimed.info['settings']['aimed_rays']} "
                  f"rays), seed {seed} | {build_s:.1f} | {mean:+.2%} | {rms:.2%} |", flush=True)
        last = g

    f = block.todense()
    err = (sp.diags(1.0 / a) @ last).toarray() - f
    tot = f @ b_ref
    rel = lambda x: np.sqrt(np.sum(a * x**2) / np.sum(a * tot**2))  # noqa: E731
    dist = np.linalg.norm(p.centroid[:, None] - p.centroid[None], axis=-1)
    print()
    print(f"one product F̂B − FB at {args.rays[-1]:,} rays: RMS per patch "
          f"{rel(err @ b_ref):.2%}; split by the pair's distance r")
    print("| r (m) | pairs nearer a patch | share of ΣAF nearer | RMS from nearer | "
          "RMS from farther |")
    print("|---|---|---|---|---|")
    for r in (0.5, 1.0, 1.5, 2.0):
        near = dist < r
        share = np.sum(np.where(near, f, 0) * a[:, None]) / np.sum(f * a[:, None])
        print(f"| {r} | {near.sum() / p.n:,.0f} | {share:.0%} | {rel((err * near) @ b_ref):.2%} |"
              f" {rel((err * ~near) @ b_ref):.2%} |")


if __name__ == "__main__":
    main()
