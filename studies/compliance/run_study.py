"""Compliance validation (docs/compliance.md): sensors against Radiance, the verdict by hand.

    python studies/compliance/run_study.py            # writes studies/compliance/RESULTS.md
    python studies/compliance/run_study.py --quick    # fewer points, lighter Radiance settings

1. The furnished room of studies/validation (5 × 4 × 3 m grey room ρ 0.5, a table, a 5000 lm
   isotropic lamp): cylindrical, semi-cylindrical (facing +x) and hemispherical sensors at
   1.2 m, lumijax against Radiance ``rtrace -I``. Radiance has planar sensors only, so each
   sensor is its surface's mean of planar irradiance: Ez the mean over 24 vertical planes
   facing every 15°, the semi-cylinder over the 12 facing its half, the dome an area-weighted
   mean over 6 × 24 (θ, φ) normals — the definition the sensors' formulas come from.
   Direct (-ab 0) and total; their difference is the inter-reflected part.
2. The office of tests/compliance and the bundled courtyard with a [compliance] table: the
   verdict as lumijax prints it, and each number of the office's recomputed by hand from the
   per-network grid values (maintenance, means, the power curve, LENI).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path.insert(0, str(REPO / "studies" / "validation"))
sys.path.insert(0, str(REPO / "tests" / "compliance"))
sys.path.insert(0, str(REPO / "benchmarks"))

import run_validation as rv  # noqa: E402  (the furnished room and its Radiance twin)

import lumijax  # noqa: E402


def sensor_points(quick: bool) -> np.ndarray:
    xs = [1.0, 2.5, 4.0] if quick else [0.8, 1.8, 2.8, 3.8, 4.4]
    ys = [1.0, 3.0] if quick else [0.8, 2.0, 3.2]
    return np.array([[x, y, 1.2] for x in xs for y in ys])


def room_with_sensors(folder: Path, pts: np.ndarray, quick: bool) -> Path:
    path = rv.room_study(folder, patch_size=0.3 if quick else 0.15,
                         gather_rays=1024 if quick else 4096, spacing=0.5)
    plist = "[" + ", ".join(f"[{p[0]:g}, {p[1]:g}, {p[2]:g}]" for p in pts) + "]"
    text = path.read_text() + "".join(
        f'\n[[grids]]\nname = "{k}"\nkind = "sensor"\nsensor = "{k}"\npoints = {plist}\n'
        + ('facing = [1, 0, 0]\n' if k == "semicylindrical" else "")
        for k in ("cylindrical", "semicylindrical", "hemispherical"))
    path.write_text(text)
    return path


def sensor_normals():
    """Per sensor kind: unit normals and weights whose weighted mean of planar irradiance is
    the sensor's reading."""
    az = (np.arange(24) + 0.5) * 2 * np.pi / 24
    cyl = np.stack([np.cos(az), np.sin(az), 0 * az], 1)
    half = np.abs(((az + np.pi) % (2 * np.pi)) - np.pi) < np.pi / 2
    th = (np.arange(6) + 0.5) * (np.pi / 2) / 6
    tt, pp = np.meshgrid(th, az, indexing="ij")
    dome = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1)
    w = np.sin(tt).ravel()
    return {"cylindrical": (cyl, np.full(24, 1 / 24)),
            "semicylindrical": (cyl[half], np.full(int(half.sum()), 1 / half.sum())),
            "hemispherical": (dome.reshape(-1, 3), w / w.sum())}


def radiance_sensors(folder: Path, pts, params) -> dict:
    scene = rv.radiance_scene(folder)
    out = {}
    for kind, (normals, w) in sensor_normals().items():
        p = np.repeat(pts, len(normals), axis=0)
        n = np.tile(normals, (len(pts), 1))
        lux, _ = rv.radiance_illuminance(folder, scene, p, n, params)
        out[kind] = lux.reshape(len(pts), len(normals)) @ w
    return out


