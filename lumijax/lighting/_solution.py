"""The lighting solution of a study: direct and inter-reflected light, one solution per network.

Light adds linearly, so each network k is solved once at dimmer 1 and any dimmer vector α gives
``B = Σ_k α_k B_k`` exactly (the paper's equation 10). The pieces, in the order they are built:

1. the scene's triangles cut into patches and partitioned into blocks (``lumijax.mesh``);
2. the transport operator F of the visible block pairs (``lumijax.transport``);
3. direct irradiance on every patch and every calculation point, per network
   (``lumijax.direct``, shadows by ray casting);
4. one batched solve ``(I − ρF) B = ρ E_direct`` for all networks at once (``lumijax.solve``);
5. gathering ``G B`` of the inter-reflected light onto the calculation points.

Changing one luminaire re-shoots only its difference (paper section 6): see
:meth:`LightingSolution.replace_luminaire`.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from ..direct import direct_illuminance
from ._gather import GatherOperator

__all__ = ["LightingSolution"]


@dataclass(frozen=True, eq=False)
class LightingSolution:
    """Per-network light on patches and calculation points, at dimmer 1.

    Attributes
    ----------
    scene
        The :class:`lumijax.scene.Scene` solved.
    patches, transport, gather
        Radiosity patches, form factors, and the patches → points gather map (``None`` when
        inter-reflection is off or the scene has no surfaces).
    rho
        Luminous reflectance per patch (dimensionless).
    patch_direct
        ``(networks, patches)`` direct irradiance on the patches (lx).
    radiosity
        ``(networks, patches)`` radiosity B (lm/m²) — reflected direct plus all bounces.
    point_direct, point_indirect
        ``(networks, points)`` direct and inter-reflected illuminance (lx) at the calculation
        points of all grids, concatenated in grid order.
    """

    scene: object
    points: Float[np.ndarray, "points 3"]
    normals: Float[np.ndarray, "points 3"]
    patches: object | None
    transport: object | None
    gather: GatherOperator | None
    rho: Float[np.ndarray, " patches"] | None
    patch_direct: Float[np.ndarray, "net patches"]
    radiosity: Float[np.ndarray, "net patches"]
    point_direct: Float[np.ndarray, "net points"]
    point_indirect: Float[np.ndarray, "net points"]
    solve_method: str = "bicgstab"
    solve_tolerance: float | None = None
    solve_max_steps: int = 1000
    stats: dict = field(default_factory=dict)

    @property
    def point_total(self) -> Float[np.ndarray, "net points"]:
        """Direct plus inter-reflected illuminance per network at dimmer 1 (lx)."""
        return self.point_direct + self.point_indirect

    def radiosity_at(self, dimmers) -> Float[np.ndarray, " patches"]:
        """B = Σ α_k B_k (lm/m²): exact for any dimmer vector, no solve."""
        return np.asarray(dimmers, np.float64) @ self.radiosity

    def patch_illuminance(self) -> Float[np.ndarray, "net patches"]:
        """Irradiance on each patch per network (lx): direct + F·B."""
        if self.transport is None:
            return self.patch_direct
        fb = np.asarray(self.transport.matmul(jnp.asarray(self.radiosity.T, self._dtype))).T
        return self.patch_direct + fb

    @property
    def _dtype(self):
        return jnp.float64 if self.radiosity.dtype == np.float64 and _x64() else jnp.float32

    def replace_luminaire(self, index: int, luminaire) -> LightingSolution:
        """The solution with luminaire ``index`` replaced (moved, re-aimed, re-lamped, …).

        Only the difference is re-shot: the old and new luminaire's direct light on patches and
        points, one single-column solve of ``(I − ρF) ΔB = ρ ΔE``, and one gather. The result
        equals a full re-solve up to the solver's tolerance. The network may change too.
        """
        sc = self.scene
        old = sc.luminaires[index]
        lums = list(sc.luminaires)
        lums[index] = luminaire
        new_scene = dataclasses.replace(sc, luminaires=tuple(lums))
        names = sc.network_names
        t0 = time.perf_counter()
        pd = self.patch_direct.copy()
        ptd = self.point_direct.copy()
        rad = self.radiosity.copy()
        ind = self.point_indirect.copy()
        for lum, sign in ((old, -1.0), (luminaire, 1.0)):
            k = names.index(lum.network)
            one = dataclasses.replace(sc, luminaires=(dataclasses.replace(lum, network=names[0]),),
                                      area_sources=())
            e_pts = direct_illuminance(one, self.points, self.normals).by_network[0]
            ptd[k] += sign * e_pts
            if self.patches is None:
                continue
            e_patch = direct_illuminance(one, self.patches.centroid,
                                         self.patches.normal).by_network[0]
            pd[k] += sign * e_patch
            values, _ = _solve_columns(self, e_patch[None, :])
            db = values[0]
            rad[k] += sign * db
            ind[k] += sign * np.asarray(self.gather(jnp.asarray(db)))
        stats = dict(self.stats, incremental_s=time.perf_counter() - t0)
        return dataclasses.replace(self, scene=new_scene, patch_direct=pd, radiosity=rad,
                                   point_direct=ptd, point_indirect=ind, stats=stats)


def _x64() -> bool:
    import jax

    return bool(jax.config.read("jax_enable_x64"))


def _solve_columns(sol: LightingSolution, direct: Float[np.ndarray, "cols patches"]):
    """Radiosity ``(cols, patches)`` for the given direct irradiances (lx) on the patches."""
    from ..solve import solve_radiosity

    dtype = sol._dtype
    rho = jnp.asarray(sol.rho, dtype)
    b0 = rho[:, None] * jnp.asarray(direct.T, dtype)
    res = solve_radiosity(sol.transport, rho[:, None], b0, method=sol.solve_method,
                          rtol=sol.solve_tolerance, max_steps=sol.solve_max_steps)
    return np.asarray(res.value, np.float64).T, res
