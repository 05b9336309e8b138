"""Constrained design benchmark (docs/optimise.md, "Design to a standard"): the least power
meeting each grid's Eavg floor (its target, else 60 % of the start's average) and a U0 floor
(80 % of the start's) on the bundled demo study (``lumijax demo``'s courtyard corner), over
the dimmers alone and over dimmers + aims (±5°).

    python benchmarks/design.py [--quick] [--study PATH] [--aims] [--profile]

Prints: variables, constrained steps (SLSQP), function evaluations, wall time of the design
step (after the study's compute; its first call includes compilation, so the same design is
timed again), the largest exact constraint violation at the end, the verdict and the objective
before → after. Goal: dimmer-only designs under 2 s, aims under 5 minutes on this machine.
``--quick`` runs the optimiser tests' small facade instead (a smoke run, numbers not for the
record). ``--profile`` prints cProfile's top functions (cumulative) of each first design call.

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
        again: bool = True):
    study = lumijax.load_study(study_path)
    t = time.perf_counter()
    results = lumijax.compute(study)
    t_compute = time.perf_counter() - t
    start = {n: g.stats for n, g in results.grids.items()}
    cons = constraints_for(results, start)
    variables = ["dimmers", "aims"] if aims else ["dimmers"]
    kw = dict(objective="power", constraints=cons, variables=variables)
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
    return dict(variables="+".join(variables), n_constraints=len(cons),
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
    args = ap.parse_args()
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
    print("| variables | constraints | steps | evaluations | compute (s) | design, first (s) | "
          "design, again (s) | worst violation | verdict | power (W) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for aims in ([True] if args.only_aims else [False, True] if args.aims else [False]):
        r = run(args.study, aims=aims, quick=args.quick, profile=args.profile,
                again=not args.once)
        print(f"| {r['variables']} | {r['n_constraints']} | {r['steps']} | {r['evaluations']} "
              f"| {r['compute_s']:.1f} | {r['design_s']:.2f} | {r['again_s']:.2f} | "
              f"{r['violation']:.2e} | "
              f"{r['verdict']} | {r['before']:.1f} → {r['after']:.1f} |")
    print("\ngoal: dimmer-only design < 2 s; aims < 5 min (timings on a shared machine are "
          "contended: run alone)")


if __name__ == "__main__":
    main()
