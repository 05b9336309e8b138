"""GR of a floodlit area by hand (CIE 112:1994) against lumijax.

    python studies/glare/gr_floodlit.py [--out DIR]

A 200 × 200 m ground (ρ = 0.25) lit uniformly by an isotropic lamp 500 m up (E_h = 20 lx under
it, within 1.5 % over the part an eye sees at grazing angles), and a floodlight on an 8 m pole
30 m ahead of a visitor, aimed at the visitor's eye (its peak intensity I₀ toward the eye; a
10° spot whose beam lands behind the visitor). By hand:

    L_av = ρ E_h / π                       (the uniformly lit ground, CIE 112)
    L_ve = 0.035 L_av
    L_vl = 10 Σ E_eye,i / θ_i²,  E_eye = I cos θ / d²   (each source: the flood and the sky lamp)
    GR   = 27 + 24 log10(L_vl / L_ve^0.9)

lumijax computes the study with radiosity (its L_av is the mean luminance of the surfaces the
eye sees, its L_vl the same formula over its own photometry and geometry). Prints both.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import tempfile
from pathlib import Path

import numpy as np

RHO, E_H, SKY_H = 0.25, 20.0, 500.0
EYE = np.array([0.0, 0.0, 1.5])
POLE = np.array([30.0, 0.0, 8.0])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    import lumijax
    from lumijax.photometry import LuminousOpening, spot, write_ies

    work = Path(tempfile.mkdtemp(prefix="gr-")) if args.out is None else args.out
    work.mkdir(parents=True, exist_ok=True)
    flood = dataclasses.replace(spot(20_000.0, 10.0),
                                opening=LuminousOpening(0.3, 0.3, 0.0, "rectangle"))
    write_ies(flood, work / "flood.ies")
    i_sky = E_H * SKY_H ** 2  # cd, so that E_h = I / h² straight under it
    (work / "study.toml").write_text(f"""[study]
name = "floodlit area"
[solver]
target_patches = 2000
gather_rays = 4096
[materials.ground]
reflectance = {RHO}
[photometry.sky]
kind = "isotropic"
flux_lm = {4 * math.pi * i_sky}
[photometry.flood]
file = "{work / 'flood.ies'}"
[[geometry]]
kind = "rectangle"
origin = [-100, -100, 0]
u = [200, 0, 0]
v = [0, 200, 0]
material = "ground"
[[luminaires]]
name = "sky"
photometry = "sky"
position = [0, 0, {SKY_H}]
network = "sky"
[[luminaires]]
name = "flood"
photometry = "flood"
position = {POLE.tolist()}
aim_at = {EYE.tolist()}
network = "flood"
[[observers]]
name = "visitor"
position = {EYE.tolist()}
direction = [1, 0, 0]
""")
    study = lumijax.load_study(work / "study.toml")
    res = lumijax.compute(study)
    d = res.glare.to_dict()["visitor"]["directions"][0]

    i0 = float(flood.distribution.peak_cd)
    sight = np.array([1.0, 0.0, 0.0])
    lvl = 0.0
    for pos, cd in ((POLE, i0), (np.array([0.0, 0.0, SKY_H]), i_sky)):
        v = pos - EYE
        dist = float(np.linalg.norm(v))
        cos_t = float(v @ sight) / dist
        theta = max(math.degrees(math.acos(cos_t)), 1.5)
        lvl += 10 * (cd * max(cos_t, 0.0) / dist ** 2) / theta ** 2
    lav = RHO * E_H / math.pi
    gr = 27 + 24 * math.log10(lvl / (0.035 * lav) ** 0.9)
    row = {"L_av hand (cd/m²)": lav, "L_av lumijax": d["environment_cdm2"],
           "L_vl hand (cd/m²)": lvl, "L_vl lumijax": d["veiling_cdm2"],
           "GR hand": gr, "GR lumijax": d["gr"]}
    for k, v in row.items():
        print(f"{k:<22} {v:10.4f}")
    (work / "gr.json").write_text(json.dumps(row, indent=1))
    print(f"wrote {work / 'gr.json'}")


if __name__ == "__main__":
    main()
