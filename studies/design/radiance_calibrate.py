"""Calibration against an independent engine (studies/design/README.md): a furnished room (the
validation study's 5 × 4 × 3 m room with a table, studies/validation/run_validation.py) rendered
by Radiance (``rtrace -I``) with planted values — walls ρ = 0.62, table ρ = 0.30, the lamp at a
light-loss factor of 0.85 — and its "measurements" at the workplane and floor grids fitted by
``lumijax.optimise.calibrate`` from a model that starts at ρ = 0.5 for both materials and a
light-loss factor of 1. Prints the recovered values, their stated uncertainty (Gauss–Newton),
the error against the planted values, and the residuals before and after.

    python studies/design/radiance_calibrate.py [--quick]

Needs pyradiance (``pip install '.[benchmark]'``). The recovered error is the sum of noise-free
model error (lumijax's radiosity against Radiance's Monte Carlo, a few % in this room:
studies/validation/RESULTS.md) and Radiance's own sampling noise — not a synthetic round trip.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

import lumijax  # noqa: E402
from lumijax.optimise import calibrate  # noqa: E402
from studies.validation.run_validation import (  # noqa: E402
    LAMP,
    LAMP_FLUX,
    ROOM,
    TABLE,
    WHTEFFICACY,
    WP_Z,
    _rad_box,
    box,
    radiance_illuminance,
    table,
    write_study,
)

TRUTH = {"walls": 0.62, "wood": 0.30, "n": 0.85}
START = 0.5


def model_study(folder: Path, spacing: float, patch_size: float, gather: int) -> Path:
    x, y, _ = ROOM
    plane = {"kind": "plane", "u": [x - 1.0, 0, 0], "v": [0, y - 1.0, 0], "spacing": spacing}
    return write_study(folder, "model", "".join([
        table("[study]", name="furnished room, calibrated to Radiance"),
        table("[materials.walls]", reflectance=START),
        table("[materials.wood]", reflectance=START),
        table("[photometry.iso]", kind="isotropic", flux_lm=LAMP_FLUX),
        box([0, 0, 0], ROOM, "inward", "walls", name="room"),
        box(TABLE[0], TABLE[1], "outward", "wood", name="table"),
        table("[[luminaires]]", name="lamp", photometry="iso", position=list(LAMP), network="n"),
        table("[[grids]]", name="workplane", origin=[0.5, 0.5, WP_Z], **plane),
        table("[[grids]]", name="floor", origin=[0.5, 0.5, 0.02], **plane),
        table("[solver]", patch_size=patch_size, gather_rays=gather, spectral_samples=0,
              precision="float64", cache=False)]))


def radiance_truth(folder: Path, sphere_r: float = 0.02) -> Path:
    """The room at the planted values: grey plastic walls and table, the lamp a small sphere
    whose radiance gives LAMP_FLUX × LLF (Φ = π L · 4π r², WHTEFFICACY lm/W)."""
    radiance = LAMP_FLUX * TRUTH["n"] / WHTEFFICACY / (4 * math.pi**2 * sphere_r**2)
    w, t = TRUTH["walls"], TRUTH["wood"]
    text = (f"void plastic walls\n0\n0\n5 {w} {w} {w} 0 0\n"
            f"void plastic wood\n0\n0\n5 {t} {t} {t} 0 0\n"
            f"void light lamp\n0\n0\n3 {radiance:.6g} {radiance:.6g} {radiance:.6g}\n"
            f"lamp sphere bulb\n0\n0\n4 {LAMP[0]} {LAMP[1]} {LAMP[2]} {sphere_r}\n"
            + _rad_box("room", (0, 0, 0), ROOM, inward=True).replace("grey polygon",
                                                                      "walls polygon")
            + _rad_box("table", *TABLE, inward=False).replace("grey polygon", "wood polygon"))
    path = folder / "truth.rad"
    path.write_text(text)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarser grids, fewer bounces")
    args = ap.parse_args()
    d = Path(tempfile.mkdtemp(prefix="radiance-calibrate-"))
    spacing = 0.5
    path = model_study(d, spacing, 0.3 if args.quick else 0.2, 512 if args.quick else 1024)
    study = lumijax.load_study(path)
    t = time.perf_counter()
    results = lumijax.compute(study)
    t_model = time.perf_counter() - t
    names = ("workplane", "floor")
    pts = np.concatenate([results.grids[n].points for n in names])
    nrm = np.concatenate([results.grids[n].normals for n in names])
    amb = (["-ab", "4", "-aa", "0.15", "-ar", "128", "-ad", "512", "-as", "128"] if args.quick
           else ["-ab", "6", "-aa", "0.1", "-ar", "256", "-ad", "1024", "-as", "256"])
    params = amb + ["-lw", "1e-4", "-dj", "0", "-ds", "0.02", "-dt", "0", "-dc", "1"]
    lux, t_rad = radiance_illuminance(d, radiance_truth(d), pts, nrm, params)
    csv = d / "measured.csv"
    csv.write_text("x,y,z,nx,ny,nz,lux\n" + "\n".join(
        ",".join(repr(float(v)) for v in (*p, *n, e)) for p, n, e in zip(pts, nrm, lux,
                                                                          strict=True))
        + "\n", encoding="utf-8")
    t = time.perf_counter()
    c = calibrate(study, results, csv)
    t_fit = time.perf_counter() - t
    print(f"# Radiance ({' '.join(params)}): {len(lux)} readings, {t_rad:.1f} s; lumijax "
          f"model {t_model:.1f} s, fit {t_fit:.1f} s (contended)")
    print("| parameter | planted (Radiance) | start | recovered (σ) | error | error / σ |")
    print("|---|---|---|---|---|---|")
    rows = [("walls ρ", TRUTH["walls"], c.reflectance["walls"], c.reflectance_sigma["walls"]),
            ("table ρ", TRUTH["wood"], c.reflectance["wood"], c.reflectance_sigma["wood"]),
            ("lamp LLF", TRUTH["n"], c.llf["n"], c.llf_sigma["n"])]
    for label, truth, v, s in rows:
        start = 1.0 if label == "lamp LLF" else START
        print(f"| {label} | {truth:.3f} | {start:.2f} | {v:.4f} ({s:.4f}) | "
              f"{v - truth:+.4f} ({100 * (v / truth - 1):+.1f} %) | "
              f"{abs(v - truth) / s if s > 0 else float('inf'):.1f} |")
    print(f"RMS relative residual: {c.rms_before:.4f} → {c.rms_after:.4f}")


if __name__ == "__main__":
    main()
