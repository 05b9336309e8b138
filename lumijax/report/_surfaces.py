"""The scene's surfaces with their light at the vertices: what views and the viewer draw.

The radiosity solution is constant per patch and view independent. For smooth pictures each
vertex takes the area-weighted mean of the patches that touch it, among those of the same plane
(vertices are welded only where position *and* normal agree, so light never bleeds round a
corner). The averaging is a fixed sparse matrix, so per-network vertex values are precomputed
once and any dimmer vector recombines them exactly: ``value(α) = Σ_k α_k value_k``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Float, Int

__all__ = ["SurfaceLight", "surface_light", "weld"]

#: CIE 1931 XYZ of the D65 white with Y = 1: the colour of a luminous-only (grey) solution.
_D65 = np.array([0.95047, 1.0, 1.08883])


def weld(vertices: Float[np.ndarray, "tri 3 3"], normals: Float[np.ndarray, "tri 3"],
         tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(points (V, 3), faces (T, 3), normals (V, 3))``: triangle corners merged where position
    (to ``tol`` metres) and normal (to ~1e-3) agree."""
    v = vertices.reshape(-1, 3)
    n = np.repeat(normals, 3, axis=0)
    key = np.concatenate([np.round(v / tol), np.round(n * 1e3)], axis=1).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return v[first], inverse.reshape(-1, 3), n[first]


@dataclass(frozen=True, eq=False)
class SurfaceLight:
    """Welded surface triangles and, per network at dimmer 1, the light at their vertices.

    Attributes
    ----------
    points, faces, normals
        ``(V, 3)`` vertex positions (m), ``(T, 3)`` vertex indices of the triangles and
        ``(V, 3)`` the front normal at each vertex.
    networks
        Network names, in the order of the per-network arrays.
    xyz
        ``(K, V, 3)`` CIE XYZ of each network's luminance at the vertices, Y in cd/m².
    patch_luminance
        ``(K, T)`` luminance of each triangle (patch) per network, cd/m² (L = B/π).
    illuminance
        ``(K, V)`` illuminance on the surfaces at the vertices, lx (None until asked for).
    area
        ``(T,)`` triangle areas, m² (weights of automatic exposure).
    """

    points: Float[np.ndarray, "vertices 3"]
    faces: Int[np.ndarray, "tri 3"]
    normals: Float[np.ndarray, "vertices 3"]
    networks: tuple[str, ...]
    xyz: Float[np.ndarray, "net vertices 3"]
    patch_luminance: Float[np.ndarray, "net tri"]
    area: Float[np.ndarray, " tri"]
    average: object  # scipy.sparse (V, T): vertex value = average @ patch value
    illuminance: Float[np.ndarray, "net vertices"] | None = None
    material: Int[np.ndarray, " tri"] | None = None  # scene material of each triangle

    def xyz_at(self, dimmers) -> Float[np.ndarray, "vertices 3"]:
        """Vertex XYZ (Y in cd/m²) at a dimmer vector, by superposition."""
        return np.einsum("k,kvc->vc", np.asarray(dimmers, np.float64), self.xyz)

    def luminance_at(self, dimmers) -> Float[np.ndarray, " vertices"]:
        """Vertex luminance (cd/m²) at a dimmer vector."""
        return np.asarray(dimmers, np.float64) @ self.xyz[..., 1]

    def illuminance_at(self, dimmers) -> Float[np.ndarray, " vertices"]:
        """Vertex illuminance (lx) at a dimmer vector (needs ``illuminance``)."""
        if self.illuminance is None:
            raise ValueError("this SurfaceLight was built without illuminance")
        return np.asarray(dimmers, np.float64) @ self.illuminance

    @property
    def vertex_area(self) -> Float[np.ndarray, " vertices"]:
        """A third of the area of each triangle at a vertex, summed (m²)."""
        return np.bincount(self.faces.ravel(), np.repeat(self.area / 3.0, 3),
                           minlength=len(self.points))

    def polydata(self):
        """The surfaces as a pyvista PolyData (no arrays attached)."""
        import pyvista as pv

        faces = np.column_stack([np.full(len(self.faces), 3), self.faces]).ravel()
        return pv.PolyData(self.points, faces=faces)


def _averaging(faces: np.ndarray, n_vertices: int, area: np.ndarray):
    import scipy.sparse as sp

    rows = faces.ravel()
    cols = np.repeat(np.arange(len(faces)), 3)
    w = np.repeat(area, 3)
    m = sp.csr_matrix((w, (rows, cols)), shape=(n_vertices, len(faces)))
    total = np.asarray(m.sum(axis=1)).ravel()
    inv = np.divide(1.0, total, out=np.zeros_like(total), where=total > 0)
    return sp.diags(inv) @ m


def surface_light(results, *, illuminance: bool = False, target_patches: int = 3000) -> SurfaceLight:
    """The surfaces of a computed study with their light per network.

    What is drawn is the solution's own: its patches and their radiosity when inter-reflection
    was solved (the fine level of a two-level solve; colour from the spectral solution, or
    neutral D65 white after a luminous-only solve), never a re-mesh. A solution without patches
    (``indirect = false`` or ``shadows=False``) has no surface light to draw: the scene's
    triangles are then cut into about ``target_patches`` patches and lit by the direct stage
    itself (:func:`lumijax.direct.direct_illuminance`, the same pairs and kernel as the grids,
    with shadows as the solution had them), ρE/π, neutral colour, no inter-reflection.
    ``illuminance`` also keeps the illuminance on the surfaces (lx), for false-colour views.
    """
    lighting = results.lighting
    scene = lighting.scene
    # a two-level solve draws its fine patches (the display level); otherwise the patches
    p = lighting.display.patches
    if p is not None and p.n:
        b = np.asarray(lighting.display.radiosity, np.float64)
        b_xyz = lighting.display.radiosity_xyz
        if b_xyz is not None:
            bxyz = np.moveaxis(np.asarray(b_xyz, np.float64), 1, 2)  # (K, P, 3)
        else:
            bxyz = b[..., None] * _D65
        e = None
        if illuminance:
            e = lighting.display_patch_illuminance()
    else:
        # an unshadowed solution (compute(shadows=False)) says so in its stats
        p, b, e = _direct_patches(scene, target_patches,
                                  shadows=bool(lighting.stats.get("shadows", True)))
        bxyz = b[..., None] * _D65
    points, faces, normals = weld(p.vertices, p.normal)
    avg = _averaging(faces, len(points), p.area)
    xyz = np.stack([avg @ (bxyz[k] / np.pi) for k in range(len(b))]) if len(b) else np.zeros(
        (0, len(points), 3))
    ill = None
    if e is not None:
        ill = np.stack([avg @ np.asarray(row, np.float64) for row in e])
    return SurfaceLight(points=points, faces=faces, normals=normals, networks=tuple(scene.network_names),
                        xyz=xyz, patch_luminance=b / np.pi, area=np.asarray(p.area),
                        average=avg, illuminance=ill, material=np.asarray(p.material))


def _direct_patches(scene, target_patches: int, *, shadows: bool = True):
    from ..direct import direct_illuminance
    from ..radiosity import mesh_patches

    tri = scene.triangles
    total = float(np.sum(tri.areas))
    size = max(np.sqrt(2.0 * total / max(target_patches, 1)), 1e-3)
    p = mesh_patches(tri.vertices, tri.material, tri.group, patch_size=size)
    e = direct_illuminance(scene, p.centroid, p.normal, shadows=shadows).by_network
    rho = np.array([m.luminous_reflectance for m in scene.materials])[p.material]
    return p, np.asarray(e, np.float64) * rho, np.asarray(e, np.float64)
