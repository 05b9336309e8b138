"""The LENI objective of a constrained design (``[optimise] objective = "leni"``): the annual
lighting energy per m² of EN 15193-1 (kWh/(m²·a)) at the design's dimmers.

Both parts are the compliance layer's own (``lumijax.compliance``): the network input power
against the dimmer (input watts of the photometry or ``[compliance.energy] watts``, standby
power, dimming curves) and :func:`~lumijax.compliance.leni_kwh_per_m2` with the hours and
factors of ``[compliance.energy]``. LENI is affine in the power, so the least-LENI design is the
least-power one when the power model is linear in the dimmers; standby power and a dimming curve
that is not linear make them differ, and the prices come out in kWh/(m²·a).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp

from ..compliance import leni_kwh_per_m2
from ..compliance._energy import PowerModel as InputPower, power_model
from ..errors import ConfigError
from ._constraints import DesignLight

__all__ = ["LeniObjective", "leni_objective"]


class LeniObjective(eqx.Module):
    """LENI (kWh/(m²·a)) of the design: ``leni_kwh_per_m2(Σ_k P_k(α_k), A, energy)``, its
    affine map taken once at construction (``slope`` kWh/(m²·a) per W, ``intercept`` the
    parasitic energy) so that the configuration stays out of the traced function."""

    power: InputPower
    slope: float = eqx.field(static=True)
    intercept: float = eqx.field(static=True)
    area_m2: float = eqx.field(static=True)

    def watts(self, light: DesignLight):
        """Input power (W) drawn at the design's dimmers."""
        return jnp.sum(self.power.network_w(light.alpha))

    def __call__(self, light: DesignLight):
        return self.intercept + self.slope * self.watts(light)


def leni_objective(study, variables) -> LeniObjective:
    """The study's LENI objective; a :class:`ConfigError` names what it lacks."""
    cfg = study.config
    energy = cfg.compliance.energy if cfg.compliance is not None else None
    if energy is None:
        raise ConfigError('objective = "leni" needs [compliance.energy] (EN 15193-1\'s hours '
                          "and factors, and area_m2)", file=cfg.source, key="optimise.objective")
    if energy.area_m2 is None:
        raise ConfigError('objective = "leni" needs the floor area the energy is spread over: '
                          "give [compliance.energy] area_m2 (m²)", file=cfg.source,
                          key="compliance.energy.area_m2")
    if "levels" in variables:
        raise ConfigError('objective = "leni" reads input power per network (the compliance '
                          'power model); per-luminaire "levels" are not in it: optimise '
                          '"dimmers" and "aims", or use objective = "power"', file=cfg.source,
                          key="optimise.variables")
    power = power_model(study)
    if power.missing:
        raise ConfigError(f"LENI needs every luminaire's input watts: none for "
                          f"{', '.join(power.missing[:3])}"
                          + (" ..." if len(power.missing) > 3 else "")
                          + " (give [compliance.energy] watts per photometry, or power_w on "
                          "the network)", file=cfg.source, key="compliance.energy.watts")
    area = float(energy.area_m2)
    at0 = float(leni_kwh_per_m2(jnp.asarray(0.0), area, energy))
    slope = float(leni_kwh_per_m2(jnp.asarray(1.0), area, energy)) - at0
    return LeniObjective(power, slope, at0, area)
