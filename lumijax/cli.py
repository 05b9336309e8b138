"""``lumijax`` command line: a thin layer over the Python API.

    lumijax run CONFIG [--out DIR] [--no-images] [--quick] [--no-shadows] [--no-optimise]
                       [--no-report]
    lumijax check CONFIG [--json]
    lumijax report CONFIG [--out DIR] [--no-pictures] [--pdf]
    lumijax view CONFIG [--web] [--host HOST] [--port PORT] [--camera NAME]
    lumijax demo [--out DIR] [--no-report] [--no-images] [--quick] [--timings]

Errors from bad input are printed as one line naming the file and key, without a traceback, and
the exit status is 1 (2 for a bad command line).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path
from typing import NamedTuple

__all__ = ["main"]


def _console():
    from rich.console import Console

    return Console(stderr=False, highlight=False)


def _time_left(elapsed: float, done: float, total: float | None,
               first: tuple[float, float] | None = None) -> float | None:
    """Seconds a stage still needs at the rate it has kept (its work units are of equal cost:
    patches, points, luminaire batches, solve columns); None before any unit is done.

    ``first``: ``(elapsed, done)`` at the stage's first report of work done. Once more is done,
    the rate is taken from there on: the first chunk pays the stage's JIT compilation, which
    would otherwise inflate the rate of every chunk after it. Units of unequal cost still
    mislead it; measured on the courtyard (benchmarks/courtyard.py --progress): direct light
    on patches 14.8 s shown against 15.7 s taken; on the grid points, counted in luminaires,
    27.8 s shown at a quarter with 5.3 s to go, 2.1 s at half-way with 0.2 s (counted in
    photometries before, 6.1 s at half-way with 0.2 s)."""
    if not total or done <= 0 or elapsed <= 0:
        return None
    if first is not None and done > first[1] and elapsed > first[0]:
        return max((elapsed - first[0]) * (total - done) / (done - first[1]), 0.0)
    return max(elapsed * (total - done) / done, 0.0)


def _progress_bar(console, description: str):
    """A rich progress bar that shows only when work takes more than a moment (and only on a
    terminal): one line per stage, with its elapsed time and the time it has left."""
    from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn, TimeElapsedColumn
    from rich.text import Text

    class Left(ProgressColumn):
        def render(self, task) -> Text:
            left = None if task.finished else _time_left(
                task.elapsed or 0.0, task.completed, task.total, first.get(task.id))
            if left is None:
                return Text("")
            m, sec = divmod(int(round(left)), 60)
            return Text(f"{m // 60}:{m % 60:02d}:{sec:02d} left", style="progress.remaining")

    progress = Progress(
        TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(), Left(), console=console, transient=True,
        disable=not console.is_terminal,
    )
    tasks = {"": progress.add_task(description, total=None)}
    current = [""]
    first: dict = {}  # task → (elapsed, done) at its first report of work done

    def update(stage: str, done: int, total: int) -> None:
        task = tasks.get(stage)
        if task is None or stage != current[0] and done < progress.tasks[task].completed:
            # a new stage (or one begun again): its own line, so its rate is its own
            progress.update(tasks[current[0]], visible=False)
            task = tasks[stage] = progress.add_task(stage, total=total)
        elif stage != current[0]:
            progress.update(tasks[current[0]], visible=False)
        current[0] = stage
        progress.update(task, completed=done, total=total, visible=True)
        if done > 0 and task not in first:
            first[task] = (progress.tasks[task].elapsed or 0.0, done)

    return progress, update


def _summary_table(study: str, grids: dict, console) -> None:
    """Each grid's statistics (``grids``: name → GridResult) and whether it meets its target."""
    from rich.table import Table

    from .results import CRITERIA_SLACK

    table = Table(title=f"{study}: illuminance per grid", title_justify="left")
    for col in ("grid", "points", "Eavg (lx)", "Emin (lx)", "Emax (lx)", "U0", "target (lx)"):
        table.add_column(col, justify="left" if col == "grid" else "right")
    for name, g in grids.items():
        s = g.stats
        target = "" if g.target_lux is None else (
            f"{g.target_lux:g} {'✓' if s['avg'] >= g.target_lux * (1 - CRITERIA_SLACK) else '✗'}")
        table.add_row(name, str(len(g.points)), f"{s['avg']:.1f}", f"{s['min']:.1f}",
                      f"{s['max']:.1f}", f"{s['u0']:.2f}", target)
    console.print(table)


