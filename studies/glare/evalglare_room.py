"""lumijax's UGR against Radiance's evalglare on fisheye renderings of the same room.

    python studies/glare/evalglare_room.py [--size 300] [--out DIR]

An 8 × 6 × 3 m room (every surface grey ρ = 0.5) lit by six 0.6 × 0.6 m Lambertian panels of
luminance 3,000 cd/m² just under the ceiling. lumijax computes the study (radiosity, UGR per
observer); Radiance renders the same room from each eye (``rpict -vta``, a 180° angular fisheye,
``-ab 2``) with the panels as ``light`` polygons of the same luminance (radiance = L / 179, the
white efficacy Radiance uses) and ``evalglare -d`` rates the picture. Printed and written to
``DIR/evalglare.json``: per observer, the UGR of both, the panels' luminance and solid angle
as each sees them, and evalglare's UGR recomputed with CIE 117's background L_b = E_ind / π
(evalglare's own L_b is the mean luminance of the non-source pixels), which isolates the
difference of the two background definitions from the sources'.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np

L_PANEL = 3000.0  # cd/m²
SIDE = 0.6  # m
ROOM = (8.0, 6.0, 3.0)
RHO = 0.5
PANELS = [(x, y) for x in (2.0, 4.0, 6.0) for y in (2.0, 4.0)]
OBSERVERS = {  # eye (m), line of sight
    "lengthwise": ((0.8, 3.0, 1.2), (1.0, 0.0, 0.0)),
    "crosswise": ((4.0, 0.8, 1.2), (0.0, 1.0, 0.0)),
    "corner": ((0.8, 0.8, 1.2), (1.0, 0.6, 0.0)),
}


def _bin(name: str) -> str:
    import pyradiance

    return str(Path(pyradiance.__file__).parent / "bin" / name)


def study_toml(ies: Path) -> str:
    """The lumijax study of the room: panels facing down 1 mm under the ceiling, one observer
    per entry of OBSERVERS."""
    import tomlkit

    return tomlkit.dumps({
        "study": {"name": "evalglare room"},
        "solver": {"target_patches": 3000, "gather_rays": 4096},
        "materials": {"grey": {"reflectance": RHO}},
        "photometry": {"panel": {"file": str(ies)}},
        "geometry": [{"kind": "box", "min": [0, 0, 0], "max": list(ROOM), "normals": "inward",
                      "material": "grey"}],
        "luminaires": [{"name": f"P{i}", "photometry": "panel", "position": [x, y, 2.999],
                        "network": "n"} for i, (x, y) in enumerate(PANELS)],
        "observers": [{"name": n, "position": list(e), "direction": list(d)}
                      for n, (e, d) in OBSERVERS.items()],
    })


def radiance_scene() -> str:
    X, Y, Z = ROOM
    r = L_PANEL / 179.0
    out = [f"void plastic grey 0 0 5 {RHO} {RHO} {RHO} 0 0", f"void light panel 0 0 3 {r} {r} {r}"]

    def poly(mat, name, pts):
        out.append(f"{mat} polygon {name} 0 0 {3 * len(pts)} " + " ".join(
            f"{p[0]} {p[1]} {p[2]}" for p in pts))

    # the room's faces, normals inward (Radiance: counter-clockwise seen from the front)
    poly("grey", "floor", [(0, 0, 0), (X, 0, 0), (X, Y, 0), (0, Y, 0)])
    poly("grey", "ceiling", [(0, 0, Z), (0, Y, Z), (X, Y, Z), (X, 0, Z)])
    poly("grey", "south", [(0, 0, 0), (0, 0, Z), (X, 0, Z), (X, 0, 0)])
    poly("grey", "north", [(0, Y, 0), (X, Y, 0), (X, Y, Z), (0, Y, Z)])
    poly("grey", "west", [(0, 0, 0), (0, Y, 0), (0, Y, Z), (0, 0, Z)])
    poly("grey", "east", [(X, 0, 0), (X, 0, Z), (X, Y, Z), (X, Y, 0)])
    h = SIDE / 2
    for i, (x, y) in enumerate(PANELS):  # facing down
        z = Z - 0.001
        poly("panel", f"p{i}", [(x - h, y - h, z), (x - h, y + h, z), (x + h, y + h, z),
                                (x + h, y - h, z)])
    return "\n".join(out) + "\n"


def evalglare(work: Path, name: str, eye, sight, size: int) -> dict:
    """Render the fisheye and rate it; returns evalglare's figures and its sources."""
    oct_ = work / "room.oct"
    if not oct_.exists():
        (work / "room.rad").write_text(radiance_scene())
        with open(oct_, "wb") as f:
            subprocess.run([_bin("oconv"), str(work / "room.rad")], stdout=f, check=True)
    pic = work / f"{name}.hdr"
    env = dict(os.environ, RAYPATH=f".{os.pathsep}{Path(_bin('rpict')).parents[1] / 'lib'}")
    view = ["-vta", "-vp", *map(str, eye), "-vd", *map(str, sight), "-vu", "0", "0", "1",
            "-vh", "180", "-vv", "180"]
    if not (pic.exists() and pic.stat().st_size > 10_000):  # --out DIR keeps the renderings
        with open(pic, "wb") as f:
            subprocess.run([_bin("rpict"), *view, "-x", str(size), "-y", str(size), "-ps", "1",
                            "-ab", "2", "-ad", "1024", "-as", "256", "-aa", "0.12", "-ar",
                            "64", "-lw", "1e-3", str(oct_)], stdout=f, check=True, env=env)
    # sources: pixels above 1,000 cd/m² (the panels are 3,000; the brightest stone ~100)
    res = subprocess.run([_bin("evalglare"), "-b", "1000", "-d", str(pic)], capture_output=True,
                         text=True, check=True, env=env).stdout
    return _parse(res)


