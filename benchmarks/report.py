"""Cost of report.html: views, grid pictures and polar plots, against the 15 s budget.

    python benchmarks/report.py [--grids 10] [--cameras 3]

An office (configs/office.toml) with ``--grids`` horizontal grids and ``--cameras`` cameras
(alternately realistic and false colour), and the bundled default study with its automatic
overview. The study is computed first (not timed); the table gives the report's own time.
"""

from __future__ import annotations

import argparse
import platform
import resource
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
BUDGET_S = 15.0


def office_text(n_grids: int, n_cameras: int) -> str:
    text = (REPO / "configs" / "office.toml").read_text(encoding="utf-8")
    for i in range(n_grids):
        z = 0.1 + 2.4 * i / max(n_grids - 1, 1)
        text += (f'\n[[grids]]\nname = "level-{i}"\nkind = "plane"\norigin = [0.25, 0.25, {z:.3f}]'
                 f'\nu = [5.5, 0, 0]\nv = [0, 7.5, 0]\nspacing = 0.25\ntarget_lux = 300\n')
    views = [((5.8, 0.2, 2.6), (2, 5, 0.6)), ((0.3, 7.8, 2.4), (4, 2, 0.5)),
             ((3, 4, 7.5), (3, 4, 0))]
    for i in range(n_cameras):
        pos, tgt = views[i % len(views)]
        kind = "realistic" if i % 2 == 0 else "falsecolour"
        up = "[0, 1, 0]" if pos[2] > 5 else "[0, 0, 1]"
        text += (f'\n[cameras.c{i}]\nposition = {list(pos)}\ntarget = {list(tgt)}\nup = {up}\n'
                 f'fov_deg = 70\nkind = "{kind}"\n')
    return text


def measure(study, results) -> dict:
    from lumijax.report import render_report, report_context

    t0 = time.perf_counter()
    ctx = report_context(study, results)
    html = render_report(ctx)
    total = time.perf_counter() - t0
    return {"total": total, "bytes": len(html.encode()), **ctx["timings"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grids", type=int, default=10)
    ap.add_argument("--cameras", type=int, default=3)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    from lumijax import compute, load_study
    from lumijax.cli import default_study_path

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "office.toml"
        cfg.write_text(office_text(args.grids, args.cameras), encoding="utf-8")
        for label, path in ((f"office, {args.grids} grids, {args.cameras} cameras", cfg),
                            ("default study, overview", default_study_path())):
            study = load_study(path)
            results = compute(study, cache_dir=Path(tmp) / "cache")
            m = measure(study, results)
            views = sum(v for k, v in m.items() if k.startswith("view:")) + m.get(
                "network_views", 0.0)  # each network alone: views too
            rows.append((label, len(results.grids), results.lighting.coarse.patches.n, views,
                         m["grid_pictures"], m["photometry"], m["total"], m["bytes"]))
    print(f"machine: {platform.machine()} {platform.system()}, python {platform.python_version()}")
    print("| study | grids | patches | views (s) | grid pictures (s) | photometry (s) | total (s) "
          "| ratio to 15 s budget | HTML size | peak RSS |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    for label, g, p, v, mp, ph, tot, size in rows:
        print(f"| {label} | {g} | {p:,} | {v:.1f} | {mp:.1f} | {ph:.1f} | {tot:.1f} | "
              f"{tot / BUDGET_S:.2f} | {size / 2**20:.1f} MiB | {rss:.1f} GB |")


if __name__ == "__main__":
    main()
