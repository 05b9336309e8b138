"""Patch results as a VTK PolyData file (``.vtp``), for ParaView and pyvista."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._atomic import atomic_path

__all__ = ["write_patches_vtp"]


def write_patches_vtp(lighting, dimmers, path: str | Path) -> Path:
    """Write the radiosity patches with their light as cell data.

    Cell arrays: ``radiosity_lm_m2`` (exitance B at the dimmers), ``luminance_cd_m2`` (B/π),
    ``illuminance_lux`` (irradiance on the patch, direct plus inter-reflected),
    ``direct_lux``, ``reflectance``, ``material`` (index into the study's materials) and, per
    network at dimmer 1, ``radiosity_lm_m2:NETWORK``. After a spectral solve also ``xyz``
    (CIE 1931 XYZ of the radiosity, Y = ``radiosity_lm_m2``), ``chromaticity_xy`` and ``srgb``
    (display colour, exposed so the 99th percentile of Y is white).
    """
    import pyvista as pv

    p = lighting.display.patches  # the fine patches of a two-level solve
    verts = p.vertices.reshape(-1, 3)
    faces = np.hstack([np.full((p.n, 1), 3), np.arange(3 * p.n).reshape(-1, 3)]).ravel()
    mesh = pv.PolyData(verts, faces)
    d = np.asarray(dimmers, np.float64)
    b = lighting.display_radiosity_at(d)
    mesh.cell_data["radiosity_lm_m2"] = b
    mesh.cell_data["luminance_cd_m2"] = b / np.pi
    mesh.cell_data["illuminance_lux"] = d @ lighting.display_patch_illuminance()
    mesh.cell_data["direct_lux"] = d @ lighting.display.patch_direct
    mesh.cell_data["reflectance"] = lighting.display_rho
    mesh.cell_data["material"] = np.asarray(p.material, np.int32)
    for name, row in zip(lighting.scene.network_names, lighting.display.radiosity, strict=True):
        mesh.cell_data[f"radiosity_lm_m2:{name}"] = row
    if lighting.display.radiosity_xyz is not None:
        from ..spectral import xyz_to_chromaticity, xyz_to_srgb

        xyz = np.einsum("k,kcp->pc", d, lighting.display.radiosity_xyz)
        mesh.cell_data["xyz"] = xyz
        mesh.cell_data["chromaticity_xy"] = xyz_to_chromaticity(xyz)
        # display colour of the surfaces' own colour: luminance-normalised, so that an image
        # shows hue and saturation; exposure and tone mapping belong to the renderer
        peak = float(np.percentile(xyz[:, 1], 99)) if len(xyz) else 1.0
        mesh.cell_data["srgb"] = xyz_to_srgb(xyz / max(peak, 1e-300))
    with atomic_path(path, what="patch file", suffix=".vtp") as tmp:
        mesh.save(str(tmp), binary=True)
    return Path(path)