def _parse(text: str) -> dict:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    sources, figures = [], {}
    for i, ln in enumerate(lines):
        if "No pixels" in ln:  # the header of the per-source table
            head = ln.split()
            for row in lines[i + 1:]:
                parts = row.split()
                if not parts or not parts[0].isdigit():
                    break
                # No, pixels, x, y, L_s, Omega_s, Posindx, L_b, L_t, E_v, Edir, Max_Lum,
                # Sigma, xdir, ydir, zdir, …
                sources.append({"omega": float(parts[5]), "L": float(parts[4]),
                                "p": float(parts[6]), "dir": [float(v) for v in parts[13:16]]})
            del head
        if ":" in ln and "dgp" in ln.split(":")[0]:
            keys = ln.split(":")[0].split(",")
            values = ln.split(":")[1].split()
            figures = {k.strip(): float(v) for k, v in zip(keys, values, strict=False)}
    return {"figures": figures, "sources": sources}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=300, help="fisheye pixels a side")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    import lumijax
    from lumijax.photometry import LuminousOpening, lambertian, write_ies

    work = Path(tempfile.mkdtemp(prefix="evalglare-")) if args.out is None else args.out
    work.mkdir(parents=True, exist_ok=True)
    ies = work / "panel.ies"
    phot = lambertian(math.pi * L_PANEL * SIDE * SIDE)  # I(γ) = L A cos γ
    write_ies(dataclasses.replace(phot, opening=LuminousOpening(SIDE, SIDE, 0.0, "rectangle")),
              ies)
    (work / "study.toml").write_text(study_toml(ies))
    results = lumijax.compute(lumijax.load_study(work / "study.toml"))
    glare = results.glare
    out = {}
    print(f"{'observer':<11} {'UGR lumijax':>11} {'UGR evalglare':>13} {'UGR eg, CIE Lb':>14} "
          f"{'Lb lumijax':>10} {'Lb eg':>7} {'Lb eg CIE':>9} {'L_s eg':>8} {'ω lumijax':>9} "
          f"{'ω eg':>8}")
    for i, (name, (eye, sight)) in enumerate(OBSERVERS.items()):
        eg = evalglare(work, name, eye, sight, args.size)
        f, src = eg["figures"], eg["sources"]
        lb_cie = (f["E_v"] - f["E_v_dir"]) / math.pi
        s = sum(x["L"] ** 2 * x["omega"] / x["p"] ** 2 for x in src)
        ugr_eg_cie = 8 * math.log10(0.25 * s / lb_cie) if s > 0 else None
        d = glare.to_dict()[name]["directions"][0]
        omega = np.asarray(glare._omega)[i]
        seen = np.asarray(glare._contributions[0])[i] > 0
        row = {"ugr_lumijax": d["ugr"], "ugr_evalglare": f.get("ugr"),
               "ugr_evalglare_cie_background": ugr_eg_cie,
               "background_lumijax_cdm2": d["background_cdm2"],
               "background_evalglare_cdm2": f.get("lum_backg"),
               "background_evalglare_cie_cdm2": lb_cie,
               "sources_evalglare": len(src),
               "sources_lumijax": int(seen.sum()),
               "source_luminance_evalglare_cdm2": float(np.mean([x["L"] for x in src])),
               "solid_angle_lumijax_sr": float(omega[seen].sum()),
               "solid_angle_evalglare_sr": float(sum(x["omega"] for x in src))}
        out[name] = row
        print(f"{name:<11} {row['ugr_lumijax']:>11.2f} {row['ugr_evalglare']:>13.2f} "
              f"{ugr_eg_cie:>14.2f} {row['background_lumijax_cdm2']:>10.1f} "
              f"{row['background_evalglare_cdm2']:>7.1f} {lb_cie:>9.1f} "
              f"{row['source_luminance_evalglare_cdm2']:>8.0f} "
              f"{row['solid_angle_lumijax_sr']:>9.4f} {row['solid_angle_evalglare_sr']:>8.4f}")
    (work / "evalglare.json").write_text(json.dumps(out, indent=1))
    print(f"wrote {work / 'evalglare.json'}")


if __name__ == "__main__":
    main()
