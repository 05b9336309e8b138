"""Benchmark of the compliance table (docs/compliance.md) against the lighting solve it reads.

    python benchmarks/compliance.py --study courtyard  # configs/courtyard.toml, full scale
    python benchmarks/compliance.py --study building   # a ≈10⁵-patch office building
    python benchmarks/compliance.py --study demo       # the bundled courtyard demo
    python benchmarks/compliance.py --quick            # a 1-room building (a smoke check)

Each study gets a ``[compliance]`` table of every kind: EN 12464-1 task areas with their
surroundings, cylindrical sensors, modelling and UGR observers (the building,
``studies/compliance/make_office_building.py``) or EN 12464-2 areas (the courtyards), CIE 97
maintenance, energy and LENI, CIE 150 obtrusive light (windows, sensitive points, ULR direct
and reflected, a surface grid's luminance), before and after curfew. One ``compute`` per study:
its ``timing_s["lighting"]`` is the lighting solve; then, timed apart and each as a ratio to
the solve: the sensor grids' light (direct and the whole-sphere gather), building the
compliance model, judging it, and judging it again at a new dimmer vector (superposition).
Peak RSS is the process's (``ru_maxrss``) after each study.
"""

from __future__ import annotations

import argparse
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "studies" / "compliance"))

from make_office_building import building_toml  # noqa: E402

#: the demo courtyard (≈ 35 × 35 m court): sensors on its "court" grid, windows across it
DEMO_COMPLIANCE = """
[[grids]]
name = "court-ez"
kind = "sensor"
sensor = "semicylindrical"
at_grid = "court"
offset_m = [0, 0, 1.49]
facing = [0, 1, 0]
[[grids]]
name = "court-hemi"
kind = "sensor"
sensor = "hemispherical"
at_grid = "court"
[[grids]]
name = "paving"
kind = "surface"
geometry = "court"
spacing = 2.0
[[grids]]
name = "neighbour"
kind = "sensor"
sensor = "vertical"
points = [[13.2, 40, 6], [40, 13.2, 6]]
facing = [0, -1, 0]
[compliance.maintenance]
mf = 0.8
[compliance.energy]
area_m2 = 697
[[compliance.areas]]
name = "court"
standard = "EN 12464-2"
reference = "5.1.1"
grid = "court"
[compliance.obtrusive]
zone = "E3"
curfew = "23:00"
after_curfew = { floods = 0.0 }
windows = ["neighbour"]
facades = ["paving"]
sensitive = [{ name = "tower", point = [13.2, 60, 30] }]
"""

#: the full courtyard (162.4 m square court, facades 4 × 40 bays): the same kinds at its scale
COURTYARD_COMPLIANCE = """
[[grids]]
name = "court-ez"
kind = "sensor"
sensor = "semicylindrical"
at_grid = "court"
offset_m = [0, 0, 1.5]
facing = [0, 1, 0]
[[grids]]
name = "court-hemi"
kind = "sensor"
sensor = "hemispherical"
at_grid = "court"
[[grids]]
name = "paving"
kind = "surface"
geometry = "court"
spacing = 8.0
[[grids]]
name = "neighbour"
kind = "sensor"
sensor = "vertical"
points = [[81.2, 200, 6], [81.2, 200, 12], [-40, 81.2, 6]]
facing = [0, -1, 0]
[compliance.maintenance]
mf = 0.8
[compliance.energy]
area_m2 = 26374
[[compliance.areas]]
name = "court"
standard = "EN 12464-2"
reference = "5.1.1"
grid = "court"
[compliance.obtrusive]
zone = "E3"
curfew = "23:00"
windows = ["neighbour"]
facades = ["paving"]
sensitive = [{ name = "tower", point = [81.2, 260, 40] }]
"""


def _timed(f):
    t = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t


def _rss_gib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # KiB on Linux


