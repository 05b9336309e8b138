"""An office building for the compliance benchmark (benchmarks/compliance.py): ``floors`` ×
``rooms`` cellular offices of 6 × 5 × 3 m, each with a window band, a carpet and a ceiling
finish, two desks with their EN 12464-1 task area (Table 34 row 34.2: Ēm 500 lx, U0 0.60,
UGR_L 19, Ēz 150 lx) and immediate surrounding, a cylindrical sensor grid and modelling, a
seated observer per desk for UGR, six recessed downlights on two networks per floor (window
row and inner rows), energy with a dimming table, CIE 97 maintenance and CIE 150 obtrusive
light (a neighbour's window, a sensitive point, ULR, a facade).

    python studies/compliance/make_office_building.py --floors 4 --rooms 12 > building.toml

The default (4 floors × 12 rooms, ``target_patches`` 100,000) is ≈ 10⁵ patches, 288
luminaires on 8 networks, 96 observers. Units: m, lm, W.
"""

from __future__ import annotations

import argparse

ROOM = (6.0, 5.0, 3.0)  # m: x across the window wall, y deep, z high
PITCH = (6.2, 5.2, 3.4)  # room spacing (walls and slabs between)


def building_toml(floors: int = 4, rooms: int = 12, target_patches: int = 100_000,
                  operator_patches: int = 8_000, gather_rays: int = 128) -> str:
    """The study text (TOML) of a ``floors`` × ``rooms`` building."""
    out = [f"""[study]
name = "office building, {floors} floors x {rooms} rooms"
[solver]
target_patches = {target_patches}
operator_patches = {operator_patches}
gather_rays = {gather_rays}
spectral_samples = 0
cache = false
[materials.walls]
reflectance = 0.7
[materials.ceiling]
reflectance = 0.8
[materials.floor]
reflectance = 0.2
[materials.desk]
reflectance = 0.45
[materials.glass]
reflectance = 0.08
[photometry.downlight]
kind = "lambertian"
flux_lm = 4500
luminous_diameter_m = 0.2
"""]
    comp = ["""
[compliance.maintenance]
llmf = 0.9
luminaire_type = "C"
environment = "clean"
cleaning_interval_years = 1
[compliance.energy]
watts = { downlight = 24 }
occupancy_factor = 0.9
leni_max = 15
"""]
    for f in range(floors):
        out.append(f'[networks.F{f}-window]\ndimmer = 0.7\n[networks.F{f}-inner]\n')
        comp.append(f"""[compliance.energy.dimming.F{f}-inner]
curve = "table"
levels = [0, 0.5, 1]
power = [0.05, 0.45, 1]
standby_w = 0.3
""")
    w, d, h = ROOM
    for f in range(floors):
        for r in range(rooms):
            ox, oy, oz = r * PITCH[0], 0.0, f * PITCH[2]
            n = f"F{f}R{r}"
            out.append(f"""
[[geometry]]
name = "{n}"
kind = "box"
min = [{ox}, {oy}, {oz}]
max = [{ox + w}, {oy + d}, {oz + h}]
normals = "inward"
material = "walls"
[[geometry]]
kind = "rectangle"
origin = [{ox}, {oy}, {oz + 0.001}]
u = [{w}, 0, 0]
v = [0, {d}, 0]
material = "floor"
[[geometry]]
kind = "rectangle"
origin = [{ox}, {oy}, {oz + h - 0.001}]
u = [0, {d}, 0]
v = [{w}, 0, 0]
material = "ceiling"
[[geometry]]
kind = "rectangle"
origin = [{ox + 0.5}, {oy + 0.001}, {oz + 0.9}]
u = [{w - 1}, 0, 0]
v = [0, 0, 1.5]
material = "glass"
""")
            for k, dx in enumerate((1.0, 3.6)):  # two desks 1.6 × 0.8 m
                x0, y0 = ox + dx, oy + 1.6
                out.append(f"""[[geometry]]
kind = "box"
min = [{x0}, {y0}, {oz + 0.72}]
max = [{x0 + 1.6}, {y0 + 0.8}, {oz + 0.75}]
material = "desk"
[[grids]]
name = "{n}-task{k}"
kind = "area"
origin = [{x0}, {y0}, {oz + 0.76}]
u = [1.6, 0, 0]
v = [0, 0.8, 0]
[[grids]]
name = "{n}-surround{k}"
kind = "area"
origin = [{x0 - 0.5}, {y0 - 0.5}, {oz + 0.76}]
u = [2.6, 0, 0]
v = [0, 1.8, 0]
exclude = "{n}-task{k}"
[[grids]]
name = "{n}-ez{k}"
kind = "sensor"
sensor = "cylindrical"
at_grid = "{n}-task{k}"
offset_m = [0, 0, 0.44]
[[observers]]
name = "{n}-eye{k}"
position = [{x0 + 0.8}, {y0 + 1.4}, {oz + 1.2}]
direction = [0, -1, 0]
""")
                comp.append(f"""[[compliance.areas]]
name = "{n}-desk{k}"
standard = "EN 12464-1"
reference = "34.2"
grid = "{n}-task{k}"
cylindrical = "{n}-ez{k}"
modelling = [0.3, 0.6]
surrounding = "{n}-surround{k}"
networks = ["F{f}-window", "F{f}-inner"]
area_m2 = 15
observers = ["{n}-eye{k}"]
""")
            for i in range(3):
                for j in range(2):
                    net = f"F{f}-window" if j == 0 else f"F{f}-inner"
                    out.append(f'[[luminaires]]\nname = "{n}-L{i}{j}"\nphotometry = "downlight"'
                               f'\nnetwork = "{net}"\nposition = [{ox + 1 + 2 * i}, '
                               f'{oy + 1.25 + 2.5 * j}, {oz + h - 0.05}]\n')
    out.append(f"""
[[grids]]
name = "F0R0-walls"
kind = "surface"
geometry = "F0R0"
spacing = 1.0
[[grids]]
name = "neighbour"
kind = "sensor"
sensor = "vertical"
points = [[{w / 2}, -20, 1.5], [{w / 2}, -20, 4.9]]
facing = [0, 1, 0]
""")
    comp.append(f"""
[compliance.obtrusive]
zone = "E2"
curfew = "22:00"
after_curfew = {{ F0-window = 0.0, F0-inner = 0.0 }}
windows = ["neighbour"]
facades = ["F0R0-walls"]
sensitive = [{{ name = "house", point = [{w / 2}, -20, 1.5] }}]
""")
    return "".join(out + comp)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--floors", type=int, default=4)
    ap.add_argument("--rooms", type=int, default=12)
    ap.add_argument("--target-patches", type=int, default=100_000)
    ap.add_argument("--operator-patches", type=int, default=8_000)
    args = ap.parse_args()
    print(building_toml(args.floors, args.rooms, args.target_patches, args.operator_patches))


if __name__ == "__main__":
    main()
