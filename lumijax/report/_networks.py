"""Each network alone: what it lights, at dimmer 1 and at the design's dimmer.

Light adds over networks (``E = Σ_k α_k E_k``), so one network's own light on a grid is its row
of ``by_network_lux`` (lx at dimmer 1) times its dimmer; its share of a grid is its part of
the grid's average at the design's dimmers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._study import Study
from ..results import Results

__all__ = ["NetworkGridLight", "NetworkPage", "network_pages"]


@dataclass(frozen=True)
class NetworkGridLight:
    """One network's light on one grid (lx)."""

    grid: str
    avg_full: float  # Eavg at dimmer 1
    max_full: float  # Emax at dimmer 1
    avg: float  # Eavg at the design's dimmer
    max: float
    share: float  # of the grid's Eavg at the design's dimmers, in [0, 1]


@dataclass(frozen=True)
class NetworkPage:
    """A network alone: its luminaires, dimmer, flux (lm) and the grids it lights."""

    name: str
    description: str
    dimmer: float
    luminaires: tuple[str, ...]
    photometries: tuple[str, ...]
    flux_full_lm: float
    lit: tuple[NetworkGridLight, ...]  # grids it lights (Emax at dimmer 1 > 0)
    unlit: tuple[str, ...]  # grids it does not reach


def network_pages(study: Study, results: Results) -> list[NetworkPage]:
    """One :class:`NetworkPage` per network, in the results' order."""
    dimmers = np.asarray(results.design.dimmers, np.float64)
    descriptions = {n.name: n.description for n in study.scene.networks}
    pages = []
    for k, (name, info) in enumerate(results.networks.items()):
        lit, unlit = [], []
        for gname, g in results.grids.items():
            mine = np.asarray(g.by_network_lux[k], np.float64)
            if not np.any(mine > 0):
                unlit.append(gname)
                continue
            total = float(np.mean(dimmers @ np.asarray(g.by_network_lux, np.float64)))
            avg_full = float(mine.mean())
            lit.append(NetworkGridLight(
                grid=gname, avg_full=avg_full, max_full=float(mine.max()),
                avg=avg_full * dimmers[k], max=float(mine.max()) * dimmers[k],
                share=avg_full * dimmers[k] / total if total > 0 else 0.0))
        used = [lum for lum in study.scene.luminaires if lum.network == name]
        areas = [a.name for a in study.scene.area_sources if a.network == name]
        pages.append(NetworkPage(
            name=name, description=descriptions.get(name, ""), dimmer=float(dimmers[k]),
            luminaires=tuple(lum.name for lum in used) + tuple(areas),
            photometries=tuple(dict.fromkeys(lum.photometry for lum in used)),
            flux_full_lm=float(info["flux_lm"]), lit=tuple(lit), unlit=tuple(unlit)))
    return pages
