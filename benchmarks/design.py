"""Constrained design benchmark (docs/optimise.md, "Design to a standard"): the least power
meeting each grid's Eavg floor (its target, else 60 % of the start's average) and a U0 floor
(80 % of the start's) on the bundled demo study (``lumijax demo``'s courtyard corner), over
the dimmers alone and over dimmers + aims (±5°).

    python benchmarks/design.py [--quick] [--study PATH] [--aims] [--profile]
        [--method auto|slsqp|augmented_lagrangian] [--courtyard BAYS]

Prints: variables, constrained steps (SLSQP), function evaluations, wall time of the design
step (after the study's compute; its first call includes compilation, so the same design is
timed again), the largest exact constraint violation at the end, the verdict and the objective
before → after. Goal: dimmer-only designs under 2 s, aims under 5 minutes on this machine.
``--quick`` runs the optimiser tests' small facade instead (a smoke run, numbers not for the
record). ``--profile`` prints cProfile's top functions (cumulative) of each first design call.
``--method`` picks the constrained method (default ``auto``: SLSQP up to 1,000 free variables,
the augmented Lagrangian above; docs/optimise.md). ``--courtyard BAYS`` runs a four-facade
courtyard of BAYS bays a facade instead (``studies/courtyard/make_courtyard.py``'s full study
with fewer bays, one level of patches, written to a temporary folder): 40 is the full
``configs/courtyard.toml`` (3,000 luminaires), 10 a mid-size one (776 luminaires).

Where the dimmer-only design's first call went (demo, 10 networks, 21 constraints: the 12
here and the study's own grid limits; empty compilation cache — this script turns JAX's
persistent cache on only if ``JAX_COMPILATION_CACHE_DIR`` is set): before the constraints were
batched and the solve's programs fused, 48 XLA compilations, 7.6 s of a 10.4 s call (each
constraint's margin, its Jacobian, the objective, the exact values apart; the exact check op by
op; the glare model's per-source terms, which ``Results.at`` computed though nothing read them).
Now 2 programs and one copy kernel (``_constrained._evaluate``: f, ∇f, the margins, their
Jacobian and the exact values; ``light_report``: the check of the lit design), the same 14
steps and optimum (to 1e-15 relative): first call 0.85 s, again 0.03 s (contended, load 4-8
on 2 cores; docs/optimise.md, which also gives the cost of the demo's own GR ceilings: the glare
model's per-source terms compiled once for their superposition).

Where the aims design's time went (demo, 230 re-aimed luminaires, 12 constraints, contended,
docs/optimise.md): the Jacobian of the margins by ``vmap`` over reverse passes cost 23× the
margins (the pair kernel's pull-back and the Krylov adjoint under ``vmap``); by the aim model's
structured pull-back (``AimLight.linearise``) 2.4×. Compilation of the aim model (its pair
kernels, tangents and pull-back) is a fixed cost of the first call.
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import lumijax
from lumijax.cli import default_study_path
from lumijax.optimise import optimise


def constraints_for(results, start_stats):
    out = []
    for name, g in results.grids.items():
        s = start_stats[name]
        floor = g.target_lux if g.target_lux is not None else 0.6 * s["avg"]
        if floor > 0:
            out.append({"criterion": "avg", "grid": name, "min": float(floor)})
        if s["u0"] > 0:
            out.append({"criterion": "u0", "grid": name, "min": round(0.8 * s["u0"], 4)})
    return out


def courtyard_study(bays: int) -> Path:
    """The full courtyard study (``make_courtyard.FULL``) with ``bays`` bays a facade, written
    to a temporary folder: 40 bays is ``configs/courtyard.toml``'s scene (there: two levels of
    patches); fewer bays run on one level (operator_patches off; 75 patches asked a bay),
    with the floods scaled with the facades' length."""
    import dataclasses
    import sys
    import tempfile

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "studies" / "courtyard"))
    import make_courtyard as mc

    c = mc.FULL
    if bays != c.bays:
        c = dataclasses.replace(
            c, name=f"Courtyard, 4 facades x {bays} bays", bays=bays,
            floods_per_facade=max(2, round(c.floods_per_facade * bays / c.bays)),
            target_patches=75 * bays * len(c.facades), operator_patches=None, spectral_samples=6,
            gather_rays=128)
    d = Path(tempfile.mkdtemp(prefix=f"courtyard{bays}_"))
    return mc.write_study(c, d / "study.toml", d / "courtyard", "benchmark")


