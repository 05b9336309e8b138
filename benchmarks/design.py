"""Constrained design benchmark (docs/optimise.md, "Design to a standard"): the least power
meeting each grid's Eavg floor (its target, else 60 % of the start's average) and a U0 floor
(80 % of the start's) on the bundled demo study (``lumijax demo``'s courtyard corner), over
the dimmers alone and over dimmers + aims (±5°).

    python benchmarks/design.py [--quick] [--study PATH] [--aims] [--profile]
        [--method auto|slsqp|augmented_lagrangian] [--courtyard BAYS [--transport sampled]]
        [--gr-max GR] [--check-prices K] [--table]

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
``configs/courtyard.toml`` (3,000 luminaires), 10 a mid-size one (776 luminaires); with
``--transport sampled`` on one level of patches and the ray-sampled operator. ``--gr-max``
adds every observer's GR ceiling; ``--table`` prints each constraint's start, bound, achieved
value and price; ``--check-prices K`` re-solves with each of the K dearest active grid
constraints tightened by 2 % and prints the first-order price beside the re-solved cost.

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
import re
import time
from pathlib import Path

import lumijax
from lumijax.cli import default_study_path
from lumijax.optimise import optimise


def constraints_for(results, start_stats, gr_max: float | None = None):
    """Each grid's Eavg floor (its target, else 60 % of the start's average) and U0 floor (80 %
    of the start's), and with ``gr_max`` every observer's GR ceiling (CIE 112)."""
    out = []
    for name, g in results.grids.items():
        s = start_stats[name]
        floor = g.target_lux if g.target_lux is not None else 0.6 * s["avg"]
        if floor > 0:
            out.append({"criterion": "avg", "grid": name, "min": float(floor)})
        if s["u0"] > 0:
            out.append({"criterion": "u0", "grid": name, "min": round(0.8 * s["u0"], 4)})
    if gr_max is not None:
        out.append({"criterion": "gr", "max": float(gr_max)})
    return out


def check_prices(study, results, kw, rec, *, top: int = 3, fraction: float = 0.02) -> list[dict]:
    """Each of the ``top`` dearest active grid constraints' price against a re-solve: its bound
    tightened by ``fraction`` of itself, the least power found again; the first-order
    estimate is ``price_per_unit × Δbound``. A grid's own target (``grids[k].target_lux``) is
    tightened through the benchmark's Eavg floor of the same grid and bound."""
    cons = kw["constraints"]
    rows = sorted((r for r in rec["constraints"] if r["active"]
                   and r.get("price_per_unit") is not None and r["criterion"] in ("avg", "u0")),
                  key=lambda r: -abs(r["price_per_unit"] * r["bound"]))
    out, seen = [], set()
    for r in rows:
        side = "min" if r["relation"] in (">=", "≥") else "max"
        m = re.fullmatch(r"optimise\.constraints\[(\d+)\]\.(min|max)", r["key"])
        grid = re.match(r"grid '(.+)'", r["label"])
        i = int(m[1]) if m else next(
            (k for k, c in enumerate(cons) if grid and c.get("grid") == grid[1]
             and c["criterion"] == r["criterion"] and c.get(side) == r["bound"]), None)
        if i is None or i in seen or len(out) == top:
            continue
        seen.add(i)
        step = fraction * abs(r["bound"])
        delta = step if side == "min" else -step
        tight = [dict(c) for c in cons]
        tight[i][side] = float(r["bound"]) + delta
        if r["key"].startswith("grids["):  # the grid's own target must move with it
            tight.append({"criterion": "avg", "grid": grid[1], side: float(r["bound"]) + delta})
        t = time.perf_counter()
        again = optimise(study, results, **{**kw, "constraints": tight}).constrained
        out.append(dict(label=r["label"], bound=float(r["bound"]), new=float(r["bound"]) + delta,
                        predicted=float(r["price_per_unit"]) * delta,
                        resolved=again["objective_end"] - rec["objective_end"],
                        verdict=again["verdict"], seconds=time.perf_counter() - t))
    return out


def courtyard_study(bays: int, transport: str = "blocks") -> Path:
    """The full courtyard study (``make_courtyard.FULL``) with ``bays`` bays a facade, written
    to a temporary folder: 40 bays is ``configs/courtyard.toml``'s scene (there: two levels of
    patches); fewer bays run on one level (operator_patches off; 75 patches asked a bay),
    with the floods scaled with the facades' length. ``transport="sampled"``: one level of
    patches with the ray-sampled operator (``[solver] transport``, docs/radiosity.md), as
    ``benchmarks/courtyard.py --operator-patches 0 --transport sampled`` runs it."""
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
    if transport == "sampled":
        c = dataclasses.replace(c, operator_patches=None)
    d = Path(tempfile.mkdtemp(prefix=f"courtyard{bays}_"))
    path = mc.write_study(c, d / "study.toml", d / "courtyard", "benchmark")
    if transport != "blocks":
        text = path.read_text(encoding="utf-8")
        path.write_text(text.replace("[solver]\n", f'[solver]\ntransport = "{transport}"\n', 1),
                        encoding="utf-8")
    return path


def _constraint_table(rec) -> None:
    """Before/after per constraint: the start's exact value, the bound, the design's exact
    value, and the price of an active one."""
    print("\n| constraint | bound | start | achieved | active | price |")
    print("|---|---|---|---|---|---|")
    for c in rec["constraints"]:
        price = c.get("price_sentence", "")
        print(f"| {c['label']} | {c['relation']} {c['bound']:.4g} | {c['start']:.4g} | "
              f"{c['achieved']:.4g} | {'yes' if c['active'] else ''} | {price} |")
    print()


def _profiled(fn, enabled):
    if not enabled:
        return fn()
    import cProfile
    import pstats

    prof = cProfile.Profile()
    out = prof.runcall(fn)
    pstats.Stats(prof).sort_stats("cumulative").print_stats(15)
    return out


def time_evaluations(problem, x, eps=1e-3, repeats=3) -> dict:
    """Seconds (best of ``repeats``, compiled first) of one light-model evaluation at ``x`` as
    each method asks it: the margins alone, the augmented Lagrangian's Φ and ∇Φ (one reverse
    pass), and the margins with their Jacobian (SLSQP's and GCMMA's step)."""
    import jax.numpy as jnp
    import numpy as np

    from lumijax.optimise._augmented import _phr_value_and_grad
    from lumijax.optimise._constrained import _g_and_jac_traced, _g_traced

    xj, e = jnp.asarray(np.asarray(x, np.float64)), jnp.asarray(eps)
    m = len(problem.constraints)
    lam, rho = jnp.ones(m), jnp.asarray(10.0)
    calls = {"margins": lambda: _g_traced(problem, xj, e),
             "phi_and_gradient": lambda: _phr_value_and_grad(problem, xj, lam, rho, e),
             "margins_and_jacobian": lambda: _g_and_jac_traced(problem, xj, e)}
    out = {}
    for name, call in calls.items():
        import jax

        jax.block_until_ready(call())
        best = float("inf")
        for _ in range(repeats):
            t = time.perf_counter()
            jax.block_until_ready(call())
            best = min(best, time.perf_counter() - t)
        out[name] = best
    return out


def _timed_solver(probe: bool = False):
    """Wrap the design layer's constrained solve so the solver's own seconds (without the
    exact recomputes of the lit design) are measured: ``(restore, record)``, ``record`` the
    list of ``(method, iterations, evaluations, seconds, message)`` of each solve."""
    from lumijax.optimise import _standard

    record: list[tuple] = []
    inner = _standard.solve_constrained

    def timed(*a, **kw):
        t = time.perf_counter()
        r = inner(*a, **kw)
        h = r.history
        every = max(1, len(h) // 12)
        trace = ", ".join(f"{v:.1f}" for v in h[::every])
        record.append((r.method, r.iterations, r.evaluations, time.perf_counter() - t,
                       f"{r.message}; violation {r.violation:.1e}; objective every {every} "
                       f"steps: {trace}"))
        if probe and len(record) == 1:
            cost = time_evaluations(a[0], r.x)
            print("    one evaluation (s, best of 3): "
                  + ", ".join(f"{k} {v:.3f}" for k, v in cost.items()), flush=True)
        return r

    _standard.solve_constrained = timed

    def restore():
        _standard.solve_constrained = inner

    return restore, record


def run(study_path: Path, *, aims: bool, quick: bool, profile: bool = False,
        again: bool = True, method: str = "auto", computed=None, probe: bool = False,
        gr_max: float | None = None, prices: int = 0):
    study = lumijax.load_study(study_path) if computed is None else computed[0]
    t = time.perf_counter()
    results = lumijax.compute(study) if computed is None else computed[1]
    t_compute = time.perf_counter() - t
    start = {n: g.stats for n, g in results.grids.items()}
    cons = constraints_for(results, start, gr_max)
    variables = ["dimmers", "aims"] if aims else ["dimmers"]
    kw = dict(objective="power", constraints=cons, variables=variables, method=method)
    if aims:
        kw.update(tilt_range_deg=(-5.0, 5.0), pan_range_deg=(-5.0, 5.0))
    restore, solves = _timed_solver(probe)
    try:
        t = time.perf_counter()
        opt = _profiled(lambda: optimise(study, results, **kw), profile)
        t_design = time.perf_counter() - t
        first_solves = list(solves)
        t_again = float("nan")
        if again:
            t = time.perf_counter()  # the same design again: what a designer's next try costs
            optimise(study, results, **kw)
            t_again = time.perf_counter() - t
    finally:
        restore()
    rec = opt.constrained
    checked = check_prices(study, results, kw, rec, top=prices) if prices else []
    worst = max([max(0.0, -r["margin"]) for r in rec["constraints"]], default=0.0)
    # free variables: a dimmer per network, a tilt and a pan per re-aimed luminaire
    n_var = len(study.scene.networks) + 2 * len(opt.aimed)
    return dict(variables="+".join(variables), n_constraints=len(cons), method=rec["method"],
                n_var=n_var,
                steps=rec["iterations"], evaluations=rec["evaluations"],
                compute_s=t_compute, design_s=t_design, again_s=t_again, violation=worst,
                verdict=rec["verdict"], before=rec["objective_start"],
                after=rec["objective_end"], solves=first_solves,
                solver_s=sum(s[3] for s in first_solves),
                rounds=len(rec["tightening_rounds"]), shortfall_first=rec["shortfall_first"],
                study=study, results=results, record=rec, prices=checked)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--aims", action="store_true", help="also dimmers + aims")
    ap.add_argument("--profile", action="store_true", help="cProfile the first design calls")
    ap.add_argument("--only-aims", action="store_true", help="with --aims: skip dimmers only")
    ap.add_argument("--once", action="store_true", help="do not time the design a second time")
    ap.add_argument("--study", type=Path, default=default_study_path())
    ap.add_argument("--method", default="auto",
                    help="auto, slsqp, trust-constr, augmented_lagrangian, mma; or several "
                         "separated by commas, each run on the same computed study")
    ap.add_argument("--time-evaluations", action="store_true",
                    help="time one evaluation of each kind at the first solve's design")
    ap.add_argument("--courtyard", type=int, default=None, metavar="BAYS",
                    help="a four-facade courtyard of BAYS bays a facade (40: the full one)")
    ap.add_argument("--transport", choices=("blocks", "sampled"), default="blocks",
                    help="with --courtyard: the operator (sampled: one level of patches)")
    ap.add_argument("--gr-max", type=float, default=None,
                    help="also a GR ceiling at every observer (the visitors' glare limit)")
    ap.add_argument("--check-prices", type=int, default=0, metavar="K",
                    help="re-solve with each of the K dearest active grid constraints "
                         "tightened, against its price")
    ap.add_argument("--table", action="store_true",
                    help="print every constraint's start, bound, achieved value and price")
    args = ap.parse_args()
    if args.courtyard is not None:
        args.study = courtyard_study(args.courtyard, args.transport)
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
          "solver, first (s) | design, first (s) | design, again (s) | rounds | "
          "worst violation | verdict | power (W) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    computed = None
    for aims in ([True] if args.only_aims else [False, True] if args.aims else [False]):
        for method in args.method.split(","):
            r = run(args.study, aims=aims, quick=args.quick, profile=args.profile,
                    again=not args.once, method=method, computed=computed,
                    probe=args.time_evaluations, gr_max=args.gr_max,
                    prices=args.check_prices)
            computed = (r["study"], r["results"])  # one compute serves every method
            print(f"| {r['variables']} | {r['n_var']} | {r['n_constraints']} | {r['method']} "
                  f"| {r['steps']} | {r['evaluations']} "
                  f"| {r['compute_s']:.1f} | {r['solver_s']:.2f} | {r['design_s']:.2f} | "
                  f"{r['again_s']:.2f} | {r['rounds']} | {r['violation']:.2e} | "
                  f"{r['verdict']} | {r['before']:.1f} → {r['after']:.1f} |", flush=True)
            for m, it, ev, sec, msg in r["solves"]:
                print(f"    solve: {m}, {it} steps, {ev} evaluations, {sec:.2f} s ({msg})",
                      flush=True)
            if args.table:
                _constraint_table(r["record"])
            for p in r["prices"]:
                ratio = p["resolved"] / p["predicted"] if p["predicted"] else float("nan")
                print(f"    price of {p['label']} {p['bound']:.4g} → {p['new']:.4g}: predicted "
                      f"{p['predicted']:+.2f} W, re-solved {p['resolved']:+.2f} W "
                      f"(ratio {ratio:.3f}; {p['verdict']}; {p['seconds']:.2f} s)", flush=True)
    print("\ngoal: dimmer-only design < 2 s; aims < 5 min (timings on a shared machine are "
          "contended: run alone)")


if __name__ == "__main__":
    main()
