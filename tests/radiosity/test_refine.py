"""Adaptive refinement (lumijax.radiosity.refine_patches) against the closed-form direct light of a
point source above a floor, with a box casting a sharp shadow.

The reference is independent of lumijax's kernels: E(x) = I cos θ / d² for an isotropic source
of intensity I = Φ/4π, times exact visibility from a slab test of the segment x → source against
the box. Patch values are that field at the patch centroids (what the pipeline computes there);
the error of the piecewise-constant field is measured by quadrature on 2 cm sub-triangles.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import box, lamp, material, photometry, rectangle, study_text, table

import lumijax
from lumijax.radiosity import edge_neighbours, mesh_patches, near_samples, refine_patches
from lumijax.radiosity._refine import _split4

PHI = 4000.0  # lm
SOURCE = np.array([1.0, 1.0, 1.2])
BOX_MIN, BOX_MAX = np.array([2.0, 1.8, 0.3]), np.array([2.8, 2.6, 0.7])
FLOOR = np.array([[[0, 0, 0], [4, 0, 0], [4, 4, 0]], [[0, 0, 0], [4, 4, 0], [0, 4, 0]]], float)


def exact(x, source=SOURCE):
    """Direct irradiance (lx) on the floor z = 0 (normal +z) at points x (..., 3)."""
    d = source - x
    r = np.linalg.norm(d, axis=-1)
    e = PHI / (4 * np.pi) * d[..., 2] / r**3
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (BOX_MIN - x) / d, (BOX_MAX - x) / d
    lo = np.nanmax(np.minimum(t1, t2), axis=-1)
    hi = np.nanmin(np.maximum(t1, t2), axis=-1)
    return np.where((lo <= hi) & (hi > 0) & (lo < 1), 0.0, e)


def at_centroids(p):
    return exact(p.centroid)[None]


def quadrature(p, h=0.01):
    """Sample points (P, S, 3) on sub-triangles of legs ≤ h of every patch, equal weights."""
    out = {}
    m_of = np.ceil(p.diameter / (h * np.sqrt(2)) - 1e-9).astype(int)
    for m in np.unique(m_of):
        w = [((a + 1 / 3) / m, (b + 1 / 3) / m) for a in range(m) for b in range(m - a)]
        w += [((a + 2 / 3) / m, (b + 2 / 3) / m) for a in range(m) for b in range(m - a - 1)]
        w = np.asarray(w)
        sel = np.flatnonzero(m_of == m)
        v = p.vertices[sel]
        out[m] = (sel, v[:, None, 0] + w[None, :, :1] * (v[:, None, 1] - v[:, None, 0])
                  + w[None, :, 1:] * (v[:, None, 2] - v[:, None, 0]))
    return out


def l1_error(p, value, h=0.02):
    """∫|E_patch − E(x)| dA / ∫E dA over the floor."""
    err = tot = 0.0
    for sel, x in quadrature(p, h).values():
        e = exact(x)
        da = p.area[sel][:, None] / x.shape[1]
        err += np.sum(np.abs(value[sel][:, None] - e) * da)
        tot += np.sum(e * da)
    return err / tot


def straddling(p, m=8):
    """Mask of patches the shadow edge crosses (lit and shadowed points among m² samples)."""
    w = np.asarray([((a + 1 / 3) / m, (b + 1 / 3) / m) for a in range(m) for b in range(m - a)]
                   + [((a + 2 / 3) / m, (b + 2 / 3) / m) for a in range(m) for b in range(m - a - 1)])
    v = p.vertices
    x = (v[:, None, 0] + w[None, :, :1] * (v[:, None, 1] - v[:, None, 0])
         + w[None, :, 1:] * (v[:, None, 2] - v[:, None, 0]))
    lit = exact(x) > 0
    return lit.any(axis=1) & ~lit.all(axis=1)


BASE = 0.5  # m, the meshing size (legs 4/12 m); three levels reach legs of 4/96 m


def test_shadow_edge_is_refined_and_the_error_drops_with_fewer_patches_than_uniform():
    base = mesh_patches(FLOOR, patch_size=BASE)
    ref = refine_patches(base, at_centroids, levels=3, threshold=0.5)
    fine = mesh_patches(FLOOR, patch_size=BASE / 8)  # uniform at the finest refined size
    p = ref.patches
    # bookkeeping: area, orientation and parents kept; values are the field at the centroids
    assert p.area.sum() == pytest.approx(16.0, rel=1e-12)
    assert np.all(np.cross(p.vertices[:, 1] - p.vertices[:, 0],
                           p.vertices[:, 2] - p.vertices[:, 0])[:, 2] > 0)
    assert np.allclose(ref.irradiance[0], exact(p.centroid))
    assert np.allclose(p.area * 4.0**ref.level, base.area[0])
    assert np.all(np.diff(p.source_triangle) >= 0)
    # The shadow edge is resolved at the finest size: nearly all patches it crosses are
    # level-3 ones, and they cover about the area the edge's patches cover in the uniform fine
    # mesh, while most of the floor keeps its coarse patches.
    s, sf = straddling(p), straddling(fine)
    print(f"edge patches: adaptive {s.sum()} ({p.area[s].sum():.3f} m², levels "
          f"{np.bincount(ref.level[s]).tolist()}), uniform fine {sf.sum()} "
          f"({fine.area[sf].sum():.3f} m²)")
    assert np.mean(ref.level[s] == 3) > 0.8
    assert p.area[s].sum() < 1.5 * fine.area[sf].sum()
    assert np.mean(ref.level == 0) > 0.25
    # L1 error of the piecewise-constant field against the exact one.
    e_base = l1_error(base, at_centroids(base)[0])
    e_ref = l1_error(p, ref.irradiance[0])
    e_fine = l1_error(fine, at_centroids(fine)[0])
    print(f"L1: base {base.n} patches {e_base:.4f}, adaptive {p.n} {e_ref:.4f}, "
          f"uniform fine {fine.n} {e_fine:.4f}")
    assert p.n < fine.n / 10
    assert e_ref < 0.97 * e_base
    # Within 1/8 m of the shadow's edge refinement removes most of the error (measured: base
    # 3.85, adaptive 0.87, uniform fine 0.23 lm); the rest of the floor's error is the smooth
    # inverse-square gradient, which a 0.5 relative threshold leaves coarse by design.
    band_ref = _band_error(p, ref.irradiance[0])
    band_base = _band_error(base, at_centroids(base)[0])
    band_fine = _band_error(fine, at_centroids(fine)[0])
    print(f"L1 in the edge band (lm): base {band_base:.2f}, adaptive {band_ref:.2f}, "
          f"uniform fine {band_fine:.2f}")
    assert band_ref < band_base / 3


def _band_error(p, value, h=0.02, width=BASE / 4):
    """∫|E_patch − E(x)| dA (lm) over floor points within ``width`` of the shadow's edge."""
    err = 0.0
    for sel, x in quadrature(p, h).values():
        e = exact(x)
        da = p.area[sel][:, None] / x.shape[1]
        err += np.sum(np.where(_near_edge(x, width), np.abs(value[sel][:, None] - e), 0) * da)
    return err


