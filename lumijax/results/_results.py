"""Results of a study: illuminance per grid and per network, and the statistics designers read."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # shapes for the reader and mypy; importing jaxtyping is 38 ms of a rerun
    from jaxtyping import Float

__all__ = ["GridResult", "Results", "grid_stats", "CRITERIA_SLACK"]

#: How far (relative) a statistic may fall short of a design criterion (a target, a minimum, a
#: maximum, a uniformity) and still meet it: the accuracy a fitted design is held to. The
#: report, the command line and the optimiser all judge with it.
CRITERIA_SLACK = 0.02


def _finite_json(value, key: str):
    """``value`` unchanged when every number in it is finite, else a SolveError naming ``key``:
    results.json never holds NaN or Infinity (docs/results.md), and a non-finite number there
    means the computation overflowed, which no null could honestly stand for."""
    if isinstance(value, dict):
        for k, v in value.items():
            _finite_json(v, f"{key}.{k}")
    elif isinstance(value, list | tuple):
        arr = np.asarray(value, dtype=object if not value or not _flat(value) else np.float64)
        if arr.dtype == object:
            for i, v in enumerate(value):
                _finite_json(v, f"{key}[{i}]")
        else:
            _check_array(arr, key)
    elif isinstance(value, float | np.floating) and not np.isfinite(value):
        _check_array(np.asarray([value], np.float64), key)
    return value


def _flat(values) -> bool:
    return all(isinstance(v, int | float | np.number) and not isinstance(v, bool) for v in values)


def _check_array(arr: np.ndarray, key: str) -> None:
    bad = ~np.isfinite(np.asarray(arr, np.float64))
    if bad.any():
        from ..errors import SolveError

        first = np.unravel_index(int(np.argmax(bad)), bad.shape)
        raise SolveError(
            f"{int(bad.sum())} of {bad.size} values are not finite (the first, at index "
            f"{list(map(int, first))}, is {float(np.asarray(arr, np.float64)[first])}): the "
            "computation overflowed; check the study's magnitudes (flux_lm, multiplier, targets)",
            key=f"results.json: {key}")


def grid_stats(lux: Float[np.ndarray, " points"]) -> dict[str, float]:
    """Average, minimum and maximum illuminance (lx), uniformity U0 = Emin/Eavg and
    diversity Ud = Emin/Emax. U0 is EN 12464-1's uniformity; Ud is a diversity from other
    codes (the SLL Code for Lighting; EN 12193's U1), not EN 12464-1's. Uniformities are 0 on
    an unlit grid."""
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
    the illuminance at any dimmer setting α is ``α @ by_network_lux`` exactly. Inside
    :class:`Results`, ``dimmers`` is a read-only view of the results' ``design.dimmers``
    (the one copy), never a dimmer vector of its own.
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
        """The grid's entry of results.json; a SolveError names any non-finite array."""
        for name, arr in (("points", self.points), ("by_network_lux", self.by_network_lux),
                          ("direct_lux", self.direct_by_network_lux),
                          ("xyz", self.xyz_by_network)):
            if arr is not None:
                _check_array(arr, f"grids.{self.name}.{name}")
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
            cct = np.asarray(cct_from_xyz(xyz))
            _check_array(cct, f"grids.{self.name}.cct_k")
            out["cct_k"] = cct.tolist()
        if self.shape is not None:
            out["shape"] = list(self.shape)
        if self.target_lux is not None:
            out["target_lux"] = self.target_lux
        return out


@dataclass(frozen=True, eq=False)
class Results:
    """Everything a study computed, ready to inspect as arrays or to write (see ``write_results``).

    ``design`` (a :class:`lumijax.design.Design`) is the one record of the dimmers, aims and
    levels the results are lit at: every grid's ``dimmers`` and every ``networks[n]["dimmer"]``
    are read from it when the results are made, and the report, the viewer and the writers
    read it. ``at(design)`` gives the results at another design.
    """

    study: str
    grids: dict[str, GridResult]
    networks: dict[str, dict[str, Any]]
    timing_s: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    solver: dict[str, Any] = field(default_factory=dict)
    lighting: Any = field(default=None, repr=False)
    optimisation: Any = field(default=None, repr=False)  # lumijax.optimise.Optimisation
    design: Any = field(default=None, repr=False)  # lumijax.design.Design
    #: ``recompute(design, override_cache_dir=None) -> Results``: the study computed again at a
    #: design, with the options these results were computed with (set by ``lumijax.compute``).
    recompute: Callable[..., Results] | None = field(default=None, repr=False)
    #: The observers' glare (a ``lumijax.glare.Glare``, typed loosely: results sit below glare),
    #: or None without ``[[observers]]``; ``at`` re-evaluates it at the new design.
    glare: Any = field(default=None, repr=False)
    #: The verdict per standard (a ``lumijax.compliance.Compliance``; docs/compliance.md).
    compliance: Any = field(default=None, repr=False)

    def __post_init__(self) -> None:
        design = self.design
        if design is None:  # made by hand: the dimmers the networks were given, no luminaires
            from ..design import Design

            design = Design([v["dimmer"] for v in self.networks.values()], [], [], [], [],
                            networks=tuple(self.networks), luminaires=())
            object.__setattr__(self, "design", design)
        if tuple(self.networks) != design.networks:
            from ..errors import LumijaxError

            raise LumijaxError(f"expected a design of the results' networks "
                               f"{list(self.networks)}, got one of {list(design.networks)}",
                               key="design.networks")
        dimmers = np.asarray(design.dimmers)
        object.__setattr__(self, "grids", {
            n: g if g.dimmers is dimmers else dataclasses.replace(g, dimmers=dimmers)
            for n, g in self.grids.items()})
        object.__setattr__(self, "networks", {
            n: {"dimmer": float(d), **{k: v for k, v in info.items() if k != "dimmer"}}
            for (n, info), d in zip(self.networks.items(), dimmers, strict=True)})

    def at(self, design, *, cache_dir=None) -> Results:
        """The results at another design of the same study.

        Where only dimmers differ this is the exact superposition of the per-network light at
        dimmer 1 (no solve, no ray; the lighting solution's scene is placed at ``design`` too).
        A design that re-aims or re-levels a luminaire is computed again in full
        (``lumijax.compute(study, design=design)``, with these results' options; the transport
        operator comes from the cache when one is kept, or from ``cache_dir``). The
        optimisation record, which described the old design, is not carried over.
        """
        from ..errors import LumijaxError

        if not self.design.same_study(design):
            raise LumijaxError("the design names other networks or luminaires than these "
                               f"results (networks: {', '.join(self.design.networks)})",
                               key="design")
        if self.design.only_dimmers_differ(design):
            lighting = self.lighting
            if lighting is not None:
                lighting = dataclasses.replace(lighting,
                                               scene=lighting.scene.with_design(design))
            return dataclasses.replace(self, design=design, lighting=lighting,
                                       optimisation=None,
                                       glare=None if self.glare is None else
                                       self.glare.at(design),
                                       compliance=None if self.compliance is None else
                                       self.compliance.at(design.dimmers))
        if self.recompute is None:
            raise LumijaxError("these results cannot be lit at a design that re-aims or "
                               "re-levels a luminaire: they were not made by lumijax.compute, "
                               "which keeps the study to compute again", key="design")
        return self.recompute(design, override_cache_dir=cache_dir)

    def __getitem__(self, grid: str) -> GridResult:
        return self.grids[grid]

    def to_dict(self) -> dict[str, Any]:
        from .._version import __version__

        return {
            "study": self.study,
            "lumijax_version": __version__,
            "grids": {name: g.to_dict() for name, g in self.grids.items()},
            "networks": _finite_json(self.networks, "networks"),
            "timing_s": self.timing_s,
            "counts": self.counts,
            "solver": _finite_json(self.solver, "solver"),
            **({"optimisation": _finite_json(self.optimisation.to_dict(), "optimisation")}
               if self.optimisation is not None else {}),
            **({"glare": self.glare.to_dict()} if self.glare is not None else {}),
            **({"compliance": _finite_json(self.compliance.to_dict(), "compliance")}
               if self.compliance is not None else {}),
        }
