"""Calibration with noise (studies/design/README.md): planted light-loss factors (network a
0.8, b 1.0) and wall reflectance (0.62) of the tests' box room recovered from "measurements"
computed by the full pipeline at the planted values, with relative Gaussian noise of 1 % and
3 % on every reading, five noise draws each. Prints the recovered values, their stated
uncertainty (Gauss–Newton) and the error in units of it.

Run: ``python studies/design/calibrate.py``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import lumijax  # noqa: E402
from lumijax.optimise import calibrate  # noqa: E402
from tests.helpers import box_room  # noqa: E402

SOLVER = ("target_patches = 150\ngather_rays = 64\nspectral_samples = 0\ncache = false\n"
          'precision = "float64"')
TRUTH = {"a": 0.8, "b": 1.0, "wall": 0.62}


def main():
    d = Path(tempfile.mkdtemp())
    (d / "model.toml").write_text(box_room(SOLVER, grid="nu = 12\nnv = 9"), "utf-8")
    (d / "truth.toml").write_text(
        box_room(SOLVER, grid="nu = 12\nnv = 9").replace("reflectance = 0.5", "reflectance = 0.62")
        .replace('network = "a"\n', 'network = "a"\nmaintenance_factor = 0.8\n'), "utf-8")
    study = lumijax.load_study(d / "model.toml")
    results = lumijax.compute(study)
    g = lumijax.compute(lumijax.load_study(d / "truth.toml"))["floor"]
    print("| noise | draw | LLF a (σ) | LLF b (σ) | ρ wall (σ) | worst error / σ | "
          "RMS residual before → after |")
    print("|---|---|---|---|---|---|---|")
    for noise in (0.0, 0.01, 0.03):
        for seed in range(5 if noise else 1):
            lux = g.illuminance_lux * (1 + noise * np.random.default_rng(seed).standard_normal(
                len(g.points)))
            rows = "\n".join(",".join(repr(float(v)) for v in (*p, *n, e))
                             for p, n, e in zip(g.points, g.normals, lux, strict=True))
            csv = d / f"m{seed}.csv"
            csv.write_text("x,y,z,nx,ny,nz,lux\n" + rows + "\n", encoding="utf-8")
            c = calibrate(study, results, csv)
            vals = [(c.llf["a"], c.llf_sigma["a"], "a"), (c.llf["b"], c.llf_sigma["b"], "b"),
                    (c.reflectance["wall"], c.reflectance_sigma["wall"], "wall")]
            worst = max(abs(v - TRUTH[k]) / s if s > 0 else 0.0 for v, s, k in vals)
            cells = " | ".join(f"{v:.4f} ({s:.4f})" for v, s, _ in vals)
            print(f"| {noise:.0%} | {seed} | {cells} | {worst:.2f} | "
                  f"{c.rms_before:.4f} → {c.rms_after:.4f} |")


if __name__ == "__main__":
    main()
