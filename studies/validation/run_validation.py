"""Validation of lumijax's inter-reflection against analytic references and Radiance.

    python studies/validation/run_validation.py            # everything, writes RESULTS.md
    python studies/validation/run_validation.py --quick    # coarse meshes, a smoke run
    python studies/validation/run_validation.py --no-radiance

Uses lumijax's public API only: every case is a TOML study written into an output folder
(``studies/validation/out/`` by default, ignored by nothing: pass ``--out`` to put it elsewhere),
then ``lumijax.load_study`` and ``lumijax.compute``. The cases and their references are explained
in ``studies/validation/README.md``; the numbers of the last full run are in ``RESULTS.md``.

Cases
-----
1. Integrating sphere (inward icosphere, isotropic source at the centre), ρ = 0.2, 0.5, 0.8:
   mean and worst patch irradiance vs Φ/(A(1−ρ)); indirect illuminance at interior points vs
   ρΦ/(A(1−ρ)). Tolerances from the issue: 1 % on the mean, 3 % point-wise.
2. Cube room (4 × 4 × 4 m, the geometry of CIE 171:2006 test case 5.8), flux balance: the
   area-weighted mean total irradiance is Φ/(S(1−ρ)) for any source (reference §9.1);
   and a furnace (every wall faced by a uniform Lambertian emitter of exitance M): total
   irradiance M/(1−ρ) on every patch and at every interior point, whatever its normal (§9.3).
3. A furnished room, side by side with Radiance (``rtrace -I``), same geometry, luminaire and
   grids; direct only (-ab 0) and with inter-reflection.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import lumijax

HERE = Path(__file__).resolve().parent
WHTEFFICACY = 179.0  # lm/W, Radiance's luminous efficacy of its "white" (equal-energy) light


# ----------------------------------------------------------------------------------------------
# helpers


@dataclass
class Row:
    """One line of the results table."""

    case: str
    quantity: str
    reference: str
    value: str
    error: str
    tolerance: str = ""
    ok: bool | None = None
    time_s: str = ""
    notes: str = ""

    def __post_init__(self):
        if self.ok is not None:  # numpy comparisons give np.bool_, which `is True` misses
            self.ok = bool(self.ok)

    def cells(self):
        flag = "" if self.ok is None else ("pass" if self.ok else "**FAIL**")
        return [self.case, self.quantity, self.reference, self.value, self.error,
                self.tolerance, flag, self.time_s, self.notes]


HEADER = ["case", "quantity", "reference", "lumijax", "error", "tolerance", "", "wall s", "notes"]


@dataclass
class Report:
    rows: list[Row] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def add(self, row: Row):
        self.rows.append(row)
        print(" | ".join(row.cells()), flush=True)


def write_study(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")
    return path


def run(path: Path):
    """Load and compute a study; return the results and the wall time (s) of both."""
    t0 = time.perf_counter()
    res = lumijax.compute(lumijax.load_study(path))
    return res, time.perf_counter() - t0


def wall_cell(res, wall: float) -> str:
    """Wall time, marked when the transport operator came from the cache."""
    hit = res.solver.get("operator_cache_hit")
    return f"{wall:.1f}" + (" (operator cached)" if hit else "")


def pct(x: float) -> str:
    return f"{100 * x:+.2f} %"


def area_mean(values, area) -> float:
    return float(np.sum(values * area) / np.sum(area))


def interior_points(n: int, radius: float, seed: int = 1):
    """n points inside a ball of `radius` (not too near the centre) with random unit normals."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = radius * rng.uniform(0.25, 1.0, size=(n, 1)) ** (1 / 3)
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return d * r, nrm


def toml_value(v) -> str:
    """A TOML value: JSON writes numbers, strings, booleans and lists as TOML reads them; a dict
    is an inline table."""
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    return json.dumps(v)


def table(header: str, **keys) -> str:
    """One TOML table, ``header`` as written (``[name]`` or ``[[name]]``), then a key a line."""
    return header + "\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in keys.items())


def rounded(a) -> list:
    """Coordinates (m) to the µm, as the study files carry them."""
    return [[round(float(v), 6) for v in row] for row in a]


def box(lo, hi, normals: str, material: str, **keys) -> str:
    return table("[[geometry]]", kind="box", min=list(lo), max=list(hi), normals=normals,
                 material=material, **keys)


