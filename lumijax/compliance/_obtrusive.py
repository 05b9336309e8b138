"""Obtrusive light (CIE 150:2017): the upward light ratio of the installation from each
luminaire's own photometry at its aim (direct) and the inter-reflected flux that leaves the
scene toward the sky (reflected), the luminous intensity of each luminaire toward sensitive
points, and the average luminance of a facade from a surface grid.

All at dimmer 1 per luminaire or network: the values at other dimmers are JAX functions of
them (``_verdict``), so they superpose and differentiate.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

__all__ = ["upward_flux", "reflected_upward_flux", "sky_fraction", "intensity_toward",
           "sphere_grid"]


def sphere_grid(n_theta: int = 180, n_phi: int = 360):
    """Midpoint directions and solid angles (sr) of a (θ, φ) grid about world +z, θ from the
    zenith: the horizon θ = 90° is a cell edge, so "above the horizontal" is exact cells."""
    t_edges = np.linspace(0.0, np.pi, n_theta + 1)
    t = 0.5 * (t_edges[1:] + t_edges[:-1])
    p = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    dw = (np.cos(t_edges[:-1]) - np.cos(t_edges[1:]))[:, None] * (2 * np.pi / n_phi)
    tt, pp = np.meshgrid(t, p, indexing="ij")
    u = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1)
    return u.reshape(-1, 3), np.broadcast_to(dw, tt.shape).reshape(-1), (tt < np.pi / 2).ravel()


def upward_flux(scene, n_theta: int = 180, n_phi: int = 360
                ) -> tuple[Float[np.ndarray, " lum"], Float[np.ndarray, " lum"]]:
    """Per luminaire at dimmer 1: the flux emitted above the horizontal plane and the total
    flux (lm), ``∫ I(Rᵀu) dω`` over the world's upper hemisphere and over the sphere (its
    scale included: multiplier, maintenance factor, level, TILT factor)."""
    u, dw, up = sphere_grid(n_theta, n_phi)
    uj, dwj, upj = jnp.asarray(u), jnp.asarray(dw), jnp.asarray(up)
    up_lm, tot_lm = np.zeros(len(scene.luminaires)), np.zeros(len(scene.luminaires))
    for i, lum in enumerate(scene.luminaires):
        dist = scene.photometries[lum.photometry].distribution
        a, b = _fluxes(dist, jnp.asarray(lum.rotation), uj, dwj, upj)
        up_lm[i], tot_lm[i] = lum.scale * float(a), lum.scale * float(b)
    return up_lm, tot_lm


@jax.jit
def _fluxes(dist, rot, u, dw, up):
    i = dist.intensity(u @ rot) * dw  # Rᵀu as row vectors: u @ R
    return jnp.sum(jnp.where(up, i, 0.0)), jnp.sum(i)


def sky_fraction(patches, caster, *, rays: int = 256, seed: int = 0, chunk: int = 4096
                 ) -> Float[np.ndarray, " patches"]:
    """Per patch, the fraction of its (Lambertian, cosine-weighted) exitance that leaves the
    scene above the horizontal: stratified cosine-weighted rays from its centroid, counted when
    they meet no surface and climb (z > 0). A ray meeting any face, front or back, is stopped
    there: what a surface reflects again is in that surface's own exitance."""
    from ..radiosity._gather import _cosine_directions, _frames

    local = _cosine_directions(rays)
    rng = np.random.default_rng(seed)
    out = np.zeros(patches.n)
    for s in range(0, patches.n, chunk):
        c = np.asarray(patches.centroid[s:s + chunk], np.float64)
        frames = _frames(np.asarray(patches.normal[s:s + chunk], np.float64), rng)
        dirs = np.einsum("pij,rj->pri", frames, local).reshape(-1, 3)
        tri, _ = caster.first_hit(np.repeat(c, rays, axis=0), dirs)
        sky = (tri < 0) & (dirs[:, 2] > 0)
        out[s:s + len(c)] = sky.reshape(len(c), rays).mean(axis=1)
    return out


def reflected_upward_flux(lighting, *, rays: int = 256, seed: int = 0
                          ) -> Float[np.ndarray, " net"]:
    """Per network at dimmer 1, the inter-reflected flux (lm) that leaves the scene toward the
    sky: ``Σ_j A_j B_kj f_j`` over the solve's patches, B the luminous exitance (lm/m²) and f
    :func:`sky_fraction`. Zeros when no inter-reflection was computed."""
    k = lighting.coarse.radiosity.shape[0]
    patches = lighting.coarse.patches
    if patches is None or patches.n == 0 or not len(lighting.scene.triangles):
        return np.zeros(k)
    f = sky_fraction(patches, lighting.scene.raycaster, rays=rays, seed=seed)
    return np.asarray(lighting.coarse.radiosity, np.float64) @ (np.asarray(patches.area) * f)


def intensity_toward(scene, point, *, shadows: bool = True) -> Float[np.ndarray, " lum"]:
    """Luminous intensity (cd) of each luminaire toward ``point`` (m) at dimmer 1, 0 where the
    scene blocks the line of sight."""
    point = np.asarray(point, np.float64)
    out = np.zeros(len(scene.luminaires))
    if not scene.luminaires:
        return out
    pos = np.array([lum.position for lum in scene.luminaires])
    d = point - pos
    w = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), np.finfo(np.float64).tiny)
    for i, lum in enumerate(scene.luminaires):
        dist = scene.photometries[lum.photometry].distribution
        out[i] = lum.scale * float(dist.intensity(jnp.asarray(w[i] @ lum.rotation)))
    if shadows and len(scene.triangles):
        blocked = scene.raycaster.occluded(pos, np.broadcast_to(point, pos.shape))
        out[blocked] = 0.0
    return out
