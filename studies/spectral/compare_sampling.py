"""Segmentation vs uniform vs Gaussian (Meyer) vs RGB rendering, against a 1 nm reference.

    python studies/spectral/compare_sampling.py [--samples 8 12 16] [--out studies/spectral/RESULTS.md]

For every lamp (CIE FL1–FL12, A, D65, colour-science's LED-* illuminants) lighting the 24
ColorChecker N Ohta reflectances after k = 1 and k = 3 diffuse bounces (the radiosity is
E(λ)·ρ(λ)^k), the CIEDE2000 difference of each method's colour from the 1 nm reference.

What is computed, exactly:

* reference XYZ = Σ_λ c̄(λ) E(λ) ρ(λ)^k over λ = 360, 361, …, 830 nm (colour-science's CIE 1931
  2° CMFs at 1 nm; E and ρ evaluated by lumijax's own rule: linear interpolation of the data,
  emission zero and reflectance constant outside it), scaled so that the lamp itself has Y = 1;
* each method: XYZ = H @ (E(λ_i) ρ(λ_i)^k), scaled by the method's own photometric
  normalisation (``photometric_normalisation``: the sampled lamp has Y = 1, as lumijax makes the
  lux of every luminaire exact);
* CIELAB with the reference white of the lamp (its 1 nm XYZ, Y = 1 — "Y = 100" on colour's
  scale) for both; ΔE00 = colour.delta_E(..., method="CIE 2000").
* (a) segmentation: ``segment([lamp], patches, max_samples=n).for_emission(lamp)``; (a')
  the same samples with the generic weights (``weights_xyz`` as returned by ``segment``, not
  tailored to the lamp); (b) ``uniform_sampling(n)`` (bin centres, binned CMFs); (b')
  the uniform samples with the emission-weighted weights of (a) (an ablation: the weights, not
  the samples); (c) ``gauss_sampling(n)`` (Meyer: Gauss–Legendre on 380–780 nm, weights
  w_i c̄(λ_i)); (d) RGB: the lamp's and the patch's linear-sRGB colours (lamp: its XYZ; patch:
  its XYZ under D65, the usual albedo) multiplied per channel k times, back to XYZ — always 3
  channels.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))


def lamps():
    import colour

    names = [f"FL{i}" for i in range(1, 13)] + ["A", "D65"]
    names += sorted(k for k in colour.SDS_ILLUMINANTS if k.startswith("LED"))
    return names


def run(samples, bounces=(1, 3)):
    import colour

    from lumijax.spectral import (
        Spectrum,
        gauss_sampling,
        photometric_normalisation,
        reference_grid,
        segment,
        uniform_sampling,
    )

    wl, cmf = reference_grid()
    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    patches = [Spectrum.from_name(f"ColorChecker N Ohta/{k}", "reflectance") for k in cc]
    rho = np.stack([p.at(wl) for p in patches])  # (24, 471)
    m_xyz2rgb = colour.models.RGB_COLOURSPACE_sRGB.matrix_XYZ_to_RGB
    m_rgb2xyz = colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ
    d65 = Spectrum.from_name("D65").at(wl)
    mat_xyz = (rho * d65) @ cmf.T / (cmf[1] @ d65)
    mat_rgb = mat_xyz @ m_xyz2rgb.T

    methods = ["a", "a'", "b", "b'", "c", "d"]
    worst = {}  # (lamp, n, k, method) -> (worst, mean)
    chosen = {}
    for name in lamps():
        lamp = Spectrum.from_name(name)
        e = lamp.at(wl)
        white = cmf @ e
        white = white / white[1]
        xy_w = colour.XYZ_to_xy(white)
        ref = {k: (rho**k * e) @ cmf.T / (cmf[1] @ e) for k in bounces}
        ref_lab = {k: colour.XYZ_to_Lab(ref[k], xy_w) for k in bounces}
        lamp_rgb = white @ m_xyz2rgb.T
        for n in samples:
            seg = segment([lamp], patches, max_samples=n)
            uni = uniform_sampling(n)
            samp = {
                "a": seg.for_emission(lamp),
                "a'": seg,
                "b": uni,
                "b'": uni.for_emission(lamp),
                "c": gauss_sampling(n),
            }
            chosen[(name, n)] = seg
            for k in bounces:
                for mth in methods:
                    if mth == "d":
                        rgb = lamp_rgb * mat_rgb**k
                        xyz = rgb @ m_rgb2xyz.T
                    else:
                        s = samp[mth]
                        f = photometric_normalisation(lamp, s)
                        el = lamp.at(s.wavelengths_nm) * f
                        rl = np.stack([p.at(s.wavelengths_nm) for p in patches])
                        xyz = s.tristimulus(el * rl**k)
                    de = colour.delta_E(colour.XYZ_to_Lab(xyz, xy_w), ref_lab[k], method="CIE 2000")
                    worst[(name, n, k, mth)] = (float(np.max(de)), float(np.mean(de)))
    return worst, chosen


LABELS = {
    "a": "(a) segmentation",
    "a'": "(a') segmentation, generic weights",
    "b": "(b) uniform",
    "b'": "(b') uniform, emission-weighted",
    "c": "(c) Gauss (Meyer)",
    "d": "(d) RGB (3 channels)",
}


def tables(worst, chosen, samples, bounces=(1, 3)):
    out = []
    methods = list(LABELS)
    # summary: worst over all lamps
    out.append("## Summary: worst ΔE00 over all lamps and all 24 patches\n")
    out.append("| method | " + " | ".join(f"n={n}, k={k}" for n in samples for k in bounces) + " |")
    out.append("|---|" + "---:|" * (len(samples) * len(bounces)))
    for m in methods:
        cells = []
        for n in samples:
            for k in bounces:
                vals = [
                    v[0]
                    for (_lamp, nn, kk, mm), v in worst.items()
                    if nn == n and kk == k and mm == m
                ]
                cells.append(f"{max(vals):.3f}")
        out.append(f"| {LABELS[m]} | " + " | ".join(cells) + " |")
    for n in samples:
        out.append(f"\n## n = {n} samples: worst (mean) ΔE00 over the 24 patches\n")
        out.append("| lamp | k | " + " | ".join(LABELS[m] for m in methods) + " | samples used |")
        out.append("|---|---:|" + "---:|" * len(methods) + "---:|")
        for name in dict.fromkeys(key[0] for key in worst):
            for k in bounces:
                cells = []
                best = min(worst[(name, n, k, m)][0] for m in methods if m in ("a", "b", "c", "d"))
                for m in methods:
                    w, mu = worst[(name, n, k, m)]
                    s = f"{w:.3f} ({mu:.3f})"
                    cells.append(f"**{s}**" if m in ("a", "b", "c", "d") and w == best else s)
                out.append(f"| {name} | {k} | " + " | ".join(cells) + f" | {chosen[(name, n)].n} |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, nargs="+", default=[8, 12, 16])
    ap.add_argument("--out", type=Path, default=HERE / "RESULTS.md")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    worst, chosen = run(args.samples)
    dt = time.perf_counter() - t0
    body = tables(worst, chosen, args.samples)
    import colour

    head = (
        "# Spectral sampling vs a 1 nm reference\n\n"
        f"Produced by `studies/spectral/compare_sampling.py` on {datetime.date.today()} "
        f"({platform.node()}, {platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}, colour-science {colour.__version__}) in {dt:.0f} s.\n"
        "See the script's docstring for exactly what is computed; bold: the best of (a)–(d).\n\n"
    )
    print(body)
    from lumijax._atomic import atomic_write_text

    atomic_write_text(args.out, head + body + "\n")
    print(f"\nwrote {args.out} ({dt:.0f} s)")


if __name__ == "__main__":
    main()
