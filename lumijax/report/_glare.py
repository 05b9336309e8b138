"""The report's glare section: per observer the worst UGR, GR and TI, the luminaires that
contribute most, and per observer a traced fisheye of the whole scene's luminance as its eye
sees it, the ratings written on it (docs/glare.md, docs/render.md)."""

from __future__ import annotations

import base64
import html

import numpy as np

from .._study import Study
from ..results import Results
from ._png import figure_png
from ._sections import ReportSection

__all__ = ["glare_sections", "fisheye_png", "observer_fisheye", "results_tracer",
           "traced_fisheye_png"]

#: Pixels across an observer's traced fisheye in the report.
FISHEYE_PX = 360


def _f(v, spec=".1f") -> str:
    return "—" if v is None else format(v, spec)


def glare_sections(study: Study, results: Results, pictures: bool) -> list[ReportSection]:
    """One section, when the study has ``[[observers]]``."""
    glare = results.glare
    if glare is None:
        return []
    data = glare.to_dict()
    rows = []
    for name, d in data.items():
        w = d["worst"]
        top = ", ".join(f"{html.escape(t['name'])} {100 * t['share']:.0f} %"
                        for t in d["top_luminaires"]["gr"][:3]) or "—"
        cells = [html.escape(name), str(len(d["directions"])),
                 _f((w["ugr"] or {}).get("value")), _f((w["gr"] or {}).get("value")),
                 _f((w["gr"] or {}).get("azimuth_deg"), "g"), _f((w["ti"] or {}).get("value")),
                 top]
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    head = "".join(f"<th>{h}</th>" for h in ("observer", "directions", "UGR", "GR",
                                             "worst GR at (deg)", "TI (%)",
                                             "largest veiling shares (GR)"))
    body = f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
    body += _surfaces_table(data)
    if pictures:
        figs = []
        tracer = None
        if results.lighting is not None:
            from ._surfaces import surface_light

            tracer = results_tracer(results, surface_light(results))
        for i, name in enumerate(data):
            views = glare.views_of(i)
            w = data[name]["worst"]
            j = (w["gr"] or w["ugr"] or {"direction": 0})["direction"]
            title = _title(name, data[name]["directions"][j])
            if tracer is not None:  # the whole scene, traced (lumijax.render)
                image, ugr, _ = observer_fisheye(results, i, view=int(views[j]), tracer=tracer)
                png = traced_fisheye_png(image, glare, int(views[j]), title=title, ugr=ugr)
                what = ("the whole scene's luminance its eye sees in its worst direction "
                        "(traced: reflections of the sources included), angular fisheye "
                        "(centre: the line of sight), the sources it rates ringed")
            else:
                png = fisheye_png(glare, int(views[j]), title=title)
                what = ("the sources its eye rates in its worst direction, angular fisheye "
                        "(centre: the line of sight)")
            uri = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
            figs.append(f'<figure><img src="{uri}" alt="what {html.escape(name)} sees">'
                        f"<figcaption>{html.escape(name)}: {what}</figcaption></figure>")
        body += "".join(figs)
    return [ReportSection(
        id="glare", title="Glare",
        lead="UGR (CIE 117), GR (CIE 112 / EN 12464-2) and TI (CIE 140) per observer, worst "
             "over its directions; docs/glare.md says how each is computed.",
        html=body)]


def _surfaces_table(data: dict) -> str:
    """The named surfaces each observer sees: largest and mean luminance B/π (cd/m²), and the
    observer's ``max_luminance_cdm2`` limit with whether it is met; empty without any."""
    rows = []
    for name, d in data.items():
        for surf, e in (d.get("surfaces") or {}).items():
            limit = e.get("limit_cdm2")
            met = "" if limit is None else ("✓" if e["meets"] else "✗")
            cells = [html.escape(name), html.escape(surf), _f(e["max_luminance_cdm2"], ".3g"),
                     _f(e["mean_luminance_cdm2"], ".3g"), _f(limit, "g"), met]
            rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    if not rows:
        return ""
    head = "".join(f"<th>{h}</th>" for h in ("observer", "surface seen", "max L (cd/m²)",
                                             "mean L (cd/m²)", "limit (cd/m²)", "met"))
    return (f"<p>Named surfaces as each observer sees them (L = B/π of the patches its eye "
            f"reaches):</p><table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}"
            "</tbody></table>")


def _title(name: str, d: dict) -> str:
    parts = [f"{name}, azimuth {d['azimuth_deg']:g}°"]
    for key, label in (("ugr", "UGR"), ("gr", "GR"), ("ti_percent", "TI %")):
        if d.get(key) is not None:
            parts.append(f"{label} {d[key]:.1f}")
    return " · ".join(parts)


