"""The traced view pass at scale: a 1920 × 1080 view of the courtyard with depth-2 specular.

    python benchmarks/views.py                 # configs/courtyard.toml, 1920 × 1080, depth 2
    python benchmarks/views.py --rough 0.08    # the paving glossy (Ward α 0.08, 4 lobe rays)
    python benchmarks/views.py --small         # 480 × 270: a smoke test

The courtyard's paving is given a mirror-like specular part (ρ_s 0.3, α 0.002) and its window
glass ρ_s 0.08 in this run's copy of the materials (the study itself is not changed), so the
paving mirrors the lit facades and the windows mirror the court: two bounces where a ray meets
glass after paving. The surfaces carry a constant luminance per material (ρ × 10 cd/m²)
instead of a radiosity solve: what a pixel costs does not depend on the values it
interpolates, and the solve is benchmarks/courtyard.py's. The 3,000 luminaires are traced at
their luminance over their openings.

Prints, in this process: scene load, tracer build (Embree BVHs of the 22 k surface triangles
and the luminaires' opening proxies), a first render (JAX compiles each photometry's
luminance there) and a second one (seconds, primary rays, all ray queries and their rate), and Embree's raw first-hit rate on the same surface scene for the same
primary rays (one query, no shading), so the pass's overhead over raw Embree is the ratio.
Timings on a shared machine are contended: re-run alone for figures.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import resource
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _specular_copy(scene, rough: float):
    """The scene with the paving and the glass given specular parts (this run only)."""
    from lumijax.spectral import Spectrum

    mats = []
    for m in scene.materials:
        if m.name == "paving":
            m = dataclasses.replace(m, specular=Spectrum.grey(0.3, name="paving specular"),
                                    rho_s=0.3, roughness=rough)
        elif m.name == "glass":
            m = dataclasses.replace(m, specular=Spectrum.grey(0.08, name="glass specular"),
                                    rho_s=0.08, roughness=0.002)
        mats.append(m)
    return dataclasses.replace(scene, materials=tuple(mats))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", default=str(ROOT / "configs" / "courtyard.toml"))
    ap.add_argument("--size", type=int, nargs=2, default=(1920, 1080))
    ap.add_argument("--depth", type=int, default=2)
    ap.add_argument("--rough", type=float, default=0.002, help="Ward α of the paving")
    ap.add_argument("--small", action="store_true", help="480 x 270 (a smoke test)")
    ap.add_argument("--png", help="also write the view, tone-mapped (metered EV), to this file")
    args = ap.parse_args()
    size = (480, 270) if args.small else tuple(args.size)

    import lumijax
    from lumijax.render import Perspective, Tracer, emitters_of, optics_of

    t0 = time.perf_counter()
    scene = _specular_copy(lumijax.load_study(args.study).scene, args.rough)
    t_load = time.perf_counter() - t0

    t0 = time.perf_counter()
    tri = scene.triangles
    points = tri.vertices.reshape(-1, 3)
    faces = np.arange(len(points)).reshape(-1, 3)
    rho = np.array([m.luminous_reflectance for m in scene.materials])
    lum = np.repeat(10.0 * rho[tri.material], 3)  # cd/m² per vertex
    vertex_xyz = np.repeat(lum[None, :, None], 3, axis=2)
    tracer = Tracer(points, faces, tri.normals, vertex_xyz, tri.material,
                    optics_of(scene.materials), emitters_of(scene), depth=args.depth)
    t_build = time.perf_counter() - t0

    lo, hi = tri.bounds
    centre = 0.5 * (lo + hi)
    # standing in the court near the north facade, looking across it at the south one
    eye = (centre[0] + 6.0, lo[1] + 0.78 * (hi[1] - lo[1]), 1.7)
    cam = Perspective(position=eye, target=(centre[0], lo[1], 6.0), size=size, fov_deg=50.0)
    dimmers = scene.dimmers
    t0 = time.perf_counter()
    tracer.render(cam, dimmers)
    t_first = time.perf_counter() - t0  # each photometry's luminance compiled once (JAX)
    tracer.stats = type(tracer.stats)()
    t0 = time.perf_counter()
    image = tracer.render(cam, dimmers)
    t_render = time.perf_counter() - t0
    st = tracer.stats

    # Embree alone: the same primary rays, first hit only, on the same surface BVH
    d, _ = cam.rays()
    origin = np.asarray(cam.position, np.float64)
    caster = tracer._surfaces
    t0 = time.perf_counter()
    caster.first_hit(origin, d)
    t_raw = time.perf_counter() - t0

    lum_img = image.luminance
    if args.png:
        from lumijax.report._tonemap import auto_ev100, tone_map
        from lumijax.report._views import write_png

        ev = auto_ev100(lum_img[lum_img > 0], np.ones(int((lum_img > 0).sum())))
        rgb = tone_map(image.xyz.reshape(-1, 3), ev).reshape(image.xyz.shape)
        write_png(np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8), args.png)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"study         {Path(args.study).name}: {len(tri)} triangles, "
          f"{len(scene.luminaires)} luminaires ({len(tracer.emitters.triangles)} proxy "
          f"triangles)")
    print(f"view          {size[0]} x {size[1]}, depth {args.depth}, paving α {args.rough:g}")
    print(f"load          {t_load:8.2f} s")
    print(f"build         {t_build:8.2f} s")
    print(f"first render  {t_first:8.2f} s   (JAX compiles each photometry's I/A_p once)")
    print(f"render        {t_render:8.2f} s   {st.primary:,} primary rays, {st.rays:,} ray "
          f"queries, {st.rays / t_render / 1e6:.2f} M queries/s, "
          f"{st.primary / t_render / 1e6:.2f} M pixels/s")
    print(f"embree raw    {t_raw:8.2f} s   {len(d):,} first hits, "
          f"{len(d) / t_raw / 1e6:.2f} M rays/s")
    print(f"overhead      {t_render / t_raw:8.1f} x raw Embree for the same pixels")
    print(f"image         median {np.median(lum_img):.3g} cd/m², max {lum_img.max():.3g} cd/m²,"
          f" {np.mean(lum_img > 0):.0%} of pixels lit")
    print(f"peak RSS      {rss:8.0f} MB")
    print(f"machine       {platform.processor() or platform.machine()}, {os.cpu_count()} "
          "CPUs (shared: timings contended)")


if __name__ == "__main__":
    main()
