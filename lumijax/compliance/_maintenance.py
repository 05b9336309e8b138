"""Maintenance factors (CIE 97:2005): ``MF = LLMF × LSF × LMF × RSMF``, per network, with the
luminaire maintenance factor looked up from the luminaire type, the environment and the
cleaning interval, or every factor given directly.

Maintained values are ``MF_k × initial_k`` per network k: light adds per network, so the
maintained light at any dimmers is the superposition of the networks scaled by their MF.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["LMF_TABLE", "LMF_YEARS", "luminaire_maintenance_factor", "maintenance_factor",
           "network_maintenance"]

#: Cleaning intervals (years) of the LMF table's columns.
LMF_YEARS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
#: CIE 97:2005, the luminaire maintenance factor table (luminaire types A–F: A open batten,
#: B open top reflector, C closed top reflector, D enclosed IP2X, E dustproof IP5X, F indirect
#: uplighter), per environment (very clean, clean, normal, dirty), at each interval above.
LMF_TABLE = {
    "A": ((.98, .96, .93, .89), (.97, .93, .89, .83), (.95, .91, .85, .78),
          (.94, .89, .82, .74), (.93, .87, .79, .70), (.92, .85, .76, .68)),
    "B": ((.98, .95, .92, .88), (.96, .91, .87, .82), (.94, .89, .84, .77),
          (.92, .87, .80, .73), (.91, .85, .78, .69), (.90, .83, .75, .65)),
    "C": ((.97, .93, .89, .83), (.94, .89, .81, .72), (.91, .84, .74, .63),
          (.89, .80, .69, .59), (.87, .77, .64, .54), (.84, .74, .61, .52)),
    "D": ((.96, .92, .87, .83), (.93, .87, .80, .73), (.90, .83, .74, .66),
          (.88, .79, .69, .60), (.85, .76, .65, .55), (.83, .73, .61, .51)),
    "E": ((.98, .96, .93, .91), (.96, .94, .90, .86), (.95, .92, .88, .83),
          (.94, .90, .86, .81), (.93, .89, .84, .78), (.92, .88, .82, .75)),
    "F": ((.97, .92, .89, .85), (.93, .86, .81, .74), (.89, .81, .73, .65),
          (.85, .77, .66, .57), (.82, .73, .60, .51), (.79, .70, .55, .45)),
}
_ENV = ("very clean", "clean", "normal", "dirty")


def luminaire_maintenance_factor(luminaire_type: str, environment: str, years: float) -> float:
    """LMF of the table, linear in the cleaning interval between its columns (1 at 0 years:
    a luminaire cleaned continuously keeps its output)."""
    col = _ENV.index(environment)
    ys = (0.0, *LMF_YEARS)
    vals = (1.0, *(row[col] for row in LMF_TABLE[luminaire_type]))
    return float(np.interp(years, ys, vals))


def maintenance_factor(f) -> float:
    """MF of one :class:`lumijax.config._compliance.MaintenanceFactors`."""
    if f.mf is not None:
        return float(f.mf)
    lmf = f.lmf if f.lmf is not None else (
        luminaire_maintenance_factor(f.luminaire_type, f.environment,
                                     f.cleaning_interval_years)
        if f.luminaire_type is not None else 1.0)
    return float(f.llmf * f.lsf * lmf * f.rsmf)


def network_maintenance(cfg, networks: tuple[str, ...], src=None) -> np.ndarray:
    """MF per network (1 without ``[compliance.maintenance]``)."""
    if cfg is None:
        return np.ones(len(networks))
    for name in cfg.networks:
        if name not in networks:
            raise ConfigError(f"unknown network {name!r}; networks: {', '.join(networks)}",
                              file=src, key=f"compliance.maintenance.networks.{name}")
    base = maintenance_factor(cfg)
    return np.array([maintenance_factor(cfg.networks[n]) if n in cfg.networks else base
                     for n in networks])
