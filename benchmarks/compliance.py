"""Benchmark of the compliance table (docs/compliance.md) against the lighting solve it reads.

    python benchmarks/compliance.py                    # the bundled courtyard demo + a 20-room office
    python benchmarks/compliance.py --study courtyard  # configs/courtyard.toml (full scale)
    python benchmarks/compliance.py --small            # a 2-room office only (a smoke check)

Each study gets a ``[compliance]`` table of every kind: EN 12464-1 task areas with their
surroundings, cylindrical sensors and modelling (the office) or EN 12464-2 areas (the
courtyard), CIE 97 maintenance, energy and LENI, CIE 150 obtrusive light (windows, sensitive
points, ULR, a surface grid's luminance), before and after curfew. Prints per study: the
lighting solve's time (``compute`` without the compliance grids), the sensor grids' light
(direct and the whole-sphere gather), building the compliance model, judging it, and judging it
again at a new dimmer vector (superposition), each in seconds and as a share of the solve.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def office_toml(rooms: int, target_patches: int) -> str:
    out = [f"""
[study]
name = "compliance benchmark: {rooms}-room office"
[solver]
target_patches = {target_patches}
spectral_samples = 0
cache = false
[materials.wall]
reflectance = 0.7
[materials.table]
reflectance = 0.4
[photometry.downlight]
kind = "lambertian"
flux_lm = 1200
[networks.general]
[networks.desk]
dimmer = 0.8
"""]
    comp = ["""
[compliance.maintenance]
llmf = 0.9
luminaire_type = "C"
environment = "clean"
cleaning_interval_years = 1
[compliance.energy]
watts = { downlight = 12 }
occupancy_factor = 0.9
leni_max = 15
[compliance.energy.dimming.desk]
curve = "table"
levels = [0, 0.5, 1]
power = [0.05, 0.4, 1]
standby_w = 0.3
"""]
    for r in range(rooms):
        ox, oy = (r % 5) * 6.4, (r // 5) * 5.4
        out.append(f"""
[[geometry]]
name = "room{r}"
kind = "box"
min = [{ox}, {oy}, 0]
max = [{ox + 6}, {oy + 5}, 3]
normals = "inward"
material = "wall"
[[geometry]]
kind = "box"
min = [{ox + 2}, {oy + 1.5}, 0.72]
max = [{ox + 4}, {oy + 3.5}, 0.75]
material = "table"
""")
        for i in range(5):
            for j in range(4):
                net = "desk" if 1 <= i <= 3 and 1 <= j <= 2 else "general"
                out.append(f'[[luminaires]]\nname = "r{r}-{i}{j}"\nphotometry = "downlight"\n'
                           f"position = [{ox + 0.6 + 1.2 * i}, {oy + 0.625 + 1.25 * j}, 2.95]\n"
                           f'network = "{net}"\n')
        out.append(f"""
[[grids]]
name = "task{r}"
kind = "area"
origin = [{ox + 1.5}, {oy + 1}, 0.8]
u = [3, 0, 0]
v = [0, 3, 0]
[[grids]]
name = "surround{r}"
kind = "area"
origin = [{ox + 1}, {oy + 0.5}, 0.8]
u = [4, 0, 0]
v = [0, 4, 0]
exclude = "task{r}"
[[grids]]
name = "ez{r}"
kind = "sensor"
sensor = "cylindrical"
at_grid = "task{r}"
offset_m = [0, 0, 0.4]
""")
        comp.append(f"""
[[compliance.areas]]
name = "room{r}"
standard = "EN 12464-1"
reference = "34.2"
grid = "task{r}"
cylindrical = "ez{r}"
modelling = [0.3, 0.6]
surrounding = "surround{r}"
networks = ["general", "desk"]
area_m2 = 30
""")
    out.append("""
[[grids]]
name = "walls0"
kind = "surface"
geometry = "room0"
spacing = 1.0
[[grids]]
name = "window0"
kind = "sensor"
sensor = "vertical"
points = [[0.05, 2.5, 1.5]]
facing = [1, 0, 0]
""")
    comp.append("""