def _optimisation_table(opt, console) -> None:
    """Before/after statistics of each grid, and every goal the optimiser could not meet."""
    from rich.table import Table

    table = Table(title=f"optimisation ({opt.solver}, {opt.iterations} steps, objective "
                        f"{opt.objective_history[0]:.4g} → {opt.objective_history[-1]:.4g})",
                  title_justify="left")
    for col in ("grid", "Eavg before", "Eavg after", "Emin before", "Emin after", "U0 before",
                "U0 after"):
        table.add_column(col, justify="left" if col == "grid" else "right")
    for name, b in opt.before.items():
        a = opt.after.get(name, b)
        table.add_row(name, f"{b['avg']:.1f}", f"{a['avg']:.1f}", f"{b['min']:.1f}",
                      f"{a['min']:.1f}", f"{b['u0']:.2f}", f"{a['u0']:.2f}")
    console.print(table)
    console.print("dimmers: " + ", ".join(f"{n} {v:.3f}" for n, v in opt.dimmers.items()))
    if opt.constrained is not None:  # a constrained design: the verdict, prices, conflict
        _constrained_table(opt.constrained, console)
        return
    for line in opt.unmet:
        console.print(f"[yellow]not met:[/yellow] {line}")


def _constrained_table(record: dict, console) -> None:
    """The constrained design's verdict, constraints, prices and any conflict (``lumijax
    run``); an infeasible design is an answer, printed plainly (the run exits 0)."""
    from rich.table import Table

    unit = f" {record['unit']}" if record["unit"] else ""
    console.print(f"verdict: {record['verdict']} — {record['objective']} "
                  f"{record['objective_start']:.4g}{unit} → {record['objective_end']:.4g}{unit} "
                  f"({record['method']}, {record['iterations']} steps; starts: "
                  f"{record['starts']['agreed']} of {record['starts']['count']} agreed)")
    table = Table(title="constraints (exact, at the final design)", title_justify="left")
    for col in ("constraint", "bound", "start", "achieved", "met", "active"):
        table.add_column(col, justify="left" if col == "constraint" else "right")
    for r in record["constraints"]:
        table.add_row(r["label"], f"{r['relation']} {r['bound']:.4g} {r['unit']}".rstrip(),
                      f"{r['start']:.4g}", f"{r['achieved']:.4g}", "✓" if r["met"] else "✗",
                      "yes" if r["active"] else "")
    console.print(table)
    for line in record["prices"]:
        console.print(f"price: {line}")
    inf = record.get("infeasibility")
    if inf is not None:
        console.print("[yellow]infeasible[/yellow]: no setting of the chosen variables meets "
                      "these constraints together:")
        for line in inf["sentences"]:
            console.print(f"  {line}")


def _glare_table(glare, console) -> None:
    """Per observer: the worst UGR, GR and TI over its directions (— where not rated)."""
    from rich.table import Table

    table = Table(title="glare per observer (worst direction)", title_justify="left")
    for col in ("observer", "directions", "UGR", "GR", "worst GR at (deg)", "TI (%)"):
        table.add_column(col, justify="left" if col == "observer" else "right")

    def fmt(v, spec=".1f"):
        return "—" if v is None else format(v, spec)

    for row in glare.summary():
        table.add_row(row["observer"], str(row["directions"]), fmt(row["ugr"]),
                      fmt(row["gr"]), fmt(row["worst_gr_azimuth_deg"], "g"), fmt(row["ti"]))
    console.print(table)