def _near_edge(x, width):
    """Points within ``width`` (m, in x or y) of a point of opposite visibility, by probing."""
    lit = exact(x) > 0
    near = np.zeros(lit.shape, bool)
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1), (0.7, 0.7), (-0.7, 0.7), (0.7, -0.7),
                   (-0.7, -0.7)):
        for f in (0.5, 1.0):
            near |= (exact(x + f * width * np.array([dx, dy, 0.0])) > 0) != lit
    return near


def test_steep_fall_off_under_a_low_luminaire_is_refined():
    """A source 0.3 m above the floor: the irradiance falls by half within 0.23 m of its foot
    (cos θ/d² = h/(h² + r²)^{3/2}), so the ring around the foot is refined; far away the
    relative change between neighbours is small and the patches stay as meshed."""
    low = np.array([2.0, 2.0, 0.3])

    def unshadowed(p):
        d = low - p.centroid
        return (PHI / (4 * np.pi) * d[:, 2] / np.linalg.norm(d, axis=1) ** 3)[None]

    ref = refine_patches(mesh_patches(FLOOR, patch_size=BASE), unshadowed, levels=2,
                         threshold=0.5)
    r = np.linalg.norm(ref.patches.centroid[:, :2] - low[:2], axis=1)
    assert np.all(ref.level[r < 0.5] >= 1)
    assert np.all(ref.level[r > 1.5] == 0)