def _profiled(fn, enabled):
    if not enabled:
        return fn()
    import cProfile
    import pstats

    prof = cProfile.Profile()
    out = prof.runcall(fn)
    pstats.Stats(prof).sort_stats("cumulative").print_stats(15)
    return out


def run(study_path: Path, *, aims: bool, quick: bool, profile: bool = False,
        again: bool = True, method: str = "auto"):
    study = lumijax.load_study(study_path)
    t = time.perf_counter()
    results = lumijax.compute(study)
    t_compute = time.perf_counter() - t
    start = {n: g.stats for n, g in results.grids.items()}
    cons = constraints_for(results, start)
    variables = ["dimmers", "aims"] if aims else ["dimmers"]
    kw = dict(objective="power", constraints=cons, variables=variables, method=method)
    if aims:
        kw.update(tilt_range_deg=(-5.0, 5.0), pan_range_deg=(-5.0, 5.0))
    t = time.perf_counter()
    opt = _profiled(lambda: optimise(study, results, **kw), profile)
    t_design = time.perf_counter() - t
    t_again = float("nan")
    if again:
        t = time.perf_counter()  # the same design again: what a designer's next try costs
        optimise(study, results, **kw)
        t_again = time.perf_counter() - t
    rec = opt.constrained
    worst = max([max(0.0, -r["margin"]) for r in rec["constraints"]], default=0.0)
    # free variables: a dimmer per network, a tilt and a pan per re-aimed luminaire
    n_var = len(study.scene.networks) + 2 * len(opt.aimed)
    return dict(variables="+".join(variables), n_constraints=len(cons), method=rec["method"],
                n_var=n_var,
                steps=rec["iterations"], evaluations=rec["evaluations"],
                compute_s=t_compute, design_s=t_design, again_s=t_again, violation=worst,
                verdict=rec["verdict"], before=rec["objective_start"],
                after=rec["objective_end"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--aims", action="store_true", help="also dimmers + aims")
    ap.add_argument("--profile", action="store_true", help="cProfile the first design calls")
    ap.add_argument("--only-aims", action="store_true", help="with --aims: skip dimmers only")
    ap.add_argument("--once", action="store_true", help="do not time the design a second time")
    ap.add_argument("--study", type=Path, default=default_study_path())
    ap.add_argument("--method", default="auto",
                    choices=["auto", "slsqp", "trust-constr", "augmented_lagrangian"])
    ap.add_argument("--courtyard", type=int, default=None, metavar="BAYS",
                    help="a four-facade courtyard of BAYS bays a facade (40: the full one)")
    args = ap.parse_args()
    if args.courtyard is not None:
        args.study = courtyard_study(args.courtyard)
    if args.quick:  # the optimiser tests' small facade (4 spots, 2 networks), for a smoke run
        import sys
        import tempfile

        root = Path(__file__).resolve().parents[1]
        sys.path[:0] = [str(root), str(root / "tests")]  # conftest imports ``helpers``
        from lumijax.photometry import spot, write_ies
        from tests.optimise.conftest import facade_text

        d = Path(tempfile.mkdtemp())
        write_ies(spot(3000, beam_deg=30), d / "spot.ies")
        args.study = d / "facade.toml"
        args.study.write_text(facade_text(optimise=None), encoding="utf-8")
    print(f"# constrained design: {args.study} ({platform.processor() or platform.machine()})")
    print("| variables | free | constraints | method | steps | evaluations | compute (s) | "
          "design, first (s) | design, again (s) | worst violation | verdict | power (W) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for aims in ([True] if args.only_aims else [False, True] if args.aims else [False]):
        r = run(args.study, aims=aims, quick=args.quick, profile=args.profile,
                again=not args.once, method=args.method)
        print(f"| {r['variables']} | {r['n_var']} | {r['n_constraints']} | {r['method']} "
              f"| {r['steps']} | {r['evaluations']} "
              f"| {r['compute_s']:.1f} | {r['design_s']:.2f} | {r['again_s']:.2f} | "
              f"{r['violation']:.2e} | "
              f"{r['verdict']} | {r['before']:.1f} → {r['after']:.1f} |")
    print("\ngoal: dimmer-only design < 2 s; aims < 5 min (timings on a shared machine are "
          "contended: run alone)")


if __name__ == "__main__":
    main()
