"""Patch results as a VTK PolyData file (``.vtp``), for ParaView and pyvista.

The file is VTK's XML PolyData format (vtk.org, "VTK File Formats": ``<VTKFile
type="PolyData">``, inline base64 ``binary`` arrays, zlib-compressed in one block each behind a
UInt64 block header, as pyvista writes them) written by numpy, so writing results does not import pyvista/VTK (≈10 s per process).
"""

from __future__ import annotations

import base64
import zlib
from html import escape
from pathlib import Path

import numpy as np

from .._atomic import atomic_path

__all__ = ["write_patches_vtp", "patch_arrays", "patch_bytes", "write_stored_patches_vtp",
           "triangles_vtp"]

#: zlib level of the arrays: the cube ρ 0.2's 13 arrays (380 kB) took 10.8 ms at 6, 4.3 at 3
#: and 3.1 at 1, for 105, 110 and 113 kB (session 23): float data barely compresses further,
#: and a dimmer-only rerun writes the file again.
_ZLIB_LEVEL = 1


def write_patches_vtp(lighting, dimmers, path: str | Path, illuminance=None) -> Path:
    """Write the radiosity patches with their light as cell data.

    Cell arrays: ``radiosity_lm_m2`` (exitance B at the dimmers), ``luminance_cd_m2`` (B/π),
    ``illuminance_lux`` (irradiance on the patch, direct plus inter-reflected),
    ``direct_lux``, ``reflectance``, ``material`` (index into the study's materials) and, per
    network at dimmer 1, ``radiosity_lm_m2:NETWORK``. After a spectral solve also ``xyz``
    (CIE 1931 XYZ of the radiosity, Y = ``radiosity_lm_m2``), ``chromaticity_xy`` and ``srgb``
    (display colour, exposed so the 99th percentile of Y is white). ``illuminance``: the
    patches' irradiance at ``dimmers`` (lx) when the caller has it already
    (``lighting.display_patch_illuminance_at(dimmers)``, figured while it drew).
    """
    d = np.asarray(dimmers, np.float64)
    arrays = patch_arrays(lighting, per_network_illuminance=False)
    if illuminance is None:
        illuminance = lighting.display_patch_illuminance_at(d)
    return _write(arrays, d, illuminance, path)


def patch_arrays(lighting, *, per_network_illuminance: bool = True) -> dict[str, np.ndarray]:
    """What patches.vtp is made of, none of it at a dimmer: ``vertices`` (3n, 3) m,
    ``radiosity`` (net, n) lm/m² and ``direct`` (net, n) lx at dimmer 1, ``reflectance``,
    ``material``, ``networks`` (names), ``xyz`` (net, 3, n) after a spectral solve and, with
    ``per_network_illuminance``, ``illuminance`` (net, n) lx: each network's irradiance at
    dimmer 1, from one operator product per network (the shape of the product at the dimmers,
    so nothing new compiles). A dimmer-only rerun (``lumijax._stored``) writes the file from
    these with :func:`write_stored_patches_vtp`, with no JAX."""
    p = lighting.display.patches  # the fine patches of a two-level solve
    k = len(lighting.scene.network_names)
    arrays = {
        "vertices": np.asarray(p.vertices).reshape(-1, 3),
        "radiosity": np.asarray(lighting.display.radiosity).reshape(k, -1),
        "direct": np.asarray(lighting.display.patch_direct).reshape(k, -1),
        "reflectance": np.asarray(lighting.display_rho),
        "material": np.asarray(p.material, np.int32),
        "networks": np.asarray(lighting.scene.network_names, dtype=str),
    }
    if lighting.display.radiosity_xyz is not None:
        arrays["xyz"] = np.asarray(lighting.display.radiosity_xyz)
    if per_network_illuminance:
        rows = [np.asarray(lighting.display_patch_illuminance_at(e)) for e in np.eye(k)]
        arrays["illuminance"] = np.stack(rows) if rows else np.zeros((0, p.n))
    return arrays


def patch_bytes(lighting) -> int:
    """The bytes :func:`patch_arrays` takes, found without its operator products."""
    arrays = patch_arrays(lighting, per_network_illuminance=False)
    k, n = arrays["radiosity"].shape
    return sum(a.nbytes for a in arrays.values()) + 8 * k * n


def write_stored_patches_vtp(arrays: dict[str, np.ndarray], dimmers,
                             path: str | Path) -> Path:
    """Write patches.vtp from :func:`patch_arrays` (with its ``illuminance``) at ``dimmers``:
    every cell array is a superposition of the per-network arrays, the irradiance included."""
    d = np.asarray(dimmers, np.float64)
    return _write(arrays, d, d @ arrays["illuminance"], path)


