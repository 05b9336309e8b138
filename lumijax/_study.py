"""The study: the Python API that the command line is a thin layer over.

``load_study`` reads and validates a config and builds its scene; ``compute`` lights it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .config import StudyConfig, load_config
from .direct import direct_illuminance
from .results import GridResult, Results
from .scene import Scene, build_scene

__all__ = ["Study", "load_study", "compute"]


@dataclass(frozen=True, eq=False)
class Study:
    """A validated config and the scene built from it."""

    config: StudyConfig
    scene: Scene
    load_s: float = 0.0

    @property
    def name(self) -> str:
        return self.scene.name

    def summary(self) -> dict:
        """What the study holds: counts, and each photometry's rated and integrated flux (lm)."""
        sc = self.scene
        return {
            "study": sc.name,
            "triangles": len(sc.triangles),
            "luminaires": len(sc.luminaires) + len(sc.area_sources),
            "networks": len(sc.networks),
            "grid_points": int(sum(len(g) for g in sc.grids)),
            "photometry": {
                name: {"rated_lm": p.rated_lm, "integrated_lm": float(p.integrated_lm)}
                for name, p in sc.photometries.items()
            },
        }


def load_study(path: str | Path) -> Study:
    """Load a TOML study config and build its scene.

    Raises :class:`lumijax.LumijaxError` (a ``ConfigError``, ``PhotometryError``,
    ``SpectrumError`` or ``GeometryError``) naming the file and key of any problem.
    """
    t0 = time.perf_counter()
    cfg = load_config(path)
    scene = build_scene(cfg)
    return Study(cfg, scene, load_s=time.perf_counter() - t0)


def compute(
    study: Study,
    *,
    shadows: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> Results:
    """Light the study: illuminance on every grid, per network, at the config's dimmers.

    This first version computes direct light (with shadows, extended and area sources);
    inter-reflected light is added by the radiosity solve.
    """
    sc = study.scene
    t0 = time.perf_counter()
    grids = sc.grids
    if grids:
        points = np.concatenate([g.points for g in grids])
        normals = np.concatenate([g.normals for g in grids])
    else:
        points = normals = np.zeros((0, 3))
    direct = direct_illuminance(sc, points, normals, shadows=shadows, progress=progress)
    t1 = time.perf_counter()
    names = sc.network_names
    dimmers = sc.dimmers
    out: dict[str, GridResult] = {}
    start = 0
    for g in grids:
        sl = slice(start, start + len(g))
        start += len(g)
        out[g.name] = GridResult(
            name=g.name, points=g.points, normals=g.normals, networks=names,
            by_network_lux=direct.by_network[:, sl], dimmers=dimmers, shape=g.shape,
            target_lux=g.target_lux,
        )
    flux = sc.network_flux_lm()
    networks = {
        n.name: {
            "dimmer": n.dimmer,
            "luminaires": [lum.name for lum in sc.luminaires if lum.network == n.name]
            + [a.name for a in sc.area_sources if a.network == n.name],
            "flux_lm": flux[n.name],
        }
        for n in sc.networks
    }
    timing = {
        "load": study.load_s,
        "direct": t1 - t0,
        "direct_kernel": direct.timing_s.get("kernel", 0.0),
        "shadow_rays": direct.timing_s.get("shadow_rays", 0.0),
    }
    return Results(
        study=sc.name, grids=out, networks=networks, timing_s=timing,
        counts={"shadow_rays": direct.shadow_rays, "grid_points": int(len(points))},
    )
