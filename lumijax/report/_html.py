"""``report.html``: one self-contained file a lighting designer can hand to a client.

Everything is inline: CSS in the page, pictures as base64 PNG data URIs. The page is a jinja2
template (``templates/report.html.j2``); this module gathers what it shows: the study's summary,
per-grid statistics against their targets, per-network dimmer, flux and power, the views of the
cameras, each grid's picture (an iso-lux map, a profile along a path, or a plan of its points)
and, for grids that are not mapped, their values, each network alone, the luminaire schedule, the
photometry and, after an optimisation, before and after. Sections of other layers (glare,
compliance) come from :func:`section_builders` as :class:`ReportSection` values.
"""

from __future__ import annotations

import base64
import datetime as _dt
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import atomic_path
from .._study import Study
from ..config._schema import _GridBase
from ..design import Design
from ..errors import OutputError
from ..results import CRITERIA_SLACK, GridResult, Results
from ._png import figure_png
from ._sections import ReportSection

__all__ = ["write_report", "report_context", "render_report", "grid_criteria",
           "section_builders"]

#: Pixel size of the pictures in the report (width, height).
VIEW_SIZE = (1280, 800)
MAP_SIZE = (1200, 820)


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _fmt(x: float | None, digits: int = 3) -> str:
    if x is None:
        return "—"
    x = float(x)
    if x == 0:
        return "0"
    if abs(x) >= 100:
        return f"{x:,.0f}"
    return f"{x:.{digits}g}"


def grid_criteria(grid_cfg, stats: dict[str, float]) -> list[dict[str, Any]]:
    """The grid's design criteria from its config and whether its statistics meet them:
    ``target_lux`` (Eavg ≥), ``min_lux`` (Emin ≥), ``max_lux`` (Emax ≤), ``uniformity_min``
    (U0 ≥). Keys a config does not have are skipped."""
    out = []
    checks = (("target_lux", "Eavg", "avg", ">=", "lx"), ("min_lux", "Emin", "min", ">=", "lx"),
              ("max_lux", "Emax", "max", "<=", "lx"), ("uniformity_min", "U0", "u0", ">=", ""))
    if grid_cfg is None:
        return []
    given = {"target_lux": grid_cfg.target_lux, "min_lux": grid_cfg.min_lux,
             "max_lux": grid_cfg.max_lux, "uniformity_min": grid_cfg.uniformity_min}
    for key, label, stat, op, unit in checks:
        wanted = given[key]
        if wanted is None:
            continue
        got = stats[stat]
        met = (got >= wanted * (1 - CRITERIA_SLACK) if op == ">="
               else got <= wanted * (1 + CRITERIA_SLACK))
        out.append({"key": key, "label": label, "op": "≥" if op == ">=" else "≤",
                    "wanted": float(wanted), "achieved": float(got), "unit": unit,
                    "met": bool(met),
                    "text": f"{label} {'≥' if op == '>=' else '≤'} {_fmt(wanted)}"
                            + (f" {unit}" if unit else "")})
    return out


def section_builders() -> list[Callable[[Study, Results, bool], list[ReportSection]]]:
    """The builders of the sections other layers add, in order: each is called as
    ``builder(study, results, pictures)`` and returns its :class:`ReportSection` values (none
    when the study has nothing for it). A layer's report module adds its builder here."""
    from ._compliance import compliance_sections
    from ._glare import glare_sections

    return [compliance_sections, glare_sections]


def _grid_configs(study: Study) -> dict[str, _GridBase]:
    return {g.name: g for g in study.config.grids}


def _optimisation_dict(results: Results) -> dict[str, Any] | None:
    opt = results.optimisation
    return None if opt is None else opt.to_dict()


def _convergence_png(history) -> bytes | None:
    h = np.asarray([float(x) for x in history if x is not None], np.float64)
    if h.size < 2:
        return None
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.0), dpi=110)
    positive = np.all(h > 0)
    ax.plot(np.arange(h.size), h, color="#1f4e79", lw=1.8, marker="o", ms=3)
    if positive and h.max() / h.min() > 20:
        ax.set_yscale("log")
    ax.set_xlabel("iteration")
    ax.set_ylabel("objective")
    ax.grid(color="#dddddd", lw=0.6)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    fig.tight_layout()
    png = figure_png(fig)
    plt.close(fig)
    return png


