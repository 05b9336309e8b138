"""The luminance of the surfaces an observer sees, from the radiosity solution.

Each observer's field (the half space in front of each of its lines of sight) is sampled once
with stratified rays from the eye; every ray's first hit, when it meets the front of a surface,
names the radiosity patch seen and the geometry item it belongs to. A Lambertian patch of
radiosity B (lm/m², reflected light: direct and inter-reflected) has luminance ``L = B / π``
(cd/m²) from every side, so its luminance follows from the surface's own material through the
solve, not from a reflectance typed again. With dimmers α the radiosity is ``B = α @ B_k``
(exact superposition), so every quantity here is linear in the dimmers and differentiable.

What a **named** surface (the ``name`` of a ``[[geometry]]`` item; several items may share
one) shows an observer: the largest and the mean luminance over the patches of that name any
of its rays reached. ``[[observers]] max_luminance_cdm2 = { NAME = limit }`` bounds the
largest; results.json reports it per observer (``surfaces``) and a constrained design meets it
as a hard constraint (``lumijax.optimise._surface_constraint``).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .._jit_cache import to_device

__all__ = ["SeenSurfaces", "build_seen_surfaces", "FIELD_RAYS"]

#: Rays over each line of sight's front half space (uniform in solid angle, stratified): at
#: 4096 a surface that fills 0.15 % of the field (9.4 msr, a 1 m panel 10 m away) is met by
#: about six rays.
FIELD_RAYS = 4096


class SeenSurfaces(eqx.Module):
    """Which patches of which named surfaces each observer sees (host index arrays).

    ``patch[j]``, ``observer[j]``, ``surface[j]``: link j says observer ``observer[j]`` sees
    patch ``patch[j]`` of surface ``surfaces[surface[j]]`` (unique links). ``limits`` holds
    the ``max_luminance_cdm2`` limits as ``(observer, surface, cd/m²)``.
    """

    patch: Int[Array, " links"]
    observer: Int[Array, " links"]
    surface: Int[Array, " links"]
    observers: tuple[str, ...] = eqx.field(static=True)
    surfaces: tuple[str, ...] = eqx.field(static=True)
    limits: tuple[tuple[int, int, float], ...] = eqx.field(static=True, default=())

    def luminance(self, radiosity: Float[Array | np.ndarray, " patches"]) -> Float[Array, " links"]:
        """``B / π`` (cd/m²) of every link's patch, for the patches' radiosity (lm/m²)."""
        return jnp.asarray(radiosity)[self.patch] / math.pi

    def maximum(self, radiosity) -> Float[Array, "obs surf"]:
        """The largest luminance (cd/m²) of each named surface each observer sees (0 where it
        sees none of it)."""
        n_o, n_s = len(self.observers), len(self.surfaces)
        seg = self.observer * n_s + self.surface
        m = jax.ops.segment_max(self.luminance(radiosity), seg, num_segments=n_o * n_s)
        return jnp.maximum(m, 0.0).reshape(n_o, n_s)

    def mean(self, radiosity) -> Float[Array, "obs surf"]:
        """The mean luminance (cd/m², over the seen patches, each counted once)."""
        n_o, n_s = len(self.observers), len(self.surfaces)
        seg = self.observer * n_s + self.surface
        s = jax.ops.segment_sum(self.luminance(radiosity), seg, num_segments=n_o * n_s)
        c = jax.ops.segment_sum(jnp.ones_like(seg, s.dtype), seg, num_segments=n_o * n_s)
        return (s / jnp.maximum(c, 1.0)).reshape(n_o, n_s)

    def seen(self) -> np.ndarray:
        """``(observers, surfaces)`` bool: whether the observer sees any of the surface."""
        out = np.zeros((len(self.observers), len(self.surfaces)), bool)
        out[np.asarray(self.observer), np.asarray(self.surface)] = True
        return out

    def links_of(self, observer: int, surface: int) -> np.ndarray:
        """The patch indices of ``surface`` that ``observer`` sees."""
        sel = (np.asarray(self.observer) == observer) & (np.asarray(self.surface) == surface)
        return np.asarray(self.patch)[sel]

    def to_dict(self, radiosity) -> dict[str, dict[str, dict]]:
        """results.json's per-observer ``surfaces``: ``{observer: {surface: {...}}}``."""
        mx, mean = (np.asarray(a, np.float64) for a in _stats(self, to_device(radiosity)))
        seen = self.seen()
        limit = {(o, s): v for o, s, v in self.limits}
        out: dict[str, dict[str, dict]] = {}
        for i, obs in enumerate(self.observers):
            row = {}
            for k, name in enumerate(self.surfaces):
                if not seen[i, k] and (i, k) not in limit:
                    continue
                entry = {"seen": bool(seen[i, k]), "max_luminance_cdm2": float(mx[i, k]),
                         "mean_luminance_cdm2": float(mean[i, k])}
                if (i, k) in limit:
                    entry["limit_cdm2"] = limit[i, k]
                    entry["meets"] = bool(mx[i, k] <= limit[i, k])
                row[name] = entry
            out[obs] = row
        return out


