"""The standards' calculation grids (docs/compliance.md): EN 12464-1 area grids by its spacing
rule, grids on a named surface of the model, and sensor grids at points or at another grid's
points. Plane and points grids are built by ``_scene._grid``; this module builds the rest, in
an order where a grid another one refers to (``at_grid``, ``exclude``) already exists."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from jaxtyping import Float, Int

from ..errors import ConfigError
from ._elements import Grid, plane_grid_points

__all__ = ["STANDARD_GRID_KINDS", "en12464_spacing", "area_counts", "road_counts",
           "SurfaceSamples",
           "surface_samples", "build_grids"]

STANDARD_GRID_KINDS = ("sensor", "area", "surface")
#: The spacing rule's cap (m), EN 12464-1:2021 (and 2011, section 4.4): p ≤ 10 m.
MAX_SPACING_M = 10.0


def en12464_spacing(d_m: float) -> float:
    """EN 12464-1's maximum grid spacing ``p = 0.2 · 5^log10(d)`` (m) for an area whose
    relevant dimension is ``d_m`` (m), capped at 10 m."""
    return float(min(0.2 * 5.0 ** math.log10(d_m), MAX_SPACING_M))


def area_counts(length_m: float, width_m: float, spacing_m: float | None = None
                ) -> tuple[int, int, float]:
    """Points along the two sides and the spacing used: the relevant dimension d is the longer
    side, or the shorter where the longer is twice it or more (EN 12464-1); each side gets
    the least whole number of cells no wider than p (``⌈side/p⌉``)."""
    long, short = max(length_m, width_m), min(length_m, width_m)
    d = short if long >= 2.0 * short else long
    p = en12464_spacing(d) if spacing_m is None else spacing_m
    return (max(1, math.ceil(length_m / p - 1e-9)), max(1, math.ceil(width_m / p - 1e-9)), p)


def road_counts(length_m: float, width_m: float) -> tuple[int, int]:
    """EN 13201-3:2015's illuminance points of a road field ``length_m`` (m, the luminaire
    spacing S) by ``width_m`` (m): N = 10 along for S ≤ 30 m, else the least N with
    S/N ≤ 3 m; across, the least n ≥ 3 with W/n ≤ 1.5 m."""
    n_along = 10 if length_m <= 30.0 + 1e-9 else math.ceil(length_m / 3.0 - 1e-9)
    return n_along, max(3, math.ceil(width_m / 1.5 - 1e-9))


@dataclass(frozen=True)
class SurfaceSamples:
    """Points on a geometry item's triangles: each the centroid of one of n² equal pieces of
    its triangle, moved ``offset`` along the normal; ``area_m2`` the piece's area and
    ``material`` the triangle's material index (into ``scene.materials``)."""

    points: Float[np.ndarray, "points 3"]
    normals: Float[np.ndarray, "points 3"]
    area_m2: Float[np.ndarray, " points"]
    material: Int[np.ndarray, " points"]


def surface_samples(triangles, item: int, offset_m: float, spacing_m: float) -> SurfaceSamples:
    """The samples of geometry item ``item`` (``triangles.item``) about ``spacing_m`` apart."""
    sel = np.flatnonzero(triangles.item == item)
    tri = np.asarray(triangles.vertices[sel], np.float64)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    cross = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    keep = area > 0
    tri, cross, area, sel = tri[keep], cross[keep], area[keep], sel[keep]
    pts, nrm, ar, mat = [], [], [], []
    longest = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2), axis=1) if len(
        tri) else np.zeros(0)
    for n in np.unique(np.maximum(1, np.ceil(longest / spacing_m - 1e-9)).astype(int)):
        rows = np.flatnonzero(np.maximum(1, np.ceil(longest / spacing_m - 1e-9)) == n)
        bary = _piece_centroids(int(n))  # (n², 3) barycentric
        p = np.einsum("kb,tbc->tkc", bary, tri[rows]).reshape(-1, 3)
        nn = cross[rows] / np.linalg.norm(cross[rows], axis=1, keepdims=True)
        nn = np.repeat(nn, len(bary), axis=0)
        pts.append(p + offset_m * nn)
        nrm.append(nn)
        ar.append(np.repeat(area[rows] / len(bary), len(bary)))
        mat.append(np.repeat(triangles.material[sel[rows]], len(bary)))
    if not pts:
        z = np.zeros((0, 3))
        return SurfaceSamples(z, z, np.zeros(0), np.zeros(0, np.int64))
    return SurfaceSamples(np.concatenate(pts), np.concatenate(nrm), np.concatenate(ar),
                          np.concatenate(mat))


def _piece_centroids(n: int) -> np.ndarray:
    """Barycentric centroids of the n² congruent pieces of a triangle cut n times per side."""
    out = []
    for i in range(n):
        for j in range(n - i):
            out.append(((i + 1 / 3) / n, (j + 1 / 3) / n))  # upright piece
            if i + j < n - 1:
                out.append(((i + 2 / 3) / n, (j + 2 / 3) / n))  # inverted piece
    ab = np.array(out)
    return np.column_stack([1.0 - ab.sum(axis=1), ab[:, 0], ab[:, 1]])