def part1(out: Path, quick: bool, few_points: bool = False) -> list[str]:
    pts = sensor_points(quick or few_points)
    folder = out / "room"
    folder.mkdir(parents=True, exist_ok=True)
    path = room_with_sensors(folder, pts, quick)
    t0 = time.perf_counter()
    study = lumijax.load_study(path)
    res = lumijax.compute(study)
    t_lj = time.perf_counter() - t0
    direct = ["-ab", "0", "-dj", "0", "-ds", "0.02", "-dt", "0", "-dc", "1"]
    amb = (["-ab", "5", "-aa", "0.1", "-ar", "256", "-ad", "1024", "-as", "256", "-lw", "1e-4"]
           if quick else
           ["-ab", "7", "-aa", "0.08", "-ar", "256", "-ad", "2048", "-as", "512", "-lw", "1e-4"])
    t0 = time.perf_counter()
    rad_d = radiance_sensors(folder, pts, direct)
    rad_t = radiance_sensors(folder, pts, amb + direct[2:])
    t_rad = time.perf_counter() - t0
    lines = ["| sensor | part | Radiance mean (lx) | lumijax mean (lx) | mean | RMS | max |",
             "|---|---|---|---|---|---|---|"]
    for kind in ("cylindrical", "semicylindrical", "hemispherical"):
        g = res.grids[kind]
        lj_t = g.illuminance_lux
        lj_d = g.at_dimmers_direct(g.dimmers)
        for label, lj, rad in (("direct", lj_d, rad_d[kind]), ("total", lj_t, rad_t[kind]),
                               ("inter-reflected", lj_t - lj_d, rad_t[kind] - rad_d[kind])):
            rel = lj / rad - 1
            lines.append(f"| {kind} | {label} | {rad.mean():.2f} | {lj.mean():.2f} | "
                         f"{100 * (lj.mean() / rad.mean() - 1):+.2f} % | "
                         f"{100 * math.sqrt(float(np.mean(rel**2))):.2f} % | "
                         f"{100 * float(np.max(np.abs(rel))):.2f} % |")
    lines += ["", f"{len(pts)} sensors at 1.2 m; lumijax {res.lighting.coarse.patches.n} "
              f"patches, sensor gather {2 * study.config.solver.gather_rays} rays, "
              f"{t_lj:.1f} s (load + compute); Radiance rtrace -I "
              f"{' '.join(amb + direct[2:])}, {t_rad:.1f} s for all sensor planes."]
    return lines


def part2(out: Path) -> list[str]:
    from conftest import OFFICE

    path = out / "office.toml"
    path.write_text(OFFICE)
    study = lumijax.load_study(path)
    res = lumijax.compute(study)
    comp = res.compliance
    lines = ["### The office (tests/compliance/conftest.py)", "", "```", comp.table(), "```", ""]
    desk = res.grids["desk"].by_network_lux
    mf = np.array([0.9 * 0.87, 0.7])
    d = np.asarray(res.design.dimmers)
    w = d * mf
    em = (w @ desk).mean()
    p = 25.0 + 0.5 + 24.5 * (0.45 + (0.6 - 0.5) / 0.5 * 0.55)
    leni = p * (2250 * 0.9 + 250 * 0.9) / 1000 / 6.0
    ez = (w @ res.grids["desk_ez"].by_network_lux).mean()

    def row(area, q, when=""):
        return next(r for r in comp.rows if r["area"] == area and r["quantity"] == q
                    and r["when"] == when)

    checks = [("office Ēm (lx)", "Σ αₖ MFₖ Eₖ averaged over the desk grid", em,
               row("office", "Em")["value"]),
              ("office Ēz (lx)", "the same over the cylindrical grid", ez,
               row("office", "Ez")["value"]),
              ("modelling", "Ēz / Ēm", ez / em, row("office", "modelling Ez/Eh")["value"]),
              ("power (W)", "25 + (0.5 + 24.5 × 0.56) (b's table at 0.6, standby 0.5 W)", p,
               row("installation", "power density")["value"] * 6.0),
              ("LENI (kWh/(m²·a))", "P × (2250 × 0.9 + 250 × 0.9) / 1000 / 6 m²", leni,
               row("installation", "LENI")["value"])]
    lines += ["| quantity | by hand | hand value | lumijax |", "|---|---|---|---|"]
    lines += [f"| {a} | {b} | {c:.4g} | {v:.4g} |" for a, b, c, v in checks]
    return lines


def part3() -> list[str]:
    from compliance import COURTYARD_COMPLIANCE

    src = REPO / "lumijax" / "data" / "studies" / "default" / "study.toml"
    path = src.parent / "_compliance_study.toml"
    path.write_text(src.read_text().replace("spectral_samples = 6", "spectral_samples = 0")
                    + COURTYARD_COMPLIANCE)
    try:
        study = lumijax.load_study(path)
        res = lumijax.compute(study)
    finally:
        path.unlink(missing_ok=True)
    return ["### The bundled courtyard (photometric solve) with benchmarks/compliance.py's table",
            "", "```", res.compliance.table(), "```"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--few-points", action="store_true",
                    help="the quick run's 6 sensors at the full settings (-ab 7, 0.15 m patches)")
    ap.add_argument("--out", type=Path, default=HERE / "out")
    ap.add_argument("--skip", nargs="*", default=[], choices=["radiance", "office", "courtyard"])
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    text = ["# Compliance validation: results", "",
            f"`python studies/compliance/run_study.py{' --quick' if args.quick else ''}`, "
            f"{time.strftime('%Y-%m-%d')}.", ""]
    if "radiance" not in args.skip:
        text += ["## 1. Sensors against Radiance", ""] + part1(args.out, args.quick,
                                                                args.few_points) + [""]
    if "office" not in args.skip:
        text += ["## 2. Verdicts", ""] + part2(args.out) + [""]
    if "courtyard" not in args.skip:
        text += part3() + [""]
    name = "RESULTS.md" if not args.skip else ("RESULTS-radiance-full.md" if args.few_points
                                                 else f"RESULTS-{'-'.join(sorted(args.skip))}.md")
    (HERE / name).write_text("\n".join(text))
    print("\n".join(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
