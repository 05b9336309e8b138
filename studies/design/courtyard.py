"""The full courtyard's least-power design (issue 16), checked by a linear programme.

    python studies/design/courtyard.py [--bays 40] [--gr-max 50] [--profile]

The full courtyard (``make_courtyard.FULL``: 3,000 luminaires on 18 networks, LoD 0, one level of
patches with the ray-sampled transport) is computed, then designed for the least power in use
over its 18 dimmers under the study's own grid limits (the walls' and columns' lux targets and
U0 floors, the walls' 25 cd/m² luminance ceiling, the court's 1 lx Emin) and the benchmark's
(each grid's Eavg at its target, else 60 % of the start's; U0 at 80 % of the start's; every
visitor's GR at most ``--gr-max``): ``benchmarks/design.py``'s constraints.

The check, by a program nobody here wrote: every criterion but GR is linear in the dimmers
point by point (Eavg ≥ b; U0 ≥ u ⟺ E_p − u·Eavg ≥ 0 at every point; Emin ≥ b ⟺ E_p ≥ b;
luminance ≤ L ⟺ ρE_p/π ≤ L), so without the GR ceilings the design is a linear programme in
the 18 dimmers over the grids' per-network illuminance (``GridResult.by_network_lux``), solved
exactly by HiGHS (scipy.optimize.linprog). That programme is a relaxation (fewer constraints,
no smoothing of min and max): where it is infeasible, so is lumijax's problem, and its
irreducible infeasible subsets (by the LP's own deletion filter) are what lumijax's minimal
conflicting set should be; where it is feasible, its least power is a lower bound of
lumijax's. Prints the design's record (verdict, steps, time, the conflict or the prices), the
LP's answer and their agreement.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import linprog

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

from design import constraints_for, courtyard_study  # noqa: E402


def linear_rows(study, results, record, gr_dropped: list[str]):
    """``(A, b, labels)``: each linear constraint of the design's ``record`` as point rows
    ``A d ≤ b`` in the dimmers ``d`` (one label per row); GR rows are left out (named in
    ``gr_dropped``)."""
    grids = {g.name: g for g in results.grids.values()}
    reflect = {gc.name: gc.reflectance for gc in study.config.grids}
    rows, rhs, labels = [], [], []
    for c in record["constraints"]:
        crit, bound = c["criterion"], float(c["bound"])
        m = re.match(r"grid '(.+)'", c["label"])
        if m is None:
            gr_dropped.append(c["label"])
            continue
        e = np.asarray(grids[m[1]].by_network_lux, np.float64).T  # (points, networks)
        avg = e.mean(axis=0)
        if crit == "avg":  # mean ≥ b
            a, r = -avg[None], [-bound]
        elif crit == "u0":  # E_p ≥ u · mean
            a, r = -(e - bound * avg[None]), np.zeros(len(e))
        elif crit == "min":
            a, r = -e, np.full(len(e), -bound)
        elif crit == "max":
            a, r = e, np.full(len(e), bound)
        elif crit == "luminance":
            a, r = float(reflect[m[1]]) * e / np.pi, np.full(len(e), bound)
        else:
            raise SystemExit(f"no linear form for {c['label']} ({crit})")
        rows.append(a)
        rhs.append(np.asarray(r, np.float64))
        labels += [c["label"] + f" {c['relation']} {bound:.4g}"] * len(a)
    return np.concatenate(rows), np.concatenate(rhs), np.asarray(labels)


def lp(a, b, lo, hi, cost):
    return linprog(cost, A_ub=a, b_ub=b, bounds=list(zip(lo, hi, strict=True)), method="highs")


def irreducible(a, b, labels, lo, hi):
    """An irreducible infeasible subset of the constraints (by label), the deletion filter."""
    keep = list(dict.fromkeys(labels))
    zero = np.zeros(a.shape[1])
    for name in list(keep):
        trial = [k for k in keep if k != name]
        mask = np.isin(labels, trial)
        if trial and lp(a[mask], b[mask], lo, hi, zero).status == 2:  # still infeasible
            keep = trial
    return keep


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bays", type=int, default=40)
    ap.add_argument("--gr-max", type=float, default=50.0)
    ap.add_argument("--profile", action="store_true", help="cProfile the design call")
    args = ap.parse_args()

    import lumijax
    from lumijax.optimise import optimise

    study = lumijax.load_study(courtyard_study(args.bays, "sampled"))
    t = time.perf_counter()
    results = lumijax.compute(study)
    print(f"compute: {time.perf_counter() - t:.1f} s; {len(study.scene.luminaires):,} "
          f"luminaires, {len(study.scene.networks)} networks, "
          f"{sum(len(g.points) for g in study.scene.grids):,} grid points", flush=True)
    start = {n: g.stats for n, g in results.grids.items()}
    kw = dict(objective="power", constraints=constraints_for(results, start, args.gr_max),
              variables=["dimmers"])
    t = time.perf_counter()
    if args.profile:
        import cProfile
        import pstats

        prof = cProfile.Profile()
        opt = prof.runcall(optimise, study, results, **kw)
        pstats.Stats(prof).sort_stats("cumulative").print_stats(25)
    else:
        opt = optimise(study, results, **kw)
    design_s = time.perf_counter() - t
    rec = opt.constrained
    print(f"design: {rec['verdict']}, {rec['iterations']} steps, {rec['evaluations']} "
          f"evaluations, {design_s:.1f} s; power {rec['objective_start']:.1f} → "
          f"{rec['objective_end']:.1f} W")
    conflict = rec.get("infeasibility", {}).get("conflict", [])
    for s in rec.get("infeasibility", {}).get("sentences", []):
        print(f"  conflict: {s}")
    for s in rec.get("prices", []):
        print(f"  price: {s}")

    gr: list[str] = []
    a, b, labels = linear_rows(study, results, rec, gr)
    lo = np.full(a.shape[1], float(study.config.optimise.dimmer_min))
    hi = np.ones(a.shape[1])
    d_end = np.asarray(opt.results.design.dimmers, np.float64)
    res = lp(a, b, lo, hi, np.zeros(a.shape[1]))
    print(f"LP (HiGHS) without the GR rows ({len(gr)} left out), {len(a):,} point rows: "
          f"{res.message}")
    if res.status == 2:
        iis = irreducible(a, b, labels, lo, hi)
        print("  irreducible infeasible subset: " + "; ".join(iis))
        theirs = {c["label"] for c in conflict}
        ours = {re.sub(r" (≥|≤) \S+$", "", k) for k in iis}
        print(f"  lumijax's conflict {sorted(theirs)} {'==' if theirs == ours else '!='} "
              f"the LP's {sorted(ours)}")
    else:
        worst = float(np.max(a @ d_end - b))
        print(f"  the design's dimmers break the LP's rows by at most {worst:.3g} "
              "(≤ 0: feasible for the relaxation)")
        from lumijax.optimise._optimise import LUMENS_PER_WATT

        # the objective's watts (docs/optimise.md): a network's power_w, else its flux at
        # LUMENS_PER_WATT, linear in its dimmer
        cfg, flux = study.config, study.scene.network_flux_lm()
        watts = np.array([cfg.networks[n].power_w if n in cfg.networks
                          and cfg.networks[n].power_w is not None else flux[n] / LUMENS_PER_WATT
                          for n in study.scene.network_names])
        best = lp(a, b, lo, hi, watts)
        p_lp = float(best.fun)
        print(f"  LP least power {p_lp:.1f} W (a lower bound: no GR, exact min and max); "
              f"lumijax {rec['objective_end']:.1f} W, {100 * (rec['objective_end'] / p_lp - 1):+.2f} %")
        tight = a @ best.x - b > -1e-6 * np.maximum(1.0, np.abs(b))
        active_lp = sorted(set(labels[tight]))
        active = sorted(f"{c['label']} {c['relation']} {float(c['bound']):.4g}"
                        for c in rec["constraints"] if c["active"])
        print(f"  active in the LP: {active_lp}\n  active in lumijax's design: {active}")


if __name__ == "__main__":
    main()
