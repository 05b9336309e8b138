"""Diffuse transmission: which patch is the other side of each patch of an opal or frosted panel.

A diffusely transmitting surface has a front and a back face (``lumijax.scene._two_sided``),
each meshed into patches. With H the irradiance arriving on a patch (lx: direct plus
inter-reflected, H = E + F B), each side leaves Lambertian

    B_front = ρ H_front + τ H_back,    B_back = ρ H_back + τ H_front,

so the solve's operator is K x = ρ ⊙ (F x) + τ ⊙ (F x)[partner] (``ReflectionOperator``) and
its start B₀ = ρ E + τ E[partner]. ``partner[i]`` is the patch of the other face under patch
i's centroid: the two faces are meshed alike, so it is the mirror patch, of the same area, and
the coupling conserves flux exactly (Σ A B counts each patch's τ H A once); if refinement cut
the faces differently, the irradiance (a density, lx) is sampled where the patch lies.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Bool, Int

from ..errors import GeometryError
from ._patches import Patches

__all__ = ["back_partners"]


def back_partners(patches: Patches, transmitting: Bool[np.ndarray, " patches"]
                  ) -> Int[np.ndarray, " patches"]:
    """``partner[i]``: the patch on the other face of a transmitting patch i (i itself elsewhere).

    The other face is found among the transmitting patches facing the opposite way
    (n_i · n_j < −0.999), within 10⁻³ of the scene's size of patch i's plane, as the one whose
    triangle holds i's centroid projected onto it (else the nearest such patch).
    Raises :class:`GeometryError` when a transmitting patch has no other face (a bug upstream:
    the scene adds one for every diffusely transmitting triangle).
    """
    from scipy.spatial import cKDTree

    n = patches.n
    partner = np.arange(n)
    idx = np.flatnonzero(np.asarray(transmitting, bool))
    if not len(idx):
        return partner
    c, nrm, v = patches.centroid[idx], patches.normal[idx], patches.vertices[idx]
    span = float(np.ptp(patches.vertices.reshape(-1, 3), axis=0).max())
    k = min(32, len(idx))
    _, near = cKDTree(c).query(c, k=k)
    near = near.reshape(len(idx), k)
    for a in range(len(idx)):
        cand = near[a]
        ok = (nrm[cand] @ nrm[a] < -0.999) & (np.abs((c[cand] - c[a]) @ nrm[a]) < 1e-3 * span)
        cand = cand[ok]
        if not len(cand):
            raise GeometryError(
                f"patch {idx[a]} of a diffusely transmitting surface has no back face near it")
        partner[idx[a]] = idx[cand[_holding(v[cand], nrm[cand], c[a])]]
    return partner


def _holding(tri, normal, point) -> int:
    """Index of the first triangle whose prism along its normal holds ``point`` (else 0, the
    nearest: candidates come sorted by distance)."""
    inside = np.ones(len(tri), bool)
    for e in range(3):
        edge = tri[:, (e + 1) % 3] - tri[:, e]
        side = np.einsum("nk,nk->n", np.cross(edge, point - tri[:, e]), normal)
        inside &= side >= -1e-12 * np.einsum("nk,nk->n", edge, edge)
    return int(np.argmax(inside)) if inside.any() else 0