def fisheye_png(glare, view: int, *, title: str = "", size_in: float = 4.5) -> bytes:
    """An angular fisheye (radius ∝ angle off the line of sight, 90° at the rim) of the
    sources view ``view`` rates: each a disc of the area of its solid angle's apparent size
    (at least a few points), coloured by log luminance (cd/m²)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    f = np.asarray(glare.model.view_direction, np.float64)[view]
    right = np.cross(f, [0.0, 0.0, 1.0])
    right /= max(np.linalg.norm(right), 1e-12)
    up = np.cross(right, f)
    src = [s for s in glare.seen_sources(view) if np.linalg.norm(s["direction"]) > 0]
    fig, ax = plt.subplots(figsize=(size_in, size_in), dpi=100)
    ax.add_patch(plt.Circle((0, 0), 90, fill=False, color="0.6"))
    for r in (30, 60):
        ax.add_patch(plt.Circle((0, 0), r, fill=False, color="0.85", lw=0.6))
    if src:
        d = np.array([s["direction"] for s in src])
        theta = np.degrees(np.arccos(np.clip(d @ f, -1, 1)))
        phi = np.arctan2(d @ up, d @ right)
        lum = np.array([s["luminance_cdm2"] for s in src])
        radius = np.degrees(np.sqrt(np.array([s["solid_angle_sr"] for s in src]) / np.pi))
        sc = ax.scatter(theta * np.cos(phi), theta * np.sin(phi),
                        s=np.maximum((2.0 * radius) ** 2 * 3.0, 6.0), c=np.log10(lum),
                        cmap="inferno", edgecolors="0.3", linewidths=0.3)
        fig.colorbar(sc, ax=ax, shrink=0.7, label="log10 luminance (cd/m²)")
    ax.set_xlim(-95, 95)
    ax.set_ylim(-95, 95)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=8)
    png = figure_png(fig, bbox_inches="tight")
    plt.close(fig)
    return png


def observer_fisheye(results: Results, observer: int, *, view: int | None = None,
                     surface=None, size: int = FISHEYE_PX, tracer=None):
    """``(LuminanceImage, UGR, L_b)``: the angular 180° fisheye (:class:`lumijax.render.
    Fisheye`) an observer's eye sees along view ``view`` (its first line of sight by default),
    traced through the whole lit scene — surfaces at their radiosity, luminaires at their
    luminance, their specular reflections and what clear glass passes — and the image's own
    UGR and background (cd/m²), evalglare's way (:meth:`LuminanceImage.ugr`). ``tracer``: the
    :func:`results_tracer` of these results, to share between observers (built if None)."""
    from ..render import Fisheye

    glare = results.glare
    if glare is None or results.lighting is None:
        raise ValueError("observer_fisheye needs results with glare and a lighting solution")
    if view is None:
        view = int(glare.views_of(observer)[0])
    eye = np.asarray(glare.observers[observer].eye, np.float64)
    f = np.asarray(glare.model.view_direction, np.float64)[view]
    if tracer is None:
        tracer = results_tracer(results, surface)
    cam = Fisheye(position=tuple(eye), target=tuple(eye + f), up=(0.0, 0.0, 1.0),
                  size=(size, size), projection="equidistant", fov_deg=180.0)
    image = tracer.render(cam, results.design.dimmers)
    ugr, lb = image.ugr()
    return image, ugr, lb


def results_tracer(results: Results, surface=None):
    """The :class:`lumijax.render.Tracer` of ``results``' lit scene, its luminaires as the
    results' design aims them (``surface``: the report's ``surface_light(results)``, figured if
    None). One per report: each tracer builds its own ray-casting structures."""
    from ..design import Design
    from ..render import Tracer
    from ._surfaces import surface_light

    scene = results.lighting.scene
    if results.design.same_study(Design.of(scene)):  # the luminaires as designed
        scene = scene.with_design(results.design)
    surface = surface if surface is not None else surface_light(results)
    return Tracer.for_scene(scene, surface)


def traced_fisheye_png(image, glare, view: int, *, title: str = "", ugr: float | None = None,
                       size_in: float = 4.5) -> bytes:
    """A traced fisheye as a log-luminance false-colour picture (cd/m²), the sources the glare
    model rates ringed at their directions, the ratings in the title and the image's own UGR
    beneath."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    lum = image.luminance
    inside = image.camera.solid_angles() > 0
    pos = lum[inside & (lum > 0)]
    lo = max(float(np.percentile(pos, 1)), 1e-3) if pos.size else 1e-3
    hi = max(float(lum.max()), lo * 10)
    shown = np.where(inside, np.log10(np.clip(lum, lo, hi)), np.nan)
    fig, ax = plt.subplots(figsize=(size_in, size_in), dpi=100)
    im = ax.imshow(shown, cmap="inferno", vmin=np.log10(lo), vmax=np.log10(hi))
    fig.colorbar(im, ax=ax, shrink=0.7, label="log10 luminance (cd/m²)")
    src = [s for s in glare.seen_sources(view) if np.linalg.norm(s["direction"]) > 0]
    if src:
        row, col, ok = image.camera.pixel(np.array([s["direction"] for s in src]))
        ax.scatter(col[ok], row[ok], s=60, facecolors="none", edgecolors="#4fc3f7",
                   linewidths=0.8)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=8)
    if ugr is not None and np.isfinite(ugr):
        ax.set_xlabel(f"UGR of this image (sources > 5 × its mean luminance): {ugr:.1f}",
                      fontsize=7)
    png = figure_png(fig, bbox_inches="tight")
    plt.close(fig)
    return png
