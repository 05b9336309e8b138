"""Geometry items (box, rectangle, mesh) to one world-space triangle soup.

Each triangle keeps where it came from (its geometry item, material and group) so that errors
and results can name it, and so that meshing can keep a user's groups apart.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from jaxtyping import Bool, Float, Int

from ..errors import GeometryError
from ..kernels import length_tolerance, rounding_length, triangle_shape
from ._frames import Frame

__all__ = ["Triangles", "box_triangles", "rectangle_triangles", "load_mesh_triangles",
           "check_triangles", "triangle_shape", "length_tolerance", "rounding_length"]

_UNIT_M = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "in": 0.0254}

@dataclass(frozen=True)
class Triangles:
    """The scene's triangles in world space.

    Attributes
    ----------
    vertices
        ``(T, 3, 3)`` metres; the front face is along ``(v1 − v0) × (v2 − v0)``.
    item
        Index of the ``[[geometry]]`` entry each triangle came from.
    material
        Index into the scene's material list.
    group
        Index into the scene's group names, −1 when the item has no group.
    closed
        Per geometry item: whether it bounds a solid (an outward box or a watertight mesh
        facing out), which lights must not sit inside.
    """

    vertices: Float[np.ndarray, "tri 3 3"]
    item: Int[np.ndarray, " tri"]
    material: Int[np.ndarray, " tri"]
    group: Int[np.ndarray, " tri"]
    closed: Bool[np.ndarray, " items"]

    def __len__(self) -> int:
        return len(self.vertices)

    @property
    def normals(self) -> Float[np.ndarray, "tri 3"]:
        v = self.vertices
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    @property
    def areas(self) -> Float[np.ndarray, " tri"]:
        v = self.vertices
        return 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)

    @property
    def bounds(self) -> Float[np.ndarray, "2 3"]:
        flat = self.vertices.reshape(-1, 3)
        return np.stack([flat.min(0), flat.max(0)])


def _quads_to_triangles(quads: Float[np.ndarray, "q 4 3"]) -> Float[np.ndarray, "t 3 3"]:
    return np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=0)


def rectangle_triangles(origin, u, v) -> Float[np.ndarray, "2 3 3"]:
    """Two triangles of the quad ``o, o+u, o+u+v, o+v``; the normal is along ``u × v``."""
    o, u, v = (np.asarray(a, np.float64) for a in (origin, u, v))
    return _quads_to_triangles(np.array([[o, o + u, o + u + v, o + v]]))


def box_triangles(lo, hi, *, inward: bool) -> Float[np.ndarray, "12 3 3"]:
    """The 12 triangles of an axis-aligned box, normals outward (a solid) or inward (a room)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    # each face listed counter-clockwise seen from outside, so the normal points outward
    quads = np.array(
        [
            [[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]],  # bottom, −z
            [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],  # top, +z
            [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],  # −y
            [[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]],  # +y
            [[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]],  # −x
            [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]],  # +x
        ]
    )
    tri = _quads_to_triangles(quads)
    return tri[:, ::-1] if inward else tri


def load_mesh_triangles(
    path: Path, *, units: str = "m", key: str | None = None
) -> tuple[Float[np.ndarray, "t 3 3"], bool]:
    """Triangles of a mesh file (any format trimesh reads) in metres, and whether it is watertight."""
    import trimesh

    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except ImportError as e:  # a format that needs an optional package: name the package
        raise GeometryError(f"cannot read mesh: {e}", file=path, key=key) from None
    except Exception as e:  # trimesh raises many types; all mean "cannot read this file"
        # trimesh's message may quote the file's text (the path may name any file,
        # docs/config.md "Paths"): give only what was expected and the error's kind
        raise GeometryError(
            f"cannot read mesh: not a valid {Path(path).suffix.lstrip('.') or 'mesh'} file "
            f"({type(e).__name__})", file=path, key=key) from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise GeometryError("mesh file holds no triangles", file=path, key=key)
    tri = np.asarray(loaded.triangles, np.float64) * _UNIT_M[units]
    return tri, bool(loaded.is_watertight and loaded.is_winding_consistent and loaded.volume > 0)


def check_triangles(tri: Float[np.ndarray, "t 3 3"], *, key: str, file: Path | None = None) -> None:
    """Refuse NaN or zero-area triangles, naming the first offender."""
    bad = ~np.all(np.isfinite(tri), axis=(1, 2))
    if bad.any():
        i = int(np.argmax(bad))
        raise GeometryError(f"triangle {i} has NaN or infinite coordinates", key=key, file=file)
    _, _, degenerate = triangle_shape(tri)
    if degenerate.any():
        i = int(np.argmax(degenerate))
        raise GeometryError(
            f"triangle {i} has zero area (vertices {tri[i].tolist()}); "
            f"{int(degenerate.sum())} degenerate triangle(s) in all — clean the mesh "
            "(e.g. trimesh's remove_degenerate_faces)",
            key=key,
            file=file,
        )


def place(tri: Float[np.ndarray, "t 3 3"], frame: Frame) -> Float[np.ndarray, "t 3 3"]:
    """Triangles from a group frame into world; a mirroring frame keeps faces facing the same way."""
    out = frame.points(tri)
    return out[:, ::-1] if frame.flips_orientation else out