def _optimisation_section(opt: dict, study, results) -> dict[str, Any]:
    before, after = opt.get("before", {}) or {}, opt.get("after", {}) or {}
    grids = []
    for name in list(before) + [n for n in after if n not in before]:
        b, a = before.get(name, {}), after.get(name, {})
        grids.append({"name": name, "rows": [
            (label, _fmt(b.get(k)), _fmt(a.get(k)), unit)
            for label, k, unit in (("Eavg", "avg", "lx"), ("Emin", "min", "lx"),
                                   ("Emax", "max", "lx"), ("U0", "u0", ""), ("Ud", "ud", ""))
            if k in b or k in a]})
    # before: the config's design, where the fit started; after: the fit's record, which is
    # read from the optimised Design (the results' own, results.design)
    start = study.design.dimmer_of()
    dimmers = [{"name": k, "before": _fmt(start.get(k)), "after": _fmt(v)}
               for k, v in (opt.get("dimmers") or {}).items()]
    aims = [{"name": k, **{a: _fmt(v.get(a)) for a in ("tilt", "pan", "spin")}}
            for k, v in (opt.get("aims") or {}).items()]
    targets = [{**t, "wanted": _fmt(t.get("wanted")), "achieved": _fmt(t.get("achieved"))}
               for t in (opt.get("targets") or [])]
    png = _convergence_png(opt.get("objective_history") or [])
    hist = opt.get("objective_history") or []
    return {
        "solver": opt.get("solver", ""), "variables": ", ".join(opt.get("variables") or []),
        "iterations": opt.get("iterations", len(hist)), "converged": opt.get("converged"),
        "objective_start": _fmt(hist[0]) if hist else "—",
        "objective_end": _fmt(hist[-1]) if hist else "—",
        "grids": grids, "dimmers": dimmers, "aims": aims, "targets": targets,
        "unmet": list(opt.get("unmet") or []),
        "convergence": None if png is None else _data_uri(png),
    }


