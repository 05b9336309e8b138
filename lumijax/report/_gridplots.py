"""The picture of a calculation grid, whatever its kind: an iso-lux map, a profile or a plan.

A plane grid (``kind = "plane"``, two or more points each way) is drawn as an iso-lux map
(:func:`falsecolour_map`). A grid whose points do not tile a plane face-on cannot be mapped: a
map projects the points along their normal, and points along a path at eye height with
horizontal normals (the demo's ``paths-eye``) collapse onto a line there. Such a grid is drawn as
a **profile** when its points run along one or a few paths (illuminance against the distance
along each leg, the grid's limits drawn), otherwise as a **plan** (the points where they are,
coloured and labelled with their lux, and the luminaires nearby with their aims). The report
lists the values of every grid that is not a map.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from ..config._schema import _GridBase
from ..errors import LumijaxError
from ..results import CRITERIA_SLACK, GridResult
from ._png import figure_png

__all__ = ["GridPicture", "grid_picture", "picture_kind", "path_legs", "PictureKind"]

PictureKind = Literal["map", "profile", "plan"]

#: A points grid of at least this many points, one normal for all, spread over its plane, is
#: mapped (interpolated) like a plane grid; fewer are drawn point by point.
MAP_MIN_POINTS = 16
#: A step between consecutive points this many times the median step starts a new leg.
LEG_BREAK = 3.0
#: At most this many legs make a profile; more (scattered points) make a plan.
MAX_LEGS = 8

ACCENT = "#1f4e79"
FAIL = "#a4262c"
LIMIT_STYLE = {"max_lux": (FAIL, "--", "max"), "min_lux": ("#c26a00", "--", "min"),
               "target_lux": ("#1e7b4a", ":", "target Eavg")}


@dataclass(frozen=True)
class GridPicture:
    """A grid's picture: its kind, the PNG and a caption (units in the text)."""

    kind: PictureKind
    png: bytes
    caption: str


def _common_normal(normals: np.ndarray) -> np.ndarray | None:
    n = np.asarray(normals, np.float64)
    if len(n) == 0 or np.linalg.norm(n[0]) == 0:
        return None
    first = n[0] / np.linalg.norm(n[0])
    unit = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return first if np.all(unit @ first > 1 - 1e-6) else None


def _spans_face_on(points: np.ndarray, normal: np.ndarray) -> bool:
    """Whether the points, seen along ``normal``, cover an area (not a line or a point)."""
    flat = points - np.outer(points @ normal, normal)
    sv = np.linalg.svd(flat - flat.mean(axis=0), compute_uv=False)
    return bool(sv.size >= 2 and sv[1] > 0.05 * max(sv[0], 1e-300))


def path_legs(points) -> list[np.ndarray]:
    """Indices of the legs of a path through ``points`` in their order: a step longer than
    :data:`LEG_BREAK` times the median step starts a new leg."""
    p = np.asarray(points, np.float64)
    if len(p) < 2:
        return [np.arange(len(p))]
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    typical = float(np.median(steps))
    breaks: np.ndarray | list[int] = (np.flatnonzero(steps > LEG_BREAK * typical) + 1
                                      if typical > 0 else [])
    return [np.asarray(leg) for leg in np.split(np.arange(len(p)), breaks)]


def _runs_along(p: np.ndarray, legs: list[np.ndarray]) -> bool:
    """Whether each leg goes somewhere: steps of like length (spread under half their mean)
    that seldom turn back (at most a quarter of the turns sharper than 60°), as points along a
    walk do and points scattered over desks do not."""
    turns = sharp = 0
    for leg in legs:
        if len(leg) < 2:
            continue
        d = np.diff(p[leg], axis=0)
        length = np.linalg.norm(d, axis=1)
        if length.min() <= 0 or length.std() > 0.5 * length.mean():
            return False
        unit = d / length[:, None]
        cos = np.einsum("ij,ij->i", unit[:-1], unit[1:])
        turns += len(cos)
        sharp += int(np.sum(cos < 0.5))
    return sharp <= 0.25 * turns


def picture_kind(points, normals, shape=None) -> PictureKind:
    """How a grid is drawn (module docstring): ``"map"``, ``"profile"`` or ``"plan"``."""
    p = np.asarray(points, np.float64)
    if shape is not None:
        return "map" if min(shape) >= 2 else "profile"
    normal = _common_normal(normals)
    if len(p) >= MAP_MIN_POINTS and normal is not None and _spans_face_on(p, normal):
        return "map"
    legs = path_legs(p)
    if len(p) >= 3 and len(legs) <= min(MAX_LEGS, len(p) / 3) and _runs_along(p, legs):
        return "profile"
    return "plan"


def _limits(config) -> dict[str, float]:
    if not isinstance(config, _GridBase):  # every grid kind's config builds on it
        return {}
    values = {"max_lux": config.max_lux, "min_lux": config.min_lux,
              "target_lux": config.target_lux}
    return {k: float(v) for k, v in values.items() if v is not None}


