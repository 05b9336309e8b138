"""Radiosity patches: the scene's triangles subdivided into pieces of about one size.

Each input triangle is split by a regular barycentric grid into n² congruent sub-triangles, with
n = ceil(longest edge / patch_size). Every patch is therefore a triangle with the orientation (and
so the front face, see ``docs/conventions.md``) of its source triangle, and every patch of one
triangle has the same area, which keeps the radiosity system well scaled. Slivers are the
exception: the grid would cut them into n² needles, so they are bisected along their longest
edge instead, down to half a nominal patch's area (pieces of one triangle then differ in area by
powers of two, and a needle's pieces may be longer than the patch size).
"""

from __future__ import annotations

import functools

import equinox as eqx
import numpy as np
from jaxtyping import Float, Int

from ..errors import GeometryError
from ..kernels import triangle_shape

__all__ = ["Patches", "mesh_patches"]


class Patches(eqx.Module):
    """Constant-radiosity triangular patches (host arrays, float64, metres).

    Attributes
    ----------
    centroid
        ``(P, 3)`` centroids, m.
    normal
        ``(P, 3)`` unit front normals (right-hand rule on the vertex order).
    area
        ``(P,)`` areas, m².
    vertices
        ``(P, 3, 3)`` vertex positions, m.
    material
        ``(P,)`` material index of the source triangle.
    group
        ``(P,)`` user group id of the source triangle (−1: none).
    source_triangle
        ``(P,)`` index of the input triangle each patch was cut from.
    """

    centroid: Float[np.ndarray, "patches 3"]
    normal: Float[np.ndarray, "patches 3"]
    area: Float[np.ndarray, " patches"]
    vertices: Float[np.ndarray, "patches 3 3"]
    material: Int[np.ndarray, " patches"]
    group: Int[np.ndarray, " patches"]
    source_triangle: Int[np.ndarray, " patches"]

    @property
    def n(self) -> int:
        """Number of patches."""
        return int(self.area.shape[0])

    @property
    def diameter(self) -> Float[np.ndarray, " patches"]:
        """Longest edge of each patch, m (the size used to decide near and far pairs)."""
        v = self.vertices
        e = np.stack([v[:, 1] - v[:, 0], v[:, 2] - v[:, 1], v[:, 0] - v[:, 2]], axis=1)
        return np.linalg.norm(e, axis=-1).max(axis=1)

    def subset(self, index) -> Patches:
        """The patches at ``index`` (an index array or boolean mask), in that order."""
        return Patches(*(np.asarray(f)[index] for f in _fields(self)))


def _fields(p: Patches):
    return (p.centroid, p.normal, p.area, p.vertices, p.material, p.group, p.source_triangle)


@functools.cache
def _template(n: int) -> np.ndarray:
    """Barycentric (w1, w2) coordinates of the n² sub-triangles of the unit triangle, (n², 3, 2).

    Up triangles (a,b)→(a+1,b)→(a,b+1) and down triangles (a+1,b)→(a+1,b+1)→(a,b+1) both keep
    the parent's orientation, so the front face is preserved.
    """
    tris = []
    for a in range(n):
        for b in range(n - a):
            tris.append([(a, b), (a + 1, b), (a, b + 1)])
            if a + b <= n - 2:
                tris.append([(a + 1, b), (a + 1, b + 1), (a, b + 1)])
    return np.asarray(tris, dtype=np.float64) / n


def subdivide_triangles(
    triangles: Float[np.ndarray, "tri 3 3"], n: int
) -> Float[np.ndarray, "tri sub 3 3"]:
    """Split each triangle into n² congruent sub-triangles of the same orientation."""
    w = _template(n)  # (S, 3, 2)
    v0 = triangles[:, None, None, 0]
    e1 = (triangles[:, 1] - triangles[:, 0])[:, None, None]
    e2 = (triangles[:, 2] - triangles[:, 0])[:, None, None]
    return v0 + w[None, ..., 0:1] * e1 + w[None, ..., 1:2] * e2


#: A triangle whose longest edge exceeds this many times its height is bisected, not gridded.
_SLIVER_ASPECT = 3.0

#: Relative margin of the meshing thresholds: a 4 m wall at 0.5 m patches is 8 patches long
#: wherever it sits, although at 5·10⁶ m its length carries 10⁻⁹ m of rounding (a ratio of
#: 8.000000001 would otherwise give 9).
_TIE = 1e-7


