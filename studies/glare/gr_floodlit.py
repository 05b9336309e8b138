"""GR of a floodlit area by hand (CIE 112:1994) against lumijax.

    python studies/glare/gr_floodlit.py [--out DIR]

A 200 × 200 m ground (ρ = 0.25) ahead of a visitor (it starts under the eye), lit uniformly by
an isotropic lamp 500 m up (E_h = 20 lx under it, within 1.5 % over the ground an eye sees),
and a floodlight on an 8 m pole 30 m ahead, aimed horizontally over the visitor's head (a 10°
Gaussian spot, ``I(γ) = I₀ exp(−ln 2 (γ/5°)²)``: the eye, 12.2° off its axis, sees
I₀ exp(−ln 2 (12.2/5)²); the ground near the eye, ≥ 15° off axis, gets < 0.3 lx of it). By
hand:

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
SKY = np.array([20.0, 0.0, SKY_H])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    import tomlkit

    import lumijax
    from lumijax.photometry import LuminousOpening, spot, write_ies

    work = Path(tempfile.mkdtemp(prefix="gr-")) if args.out is None else args.out
    work.mkdir(parents=True, exist_ok=True)
    flood = dataclasses.replace(spot(20_000.0, 10.0),
                                opening=LuminousOpening(0.3, 0.3, 0.0, "rectangle"))
    write_ies(flood, work / "flood.ies")
    i_sky = E_H * SKY_H ** 2  # cd, so that E_h = I / h² straight under it
    (work / "study.toml").write_text(tomlkit.dumps({
        "study": {"name": "floodlit area"},
        "solver": {"target_patches": 2000, "gather_rays": 4096},
        "materials": {"ground": {"reflectance": RHO}},
        "photometry": {"sky": {"kind": "isotropic", "flux_lm": 4 * math.pi * i_sky},
                       "flood": {"file": str(work / "flood.ies")}},
        "geometry": [{"kind": "rectangle", "origin": [0, -100, 0], "u": [200, 0, 0],
                      "v": [0, 200, 0], "material": "ground"}],
        "luminaires": [
            {"name": "sky", "photometry": "sky", "position": SKY.tolist(), "network": "sky"},
            {"name": "flood", "photometry": "flood", "position": POLE.tolist(),
             "aim_at": [0, 0, float(POLE[2])], "network": "flood"}],
        "observers": [{"name": "visitor", "position": EYE.tolist(), "direction": [1, 0, 0]}],
    }))
    study = lumijax.load_study(work / "study.toml")
    res = lumijax.compute(study)
    d = res.glare.to_dict()["visitor"]["directions"][0]

    i0 = float(flood.distribution.peak_cd)
    gamma = math.degrees(math.atan2(POLE[2] - EYE[2], POLE[0] - EYE[0]))  # off the flood's axis
    i_eye = i0 * math.exp(-math.log(2) * (gamma / 5.0) ** 2)
    sight = np.array([1.0, 0.0, 0.0])
    lvl = 0.0
    for pos, cd in ((POLE, i_eye), (SKY, i_sky)):
        v = pos - EYE
        dist = float(np.linalg.norm(v))
        cos_t = float(v @ sight) / dist
        theta = max(math.degrees(math.acos(cos_t)), 1.5)
        lvl += 10 * (cd * max(cos_t, 0.0) / dist ** 2) / theta ** 2
    # the eye's cosine-weighted view of the ground is mostly within 10 m of it: E_h there
    near = np.array([5.0, 0.0, 0.0])
    e_h = i_sky * SKY_H / float(np.linalg.norm(SKY - near)) ** 3
    lav = RHO * e_h / math.pi
    gr = 27 + 24 * math.log10(lvl / (0.035 * lav) ** 0.9)
    row = {"I toward the eye, hand (cd)": i_eye, "L_av hand (cd/m²)": lav, "L_av lumijax": d["environment_cdm2"],
           "L_vl hand (cd/m²)": lvl, "L_vl lumijax": d["veiling_cdm2"],
           "GR hand": gr, "GR lumijax": d["gr"]}
    for k, v in row.items():
        print(f"{k:<22} {v:10.4f}")
    (work / "gr.json").write_text(json.dumps(row, indent=1))
    print(f"wrote {work / 'gr.json'}")


if __name__ == "__main__":
    main()