# ----------------------------------------------------------------------------------------------
# 1. integrating sphere


def sphere_study(folder: Path, rho: float, *, subdivisions: int, patch_size: float,
                 gather_rays: int, points: int, flux: float = 10_000.0, radius: float = 2.0):
    """Write the integrating-sphere study (inward icosphere, isotropic source at the centre,
    ``points`` interior calculation points with random normals); return its path, the mesh's
    own area (m²) and the points. Shared with ``tests/validation``."""
    import trimesh

    folder.mkdir(parents=True, exist_ok=True)
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    sphere.invert()  # seen from inside: normals point inward
    sphere.export(folder / "sphere.ply")
    pts, nrm = interior_points(points, 0.75 * radius)
    path = write_study(folder, f"rho{rho}", "".join([
        table("[study]", name=f"integrating sphere rho={rho}"),
        table("[materials.wall]", reflectance=rho),
        table("[photometry.iso]", kind="isotropic", flux_lm=flux),
        table("[[geometry]]", kind="mesh", file="sphere.ply", material="wall"),
        table("[[luminaires]]", name="L", photometry="iso", position=[0, 0, 0], network="n"),
        table("[[grids]]", name="inside", kind="points", points=rounded(pts),
              normals=rounded(nrm)),
        table("[solver]", patch_size=patch_size, gather_rays=gather_rays)]))
    return path, float(sphere.area), pts


def sphere_case(out: Path, rho: float, subdivisions: int, patch_size: float, rep: Report,
                flux: float = 10_000.0, gather_rays: int = 4096, radius: float = 2.0):
    # one folder: the ρ variants share the operator (reflectance is not in its key)
    path, area, _ = sphere_study(out / f"sphere-s{subdivisions}", rho, subdivisions=subdivisions,
                                 patch_size=patch_size, gather_rays=gather_rays, points=24,
                                 flux=flux, radius=radius)
    res, wall = run(path)
    sol = res.lighting
    e = sol.patch_illuminance()[0]
    ref = flux / (area * (1 - rho))
    mean = area_mean(e, sol.coarse.patches.area)
    worst = e[np.argmax(np.abs(e - ref))]
    g = res.grids["inside"]
    indirect = g.illuminance_lux - g.at_dimmers_direct(g.dimmers)
    ref_ind = rho * ref
    worst_ind = indirect[np.argmax(np.abs(indirect - ref_ind))]
    case = f"1 sphere ρ={rho}"
    geo = f"icosphere s{subdivisions}, {sol.coarse.patches.n} patches"
    rep.add(Row(case, "mean patch irradiance (lx)", f"Φ/(A(1−ρ)) = {ref:.2f}", f"{mean:.2f}",
                pct(mean / ref - 1), "1 %", abs(mean / ref - 1) <= 0.01, wall_cell(res, wall), geo))
    rep.add(Row(case, "worst patch irradiance (lx)", f"{ref:.2f}", f"{worst:.2f}",
                pct(worst / ref - 1), "3 %", abs(worst / ref - 1) <= 0.03))
    rep.add(Row(case, "indirect at 24 interior points (lx), mean / worst",
                f"ρΦ/(A(1−ρ)) = {ref_ind:.2f}", f"{indirect.mean():.2f} / {worst_ind:.2f}",
                f"{pct(indirect.mean() / ref_ind - 1)} / {pct(worst_ind / ref_ind - 1)}",
                "1 % / 3 %",
                abs(indirect.mean() / ref_ind - 1) <= 0.01
                and abs(worst_ind / ref_ind - 1) <= 0.03, "", f"{gather_rays} gather rays"))
    # The direct light alone: what the patches receive from the source (their centroid values ×
    # area) against the flux Φ that lands on the walls. Any excess is point sampling of the
    # inverse-square law on flat facets, not inter-reflection, and scales every value above.
    direct = float(np.sum(sol.coarse.patch_direct[0] * sol.coarse.patches.area))
    rep.add(Row(case, "direct flux on the patches, Σ A·E_direct (lm)", f"Φ = {flux:.0f}",
                f"{direct:.1f}", pct(direct / flux - 1),
                notes="informative: centroid sampling of the direct light"))
    return res


# ----------------------------------------------------------------------------------------------
# 2. cube room: flux balance and furnace (CIE 171 TC 5.8 geometry: 4 x 4 x 4 m, S = 96 m²)

CUBE = 4.0


