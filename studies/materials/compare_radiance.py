"""Clear glass and an opal diffuser: lumijax against Radiance (pyradiance), side by side.

Two 3 × 3 × 3 m rooms share the wall x = 3 m; a 1 × 1 m opening in its middle (y, z from 1 to
2 m) holds either a clear pane (τ(0) = 0.88: Radiance ``glass``) or an opal panel (ρ_d = 0.3,
τ_d = 0.5: Radiance ``trans`` with colour 0.8 and trans 0.625, since ``trans`` splits its
colour c as ρ_d = c (1 − trans), τ_d = c · trans). A 3000 lm isotropic lamp at the centre of
room A lights room B only through the opening. Every other surface is grey, ρ = 0.5 (Radiance
``plastic``, two-sided; lumijax gets one rectangle per side). The calculation points are a
5 × 5 grid 1 cm above room B's floor and a row of 5 points on room B's far wall facing the
opening.

    python studies/materials/compare_radiance.py [--quick] [--out DIR]

writes ``RESULTS.md`` beside this script (``--out``: elsewhere). Times are wall seconds on the
shared, contended 2-core machine: indicative only, not benchmarks. lumijax times include
loading, meshing, the form factors (cache off), JIT compilation, the solve and the gather;
Radiance's include ``oconv``.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests"))

from helpers import (  # noqa: E402
    lamp,
    material,
    network,
    photometry,
    point_grid,
    rectangle,
    study_text,
    table,
)

import lumijax  # noqa: E402

FLUX = 3000.0
LAMP = (1.5, 1.5, 1.5)
RHO = 0.5
WHTEFFICACY = 179.0
GLASS_TN = 0.88
OPAL_RHO, OPAL_TAU = 0.3, 0.5


def _rects() -> list[tuple[tuple, tuple, tuple]]:
    """(origin, u, v) of every opaque surface, facing into its room (m)."""
    out = []
    for x0 in (0.0, 3.0):
        out += [((x0, 0, 0), (3, 0, 0), (0, 3, 0)), ((x0, 0, 3), (0, 3, 0), (3, 0, 0)),
                ((x0, 0, 0), (0, 0, 3), (3, 0, 0)), ((x0, 3, 0), (3, 0, 0), (0, 0, 3))]
    out += [((0, 0, 0), (0, 3, 0), (0, 0, 3)), ((6, 0, 0), (0, 0, 3), (0, 3, 0))]
    # the partition around the opening, each piece once facing A (−x) and once facing B (+x)
    for (y0, z0), (dy, dz) in (((0, 0), (3, 1)), ((0, 2), (3, 1)), ((0, 1), (1, 1)),
                               ((2, 1), (1, 1))):
        out += [((3, y0, z0), (0, 0, dz), (0, dy, 0)), ((3, y0, z0), (0, dy, 0), (0, 0, dz))]
    return out


OPENING = ((3, 1, 1), (0, 0, 1), (0, 1, 0))  # faces −x, toward the lamp


def _points():
    g = np.linspace(3.3, 5.7, 5)
    floor = np.array([[x, y, 0.01] for x in g for y in np.linspace(0.3, 2.7, 5)])
    wall = np.array([[5.99, y, 1.5] for y in np.linspace(0.3, 2.7, 5)])
    return floor, wall


def lumijax_study(folder: Path, kind: str, patch_size: float, gather: int) -> Path:
    pane = (material("pane", 0.0, transmittance=GLASS_TN, kind="clear") if kind == "glass"
            else material("pane", OPAL_RHO, transmittance=OPAL_TAU, kind="diffuse"))
    opening = [] if kind == "open" else [rectangle(*(list(a) for a in OPENING), "pane")]
    floor, wall = _points()
    text = study_text(
        table("study", name=f"materials-{kind}"), material("grey", RHO), pane,
        photometry("iso", "isotropic", FLUX), network("n"), lamp("L", list(LAMP)),
        *(rectangle(list(o), list(u), list(v), "grey") for o, u, v in _rects()),
        *opening,
        point_grid("floor", floor.tolist(), [0, 0, 1]),
        point_grid("wall", wall.tolist(), [-1, 0, 0]),
        table("solver", patch_size=patch_size, gather_rays=gather),
    )
    path = folder / f"{kind}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _polygon(mat: str, name: str, o, u, v) -> str:
    o, u, v = (np.asarray(a, float) for a in (o, u, v))
    pts = [o, o + u, o + u + v, o + v]
    return f"{mat} polygon {name}\n0\n0\n12 " + " ".join(f"{c:g}" for p in pts for c in p) + "\n"


def radiance_scene(folder: Path, kind: str, r: float = 0.02) -> Path:
    # a sphere of radius r and radiance L emits π L 4π r² W; Φ lm is Φ / 179 W on each channel
    radiance = FLUX / WHTEFFICACY / (4 * math.pi**2 * r**2)
    from lumijax.scene import internal_transmissivity

    if kind == "open":  # the reference for the opening alone: no pane at all
        pane = ""
    elif kind == "glass":
        tn = float(internal_transmissivity(GLASS_TN))
        pane = f"void glass pane\n0\n0\n3 {tn:.6f} {tn:.6f} {tn:.6f}\n"
    else:
        c = OPAL_RHO + OPAL_TAU
        pane = f"void trans pane\n0\n0\n7 {c:g} {c:g} {c:g} 0 0 {OPAL_TAU / c:.6f} 0\n"
    seen = set()
    polys = []
    for i, (o, u, v) in enumerate(_rects()):
        key = (tuple(o), tuple(sorted([tuple(u), tuple(v)])))
        if key in seen:  # plastic is two-sided: one polygon per partition piece
            continue
        seen.add(key)
        polys.append(_polygon("grey", f"s{i}", o, u, v))
    text = (f"void plastic grey\n0\n0\n5 {RHO} {RHO} {RHO} 0 0\n"
            f"void light bulb\n0\n0\n3 {radiance:.6g} {radiance:.6g} {radiance:.6g}\n"
            f"bulb sphere lamp\n0\n0\n4 {LAMP[0]} {LAMP[1]} {LAMP[2]} {r}\n"
            + pane + "".join(polys) + (_polygon("pane", "opening", *OPENING) if pane else ""))
    path = folder / f"{kind}.rad"
    path.write_text(text, encoding="utf-8")
    return path


def radiance_lux(folder: Path, scene: Path, points, normals, params) -> tuple[np.ndarray, float]:
    import pyradiance as pr

    t0 = time.perf_counter()
    octree = folder / (scene.stem + ".oct")
    octree.write_bytes(pr.oconv(str(scene)))
    rays = "".join(f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f} {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}\n"
                   for p, n in zip(points, normals, strict=True))
    out = pr.rtrace(rays.encode(), str(octree), irradiance=True, header=False,
                    params=list(params))
    rgb = np.array([[float(x) for x in line.split()] for line in out.decode().splitlines()
                    if line.strip()])
    return WHTEFFICACY * (0.265 * rgb[:, 0] + 0.670 * rgb[:, 1] + 0.065 * rgb[:, 2]), \
        time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarser patches, fewer rays")
    ap.add_argument("--out", type=Path, default=HERE / "RESULTS.md")
    ap.add_argument("--cases", nargs="+", default=["glass", "opal", "open"],
                    choices=["glass", "opal", "open"],
                    help="open: the opening without a pane, to tell the pane's error from the "
                         "opening's")
    args = ap.parse_args(argv)
    try:
        import pyradiance
    except ImportError:
        print("pyradiance is not installed: nothing to compare against")
        return 1
    patch_size, gather = (0.3, 2048) if args.quick else (0.25, 4096)
    direct = ["-ab", "0", "-dj", "0", "-ds", "0.02", "-dt", "0", "-dc", "1"]
    amb = (["-ab", "5", "-aa", "0.1", "-ar", "256", "-ad", "1024", "-as", "256", "-lw", "1e-4"]
           if args.quick else
           ["-ab", "7", "-aa", "0.08", "-ar", "256", "-ad", "2048", "-as", "512", "-lw", "1e-4"])
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for kind in args.cases:
            path = lumijax_study(folder, kind, patch_size, gather)
            t0 = time.perf_counter()
            res = lumijax.compute(lumijax.load_study(path))
            t_lj = time.perf_counter() - t0
            t0 = time.perf_counter()
            res_d = lumijax.compute(lumijax.load_study(path), indirect=False)
            t_lj_d = time.perf_counter() - t0
            scene = radiance_scene(folder, kind)
            pts = np.concatenate([res.grids[g].points for g in ("floor", "wall")])
            nrm = np.concatenate([res.grids[g].normals for g in ("floor", "wall")])
            rad_d, t_rd = radiance_lux(folder, scene, pts, nrm, direct)
            rad_t, t_rt = radiance_lux(folder, scene, pts, nrm, amb + direct[2:])
            n_floor = len(res.grids["floor"].points)
            for label, lj, rad, times in (
                ("direct (-ab 0)", np.concatenate([res_d.grids[g].illuminance_lux
                                                   for g in ("floor", "wall")]), rad_d,
                 (t_lj_d, t_rd)),
                (f"total (-ab {amb[1]})", np.concatenate([res.grids[g].illuminance_lux
                                                          for g in ("floor", "wall")]), rad_t,
                 (t_lj, t_rt)),
            ):
                for gname, sl in (("floor", slice(0, n_floor)), ("wall", slice(n_floor, None))):
                    a, b = lj[sl], rad[sl]
                    if b.max() <= 0:
                        rows.append((kind, gname, label, f"{a.mean():.3f}", f"{b.mean():.3f}",
                                     "— (no light)", ""))
                        continue
                    rel = a / b - 1
                    rows.append((kind, gname, label, f"{a.mean():.3f}", f"{b.mean():.3f}",
                                 f"mean {100 * (a.mean() / b.mean() - 1):+.2f} %, max "
                                 f"{100 * np.abs(rel).max():.2f} %",
                                 f"{times[0]:.1f} / {times[1]:.1f}" if gname == "floor" else ""))
            rows.append((kind, "", f"{res.lighting.coarse.patches.n} patches", "", "", "", ""))
    lines = [
        "# Clear glass and an opal diffuser: lumijax against Radiance",
        "",
        f"`python studies/materials/compare_radiance.py{' --quick' if args.quick else ''}` "
        f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}); pyradiance "
        f"{pyradiance.__version__}; lumijax patch_size {patch_size} m, gather_rays {gather}; "
        f"Radiance direct `{' '.join(direct)}`, total `{' '.join(amb + direct[2:])}`.",
        "The scene is in the script's docstring. Times (s) are wall time on the shared, "
        "contended 2-core machine (other sessions were running): indicative, not benchmarks; "
        "lumijax's include JIT compilation and the form factors (no cache).",
        "",
        "| pane | grid | light | lumijax mean lx | Radiance mean lx | difference | time lumijax / "
        "Radiance (s) |",
        "|---|---|---|---|---|---|---|",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
