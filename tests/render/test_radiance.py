"""The traced fisheye against Radiance: the same room (uniform walls, one bright panel) drawn by
``rpict -vta`` agrees pixel by pixel, and evalglare reading lumijax's own picture
(``LuminanceImage.write_hdr``) finds the panel's luminance and solid angle and the UGR that
``LuminanceImage.ugr`` gives. Skipped without pyradiance (CI does not install it)."""

from __future__ import annotations

import math
import os
import subprocess
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from test_cameras import _box, _tracer_of

from lumijax.render import Fisheye, Optics
from lumijax.scene import AreaSource

L_WALL, L_PANEL, SIDE = 20.0, 3000.0, 0.6  # cd/m², cd/m², m
EYE, AHEAD = (0.0, 0.0, 1.2), (1.0, 0.0, 0.0)


def _run(root, env, cwd, args, out=None):
    if out is None:
        return subprocess.run([str(root / "bin" / args[0]), *args[1:]], capture_output=True,
                              text=True, check=True, cwd=cwd, env=env).stdout
    with open(cwd / out, "wb") as f:
        subprocess.run([str(root / "bin" / args[0]), *args[1:]], stdout=f, check=True, cwd=cwd,
                       env=env)
    return None


def test_fisheye_against_rpict_and_evalglare(tmp_path):
    pyradiance = pytest.importorskip("pyradiance")
    root = Path(pyradiance.__file__).parent
    env = dict(os.environ, RAYPATH=f".{os.pathsep}{root / 'lib'}")
    lo, hi = (-3.0, -4.0, 0.0), (5.0, 4.0, 3.0)
    # the panel on the far wall's plane less 1 cm, facing the eye (−x), centre (4.99, 0.5, 2)
    cx, cy, cz = 4.99, 0.5, 2.0
    corners = [(cx, cy - SIDE / 2, cz - SIDE / 2), (cx, cy - SIDE / 2, cz + SIDE / 2),
               (cx, cy + SIDE / 2, cz + SIDE / 2), (cx, cy + SIDE / 2, cz - SIDE / 2)]
    rw, rp = L_WALL / 179.0, L_PANEL / 179.0
    (tmp_path / "s.rad").write_text(
        f"void glow walls 0 0 4 {rw} {rw} {rw} 0\n"
        f"!genbox walls room {hi[0] - lo[0]} {hi[1] - lo[1]} {hi[2] - lo[2]} -i "
        f"| xform -t {lo[0]} {lo[1]} {lo[2]}\n"
        f"void light bright 0 0 3 {rp} {rp} {rp}\n"
        "bright polygon panel 0 0 12 " + " ".join(f"{x} {y} {z}" for x, y, z in corners) + "\n")
    _run(root, env, tmp_path, ["oconv", "s.rad"], "s.oct")
    n = 240
    _run(root, env, tmp_path, ["rpict", "-vta", "-vp", *map(str, EYE), "-vd", *map(str, AHEAD),
                               "-vu", "0", "0", "1", "-vh", "180", "-vv", "180", "-x", str(n),
                               "-y", str(n), "-ps", "1", "-pj", "0", "-ab", "0", "s.oct"],
         "rad.hdr")
    text = _run(root, env, tmp_path, ["pvalue", "-h", "-H", "-o", "-b", "-d", "rad.hdr"])
    # radiance (W/sr/m²) of a grey picture, top row first: luminance = 179 × it
    rad = 179.0 * np.array(text.split(), float).reshape(n, n)

    o = np.array(corners[0])
    panel = AreaSource(name="P", origin=o, u=np.array(corners[1]) - o,
                       v=np.array(corners[3]) - o, flux_lm=math.pi * L_PANEL * SIDE ** 2,
                       network="n")
    assert np.allclose(panel.normal, [-1.0, 0.0, 0.0])
    scene = SimpleNamespace(luminaires=(), photometries={}, network_names=("n",),
                            area_sources=(panel,))
    tracer = _tracer_of(_box(lo, hi), L_WALL, Optics.lambertian(1), scene)
    cam = Fisheye(position=EYE, target=tuple(np.add(EYE, AHEAD)), size=(n, n))
    img = tracer.render(cam, [1.0])
    ours = img.luminance
    inside = cam.solid_angles() > 0
    same = np.isclose(ours, rad, rtol=0.02)
    # Radiance and lumijax agree but where a pixel straddles the panel's edge or the rim
    assert same[inside].mean() > 0.99
    assert np.isclose(ours, L_PANEL, rtol=1e-6).sum() == pytest.approx(
        np.isclose(rad, L_PANEL, rtol=0.02).sum(), rel=0.1)

    img.write_hdr(tmp_path / "ours.hdr")
    out = _run(root, env, tmp_path, ["evalglare", "-b", "1000", "-d", "ours.hdr"]).splitlines()
    (src,) = [ln.split() for ln in out if ln.startswith("1 ") and "No" not in ln]
    eg_lum, eg_omega = float(src[4]), float(src[5])
    assert eg_lum == pytest.approx(L_PANEL, rel=0.02)
    d = np.array([cx, cy, cz]) - EYE
    omega = SIDE ** 2 * (d[0] / np.linalg.norm(d)) / float(d @ d)
    assert eg_omega == pytest.approx(omega, rel=0.1)  # pixelated edges at 240 px
    # the summary line: "dgp,av_lum,...,ugr,...: values"
    (summary,) = [ln for ln in out if ln.startswith("dgp,")]
    names, values = summary.split(":")
    eg = dict(zip(names.split(","), map(float, values.split()), strict=True))
    ours_ugr, ours_lb = img.ugr(threshold_cdm2=1000.0)
    assert ours_lb == pytest.approx(eg["lum_backg"], rel=0.02)
    assert ours_ugr == pytest.approx(eg["ugr"], abs=0.3)
