"""Generate Cour Carrée-like courtyard studies: lumijax's default study and the full-scale ones.

The scene follows the paper's headline case (Fasse & Paul 1995, sections 2 and 6): up to four
stone facades around a square court, each a row of identical bays between corner piers. A bay is
three storeys (ground floor, first floor, attic) of wall with a recessed window, two engaged
columns (half n-gon prisms; the columns of neighbouring bays stand 0.9 m apart and read as the
facade's double columns) and, per storey, a cornice running the facade's length. Every bay is a
group (its own local frame: x along the facade, y out into the court, z up) and all its
luminaires are placed in that frame, as the paper's designers placed theirs per bay.

Lighting, per bay: linear halogen washers under each cornice throwing light down the wall
(top-down ambient), narrow "dichroic" spots at each column base aimed up the column (bottom-up
accent), and a small spot per window picking out the ornament above it. Courtyard-wide: floods
on each facade's central pavilion and low path lights along the four entry paths. Networks are
per facade and kind (``S-wash``, ``S-attic``, ``S-columns``, ``S-windows``, …) plus ``floods``
and ``paths``: 18 for the full courtyard.

Photometry is lumijax's parametric model (docs/photometry.md) written as LM-63, spectra are
written as CSV (a 3200 K dichroic, and for the Stanislas-like variant an F-series fluorescent
behind a pink filter), and the bay is an OBJ mesh whose level of detail sets the triangle count.
All of it is generated, so the package can ship it. Run from the repository root::

    python studies/courtyard/make_courtyard.py            # everything below
    python studies/courtyard/make_courtyard.py default    # lumijax/data/studies/default/
    python studies/courtyard/make_courtyard.py full plate6 plate7   # configs/courtyard*.toml
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
KINDS = ("wash", "attic", "columns", "windows")
FACADES = ("S", "E", "N", "W")
#: Facade frames: rotation about z (deg) and the corner the facade's x axis starts from, in
#: units of the court's side L. Local y points into the court in every one.
_FACADE_FRAME = {"S": (0.0, (0, 0)), "E": (90.0, (1, 0)), "N": (180.0, (1, 1)),
                 "W": (270.0, (0, 1))}
#: Rated flux (lm) and electrical power (W) of one fitting of each kind.
FITTINGS = {
    "wash": (800.0, 50.0),      # 0.8 m bar, four 12 V halogen capsules
    "attic": (800.0, 50.0),
    "columns": (450.0, 35.0),   # 35 W dichroic spot, 8° beam
    "windows": (300.0, 20.0),   # 20 W spot on the ornament above a window
    "floods": (6000.0, 150.0),  # 150 W flood on the central pavilions
    "paths": (400.0, 20.0),     # low path light, Lambertian downwards
}


@dataclass(frozen=True)
class Courtyard:
    """Everything the generator needs; lengths in metres."""

    name: str = "Cour Carrée-like courtyard"
    description: str = ""
    facades: tuple[str, ...] = FACADES
    bays: int = 40                     # bays per facade
    bay_width: float = 4.0
    corner: float = 1.2                # plain pier at each end of a facade
    storeys: tuple[float, ...] = (6.5, 6.5, 4.5)  # ground, first, attic (floor to cornice top)
    cornice_height: tuple[float, ...] = (0.6, 0.6, 0.8)
    cornice_depth: float = 0.8
    column_radius: tuple[float, ...] = (0.3, 0.3, 0.22)
    column_offset: float = 0.45        # column axis from the bay's edge
    window: tuple[float, ...] = (1.3, 1.2, 3.0, 1.0, 1.6)  # width; sill, height per storey
    recess: float = 0.25               # window reveal depth
    lod: int = 0                       # 0: 8-gon columns, unsplit walls … 3: 32-gon, 5×5 splits
    washers: int = 3                   # per cornice and bay
    bar_length: float = 0.8
    floods_per_facade: int = 24
    paths_per_path: int = 6
    column_spectrum: str = "dichroic"  # "dichroic" (3200 K), "A", or a CSV name in spectra/
    wash_spectrum: str = "A"
    variant: str = "louvre"            # "louvre" or "stanislas" (pink-filtered fluorescent)
    dimmers: dict[str, float] = field(default_factory=dict)  # by kind
    target_patches: int = 200_000
    operator_patches: int | None = None  # two levels (docs/radiosity.md): coarse elements
    spectral_samples: int = 8
    gather_rays: int = 256
    grid_spacing: float = 1.0          # wall points (m)
    ground_spacing: float = 2.0
    optimise: bool = True
    gr_max: float | None = None        # [optimise]: the visitors' GR ceiling (power objective)

    @property
    def side(self) -> float:
        return 2 * self.corner + self.bays * self.bay_width

    @property
    def levels(self) -> list[tuple[float, float]]:
        """(floor, cornice top) of each storey."""
        z = np.concatenate([[0.0], np.cumsum(self.storeys)])
        return [(float(a), float(b)) for a, b in zip(z[:-1], z[1:], strict=True)]

    def windows(self, storey: int) -> tuple[float, float, float, float]:
        """Window opening (x0, x1, z0, z1) in the bay frame."""
        w = self.window[0]
        sill, height = (self.window[1:3] if storey < len(self.storeys) - 1 else self.window[3:5])
        z0 = self.levels[storey][0] + sill
        x0 = self.bay_width / 2 - w / 2
        return x0, x0 + w, z0, z0 + height

    def column_x(self) -> tuple[float, float]:
        return self.column_offset, self.bay_width - self.column_offset

    def networks(self) -> list[str]:
        return [f"{f}-{k}" for f in self.facades for k in KINDS] + ["floods", "paths"]

    def luminaire_count(self) -> int:
        n = len(self.storeys)
        per_bay = n * self.washers + 2 * n + n
        return (len(self.facades) * (self.bays * per_bay + self.floods_per_facade)
                + len(self.facades) * self.paths_per_path)


# --- geometry ---------------------------------------------------------------------------


def _lod(lod: int) -> tuple[int, int]:
    """(column polygon sides, splits per rectangle edge) of a level of detail."""
    return [(8, 1), (16, 2), (24, 3), (32, 5)][lod]


def _quad(o, u, v, n: int) -> list[np.ndarray]:
    """Triangles of the quad o, o+u, o+u+v, o+v split n × n; front face along u × v."""
    o, u, v = (np.asarray(a, float) for a in (o, u, v))
    out = []
    for i in range(n):
        for j in range(n):
            a = o + u * i / n + v * j / n
            du, dv = u / n, v / n
            out += [np.array([a, a + du, a + du + dv]), np.array([a, a + du + dv, a + dv])]
    return out


def bay_triangles(c: Courtyard) -> tuple[np.ndarray, np.ndarray]:
    """(stone, glass) triangles of one bay in its frame: walls, window reveals, columns."""
    sides, n = _lod(c.lod)
    W, d = c.bay_width, c.recess
    stone, glass = [], []
    for s, (z0, z1) in enumerate(c.levels):
        top = z1 - c.cornice_height[s]  # the wall stops under the storey's cornice
        x0, x1, wz0, wz1 = c.windows(s)
        ez, ex = (0, 0, 1), (1, 0, 0)
        # wall at y = 0 around the window opening, facing +y (u = +z, v = +x → u × v = +y)
        for o, hx, hz in (((0, 0, z0), x0, top - z0), ((x1, 0, z0), W - x1, top - z0),
                          ((x0, 0, z0), x1 - x0, wz0 - z0), ((x0, 0, wz1), x1 - x0, top - wz1)):
            stone += _quad(o, np.multiply(ez, hz), np.multiply(ex, hx), n)
        # reveals of the recess, facing into the opening
        stone += _quad((x0, -d, wz0), (0, d, 0), (0, 0, wz1 - wz0), n)   # y × z = +x
        stone += _quad((x1, -d, wz0), (0, 0, wz1 - wz0), (0, d, 0), n)   # z × y = −x
        stone += _quad((x0, -d, wz0), (x1 - x0, 0, 0), (0, d, 0), n)     # sill, x × y = +z
        stone += _quad((x0, -d, wz1), (0, d, 0), (x1 - x0, 0, 0), n)     # head, y × x = −z
        glass += _quad((x0, -d, wz0), (0, 0, wz1 - wz0), (x1 - x0, 0, 0), 1)
        # engaged columns: the half of an n-gon prism in front of the wall
        r = c.column_radius[s]
        for cx in c.column_x():
            ang = np.linspace(0.0, math.pi, sides // 2 + 1)
            pts = np.stack([cx + r * np.cos(ang), r * np.sin(ang)], axis=1)
            for a, b in zip(pts[:-1], pts[1:], strict=True):
                # from b to a then up: (a − b) × z points away from the axis
                stone += _quad((b[0], b[1], z0), (0, 0, top - z0), (a[0] - b[0], a[1] - b[1], 0),
                               n)
    return np.array(stone), np.array(glass)


def write_obj(path: Path, triangles: np.ndarray, comment: str) -> None:
    """A compact OBJ: shared vertices, 1-based faces, 4 significant decimals (0.1 mm)."""
    verts, index = {}, []
    for t in np.round(triangles, 4):
        index.append([verts.setdefault(tuple(p), len(verts)) + 1 for p in t])
    lines = [f"# {comment}", f"# {len(index)} triangles, metres"]
    lines += ["v " + " ".join(f"{x:g}" for x in v) for v in verts]
    lines += [f"f {a} {b} {e}" for a, b, e in index]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


# --- photometry and spectra ---------------------------------------------------------------


def write_assets(c: Courtyard, folder: Path) -> dict[str, str]:
    """Photometry, spectra and bay meshes under ``folder``; returns relative paths by name."""
    from lumijax.photometry import flood, linear_washer, spot, write_ies

    (folder / "photometry").mkdir(parents=True, exist_ok=True)
    (folder / "spectra").mkdir(exist_ok=True)
    (folder / "meshes").mkdir(exist_ok=True)
    rel = folder.name
    files = {
        "washer": "photometry/washer_800.ies",
        "column": "photometry/spot_8deg.ies",
        "window": "photometry/spot_20deg.ies",
        "flood": "photometry/flood_40x24.ies",
    }
    # a bar under the cornice: narrow across, wide along, its axis thrown 8° to the wall
    write_ies(linear_washer(FITTINGS["wash"][0], c.bar_length, 24.0, 110.0, width_m=0.06,
                            offset_deg=8.0), folder / files["washer"])
    write_ies(spot(FITTINGS["columns"][0], 8.0, 14.0), folder / files["column"])
    write_ies(spot(FITTINGS["windows"][0], 20.0, 36.0), folder / files["window"])
    write_ies(flood(FITTINGS["floods"][0], 40.0, 24.0), folder / files["flood"])
    for name, path in _write_spectra(folder / "spectra").items():
        files[name] = f"spectra/{path.name}"
    stone, glass = bay_triangles(c)
    sides, n = _lod(c.lod)
    files["bay"] = f"meshes/bay-lod{c.lod}.obj"
    files["glass"] = "meshes/bay-glass.obj"
    write_obj(folder / files["bay"], stone,
              f"courtyard bay, {c.bay_width:g} m, LOD {c.lod} ({sides}-gon columns, {n}x{n} "
              "splits) - generated by studies/courtyard/make_courtyard.py")
    write_obj(folder / files["glass"], glass, "courtyard bay windows (glass)")
    return {k: f"{rel}/{v}" for k, v in files.items()}


def _write_spectra(folder: Path) -> dict[str, Path]:
    """Dichroic 3200 K, warm limestone, and pink-filtered fluorescent spectra as CSV."""
    import colour

    def write_csv(path, wl, values, kind, name):
        col = "reflectance" if kind == "reflectance" else "value"
        rows = [f"# {name}; generated by studies/courtyard/make_courtyard.py", f"wavelength_nm,{col}"]
        rows += [f"{w:g},{v:.5f}" for w, v in zip(wl, values, strict=True)]
        path.write_text("\n".join(rows) + "\n", encoding="utf-8")
        return path

    wl = np.arange(380.0, 781.0, 5.0)
    out = {}
    # a dichroic reflector passes the visible of a ~3200 K filament (Planck's law)
    sd = colour.sd_blackbody(3200, colour.SpectralShape(380, 780, 5))
    out["dichroic"] = write_csv(folder / "dichroic_3200K.csv", wl, sd.values / sd.values.max(),
                                "emission", "dichroic halogen, 3200 K blackbody")
    # limestone: a smooth warm curve, 0.36 at 400 nm rising to 0.62 at 700 nm (luminous ≈ 0.52)
    stone = 0.36 + 0.26 / (1.0 + np.exp(-(wl - 520.0) / 45.0))
    out["limestone"] = write_csv(folder / "limestone.csv", wl, stone, "reflectance",
                                 "warm limestone (smooth model)")
    # Stanislas-like: a tri-phosphor fluorescent (FL11) behind a pink gel that cuts the green
    fl = colour.SDS_ILLUMINANTS["FL11"].copy().align(colour.SpectralShape(380, 780, 5))
    gel = 0.85 - 0.7 * np.exp(-0.5 * ((wl - 540.0) / 35.0) ** 2)
    pink = fl.values * gel
    out["pink"] = write_csv(folder / "fl11_pink_gel.csv", wl, pink / pink.max(), "emission",
                            "FL11 behind a pink gel (transmission 0.15 at 540 nm, 0.85 beyond)")
    return out


# --- the study ----------------------------------------------------------------------------


def _v(v) -> str:
    return "[" + ", ".join(f"{round(float(x), 4):g}" for x in v) + "]"


def _points(pts) -> str:
    return "[\n" + ",\n".join("  " + _v(p) for p in pts) + ",\n]"


def study_toml(c: Courtyard, files: dict[str, str], generator_args: str) -> str:
    L = c.side
    spectra = {"dichroic": f'"{files["dichroic"]}"', "pink": f'"{files["pink"]}"',
               "A": '"A"'}
    wash_sp = spectra["pink"] if c.variant == "stanislas" else spectra.get(c.wash_spectrum,
                                                                        f'"{c.wash_spectrum}"')
    col_sp = spectra.get(c.column_spectrum, f'"{c.column_spectrum}"')
    out = [
        f"# lumijax study generated by: python studies/courtyard/make_courtyard.py {generator_args}",
        "# Units: metres, lumens, lux, degrees. Frames and aims: docs/conventions.md.",
        f"# {len(c.facades)} facade(s) x {c.bays} bays, {c.luminaire_count()} luminaires, "
        f"{len(c.networks())} networks; each bay is a group (x along the facade, y into the "
        "court, z up).",
        "",
        "[study]",
        f'name = "{c.name}"',
        f'description = "{c.description}"',
        "",
        "[materials.stone]",
        f'reflectance = "{files["limestone"]}"  # warm limestone, luminous ρ ≈ 0.52',
        "[materials.glass]",
        "reflectance = 0.08",
        "[materials.paving]",
        "srgb = [0.42, 0.40, 0.36]  # grey-beige paving",
        "",
        "[photometry.washer]",
        f'file = "{files["washer"]}"',
        "[photometry.column]",
        f'file = "{files["column"]}"',
        "[photometry.window]",
        f'file = "{files["window"]}"',
        "[photometry.flood]",
        f'file = "{files["flood"]}"',
        "[photometry.path]",
        'kind = "lambertian"',
        f"flux_lm = {FITTINGS['paths'][0]:g}",
        "",
    ]
    n_st = len(c.storeys)
    per_kind = {"wash": (n_st - 1) * c.washers, "attic": c.washers, "columns": 2 * n_st,
                "windows": n_st}
    describe = {"wash": "top-down linear halogen bars under the ground- and first-floor cornices",
                "attic": "top-down linear halogen bars under the attic cornice",
                "columns": "bottom-up narrow dichroic spots at the column bases",
                "windows": "small spots on the ornaments above the windows"}
    for f in c.facades:
        for k in KINDS:
            n = per_kind[k] * c.bays
            out += [f"[networks.{f}-{k}]", f"dimmer = {c.dimmers.get(k, 1.0):g}",
                    f'description = "facade {f}: {describe[k]}"',
                    f"power_w = {n * FITTINGS[k][1]:g}"]
    nf, npth = len(c.facades) * c.floods_per_facade, len(c.facades) * c.paths_per_path
    out += ["[networks.floods]", f"dimmer = {c.dimmers.get('floods', 1.0):g}",
            'description = "floods from the court on each central pavilion"',
            f"power_w = {nf * FITTINGS['floods'][1]:g}",
            "[networks.paths]", f"dimmer = {c.dimmers.get('paths', 1.0):g}",
            'description = "low path lights along the entry paths"',
            f"power_w = {npth * FITTINGS['paths'][1]:g}", ""]

    # --- frames: facade groups around the court, bay groups along each facade
    for f in c.facades:
        rot, (cx, cy) = _FACADE_FRAME[f]
        out += [f"[groups.{f}]", f"translate = [{cx * L:g}, {cy * L:g}, 0]",
                f"rotate = [0, 0, {rot:g}]"]
        for b in range(c.bays):
            out += [f"[groups.{f}{b + 1:02d}]", f'parent = "{f}"',
                    f"translate = [{c.corner + b * c.bay_width:g}, 0, 0]"]
    out.append("")

    # --- geometry
    def geo(kind: str, **kw) -> None:
        out.extend(["[[geometry]]", f'kind = "{kind}"'])
        out.extend(f"{k} = {_v(v) if isinstance(v, list | tuple) else v}" for k, v in kw.items())

    W = c.bay_width
    geo("rectangle", origin=[0, 0, 0], u=[L, 0, 0], v=[0, L, 0], material='"paving"',
        name='"court"')
    for f in c.facades:
        for b in range(c.bays):
            geo("mesh", file=f'"{files["bay"]}"', material='"stone"', group=f'"{f}{b + 1:02d}"')
            geo("mesh", file=f'"{files["glass"]}"', material='"glass"', group=f'"{f}{b + 1:02d}"')
            # cornices per bay, not one facade-long box: patches keep their triangle's shape,
            # and a 160 m × 0.6 m face would be cut into ~10⁴ slivers per triangle
            for s, (_, z1) in enumerate(c.levels):
                geo("box", min=[0, 0, z1 - c.cornice_height[s]], max=[W, c.cornice_depth, z1],
                    material='"stone"', group=f'"{f}{b + 1:02d}"')
        # A court corner holds the end pier of the facade before (in S, E, N, W order) and the
        # start pier of this one: their cornice boxes would overlap on cornice_depth² and
        # their top, bottom and back faces lie on each other facing the same way (light
        # counted twice). The earlier facade's box runs to the corner; this one's starts where
        # that one's front face is, so the two make one L-shaped cornice.
        before = FACADES[FACADES.index(f) - 1]
        start = c.cornice_depth if before in c.facades else 0.0
        for s, (z0, z1) in enumerate(c.levels):  # corner piers: wall and cornice
            top = z1 - c.cornice_height[s]
            for x in (0.0, L - c.corner):
                geo("rectangle", origin=[x, 0, z0], u=[0, 0, top - z0], v=[c.corner, 0, 0],
                    material='"stone"', group=f'"{f}"')
                x0 = x + start if x == 0.0 else x
                geo("box", min=[x0, 0, top], max=[x + c.corner, c.cornice_depth, z1],
                    material='"stone"', group=f'"{f}"')
    out.append("")

    # --- luminaires, in each bay's frame
    def lum(name, phot, net, group, pos, spectrum=None, aim=None, aim_at=None):
        out.extend(["[[luminaires]]", f'name = "{name}"', f'photometry = "{phot}"',
                    f'network = "{net}"'])
        if group:
            out.append(f'group = "{group}"')
        out.append(f"position = {_v(pos)}")
        if aim is not None:
            out.append(f"aim = {{ tilt = {aim[0]:g}, pan = {aim[1]:g}, spin = {aim[2]:g} }}")
        if aim_at is not None:
            out.append(f"aim_at = {_v(aim_at)}")
        if spectrum:
            out.append(f"spectrum = {spectrum}")

    bar_x = [W / 2 + (i - (c.washers - 1) / 2) * (W - 2 * c.column_offset - 0.7) / c.washers
             for i in range(c.washers)]
    for f in c.facades:
        for b in range(c.bays):
            g = f"{f}{b + 1:02d}"
            for s, (z0, z1) in enumerate(c.levels):
                top = z1 - c.cornice_height[s]
                net = f"{f}-attic" if s == n_st - 1 else f"{f}-wash"
                # spin 180 turns the bar's +y side (where its beam is thrown) to the wall (−y)
                for i, x in enumerate(bar_x):
                    lum(f"{g}-w{s}{i}", "washer", net, g, (x, 0.55, top - 0.08), wash_sp,
                        aim=(0, 0, 180))
                r = c.column_radius[s]
                for j, x in enumerate(c.column_x()):
                    lum(f"{g}-c{s}{j}", "column", f"{f}-columns", g, (x, r + 0.35, z0 + 0.1),
                        col_sp, aim_at=(x, r, z0 + 0.7 * (top - z0)))
                x0, x1, wz0, wz1 = c.windows(s)
                lum(f"{g}-o{s}", "window", f"{f}-windows", g, (W / 2, 0.6, z0 + 0.1), wash_sp,
                    aim_at=(W / 2, 0.0, min(wz1 + 0.4, top - 0.05)))
    # floods stand 12 m out from each facade's centre, aimed at the central pavilion
    span = min(24.0, L - 2 * c.corner)
    for f in c.facades:
        for i in range(c.floods_per_facade):
            x = L / 2 + (i / max(c.floods_per_facade - 1, 1) - 0.5) * span
            lum(f"{f}-flood{i + 1}", "flood", "floods", f, (x, 12.0, 0.6), '"A"',
                aim_at=(x, 0.0, 0.55 * c.levels[-1][1]))
    # path lights: from each facade's centre (its passage) towards the court's centre
    for f in c.facades:
        for i in range(c.paths_per_path):
            y = 3.0 + i * (L / 2 - 6.0) / max(c.paths_per_path - 1, 1)
            lum(f"{f}-path{i + 1}", "path", "paths", f, (L / 2 + 2.0, y, 0.9), '"A"')
    out.append("")

    out += _grids(c)
    out += _cameras(c)
    out += _observers(c)
    out += [
        "", "[solver]",
        f"target_patches = {c.target_patches}",
        *([f"operator_patches = {c.operator_patches}"] if c.operator_patches else []),
        f"spectral_samples = {c.spectral_samples}",
        f"gather_rays = {c.gather_rays}",
    ]
    if c.optimise:
        # no global patch-luminance ceiling: the stone right next to a fitting is always hot;
        # the facade limit is on the wall grids (max_luminance_cdm2 with their reflectance)
        out += ["", "[optimise]", 'variables = ["dimmers"]']
        if c.gr_max is not None:  # the visitors' GR ceiling: a constrained design
            out += ["# design to a standard: the least power in use that meets every grid's "
                    "limits and keeps each",
                    "# visitor's GR_max over its fan within EN 12464-2's GR_L = 50 (Table "
                    "5.1.1, walkways for",
                    "# pedestrians); GR replaces the old proxy, max_lux = 10 of vertical lux at "
                    "eye height",
                    'objective = "power"', "[[optimise.constraints]]", 'criterion = "gr"',
                    f"max = {c.gr_max:g}"]
    return "\n".join(out) + "\n"


def _cameras(c: Courtyard) -> list[str]:
    """A visitor's view across the court to the south-east corner (S and E facades), drawn
    realistic and in false-colour luminance, for the report and the viewer."""
    L, top = c.side, c.levels[-1][1]
    eye = f"[{0.12 * L:.2f}, {0.88 * L:.2f}, 1.7]"
    corner = f"[{0.85 * L:.2f}, {0.15 * L:.2f}, {0.4 * top:.2f}]"
    out = ["", "# --- views for the report: a visitor standing in the court"]
    for name, kind in (("court-view", "realistic"), ("court-luminance", "falsecolour")):
        out += [f"[cameras.{name}]", f"position = {eye}", f"target = {corner}",
                "fov_deg = 62", f'kind = "{kind}"']
    return out


def _observers(c: Courtyard) -> list[str]:
    """Visitors on each entry path looking into the court (EN 12464-2's GR observers: eye at
    1.6 m, the line of sight 2° below the horizontal, a fan every 45°), at the path's start
    and half-way in; docs/glare.md."""
    L = c.side
    out = ["", "# --- observers: visitors walking in along the entry paths (glare, GR)"]
    for f in c.facades:
        rot, (cx, cy) = _FACADE_FRAME[f]
        a = math.radians(rot)
        R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        d = R @ np.array([0.0, 1.0])
        for label, y in (("entry", 2.0), ("halfway", L / 4)):
            p = np.array([cx * L, cy * L]) + R @ np.array([L / 2, y])
            out += ["[[observers]]", f'name = "{f}-path-{label}"',
                    f"position = [{p[0]:.3f}, {p[1]:.3f}, 1.6]",
                    f"direction = [{d[0]:.4f}, {d[1]:.4f}, {-math.tan(math.radians(2)):.4f}]",
                    "fan = { step_deg = 45 }"]
    return out


def _grids(c: Courtyard) -> list[str]:
    """Wall points between the columns, column faces, the court floor and the entry paths."""
    L, W = c.side, c.bay_width
    out = ["# --- calculation grids (points in each facade's frame, normals into the court)"]
    xa, xb = c.column_offset + max(c.column_radius) + 0.15, W - c.column_offset - max(
        c.column_radius) - 0.15
    for f in c.facades:
        wall, cols = [], []
        for b in range(c.bays):
            bx = c.corner + b * W
            for s, (z0, z1) in enumerate(c.levels):
                top = z1 - c.cornice_height[s]
                x0, x1, wz0, wz1 = c.windows(s)
                nx = max(2, round((xb - xa) / c.grid_spacing) + 1)
                nz = max(2, round((top - z0 - 0.6) / c.grid_spacing) + 1)
                for x in np.linspace(xa, xb, nx):
                    for z in np.linspace(z0 + 0.3, top - 0.3, nz):
                        if x0 - 0.1 < x < x1 + 0.1 and wz0 - 0.1 < z < wz1 + 0.1:
                            continue
                        wall.append((bx + x, 0.02, z))
                for x in c.column_x():
                    for t in (0.2, 0.4, 0.6, 0.8):
                        cols.append((bx + x, c.column_radius[s] + 0.02, z0 + t * (top - z0)))
        out += [
            "[[grids]]", f'name = "{f}-wall"', 'kind = "points"', f'group = "{f}"',
            "normals = [0, 1, 0]", "target_lux = 40", "uniformity_min = 0.1",
            "reflectance = 0.52", "max_luminance_cdm2 = 25",
            f"points = {_points(wall)}",
            "[[grids]]", f'name = "{f}-columns"', 'kind = "points"', f'group = "{f}"',
            "normals = [0, 1, 0]", "target_lux = 100",
            "# columns brighter than the wall between them (the paper's rhythm)",
            f"points = {_points(cols)}",
        ]
    n = max(2, round(L / c.ground_spacing))
    out += ["[[grids]]", 'name = "court"', 'kind = "plane"', "origin = [0, 0, 0.01]",
            f"u = [{L:g}, 0, 0]", f"v = [0, {L:g}, 0]", f"nu = {n}", f"nv = {n}",
            # a floor for safe walking (EN 12464-2 style Emin), not a level to fit: the
            # washers' spill lights the court, and fitting it down would dim the facades
            "min_lux = 1"]
    # eye points on each entry path, looking along the path into the court: vertical
    # illuminance at the eye is the glare proxy (no flood or spot aimed at the visitors)
    eyes, normals = [], []
    for f in c.facades:
        rot, (cx, cy) = _FACADE_FRAME[f]
        a = math.radians(rot)
        R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        for y in np.linspace(2.0, L / 2 - 2.0, 6):
            p = np.array([cx * L, cy * L]) + R @ np.array([L / 2, y])
            eyes.append((p[0], p[1], 1.6))
            nrm = R @ np.array([0.0, 1.0])
            normals.append((nrm[0], nrm[1], 0.0))
    out += ["[[grids]]", 'name = "paths-eye"', 'kind = "points"',
            "# vertical illuminance at a visitor's eye walking in (reported; the glare limit "
            "is the",
            "# observers' GR ceiling in [optimise])",
            f"points = {_points(eyes)}", f"normals = {_points(normals)}"]
    return out


# --- the studies --------------------------------------------------------------------------

DEFAULT = Courtyard(
    name="Courtyard corner (two facades, twelve bays)",
    description=("A Cour Carrée-like corner: top-down halogen wash under the cornices, "
                 "bottom-up spots on the double columns, window accents, pavilion floods."),
    facades=("S", "E"), bays=6, floods_per_facade=4, paths_per_path=3,
    target_patches=1500, spectral_samples=6, gather_rays=128, grid_spacing=1.0,
    ground_spacing=1.5, dimmers={"wash": 0.8, "attic": 0.8, "columns": 1.0, "windows": 0.6,
                                 "floods": 0.5, "paths": 0.7}, gr_max=50.0,
)
FULL = Courtyard(
    name="Cour Carrée-like courtyard (full scale)",
    description="Four facades x 40 bays, 3,000 luminaires in 18 networks (paper section 2).",
    dimmers=DEFAULT.dimmers,
    target_patches=140_000,  # ≈ 2.0·10⁵ patches: the columns' slivers add ~50 % to the ask
    # The one-level operator at 2·10⁵ patches would be ≈ 105 GiB (README, "Scale"): solve on
    # ≈ 2.6·10⁴ elements (the 22,418 LOD-0 triangles are the floor; 1.7 GiB of operator) and
    # gather onto the fine patches.
    operator_patches=6_000,
)
PLATE6 = dataclasses.replace(
    FULL, name="Courtyard, Plate 6 variation: warm columns",
    description="As the full study, with halogen (CIE A) column spots instead of 3200 K "
                "dichroics, and the floods off.",
    column_spectrum="A", dimmers={**FULL.dimmers, "floods": 0.0},
)
PLATE7 = dataclasses.replace(
    FULL, name="Courtyard, Plate 7 variation: Stanislas-like pink fluorescent",
    description="As the full study, with the washers and window spots behind pink-filtered "
                "FL11 fluorescent tubes (sharp spectral peaks), as at Place Stanislas.",
    variant="stanislas", spectral_samples=16,
)


def write_study(c: Courtyard, toml_path: Path, assets: Path, args: str) -> Path:
    files = write_assets(c, assets)
    toml_path.write_text(study_toml(c, files, args), encoding="utf-8")
    return toml_path


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("which", nargs="*", choices=["default", "full", "plate6", "plate7", []],
                   help="which studies (default: all)")
    p.add_argument("--lod", type=int, default=None, help="level of detail 0-3 (full studies)")
    args = p.parse_args(argv)
    targets = {
        "default": (DEFAULT, ROOT / "lumijax/data/studies/default/study.toml",
                    ROOT / "lumijax/data/studies/default/courtyard"),
        "full": (FULL, ROOT / "configs/courtyard.toml", ROOT / "configs/courtyard"),
        "plate6": (PLATE6, ROOT / "configs/courtyard-plate6.toml", ROOT / "configs/courtyard"),
        "plate7": (PLATE7, ROOT / "configs/courtyard-plate7.toml", ROOT / "configs/courtyard"),
    }
    for w in args.which or ["default", "full", "plate6", "plate7"]:
        c, toml_path, assets = targets[w]
        if args.lod is not None and w != "default":
            c = dataclasses.replace(c, lod=args.lod)
        path = write_study(c, toml_path, assets, w)
        print(f"wrote {path} ({c.luminaire_count()} luminaires, {len(c.networks())} networks)")


if __name__ == "__main__":
    main()