def cube_flux_case(out: Path, rho: float, patch_size: float, rep: Report, flux: float = 10_000.0):
    """Isotropic source at the centre and an off-centre tilted Lambertian: Φ/(S(1−ρ))."""
    folder = out / "cube"  # every cube study shares one operator (materials are not in its key)
    path = write_study(folder, f"flux-rho{rho}", "".join([
        table("[study]", name=f"cube flux balance rho={rho}"),
        table("[materials.wall]", reflectance=rho),
        table("[photometry.iso]", kind="isotropic", flux_lm=flux),
        table("[photometry.down]", kind="lambertian", flux_lm=flux),
        box([0, 0, 0], [CUBE] * 3, "inward", "wall"),
        table("[[luminaires]]", name="centre", photometry="iso", position=[2, 2, 2],
              network="iso"),
        table("[[luminaires]]", name="tilted", photometry="down", position=[1.0, 2.7, 3.5],
              aim={"tilt": 35, "pan": 20}, network="lambertian"),
        table("[[grids]]", name="floor", kind="plane", origin=[0, 0, 0.0], u=[CUBE, 0, 0],
              v=[0, CUBE, 0], nu=8, nv=8),
        table("[solver]", patch_size=patch_size)]))
    res, wall = run(path)
    sol = res.lighting
    e = sol.patch_illuminance()
    s = CUBE * CUBE * 6
    ref = flux / (s * (1 - rho))
    case = f"2 cube ρ={rho}"
    for k, name in enumerate(sol.scene.network_names):
        mean = area_mean(e[k], sol.coarse.patches.area)
        rep.add(Row(case, f"mean total irradiance, {name} source (lx)",
                    f"Φ/(S(1−ρ)) = {ref:.2f}", f"{mean:.3f}", pct(mean / ref - 1), "1 %",
                    abs(mean / ref - 1) <= 0.01, wall_cell(res, wall) if k == 0 else "",
                    f"{sol.coarse.patches.n} patches" if k == 0 else ""))
    # the floor grid's indirect part, for information: not uniform in a cube (§9.2)
    g = res.grids["floor"]
    ind = sol.point_indirect[0][: len(g.points)]
    rep.add(Row(case, "floor indirect, centre source, min…max / uniform value", "(informative)",
                f"{ind.min():.1f}…{ind.max():.1f} / {rho * ref:.1f}",
                f"{pct(ind.min() / (rho * ref) - 1)} … {pct(ind.max() / (rho * ref) - 1)}",
                notes="a cube is not a sphere: not uniform (§9.2)"))
    return res


def cube_furnace_case(out: Path, rho: float, patch_size: float, rep: Report,
                      exitance: float = 100.0, gather_rays: int = 4096):
    """Every wall faced by a Lambertian area source of exitance M, 1 mm in front of it.

    The walls and the emitters together are a uniform diffuse enclosure: wherever one looks
    one sees M + B with B = ρ(M + B), so the irradiance is M/(1−ρ) on every patch and at every
    interior point whatever its normal.
    """
    folder = out / "cube"
    eps = 1e-3
    c = CUBE
    flux = exitance * c * c
    # (origin, u, v) with u × v pointing into the room
    faces = [
        ([0, 0, eps], [c, 0, 0], [0, c, 0]),  # floor, +z
        ([0, 0, c - eps], [0, c, 0], [c, 0, 0]),  # ceiling, −z
        ([eps, 0, 0], [0, c, 0], [0, 0, c]),  # x = 0, +x
        ([c - eps, 0, 0], [0, 0, c], [0, c, 0]),  # x = c, −x
        ([0, eps, 0], [0, 0, c], [c, 0, 0]),  # y = 0, +y
        ([0, c - eps, 0], [c, 0, 0], [0, 0, c]),  # y = c, −y
    ]
    lum = "".join(table("[[luminaires]]", kind="area", name=f"E{i}", origin=o, u=u, v=v,
                        flux_lm=flux, network="all") for i, (o, u, v) in enumerate(faces))
    pts, nrm = interior_points(16, 1.2)
    pts += c / 2
    path = write_study(folder, f"furnace-rho{rho}", "".join([
        table("[study]", name=f"cube furnace rho={rho}"),
        table("[materials.wall]", reflectance=rho),
        box([0, 0, 0], [c] * 3, "inward", "wall"), lum,
        table("[[grids]]", name="inside", kind="points", points=rounded(pts),
              normals=rounded(nrm)),
        table("[solver]", patch_size=patch_size, gather_rays=gather_rays)]))
    res, wall = run(path)
    sol = res.lighting
    e = sol.patch_illuminance()[0]
    ref = exitance / (1 - rho)
    mean = area_mean(e, sol.coarse.patches.area)
    worst = e[np.argmax(np.abs(e - ref))]
    g = res.grids["inside"]
    tot = g.illuminance_lux
    worst_pt = tot[np.argmax(np.abs(tot - ref))]
    case = f"2 furnace ρ={rho}"
    rep.add(Row(case, "patch irradiance (lx), mean / worst", f"M/(1−ρ) = {ref:.2f}",
                f"{mean:.2f} / {worst:.2f}", f"{pct(mean / ref - 1)} / {pct(worst / ref - 1)}",
                "1 % / 3 %", abs(mean / ref - 1) <= 0.01 and abs(worst / ref - 1) <= 0.03,
                wall_cell(res, wall), f"{sol.coarse.patches.n} patches"))
    rep.add(Row(case, "16 interior points, any normal (lx), mean / worst", f"{ref:.2f}",
                f"{tot.mean():.2f} / {worst_pt:.2f}",
                f"{pct(tot.mean() / ref - 1)} / {pct(worst_pt / ref - 1)}", "1 % / 3 %",
                abs(tot.mean() / ref - 1) <= 0.01 and abs(worst_pt / ref - 1) <= 0.03))
    return res


