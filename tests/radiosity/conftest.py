"""Small meshes for the radiosity tests (shared per module: building is the slow part)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from lumijax.radiosity import build_operator, mesh_patches, partition


def quad(o, u, v) -> np.ndarray:
    """Two triangles of the parallelogram o, o+u, o+u+v, o+v; front normal along u × v."""
    o, u, v = (np.asarray(x, float) for x in (o, u, v))
    return np.array([[o, o + u, o + u + v], [o, o + u + v, o + v]])


def opposed_rectangles(x: float, y: float) -> float:
    """The factor between two directly opposed, equal parallel rectangles a × b, c apart, with
    X = a/c and Y = b/c (Howell's catalogue; ../shared/reference/form-factors.md §3, whose §8
    gives 0.1998248957 at X = Y = 1)."""
    return 2 / (np.pi * x * y) * (
        np.log(np.sqrt((1 + x * x) * (1 + y * y) / (1 + x * x + y * y)))
        + x * np.sqrt(1 + y * y) * np.arctan(x / np.sqrt(1 + y * y))
        + y * np.sqrt(1 + x * x) * np.arctan(y / np.sqrt(1 + x * x))
        - x * np.arctan(x) - y * np.arctan(y))


def disk(centre, radius, up: bool, sides: int = 96) -> np.ndarray:
    """A triangle fan approximating a disk in a horizontal plane, facing +z if ``up``."""
    c = np.asarray(centre, float)
    t = np.linspace(0, 2 * np.pi, sides + 1)
    # Scale the radius so the polygon has the disk's exact area.
    r = radius * np.sqrt(2 * np.pi / (sides * np.sin(2 * np.pi / sides)))
    rim = c + r * np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], 1)
    tris = np.stack([np.broadcast_to(c, rim[:-1].shape), rim[:-1], rim[1:]], 1)
    return tris if up else tris[:, ::-1]


def surface_factor(t1, t2, patch_size):
    """Area-weighted F from surface 1 to surface 2 and back, and the operator."""
    tri = np.concatenate([t1, t2])
    grp = np.r_[np.zeros(len(t1), int), np.ones(len(t2), int)]
    p = mesh_patches(tri, group=grp, patch_size=patch_size)
    op = build_operator(p, partition(p, 1024), None)
    f = op.todense()
    m1, m2 = p.group == 0, p.group == 1
    a = p.area
    f12 = (a[m1, None] * f[np.ix_(m1, m2)]).sum() / a[m1].sum()
    f21 = (a[m2, None] * f[np.ix_(m2, m1)]).sum() / a[m2].sum()
    return f12, f21, a[m1].sum(), a[m2].sum(), op


def facing_squares():
    """Two facing 1 m squares 0.5 m apart (patches of 0.25 m) and their operator: a small open
    scene with real form factors."""
    tri = np.concatenate([quad([0, 0, 0], [1, 0, 0], [0, 1, 0]),
                          quad([0, 0, 0.5], [0, 1, 0], [1, 0, 0])])
    p = mesh_patches(tri, group=np.r_[0, 0, 1, 1], patch_size=0.25)
    return p, build_operator(p, partition(p, 1024), None)


def room(mesh: trimesh.Trimesh, patch_size: float, max_block: int = 512):
    mesh = mesh.copy()
    mesh.invert()  # inward-facing: a room seen from inside
    tri = mesh.triangles
    p = mesh_patches(tri, patch_size=patch_size)
    part = partition(p, max_block, occluders=tri)
    return p, part, build_operator(p, part, tri)


@pytest.fixture(scope="module")
def cube_room():
    return room(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), 0.15)


@pytest.fixture(scope="module")
def sphere_room():
    return room(trimesh.creation.icosphere(subdivisions=3, radius=1.0), 1.0)