def bisect_triangles(
    triangles: Float[np.ndarray, "tri 3 3"], source: Int[np.ndarray, " tri"], size: float
) -> tuple[Float[np.ndarray, "sub 3 3"], Int[np.ndarray, " sub"]]:
    """Halve triangles at the midpoint of their longest edge until no edge exceeds ``size``, or
    a piece is down to ``size²/8`` (half the area of a nominal patch, ``size²/4``): cutting a
    needle thinner only multiplies patches.

    The vertex order is rotated cyclically before the cut, so both halves keep the parent's
    orientation (front face); the halves have equal areas.
    """
    tri, src = np.asarray(triangles, np.float64), np.asarray(source, np.int64)
    done_v, done_s = [], []
    while len(tri):
        e = np.linalg.norm(np.roll(tri, -1, axis=1) - tri, axis=-1)  # edge i: vertex i → i+1
        a = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        ok = (e.max(axis=1) <= size * (1 + _TIE)) | (a <= size**2 / 8 * (1 + _TIE))
        done_v.append(tri[ok])
        done_s.append(src[ok])
        tri, src, j = tri[~ok], src[~ok], e[~ok].argmax(axis=1)
        r = np.take_along_axis(tri, ((np.arange(3) + j[:, None]) % 3)[:, :, None], axis=1)
        m = 0.5 * (r[:, 0] + r[:, 1])
        tri = np.concatenate([np.stack([r[:, 0], m, r[:, 2]], 1), np.stack([m, r[:, 1], r[:, 2]], 1)])
        src = np.concatenate([src, src])
    return np.concatenate(done_v), np.concatenate(done_s)


def mesh_patches(
    triangles: Float[np.ndarray, "tri 3 3"],
    material: Int[np.ndarray, " tri"] | None = None,
    group: Int[np.ndarray, " tri"] | None = None,
    patch_size: float = 0.25,
) -> Patches:
    """Subdivide the scene's triangles into patches of about ``patch_size`` metres.

    Parameters
    ----------
    triangles
        ``(T, 3, 3)`` vertex positions, m. The front face follows the right-hand rule.
    material, group
        ``(T,)`` per-triangle material index and user group id (−1 for none); default 0 and −1.
    patch_size
        Target longest edge of a patch, m. A triangle whose longest edge is L is cut into
        ceil(L / patch_size)² congruent patches; a sliver (L > 3 × its height) is instead
        halved along its longest edge until every piece is shorter than ``patch_size`` or
        smaller than ``patch_size²/8`` in area.

    Raises
    ------
    GeometryError
        A triangle has a NaN/infinite coordinate or (near) zero area; the message names it.
    """
    tri = np.asarray(triangles, dtype=np.float64)
    if tri.ndim != 3 or tri.shape[1:] != (3, 3):
        raise GeometryError(f"triangles must have shape (T, 3, 3), got {tri.shape}")
    t = len(tri)
    material = np.zeros(t, np.int64) if material is None else np.asarray(material, np.int64)
    group = np.full(t, -1, np.int64) if group is None else np.asarray(group, np.int64)
    if material.shape != (t,) or group.shape != (t,):
        raise GeometryError(
            f"material and group must have shape ({t},) like triangles, got "
            f"{material.shape} and {group.shape}"
        )
    if not (np.isfinite(patch_size) and patch_size > 0):
        raise GeometryError(f"patch_size must be a positive length in metres, got {patch_size}")
    bad = ~np.isfinite(tri).all(axis=(1, 2))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise GeometryError(f"triangle {i} has a NaN or infinite coordinate: {tri[i].tolist()}",
                            key=f"triangles[{i}]")
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    # the scene's own rule (relative to each triangle's size, whatever the model's unit)
    area, longest, degenerate = triangle_shape(tri)
    if degenerate.any():
        i = int(np.flatnonzero(degenerate)[0])
        raise GeometryError(
            f"triangle {i} is degenerate (area {area[i]:.3g} m², vertices {tri[i].tolist()}); "
            f"{int(degenerate.sum())} degenerate triangle(s) in all",
            key=f"triangles[{i}]",
        )
    nsub = np.maximum(1, np.ceil(longest / patch_size * (1 - _TIE))).astype(np.int64)
    # Slivers (a column face, a cornice band) would give n² needle patches under the regular
    # grid, n set by their length alone: bisect them along their longest edge instead, which
    # costs about 2·length/patch_size patches.
    sliver = (nsub > 1) & (longest**2 > _SLIVER_ASPECT * 2.0 * area * (1 + _TIE))
    out_v, out_src = [], []
    if sliver.any():
        v, s = bisect_triangles(tri[sliver], np.flatnonzero(sliver), patch_size)
        out_v.append(v)
        out_src.append(s)
    for n in np.unique(nsub[~sliver]):
        idx = np.flatnonzero((nsub == n) & ~sliver)
        sub = subdivide_triangles(tri[idx], int(n))  # (k, n², 3, 3)
        out_v.append(sub.reshape(-1, 3, 3))
        out_src.append(np.repeat(idx, n * n))
    verts = np.concatenate(out_v) if out_v else np.zeros((0, 3, 3))
    src = np.concatenate(out_src) if out_src else np.zeros(0, np.int64)
    order = np.argsort(src, kind="stable")  # patches of one triangle stay together, in order
    verts, src = verts[order], src[order]
    c = np.cross(verts[:, 1] - verts[:, 0], verts[:, 2] - verts[:, 0])
    pa = 0.5 * np.linalg.norm(c, axis=1)
    normal = cross[src] / (2.0 * area[src])[:, None]  # the parent's normal: exact, no rounding
    return Patches(
        centroid=verts.mean(axis=1),
        normal=normal,
        area=pa,
        vertices=verts,
        material=material[src],
        group=group[src],
        source_triangle=src,
    )