# ----------------------------------------------------------------------------------------------
# 3. furnished room vs Radiance

ROOM = (5.0, 4.0, 3.0)
TABLE = ((1.6, 1.2, 0.70), (3.4, 2.4, 0.75))  # min, max of the table top (an outward box)
LAMP = (2.2, 2.0, 2.5)
LAMP_FLUX = 5000.0  # lm, isotropic
WP_Z = 0.8
ROOM_RHO = 0.5


def room_study(folder: Path, patch_size: float, gather_rays: int, spacing: float) -> Path:
    x, y, _ = ROOM
    plane = {"kind": "plane", "u": [x - 1.0, 0, 0], "v": [0, y - 1.0, 0], "spacing": spacing}
    return write_study(folder, "study", "".join([
        table("[study]", name="furnished room vs Radiance"),
        table("[materials.grey]", reflectance=ROOM_RHO),
        table("[photometry.iso]", kind="isotropic", flux_lm=LAMP_FLUX),
        box([0, 0, 0], ROOM, "inward", "grey", name="room"),
        box(TABLE[0], TABLE[1], "outward", "grey", name="table"),
        table("[[luminaires]]", name="lamp", photometry="iso", position=list(LAMP), network="n"),
        table("[[grids]]", name="workplane", origin=[0.5, 0.5, WP_Z], **plane),
        table("[[grids]]", name="floor", origin=[0.5, 0.5, 0.02], **plane),
        table("[solver]", patch_size=patch_size, gather_rays=gather_rays, cache=False)]))