def _run(config: Path, out: Path, *, images: bool, shadows: bool, console,
         cache_dir: Path | None = None, optimise: bool = True, report: bool = True,
         quick: bool = False, timings: bool = False, scheduler: str | None = None) -> int:
    startup = _process_age()  # Python's start and the imports of lumijax, before this call
    if scheduler is not None:  # an address that does not answer is refused now, in seconds
        from .parallel import connect

        scheduler = connect(scheduler)
    t0 = time.perf_counter()  # before the imports: a rerun's budget is end to end
    from ._recorded import read_study
    from .report._write import ResultSet

    # the study's text, read once: a numbers run whose file was recorded by an earlier run
    # answers without the config's schema (lumijax._recorded)
    study_file = read_study(config, {"quick": quick, "shadows": shadows, "optimise": optimise})
    marks: dict[str, float] = {}  # wall time (s) of this run's steps (--timings)
    # The folder is locked from the start (a second run into it stops at once, not after its
    # compute), and every file, the report included, is staged and swapped in as one set.
    with ResultSet(out) as rs:
        if (study_file is not None and study_file.key is not None and not images
                and not report and _recorded_rerun(
                    study_file, config, cache_dir, rs, out, config_s=time.perf_counter() - t0,
                    startup=startup, t0=t0, timings=timings, console=console)):
            return 0
        t = time.perf_counter()
        from .config import load_config, parse_config

        marks["import_config"] = time.perf_counter() - t  # the config's schema (pydantic)
        t = time.perf_counter()
        cfg = (load_config(config) if study_file is None
               else parse_config(study_file.text, source=config))
        if quick:
            cfg = _quick_config(cfg)
        config_s = time.perf_counter() - t
        kept = _kept_solution(cfg, cache_dir, quick=quick, optimise=optimise, shadows=shadows)
        # numbers only (results.json, CSV, patches.vtp) can come from the store; images and
        # the report need the scene, so such a run computes (and stores for the next one)
        if (kept is not None and not images and not report
                and _rerun(kept.folder, kept.key, _dimmers_of(cfg), rs, out,
                           config_s=config_s, startup=startup, t0=t0, timings=timings,
                           console=console)):
            _record(kept, study_file)
            return 0
        t = time.perf_counter()
        _compilation_cache()
        from ._study import compute, study_of
        from .report import write_results

        marks["import"] = time.perf_counter() - t  # JAX and the compute's modules

        study = study_of(cfg, config_s=config_s)
        prewarm = None
        if images or report:  # pyvista, matplotlib, polar curves: while the numbers compute
            from .report._prewarm import start

            prewarm = start(study.scene.photometries if report else None)
        progress, update = _progress_bar(console, "lighting")
        t = time.perf_counter()
        with progress:
            results = compute(study, shadows=shadows, progress=update, cache_dir=cache_dir,
                              scheduler=scheduler)
        marks["compute"] = time.perf_counter() - t
        stored_patches = None  # a full run's patch arrays, figured while the files are written
        if kept is not None:  # the next run that changes only dimmers reads this back
            from ._stored import MAX_PATCH_BYTES

            t = time.perf_counter()
            if quick or results.lighting.coarse.patches is None:
                _keep(results, kept, study_file)
            else:
                from .report._vtk import patch_arrays, patch_bytes
                from .report._write import _in_thread

                if patch_bytes(results.lighting) > MAX_PATCH_BYTES:
                    kept = None  # too large to keep: this study always computes
                else:  # one operator product per network: in a thread, as the maps draw
                    stored_patches = _in_thread(patch_arrays, results.lighting)
            marks["store"] = time.perf_counter() - t
        stages = dict(results.timing_s)  # the compute's (a fit that re-aims computes again)
        if optimise and study.config.optimise is not None:
            from .optimise import optimise as fit

            t = time.perf_counter()
            results = fit(study, results, cache_dir=cache_dir).results
            marks["optimise"] = time.perf_counter() - t
        t = time.perf_counter()
        if prewarm is not None:  # drawing must not start inside a half-done import of pyvista
            prewarm.join()     # or matplotlib (another thread's module is seen half made)
        paths = write_results(results, rs, images=images, timings=marks, patches=not quick,
                              stored_patches=stored_patches)
        marks["write"] = time.perf_counter() - t
        if stored_patches is not None and kept is not None:
            t = time.perf_counter()
            _keep(results, kept, study_file, patches=stored_patches.result())
            marks["store"] += time.perf_counter() - t
        _summary_table(results.study, results.grids, console)
        if results.optimisation is not None:
            _optimisation_table(results.optimisation, console)
        if results.glare is not None:  # the observers' ratings (docs/glare.md)
            _glare_table(results.glare, console)
        if results.compliance is not None:  # the verdict per standard (docs/compliance.md)
            console.print(results.compliance.table(), markup=False, highlight=False)
        if report:
            from .report import write_report

            t1 = time.perf_counter()
            write_report(study, results, rs.staging / "report.html", pictures=images)
            paths["report.html"] = rs.out / "report.html"
            marks["report"] = time.perf_counter() - t1
            console.print(f"report: {paths['report.html']} ({marks['report']:.1f} s)")
        t = time.perf_counter()
        rs.commit()
        marks["write"] += time.perf_counter() - t  # swapping the set in is part of writing
    n = results.counts.get("shadow_rays", 0)
    console.print(
        f"wrote {len(paths)} files to {out} in {time.perf_counter() - t0:.1f} s "
        f"({n:,} shadow rays)"
    )
    if timings:
        _timings_table(stages, marks, startup, time.perf_counter() - t0, console)
    return 0