[compliance.obtrusive]
zone = "E2"
curfew = "22:00"
after_curfew = { general = 0.0 }
windows = ["window0"]
facades = ["walls0"]
sensitive = [{ name = "house", point = [3, 2.5, 1.5] }]
""")
    return "".join(out + comp)


COURTYARD_COMPLIANCE = """
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


def _timed(f):
    t = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t


def run(name: str, path: Path) -> dict:
    import jax.numpy as jnp

    from lumijax import compute, load_study
    from lumijax.compliance import Compliance, compliance_model, sensor_grids

    study = load_study(path)
    bare = dataclasses.replace(study, config=study.config.model_copy(update={"compliance": None}))
    res, t_compute = _timed(lambda: compute(bare))
    t_solve = float(res.timing_s.get("lighting", res.timing_s.get("total", t_compute)))
    _, t_sensors = _timed(lambda: sensor_grids(study, res.lighting))
    full, t_full = _timed(lambda: compute(study))
    model, t_model = _timed(lambda: compliance_model(study, full))
    comp, t_judge = _timed(lambda: Compliance.judge(model, full.design.dimmers))
    new = np.clip(np.asarray(full.design.dimmers) * 0.7 + 0.1, 0, 1)
    _, t_at = _timed(lambda: comp.at(new))
    _, t_at2 = _timed(lambda: comp.at(new[::-1].copy()))
    _, t_q = _timed(lambda: {k: float(v) for k, v in model.quantities(jnp.asarray(new)).items()})
    return {"study": name, "points": int(sum(len(g) for g in study.scene.grids)),
            "criteria": len(comp.rows), "solve_s": t_solve, "compute_s": t_compute,
            "sensor_grids_s": t_sensors, "compute_with_compliance_s": t_full,
            "model_s": t_model, "judge_s": t_judge, "at_new_dimmers_s": t_at,
            "at_again_s": t_at2, "quantities_s": t_q, "compliant": comp.compliant}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", choices=["demo", "courtyard", "office", "all"], default="all")
    ap.add_argument("--small", action="store_true", help="a 2-room office only (smoke check)")
    ap.add_argument("--rooms", type=int, default=20)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        studies = []
        if args.small:
            p = tmp / "office.toml"
            p.write_text(office_toml(2, 800))
            studies.append(("office, 2 rooms", p))
        else:
            if args.study in ("demo", "all"):
                src = REPO / "lumijax" / "data" / "studies" / "default" / "study.toml"
                p = src.parent / "_compliance_benchmark.toml"  # beside its meshes
                p.write_text(src.read_text() + COURTYARD_COMPLIANCE)
                studies.append(("demo courtyard", p))
            if args.study == "courtyard":
                src = REPO / "configs" / "courtyard.toml"
                p = src.parent / "_compliance_benchmark.toml"
                p.write_text(src.read_text() + COURTYARD_COMPLIANCE)
                studies.append(("full courtyard", p))
            if args.study in ("office", "all"):
                p = tmp / "office.toml"
                # 20 rooms of ~5,000 patches each: ~10⁵ patches
                p.write_text(office_toml(args.rooms, 5000 * args.rooms))
                studies.append((f"office, {args.rooms} rooms", p))
        try:
            for name, p in studies:
                rows.append(run(name, p))
        finally:
            for _, p in studies:
                if p.name == "_compliance_benchmark.toml":
                    p.unlink(missing_ok=True)
    print(f"machine: {platform.processor() or platform.machine()}, "
          f"python {platform.python_version()}")
    keys = ["points", "criteria", "solve_s", "sensor_grids_s", "model_s", "judge_s",
            "at_new_dimmers_s", "at_again_s", "quantities_s"]
    print("| study | " + " | ".join(keys) + " | compliance / solve |")
    print("|---|" + "---|" * (len(keys) + 1))
    for r in rows:
        share = (r["sensor_grids_s"] + r["model_s"] + r["judge_s"]) / max(r["solve_s"], 1e-9)
        cells = [f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]) for k in keys]
        print(f"| {r['study']} | " + " | ".join(cells) + f" | {100 * share:.0f} % |")


if __name__ == "__main__":
    main()