def _pictures(study: Study, results: Results, cameras, timings) -> tuple[list, list, dict]:
    """The views of the cameras, notes, and each network's own picture."""
    from ._camera import cameras_of
    from ._png import png_bytes
    from ._surfaces import surface_light
    from ._views import render_falsecolour_view, render_realistic

    views: list = []
    notes: list = []
    lighting = results.lighting
    if lighting is None:
        return views, ["No surfaces to draw: the results carry no lighting solution."], {}
    cams = cameras if cameras is not None else cameras_of(study)
    if not cams:
        return views, notes, {}
    t0 = time.perf_counter()
    need_e = any(c.kind == "falsecolour" and c.quantity == "illuminance" for c in cams)
    surface = surface_light(results, illuminance=need_e)
    dimmers = np.asarray(results.design.dimmers, np.float64)
    scene = study.scene
    if results.design.same_study(Design.of(scene)):  # the fittings drawn as designed
        scene = scene.with_design(results.design)
    timings["surfaces"] = time.perf_counter() - t0
    auto = len(cams) == 1 and cams[0].name == "overview" and not study.config.cameras
    for cam in cams:
        t1 = time.perf_counter()
        kinds = ["realistic", "falsecolour"] if auto else [cam.kind]
        for kind in kinds:
            if kind == "realistic":
                img, ev = render_realistic(surface, cam, dimmers, scene)
                caption = (f"Realistic view “{cam.name}”: {cam.fov_deg:g}° field of view, "
                           f"exposure EV {ev:.1f} (ISO 100"
                           f"{', metered' if cam.exposure_ev is None else ''}), "
                           f"{cam.tone} tone curve.")
            else:
                q = cam.quantity
                vals = surface.luminance_at(dimmers) if q == "luminance" else (
                    surface.illuminance_at(dimmers))
                img, (lo, hi) = render_falsecolour_view(
                    surface, vals, cam, quantity=q, scale=cam.scale, levels=cam.levels,
                    title=f"{'Luminance' if q == 'luminance' else 'Illuminance'} — {cam.name}")
                unit = "cd/m²" if q == "luminance" else "lx"
                caption = (f"False-colour {q} “{cam.name}”, {cam.scale} scale "
                           f"{_fmt(lo)}–{_fmt(hi)} {unit}.")
            views.append({"name": cam.name, "kind": kind, "src": _data_uri(png_bytes(img)),
                          "caption": caption})
        timings[f"view:{cam.name}"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    alone = _network_views(surface, cams, dimmers, scene, results)
    timings["network_views"] = time.perf_counter() - t1
    return views, notes, alone


#: Width (px) of each network's own picture; at most this many networks are pictured.
NETWORK_VIEW_WIDTH = 560
MAX_NETWORK_VIEWS = 24


def _network_views(surface, cams, dimmers, scene, results) -> dict[str, dict[str, str]]:
    """Each network alone at dimmer 1, through the first realistic camera (or the first one),
    at the exposure metered for the whole design, so each picture is as bright as that
    network's light is beside the others'."""
    from ._png import png_bytes
    from ._views import auto_exposure, render_realistic

    cam = next((c for c in cams if c.kind == "realistic"), cams[0])
    w, h = cam.size
    small = cam.replace(size=(NETWORK_VIEW_WIDTH, max(1, round(NETWORK_VIEW_WIDTH * h / w))))
    ev = cam.exposure_ev if cam.exposure_ev is not None else auto_exposure(surface, dimmers, cam)
    out = {}
    names = list(results.networks)[:MAX_NETWORK_VIEWS]
    for k, name in enumerate(names):
        alone = np.zeros(len(dimmers))
        alone[k] = 1.0
        img, _ = render_realistic(surface, small, alone, scene, ev=ev, tone=cam.tone)
        out[name] = {"src": _data_uri(png_bytes(img)),
                     "caption": f"{name} alone at dimmer 100 % (the design has it at "
                                f"{100 * dimmers[k]:.0f} %), through “{cam.name}” at the whole "
                                f"design's exposure, EV {ev:.1f}."}
    return out


def _grid_pictures(study: Study, results: Results, timings) -> dict[str, dict[str, Any]]:
    """Each grid's picture (``_gridplots``): ``{name: {"kind", "src", "caption"}}``."""
    from ._gridplots import safe_grid_picture

    gcfg = _grid_configs(study)
    aims = [(lum.position, lum.axis) for lum in study.scene.luminaires]
    out = {}
    t0 = time.perf_counter()
    for name, g in results.grids.items():
        pic = safe_grid_picture(g, gcfg.get(name), title=f"{results.study} — {name}",
                                luminaires=aims, size=MAP_SIZE)
        if pic is not None:
            out[name] = {"kind": pic.kind, "src": _data_uri(pic.png), "caption": pic.caption}
    timings["grid_pictures"] = time.perf_counter() - t0
    return out


#: Grids that are not mapped list their points' values, up to this many rows.
MAX_VALUE_ROWS = 120


def _point_values(g: GridResult, cfg: _GridBase | None) -> dict[str, Any]:
    """The values of a grid's points, each against the grid's point limits (min/max lux)."""
    lux = np.asarray(g.illuminance_lux, np.float64)
    lo = None if cfg is None else cfg.min_lux
    hi = None if cfg is None else cfg.max_lux
    rows = []
    for i in range(min(len(lux), MAX_VALUE_ROWS)):
        ok = (lo is None or lux[i] >= lo * (1 - CRITERIA_SLACK)) and (
            hi is None or lux[i] <= hi * (1 + CRITERIA_SLACK))
        rows.append({"i": i + 1, "point": ", ".join(f"{x:.3g}" for x in g.points[i]),
                     "normal": ", ".join(f"{x:.2g}" for x in g.normals[i]),
                     "lux": _fmt(lux[i]), "ok": bool(ok), "judged": lo is not None
                     or hi is not None})
    return {"rows": rows, "more": max(0, len(lux) - MAX_VALUE_ROWS)}


def _schedule_context(study: Study) -> dict[str, Any]:
    from ._schedule import luminaire_schedule

    s = luminaire_schedule(study)
    rows = [{"name": r.name, "count": r.count, "manufacturer": r.manufacturer or "—",
             "catalogue": r.catalogue or "—", "description": r.description, "lamp": r.lamp or "—",
             "flux": _fmt(r.flux_lm), "watts": _fmt(r.watts),
             "mf": ", ".join(f"{m:.2f}" for m in r.maintenance_factors),
             "networks": ", ".join(r.networks), "total_flux": _fmt(r.total_flux_lm),
             "maintained": _fmt(r.maintained_flux_lm), "total_watts": _fmt(r.total_watts)}
            for r in s.rows]
    return {"rows": rows, "count": s.count, "total_flux": _fmt(s.total_flux_lm),
            "maintained": _fmt(s.maintained_flux_lm), "total_watts": _fmt(s.total_watts),
            "complete_power": s.complete_power}


def _network_pages(study: Study, results: Results) -> list[dict[str, Any]]:
    from ._networks import network_pages

    return [{"name": p.name, "description": p.description,
             "dimmer": f"{100 * p.dimmer:.0f} %", "count": len(p.luminaires),
             "luminaires": ", ".join(p.luminaires[:12])
             + (f" and {len(p.luminaires) - 12} more" if len(p.luminaires) > 12 else ""),
             "photometries": ", ".join(p.photometries), "flux_full": _fmt(p.flux_full_lm),
             "flux": _fmt(p.flux_full_lm * p.dimmer),
             "lit": [{"grid": x.grid, "avg_full": _fmt(x.avg_full), "max_full": _fmt(x.max_full),
                      "avg": _fmt(x.avg), "max": _fmt(x.max),
                      "share": f"{100 * x.share:.0f} %"} for x in p.lit],
             "unlit": ", ".join(p.unlit)}
            for p in network_pages(study, results)]


def report_context(study: Study, results: Results, *, cameras=None, pictures: bool = True,
                   config_path: str | Path | None = None) -> dict[str, Any]:
    """Everything ``report.html`` shows, as plain values (numbers already formatted)."""
    from .._version import __version__
    from ._polar import beam_angle_deg, polar_plot

    timings: dict[str, float] = {}
    gcfg = _grid_configs(study)
    ncfg = study.config.networks
    grids = []
    n_met = n_crit = 0
    for name, g in results.grids.items():
        s = g.stats
        crit = grid_criteria(gcfg.get(name), s)
        n_crit += len(crit)
        n_met += sum(c["met"] for c in crit)
        grids.append({
            "name": name, "points": len(g.points),
            "shape": "×".join(str(x) for x in g.shape) if g.shape else "points",
            "avg": _fmt(s["avg"]), "min": _fmt(s["min"]), "max": _fmt(s["max"]),
            "u0": f"{s['u0']:.2f}", "ud": f"{s['ud']:.2f}", "criteria": crit,
            "raw": s, "point_values": None,
        })
    networks, total_flux, total_power, any_power = [], 0.0, 0.0, False
    design_dimmers = results.design.dimmer_of()
    for name, n in results.networks.items():
        dimmer = design_dimmers[name]
        cfg = ncfg.get(name)
        power_w = None if cfg is None else cfg.power_w
        any_power |= power_w is not None
        flux = float(n["flux_lm"])
        total_flux += flux * dimmer
        if power_w is not None:
            total_power += power_w * dimmer
        networks.append({
            "name": name, "description": "" if cfg is None else cfg.description,
            "count": len(n["luminaires"]), "dimmer": f"{100 * dimmer:.0f} %",
            "dimmer_value": dimmer, "flux_full": _fmt(flux), "flux": _fmt(flux * dimmer),
            "power_full": None if power_w is None else _fmt(power_w),
            "power": None if power_w is None else _fmt(power_w * dimmer),
        })
    photometry = []
    t0 = time.perf_counter()
    for name, p in study.scene.photometries.items():
        d = p.distribution
        photometry.append({
            "name": name, "file": p.source.name if p.source is not None else p.format,
            "rated": _fmt(p.rated_lm), "integrated": _fmt(p.integrated_lm),
            # the peak in numpy: an eager jnp.max compiles a kernel per table shape
            "peak": _fmt(float(np.max(np.asarray(d.candela)))),
            "beam": f"{beam_angle_deg(d, 0):.0f}° × {beam_angle_deg(d, 90):.0f}°",
            "count": sum(lum.photometry == name for lum in study.scene.luminaires),
            "src": _data_uri(polar_plot(p, name)) if pictures else None,
        })
    timings["photometry"] = time.perf_counter() - t0
    views, notes, alone = (_pictures(study, results, cameras, timings) if pictures
                           else ([], [], {}))
    drawn = _grid_pictures(study, results, timings) if pictures else {}
    from ._gridplots import picture_kind

    for g in grids:
        res = results.grids[g["name"]]
        g["picture"] = drawn.get(g["name"])
        g["map"] = None if g["picture"] is None else g["picture"]["src"]
        if picture_kind(res.points, res.normals, res.shape) != "map":
            g["point_values"] = _point_values(res, gcfg.get(g["name"]))
    opt = _optimisation_dict(results)
    extra = [sec for build in section_builders() for sec in build(study, results, pictures)]
    sc = study.scene
    solver = results.solver or {}
    return {
        "title": results.study, "description": study.config.study.description,
        "config": str(config_path or study.config.source or ""),
        "generated": _dt.datetime.now().strftime("%Y-%m-%d %H:%M"), "version": __version__,
        "summary": {
            "luminaires": len(sc.luminaires) + len(sc.area_sources),
            "networks": len(sc.networks), "grids": len(results.grids),
            "points": sum(len(g.points) for g in results.grids.values()),
            "flux": _fmt(total_flux), "power": _fmt(total_power) if any_power else None,
            "criteria_met": n_met, "criteria": n_crit,
            "patches": None if results.lighting is None or results.lighting.coarse.patches is None
            else results.lighting.coarse.patches.n,
            "compute_s": f"{results.timing_s.get('total', 0.0):.1f}",
            "noise": _noise_text(solver.get("sampled_noise"), solver.get("final_gather_rays")),
        },
        "grids": grids, "networks": networks, "any_power": any_power,
        "photometry": photometry, "views": views, "notes": notes,
        "optimisation": None if opt is None else _optimisation_section(opt, study, results),
        "solver": {k: v for k, v in solver.items() if k != "wavelengths_nm"},
        "timings": timings,
        "schedule": _schedule_context(study),
        "network_pages": [{**n, "picture": alone.get(n["name"])}
                          for n in _network_pages(study, results)],
        "first_sections": [x for x in extra if x.first],
        "sections": [x for x in extra if not x.first],
    }


def _noise_text(noise: dict | None, final_rays: int | None = None) -> str | None:
    """The sampled transport's own noise as the report's footer states it (docs/radiosity.md,
    "Own noise, stated with every run"), its final gather's where it has one; None for the
    block operator."""
    if not noise:
        return None
    points = noise.get("points_rms")
    rays = f"{noise['rays_per_patch']:,} rays a patch"
    if final_rays is not None:
        rays = f"a final gather of {rays}"
    return (f"{rays}, own noise ≈ {100 * noise['rms']:.1f} % "
            "RMS per patch" + ("" if points is None else
                               f", ≈ {100 * points:.1f} % at the grid points"))


def _css_string(text: str) -> str:
    """``text`` as a CSS string literal (for the pages' running heads)."""
    return '"' + str(text).replace("\\", "\\\\").replace('"', '\\"').replace(
        "\n", " ") + '"'


def render_report(context: dict[str, Any]) -> str:
    """The HTML of a report context (the packaged jinja2 template)."""
    import jinja2
    from markupsafe import Markup

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("lumijax.report", "templates"),
        autoescape=jinja2.select_autoescape(["html", "j2"]),
        undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
    )
    env.filters["css_string"] = lambda t: Markup(_css_string(t).replace("<", "\\3C "))
    env.filters["trusted"] = Markup  # a ReportSection's html, built by the layer's own code
    return env.get_template("report.html.j2").render(**context)


def write_report(study: Study, results: Results, path: str | Path, *, cameras=None,
                 pictures: bool = True, pdf: str | Path | None = None) -> Path:
    """Write ``report.html`` (self-contained) for computed ``results``; return its path.

    ``cameras``: a list of :class:`Camera` (default: the config's ``[cameras]``, or an
    automatic overview). ``pictures=False`` leaves out every image (tables only; fast).
    ``pdf``: also write the same report as a PDF there (``_pdf.write_pdf``: WeasyPrint, the
    ``lumijax[pdf]`` extra).
    """
    path = Path(path)
    if path.parent.exists() and not path.parent.is_dir():
        raise OutputError("not a folder", file=path.parent)
    if pdf is not None:
        from ._pdf import require_pdf

        require_pdf()  # before the pictures are drawn
    ctx = report_context(study, results, cameras=cameras, pictures=pictures)
    html = render_report(ctx)
    with atomic_path(path, what="report", suffix=".html") as tmp:
        Path(tmp).write_text(html, encoding="utf-8")
    if pdf is not None:
        from ._pdf import write_pdf

        write_pdf(html, pdf)
    return path
