"""One panel seen by lumijax and by Radiance's evalglare on an ``rpict -vta`` fisheye: source
luminance, solid angle, position index, direct illuminance at the eye and veiling luminance.

A fast check (a 300 × 300 picture, no inter-reflection); the room comparison with backgrounds
and UGR is studies/glare/evalglare_room.py. Skipped without pyradiance (CI does not install it).
"""

from __future__ import annotations

import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

L_PANEL, SIDE = 3000.0, 0.6  # cd/m², m


def test_one_panel_against_evalglare(tmp_path):
    pyradiance = pytest.importorskip("pyradiance")
    from _glare import rect, scene_of, write_with_opening
    from helpers import lamp, photometry

    from lumijax.design import Design
    from lumijax.glare import Observer, build_glare_model
    from lumijax.photometry import lambertian

    root = Path(pyradiance.__file__).parent
    env = dict(os.environ, RAYPATH=f".{os.pathsep}{root / 'lib'}")
    r = L_PANEL / 179.0  # Radiance radiance of a white source of this luminance
    (tmp_path / "s.rad").write_text(
        f"void light panel 0 0 3 {r} {r} {r}\n"
        "panel polygon p 0 0 12 1.7 -0.3 2.999 1.7 0.3 2.999 2.3 0.3 2.999 2.3 -0.3 2.999\n")
    with open(tmp_path / "s.oct", "wb") as f:
        subprocess.run([str(root / "bin" / "oconv"), "s.rad"], stdout=f, check=True,
                       cwd=tmp_path, env=env)
    with open(tmp_path / "s.hdr", "wb") as f:
        subprocess.run([str(root / "bin" / "rpict"), "-vta", "-vp", "0", "0", "1.2", "-vd", "1",
                        "0", "0", "-vu", "0", "0", "1", "-vh", "180", "-vv", "180", "-x", "300",
                        "-y", "300", "-ps", "1", "-ab", "0", "s.oct"], stdout=f, check=True,
                       cwd=tmp_path, env=env)
    out = subprocess.run([str(root / "bin" / "evalglare"), "-b", "1000", "-d", "s.hdr"],
                         capture_output=True, text=True, check=True, cwd=tmp_path,
                         env=env).stdout.splitlines()
    (src,) = [ln.split() for ln in out if ln.startswith("1 ") and "No" not in ln]
    # columns: No, pixels, x, y, L_s, Omega_s, Posindx, L_b, L_t, E_v, Edir, …, Lveil_cie (17)
    eg_lum, eg_omega, eg_p, eg_edir = float(src[4]), float(src[5]), float(src[6]), float(src[10])
    eg_lveil = float(src[17])

    ies = write_with_opening(tmp_path / "panel.ies", lambertian(math.pi * L_PANEL * SIDE ** 2),
                             rect(SIDE))
    scene = scene_of(photometry("panel", file=ies), lamp("P", [2, 0, 2.999], "n", "panel"))
    model = build_glare_model(scene, [Observer.looking("eye", [0, 0, 1.2], [1, 0, 0])])
    from lumijax.glare import Glare

    glare = Glare(model, Design.of(scene))
    (seen,) = glare.seen_sources(0)
    assert seen["luminance_cdm2"] == pytest.approx(eg_lum, rel=0.02)
    assert seen["solid_angle_sr"] == pytest.approx(eg_omega, rel=0.05)  # pixelated edges
    assert seen["position_index"] == pytest.approx(eg_p, rel=0.04)
    lveil = float(np.asarray(model(Design.of(scene)).veiling_cdm2)[0])
    assert lveil == pytest.approx(eg_lveil, rel=0.04)
    e_eye = lveil * float(np.degrees(np.arccos(np.dot(seen["direction"], [1, 0, 0])))) ** 2 / 10
    assert e_eye == pytest.approx(eg_edir, rel=0.04)