class _Kept(NamedTuple):
    """A study's stored solution: its cache folder, its key, and the SHA-256 of every path
    its config names (what a record of the study file checks instead: ``lumijax._recorded``)."""

    folder: Path
    key: str
    files: dict[str, str | None]


def _kept_solution(cfg, cache_dir: Path | None, *, quick: bool, optimise: bool,
                   shadows: bool) -> _Kept | None:
    """The study's stored solution (``lumijax._stored``) for a run whose numbers are nothing
    but a superposition of dimmers (no fit, no glare, no compliance verdict: those need the
    scene and JAX) with ``[solver] cache`` on; else None. A ``--quick`` run's solution (grids
    only) and a full run's (grids and patches.vtp's arrays, every wavelength) have different
    keys."""
    if (not cfg.solver.cache or cfg.observers or cfg.compliance is not None
            or (optimise and cfg.optimise is not None)):
        return None
    if cache_dir is None and cfg.source is None:
        return None  # a config from text, with no folder of its own
    folder = _cache_folder(cache_dir, cfg.source)
    from ._stored import solution_key

    files: dict[str, str | None] = {}
    key = solution_key(cfg, shadows=shadows, full=not quick, files=files)
    return _Kept(folder, key, files)


def _cache_folder(cache_dir: Path | None, study: Path) -> Path:
    """Where a study's solutions and records live: ``cache_dir`` if given, else
    ``.lumijax-cache`` beside the study file ``study`` (resolved)."""
    return Path(cache_dir) if cache_dir is not None else study.parent / ".lumijax-cache"


def _dimmers_of(cfg) -> dict[str, float]:
    """The config's dimmer of each network it names."""
    return {name: net.dimmer for name, net in cfg.networks.items()}


def _keep(results, kept: _Kept, study_file, patches=None) -> None:
    """Store ``results``' solution for dimmer-only reruns, and record the study file that
    leads to it (``lumijax._recorded``; not where the store failed: it has warned)."""
    from ._stored import store_solution

    if store_solution(results, kept.folder, kept.key, patches=patches) is not None:
        _record(kept, study_file)


def _record(kept: _Kept, study_file) -> None:
    """Record that the study file leads to ``kept``'s solution, where it has a key."""
    if study_file is not None and study_file.key is not None:
        from ._recorded import write_record

        write_record(kept.folder, study_file.key, kept.key, kept.files)


def _recorded_rerun(study_file, config: Path, cache_dir: Path | None, rs, out: Path, *,
                    config_s: float, startup: float | None, t0: float, timings: bool,
                    console) -> bool:
    """A dimmer-only rerun of a study file recorded by an earlier run: its stored solution
    at the file's dimmers, with no schema, no scene and no JAX; False where no record stands
    for the file (the caller validates the config)."""
    from ._recorded import recorded_solution

    folder = _cache_folder(cache_dir, Path(config).resolve())
    key = recorded_solution(folder, study_file.key)
    return key is not None and _rerun(folder, key, study_file.dimmers, rs, out,
                                      config_s=config_s, startup=startup, t0=t0,
                                      timings=timings, console=console, recorded=True)


