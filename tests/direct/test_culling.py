"""The direct light's culling is exact: it skips only pairs whose light is exactly zero.

The reference is every (luminaire, receiver) pair evaluated with no culling at all — the
unshadowed kernel :func:`lumijax.kernels.point_illuminance` on all pairs, times each pair's own
shadow ray — against ``direct_illuminance``, which culls by tiles of receivers (support cone,
the table's cells with light, facing) and per pair before any kernel or ray.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import box, lamp, material, network, photometry, study_text

from lumijax import load_study
from lumijax.direct import direct_illuminance
from lumijax.kernels import point_illuminance
from lumijax.photometry import LuminousOpening, lambertian, linear_washer, spot, write_ies


def _point_washer():
    """A washer's 110° × 24° beam thrown 8° sideways (light to γ 172° along the bar, 58°
    towards the wall), from a point opening so that the reference needs no sub-sources."""
    w = linear_washer(800.0, 0.8, 24.0, 110.0, width_m=0.06, offset_deg=8.0)
    return dataclasses.replace(w, opening=LuminousOpening(0.0, 0.0, 0.0, "point"))


def _uncut(scene, points, normals, shadows=True):
    """Per network: every luminaire × every point, no culling, a shadow ray per pair; and
    the number of pairs with light before shadows."""
    out = np.zeros((len(scene.networks), len(points)))
    lit = 0
    net = {n.name: k for k, n in enumerate(scene.networks)}
    caster = scene.raycaster if shadows else None
    for lum in scene.luminaires:
        dist = scene.photometries[lum.photometry].distribution
        e = np.asarray(point_illuminance(
            dist, jnp.asarray(lum.position[None]), jnp.asarray(lum.rotation[None]),
            jnp.asarray([lum.scale]), jnp.asarray(points), jnp.asarray(normals)))[0]
        lit += int((e > 0).sum())
        if caster is not None:
            e = e * caster.transmission(np.broadcast_to(lum.position, points.shape), points)
        out[net[lum.network]] += e
    return out, lit


@pytest.fixture
def spots_room(write_study, tmp_path):
    """A 12 × 9 × 5 m room with a pillar; two 8° spots at walls, a downlight, a washer."""
    for name, ph in (("spot", spot(450.0, 8.0, 14.0)), ("down", lambertian(1000.0)),
                     ("wash", _point_washer())):
        write_ies(ph, tmp_path / f"{name}.ies")
    text = study_text(
        material("wall", 0.5),
        photometry("spot", file=tmp_path / "spot.ies"),
        photometry("down", file=tmp_path / "down.ies"),
        photometry("wash", file=tmp_path / "wash.ies"),
        network("a"), network("b"),
        box([0, 0, 0], [12, 9, 5], "wall"),
        box([5, 4, 0], [6, 5, 3], "wall", normals=None),
        lamp("s1", [2, 2, 4.5], "a", "spot", aim_at=[11.9, 7, 2]),
        lamp("s2", [10, 7, 1], "a", "spot", aim_at=[0.1, 1, 4]),
        lamp("d", [6, 2, 4.9], "b", "down"),
        lamp("w", [3, 8.5, 4.5], "b", "wash", aim={"tilt": 0, "pan": 30, "spin": 0}))
    return load_study(write_study(text)).scene


def _room_points(n, seed=0):
    """Receivers on the room's floor, ceiling and walls (their inward normals) and loose
    in the air with random normals."""
    rng = np.random.default_rng(seed)
    u = rng.random((n, 2))
    face = rng.integers(0, 7, n)
    size = np.array([12.0, 9.0, 5.0])
    p = np.zeros((n, 3))
    nrm = np.zeros((n, 3))
    for k, (axis, side) in enumerate([(2, 0), (2, 1), (0, 0), (0, 1), (1, 0), (1, 1)]):
        m = face == k
        other = [a for a in range(3) if a != axis]
        p[np.ix_(m, other)] = u[m] * size[other]
        p[m, axis] = side * size[axis]
        nrm[m, axis] = 1.0 if side == 0 else -1.0
    m = face == 6
    p[m] = rng.random((m.sum(), 3)) * size
    nrm[m] = rng.normal(size=(m.sum(), 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    inset = 1e-3 * (face < 6)[:, None] * nrm  # just off the wall, in front of it
    return p + inset, nrm


def test_culled_direct_light_equals_every_pair_with_its_ray(spots_room):
    pts, nrm = _room_points(3000)
    got = direct_illuminance(spots_room, pts, nrm)
    ref, lit = _uncut(spots_room, pts, nrm)
    np.testing.assert_allclose(got.by_network, ref, rtol=1e-9, atol=1e-12 * ref.max())
    assert (ref[0] > 0).sum() > 50 and (ref[1] > 0).sum() > 500  # the spots light something
    # a shadow ray for exactly the pairs with light, and the kernel for few more
    assert got.shadow_rays == lit
    assert lit <= got.candidate_pairs < 1.5 * lit


def _washer_alone(write_study, tmp_path):
    write_ies(_point_washer(), tmp_path / "wash.ies")
    return load_study(write_study(study_text(
        photometry("wash", file=tmp_path / "wash.ies"), lamp("w", [0, 0, 0], "n", "wash"),
        network("n")))).scene


def _cutoff(dist, c_deg):
    """(largest γ with light on the table's C row, first γ with no light on any row within
    10° of it: where the bilinear interpolant is zero around that azimuth)."""
    h, v = np.asarray(dist.h_deg), np.asarray(dist.v_deg)
    cd = np.asarray(dist.candela)
    row = cd[int(np.argmin(np.abs(h - c_deg)))]
    near = cd[np.abs((h - c_deg + 180.0) % 360.0 - 180.0) <= 10.0]
    return v[int(np.flatnonzero(row > 0).max())], v[int(np.flatnonzero(near.max(0) > 0).max()) + 1]


def test_zero_region_gets_exactly_zero_and_the_cutoff_edge_gets_its_light(
        write_study, tmp_path):
    """Receivers 10 m from the washer on its table's C rows, at γ on both sides of the last
    cell with light: the zero region reads exactly 0, the edge of the cutoff its own light.
    Each receiver is a tight cluster of 256 points (about one culling tile), so zero-region
    clusters are rejected whole, before the kernel, and edge clusters kept."""
    scene = _washer_alone(write_study, tmp_path)
    dist = scene.photometries["wash"].distribution
    h, v = np.asarray(dist.h_deg), np.asarray(dist.v_deg)
    dirs, inside = [], []
    for c in h[(h < 360.0) & (np.mod(h, 30.0) == 0)]:
        lit, zero = _cutoff(dist, c)
        # just inside the cutoff (the bilinear cell still has light) and just past it
        for g, ok in ((lit + 0.4 * (v[1] - v[0]), True), (zero + 2.0, False)):
            if g < 179.0:
                cr, gr = np.radians(c), np.radians(g)
                dirs.append([np.sin(gr) * np.cos(cr), np.sin(gr) * np.sin(cr), -np.cos(gr)])
                inside.append(ok)
    while len(dirs) & (len(dirs) - 1):  # a power of two of clusters: tiles split between them
        dirs.append([0.0, -0.866, 0.5])  # C 270°, γ 120°: behind the beam, no light
        inside.append(False)
    dirs, inside = np.array(dirs), np.array(inside)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    rng = np.random.default_rng(1)
    m = 256
    pts = (10.0 * dirs[:, None, :] + 0.002 * rng.normal(size=(len(dirs), m, 3))).reshape(-1, 3)
    nrm = -pts / np.linalg.norm(pts, axis=1, keepdims=True)
    out = direct_illuminance(scene, pts, nrm, shadows=False)
    got = out.by_network[0].reshape(len(dirs), m)
    ref = _uncut(scene, pts, nrm, shadows=False)[0][0].reshape(len(dirs), m)
    assert np.all(ref[~inside] == 0.0) and np.all(ref[inside] > 0)
    assert np.all(got[~inside] == 0.0) and np.all(got[inside] > 0)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=0)
    # the support cone (174.5° here) admits all but the far side; the table's cells reject the
    # zero clusters' tiles (a tile may straddle two clusters: bisection splits on points)
    assert m * inside.sum() <= out.candidate_pairs < 1.25 * m * inside.sum()
