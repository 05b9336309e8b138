"""Clear glass: the thin pane's angle-dependent transmittance, and rays that pass through panes.

A clear pane is one surface in the model (a single triangle layer, not a box with two faces).
Light crossing it at incidence θ is attenuated by the transmittance of a thin, parallel,
absorbing slab of refractive index n = 1.52 in air, with both surfaces and every internal
reflection counted (the incoherent sum of the multiply reflected beams), averaged over the two
polarisations — the model of Radiance's ``glass`` material:

    cos θ_t = √(1 − sin²θ / n²)
    r_s = ((cos θ − n cos θ_t) / (cos θ + n cos θ_t))²,  r_p = ((n cos θ − cos θ_t) /
          (n cos θ + cos θ_t))²                                       (Fresnel, one surface)
    t(θ) = t_n^(1 / cos θ_t)                                         (internal, one pass)
    τ(θ) = ½ Σ_{r ∈ r_s, r_p} (1 − r)² t / (1 − r² t²)

The config's ``transmittance`` is τ(0), the figure a glass maker quotes; the internal
transmissivity t_n follows from it (:func:`internal_transmissivity`, Radiance's conversion
``tn = (√(0.8402528435 + 0.0072522239 Tn²) − 0.9166530661) / 0.0036261119 / Tn``). A pane
without absorption (t_n = 1) has τ(0) = (1 − r₀)/(1 + r₀) = 0.9183: a larger value is refused.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Bool, Float

from ._raycast import RayCaster

__all__ = ["GLASS_INDEX", "MAX_CLEAR_TRANSMITTANCE", "internal_transmissivity",
           "glass_transmittance", "GlazedCaster"]

GLASS_INDEX = 1.52
"""Refractive index of soda-lime float glass (and of Radiance's ``glass``)."""

_R0 = ((GLASS_INDEX - 1.0) / (GLASS_INDEX + 1.0)) ** 2

MAX_CLEAR_TRANSMITTANCE = (1.0 - _R0) / (1.0 + _R0)
"""τ(0) of a non-absorbing pane of index 1.52 (0.9183): no clear pane transmits more."""

_LAYERS = 16  # panes one ray may cross; beyond, the light left is below τ¹⁶ ≈ 0.25 % anyway


def internal_transmissivity(tau_normal: Float[np.ndarray, "..."]) -> np.ndarray:
    """The one-pass internal transmissivity t_n of a pane whose normal transmittance is τ(0).

    Inverts τ(0) = (1 − r₀)² t / (1 − r₀² t²) for t (dimensionless, in [0, 1] for
    0 ≤ τ(0) ≤ :data:`MAX_CLEAR_TRANSMITTANCE`).
    """
    tau = np.asarray(tau_normal, np.float64)
    a = (1.0 - _R0) ** 2
    safe = np.where(tau > 0, tau, 1.0)
    t = (np.sqrt(a * a + 4.0 * _R0 * _R0 * safe * safe) - a) / (2.0 * _R0 * _R0 * safe)
    return np.where(tau > 0, np.minimum(t, 1.0), 0.0)


def glass_transmittance(cos_incidence: Float[np.ndarray, "..."],
                        tau_normal: Float[np.ndarray, "..."]) -> np.ndarray:
    """τ(θ) of a thin clear pane (module docstring) at incidence cos θ, for normal value τ(0).

    ``cos_incidence`` is |cos θ| (either side of the pane); both broadcast. Dimensionless.
    """
    ci = np.clip(np.abs(np.asarray(cos_incidence, np.float64)), 0.0, 1.0)
    t_n = internal_transmissivity(tau_normal)
    n = GLASS_INDEX
    ct = np.sqrt(1.0 - (1.0 - ci * ci) / (n * n))
    rs = ((ci - n * ct) / (ci + n * ct)) ** 2
    rp = ((n * ci - ct) / (n * ci + ct)) ** 2
    t = np.where(t_n > 0, t_n, 1.0) ** (1.0 / ct) * (t_n > 0)
    out = np.zeros(np.broadcast(rs, t).shape)
    for r in (rs, rp):
        out = out + 0.5 * (1.0 - r) ** 2 * t / (1.0 - r * r * t * t)
    return out


class GlazedCaster(RayCaster):
    """A :class:`RayCaster` whose clear-glass triangles pass light instead of blocking it.

    Parameters
    ----------
    triangles
        ``(T, 3, 3)`` every triangle of the scene (m); :meth:`first_hit` still sees all of them,
        so a gather ray stops at a pane (its own diffuse reflection).
    tau_normal
        ``(T,)`` normal transmittance τ(0) of each triangle: > 0 for clear glass, 0 for opaque.

    :meth:`transmission` is the fraction of light a segment carries: 0 when an opaque triangle
    blocks it, else the product of τ(θ) over the panes it crosses. :meth:`occluded` is True only
    for an opaque block (a yes/no caller sees glass as clear).
    """

    def __init__(self, triangles, tau_normal) -> None:
        super().__init__(triangles)
        tau = np.asarray(tau_normal, np.float64)
        tri = np.asarray(triangles, np.float64)
        self._args = (tri, tau)
        glass = tau > 0
        self._tau_all = tau
        self._normal_all = self._unit_normals(tri)
        self._glass_index = np.flatnonzero(glass)
        self._glass_tau = tau[glass]
        self._glass_normal = self._normal_all[glass]
        self._opaque = self._embree(tri[~glass])
        self._panes = self._embree(tri[glass])
        import hashlib

        h = hashlib.sha256(np.ascontiguousarray(tau).tobytes())
        self.glazing_key = h.hexdigest()

    @staticmethod
    def _unit_normals(tri):
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    def first_hit_through(self, origins, directions):
        """The first triangle that is not clear glass along each ray (−1 for none), its
        distance (m; inf for none), and the light carried to it: the product of τ(θ) of the
        panes passed on the way."""
        d = np.asarray(directions, np.float64)
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        pos = np.array(np.broadcast_to(np.asarray(origins, np.float64), d.shape))
        n = len(d)
        tri, dist, carried = np.full(n, -1, np.int64), np.full(n, np.inf), np.ones(n)
        travelled = np.zeros(n)
        live = np.arange(n)
        for _ in range(_LAYERS):
            if not len(live):
                break
            t, s = RayCaster.first_hit(self, pos[live], d[live])
            pane = (t >= 0) & (self._tau_all[np.maximum(t, 0)] > 0)
            stop = live[~pane]
            tri[stop] = t[~pane]
            dist[stop] = np.where(t[~pane] >= 0, travelled[stop] + s[~pane], np.inf)
            live, t, s = live[pane], t[pane], s[pane]
            cos = np.einsum("nk,nk->n", d[live], self._normal_all[t])
            carried[live] *= glass_transmittance(cos, self._tau_all[t])
            pos[live] += s[:, None] * d[live]
            travelled[live] += s
        carried[live] = 0.0  # still among panes after _LAYERS: nothing worth carrying
        return tri, dist, carried

    def __reduce__(self):
        # pickled as its triangles and panes (a plain RayCaster's pickle would lose the glass)
        return (GlazedCaster, self._args)

    def _embree(self, tri):
        if not len(tri):
            return None
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        verts = (tri.reshape(-1, 3) - self.origin).astype(np.float32)
        faces = np.arange(len(verts), dtype=np.int32).reshape(-1, 3)
        scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene=scene, vertices=verts, indices=faces)
        return scene

    def _segments(self, origins, targets):
        origins = np.broadcast_to(np.asarray(origins, np.float64), np.shape(targets))
        targets = np.asarray(targets, np.float64)
        d = targets - origins
        length = np.linalg.norm(d, axis=1)
        ok = length > 2 * self.epsilon
        d = d / np.where(ok, length, 1.0)[:, None]
        start = (origins - self.origin) + self.epsilon * d
        return start, d, np.where(ok, length - 2 * self.epsilon, 0.0), ok

    def occluded(self, origins, targets) -> Bool[np.ndarray, " rays"]:
        """Whether an opaque triangle blocks each open segment (clear panes do not)."""
        start, d, tfar, ok = self._segments(origins, targets)
        if self._opaque is None or not len(start):
            return np.zeros(len(start), bool)
        hit = self._opaque.run(start.astype(np.float32), d.astype(np.float32),
                               dists=tfar.astype(np.float32), query="OCCLUDED")
        return (np.asarray(hit) >= 0) & ok

    def occluded_along(self, origins, directions, lengths) -> Bool[np.ndarray, " rays"]:
        """:meth:`occluded` of segments given by their unit directions and lengths (m): the
        ends are made again, as the panes' tests start from them."""
        return self.occluded(origins, origins + np.asarray(lengths)[:, None] * directions)

    def transmission_along(self, origins, directions, lengths) -> Float[np.ndarray, " rays"]:
        """:meth:`transmission` of segments given by their unit directions and lengths (m)."""
        return self.transmission(origins, origins + np.asarray(lengths)[:, None] * directions)

    def pair_transmission(self, origins, targets) -> Float[np.ndarray, " rays"]:
        """:meth:`transmission` of a visibility ray between two patches, × (1 − τ(θ)) for an
        end that lies on a pane (a pane's own patch, dimensionless).

        A patch facing a pane sees the pane's patch and, × τ(θ), what lies behind it: the
        pane's footprint twice, so its row of F summed to 1 + τ F(pane) in a closed room, and
        the solve's row correction took that for discretisation error and cut the row. A pane
        is reached by the share of the light it does not pass, so its patch's factor is the
        bare one × (1 − τ(θ)) and the row sums to 1 again (its own diffuse reflection then
        applies to that share: give clear glass ``reflectance`` 0, docs/materials.md)."""
        out = self.transmission(origins, targets)
        if self._panes is None:
            return out
        start, d, tfar, ok = self._segments(origins, targets)
        live = np.flatnonzero((out > 0) & ok)
        if not len(live):
            return out
        e = self.epsilon
        # a short probe across each end (±3 ε): a pane there holds that end
        for at in (start[live] - e * d[live], start[live] + tfar[live, None] * d[live]
                   + e * d[live]):
            res = self._panes.run((at - 3 * e * d[live]).astype(np.float32),
                                  d[live].astype(np.float32),
                                  dists=np.full(len(live), 6 * e, np.float32), output=1)
            prim = np.asarray(res["primID"], np.int64)
            on = prim >= 0
            cos = np.einsum("nk,nk->n", d[live][on], self._glass_normal[prim[on]])
            out[live[on]] *= 1.0 - glass_transmittance(cos, self._glass_tau[prim[on]])
        return out

    def transmission(self, origins, targets) -> Float[np.ndarray, " rays"]:
        """Fraction of light carried along each open segment (dimensionless, in [0, 1])."""
        out = np.where(self.occluded(origins, targets), 0.0, 1.0)
        if self._panes is None:
            return out
        start, d, tfar, ok = self._segments(origins, targets)
        live = np.flatnonzero((out > 0) & ok)
        pos, left = start[live], tfar[live]
        for _ in range(_LAYERS):
            if not len(live):
                break
            res = self._panes.run(pos.astype(np.float32), d[live].astype(np.float32),
                                  dists=left.astype(np.float32), output=1)
            prim = np.asarray(res["primID"], np.int64)
            t = np.asarray(res["tfar"], np.float64)
            hit = (prim >= 0) & (t < left) & (left > 0)
            live, pos, left, prim, t = live[hit], pos[hit], left[hit], prim[hit], t[hit]
            cos = np.einsum("nk,nk->n", d[live], self._glass_normal[prim])
            out[live] *= glass_transmittance(cos, self._glass_tau[prim])
            # continue just past the pane: the same nudge a ray gets off its own surface
            step = t + self.epsilon
            pos = pos + step[:, None] * d[live]
            left = left - step
        return out