def _rerun(folder: Path, key: str, dimmers_by_name: dict[str, float], rs, out: Path, *,
           config_s: float, startup: float | None, t0: float, timings: bool,
           console, recorded: bool = False) -> bool:
    """A dimmer-only rerun: the stored solution superposed at ``dimmers_by_name`` (the
    study's, by network) and written (results.json, the grids' CSV and, for a full run's
    solution, patches.vtp: what a numbers run writes), with no scene, no solve and no JAX;
    False when no solution is stored under the key (the caller computes). ``recorded``: the
    solution was found from the study file's record, its config not validated (results.json
    says so: ``solver.recorded_study``)."""
    from ._stored import load_solution
    from .report._write import write_stored

    t = time.perf_counter()
    stored = load_solution(folder, key)
    if stored is None:
        return False
    dimmers = stored.dimmers_of(dimmers_by_name)
    grids = stored.grid_results(dimmers)
    superpose_s = time.perf_counter() - t
    document = stored.document_at(dimmers, grids, {
        "load": config_s, "config": config_s, "stored_solution": superpose_s,
        "total": superpose_s})
    document["solver"] = {**document["solver"], "solution_reused": True,
                          **({"recorded_study": True} if recorded else {})}
    t = time.perf_counter()
    paths = write_stored(document, grids, rs, patches=stored.patches, dimmers=dimmers)
    _summary_table(document["study"], grids, console)
    rs.commit()
    marks = {"compute": superpose_s, "write": time.perf_counter() - t}
    console.print(f"wrote {len(paths)} files to {out} in {time.perf_counter() - t0:.1f} s "
                  "(dimmers only: the stored solution superposed, nothing computed)")
    if timings:
        _timings_table({"config": config_s}, marks, startup, time.perf_counter() - t0, console)
    return True


def _process_age() -> float | None:
    """Seconds since this process started (Linux's /proc), or None where that is unknown."""
    import os

    try:
        stat = Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
        uptime = float(Path("/proc/uptime").read_text().split()[0])
        return max(uptime - int(stat[19]) / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError):
        return None


#: ``lumijax run --timings``: rows of the table, each the sum of these results.json
#: ``timing_s`` keys (docs/results.md); the CLI adds start-up, optimise, images, write, report.
TIMING_ROWS = (
    ("config", ("config",)), ("scene", ("scene",)), ("meshing", ("mesh",)),
    ("direct light", ("direct_points", "direct_patches")),
    ("operator", ("memory_bound", "partition", "operator", "sampled_noise")),
    ("spectral sampling", ("spectral_sampling",)), ("solve", ("solve",)),
    ("final gather on patches (sampled)", ("sampled_final_gather",)),
    ("gather", ("gather_rays", "gather", "final_gather")),
)


def _timings_table(timing: dict, marks: dict, startup: float | None, run_s: float,
                   console) -> None:
    """Where the run's time went: one row per stage (s and % of the total)."""
    from rich.table import Table

    rows: list[tuple[str, float]] = []
    if startup is not None:
        rows.append(("start-up + import", startup))
    if "import_config" in marks:
        rows.append(("import the config schema", marks["import_config"]))
    if "import" in marks:
        rows.append(("import JAX and the compute", marks["import"]))
    for label, keys in TIMING_ROWS:
        if any(k in timing for k in keys):
            rows.append((label, sum(timing.get(k, 0.0) for k in keys)))
    staged = sum(v for label, v in rows[(startup is not None) + ("import" in marks)
                                        + ("import_config" in marks):]
                 if label not in ("config", "scene"))
    rows.append(("compute, rest (grids, glare, compliance)", marks["compute"] - staged))
    if "store" in marks:
        rows.append(("store (for dimmer-only reruns)", marks["store"]))
    for key in ("optimise", "images"):
        if key in marks:
            rows.append((key, marks[key]))
    rows.append(("write", marks["write"] - marks.get("images", 0.0)))
    if "report" in marks:
        rows.append(("report", marks["report"]))
    total = run_s + (startup or 0.0)
    rows.append(("other (locking, tables)", total - sum(v for _, v in rows)))
    table = Table(title="where the time went (lumijax run --timings)", title_justify="left")
    for col in ("stage", "s", "%"):
        table.add_column(col, justify="left" if col == "stage" else "right")
    for label, v in rows:
        table.add_row(label, f"{v:.2f}", f"{100 * v / total:.0f}" if total > 0 else "")
    table.add_row("total", f"{total:.2f}", "100")
    console.print(table)


