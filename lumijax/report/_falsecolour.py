"""False-colour iso-lux maps of calculation grids (PNG, rendered off-screen with pyvista).

The map shows the grid face-on (parallel projection, looking against the plane's normal),
coloured by illuminance with smooth interpolation between points, with labelled iso-lux lines at
round levels, a colour bar "Illuminance (lx)", metre rulers along two edges, an orientation triad
and a line of statistics (Emin, Eavg, Emax, U0 = Emin/Eavg).

pyvista (VTK) is imported inside the functions that render, so ``import lumijax`` stays light.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from .._atomic import atomic_path
from ..errors import GeometryError, OutputError

__all__ = ["falsecolour_map", "lux_to_rgb", "nice_levels", "DEFAULT_CMAP"]

#: Perceptually uniform, prints in grey scale monotonically, readable with colour-vision deficiency.
DEFAULT_CMAP = "viridis"
#: Number of entries of the colour lookup table (as matplotlib's and VTK's default).
N_COLOURS = 256
#: Colour of the iso-lux lines (RGB in [0, 1]).
CONTOUR_RGB = (0.0, 0.0, 0.0)
#: Default image size in pixels (width, height).
WINDOW_SIZE = (1600, 1100)

# Where the grid is placed in the image (fractions of width/height, from the lower left):
# left margin for the vertical ruler, right part for the colour bar, top for title and statistics.
_PLOT_BOX = (0.09, 0.12, 0.77, 0.83)  # x0, y0, x1, y1

Scale = Literal["linear", "log"]


# ------------------------------------------------------------------------------ colour mapping
def _cmap(cmap):
    import matplotlib

    if isinstance(cmap, str):
        return matplotlib.colormaps[cmap].resampled(N_COLOURS)
    return cmap.resampled(N_COLOURS)


def _normalise(lux, vmin: float, vmax: float, scale: str) -> np.ndarray:
    e = np.asarray(lux, dtype=np.float64)
    if scale == "log":
        lo, hi = np.log10(vmin), np.log10(vmax)
        t = (np.log10(np.maximum(e, vmin)) - lo) / (hi - lo)
    else:
        t = (e - vmin) / (vmax - vmin)
    return np.clip(t, 0.0, 1.0)


def lux_to_rgb(
    lux, vmin: float, vmax: float, scale: Scale = "linear", cmap=DEFAULT_CMAP
) -> np.ndarray:
    """The colour (RGB in [0, 1], shape ``lux.shape + (3,)``) that :func:`falsecolour_map` gives
    to illuminance ``lux`` for the colour range ``[vmin, vmax]``.

    ``scale="linear"`` maps lux linearly, ``"log"`` maps log10(lux); values outside the range take
    the end colours (lux ≤ vmin, including 0 on a log scale, gets the lowest colour). The map is a
    matplotlib colour map sampled to :data:`N_COLOURS` entries, as in the rendered image.
    """
    _check_range(vmin, vmax, scale)
    t = _normalise(lux, vmin, vmax, scale)
    return np.asarray(_cmap(cmap)(t))[..., :3]


def _check_range(vmin: float, vmax: float, scale: str) -> None:
    if scale not in ("linear", "log"):
        raise OutputError(f"scale must be 'linear' or 'log', got {scale!r}", key="scale")
    if not (np.isfinite(vmin) and np.isfinite(vmax) and vmax > vmin):
        raise OutputError(f"colour range must satisfy vmin < vmax, got [{vmin}, {vmax}]")
    if scale == "log" and vmin <= 0:
        raise OutputError(f"a log colour scale needs vmin > 0, got {vmin}")


# ------------------------------------------------------------------------------------ levels
def nice_levels(vmin: float, vmax: float, scale: Scale = "linear", max_levels: int = 9):
    """Round iso-lux levels strictly inside ``(vmin, vmax)``.

    Linear: multiples of 1, 2, 2.5 or 5 × 10^k (about 4 to ``max_levels`` of them). Log: 1, 2, 5
    × 10^k (1 and 3 × 10^k too when the range is short).
    """
    from matplotlib.ticker import LogLocator, MaxNLocator

    if not vmax > vmin:
        return np.array([])
    if scale == "log":
        for subs in ((1.0,), (1.0, 2.0, 5.0), (1.0, 2.0, 3.0, 5.0, 7.0)):
            levels = LogLocator(base=10.0, subs=subs, numticks=100).tick_values(vmin, vmax)
            levels = levels[(levels > vmin) & (levels < vmax)]
            if levels.size >= 3:
                break
    else:
        levels = MaxNLocator(nbins=max_levels, steps=[1, 2, 2.5, 5, 10]).tick_values(vmin, vmax)
        levels = levels[(levels > vmin) & (levels < vmax)]
    return np.asarray(levels[:max_levels] if levels.size > max_levels else levels, dtype=float)


def _fmt(level: float) -> str:
    if level >= 100 or float(level).is_integer():
        return f"{level:,.0f}"
    return f"{level:.3g}"


# ------------------------------------------------------------------------------------- view
@dataclass(frozen=True)
class View:
    """The fixed parallel-projection camera of a map: world point ↔ pixel is exact.

    ``pixel(p)`` gives (column, row) from the image's top-left corner, in pixels.
    """

    centre: np.ndarray  # world point at the image centre (camera focal point)
    right: np.ndarray  # unit world vector pointing to image +x
    up: np.ndarray  # unit world vector pointing to image up
    normal: np.ndarray  # unit normal, towards the camera
    px_per_m: float
    window_size: tuple[int, int]

    @property
    def parallel_scale(self) -> float:
        """Half the image height in metres (VTK's parallel scale)."""
        return self.window_size[1] / 2.0 / self.px_per_m

    def pixel(self, points) -> np.ndarray:
        d = np.asarray(points, dtype=np.float64) - self.centre
        w, h = self.window_size
        col = w / 2.0 + (d @ self.right) * self.px_per_m
        row = h / 2.0 - (d @ self.up) * self.px_per_m
        return np.stack([col, row], axis=-1)


def plane_frame(points: np.ndarray, normal=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(normal, right, up)`` unit vectors of the view of a plane grid.

    ``normal`` (towards the viewer) defaults to the best-fit plane normal, oriented towards +z
    (or +y, +x for vertical planes). ``up`` is world +y for a horizontal plane (plan view, x to
    the right) and otherwise the projection of world +z (elevation view).
    """
    if normal is None:
        centred = points - points.mean(axis=0)
        _, sv, vt = np.linalg.svd(centred, full_matrices=False)
        if sv.size < 2 or sv[1] <= 1e-9 * max(sv[0], 1e-300):
            raise GeometryError(
                "grid points are collinear: they span no plane to draw", key="points"
            )
        n = vt[-1]
        for axis in (2, 1, 0):  # orient towards +z, then +y, then +x
            if abs(n[axis]) > 1e-9:
                n = n * np.sign(n[axis])
                break
    else:
        n = np.asarray(normal, dtype=np.float64)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
            raise GeometryError(f"normal must be a non-zero 3-vector, got {normal!r}", key="normal")
    n = n / np.linalg.norm(n)
    ez = np.array([0.0, 0.0, 1.0])
    if abs(n[2]) > 0.9:  # (nearly) horizontal plane: plan view, north (+y) up
        up = np.array([0.0, 1.0, 0.0]) - n[1] * n
    else:  # wall or tilted plane: elevation view, +z up
        up = ez - n[2] * n
    up = up / np.linalg.norm(up)
    right = np.cross(up, n)
    return n, right / np.linalg.norm(right), up


def make_view(points, normal=None, window_size: Sequence[int] = WINDOW_SIZE) -> View:
    """The :class:`View` that :func:`falsecolour_map` uses for these points: the grid and its
    metre rulers (which run from a round value at or before the first point to one at or past
    the last, so that they cover the data) fit the plot box."""
    p = np.asarray(points, dtype=np.float64)
    n, right, up = plane_frame(p, normal)
    u, v = p @ right, p @ up
    u_lo, u_hi = _covered(u, right)
    v_lo, v_hi = _covered(v, up)
    w, h = (int(window_size[0]), int(window_size[1]))
    x0, y0, x1, y1 = _PLOT_BOX
    span_u = max(u_hi - u_lo, 1e-9)
    span_v = max(v_hi - v_lo, 1e-9)
    px_per_m = min((x1 - x0) * w / span_u, (y1 - y0) * h / span_v)
    # Put the drawing's centre at the centre of the plot box, not of the image.
    box_centre_px = np.array([(x0 + x1) / 2.0 * w, (y0 + y1) / 2.0 * h])
    offset_m = (box_centre_px - np.array([w / 2.0, h / 2.0])) / px_per_m
    mid = (u_lo + u_hi) / 2.0 * right + (v_lo + v_hi) / 2.0 * up
    depth = float(np.mean(p @ n)) * n
    centre = mid + depth - offset_m[0] * right - offset_m[1] * up
    return View(centre, right, up, n, float(px_per_m), (w, h))


def _ruler_ticks(t: np.ndarray, vec: np.ndarray) -> tuple[str | None, float, float, np.ndarray]:
    """``(world axis name or None, sign, offset, ticks)`` of the ruler along ``vec`` for
    points at coordinates ``t`` along it: the labelled value of coordinate ``t`` is
    ``sign * (t - offset)`` (a world coordinate along a world axis, else the distance from the
    first point), and the round ``ticks`` run from at or before the smallest value to at or past
    the largest."""
    from matplotlib.ticker import MaxNLocator

    axis = _axis_name(vec)
    name, sign = axis if axis is not None else (None, 1.0)
    offset = 0.0 if axis is not None else float(t.min())
    q = sign * (t - offset)
    lo, hi = float(q.min()), float(q.max())
    span = max(hi - lo, 1e-9)
    ticks = MaxNLocator(nbins=7, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
    eps = 1e-9 * span
    first = ticks[ticks <= lo + eps].max() if np.any(ticks <= lo + eps) else lo
    last = ticks[ticks >= hi - eps].min() if np.any(ticks >= hi - eps) else hi
    inner: np.ndarray = ticks[(ticks >= first - eps) & (ticks <= last + eps)]
    if inner.size < 2:
        inner = np.array([first, last])
    return name, sign, offset, inner


def _covered(t: np.ndarray, vec: np.ndarray) -> tuple[float, float]:
    """The coordinates along ``vec`` that the points and their ruler span (m)."""
    _, sign, offset, ticks = _ruler_ticks(t, vec)
    ends = ticks[[0, -1]] * sign + offset
    return min(float(t.min()), float(ends.min())), max(float(t.max()), float(ends.max()))


# -------------------------------------------------------------------------------------- mesh
def _build_mesh(pv, points: np.ndarray, lux: np.ndarray, shape, view: View):
    if shape is not None:
        nu, nv = (int(s) for s in shape)
        if nu < 2 or nv < 2 or nu * nv != len(points):
            raise GeometryError(
                f"shape {tuple(shape)} does not fit {len(points)} points: need nu, nv >= 2 and "
                "nu * nv == number of points",
                key="shape",
            )
        # Point index = i_u * nv + i_v; each grid cell is split into two triangles.
        iu, iv = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="ij")
        a = (iu * nv + iv).ravel()
        tris = np.concatenate(
            [np.stack([a, a + nv, a + nv + 1], axis=1), np.stack([a, a + nv + 1, a + 1], axis=1)]
        )
        faces = np.column_stack([np.full(len(tris), 3), tris]).ravel()
        mesh = pv.PolyData(points, faces=faces)
    else:
        flat = np.column_stack([points @ view.right, points @ view.up, np.zeros(len(points))])
        tri = pv.PolyData(flat).delaunay_2d()
        if tri.n_cells == 0:
            raise GeometryError("grid points could not be triangulated", key="points")
        if tri.n_points != len(points):
            raise GeometryError("grid has duplicate points (in its plane)", key="points")
        mesh = pv.PolyData(points, faces=tri.faces)
    mesh.point_data["lux"] = lux
    return mesh


#: A structured grid's iso-lux lines are traced on a smoothed copy of its lux when the part a
#: 1-2-1 filter removes has an RMS above this fraction of the lux range (Monte Carlo noise in
#: the gathered light); the colours always show the lux as computed.
NOISE_FRACTION = 0.01


def _smooth(field: np.ndarray) -> np.ndarray:
    """One pass of the separable 1-2-1 (binomial) filter over a (nu, nv) field, edges repeated."""
    out = field
    for axis in (0, 1):
        pad = np.pad(out, [(1, 1) if a == axis else (0, 0) for a in (0, 1)], mode="edge")
        lo = np.take(pad, np.arange(0, out.shape[axis]), axis=axis)
        mid = np.take(pad, np.arange(1, out.shape[axis] + 1), axis=axis)
        hi = np.take(pad, np.arange(2, out.shape[axis] + 2), axis=axis)
        out = 0.25 * lo + 0.5 * mid + 0.25 * hi
    return out


def contour_field(lux: np.ndarray, shape) -> np.ndarray:
    """The field the iso-lux lines follow: ``lux`` itself, or, on a noisy structured grid
    (:data:`NOISE_FRACTION`), ``lux`` smoothed once by the 1-2-1 filter, so that noise does not
    break a line into rings and wiggles."""
    lux = np.asarray(lux, np.float64)
    if shape is None or min(shape) < 3 or np.ptp(lux) <= 0:
        return lux
    field = lux.reshape(tuple(int(x) for x in shape))
    smooth = _smooth(field)
    noise = float(np.sqrt(np.mean((field - smooth) ** 2)))
    return smooth.ravel() if noise > NOISE_FRACTION * float(np.ptp(lux)) else lux


def _label_positions(pv, mesh, level: float, min_points: int) -> list[np.ndarray]:
    line = mesh.contour([level], scalars="contour")
    if line.n_points == 0:
        return []
    parts = line.connectivity("all")
    ids = np.asarray(parts.point_data["RegionId"])
    # a label per line that matters: not on fragments much shorter than the level's longest
    regions, counts = np.unique(ids, return_counts=True)
    least = max(min_points, int(0.25 * counts.max()))
    out = []
    for rid, count in zip(regions, counts, strict=True):
        pts = np.asarray(parts.points)[ids == rid]
        if count < least:
            continue
        mid = pts[np.argmin(np.linalg.norm(pts - pts.mean(axis=0), axis=1))]
        out.append(mid)
    return out


# --------------------------------------------------------------------------------- rendering
def falsecolour_map(
    points,
    lux,
    path: str | os.PathLike,
    *,
    shape: tuple[int, int] | None = None,
    normal=None,
    title: str,
    levels: Sequence[float] | None = None,
    scale: Scale = "linear",
    cmap=DEFAULT_CMAP,
    clim: tuple[float, float] | None = None,
    window_size: tuple[int, int] = WINDOW_SIZE,
    labels: bool = True,
    luminaires: Sequence[tuple] = (),
) -> Path:
    """Write a false-colour iso-lux map of a calculation grid to the PNG ``path``; return it.

    Parameters
    ----------
    points
        (N, 3) calculation points, metres, all in one plane.
    lux
        (N,) illuminance at the points, lx.
    shape
        ``(nu, nv)`` when the points are a structured grid of cell centres in row order: point
        index = ``i_u * nv + i_v`` (``i_v`` runs fastest). None: an unstructured set,
        triangulated (Delaunay) in its best-fit plane.
    normal
        Normal of the grid plane, pointing towards the viewer; default: the best-fit normal,
        oriented towards +z (then +y, +x). Horizontal grids are drawn in plan view with +y up,
        others in elevation with +z up (see :func:`plane_frame`).
    title
        Shown at the top.
    levels
        Iso-lux levels (lx); default :func:`nice_levels` of the colour range. ``[]``: none.
    scale
        ``"linear"`` or ``"log"`` colour scale (log: lux ≤ 0 takes the lowest colour).
    cmap
        A matplotlib colour-map name or object; default viridis (perceptually uniform,
        colour-blind safe, prints well). Avoid rainbow maps such as jet.
    clim
        Colour range ``(vmin, vmax)`` in lx; default the data range (log: from the smallest
        positive value, at most 4 decades below the maximum). Set it to compare maps.
    window_size
        Image size in pixels.
    labels
        Label the iso-lux lines with their values.
    luminaires
        ``(position, aim axis)`` pairs (m; unit vector): each luminaire whose position, seen
        face-on, falls on the drawing is drawn there as a black dot with a short line along its
        aim's component in the grid's plane (none for one aimed straight at the plane).

    The camera is a fixed parallel projection (see :func:`make_view`), so a world point maps to
    an exact pixel; the grid is drawn unlit, so its colours are exactly :func:`lux_to_rgb` of the
    interpolated lux. The file is written atomically (a temporary file in the same folder, then
    renamed over ``path``).
    """
    path = Path(path)
    p = np.asarray(points, dtype=np.float64)
    e = np.asarray(lux, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 3:
        raise GeometryError(
            f"points must be an (N >= 3, 3) array, got shape {p.shape}", key="points"
        )
    if e.shape != (len(p),):
        raise OutputError(f"lux must have shape ({len(p)},), got {e.shape}", key="lux")
    if not np.all(np.isfinite(p)):
        raise GeometryError("points contain NaN or infinity", key="points")
    if not np.all(np.isfinite(e)):
        raise OutputError("lux contains NaN or infinity", key="lux")
    if np.any(e < 0):
        raise OutputError("lux contains negative values", key="lux")
    vmin, vmax = _colour_range(e, scale, clim)
    if levels is None:
        levels = nice_levels(vmin, vmax, scale)
    levels = [float(x) for x in levels if vmin <= float(x) <= vmax]
    if not path.parent.is_dir():
        raise OutputError("folder does not exist", file=path.parent)

    import pyvista as pv

    view = make_view(p, normal, window_size)
    mesh = _build_mesh(pv, p, e, shape, view)
    # A log scale maps log10(lux): lux below vmin (zeros in shadow) take the lowest colour.
    if scale == "log":
        mesh.point_data["lux"] = np.maximum(e, vmin)
    mesh.point_data["contour"] = contour_field(np.asarray(mesh.point_data["lux"]), shape)

    from ._plotters import plotter as lent

    was_off_screen = pv.OFF_SCREEN
    pv.OFF_SCREEN = True
    try:
        with lent(view.window_size) as plotter:  # kept for the next map of this size
            _draw(pv, plotter, mesh, view, p, e, title, levels, scale, cmap, (vmin, vmax),
                  labels)
            _luminaires(pv, plotter, view, p, luminaires)
            with atomic_path(path, what="map", suffix=".png") as tmp:  # VTK reads the suffix
                plotter.screenshot(str(tmp), transparent_background=False)
    finally:
        pv.OFF_SCREEN = was_off_screen
    return path


def _colour_range(e: np.ndarray, scale: str, clim) -> tuple[float, float]:
    if clim is not None:
        vmin, vmax = (float(c) for c in clim)
    elif scale == "log":
        vmax = float(e.max())
        positive = e[e > 0]
        if vmax <= 0:
            raise OutputError("a log scale needs some lux > 0; all are zero", key="lux")
        vmin = max(float(positive.min()), vmax * 1e-4)
    else:
        vmin, vmax = float(e.min()), float(e.max())
    if vmax <= vmin:  # a uniform field: centre it in a small range so it still draws
        pad = max(abs(vmin) * 0.05, 1.0)
        vmin, vmax = (vmin - pad, vmax + pad) if scale == "linear" else (vmin / 1.1, vmax * 1.1)
        vmin = max(vmin, 0.0) if scale == "linear" else vmin
    _check_range(vmin, vmax, scale)
    return vmin, vmax


def _draw(pv, pl, mesh, view, p, e, title, levels, scale, cmap, clim, labels) -> None:
    w, h = view.window_size
    font = max(10, int(round(h / 55)))
    pl.set_background("white")
    pl.add_mesh(
        mesh,
        scalars="lux",
        cmap=_cmap(cmap),
        clim=clim,
        log_scale=scale == "log",
        n_colors=N_COLOURS,
        interpolate_before_map=True,
        lighting=False,
        show_edges=False,
        scalar_bar_args=dict(
            title="Illuminance (lx)",
            vertical=True,
            position_x=0.86,
            position_y=0.13,
            width=0.045,
            height=0.74,
            n_labels=len(levels) if levels else 5,
            unconstrained_font_size=True,
            fmt="%.0f" if clim[1] >= 20 else "%.2g",
            title_font_size=font + 2,
            label_font_size=font,
            color="black",
            font_family="arial",
        ),
    )
    bar = pl.scalar_bar
    if levels:  # put the iso-lux levels on the colour bar as its labels: the bar explains the lines
        bar.SetUseCustomLabels(True)
        from vtkmodules.vtkCommonCore import vtkDoubleArray

        arr = vtkDoubleArray()
        for level in levels:
            arr.InsertNextValue(level)
        bar.SetCustomLabels(arr)
        bar.SetLabelFormat("%.0f" if all(float(x).is_integer() for x in levels) else "%.3g")
        bar.SetNumberOfLabels(len(levels))

    if levels:
        lines = mesh.contour(levels, scalars="contour")
        if lines.n_points:
            # Lift the lines a hair towards the camera so the surface never hides them.
            lines.points = np.asarray(lines.points) + view.normal * 1e-4 * view.parallel_scale
            pl.add_mesh(lines, color=CONTOUR_RGB, line_width=max(2, h // 500), lighting=False)
        if labels:
            pts, text = [], []
            min_pts = max(3, int(0.05 * np.sqrt(mesh.n_points)))
            for level in levels:
                for q in _label_positions(pv, mesh, level, min_pts):
                    pts.append(q + view.normal * 2e-4 * view.parallel_scale)
                    text.append(_fmt(level))
            if pts:
                pl.add_point_labels(
                    np.array(pts),
                    text,
                    font_size=font,
                    text_color="black",
                    bold=False,
                    shape="rounded_rect",
                    shape_color="white",
                    shape_opacity=0.85,
                    margin=3,
                    show_points=False,
                    always_visible=True,
                )

    _rulers(pl, view, p, font)
    pl.add_text(
        title,
        position=(int(_PLOT_BOX[0] * w), int(0.945 * h)),
        font_size=font + 4,
        color="black",
        font="arial",
    )
    mean = float(e.mean())
    stats = (
        f"Emin {_fmt(float(e.min()))} lx   Eavg {_fmt(mean)} lx   "
        f"Emax {_fmt(float(e.max()))} lx   U0 = Emin/Eavg = {float(e.min()) / mean if mean > 0 else 0.0:.2f}"
    )
    pl.add_text(
        stats,
        position=(int(_PLOT_BOX[0] * w), int(0.905 * h)),
        font_size=font,
        color="#333333",
        font="arial",
    )
    pl.add_axes(
        interactive=False,
        line_width=3,
        color="black",
        viewport=(0.84, 0.0, 0.99, 0.13),
        labels_off=False,
    )
    cam = pl.camera
    cam.parallel_projection = True
    cam.focal_point = tuple(view.centre)
    cam.position = tuple(view.centre + view.normal * 10.0 * max(view.parallel_scale, 1.0))
    cam.up = tuple(view.up)
    cam.parallel_scale = view.parallel_scale
    pl.renderer.ResetCameraClippingRange()


def _luminaires(pv, pl, view: View, p: np.ndarray, luminaires) -> None:
    """Luminaires over the grid (``falsecolour_map``'s ``luminaires``), lifted towards the
    camera so the surface never hides them."""
    if not len(luminaires):
        return
    u, v = p @ view.right, p @ view.up
    margin = 0.1 * max(float(np.ptp(u)), float(np.ptp(v)), 1e-9)
    depth = float(np.max(p @ view.normal)) + 1e-3 * view.parallel_scale
    length = 0.06 * max(float(np.ptp(u)), float(np.ptp(v)), 1e-9)
    dots, segments = [], []
    for pos, axis in luminaires:
        pos, axis = np.asarray(pos, np.float64), np.asarray(axis, np.float64)
        a, b = float(pos @ view.right), float(pos @ view.up)
        if not (u.min() - margin <= a <= u.max() + margin
                and v.min() - margin <= b <= v.max() + margin):
            continue
        at = a * view.right + b * view.up + depth * view.normal
        dots.append(at)
        flat = (axis @ view.right) * view.right + (axis @ view.up) * view.up
        if np.linalg.norm(flat) > 1e-3:
            segments.append((at, at + length * flat / max(np.linalg.norm(axis), 1e-300)))
    if not dots:
        return
    size = max(7, view.window_size[1] // 80)
    # black on a white halo: readable on viridis' dark end as on its bright one
    if segments:
        pts = np.array([q for seg in segments for q in seg])
        lines = np.column_stack([np.full(len(segments), 2), np.arange(0, len(pts), 2),
                                 np.arange(1, len(pts), 2)]).ravel()
        aims = pv.PolyData(pts, lines=lines)
        pl.add_mesh(aims, color="white", line_width=5, lighting=False)
    lift = view.normal * 1e-4 * view.parallel_scale  # white under black, dots over lines
    pl.add_points(np.array(dots) + lift, color="white", point_size=size + 4,
                  render_points_as_spheres=False, lighting=False)
    if segments:
        pl.add_mesh(aims.translate(2 * lift), color="black", line_width=2, lighting=False)
    pl.add_points(np.array(dots) + 3 * lift, color="black", point_size=size,
                  render_points_as_spheres=False, lighting=False)


def _axis_name(vec: np.ndarray) -> tuple[str, float] | None:
    """("x"|"y"|"z", sign) if ``vec`` is a world axis, else None."""
    i = int(np.argmax(np.abs(vec)))
    if abs(vec[i]) > 1 - 1e-9:
        return "xyz"[i], float(np.sign(vec[i]))
    return None


def _rulers(pl, view: View, p: np.ndarray, font: int) -> None:
    """Metre rulers below and left of the grid, with ticks at round coordinates.

    Along a world axis the labels are that world coordinate; otherwise the distance along the
    grid from its first edge.
    """
    w, h = view.window_size
    u, v = p @ view.right, p @ view.up
    depth = float(np.mean(p @ view.normal)) * view.normal
    gap = 14.0 / view.px_per_m  # 14 px outside the grid

    def world(a, b):
        return a * view.right + b * view.up + depth

    for which, vec, t in (("u", view.right, u), ("v", view.up, v)):
        name, sign, offset, inner = _ruler_ticks(t, vec)
        axis = None if name is None else (name, sign)
        # screen coordinate of a labelled value, and the ruler's two ends (labels fall outside
        # the grid: below a left-to-right ruler, left of a top-to-bottom one)
        t0, t1 = (inner[0] * sign + offset), (inner[-1] * sign + offset)
        if which == "u":
            ends = sorted([(t0, inner[0]), (t1, inner[-1])])
            (ta, qa), (tb, qb) = ends
            a, b = world(ta, v.min() - gap), world(tb, v.min() - gap)
        else:
            ends = sorted([(t0, inner[0]), (t1, inner[-1])], reverse=True)
            (ta, qa), (tb, qb) = ends
            a, b = world(u.min() - gap, ta), world(u.min() - gap, tb)
        ruler = pl.add_ruler(
            a,
            b,
            title="",
            number_minor_ticks=4,
            font_size_factor=1.0,
            label_size_factor=0.8,
            label_color="black",
            tick_color="black",
            tick_length=8,
            minor_tick_length=4,
            tick_label_offset=4,
        )
        ruler.SetRange(float(qa), float(qb))
        ruler.SetNumberOfLabels(int(inner.size))
        ruler.SetAdjustLabels(False)
        ruler.SetLabelFormat("%g")
        prop = ruler.GetLabelTextProperty()
        prop.SetFontFamilyToArial()
        prop.SetBold(False)
        prop.SetItalic(False)
        prop.SetShadow(False)
        prop.SetColor(0.0, 0.0, 0.0)
        label = f"{name} (m)" if axis is not None else "distance along the grid (m)"
        if which == "u":  # right of the ruler, on the level of its labels
            px = view.pixel(world(max(u.max(), ta, tb), v.min() - gap))
            pos = (int(px[0] + 0.8 * font), int(h - px[1] - 1.9 * font))
        else:  # above the ruler
            px = view.pixel(world(u.min() - gap, max(v.max(), ta, tb)))
            pos = (int(px[0] - 1.5 * font), int(h - px[1] + 0.8 * font))
        pl.add_text(label, position=pos, font_size=font, color="black", font="arial")