def test_edge_neighbours_across_t_junctions():
    """One triangle gridded 4 × 4 has 18 interior edges; splitting an interior patch into four
    leaves 15 of them, adds 3 inside it and 2 × 3 T-junction pairs with its neighbours."""
    tri = FLOOR[:1]
    p = mesh_patches(tri, patch_size=4 * np.sqrt(2) / 4)
    assert p.n == 16
    i, j = edge_neighbours(p)
    assert len(i) == 18
    deg = np.bincount(np.concatenate([i, j]), minlength=p.n)
    k = int(np.flatnonzero(deg == 3)[0])
    keep = np.arange(p.n) != k
    from lumijax.radiosity._refine import _concat

    q = _concat(p.subset(keep), _split4(p.subset(np.array([k]))))
    i, j = edge_neighbours(q)
    assert len(i) == 15 + 3 + 6
    # only pairs with a new patch, when asked
    among = np.arange(q.n) >= p.n - 1
    i2, _ = edge_neighbours(q, among)
    assert len(i2) == 3 + 6
    # a wall meeting the floor at 90° is not a neighbour
    wall = np.array([[[0, 0, 0], [0, 0, 1], [4, 0, 0]]], float)
    both = mesh_patches(np.concatenate([tri, wall]), patch_size=10)
    assert len(edge_neighbours(both)[0]) == 0


def test_refine_setting_reaches_the_solve(write_study):
    """``[solver] refine`` through lumijax.compute: the solve runs on the refined patches, and
    their direct light is the closed-form field at their centroids (where the lamp is near
    enough for the patch to take its mean over pieces instead, ``near_samples``, it is not
    compared: a small study cuts the floor's coarse patches under the lamp)."""
    text = study_text(
        material("grey", 0.5), photometry("iso", "isotropic", PHI),
        rectangle([0, 0, 0], [4, 0, 0], [0, 4, 0], "grey"),
        box(BOX_MIN, BOX_MAX, "grey", normals=None), lamp("L", SOURCE),
        table("solver", patch_size=BASE, spectral_samples=0, refine=2))
    study = lumijax.load_study(write_study(text))
    tri = study.scene.triangles
    p0 = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=BASE)
    res = lumijax.compute(study)
    p = res.lighting.coarse.patches
    assert p.n > p0.n
    assert p.area.sum() == pytest.approx(p0.area.sum())
    floor = (p.normal[:, 2] > 0.99) & (p.centroid[:, 2] < 1e-9)
    assert p.area[floor].min() == pytest.approx(p0.area[0] / 16)
    floor[near_samples(p, SOURCE[None]).patch] = False
    assert floor.sum() > 300  # the refined shadow edge's patches among them
    assert np.allclose(res.lighting.coarse.patch_direct[0][floor], exact(p.centroid[floor]),
                       rtol=1e-4, atol=1e-6 * PHI)


@pytest.mark.parametrize("line", ["refine = -1", "refine = 1.5", "refine_threshold = 0"])
def test_bad_refine_settings_name_their_key(write_study, line):
    path = write_study(study_text(material("m", 0.5), rectangle([0, 0, 0], [1, 0, 0], [0, 1, 0], "m"),
                             table("solver")) + line + "\n")
    with pytest.raises(lumijax.ConfigError, match=f"solver.{line.split()[0]}"):
        lumijax.load_study(path)