def _quick_config(cfg):
    """The config with the photometric solve (``[solver] spectral_samples = 0``): lux as before
    for grey rooms, no colour (XYZ, CCT), and one wavelength instead of 16 to solve and gather
    (docs/radiosity.md, "Distinct columns"; what ``--quick`` trades: docs/results.md)."""
    solver = cfg.solver.model_copy(update={"spectral_samples": 0})
    return cfg.model_copy(update={"solver": solver})


def _compilation_cache() -> None:
    """JAX's persistent compilation cache on, before anything compiles (warns, never raises);
    called where a command first needs JAX, so a dimmer-only rerun never imports it."""
    from ._jit_cache import enable_compilation_cache

    enable_compilation_cache()


def _report(config: Path, out: Path, *, pictures: bool, console, pdf: bool = False) -> int:
    """Compute the study as configured (the operator cache makes this quick) and write
    ``report.html`` (and, with ``pdf``, ``report.pdf``); ``lumijax run`` writes the same report
    after results and optimisation."""
    from ._atomic import FolderLock, is_temporary, remove_orphans
    from ._study import compute, load_study
    from .report import write_report
    from .report._write import KEPT_NAMES, SET_NAMES

    if pdf:
        from .report._pdf import require_pdf

        require_pdf()  # fail before the compute, naming what to install
    t0 = time.perf_counter()
    # report.html alone is replaced (one atomic rename), under the folder's lock; the rest of
    # a run's set, if any, stays as it was (docs/results.md, "Atomic writing")
    with FolderLock(out):
        remove_orphans(out)  # a report temporary of a killed run
        if out.is_dir() and (names := sorted(
                p.name for p in out.iterdir() if p.name not in SET_NAMES
                and p.name not in KEPT_NAMES and not is_temporary(p.name))):
            from .errors import OutputError

            raise OutputError(f"holds {names[0]!r}, which lumijax did not write; give an empty "
                              "or a new --out", file=out)
        study = load_study(config)
        progress, update = _progress_bar(console, "lighting")
        with progress:
            results = compute(study, progress=update)
        path = write_report(study, results, out / "report.html", pictures=pictures,
                            pdf=out / "report.pdf" if pdf else None)
    console.print(f"wrote {path}{' and report.pdf' if pdf else ''} in "
                  f"{time.perf_counter() - t0:.1f} s")
    return 0


def _view(config: Path, *, web: bool, host: str, port: int, camera: str | None,
          console) -> int:
    """The live dimmer viewer: a desktop window, or (``web``) a page served on ``host:port``."""
    from ._study import compute, load_study
    from .errors import OutputError

    if web:
        from .view._web import _require_trame

        _require_trame()  # fail before the compute, naming the extra to install
    study = load_study(config)
    cam = None
    if camera is not None:
        from .report import cameras_of

        cams = {c.name: c for c in cameras_of(study)}
        if camera not in cams:
            raise OutputError(f"no camera {camera!r}; cameras: {', '.join(cams)}",
                              file=config, key="cameras")
        cam = cams[camera]
    progress, update = _progress_bar(console, "lighting")
    with progress:
        results = compute(study, progress=update)
    from .view import build_viewer

    if web:
        from .view import serve

        viewer = build_viewer(study, results, off_screen=True, camera=cam, widgets=False)
        console.print("serving the viewer (Ctrl-C to stop)")
        serve(viewer, host=host, port=port)
        return 0
    import os

    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY")
                                                 or os.environ.get("WAYLAND_DISPLAY")):
        raise OutputError("no display to open a window on (DISPLAY is not set); use "
                          "'lumijax view --web' and open the address it prints")
    try:
        viewer = build_viewer(study, results, camera=cam)
        viewer.plotter.show()
    except RuntimeError as e:  # no display: VTK cannot open a window
        raise OutputError(f"cannot open a window ({e}); try 'lumijax view --web'") from None
    return 0


