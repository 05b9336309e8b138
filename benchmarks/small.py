"""A small study answers in seconds (issue 19): lumijax against Radiance on the same scenes and
points, in the same run.

    python benchmarks/small.py                 # every case (minutes; run it alone on the machine)
    python benchmarks/small.py --case cube0.8  # one case
    python benchmarks/small.py --smoke         # a tiny cube, coarse settings: the code runs
    python benchmarks/small.py --patch-sweep   # accuracy against target_patches and of the
                                               # default rule ([solver] accuracy; no timing)

Cases: the closed 4 m cube at ρ 0.2 / 0.5 / 0.8 (an isotropic 10,000 lm source at its centre,
100 floor points 1 cm up), the furnished room of ``studies/validation`` (100 workplane points)
and a 20-luminaire office (8 × 6 × 3 m, four dimmer networks, 100 workplane points).

lumijax runs as a user runs it: ``lumijax run STUDY --no-images --no-report`` in a new process,
timed end to end (interpreter start, import, load, compute, results.json), in three states:

* **first**: every cache empty (a new JAX compilation cache folder, no operator cache) — the
  very first run after installing;
* **cold**: a new study (no operator cache) with the compilation cache as an earlier,
  *different* study left it (a 3 × 3 × 2.5 m room run first into the same cache folder);
* **warm**: the same study again (operator cache present, and the first run's stored
  solution: a numbers run of an unchanged study is answered from it, with no JAX;
  docs/results.md, "Dimmer-only reruns");
* **moved**: one luminaire moved 0.1 m in the study file, run again: the operator comes from
  the cache, the light is computed again in full (direct, solve, gather).

Then the iterate loop: ``lumijax run --quick`` (the photometric solve, numbers only; "quick
s"), one dimmer changed in the study file and ``lumijax run --quick`` again ("dimmer s", end to
end, CLI included; target < 2 s): the second run superposes the first's stored solution. Radiance: ``oconv`` + ``rtrace -I -ab 8 -aa 0`` on the same
geometry and points (pyradiance), timed the same way (the lamp a 2 cm sphere of ``light``).

References (independent of both programs): an exact-kernel radiosity written in numpy
(``benchmarks/room_reference.py``) — every face cut into squares (``Case.ref_size``;
``--ref-size``), point-to-polygon form factors in closed form (Lambert's contour formula),
3 × 3 Gauss points on the receiving square, a dense solve; the point irradiance is the
closed-form direct light plus what the squares send it, each square's B read linearly across
it (the least-squares gradient of its face's neighbouring squares, its mean kept; every
square summed as sub-squares of ≤ 0.0125 m with the exact point-to-square factor).

* convex rooms (cube, office): one unknown per orbit of squares under the room's symmetries
  (the cube's 48: 820 orbits of 38,400 squares at 0.05 m). The cube ρ 0.5 at 0.25 / 0.2 /
  0.16 / 0.1 / 0.08 m lies 0.0150 / 0.0101 / 0.0067 / 0.0025 / 0.0010 % RMS from 0.05 m,
  close to h²: the 0.05 m reference is within ≈ 0.001 %;
* the furnished room (a table occludes): every square an unknown and the table's shadows
  exact — the part of a square inside the cone of rays from a point through the table is
  clipped out and its factor (from a lamp, its solid angle) taken off (convergence:
  benchmarks/RESULTS.md, session 30). Its points, 5 cm above the table, see nothing of it.

Each reference prints its own checks: the area-mean irradiance against the closed form
Φ/(S(1 − ρ)) (the validation study's check; it holds for any closed room of one ρ), the
furnished room's factors' closure (each Gauss point's factors sum to 1) and the change from
a mesh 1.6× coarser.

Errors are RMS relative errors over the points. Targets (issue 19): cold no slower than
Radiance while ≥ 10× more accurate, first within 3× Radiance's time, warm ≥ 5× faster.
Timings on a shared machine are not results: run this alone.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import platform
import runpy
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from room_reference import reference  # benchmarks/room_reference.py

WHTEFFICACY = 179.0  # lm/W: Radiance's luminous efficacy of its equal-energy white
RADIANCE = ["-ab", "8", "-aa", "0"]


@dataclass
class Case:
    """A grey scene: inward room box, outward obstacle boxes, isotropic lamps, sensor points."""

    name: str
    room: tuple
    rho: float
    lamps: list  # (position (m), flux (lm), network)
    points: np.ndarray
    normals: np.ndarray
    obstacles: list = field(default_factory=list)  # (min, max) outward boxes
    solver: str = ""  # extra [solver] lines
    ref_size: float = 0.2  # square size (m) of the numpy reference


def grid_points(lo, hi, z, n=10):
    """n × n cell centres of the rectangle lo..hi (x, y) at height z, facing up."""
    xs = lo[0] + (np.arange(n) + 0.5) * (hi[0] - lo[0]) / n
    ys = lo[1] + (np.arange(n) + 0.5) * (hi[1] - lo[1]) / n
    p = np.array([[x, y, z] for y in ys for x in xs])
    return p, np.tile([0.0, 0.0, 1.0], (len(p), 1))


def cases(smoke: bool) -> list[Case]:
    if smoke:
        p, n = grid_points((0, 0), (4, 4), 0.01, n=4)
        return [Case("smoke cube ρ=0.5", (4.0, 4.0, 4.0), 0.5, [((2, 2, 2), 10_000.0, "n")],
                     p, n, solver="target_patches = 300\ngather_rays = 64", ref_size=0.8)]
    out = []
    p, n = grid_points((0, 0), (4, 4), 0.01)
    for rho in (0.2, 0.5, 0.8):
        out.append(Case(f"cube{rho}", (4.0, 4.0, 4.0), rho, [((2, 2, 2), 10_000.0, "n")], p, n,
                        ref_size=0.05))
    p, n = grid_points((0.5, 0.5), (4.5, 3.5), 0.8)
    out.append(Case("furnished", (5.0, 4.0, 3.0), 0.5, [((2.2, 2.0, 2.5), 5000.0, "n")], p, n,
                    obstacles=[((1.6, 1.2, 0.70), (3.4, 2.4, 0.75))], ref_size=1 / 6))
    lamps = [((0.8 + 1.6 * i, 0.75 + 1.5 * j, 2.8), 1000.0, f"row{j}")
             for j in range(4) for i in range(5)]
    p, n = grid_points((0.5, 0.5), (7.5, 5.5), 0.8)
    out.append(Case("office", (8.0, 6.0, 3.0), 0.6, lamps, p, n))
    return out


# ------------------------------------------------------------------------------------------
# study files


def _list(a) -> str:
    return "[" + ", ".join("[" + ", ".join(f"{v:.6f}" for v in r) + "]" for r in a) + "]"


def study_toml(case: Case, name: str | None = None) -> str:
    x, y, z = case.room
    nets = sorted({lamp[2] for lamp in case.lamps})
    parts = [f'[study]\nname = "{name or case.name}"\n[materials.grey]\nreflectance = {case.rho}\n']
    for net in nets:
        parts.append(f"[networks.{net}]\ndimmer = 1.0\n")
    parts.append(f'[[geometry]]\nname = "room"\nkind = "box"\nmin = [0, 0, 0]\n'
                 f'max = [{x}, {y}, {z}]\nnormals = "inward"\nmaterial = "grey"\n')
    for i, (lo, hi) in enumerate(case.obstacles):
        parts.append(f'[[geometry]]\nname = "obstacle{i}"\nkind = "box"\nmin = {list(lo)}\n'
                     f'max = {list(hi)}\nnormals = "outward"\nmaterial = "grey"\n')
    for i, (pos, flux, net) in enumerate(case.lamps):
        parts.append(f'[photometry.p{i}]\nkind = "isotropic"\nflux_lm = {flux}\n'
                     f'[[luminaires]]\nname = "L{i}"\nphotometry = "p{i}"\n'
                     f"position = {list(pos)}\nnetwork = \"{net}\"\n")
    parts.append(f'[[grids]]\nname = "points"\nkind = "points"\npoints = {_list(case.points)}\n'
                 f"normals = {_list(case.normals)}\n")
    if case.solver:
        parts.append(f"[solver]\n{case.solver}\n")
    return "\n".join(parts)


def prime_case(smoke: bool) -> Case:
    """A different, smaller study that fills the compilation cache before a 'cold' run."""
    p, n = grid_points((0.5, 0.5), (2.5, 2.5), 0.8, n=5)
    return Case("prime room", (3.0, 3.0, 2.5), 0.4, [((1.5, 1.5, 2.2), 2000.0, "n")], p, n,
                solver="target_patches = 300\ngather_rays = 64" if smoke else "")


# ------------------------------------------------------------------------------------------
# lumijax, as a user runs it


def lumijax_run(study: Path, out: Path, jax_cache: Path,
                quick: bool = False) -> tuple[float, np.ndarray, dict]:
    """``lumijax run`` in a new process: (wall s, lux at the points, results.json)."""
    env = dict(os.environ, LUMIJAX_JAX_CACHE=str(jax_cache))
    # an installed lumijax has its bytecode from pip; a machine that sets this (ours does)
    # would make every run compile lumijax's sources again (0.2-0.3 s), which no user pays
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    cmd = [sys.executable, "-m", "lumijax.cli", "run", str(study), "--out", str(out),
           *(["--quick"] if quick else ["--no-images", "--no-report"])]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}")
    res = json.loads((out / "results.json").read_text())
    return wall, np.asarray(res["grids"]["points"]["illuminance_lux"]), res


def write(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "study.toml"
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------------------------------------------------
# Radiance


@functools.cache
def _validation() -> dict:
    """studies/validation/run_validation.py's names, loaded once by path (studies is no
    package)."""
    path = Path(__file__).resolve().parents[1] / "studies" / "validation" / "run_validation.py"
    return runpy.run_path(str(path))


def _rad_box(name: str, lo, hi, inward: bool) -> str:
    """A Radiance box as six grey polygons: the validation's own (run_validation._rad_box), so
    the small cases' Radiance rooms are written as the validation's are."""
    return _validation()["_rad_box"](name, lo, hi, inward)


def radiance_scene(case: Case, folder: Path, r: float = 0.02) -> Path:
    """Grey plastic ρ; each lamp a sphere of radius r and radiance L with Φ = π L 4π r²."""
    text = [f"void plastic grey\n0\n0\n5 {case.rho} {case.rho} {case.rho} 0 0\n"]
    for i, (pos, flux, _) in enumerate(case.lamps):
        rad = flux / WHTEFFICACY / (4 * math.pi**2 * r**2)
        text.append(f"void light lamp{i}\n0\n0\n3 {rad:.6g} {rad:.6g} {rad:.6g}\n"
                    f"lamp{i} sphere bulb{i}\n0\n0\n4 {pos[0]} {pos[1]} {pos[2]} {r}\n")
    text.append(_rad_box("room", (0, 0, 0), case.room, inward=True))
    for i, (lo, hi) in enumerate(case.obstacles):
        text.append(_rad_box(f"obstacle{i}", lo, hi, inward=False))
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.rad"
    path.write_text("".join(text))
    return path


def radiance(case: Case, folder: Path, params) -> tuple[float, np.ndarray]:
    """(wall s of oconv + rtrace -I, lux at the points)."""
    import pyradiance as pr

    scene = radiance_scene(case, folder)
    rays = "".join(f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f} {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}\n"
                   for p, n in zip(case.points, case.normals, strict=True)).encode()
    t0 = time.perf_counter()
    octree = folder / "scene.oct"
    octree.write_bytes(pr.oconv(str(scene)))
    out = pr.rtrace(rays, str(octree), irradiance=True, header=False, params=list(params))
    wall = time.perf_counter() - t0
    rgb = np.array([[float(v) for v in line.split()] for line in out.decode().splitlines()
                    if line.strip()])
    return wall, WHTEFFICACY * (0.265 * rgb[:, 0] + 0.670 * rgb[:, 1] + 0.065 * rgb[:, 2])


# ------------------------------------------------------------------------------------------


def rms(x, ref) -> float:
    return float(np.sqrt(np.mean((np.asarray(x) / ref - 1) ** 2)))


def run_case(case: Case, work: Path, smoke: bool, ref_size: float | None) -> dict:
    folder = work / case.name.replace(" ", "-").replace("=", "")
    shutil.rmtree(folder, ignore_errors=True)
    text = study_toml(case)
    row: dict = {"case": case.name}
    # the very first run: every cache empty
    t, lux_first, _ = lumijax_run(write(folder / "first", text), folder / "first" / "out",
                                  folder / "jax-empty")
    row["first_s"] = t
    # cold: a different study fills the compilation cache, then this one in a new folder
    shared = folder / "jax-shared"
    lumijax_run(write(folder / "prime", study_toml(prime_case(smoke))),
                folder / "prime" / "out", shared)
    study = write(folder / "study", text)
    row["cold_s"], lux, cold = lumijax_run(study, folder / "study" / "out", shared)
    row["warm_s"], _, warm = lumijax_run(study, folder / "study" / "out", shared)
    row["warm_reused"] = bool(warm["solver"].get("solution_reused"))
    row["patches"] = cold["counts"].get("patches")
    row["columns_solved"] = cold["solver"].get("columns_solved")
    row["operator_cache_hit"] = cold["solver"].get("operator_cache_hit")
    # the iterate loop, as a designer runs it: `lumijax run --quick` once, then one dimmer
    # changed and `lumijax run --quick` again (end to end, CLI included): the second answers
    # from the first's stored solution (docs/results.md, "Dimmer-only reruns")
    row["quick_s"], _, _ = lumijax_run(study, folder / "study" / "quick", shared, quick=True)
    net = sorted({lamp[2] for lamp in case.lamps})[0]
    study.write_text(text.replace(f"[networks.{net}]\ndimmer = 1.0",
                                  f"[networks.{net}]\ndimmer = 0.5"), encoding="utf-8")
    row["dimmer_s"], lux_dimmed, dimmed = lumijax_run(study, folder / "study" / "quick", shared,
                                                      quick=True)
    row["dimmer_reused"] = bool(dimmed["solver"].get("solution_reused"))
    # the rerun's answer against superposition of the cold run's own per-network light
    by_net = {k: np.asarray(v) for k, v in cold["grids"]["points"]["by_network_lux"].items()}
    expect = sum(v * (0.5 if k == net else 1.0) for k, v in by_net.items())
    row["dimmer_vs_cold"] = float(np.max(np.abs(lux_dimmed / expect - 1)))
    row["lumijax_spread"] = float(np.max(np.abs(lux_first / lux - 1)))
    # a real recompute: the first luminaire moved 0.1 m along x (the operator cached: it does
    # not depend on the luminaires; no stored solution has this key)
    (pos, flux, lamp_net), *others = case.lamps
    moved_case = Case(**{**case.__dict__,
                         "lamps": [((pos[0] + 0.1, *pos[1:]), flux, lamp_net), *others]})
    study.write_text(study_toml(moved_case), encoding="utf-8")
    row["moved_s"], lux_moved, moved = lumijax_run(study, folder / "study" / "out", shared)
    row["moved_reused"] = bool(moved["solver"].get("solution_reused"))
    row["moved_operator_cache_hit"] = moved["solver"].get("operator_cache_hit")
    row["moved_change"] = float(np.max(np.abs(lux_moved / lux - 1)))
    # Radiance, same scene and points
    try:
        row["radiance_s"], lux_rad = radiance(case, folder / "radiance", RADIANCE)
    except ImportError:
        print("pyradiance is not installed: no Radiance columns (pip install '.[benchmark]')")
        row["radiance_s"], lux_rad = float("nan"), np.full(len(lux), np.nan)
    # the reference
    size = ref_size or case.ref_size
    ref = reference(case, size)
    coarse = reference(case, size * 1.6)
    how = (f"{ref['orbits']} orbits of {ref['symmetries']} symmetries" if "orbits" in ref
           else f"the box's shadows exact, factors' closure within {ref['closure']:.0e}")
    row["reference"] = (f"exact-kernel numpy, {ref['squares']} squares of {size:.4g} m ({how}): "
                        f"area mean {100 * ref['mean_vs_closed_form']:+.4f} % of Φ/(S(1−ρ)); "
                        f"{100 * rms(coarse['lux'], ref['lux']):.4f} % RMS from a 1.6× "
                        "coarser mesh")
    ref_lux = ref["lux"]
    row["lumijax_err"] = rms(lux, ref_lux)
    row["radiance_err"] = rms(lux_rad, ref_lux)
    return row


def patch_sweep(chosen: list[Case], counts, ref_size: float | None, work: Path,
                accuracies=(0.01,)) -> str:
    """Error against the reference of ``[solver] target_patches`` = each of ``counts`` (the
    default settings otherwise), and the a-posteriori estimate |E_N − E_N/2| beside it; then
    the default rule (``target_patches`` unset) at each of ``accuracies`` (``[solver]
    accuracy``). An accuracy measurement (run in-process; no timing)."""
    import lumijax

    lines = ["| case | target_patches | patches | RMS error | max error | "
             "RMS |E_N − E_N/2| |", "|---|---|---|---|---|---|"]
    for case in chosen:
        lux = {}
        runs = [(str(n), f"target_patches = {n}") for n in counts]
        runs += [(f"rule, accuracy = {a:g}", f"accuracy = {a}") for a in accuracies]
        for key, line in runs:
            case_n = Case(**{**case.__dict__, "solver": f"{line}\ncache = false"})
            path = write(work / "sweep" / case.name / key.replace(" ", "").replace(",", "_"),
                         study_toml(case_n))
            res = lumijax.compute(lumijax.load_study(path))
            lux[key] = (res.grids["points"].illuminance_lux, res.counts.get("patches"))
        size = ref_size or case.ref_size
        ref, what = reference(case, size)["lux"], f"numpy reference ({size:.4g} m)"
        prev = None
        for key, _ in runs:
            e, patches = lux[key]
            est = "" if prev is None or not key.isdigit() else \
                f"{100 * rms(e, lux[prev][0]):.3f} %"
            lines.append(f"| {case.name} ({what}) | {key} | {patches} | "
                         f"{100 * rms(e, ref):.3f} % | {100 * np.max(np.abs(e / ref - 1)):.3f} %"
                         f" | {est} |")
            prev = key
        print("\n".join(lines[-len(runs):]), flush=True)
    return "\n".join(lines)


def machine() -> str:
    import jax

    import lumijax

    return (f"{platform.node()} {platform.machine()}, nproc {os.cpu_count()}, Python "
            f"{platform.python_version()}, lumijax {lumijax.__version__}, jax {jax.__version__}")


def report(rows: list[dict]) -> str:
    head = ("| case | Radiance s | first s (×R) | cold s (×R) | warm s (R/warm) | "
            "moved s (R/moved) | quick s | dimmer s | lumijax RMS | Radiance RMS | accuracy ×")
    lines = [head, "|" + "---|" * 11]
    for r in rows:
        rs = r["radiance_s"]
        lines.append(
            f"| {r['case']} | {rs:.2f} | {r['first_s']:.1f} ({r['first_s'] / rs:.1f}) | "
            f"{r['cold_s']:.1f} ({r['cold_s'] / rs:.2f}) | {r['warm_s']:.1f} "
            f"({rs / r['warm_s']:.2f}) | {r['moved_s']:.1f} ({rs / r['moved_s']:.2f}) | "
            f"{r['quick_s']:.1f} | {r['dimmer_s']:.2f} | "
            f"{100 * r['lumijax_err']:.4f} % | "
            f"{100 * r['radiance_err']:.2f} % | {r['radiance_err'] / r['lumijax_err']:.1f} |")
    lines.append("")
    lines.append("Targets: cold ×R ≤ 1 with accuracy × ≥ 10; first ×R ≤ 3; R/warm ≥ 5; "
                 "dimmer < 2 s. warm: the same study again, answered from the stored "
                 "solution; moved: one luminaire moved 0.1 m, computed again with the "
                 "operator cached.")
    for r in rows:
        lines.append(f"- {r['case']}: reference {r['reference']}; {r['patches']} patches, "
                     f"columns solved "
                     f"{r['columns_solved']}; operator cache hit, cold: "
                     f"{r['operator_cache_hit']}; first vs cold lux differ ≤ "
                     f"{r['lumijax_spread']:.1e}; dimmer rerun reused the stored solution: "
                     f"{r['dimmer_reused']}, differs from the cold run's superposition by ≤ "
                     f"{r['dimmer_vs_cold']:.1e}; warm answered from the stored solution: "
                     f"{r['warm_reused']}; moved computed again: {not r['moved_reused']} "
                     f"(operator cache hit: {r['moved_operator_cache_hit']}; lux changed ≤ "
                     f"{r['moved_change']:.1e})")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--smoke", action="store_true", help="one tiny cube, coarse settings")
    ap.add_argument("--case", action="append", help="run only these cases (names)")
    ap.add_argument("--ref-size", type=float, default=None,
                    help="square size (m) of the numpy reference (default: the cubes 0.05, "
                    "the furnished room 1/6, the office 0.2, smoke 0.8)")
    ap.add_argument("--work", type=Path, default=None, help="keep the studies here")
    ap.add_argument("--patch-sweep", type=int, nargs="*", default=None, metavar="N",
                    help="accuracy only: error against the reference at these target_patches "
                    "(default 500 1000 2000 4000 8000), and the default rule")
    ap.add_argument("--accuracy", type=float, action="append", default=None,
                    help="with --patch-sweep: the rule's [solver] accuracy (default 0.01)")
    args = ap.parse_args(argv)
    ref_size = args.ref_size
    chosen = [c for c in cases(args.smoke) if not args.case or c.name in args.case]
    work = args.work or Path(tempfile.mkdtemp(prefix="lumijax-small-"))
    print(textwrap.dedent(f"""\
        # small studies against Radiance ({time.strftime('%Y-%m-%d %H:%M %Z')})
        {machine()}
        lumijax: `lumijax run STUDY --no-images --no-report`, a new process each; Radiance:
        oconv + rtrace -I {' '.join(RADIANCE)}; work folder {work}
    """))
    if args.patch_sweep is not None:
        counts = args.patch_sweep or [500, 1000, 2000, 4000, 8000]
        print(patch_sweep(chosen, counts, ref_size, work, args.accuracy or [0.01]))
        return 0
    rows = []
    for case in chosen:
        rows.append(run_case(case, work, args.smoke, ref_size))
        print(report(rows[-1:]), flush=True)
    print()
    print(report(rows))
    if args.work is None:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
