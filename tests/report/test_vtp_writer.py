"""patches.vtp is written by numpy (report/_vtk.py), not pyvista: read back by pyvista/VTK's own
XML reader (the independent reference, in the test only) it holds exactly the arrays given."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.report._vtk import triangles_vtp

pv = pytest.importorskip("pyvista")


def _cells(n: int, rng) -> dict[str, np.ndarray]:
    return {
        "radiosity_lm_m2": rng.uniform(0, 500, n),
        "material": rng.integers(0, 7, n).astype(np.int32),
        "radiosity_lm_m2:row 1 <&>": rng.uniform(0, 1, n),  # a network name needing escapes
        'radiosity_lm_m2:the "east"\trow': rng.uniform(0, 1, n),  # a double quote, a tab
        "xyz": rng.uniform(0, 1, (n, 3)),
        "chromaticity_xy": rng.uniform(0, 1, (n, 2)),
    }


@pytest.mark.parametrize("n", [0, 1, 257])
def test_read_back_by_pyvista(tmp_path, n):
    rng = np.random.default_rng(n)
    verts = rng.uniform(-5, 5, (3 * n, 3))
    cells = _cells(n, rng)
    path = tmp_path / "p.vtp"
    path.write_bytes(triangles_vtp(verts, cells))
    mesh = pv.read(path)
    assert mesh.n_cells == n and mesh.n_points == 3 * n
    if n:
        np.testing.assert_array_equal(mesh.points, verts)
        # every cell a triangle of its own three points, in order
        np.testing.assert_array_equal(mesh.faces.reshape(-1, 4),
                                      np.c_[np.full(n, 3), np.arange(3 * n).reshape(-1, 3)])
        for name, a in cells.items():
            got = mesh.cell_data[name]
            assert got.dtype == a.dtype
            np.testing.assert_array_equal(got, a)


def test_same_content_as_pyvistas_writer(tmp_path):
    rng = np.random.default_rng(7)
    n = 40
    verts = rng.uniform(0, 4, (3 * n, 3))
    # VTK's own writer does not escape names: the comparison keeps to plain ones
    cells = {k.split(" ")[0]: v for k, v in _cells(n, rng).items()}
    ref = pv.PolyData(verts, np.c_[np.full(n, 3), np.arange(3 * n).reshape(-1, 3)].ravel())
    for name, a in cells.items():
        ref.cell_data[name] = a
    ref.save(str(tmp_path / "ref.vtp"), binary=True)
    (tmp_path / "ours.vtp").write_bytes(triangles_vtp(verts, cells))
    a, b = pv.read(tmp_path / "ref.vtp"), pv.read(tmp_path / "ours.vtp")
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.faces, b.faces)
    assert list(a.cell_data.keys()) == list(b.cell_data.keys())
    for name in a.cell_data.keys():
        np.testing.assert_array_equal(a.cell_data[name], b.cell_data[name])