def _check(config: Path, *, as_json: bool, console) -> int:
    from ._study import check_memory, load_study

    study = load_study(config)
    estimate = check_memory(study)  # refuses an operator that cannot fit (SolveError)
    summary = study.summary()
    if as_json:
        print(json.dumps({k: v for k, v in summary.items() if k != "study"}, indent=1))
        return 0
    from rich.table import Table

    console.print(f"[bold]{summary['study']}[/bold]: {config}")
    console.print(
        f"{summary['triangles']:,} triangles, {summary['luminaires']:,} luminaires, "
        f"{summary['networks']} networks, {summary['grid_points']:,} grid points"
    )
    table = Table(title="photometry", title_justify="left")
    for col in ("name", "rated (lm)", "integrated (lm)"):
        table.add_column(col, justify="left" if col == "name" else "right")
    for name, p in summary["photometry"].items():
        rated = "—" if p["rated_lm"] is None else f"{p['rated_lm']:.1f}"
        table.add_row(name, rated, f"{p['integrated_lm']:.1f}")
    console.print(table)
    if estimate is not None:
        console.print(f"transport operator: at most {estimate.stored_bytes / 2**20:,.0f} MiB "
                      f"for {estimate.patches:,} patches")
    console.print("config is valid")
    return 0


def _ugr_table(path: Path, *, spacing_h: float, lamp_flux_lm, as_json: bool, console) -> int:
    """Print a luminaire file's CIE 190 UGR table: rooms down, reflectances across, viewed
    crosswise then endwise (lumijax.glare.ugr_table; docs/glare.md)."""
    import json

    from rich.table import Table

    from .glare import ugr_table
    from .photometry import read_photometry

    t = ugr_table(read_photometry(path), spacing_h=spacing_h, lamp_flux_lm=lamp_flux_lm)
    if as_json:
        print(json.dumps(t.to_dict(), indent=2))
        return 0
    for o, orientation in enumerate(t.orientations):
        table = Table(title=f"{t.name}: UGR (CIE 190) viewed {orientation}, S = "
                      f"{t.spacing_h:g} H, lamp flux {t.lamp_flux_lm:g} lm", title_justify="left")
        table.add_column("X", justify="right")
        table.add_column("Y", justify="right")
        for c, w, f in t.reflectances:
            table.add_column(f"{100 * c:.0f}/{100 * w:.0f}/{100 * f:.0f}", justify="right")
        for r, (x, y) in enumerate(t.rooms):
            table.add_row(f"{x:g}H", f"{y:g}H", *(f"{v:.1f}" for v in t.ugr[r, o]))
        console.print(table)
    console.print("X across the line of sight, Y along it; reflectances ceiling/walls/floor; "
                  "crosswise: the luminous length across the line of sight")
    return 0


def default_study_path() -> Path:
    """The bundled default study (a small courtyard facade)."""
    return Path(__file__).parent / "data" / "studies" / "default" / "study.toml"


