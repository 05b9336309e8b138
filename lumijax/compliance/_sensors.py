"""Cylindrical, semi-cylindrical and hemispherical illuminance per point, per network: the
direct part through the direct stage's pair set with the sensor's response
(:class:`lumijax.direct.SensorResponse`), the inter-reflected part gathered from the radiosity
solution over the whole sphere (:func:`lumijax.radiosity._gather.build_sensor_gather`).

Light adds per network, so a :class:`SensorLight` at dimmer 1 gives any dimmer vector by
superposition, as a JAX function (differentiable in the dimmers and maintenance factors).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..direct import SensorResponse, direct_illuminance
from ..radiosity._gather import build_sensor_gather

__all__ = ["SensorLight", "sensor_light", "modelling_ratio", "AREA_PIECES"]

#: Pieces per side an area source is cut into for a sensor (point-like Lambertian pieces).
AREA_PIECES = 8


class SensorLight(eqx.Module):
    """Sensor illuminance (lx) per network at dimmer 1: ``direct`` and ``indirect``
    (inter-reflected), each ``(networks, points)``."""

    direct: Float[Array, "net points"]
    indirect: Float[Array, "net points"]

    @property
    def by_network(self) -> Float[Array, "net points"]:
        return self.direct + self.indirect

    def at(self, dimmers: Float[Array, " net"]) -> Float[Array, " points"]:
        """Sensor illuminance (lx) at ``dimmers`` (factors per network, maintenance included
        by the caller): ``Σ_k α_k E_k``."""
        return jnp.asarray(dimmers) @ self.by_network


def sensor_light(solution, points: Float[np.ndarray, "points 3"], response: SensorResponse,
                 *, rays: int = 1024, shadows: bool = True) -> SensorLight:
    """The sensors' light in a :class:`lumijax.lighting.LightingSolution` (its scene and its
    per-network radiosity): direct from every luminaire and area source, with shadows, and
    inter-reflected from the patches (none when the solution has no patches)."""
    scene = solution.scene
    points = np.ascontiguousarray(points, np.float64)
    direct = direct_illuminance(scene, points, response.facing, shadows=shadows,
                                response=response).by_network
    direct = direct + _area_sources(scene, points, response, shadows)
    k = len(scene.networks)
    indirect = np.zeros((k, len(points)))
    patches = solution.coarse.patches
    if patches is not None and patches.n and len(points):
        gather = build_sensor_gather(points, response, patches, scene.raycaster, rays=rays)
        indirect = np.asarray(gather(jnp.asarray(np.asarray(solution.coarse.radiosity).T)),
                              np.float64).T
    return SensorLight(jnp.asarray(direct), jnp.asarray(indirect))


def _area_sources(scene, points, response, shadows) -> np.ndarray:
    """Area sources as ``AREA_PIECES``² Lambertian pieces, each ``I(θ) = M·a·cos θ / π``
    (cd) seen by the sensors with their response, shadowed piece by piece."""
    net = {n.name: i for i, n in enumerate(scene.networks)}
    out = np.zeros((len(scene.networks), len(points)))
    caster = scene.raycaster if shadows and len(scene.triangles) else None
    n = AREA_PIECES
    s = (np.arange(n) + 0.5) / n
    for a in scene.area_sources:
        centres = (a.origin + s[:, None, None] * a.u + s[None, :, None] * a.v).reshape(-1, 3)
        normal, piece = a.normal, a.area / n**2
        for c in centres:
            d = points - c
            r2 = np.maximum(np.einsum("ij,ij->i", d, d), np.finfo(np.float64).tiny)
            w = d / np.sqrt(r2)[:, None]
            cos_s = np.maximum(w @ normal, 0.0)
            e = a.exitance / np.pi * piece * cos_s * response.factor(
                w, np.arange(len(points))) / r2
            if caster is not None:
                lit = np.flatnonzero(e > 0)
                if len(lit):
                    e[lit[caster.occluded(np.broadcast_to(c, (len(lit), 3)), points[lit])]] = 0
            out[net[a.network]] += e
    return out


def modelling_ratio(ez: Float[Array, " points"], eh: Float[Array, " points"]
                    ) -> Float[Array, ""]:
    """Modelling Ēz/Ēh (EN 12464-1:2021): mean cylindrical over mean horizontal illuminance
    of an area (0 when the area is unlit)."""
    eh_mean = jnp.mean(eh)
    return jnp.where(eh_mean > 0, jnp.mean(ez) / jnp.where(eh_mean > 0, eh_mean, 1.0), 0.0)
