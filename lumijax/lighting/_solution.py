"""The lighting solution of a study: direct and inter-reflected light, one solution per network.

Light adds linearly, so each network k is solved once at dimmer 1 and any dimmer vector α gives
``B = Σ_k α_k B_k`` exactly (the paper's equation 10). The pieces, in the order they are built:

1. the scene's triangles cut into patches and partitioned into blocks (``lumijax.radiosity``);
2. the transport operator F of the visible block pairs (``lumijax.radiosity``);
3. direct irradiance on every patch and every calculation point, per (network, spectrum)
   group (``lumijax.direct``, shadows by ray casting);
4. one batched solve ``(I − ρ(λ)F) B = ρ(λ) E_direct s(λ)`` for all groups and sample
   wavelengths at once (``lumijax.radiosity``);
5. gathering ``G B`` of the inter-reflected light onto the calculation points, and the
   reduction of the spectral values to lux and CIE XYZ.

Changing one luminaire re-shoots only its difference (paper section 6): see
:meth:`LightingSolution.replace_luminaire`.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from ..direct import direct_illuminance
from ..radiosity._gather import GatherOperator
from ._spectral import SpectralSetup

__all__ = ["LightingSolution"]


@dataclass(frozen=True, eq=False)
class LightingSolution:
    """Per-network light on patches and calculation points, at dimmer 1.

    Attributes
    ----------
    scene
        The :class:`lumijax.scene.Scene` solved.
    points, normals
        The calculation points of all grids, concatenated in grid order.
    patches, transport, gather, spectral
        Radiosity patches, form factors, the patches → points gather map and the spectral
        set-up (all ``None`` when inter-reflection is off or the scene has no surfaces).
    rho
        Luminous reflectance per patch (dimensionless).
    patch_direct
        ``(networks, patches)`` direct irradiance on the patches (lx).
    radiosity
        ``(networks, patches)`` luminous radiosity B (lm/m²): reflected direct plus all bounces.
    radiosity_xyz
        ``(networks, 3, patches)`` CIE XYZ of the radiosity (Y = ``radiosity``), or None.
    point_direct, point_indirect
        ``(networks, points)`` direct and inter-reflected illuminance (lx).
    point_xyz
        ``(networks, 3, points)`` CIE XYZ of the total illuminance (Y in lx), or None.
    """

    scene: object
    points: Float[np.ndarray, "points 3"]
    normals: Float[np.ndarray, "points 3"]
    patches: object | None
    transport: object | None
    gather: GatherOperator | None
    spectral: SpectralSetup | None
    rho: Float[np.ndarray, " patches"] | None
    patch_direct: Float[np.ndarray, "net patches"]
    radiosity: Float[np.ndarray, "net patches"]
    radiosity_xyz: Float[np.ndarray, "net 3 patches"] | None
    point_direct: Float[np.ndarray, "net points"]
    point_indirect: Float[np.ndarray, "net points"]
    point_xyz: Float[np.ndarray, "net 3 points"] | None
    solve_method: str = "bicgstab"
    solve_tolerance: float | None = None
    solve_max_steps: int = 1000
    stats: dict = field(default_factory=dict)
    # Two-level solve (docs/radiosity.md, "Two levels"): the fields above are the operator's
    # elements; these are the fine patches that gathered from them (None: one level).
    fine_patches: object | None = None
    fine_gather: GatherOperator | None = None
    fine_rho: Float[np.ndarray, "fine w"] | None = None
    fine_patch_direct: Float[np.ndarray, "net fine"] | None = None
    fine_patch_indirect: Float[np.ndarray, "net fine"] | None = None
    fine_radiosity: Float[np.ndarray, "net fine"] | None = None
    fine_radiosity_xyz: Float[np.ndarray, "net 3 fine"] | None = None

    @property
    def display_patches(self):
        """The patches to show and write: the fine ones of a two-level solve, else the elements."""
        return self.fine_patches if self.fine_patches is not None else self.patches

    @property
    def display_radiosity(self) -> Float[np.ndarray, "net patches"]:
        """``(networks, display patches)`` luminous radiosity (lm/m²) at dimmer 1."""
        return self.fine_radiosity if self.fine_patches is not None else self.radiosity

    @property
    def display_radiosity_xyz(self) -> Float[np.ndarray, "net 3 patches"] | None:
        """``(networks, 3, display patches)`` CIE XYZ of the radiosity, or None."""
        return self.fine_radiosity_xyz if self.fine_patches is not None else self.radiosity_xyz

    @property
    def display_patch_direct(self) -> Float[np.ndarray, "net patches"]:
        """``(networks, display patches)`` direct irradiance (lx)."""
        return self.fine_patch_direct if self.fine_patches is not None else self.patch_direct

    @property
    def display_rho(self) -> Float[np.ndarray, " patches"] | None:
        """Luminous reflectance of the display patches."""
        if self.fine_patches is None:
            return self.rho
        return np.array([m.luminous_reflectance for m in self.scene.materials])[
            self.fine_patches.material]

    def display_patch_illuminance(self) -> Float[np.ndarray, "net patches"]:
        """Irradiance on each display patch per network (lx): direct + inter-reflected."""
        if self.fine_patches is None:
            return self.patch_illuminance()
        return self.fine_patch_direct + self.fine_patch_indirect

    def display_radiosity_at(self, dimmers) -> Float[np.ndarray, " patches"]:
        """Radiosity of the display patches at any dimmer vector (lm/m²), exact, no solve."""
        return np.asarray(dimmers, np.float64) @ self.display_radiosity

    @property
    def point_total(self) -> Float[np.ndarray, "net points"]:
        """Direct plus inter-reflected illuminance per network at dimmer 1 (lx)."""
        return self.point_direct + self.point_indirect

    def radiosity_at(self, dimmers) -> Float[np.ndarray, " patches"]:
        """B = Σ α_k B_k (lm/m²): exact for any dimmer vector, no solve."""
        return np.asarray(dimmers, np.float64) @ self.radiosity

    def patch_illuminance(self) -> Float[np.ndarray, "net patches"]:
        """Irradiance on each patch per network (lx): direct + F·B (luminous)."""
        if self.transport is None:
            return self.patch_direct
        fb = np.asarray(self.transport.matmul(jnp.asarray(self.radiosity.T, _dtype()))).T
        return self.patch_direct + fb

    def replace_luminaire(self, index: int, luminaire) -> LightingSolution:
        """The solution with luminaire ``index`` replaced (moved, re-aimed, re-lamped, …).

        Only the difference is re-shot: the old and new luminaire's direct light on patches and
        points (that luminaire's candidate pairs only), one solve of ``(I − ρF) ΔB = ρ ΔE``
        over the sample wavelengths (one column per wavelength when network and spectrum stay,
        two otherwise), and one gather. The result equals a full re-solve up to the solver's tolerance. The network
        and the spectrum may change too.
        """
        sc = self.scene
        old = sc.luminaires[index]
        lums = list(sc.luminaires)
        lums[index] = luminaire
        new_scene = dataclasses.replace(sc, luminaires=tuple(lums))
        names = sc.network_names
        t0 = time.perf_counter()
        upd = {name: np.array(getattr(self, name), copy=True) for name in (
            "patch_direct", "radiosity", "point_direct", "point_indirect")}
        for name in ("radiosity_xyz", "point_xyz", "fine_patch_direct", "fine_patch_indirect",
                     "fine_radiosity", "fine_radiosity_xyz"):
            arr = getattr(self, name)
            upd[name] = None if arr is None else arr.copy()
        # direct light of the old and new luminaire alone (its candidate pairs only)
        rows = []
        for lum, sign in ((old, -1.0), (luminaire, 1.0)):
            one = dataclasses.replace(
                sc, luminaires=(dataclasses.replace(lum, network=names[0]),), area_sources=())
            e_pts = sign * direct_illuminance(one, self.points, self.normals).by_network[0]
            e_fine = None if self.fine_patches is None else sign * direct_illuminance(
                one, self.fine_patches.centroid, self.fine_patches.normal).by_network[0]
            if e_fine is not None:  # two levels: the elements' direct is the fine flux's mean
                from ..radiosity._final_gather import element_means

                e_patch = element_means(self.fine_patches, self.patches, e_fine[None])[0][0]
            else:
                e_patch = None if self.patches is None else sign * direct_illuminance(
                    one, self.patches.centroid, self.patches.normal).by_network[0]
            rows.append([names.index(lum.network), lum.spectrum, e_pts, e_patch, e_fine])
        # same network and spectrum: one difference row, so one solve of W columns, not two
        if rows[0][0] == rows[1][0] and rows[0][1] is rows[1][1]:
            rows = [[rows[0][0], rows[0][1], rows[0][2] + rows[1][2],
                     None if self.patches is None else rows[0][3] + rows[1][3],
                     None if self.fine_patches is None else rows[0][4] + rows[1][4]]]
        for k, _, e_pts, e_patch, _fine in rows:
            upd["point_direct"][k] += e_pts
            if e_patch is not None:
                upd["patch_direct"][k] += e_patch
        if self.patches is not None:
            shot = shoot(self, np.stack([r[3] for r in rows]), [r[1] for r in rows],
                         np.stack([r[2] for r in rows]))
            for q, (k, *_rest) in enumerate(rows):
                upd["radiosity"][k] += shot.radiosity[q]
                upd["point_indirect"][k] += shot.point_indirect[q]
                if upd["point_xyz"] is not None:
                    upd["radiosity_xyz"][k] += shot.radiosity_xyz[q]
                    upd["point_xyz"][k] += shot.point_xyz[q]
            if self.fine_patches is not None:
                from ..radiosity._final_gather import reflect_onto_fine

                rb, rxyz, rind = reflect_onto_fine(
                    self.fine_gather, self.fine_rho, np.stack([r[4] for r in rows]),
                    [self.spectral.weights(r[1]) for r in rows], shot.value)
                for q, (k, *_rest) in enumerate(rows):
                    upd["fine_patch_direct"][k] += rows[q][4]
                    upd["fine_patch_indirect"][k] += rind[q]
                    upd["fine_radiosity"][k] += rb[q]
                    if upd["fine_radiosity_xyz"] is not None:
                        upd["fine_radiosity_xyz"][k] += rxyz[q]
        stats = dict(self.stats, incremental_s=time.perf_counter() - t0)
        return dataclasses.replace(self, scene=new_scene, stats=stats, **upd)


def _dtype():
    return jnp.float64 if jax.config.read("jax_enable_x64") else jnp.float32


@dataclass(frozen=True)
class Shot:
    """Light shot by a set of sources (one row each) into the scene."""

    radiosity: Float[np.ndarray, "src patches"]
    radiosity_xyz: Float[np.ndarray, "src 3 patches"] | None
    point_indirect: Float[np.ndarray, "src points"]
    point_xyz: Float[np.ndarray, "src 3 points"] | None
    result: object
    timing_s: dict = field(default_factory=dict)
    value: Float[np.ndarray, "patches src w"] | None = None  # the spectral radiosity solved


def shoot(sol: LightingSolution, patch_direct, spectra, point_direct) -> Shot:
    """Solve and gather the inter-reflected light of sources with these direct irradiances.

    Parameters
    ----------
    patch_direct, point_direct
        ``(src, patches)`` and ``(src, points)`` direct illuminance (lx), one row per source
        (group) with spectrum ``spectra[i]`` (None: the default).
    """
    from ..radiosity import solve_radiosity

    t0 = time.perf_counter()
    sp = sol.spectral
    weights = [sp.weights(s) for s in spectra]
    s = np.stack([w[0] for w in weights])  # (src, W)
    h = np.stack([w[1] for w in weights])  # (src, 3, W)
    dtype = _dtype()
    rho = jnp.asarray(sp.rho, dtype)  # (P, W)
    b0 = rho[:, None, :] * jnp.asarray(np.asarray(patch_direct).T[:, :, None] * s[None], dtype)
    res = solve_radiosity(sol.transport, rho[:, None, :], b0, method=sol.solve_method,
                          rtol=sol.solve_tolerance, max_steps=sol.solve_max_steps)
    b = np.asarray(res.value, np.float64)  # (P, src, W)
    t1 = time.perf_counter()
    b_xyz = np.einsum("scw,psw->scp", h, b)  # (src, 3, P)
    e_ind = np.asarray(sol.gather(jnp.asarray(b, dtype)), np.float64)  # (N, src, W)
    ind_xyz = np.einsum("scw,nsw->scn", h, e_ind)  # (src, 3, N)
    colour = np.einsum("scw,sw->sc", h, s)  # XYZ of each source's light, Y = 1
    point_xyz = ind_xyz + colour[:, :, None] * np.asarray(point_direct)[:, None, :]
    spectral = sp.sampling is not None
    return Shot(
        radiosity=b_xyz[:, 1], radiosity_xyz=b_xyz if spectral else None,
        point_indirect=ind_xyz[:, 1], point_xyz=point_xyz if spectral else None, result=res,
        timing_s={"solve": t1 - t0, "gather": time.perf_counter() - t1}, value=b,
    )