def _field_directions(forward: np.ndarray, rays: int) -> np.ndarray:
    """``rays`` stratified directions, uniform in solid angle over the half space in front of
    the unit ``forward``."""
    from ..radiosity._gather import _sphere_directions

    d = _sphere_directions(2 * rays)
    d = d[d[:, 2] > 0]  # the +z half
    f = forward / np.linalg.norm(forward)
    helper = np.array([1.0, 0, 0]) if abs(f[0]) < 0.9 else np.array([0, 1.0, 0])
    t = np.cross(helper, f)
    t /= np.linalg.norm(t)
    b = np.cross(f, t)
    return d @ np.stack([t, b, f])


@eqx.filter_jit
def _stats(links: SeenSurfaces, radiosity):
    """``(maximum, mean)`` in one program: op by op the luminance, the segment maximum and the
    two segment sums compiled ~20 eager kernels per shape and process (the results' surfaces,
    issue 19); the same operations, so the same bits."""
    return links.maximum(radiosity), links.mean(radiosity)


def build_seen_surfaces(scene, observers, patches, surface_names, *,
                        rays: int = FIELD_RAYS, limits=()) -> SeenSurfaces:
    """The :class:`SeenSurfaces` of ``observers`` (:class:`~lumijax.glare.Observer`) over the
    radiosity ``patches`` of ``scene``; ``surface_names[i]`` is geometry item i's name (None:
    unnamed, not reported). ``limits``: ``(observer name, surface name, cd/m²)``."""
    from ..radiosity._gather import patch_of_hits

    names = tuple(dict.fromkeys(n for n in surface_names if n))
    item_surface = np.array([names.index(n) if n else -1 for n in surface_names], np.int64)
    caster = scene.raycaster if len(scene.triangles) else None
    obs_names = tuple(o.name for o in observers)
    links = []
    if caster is not None and patches is not None and patches.n and names:
        tri_item = np.asarray(scene.triangles.item)
        for i, o in enumerate(observers):
            dirs = np.concatenate([_field_directions(np.asarray(f, np.float64), rays)
                                   for f in o.directions])
            origins = np.repeat(np.asarray(o.eye, np.float64)[None], len(dirs), axis=0)
            # through clear panes (a glazed caster passes them): a facade seen through a
            # window is seen, at its own luminance B/π (what a limit on it bounds)
            tri, dist, _ = caster.first_hit_through(origins, dirs)
            hit = tri >= 0
            hit_n = np.zeros((len(dirs), 3))
            hit_n[hit] = np.cross(*(scene.triangles.vertices[tri[hit]][:, 1:] -
                                    scene.triangles.vertices[tri[hit]][:, :1]).transpose(1, 0, 2))
            hit &= np.einsum("ij,ij->i", dirs, hit_n) < 0  # the front of a one-sided surface
            hit[hit] &= item_surface[tri_item[tri[hit]]] >= 0
            if not hit.any():
                continue
            points = origins[hit] + dirs[hit] * dist[hit, None]
            patch = patch_of_hits(patches, points, tri[hit])
            surf = item_surface[tri_item[tri[hit]]]
            pairs = np.unique(np.stack([patch, surf], axis=1), axis=0)
            links.append(np.column_stack([np.full(len(pairs), i), pairs]))
    link = np.concatenate(links) if links else np.zeros((0, 3), np.int64)
    lim = tuple((obs_names.index(o), names.index(s), float(v)) for o, s, v in limits)
    return SeenSurfaces(patch=jnp.asarray(link[:, 1], jnp.int32),
                        observer=jnp.asarray(link[:, 0], jnp.int32),
                        surface=jnp.asarray(link[:, 2], jnp.int32), observers=obs_names,
                        surfaces=names, limits=lim)