def _write(arrays: dict[str, np.ndarray], d: np.ndarray, illuminance: np.ndarray,
           path: str | Path) -> Path:
    cells: dict[str, np.ndarray] = {}
    b = d @ arrays["radiosity"]
    cells["radiosity_lm_m2"] = b
    cells["luminance_cd_m2"] = b / np.pi
    cells["illuminance_lux"] = illuminance
    cells["direct_lux"] = d @ arrays["direct"]
    cells["reflectance"] = arrays["reflectance"]
    cells["material"] = arrays["material"]
    for name, row in zip(arrays["networks"], arrays["radiosity"], strict=True):
        cells[f"radiosity_lm_m2:{name}"] = row
    if "xyz" in arrays:
        from ..spectral import xyz_to_chromaticity, xyz_to_srgb

        xyz = np.einsum("k,kcp->pc", d, arrays["xyz"])
        cells["xyz"] = xyz
        cells["chromaticity_xy"] = xyz_to_chromaticity(xyz)
        # display colour of the surfaces' own colour: luminance-normalised, so that an image
        # shows hue and saturation; exposure and tone mapping belong to the renderer
        # a sample's Y ('higher'): numpy's interpolating default imports numpy.ma, 25 ms of
        # a dimmer-only rerun's 0.3 s
        peak = float(np.percentile(xyz[:, 1], 99, method="higher")) if len(xyz) else 1.0
        cells["srgb"] = xyz_to_srgb(xyz / max(peak, 1e-300))
    text = triangles_vtp(arrays["vertices"], cells)
    with atomic_path(path, what="patch file", suffix=".vtp") as tmp:
        Path(tmp).write_bytes(text)
    return Path(path)


#: numpy dtype → VTK XML type name
_VTK_TYPES = {"f8": "Float64", "f4": "Float32", "i8": "Int64", "i4": "Int32", "u1": "UInt8"}


def _data_array(name: str, a: np.ndarray) -> bytes:
    a = np.ascontiguousarray(a)
    key = a.dtype.str.lstrip("<>|=")
    if key not in _VTK_TYPES:  # bool or other: widen to a type every VTK reader knows
        a = a.astype(np.float64 if a.dtype.kind == "f" else np.int64)
        key = a.dtype.str.lstrip("<>|=")
    a = a.astype(a.dtype.newbyteorder("<"), copy=False)
    comps = 1 if a.ndim == 1 else int(np.prod(a.shape[1:]))
    raw = a.tobytes()
    # one zlib block: header [blocks, block size, last block size, compressed size], base64'd
    # apart from the data as VTK's reader expects
    packed = zlib.compress(raw, _ZLIB_LEVEL)
    head = [1, len(raw), len(raw), len(packed)] if raw else [0, 0, 0]
    payload = (base64.b64encode(np.asarray(head, "<u8").tobytes())
               + base64.b64encode(packed if raw else b""))
    nc = f' NumberOfComponents="{comps}"' if comps != 1 else ""
    return (f'<DataArray type="{_VTK_TYPES[key]}" Name="{name}"{nc} format="binary">'
            .encode() + payload + b"</DataArray>\n")


def triangles_vtp(vertices: np.ndarray, cell_data: dict[str, np.ndarray]) -> bytes:
    """A VTK XML PolyData document of independent triangles (``vertices`` (3n, 3), m; three per
    triangle) with ``cell_data`` arrays (first axis n), little-endian, zlib-compressed."""
    v = np.asarray(vertices)
    n = len(v) // 3
    head = (b'<?xml version="1.0"?>\n<VTKFile type="PolyData" version="1.0" '
            b'byte_order="LittleEndian" header_type="UInt64" '
            b'compressor="vtkZLibDataCompressor">\n<PolyData>\n'
            + f'<Piece NumberOfPoints="{len(v)}" NumberOfVerts="0" NumberOfLines="0" '
              f'NumberOfStrips="0" NumberOfPolys="{n}">\n'.encode())
    parts = [head, b"<Points>\n", _data_array("Points", v), b"</Points>\n"]
    parts += [b"<Polys>\n", _data_array("connectivity", np.arange(3 * n, dtype=np.int64)),
              _data_array("offsets", 3 * np.arange(1, n + 1, dtype=np.int64)), b"</Polys>\n"]
    parts.append(b"<CellData>\n")
    for name, a in cell_data.items():
        parts.append(_data_array(_attribute(name), np.asarray(a)))
    parts.append(b"</CellData>\n</Piece>\n</PolyData>\n</VTKFile>\n")
    return b"".join(parts)


def _attribute(text: str) -> str:
    """``text`` inside a double-quoted XML attribute: markup and both quotes escaped, and the
    whitespace an XML reader would fold to spaces kept as character references.
    (``xml.sax.saxutils.quoteattr`` picks single quotes for a name holding a double one, and
    imports urllib: 20 ms of a rerun.)"""
    return escape(text, quote=True).replace("\n", "&#10;").replace("\r", "&#13;").replace(
        "\t", "&#9;")