def run(name: str, path: Path) -> dict:
    """One study: compute once, then the compliance stages timed apart (module docstring)."""
    import jax.numpy as jnp

    from lumijax import compute, load_study
    from lumijax.compliance import Compliance, compliance_model, sensor_grids

    study = load_study(path)
    full, t_compute = _timed(lambda: compute(study))
    t_solve = float(full.timing_s["lighting"])
    _, t_sensors = _timed(lambda: sensor_grids(study, full.lighting))
    model, t_model = _timed(lambda: compliance_model(study, full))
    comp, t_judge = _timed(lambda: Compliance.judge(model, full.design.dimmers))
    new = np.clip(np.asarray(full.design.dimmers) * 0.7 + 0.1, 0, 1)
    _, t_at = _timed(lambda: comp.at(new))
    _, t_at2 = _timed(lambda: comp.at(new[::-1].copy()))
    _, t_q = _timed(lambda: {k: float(v) for k, v in model.quantities(jnp.asarray(new)).items()})
    counts = full.counts
    return {"study": name, "points": int(counts.get("grid_points", 0)),
            "criteria": len(comp.rows),
            "patches": int(counts.get("fine_patches", counts.get("patches", 0))),
            "elements": int(counts.get("patches", 0)), "luminaires": len(study.scene.luminaires),
            "networks": len(full.networks), "solve_s": t_solve, "compute_s": t_compute,
            "sensor_grids_s": t_sensors, "model_s": t_model, "judge_s": t_judge,
            "at_new_dimmers_s": t_at, "at_again_s": t_at2, "quantities_s": t_q,
            "compliant": comp.compliant, "failed": sum(r["passed"] is False for r in comp.rows),
            "peak_rss_gib": _rss_gib()}


def table(rows: list[dict]) -> str:
    """The benchmark's Markdown table: sizes, times (s) and each time over the solve's."""
    head = ("| study | points | criteria | patches (elements) | luminaires / networks | solve (s) "
            "| sensor grids (s) | model (s) | judge (s) | at new dimmers (s) "
            "| sensors+model / solve | judge / solve | at / solve | peak RSS (GiB) |")
    out = [head, "|" + "---|" * head.count(" | ") + "---|"]
    for r in rows:
        s = max(r["solve_s"], 1e-9)
        out.append(
            f"| {r['study']} | {r['points']:,} | {r['criteria']} | {r['patches']:,} "
            f"({r['elements']:,}) | {r['luminaires']} / {r['networks']} | {r['solve_s']:.4g} "
            f"| {r['sensor_grids_s']:.3g} | {r['model_s']:.3g} | {r['judge_s']:.3g} "
            f"| {r['at_new_dimmers_s']:.3g} | {(r['sensor_grids_s'] + r['model_s']) / s:.3g} "
            f"| {r['judge_s'] / s:.2g} | {r['at_new_dimmers_s'] / s:.2g} "
            f"| {r['peak_rss_gib']:.2f} |")
    return "\n".join(out)


def studies(which: str, tmp: Path, quick: bool, floors: int, rooms: int) -> list:
    """(name, config path) per study; configs that read meshes are written beside them."""
    out = []
    if quick:
        p = tmp / "building.toml"
        p.write_text(building_toml(1, 1, target_patches=400, operator_patches=150,
                                   gather_rays=16))
        return [("office building, 1 room (quick)", p)]
    if which in ("demo", "all"):
        src = REPO / "lumijax" / "data" / "studies" / "default" / "study.toml"
        p = src.parent / f"_compliance_benchmark_{tmp.name}.toml"  # beside its meshes
        p.write_text(src.read_text() + DEMO_COMPLIANCE)
        out.append(("demo courtyard", p))
    if which in ("courtyard", "all"):
        src = REPO / "configs" / "courtyard.toml"
        p = src.parent / f"_compliance_benchmark_{tmp.name}.toml"
        p.write_text(src.read_text() + COURTYARD_COMPLIANCE)
        out.append(("full courtyard", p))
    if which in ("building", "all"):
        p = tmp / "building.toml"
        p.write_text(building_toml(floors, rooms))
        out.append((f"office building, {floors} × {rooms} rooms", p))
    return out


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", choices=["demo", "courtyard", "building", "all"], default="all")
    ap.add_argument("--quick", action="store_true", help="a 1-room building only (smoke check)")
    ap.add_argument("--floors", type=int, default=4)
    ap.add_argument("--rooms", type=int, default=12, help="rooms per floor")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        todo = studies(args.study, Path(tmp), args.quick, args.floors, args.rooms)
        try:
            for name, p in todo:
                rows.append(run(name, p))
                print(f"{name}: done ({rows[-1]['compute_s']:.1f} s compute)", flush=True)
        finally:
            for _, p in todo:
                if p.name.startswith("_compliance_benchmark"):
                    p.unlink(missing_ok=True)
    print(f"machine: {platform.platform()}, {platform.processor() or platform.machine()}, "
          f"python {platform.python_version()}")
    print(table(rows))
    return rows


if __name__ == "__main__":
    main()
