"""Energy: each network's input power against its dimmer, W/m² per area, and the lighting
energy numeric indicator LENI (EN 15193-1).

Input watts per luminaire come from ``[compliance.energy] watts`` (by photometry) or else the
photometry file (IES LM-63 input watts, EULUMDAT wattage of the first lamp set); a network's
``power_w`` replaces the sum. A network's power at dimmer α is ``S + (P₁ − S)·c(α)`` with P₁ its
power at dimmer 1, S its luminaires' standby power and ``c`` the dimming curve (``α``, or the
table's fractions interpolated linearly).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..errors import ConfigError

__all__ = ["PowerModel", "power_model", "leni_kwh_per_m2", "HOURS_PER_YEAR"]

HOURS_PER_YEAR = 8760.0


class PowerModel(eqx.Module):
    """Input power (W) of each network against its dimmer."""

    full_w: Float[Array, " net"]
    standby_w: Float[Array, " net"]
    levels: tuple  # per network: None (linear) or the table's dimmer levels
    fractions: tuple
    missing: tuple = eqx.field(static=True, default=())  # luminaires without input watts

    def network_w(self, dimmers: Float[Array, " net"]) -> Float[Array, " net"]:
        """Power (W) of each network at ``dimmers``."""
        d = jnp.asarray(dimmers)
        curve = [d[k] if lv is None else jnp.interp(d[k], jnp.asarray(lv), jnp.asarray(fr))
                 for k, (lv, fr) in enumerate(zip(self.levels, self.fractions, strict=True))]
        c = jnp.stack(curve) if curve else jnp.zeros(0)
        return self.standby_w + (self.full_w - self.standby_w) * c

    def total_w(self, dimmers: Float[Array, " net"], networks=None) -> Float[Array, ""]:
        """Total power (W) at ``dimmers``, of the network indices ``networks`` (all)."""
        p = self.network_w(dimmers)
        return jnp.sum(p if networks is None else p[jnp.asarray(networks, jnp.int32)])


def power_model(study) -> PowerModel:
    """The study's :class:`PowerModel` from its photometry, ``[compliance.energy]`` and its
    networks' ``power_w``."""
    cfg, sc = study.config, study.scene
    energy = cfg.compliance.energy if cfg.compliance is not None else None
    src = cfg.source
    names = sc.network_names
    watts_cfg = {} if energy is None else energy.watts
    for p in watts_cfg:
        if p not in sc.photometries:
            raise ConfigError(f"unknown photometry {p!r}; photometry: "
                              f"{', '.join(sc.photometries)}", file=src,
                              key=f"compliance.energy.watts.{p}")
    curves = {} if energy is None else energy.dimming
    for n in curves:
        if n not in names:
            raise ConfigError(f"unknown network {n!r}; networks: {', '.join(names)}",
                              file=src, key=f"compliance.energy.dimming.{n}")
    full = np.zeros(len(names))
    count = np.zeros(len(names))
    missing = []
    levels = np.ones(len(sc.luminaires)) if sc.levels is None else np.asarray(sc.levels)
    for i, lum in enumerate(sc.luminaires):
        k = names.index(lum.network)
        count[k] += 1
        w = watts_cfg.get(lum.photometry, sc.photometries[lum.photometry].input_watts)
        if w is None or (w <= 0 and lum.photometry not in watts_cfg):
            missing.append(lum.name)
            continue
        full[k] += float(w) * float(levels[i])
    for a in sc.area_sources:
        count[names.index(a.network)] += 1
        missing.append(a.name)
    for k, n in enumerate(names):
        given = cfg.networks[n].power_w if n in cfg.networks else None
        if given is not None:
            full[k] = given
            missing = [m for m in missing if _network_of(sc, m) != n]
    standby = np.array([count[k] * (curves[n].standby_w if n in curves else 0.0)
                        for k, n in enumerate(names)])
    lv = tuple(None if n not in curves or curves[n].curve == "linear"
               else tuple(curves[n].levels) for n in names)
    fr = tuple(None if n not in curves or curves[n].curve == "linear"
               else tuple(curves[n].power) for n in names)
    return PowerModel(jnp.asarray(full), jnp.asarray(standby), lv, fr, tuple(missing))


def _network_of(scene, name: str) -> str:
    for s in (*scene.luminaires, *scene.area_sources):
        if s.name == name:
            return s.network
    return ""


def leni_kwh_per_m2(power_w, area_m2: float, energy) -> Float[Array, ""]:
    """LENI (kWh/(m²·a)), EN 15193-1's expression of the annual energy:
    ``W_L = P·F_C·(t_D·F_O·F_D + t_N·F_O)/1000`` and
    ``W_P = (P_pc·(t_y − t_D − t_N) + P_em·t_e)·A/1000``, LENI = (W_L + W_P)/A, with P the
    installed power (W) drawn at the design's dimmers, hours t (h) and factors from
    ``[compliance.energy]``, parasitic powers per m² of the area."""
    e = energy
    w_l = power_w * e.constant_illuminance_factor * (
        e.hours_day * e.occupancy_factor * e.daylight_factor + e.hours_night * e.occupancy_factor
    ) / 1000.0
    w_p = (e.parasitic_w_per_m2 * (HOURS_PER_YEAR - e.hours_day - e.hours_night)
           + e.emergency_w_per_m2 * e.emergency_charge_hours) * area_m2 / 1000.0
    return (w_l + w_p) / area_m2