def _area_points(g, frame, src, key, areas: dict):
    """Points of an area grid, and its rectangle (origin, u, v) for ``exclude``."""
    u, v = frame.vectors(g.u), frame.vectors(g.v)
    lu, lv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    cross = np.cross(u, v)
    if np.linalg.norm(cross) <= 1e-12 * lu * lv:
        raise ConfigError("'u' and 'v' are parallel or zero: the area has no area",
                          file=src, key=key)
    origin = frame.points(g.origin)
    b = g.border_m
    if 2 * b >= lu or 2 * b >= lv:
        raise ConfigError(f"a border of {b:g} m leaves no area inside {lu:g} × {lv:g} m: the "
                          "area has no points", file=src, key=f"{key}.border_m")
    uu, vv = u / lu, v / lv
    o = origin + b * uu + b * vv
    u2, v2 = (lu - 2 * b) * uu, (lv - 2 * b) * vv
    if g.rule == "EN 13201-3":
        nu, nv = road_counts(lu, lv)
    else:
        nu, nv, _ = area_counts(lu - 2 * b, lv - 2 * b, g.spacing)
    if nu * nv > 100_000_000:
        raise ConfigError(f"{nu} × {nv} points, more than a grid may have", file=src, key=key)
    pts = plane_grid_points(o, u2, v2, nu, nv)
    shape = (nu, nv)
    if g.exclude is not None:
        if g.exclude not in areas:
            raise ConfigError(f"'exclude' names {g.exclude!r}, which is not an area grid "
                              f"(area grids: {', '.join(areas) or 'none'})", file=src,
                              key=f"{key}.exclude")
        eo, eu, ev = areas[g.exclude]
        rel = pts - eo
        s, t = rel @ eu / (eu @ eu), rel @ ev / (ev @ ev)
        inside = (s > 0) & (s < 1) & (t > 0) & (t < 1)
        pts, shape = pts[~inside], None
    if not len(pts):
        raise ConfigError("the area has no points (all of it is excluded)", file=src, key=key)
    n = frame.normals(np.asarray(g.normal, np.float64)) if g.normal is not None else (
        cross / np.linalg.norm(cross))
    grid = Grid(g.name, pts, np.broadcast_to(n, pts.shape).copy(), shape=shape,
                origin=o if shape else None, u=u2 if shape else None, v=v2 if shape else None,
                target_lux=g.target_lux)
    return grid, (origin, u, v)


def build_grids(cfg, triangles, frame_of, plain, src) -> tuple[Grid, ...]:
    """Every grid of ``cfg``, in config order; ``plain(g, frame, key)`` builds plane and
    points grids (``_scene._grid``)."""
    built: dict[int, Grid] = {}
    areas: dict[str, tuple] = {}
    names = [g.name for g in cfg.geometry]
    order = sorted(range(len(cfg.grids)), key=lambda i: (
        {"sensor": 2, "area": 1}.get(cfg.grids[i].kind, 0), i))
    for i in order:
        g = cfg.grids[i]
        key = f"grids[{i}]"
        frame = frame_of(g.group)
        if g.kind not in STANDARD_GRID_KINDS:
            built[i] = plain(g, frame, key)
        elif g.kind == "area":
            built[i], areas[g.name] = _area_points(g, frame, src, key, areas)
        elif g.kind == "surface":
            if g.geometry not in names:
                known = ", ".join(n for n in names if n) or "no geometry is named"
                raise ConfigError(f"no geometry named {g.geometry!r} (named: {known})",
                                  file=src, key=f"{key}.geometry")
            s = surface_samples(triangles, names.index(g.geometry), g.offset_m, g.spacing)
            if not len(s.points):
                raise ConfigError(f"geometry {g.geometry!r} has no area: no points to place",
                                  file=src, key=f"{key}.geometry")
            built[i] = Grid(g.name, s.points, s.normals, target_lux=g.target_lux)
        else:
            built[i] = _sensor_grid(g, frame, src, key, cfg, built)
    return tuple(built[i] for i in range(len(cfg.grids)))


def _sensor_grid(g, frame, src, key, cfg, built) -> Grid:
    if g.points is not None:
        pts = frame.points(np.asarray(g.points, np.float64))
    else:
        at = [j for j, o in enumerate(cfg.grids) if o.name == g.at_grid]
        if not at or cfg.grids[at[0]].kind == "sensor":
            raise ConfigError(f"'at_grid' names {g.at_grid!r}, which is not a grid of plane, "
                              "points, area or surface kind", file=src, key=f"{key}.at_grid")
        pts = built[at[0]].points
    pts = pts + frame.vectors(np.asarray(g.offset_m, np.float64))
    # the normal the pipeline lights these points with: the facing (vertical) or the axis
    n = np.asarray(g.facing if g.facing is not None else g.axis, np.float64)
    n = frame.normals(n)
    return Grid(g.name, pts, np.broadcast_to(n, pts.shape).copy(), target_lux=g.target_lux)
