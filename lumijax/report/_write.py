"""Write a study's results atomically: results.json, grids/NAME.csv, images/NAME.png.

Everything is first written into a staging folder beside the output folder; only when every
file is complete are they moved into place, each by an atomic rename. A failure half-way leaves
the output folder as it was.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from .._atomic import file_mode
from ..errors import LumijaxError, OutputError
from ..results import Results

__all__ = ["write_results"]


def _spans_an_area(points: np.ndarray) -> bool:
    if len(points) < 3:
        return False
    centred = points - points.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    return bool(sv[1] > 1e-9 * max(sv[0], 1e-300))


def _grid_csv(points: np.ndarray, lux: np.ndarray) -> str:
    rows = np.column_stack([points, lux])
    body = "\n".join(",".join(f"{x:.6g}" for x in r[:3]) + f",{r[3]:.6g}" for r in rows)
    return "x,y,z,lux\n" + body + "\n"


def write_results(results: Results, out_dir: str | Path, *, images: bool = True) -> dict[str, Path]:
    """Write results into ``out_dir`` (created if needed) and return the paths written.

    Files: ``results.json`` (the documented contract, docs/results.md), ``grids/NAME.csv``
    (x, y, z in m; lux), ``patches.vtp`` (the radiosity patches and their light, when
    inter-reflection was computed) and, with ``images``, ``images/NAME.png`` false-colour
    iso-lux maps.
    """
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"cannot create output folder: {e.strerror}", file=out_dir) from None
    if not os.access(out_dir, os.W_OK):
        raise OutputError("output folder is not writable", file=out_dir)
    staging = Path(tempfile.mkdtemp(dir=out_dir, prefix=".staging-"))
    try:
        written: dict[str, Path] = {}
        (staging / "results.json").write_text(
            json.dumps(results.to_dict(), indent=1, allow_nan=False), encoding="utf-8"
        )
        written["results.json"] = Path("results.json")
        if getattr(results, "optimisation", None) is not None:
            # the optimised study, its file paths relative to where it will live
            (staging / "optimised.toml").write_text(
                results.optimisation.config_text(out_dir), encoding="utf-8")
            written["optimised.toml"] = Path("optimised.toml")
        (staging / "grids").mkdir()
        for name, g in results.grids.items():
            (staging / "grids" / f"{name}.csv").write_text(
                _grid_csv(g.points, g.illuminance_lux), encoding="utf-8"
            )
            written[f"grids/{name}.csv"] = Path("grids") / f"{name}.csv"
        if images and results.grids:
            from ._falsecolour import falsecolour_map

            (staging / "images").mkdir()
            for name, g in results.grids.items():
                if not _spans_an_area(g.points):
                    continue  # a map of one point, or of points on a line, shows nothing
                normal = g.normals.mean(axis=0)
                try:
                    falsecolour_map(
                        g.points, g.illuminance_lux, staging / "images" / f"{name}.png",
                        shape=g.shape, normal=normal if np.linalg.norm(normal) > 0 else None,
                        title=f"{results.study} — {name}",
                    )
                except LumijaxError as e:
                    raise OutputError(f"cannot draw the map of grid {name!r}: {e.message}",
                                      file=out_dir) from None
                written[f"images/{name}.png"] = Path("images") / f"{name}.png"
        lighting = results.lighting
        if lighting is not None and lighting.patches is not None:
            from ._vtk import write_patches_vtp

            write_patches_vtp(lighting, results.design.dimmers, staging / "patches.vtp")
            written["patches.vtp"] = Path("patches.vtp")
        final: dict[str, Path] = {}
        mode = file_mode()
        for key, rel in written.items():
            dest = out_dir / rel
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.chmod(staging / rel, mode)  # temp files are private; results are not
            os.replace(staging / rel, dest)
            final[key] = dest
        return final
    except OSError as e:
        raise OutputError(f"cannot write results: {e}", file=out_dir) from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)
