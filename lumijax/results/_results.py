"""Results of a study: illuminance per grid and per network, and the statistics designers read."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from jaxtyping import Float

__all__ = ["GridResult", "Results", "grid_stats", "CRITERIA_SLACK"]

#: How far (relative) a statistic may fall short of a design criterion (a target, a minimum, a
#: maximum, a uniformity) and still meet it: the accuracy a fitted design is held to. The
#: report, the command line and the optimiser all judge with it.
CRITERIA_SLACK = 0.02


def grid_stats(lux: Float[np.ndarray, " points"]) -> dict[str, float]:
    """Average, minimum and maximum illuminance (lx), uniformity U0 = Emin/Eavg and
    diversity Ud = Emin/Emax (EN 12464-1 names). Uniformities are 0 on an unlit grid."""
    lux = np.asarray(lux, np.float64)
    avg, lo, hi = float(lux.mean()), float(lux.min()), float(lux.max())
    return {
        "avg": avg,
        "min": lo,
        "max": hi,
        "u0": lo / avg if avg > 0 else 0.0,
        "ud": lo / hi if hi > 0 else 0.0,
    }


@dataclass(frozen=True, eq=False)
class GridResult:
    """Illuminance on one calculation grid.

    ``by_network_lux[k]`` is network k's illuminance at dimmer 1 (lx); light adds linearly, so
    the illuminance at any dimmer setting α is ``α @ by_network_lux`` exactly.
    """

    name: str
    points: Float[np.ndarray, "points 3"]
    normals: Float[np.ndarray, "points 3"]
    networks: tuple[str, ...]
    by_network_lux: Float[np.ndarray, "net points"]
    dimmers: Float[np.ndarray, " net"]
    shape: tuple[int, int] | None = None
    target_lux: float | None = None
    direct_by_network_lux: Float[np.ndarray, "net points"] | None = None
    xyz_by_network: Float[np.ndarray, "net 3 points"] | None = None

    @property
    def xyz(self) -> Float[np.ndarray, "points 3"] | None:
        """CIE 1931 2° XYZ of the illuminance at the dimmers (Y = ``illuminance_lux``)."""
        if self.xyz_by_network is None:
            return None
        return np.einsum("k,kcp->pc", np.asarray(self.dimmers, np.float64), self.xyz_by_network)

    @property
    def illuminance_lux(self) -> Float[np.ndarray, " points"]:
        """Illuminance at the study's dimmer settings (lx)."""
        return self.at_dimmers(self.dimmers)

    def at_dimmers(self, dimmers) -> Float[np.ndarray, " points"]:
        """Illuminance (lx) at another dimmer vector, by superposition: no recomputation."""
        d = np.asarray(dimmers, np.float64)
        if d.shape != (len(self.networks),):
            raise ValueError(f"expected {len(self.networks)} dimmers, got shape {d.shape}")
        return d @ self.by_network_lux

    def at_dimmers_direct(self, dimmers) -> Float[np.ndarray, " points"]:
        """The direct component alone (lx) at a dimmer vector."""
        direct = self.by_network_lux if self.direct_by_network_lux is None else (
            self.direct_by_network_lux)
        return np.asarray(dimmers, np.float64) @ direct

    @property
    def stats(self) -> dict[str, float]:
        return grid_stats(self.illuminance_lux)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "points": self.points.tolist(),
            "normals": self.normals.tolist(),
            "illuminance_lux": self.illuminance_lux.tolist(),
            "by_network_lux": {
                n: row.tolist() for n, row in zip(self.networks, self.by_network_lux, strict=True)
            },
            "stats": self.stats,
        }
        if self.direct_by_network_lux is not None:
            out["direct_lux"] = self.at_dimmers_direct(self.dimmers).tolist()
        xyz = self.xyz
        if xyz is not None:
            from ..spectral import cct_from_xyz

            out["xyz"] = xyz.tolist()
            out["cct_k"] = np.asarray(cct_from_xyz(xyz)).tolist()
        if self.shape is not None:
            out["shape"] = list(self.shape)
        if self.target_lux is not None:
            out["target_lux"] = self.target_lux
        return out


@dataclass(frozen=True, eq=False)
class Results:
    """Everything a study computed, ready to inspect as arrays or to write (see ``write_results``)."""

    study: str
    grids: dict[str, GridResult]
    networks: dict[str, dict[str, Any]]
    timing_s: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    solver: dict[str, Any] = field(default_factory=dict)
    lighting: Any = field(default=None, repr=False)
    optimisation: Any = field(default=None, repr=False)  # lumijax.optimise.Optimisation

    def __getitem__(self, grid: str) -> GridResult:
        return self.grids[grid]

    def to_dict(self) -> dict[str, Any]:
        from .._version import __version__

        return {
            "study": self.study,
            "lumijax_version": __version__,
            "grids": {name: g.to_dict() for name, g in self.grids.items()},
            "networks": self.networks,
            "timing_s": self.timing_s,
            "counts": self.counts,
            "solver": self.solver,
            **({"optimisation": self.optimisation.to_dict()}
               if self.optimisation is not None else {}),
        }
