"""Optimiser benchmark: a dimmer fit (18 networks × 10⁴ points) and aim fits (100 and 1,000
luminaires on a generated facade), each to a planted target.

The facade: a 10 m wall with ground in front, 30° spots every 2 m, 1 m out, aimed up the wall
(tilt 155°), on 18 networks; a 20 × 500 grid on the wall (10⁴ points). With 100 spots each
beam (about 1.5 m wide, 4.5 m tall) covers about 4 × 9 grid points of its own, so every aim is
seen and the planted aims are identifiable; with 1,000 spots on the same 10⁴ points (grid
columns 4 m apart, wider than a beam) they are not, and only the cost per step is measured.

    python benchmarks/optimise.py [--quick]

Prints a table: size, cold time (first call: compiles), warm time (the same fit again),
iterations, time per iteration, the error of the recovered variables, and the ratio to the
1 s goal of the dimmer fit. "After the precompute" = the per-network solutions (dimmers) or
the lighting solution and the aim model's pairs (aims) exist; their cost is printed apart.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import textwrap
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import lumijax  # noqa: E402
from lumijax.optimise import DimmerLight, Objective, minimise  # noqa: E402
from lumijax.optimise._models import build_aim_light  # noqa: E402
from lumijax.optimise._optimise import _residuals  # noqa: E402
from lumijax.optimise._targets import GridGoal  # noqa: E402


def dimmer_fit(solver: str, k: int = 18, n: int = 10_000):
    rng = np.random.default_rng(0)
    side = int(np.sqrt(n))
    u, v = np.meshgrid(np.linspace(0, 1, side), np.linspace(0, 1, side), indexing="ij")
    centres = rng.uniform(0, 1, (k, 2))
    # each network: a beam on the grid plus a little uniform inter-reflected light (lx)
    total = np.stack([200 * np.exp(-((u - cx) ** 2 + (v - cy) ** 2) / 0.02).ravel() + 5.0
                      for cx, cy in centres])
    truth = rng.uniform(0.2, 0.9, k)
    goal = GridGoal("g", 0, total.shape[1], target=truth @ total, target_kind="target_csv")
    args = (DimmerLight(jnp.asarray(total), None), Objective.build((goal,), np.ones(k)))
    x0, lo, hi = np.full(k, 1.0), np.zeros(k), np.ones(k)
    out = []
    for _ in range(2):
        t = time.perf_counter()
        run = minimise(_residuals, args, x0, lo, hi, solver=solver, max_steps=500,
                       tolerance=1e-10)
        out.append(time.perf_counter() - t)
    return out, run, float(np.max(np.abs(run.x - truth)))


FACADE = """
[solver]
target_patches = {patches}
gather_rays = 64
spectral_samples = 0
cache = false
[materials.stone]
reflectance = 0.5
[photometry.spot]
file = "spot.ies"
[[geometry]]
kind = "rectangle"
origin = [0, 0, 0]
u = [0, 0, 10]
v = [{length}, 0, 0]
material = "stone"
[[geometry]]
kind = "rectangle"
origin = [0, 0, 0]
u = [{length}, 0, 0]
v = [0, 4, 0]
material = "stone"
[[grids]]
name = "facade"
kind = "plane"
origin = [0, 0.01, 0.1]
u = [0, 0, 9.8]
v = [{length}, 0, 0]
nu = 20
nv = {nv}
"""


SPACING = 2.0  # m between spots along the wall
TILT, PAN = 155.0, -90.0  # degrees: up the wall


def facade(n_lum: int, tmp: Path, points: int = 10_000, aims=None, dimmer=None,
           name="start"):
    from lumijax.photometry import spot, write_ies

    write_ies(spot(2000, beam_deg=30), tmp / "spot.ies")
    length = SPACING * n_lum
    text = FACADE.format(length=length, nv=points // 20, patches=2000)
    if dimmer is not None:
        text += "".join(f"[networks.n{k}]\ndimmer = {dimmer}\n" for k in range(18))
    for i in range(n_lum):
        x = SPACING * (i + 0.5)
        t, p = (TILT, PAN) if aims is None else aims[i]
        text += textwrap.dedent(f"""
            [[luminaires]]
            name = "s{i}"
            photometry = "spot"
            network = "n{i % 18}"
            position = [{x}, 1.0, 0.3]
            aim = {{ tilt = {t!r}, pan = {p!r} }}
            """)
    path = tmp / f"{name}{n_lum}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def aim_fit(n_lum: int, tmp: Path, max_steps: int, pipeline_truth: bool):
    """Plant aims ±4° and dimmers 0.8, fit from the config's aims and dimmer 1 (bounds ±8°).
    The target is the full pipeline's light at the planted design (``pipeline_truth``) or the
    aim model's own (1,000 spots: only the cost per step is measured)."""
    rng = np.random.default_rng(1)
    d_tilt, d_pan = rng.uniform(-4, 4, n_lum), rng.uniform(-4, 4, n_lum)
    t = time.perf_counter()
    study = lumijax.load_study(facade(n_lum, tmp))
    results = lumijax.compute(study)
    t_compute = time.perf_counter() - t
    lighting = results.lighting
    span = np.radians(np.full(n_lum, 8.0))
    t = time.perf_counter()
    model = build_aim_light(lighting, list(range(n_lum)), span, span, aims=True, levels=False)
    t_model = time.perf_counter() - t
    pairs = sum(int(p.source.shape[0]) for p in model.pairs)
    k = len(study.scene.networks)
    t0, p0 = np.asarray(model.tilt0), np.asarray(model.pan0)
    x_true = np.concatenate([np.full(k, 0.8), t0 + np.radians(d_tilt), p0 + np.radians(d_pan)])
    if pipeline_truth:
        aims = [(TILT + a, PAN + b) for a, b in zip(d_tilt, d_pan, strict=True)]
        truth = lumijax.compute(lumijax.load_study(
            facade(n_lum, tmp, aims=aims, dimmer=0.8, name="truth")))
        target = truth["facade"].illuminance_lux
    else:
        target = np.asarray(jax.jit(lambda x, m: m(x)[0])(jnp.asarray(x_true), model))
    goal = GridGoal("facade", 0, len(lighting.points), target=target, target_kind="target_csv")
    args = (model, Objective.build((goal,), np.ones(k)))
    x0 = np.concatenate([np.ones(k), t0, p0])
    lo = np.concatenate([np.zeros(k), t0 - span, p0 - span])
    hi = np.concatenate([np.ones(k), t0 + span, p0 + span])
    t = time.perf_counter()
    run = minimise(_residuals, args, x0, lo, hi, solver="lbfgsb", max_steps=max_steps,
                   tolerance=1e-10)
    t_fit = time.perf_counter() - t
    # per-step cost without compilation: a short second run (the compiled f and ∇f are kept)
    t = time.perf_counter()
    run2 = minimise(_residuals, args, x0, lo, hi, solver="lbfgsb", max_steps=10,
                    tolerance=1e-10)
    per_iter = (time.perf_counter() - t) / max(run2.iterations, 1)
    e_fit = np.asarray(jax.jit(lambda x, m: m(x)[0])(jnp.asarray(run.x), model))
    rms = float(np.sqrt(np.mean((e_fit - target) ** 2)) / np.mean(target))
    aim_err = np.degrees(np.max(np.abs(run.x[k:] - x_true[k:])))
    return dict(compute=t_compute, model=t_model, pairs=pairs, fit=t_fit, iters=run.iterations,
                evals=run.evaluations, per_iter=per_iter, aim_err=aim_err, f0=run.history[0],
                f=run.history[-1], rms=rms, dimmer_err=float(np.max(np.abs(run.x[:k] - 0.8))),
                truth="pipeline" if pipeline_truth else "model")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="100 luminaires only")
    ap.add_argument("--max-steps", type=int, default=300)
    ap.add_argument("--max-steps-large", type=int, default=30,
                    help="steps of the 1,000-spot fit (only its cost per step is measured)")
    ap.add_argument("--skip-dimmers", action="store_true")
    a = ap.parse_args()
    print(f"machine: {platform.platform()}, {platform.processor() or 'cpu'}, JAX "
          f"{jax.__version__} {jax.default_backend()}, float64")
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2 cores: contended above 2)")
    print("\n## dimmer fit: 18 networks x 10^4 points, planted target, start at dimmer 1")
    print("| solver | cold (s) | warm (s) | iterations | max dimmer error | warm / 1 s goal |")
    print("|---|---|---|---|---|---|")
    for solver in () if a.skip_dimmers else ("lbfgsb", "levenberg_marquardt", "bfgs",
                                               "projected_gradient"):
        (cold, warm), run, err = dimmer_fit(solver)
        print(f"| {solver} | {cold:.2f} | {warm:.3f} | {run.iterations} | {err:.1e} | "
              f"{warm / 1.0:.3f} |")
    print("\n## aim fit: facade, 30° spots every 2 m aimed up the wall, 18 networks, 10^4 "
          "points, 2,000 patches, planted aims ±4° and dimmers 0.8, bounds ±8°, lbfgsb, with "
          "inter-reflection, study precision float32")
    print("| luminaires | compute (s) | aim model (s) | pairs | target | fit incl. compile (s) | "
          "iterations | evaluations | s / iteration (warm) | max aim error (°) | "
          "max dimmer error | map RMS / mean | f start → end |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    sizes = (100,) if a.quick else (100, 1000)
    with tempfile.TemporaryDirectory() as d:
        for n in sizes:
            r = aim_fit(n, Path(d), a.max_steps if n <= 100 else a.max_steps_large,
                        pipeline_truth=n <= 100)
            print(f"| {n} | {r['compute']:.1f} | {r['model']:.1f} | {r['pairs']:,} | "
                  f"{r['truth']} | {r['fit']:.1f} | {r['iters']} | {r['evals']} | "
                  f"{r['per_iter']:.3f} | {r['aim_err']:.2f} | {r['dimmer_err']:.1e} | "
                  f"{r['rms']:.1e} | {r['f0']:.2e} → {r['f']:.2e} |", flush=True)


if __name__ == "__main__":
    main()
