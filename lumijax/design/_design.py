"""The design: what a lighting designer sets and the optimiser fits, in one place.

A :class:`Design` holds every network's dimmer and every photometric luminaire's aim (tilt, pan,
spin, in degrees) and level; nothing else in lumijax keeps its own copy. ``Design.of(scene)``
reads it from a scene, ``scene.with_design(design)`` places it (no config text in between),
``results.design`` is the design the results are lit at and ``results.at(design)`` re-lights
them at another one.

:func:`traverse` is the optimiser's view (in the spirit of Mitsuba 3's ``mi.traverse`` and its
``SceneParameters``): the free variables as one flat vector with their bounds, and the map back
to a Design.

Units: dimmers and levels are factors (1 = as configured: a network at full output, a
luminaire at its config ``multiplier``), aims are degrees in the luminaire's group frame
(docs/conventions.md), as configs and reports speak them. The one conversion to radians is in
the flattened vector (see :class:`DesignParameters`).
"""

from __future__ import annotations

import equinox as eqx
import jax
import numpy as np
from jaxtyping import ArrayLike, Float

from ..errors import ConfigError
from ..scene import Scene

__all__ = ["Design"]


def _host(values, n: int, what: str) -> np.ndarray:
    """A read-only float64 copy on the host, ``n`` long and finite."""
    a = np.array(values, np.float64).reshape(-1)
    if a.shape != (n,):
        raise ConfigError(f"expected {n} values (one per {what.split('.')[0]}), got {a.size}",
                          key=f"design.{what}")
    if not np.all(np.isfinite(a)):
        raise ConfigError(f"expected finite numbers, got {a[~np.isfinite(a)][0]!r}",
                          key=f"design.{what}")
    a.flags.writeable = False
    return a


def _traced(x) -> bool:
    return isinstance(x, jax.Array)


class Design(eqx.Module):
    """Dimmers, aims and levels of one study.

    Attributes
    ----------
    dimmers
        One per network (``networks`` order), a factor in [0, 1] on its output.
    tilt_deg, pan_deg, spin_deg
        One per photometric luminaire (``luminaires`` order, that of ``scene.luminaires``):
        the aim in degrees, in the luminaire's group frame (an ``aim_at`` read as the angles it
        stands for).
    level
        One per luminaire: a factor on its config ``multiplier`` (1 = as configured).
    networks, luminaires
        The names, so that the Design can say which index is which (static: two designs of one
        study share them).

    Built from host values, the leaves are read-only float64 numpy arrays (configs, results
    and reports stay float64 whatever the JAX precision flag); inside a traced function
    (:meth:`DesignParameters.unflatten` under ``jax.jit``) they are JAX arrays.
    """

    dimmers: Float[ArrayLike, " net"]
    tilt_deg: Float[ArrayLike, " lum"]
    pan_deg: Float[ArrayLike, " lum"]
    spin_deg: Float[ArrayLike, " lum"]
    level: Float[ArrayLike, " lum"]
    networks: tuple[str, ...] = eqx.field(static=True)
    luminaires: tuple[str, ...] = eqx.field(static=True)

    def __init__(self, dimmers, tilt_deg, pan_deg, spin_deg, level, *, networks, luminaires):
        self.networks = tuple(networks)
        self.luminaires = tuple(luminaires)
        k, n = len(self.networks), len(self.luminaires)
        leaves = (dimmers, tilt_deg, pan_deg, spin_deg, level)
        if any(_traced(v) for v in leaves):
            self.dimmers, self.tilt_deg, self.pan_deg, self.spin_deg, self.level = leaves
            return
        self.dimmers = _host(dimmers, k, "dimmers")
        self.tilt_deg = _host(tilt_deg, n, "luminaires.tilt_deg")
        self.pan_deg = _host(pan_deg, n, "luminaires.pan_deg")
        self.spin_deg = _host(spin_deg, n, "luminaires.spin_deg")
        self.level = _host(level, n, "luminaires.level")

    @classmethod
    def of(cls, scene: Scene) -> Design:
        """The design a :class:`lumijax.scene.Scene` is placed at."""
        lums = scene.luminaires
        levels = scene.levels
        return cls(
            [nw.dimmer for nw in scene.networks], [lum.tilt for lum in lums],
            [lum.pan for lum in lums], [lum.spin for lum in lums],
            np.ones(len(lums)) if levels is None else levels,
            networks=scene.network_names, luminaires=[lum.name for lum in lums],
        )

    def replace(self, **changes) -> Design:
        """The design with some fields changed: an array, or for ``dimmers`` a
        ``{network: dimmer}`` mapping (the others kept)."""
        d = changes.get("dimmers")
        if isinstance(d, dict):
            unknown = sorted(set(d) - set(self.networks))
            if unknown:
                raise ConfigError(f"no network named {unknown[0]!r}; networks: "
                                  f"{', '.join(self.networks)}", key="design.dimmers")
            changes["dimmers"] = [d.get(n, v) for n, v in zip(self.networks, self.dimmers,
                                                               strict=True)]
        fields = {"dimmers": self.dimmers, "tilt_deg": self.tilt_deg, "pan_deg": self.pan_deg,
                  "spin_deg": self.spin_deg, "level": self.level}
        unknown = sorted(set(changes) - set(fields))
        if unknown:
            raise ConfigError(f"a Design has no field {unknown[0]!r}; fields: "
                              f"{', '.join(fields)}", key="design")
        fields.update(changes)
        return Design(**fields, networks=self.networks, luminaires=self.luminaires)

    def dimmer_of(self) -> dict[str, float]:
        """``{network: dimmer}``."""
        return {n: float(v) for n, v in zip(self.networks, self.dimmers, strict=True)}

    def aim_of(self, luminaire: str) -> dict[str, float]:
        """``{"tilt", "pan", "spin"}`` of one luminaire, in degrees (group frame)."""
        i = self.luminaires.index(luminaire)
        return {"tilt": float(self.tilt_deg[i]), "pan": float(self.pan_deg[i]),
                "spin": float(self.spin_deg[i])}

    def level_of(self, luminaire: str) -> float:
        return float(self.level[self.luminaires.index(luminaire)])

    def same_study(self, other: Design) -> bool:
        """Whether ``other`` names the same networks and luminaires in the same order."""
        return self.networks == other.networks and self.luminaires == other.luminaires

    def only_dimmers_differ(self, other: Design) -> bool:
        """Whether ``other`` has the same aims and levels (exactly): then light at ``other``
        is the superposition of the per-network light at dimmer 1, no recomputation."""
        return self.same_study(other) and all(
            np.array_equal(np.asarray(a), np.asarray(b))
            for a, b in ((self.tilt_deg, other.tilt_deg), (self.pan_deg, other.pan_deg),
                         (self.spin_deg, other.spin_deg), (self.level, other.level)))