def _parser() -> argparse.ArgumentParser:
    from . import __version__

    p = argparse.ArgumentParser(
        prog="lumijax", description="Differentiable radiosity lighting design for architecture."
    )
    p.add_argument("--version", action="version", version=f"lumijax {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="compute a study and write results.json, CSV and images")
    run.add_argument("config", type=Path)
    run.add_argument("--out", type=Path, default=None, help="output folder (default: CONFIG's "
                     "name + '-out' beside it)")
    run.add_argument("--no-images", action="store_true",
                     help="numbers only: no false-colour images, no pictures in report.html")
    run.add_argument("--quick", action="store_true",
                     help="the iterate loop: --no-images --no-report and the photometric solve "
                     "(lux only, no colour; docs/results.md)")
    run.add_argument("--no-shadows", action="store_true", help="ignore occlusion (photometry only)")
    run.add_argument("--no-optimise", action="store_true",
                     help="skip the [optimise] step of the config (docs/optimise.md)")
    run.add_argument("--no-report", action="store_true", help="do not write report.html")
    run.add_argument("--timings", action="store_true", help="print where the time went")
    run.add_argument("--scheduler", default=None, metavar="tcp://HOST:8786",
                     help="run direct light, the transport build and the final gather on this "
                          "Dask scheduler's workers (docs/parallel.md)")
    report = sub.add_parser("report", help="compute a study and write report.html")
    report.add_argument("config", type=Path)
    report.add_argument("--out", type=Path, default=None, help="output folder (default: "
                        "CONFIG's name + '-out' beside it)")
    report.add_argument("--no-pictures", action="store_true",
                        help="tables only: no views, maps or plots (fast)")
    report.add_argument("--pdf", action="store_true",
                        help="also write report.pdf (needs the lumijax[pdf] extra: WeasyPrint)")
    view = sub.add_parser("view", help="the live dimmer viewer (one slider per network)")
    view.add_argument("config", type=Path)
    view.add_argument("--web", action="store_true",
                      help="serve the viewer to a browser (needs: pip install 'lumijax[view]')")
    view.add_argument("--host", default="127.0.0.1", help="address to serve on (--web)")
    view.add_argument("--port", type=int, default=0, help="port (--web); 0: a free one")
    view.add_argument("--camera", default=None, help="a [cameras.NAME] to start from")
    check = sub.add_parser("check", help="validate a config and print what it holds")
    check.add_argument("config", type=Path)
    check.add_argument("--json", action="store_true", help="print a JSON summary")
    ugr = sub.add_parser("ugr-table", help="a luminaire file's CIE 190 UGR table (as data "
                         "sheets print it)")
    ugr.add_argument("file", type=Path, help="an IES or EULUMDAT file with luminous dimensions")
    ugr.add_argument("--spacing", type=float, default=0.25,
                     help="luminaire spacing S / H (default 0.25, as catalogues; CIE 190's "
                     "standard condition is 1)")
    ugr.add_argument("--lamp-flux", type=float, default=None,
                     help="lamp flux (lm) the table is for (default: the file's own)")
    ugr.add_argument("--json", action="store_true", help="print the table as JSON")
    demo = sub.add_parser("demo", help="run the bundled default study")
    demo.add_argument("--out", type=Path, default=Path("lumijax-demo"))
    demo.add_argument("--no-report", action="store_true", help="do not write report.html")
    demo.add_argument("--no-images", action="store_true", help="numbers only (as run)")
    demo.add_argument("--quick", action="store_true", help="as run --quick")
    demo.add_argument("--timings", action="store_true", help="as run --timings")
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``lumijax`` command; returns the exit status."""
    from .errors import LumijaxError, LumijaxWarning

    args = _parser().parse_args(argv)
    console = _console()

    def show_warning(message, category, filename, lineno, file=None, line=None):
        from rich.markup import escape  # "[solver] method" is text, not a style tag

        console.print(f"[yellow]warning:[/yellow] {escape(str(message))}")

    warnings.showwarning = show_warning
    warnings.simplefilter("default", LumijaxWarning)
    try:
        if args.command in ("check", "view", "report"):
            _compilation_cache()
        if args.command == "check":
            return _check(args.config, as_json=args.json, console=console)
        if args.command == "demo":
            console.print(f"lumijax demo: {default_study_path()}")
            # the bundled study may sit in a read-only install: cache beside the outputs
            return _run(default_study_path(), args.out,
                        images=not (args.no_images or args.quick), shadows=True,
                        console=console, cache_dir=args.out / ".lumijax-cache",
                        report=not (args.no_report or args.quick), quick=args.quick,
                        timings=args.timings)
        if args.command == "ugr-table":
            return _ugr_table(args.file, spacing_h=args.spacing, lamp_flux_lm=args.lamp_flux,
                              as_json=args.json, console=console)
        if args.command == "view":
            return _view(args.config, web=args.web, host=args.host, port=args.port,
                         camera=args.camera, console=console)
        out = args.out if args.out is not None else args.config.with_name(
            args.config.stem + "-out")
        if args.command == "report":
            return _report(args.config, out, pictures=not args.no_pictures, console=console,
                           pdf=args.pdf)
        return _run(args.config, out, images=not (args.no_images or args.quick),
                    shadows=not args.no_shadows, optimise=not args.no_optimise,
                    report=not (args.no_report or args.quick), quick=args.quick,
                    timings=args.timings, console=console, scheduler=args.scheduler)
    except LumijaxError as e:
        print(f"lumijax: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("lumijax: interrupted; nothing was written", file=sys.stderr)
        return 130


def entry() -> None:
    """The ``lumijax`` command: :func:`main`, then exit with its status.

    Before the interpreter exits, every object is frozen out of the garbage collector
    (``gc.freeze``): its final collections would otherwise walk all that JAX and the compute
    made, 0.3–0.7 s of a small study's 3 s run (benchmarks/RESULTS.md, session 10). The
    memory is the OS's to reclaim. Not in :func:`main`, which tests and scripts call.
    """
    import gc

    status = main()
    gc.freeze()
    sys.exit(status)


if __name__ == "__main__":
    entry()