def _fmt(x: float) -> str:
    x = float(x)
    return f"{x:,.0f}" if abs(x) >= 100 else f"{x:.3g}"


def _vec(v) -> str:
    return "(" + ", ".join(f"{float(c):.3g}" for c in v) + ")"


def _figure(size):
    from matplotlib.figure import Figure

    return Figure(figsize=(size[0] / 100.0, size[1] / 100.0), dpi=100)


def _png(fig) -> bytes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    return figure_png(fig, dpi=100, facecolor="white")


def profile_png(grid: GridResult, config=None, *, title: str, size=(1200, 560)) -> bytes:
    """Illuminance (lx) against the distance (m) along each leg of the grid's path, one panel
    per leg on a shared lux axis; the grid's limits as horizontal lines, points that break a
    point limit (``min_lux``, ``max_lux``) in red."""
    p = np.asarray(grid.points, np.float64)
    e = np.asarray(grid.illuminance_lux, np.float64)
    legs = path_legs(p)
    limits = _limits(config)
    lengths = [max(float(np.linalg.norm(np.diff(p[leg], axis=0), axis=1).sum()), 1e-9)
               for leg in legs]
    fig = _figure(size)
    ratios = [max(n, 0.25 * max(lengths)) for n in lengths]
    axes = fig.subplots(1, len(legs), sharey=True, squeeze=False,
                        gridspec_kw={"width_ratios": ratios})[0]
    top = max([float(e.max())] + list(limits.values())) * 1.15 or 1.0
    bad = np.zeros(len(e), bool)
    # judged as the report's tables judge them: with the criteria's slack
    if "max_lux" in limits:
        bad |= e > limits["max_lux"] * (1 + CRITERIA_SLACK)
    if "min_lux" in limits:
        bad |= e < limits["min_lux"] * (1 - CRITERIA_SLACK)
    for i, (ax, leg) in enumerate(zip(axes, legs, strict=True)):
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p[leg], axis=0), axis=1))])
        ax.plot(s, e[leg], color=ACCENT, lw=2.0, zorder=3)
        ax.scatter(s, e[leg], s=28, zorder=4,
                   c=[FAIL if b else ACCENT for b in bad[leg]], edgecolors="white", linewidths=0.6)
        for key, value in limits.items():
            colour, style, _ = LIMIT_STYLE[key]
            ax.axhline(value, color=colour, ls=style, lw=1.6, zorder=2)
        ax.set_ylim(0.0, top)
        ax.set_xlim(-0.04 * max(s[-1], 1.0), s[-1] + 0.04 * max(s[-1], 1.0))
        ax.grid(color="#e3e7ec", lw=0.7)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
        ax.set_xlabel("distance along the leg (m)")
        normal = _common_normal(grid.normals[leg])
        facing = f"; normal {_vec(normal)}" if normal is not None else ""
        ax.set_title(f"leg {i + 1}: {_vec(p[leg[0]])} → {_vec(p[leg[-1]])} m{facing}",
                     fontsize=8.5, color="#5b6675", loc="left")
    axes[0].set_ylabel("illuminance (lx)")
    handles = [axes[0].plot([], [], color=ACCENT, lw=2, marker="o", label="E at the points")[0]]
    for key, value in limits.items():
        colour, style, label = LIMIT_STYLE[key]
        handles.append(axes[0].plot([], [], color=colour, ls=style, lw=1.6,
                                    label=f"{label} {_fmt(value)} lx")[0])
    if bad.any():
        handles.append(axes[0].scatter([], [], s=28, c=FAIL, label="outside a limit"))
    fig.legend(handles=handles, loc="upper right", ncols=len(handles), frameon=False,
               fontsize=9, bbox_to_anchor=(0.99, 0.995))
    fig.suptitle(title, x=0.01, y=0.995, ha="left", va="top", fontsize=12)
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.13, top=0.84, wspace=0.08)
    return _png(fig)


def _plan_axes(p: np.ndarray) -> tuple[int, int]:
    """The two world axes the points spread over most (x, y for a plan)."""
    spread = np.ptp(p, axis=0)
    if spread[2] <= max(spread[0], spread[1]) or min(spread[0], spread[1]) >= spread[2]:
        return 0, 1
    return (0, 2) if spread[0] >= spread[1] else (1, 2)