def _rad_box(name: str, lo, hi, inward: bool) -> str:
    """A Radiance box as six polygons; Radiance's plastic is two-sided, orientation is cosmetic."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    quads = [
        [(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)],  # bottom (normal −z)
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # top (+z)
        [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],  # x0 (−x)
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],  # x1 (+x)
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],  # y0 (−y)
        [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],  # y1 (+y)
    ]
    out = []
    for i, q in enumerate(quads):
        if inward:
            q = q[::-1]
        coords = " ".join(f"{v:g}" for p in q for v in p)
        out.append(f"grey polygon {name}.{i}\n0\n0\n12 {coords}\n")
    return "".join(out)


def radiance_scene(folder: Path, sphere_r: float = 0.02) -> Path:
    """The same room for Radiance: grey plastic ρ, the lamp as a small sphere `light`.

    A sphere of radius r and radiance L emits Φ = π L · 4π r² (W), so an isotropic lamp of
    Φ lm is L = (Φ / 179) / (4 π² r²) W/(sr m²) on each of R, G, B (grey, WHTEFFICACY = 179).
    """
    phi_w = LAMP_FLUX / WHTEFFICACY
    radiance = phi_w / (4 * math.pi**2 * sphere_r**2)
    text = (
        f"void plastic grey\n0\n0\n5 {ROOM_RHO} {ROOM_RHO} {ROOM_RHO} 0 0\n"
        f"void light lamp\n0\n0\n3 {radiance:.6g} {radiance:.6g} {radiance:.6g}\n"
        f"lamp sphere bulb\n0\n0\n4 {LAMP[0]} {LAMP[1]} {LAMP[2]} {sphere_r}\n"
        + _rad_box("room", (0, 0, 0), ROOM, inward=True)
        + _rad_box("table", *TABLE, inward=False)
    )
    path = folder / "room.rad"
    path.write_text(text)
    return path


def radiance_illuminance(folder: Path, scene: Path, points, normals, params) -> tuple:
    """Illuminance (lx) at points from `rtrace -I` (W/m² per channel × 179), and wall time."""
    import pyradiance as pr

    octree = folder / "room.oct"
    t0 = time.perf_counter()
    octree.write_bytes(pr.oconv(str(scene)))
    # start the sensor a hair above its plane, as rtrace -I measures at the ray origin
    rays = "".join(f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f} {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}\n"
                   for p, n in zip(points, normals, strict=True))
    out = pr.rtrace(rays.encode(), str(octree), irradiance=True, header=False,
                    params=list(params))
    wall = time.perf_counter() - t0
    rgb = np.array([[float(v) for v in line.split()] for line in out.decode().splitlines()
                    if line.strip()])
    lux = WHTEFFICACY * (0.265 * rgb[:, 0] + 0.670 * rgb[:, 1] + 0.065 * rgb[:, 2])
    return lux, wall


def radiance_case(out: Path, rep: Report, quick: bool):
    try:
        import pyradiance  # noqa: F401
    except ImportError:
        msg = ("Radiance comparison skipped: pyradiance is not installed "
               "(pip install '.[benchmark]').")
        print(msg)
        rep.notes.append(msg)
        return None
    folder = out / "room-radiance"
    patch_size = 0.3 if quick else 0.15
    gather = 1024 if quick else 4096
    path = room_study(folder, patch_size=patch_size, gather_rays=gather,
                      spacing=0.5 if quick else 0.25)
    res, wall_lj = run(path)
    t0 = time.perf_counter()
    res_d = lumijax.compute(lumijax.load_study(path), indirect=False)
    wall_lj_d = time.perf_counter() - t0
    scene = radiance_scene(folder)
    nproc = os.cpu_count() or 1
    direct_params = ["-ab", "0", "-dj", "0", "-ds", "0.02", "-dt", "0", "-dc", "1"]
    if quick:
        amb = ["-ab", "6", "-aa", "0.1", "-ar", "256", "-ad", "1024", "-as", "256", "-lw", "1e-4"]
    else:
        # -ab 8 -ad 4096 -lw 1e-5 ran > 13 CPU minutes on 384 points without finishing here;
        # the bounces past 7 carry ρ⁷ ≈ 0.8 % of the indirect light at ρ = 0.5
        amb = ["-ab", "7", "-aa", "0.08", "-ar", "256", "-ad", "2048", "-as", "512",
               "-lw", "1e-4"]
    params_gi = amb + direct_params[2:]
    names = ("workplane", "floor")
    pts = np.concatenate([res.grids[n].points for n in names])
    nrm = np.concatenate([res.grids[n].normals for n in names])
    rad_d_all, t_rd = radiance_illuminance(folder, scene, pts, nrm, direct_params)
    rad_t_all, t_rt = radiance_illuminance(folder, scene, pts, nrm, params_gi)
    start = 0
    for gname in names:
        g = res.grids[gname]
        sl = slice(start, start + len(g.points))
        start += len(g.points)
        rad_d, rad_t = rad_d_all[sl], rad_t_all[sl]
        lj_t = g.illuminance_lux
        lj_d = res_d.grids[gname].illuminance_lux
        first = gname == names[0]
        for label, lj, rad, times in (
            ("direct (-ab 0)", lj_d, rad_d, (wall_lj_d, t_rd)),
            (f"total (-ab {amb[1]})", lj_t, rad_t, (wall_lj, t_rt)),
            ("indirect = total − direct", lj_t - lj_d, rad_t - rad_d, None),
        ):
            lit = rad > 0.01 * rad.max()  # relative errors where Radiance sees light
            rel = lj[lit] / rad[lit] - 1
            rms = float(np.sqrt(np.mean(rel**2)))
            mean_rel = float(np.mean(lj) / np.mean(rad) - 1)
            dark = int(np.sum(~lit))
            note = f"{len(lj)} points"
            if dark:
                note += (f" ({dark} in the table's shadow: lumijax max "
                         f"{np.max(np.abs(lj[~lit])):.2g} lx there)")
            if label.startswith("total"):
                note += f"; {res.lighting.coarse.patches.n} patches, {gather} gather rays"
            time_cell = ""
            if times is not None:
                time_cell = (f"lumijax {times[0]:.2f} / Radiance {times[1]:.2f}"
                             + (" (both grids)" if first else " (same run)"))
            rep.add(Row(
                f"3 room vs Radiance, {gname}", f"{label}: mean lx",
                f"Radiance {np.mean(rad):.2f}", f"{np.mean(lj):.2f}",
                f"mean {pct(mean_rel)}, RMS {100 * rms:.2f} %, max {100 * np.max(np.abs(rel)):.2f} %",
                "", None, time_cell, note,
            ))
    rep.notes.append(
        f"Radiance: pyradiance {pyradiance.__version__}, rtrace -I -h, direct {' '.join(direct_params)};"
        f" with inter-reflection {' '.join(params_gi)}; run on one process (nproc here = {nproc})."
        " Radiance times include oconv. lumijax times include loading, meshing, the form-factor"
        " build (operator cache off), JIT compilation, the solve and gathering."
    )
    return res


# ----------------------------------------------------------------------------------------------


def machine() -> list[str]:
    uname = " ".join(platform.uname())
    try:
        uname = subprocess.run(["uname", "-a"], capture_output=True, text=True,
                               check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        pass
    import jax

    return [
        f"- machine: `{uname}`",
        f"- `nproc`: {os.cpu_count()} (shared with other work: timings ±30 %)",
        f"- date: {datetime.datetime.now().astimezone().isoformat(timespec='minutes')}",
        f"- lumijax {lumijax.__version__}, jax {jax.__version__}, Python {sys.version.split()[0]}",
    ]


#: Sections in run order, and the prefix of their rows' first cell.
SECTIONS = {"sphere": "1 sphere", "cube": "2 cube", "furnace": "2 furnace", "radiance": "3 room"}


def _row_line(r: Row) -> str:
    return "| " + " | ".join(c.replace("|", "\\|") for c in r.cells()) + " |"


def _kept_sections(previous: str, rerun: set[str]) -> tuple[dict[str, list[str]], list[str], str]:
    """The table lines of the sections *not* re-run, from a previous RESULTS.md, with that run's
    notes and date, so that a partial run (``--only``) updates its rows and keeps the others
    verbatim instead of dropping them."""
    kept: dict[str, list[str]] = {s: [] for s in SECTIONS if s not in rerun}
    notes, date = [], "an earlier run"
    for line in previous.splitlines():
        if line.startswith("- date: ") and date == "an earlier run":
            date = line.removeprefix("- date: ").strip()
        elif line.startswith("- ") and not line.startswith(("- machine", "- `nproc`", "- lumijax ")):
            notes.append(line[2:])
        for s in kept:
            if line.startswith(f"| {SECTIONS[s]}"):
                kept[s].append(line)
    return kept, notes, date


def _changes(rep: Report, previous: str, date: str) -> str:
    """The re-run rows whose error column changed, old → new, read from the previous table."""
    old = {}
    for line in previous.splitlines():
        cells = [c.strip() for c in line.strip("| ").split(" | ")]
        if len(cells) >= 5 and cells[0][:1].isdigit():
            old[(cells[0], cells[1])] = cells[4]
    changed = [f"{r.case}, {r.quantity}: {old[(r.case, r.quantity)]} → {r.error}"
               for r in rep.rows
               if (r.case, r.quantity) in old and old[(r.case, r.quantity)] != r.error]
    if not changed:
        return f"No error changed against the run of {date}."
    return f"Errors changed against the run of {date}: " + "; ".join(changed) + "."


def markdown(rep: Report, args, previous: str | None = None) -> str:
    only = [s for s in SECTIONS if s in set(args.only.split(","))]
    kept, old_notes, old_date = ({}, [], "") if previous is None else _kept_sections(
        previous, set(only))
    cmd = "python studies/validation/run_validation.py" + (" --quick" if args.quick else "")
    if kept:
        cmd += f" --only {','.join(only)}"
    lines = ["# Validation results", "", f"Written by `{cmd}`; see `README.md` for the cases.", ""]
    if kept:
        lines += [f"Re-run here: {', '.join(only)}. The rows of {', '.join(kept)} are copied "
                  f"unchanged from the run of {old_date} (same machine kind).", ""]
    lines += machine() + [""]
    lines.append("| " + " | ".join(HEADER) + " |")
    lines.append("|" + "---|" * len(HEADER))
    table = []
    for s in SECTIONS:
        if s in kept:
            table += kept[s]
        else:
            table += [_row_line(r) for r in rep.rows if r.case.startswith(SECTIONS[s])]
    lines += table + [""]
    passed = sum(line.split(" | ")[6] == "pass" for line in table)
    failed = sum(line.split(" | ")[6] == "**FAIL**" for line in table)
    lines.append(f"{passed} checks pass, {failed} fail.")
    lines.append("")
    notes = list(rep.notes)
    if previous is not None:
        notes.append(_changes(rep, previous, old_date))
    if "radiance" in kept:  # the Radiance settings note belongs to the kept rows
        notes = [n for n in old_notes if n.startswith("Radiance:")] + notes
    for n in notes:
        lines.append(f"- {n}")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=None, help="folder for the generated studies")
    ap.add_argument("--quick", action="store_true", help="coarse meshes (a smoke run)")
    ap.add_argument("--no-radiance", action="store_true")
    ap.add_argument("--results", type=Path, default=HERE / "RESULTS.md",
                    help="where to write the table (default studies/validation/RESULTS.md)")
    ap.add_argument("--only", default=",".join(SECTIONS),
                    help="comma-separated sections to run (sphere, cube, furnace, radiance); "
                         "the other sections' rows are kept from the existing --results file")
    ap.add_argument("--previous", type=Path, default=None,
                    help="results file to keep the other sections' rows from and to compare "
                         "with (default: --results)")
    args = ap.parse_args(argv)
    only = set(args.only.split(","))
    tmp = None
    out = args.out
    if out is None:
        tmp = tempfile.TemporaryDirectory(prefix="lumijax-validation-")
        out = Path(tmp.name)
    rep = Report()
    print(" | ".join(HEADER))
    if "sphere" in only:
        for rho in (0.2, 0.5, 0.8):
            if args.quick:
                sphere_case(out, rho, 3, 0.3, rep, gather_rays=1024)
            else:
                sphere_case(out, rho, 4, 0.2, rep)
    if "cube" in only:
        for rho in (0.2, 0.5, 0.8):
            cube_flux_case(out, rho, 0.4 if args.quick else 0.2, rep)
    if "furnace" in only:
        for rho in (0.2, 0.5, 0.8):
            cube_furnace_case(out, rho, 0.4 if args.quick else 0.2, rep,
                              gather_rays=1024 if args.quick else 4096)
    if "radiance" in only and not args.no_radiance:
        radiance_case(out, rep, args.quick)
    elif "radiance" in only:
        rep.notes.append("Radiance comparison not run (--no-radiance).")
    rep.notes.append(
        "CIE 171:2006: the report's tabulated reference values were not available to us (the "
        "report is sold by the CIE; only its abstract and third-party errata commentary are "
        "public). Case 2 uses the geometry of test case 5.8 (a 4 × 4 × 4 m room, S = 96 m², as "
        "described in I. Ashdown's CIE 171:2006 errata page, lightinganalysts.com) with the "
        "exact analytic flux-balance reference instead of the report's tables. Not reproduced: "
        "5.7 (diffuse reflections with internal obstructions; Ashdown reports its Table 19 as "
        "incorrect), 5.9 onwards and every experimental case. See README.md."
    )
    partial = set(SECTIONS) - only
    previous = None
    before = args.previous or args.results
    if partial and before.exists() and not args.quick:
        previous = before.read_text(encoding="utf-8")
        print(f"keeping the rows of {', '.join(sorted(partial))} from {before}")
    text = markdown(rep, args, previous)
    args.results.write_text(text, encoding="utf-8")
    print(f"\nwrote {args.results}")
    if tmp is not None:
        tmp.cleanup()
    return 1 if any(r.ok is False for r in rep.rows) else 0


if __name__ == "__main__":
    sys.exit(main())