def plan_png(grid: GridResult, config=None, *, title: str, luminaires=(),
             size=(1000, 760)) -> bytes:
    """The grid's points where they are (plan x–y, or an elevation when they stand taller than
    they spread), coloured by illuminance (viridis, colour bar in lx) and labelled with their
    lux; each point's normal as a short grey tick; ``luminaires`` (positions and aim axes, m)
    within the drawing as black dots with their aim."""
    from matplotlib.colors import Normalize

    from ._falsecolour import DEFAULT_CMAP, _cmap

    p = np.asarray(grid.points, np.float64)
    e = np.asarray(grid.illuminance_lux, np.float64)
    a, b = _plan_axes(p)
    names = "xyz"
    fig = _figure(size)
    ax = fig.add_axes((0.09, 0.1, 0.72, 0.78))
    cax = fig.add_axes((0.86, 0.1, 0.03, 0.78))
    lo, hi = float(e.min()), float(e.max())
    if hi <= lo:
        lo, hi = max(lo - 1.0, 0.0), hi + 1.0
    norm = Normalize(lo, hi)
    span = max(float(np.ptp(p[:, a])), float(np.ptp(p[:, b])), 1.0)
    ax.scatter(p[:, a], p[:, b], c=e, cmap=_cmap(DEFAULT_CMAP), norm=norm, s=140,
               edgecolors="black", linewidths=0.6, zorder=3)
    n = np.asarray(grid.normals, np.float64)
    ax.quiver(p[:, a], p[:, b], n[:, a], n[:, b], color="#8a939e", angles="xy",
              scale_units="xy", scale=1.0 / (0.06 * span), width=0.003, zorder=2)
    if len(p) <= 80:
        for q, v in zip(p, e, strict=True):
            ax.annotate(f"{_fmt(v)}", (q[a], q[b]), xytext=(7, 7), textcoords="offset points",
                        fontsize=8.5, zorder=4,
                        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                              "alpha": 0.8})
    lo_a, hi_a = p[:, a].min() - 0.15 * span, p[:, a].max() + 0.15 * span
    lo_b, hi_b = p[:, b].min() - 0.15 * span, p[:, b].max() + 0.15 * span
    for pos, axis in luminaires:
        pos, axis = np.asarray(pos, np.float64), np.asarray(axis, np.float64)
        if not (lo_a <= pos[a] <= hi_a and lo_b <= pos[b] <= hi_b):
            continue
        ax.plot(pos[a], pos[b], "o", color="black", ms=4, zorder=5)
        ax.annotate("", (pos[a] + 0.08 * span * axis[a], pos[b] + 0.08 * span * axis[b]),
                    (pos[a], pos[b]), arrowprops={"arrowstyle": "->", "color": "black",
                                                  "lw": 0.9}, zorder=5)
    ax.set_xlim(lo_a, hi_a)
    ax.set_ylim(lo_b, hi_b)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(f"{names[a]} (m)")
    ax.set_ylabel(f"{names[b]} (m)")
    ax.grid(color="#e3e7ec", lw=0.7)
    from matplotlib.cm import ScalarMappable

    bar = fig.colorbar(ScalarMappable(norm=norm, cmap=_cmap(DEFAULT_CMAP)), cax=cax)
    bar.set_label("Illuminance (lx)")
    fig.suptitle(title, x=0.01, y=0.985, ha="left", va="top", fontsize=12)
    return _png(fig)


def grid_picture(grid: GridResult, config=None, *, title: str, luminaires=(),
                 size=(1200, 820)) -> GridPicture:
    """The picture of one grid (module docstring); ``config`` is its ``[[grids]]`` entry (for
    the limits drawn on a profile), ``luminaires`` ``(position, aim axis)`` pairs (m) drawn on
    a map or a plan where they stand over the grid. A map that cannot be drawn raises the renderer's :class:`LumijaxError`."""
    kind = picture_kind(grid.points, grid.normals, grid.shape)
    e = np.asarray(grid.illuminance_lux, np.float64)
    stats = f"Eavg {_fmt(e.mean())} lx, Emin {_fmt(e.min())} lx, Emax {_fmt(e.max())} lx"
    marks = ", luminaires over it as black dots with their aims" if len(luminaires) else ""
    if kind == "map":
        from ._falsecolour import falsecolour_map

        normal = _common_normal(grid.normals)
        if normal is None:
            normal = np.asarray(grid.normals, np.float64).mean(axis=0)
        with tempfile.TemporaryDirectory(prefix="lumijax-map-") as tmp:
            path = Path(tmp) / "map.png"
            falsecolour_map(grid.points, e, path, shape=grid.shape,
                            normal=normal if np.linalg.norm(normal) > 0 else None,
                            title=title, window_size=size, luminaires=luminaires)
            png = path.read_bytes()
        return GridPicture("map", png, f"{grid.name}: iso-lux map{marks}; {stats}, "
                           f"U0 {grid.stats['u0']:.2f}.")
    if kind == "profile":
        legs = len(path_legs(grid.points))
        png = profile_png(grid, config, title=title, size=(size[0], int(size[1] * 0.68)))
        return GridPicture("profile", png, f"{grid.name}: illuminance along the path "
                           f"({legs} leg{'s' if legs > 1 else ''}); {stats}.")
    png = plan_png(grid, config, title=title, luminaires=luminaires, size=size)
    return GridPicture("plan", png, f"{grid.name}: the points in plan, labelled in lx; {stats}.")


def safe_grid_picture(grid: GridResult, config=None, **kw) -> GridPicture | None:
    """:func:`grid_picture`, or None for a grid the renderer refuses (its numbers stay in the
    report's tables)."""
    try:
        return grid_picture(grid, config, **kw)
    except LumijaxError:
        return None
