"""What observers see of every luminaire, fixed once, and the ratings as a function of the design.

Built once from a lit study (:func:`build_glare_model`), on the host and with rays:

* per observer and luminaire: the unit direction luminaire → eye (world), 1/d² (m⁻²) and
  the fraction of its luminance a ray from the eye sees: 0 behind an opaque triangle (a
  luminaire hidden behind a column does not glare), τ(θ) of each clear pane on the way (a
  luminaire seen through a window glares with luminance τ L, its solid angle unchanged);
* per view (an observer's line of sight; a fan gives several) and luminaire: the Guth position
  index, the cosine and angle (deg) off the line of sight, and whether the source is in front of
  the eye;
* per view and network at dimmer 1: the background luminance ``L_b = E_ind / π`` (cd/m²) from
  the inter-reflected light gathered at the eye across the line of sight (the grids' gather,
  with the line of sight as the normal: indirect = total − direct, since patches' radiosity
  holds reflected light only), and the environment's average luminance ``L_av`` (cd/m²): the
  cosine-weighted mean luminance of the surfaces the eye sees in that hemisphere, sky left out
  (for an eye over a uniformly lit plane this is CIE 112's ``ρ E_h / π``);
* per observer: the road's average luminance for TI, given or from a road grid (``ρ E / π`` of
  the surface under each grid point, from its own material).

:meth:`GlareModel.__call__` then evaluates everything that depends on the design, in pure JAX:
each luminaire's candela toward the eye through its photometry at the design's aim and level
(the same ``CandelaDistribution.intensity`` the light is computed with), its luminance
``I / A_p`` and solid angle ``A_p / d²``, and the ratings of :mod:`lumijax.glare._ratings`,
with every network's luminances scaled by its dimmer. Differentiable in dimmers, aims and
levels; no ray. As in the optimiser's aim model, the LM-63 TILT factor keeps its start value.
"""

from __future__ import annotations

import functools
import math
import warnings
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .. import _executables
from .._jit_cache import to_device
from ..errors import GeometryError, LumijaxWarning
from ..scene._frames import aim_rotation
from ._area import NoLuminousSizeWarning, opening_size, projected_area
from ._position import position_index, view_angles
from ._ratings import (
    VEILING_ANGLE_RANGE_DEG,
    glare_rating,
    threshold_increment,
    ugr_of_sum,
)

__all__ = ["GlareModel", "GlareRatings", "NearSourceWarning", "build_glare_model", "worst_ratings"]


class NearSourceWarning(LumijaxWarning):
    """An eye is closer to a luminaire than the luminaire's own size: its solid angle
    ``A_p / d²`` and position index (taken at its centre) are rough there."""


class _Seen(eqx.Module):
    """What every kind of source shares: its network, and where it stands in each view
    (position index p, cos σ from the line of sight, angle θ in degrees)."""

    network: Int[Array, " m"]
    position: Float[Array, "views m"]
    cos_sigma: Float[Array, "views m"]
    angle_deg: Float[Array, "views m"]


class _Sources(_Seen):
    """One photometry's luminaires as the observers see them (see the module docstring)."""

    distribution: object
    opening: object = eqx.field(static=True)
    index: Int[Array, " m"]
    frame: Float[Array, "m 3 3"]
    scale: Float[Array, " m"]
    towards_eye: Float[Array, "obs m 3"]
    inv_d2: Float[Array, "obs m"]
    visible: Float[Array, "obs m"]


class _AreaSources(_Seen):
    """Lambertian area sources: fixed luminance (cd/m² at dimmer 1) and solid angle."""

    luminance: Float[Array, " m"]
    solid_angle: Float[Array, "obs m"]
    transmission: Float[Array, "obs m"]  # τ of the panes on the line of sight (1: none)


class GlareRatings(NamedTuple):
    """The ratings of every view (an observer's line of sight), at one design.

    ``ugr``, ``gr``, ``ti``: the ratings (TI in %, 0 for an observer without a road);
    ``ugr_sum``: ``Σ L² ω / p²``; ``background_cdm2``: L_b; ``veiling_cdm2``: the luminaires'
    veiling luminance L_vl; ``environment_cdm2``: L_av; ``road_cdm2``: the road's L_av.
    """

    ugr: Array
    gr: Array
    ti: Array
    ugr_sum: Array
    background_cdm2: Array
    veiling_cdm2: Array
    environment_cdm2: Array
    road_cdm2: Array


class GlareModel(eqx.Module):
    """The observers' fixed geometry and background per network; call it with a
    :class:`lumijax.design.Design` (host or traced) for the :class:`GlareRatings`.

    ``views`` are the observers' lines of sight in order (observer 0's fan, then observer
    1's, …); ``view_observer[v]`` is the observer of view v.
    """

    sources: tuple[_Sources, ...]
    areas: _AreaSources | None
    view_observer: Int[Array, " views"]
    background: Float[Array, "views net"]
    environment: Float[Array, "views net"]
    road: Float[Array, "obs net"]
    road_fixed: Float[Array, " obs"]
    view_direction: Float[Array, "views 3"]
    source_order: Int[Array, " src"]  # sources grouped by photometry → ``names`` order
    observers: tuple[str, ...] = eqx.field(static=True)
    azimuths_deg: tuple[tuple[float, ...], ...] = eqx.field(static=True)
    has_road: tuple[bool, ...] = eqx.field(static=True)
    names: tuple[str, ...] = eqx.field(static=True)  # luminaires, then area sources
    n_luminaires: int = eqx.field(static=True)

    @property
    def n_views(self) -> int:
        return int(self.view_observer.shape[0])

    def __call__(self, design) -> GlareRatings:
        """The ratings of every view at ``design`` (compiled once per model shape; inside a
        caller's jit or grad simply traced through)."""
        return _ratings(self, design)

    def contributions(self, design) -> tuple[Array, Array]:
        """Per view and source (``names`` order): the UGR terms ``L² ω / p²`` and the veiling
        luminance terms ``10 E / θ²`` (cd/m²), at ``design``."""
        small = self.n_views * len(self.names) <= _SMALL_TERMS
        return (_contributions_small() if small else _contributions)(self, design)

    def ratings(self, design) -> GlareRatings:
        """As calling the model, not compiled (for tracing inside another transformation)."""
        ugr_s, veil = self._terms(design, reduce=True)
        return self._rate(ugr_s, veil, jnp.asarray(design.dimmers))

    def at_aims(self, design) -> DimmerGlare:
        """The ratings at ``design``'s aims and levels for any dimmer vector (a
        :class:`DimmerGlare`: each network's terms summed once, at dimmer 1)."""
        ones = design.replace(dimmers=np.ones(len(design.networks)))
        # in the model's precision, not the caller's: the optimiser builds its constraints
        # under x64 (float64_scope), the results rate glare outside it, and JAX keys a
        # compiled program on that flag, so the same terms compiled twice (~4 s of the
        # demo's first run, contended). The terms are the model's dtype (float32 here)
        # either way; only the aim's rotation was figured in float64 before rounding.
        with jax.enable_x64(self.background.dtype == np.float64):
            # through contributions(): the same program as the results' (optimised or not by
            # the model's size), so a run that designs and then reports compiles it once
            ugr_terms, veil_terms = self.contributions(ones)
            return DimmerGlare(self, *_per_network(self, ugr_terms, veil_terms))

    def _source_network(self) -> Int[Array, " src"]:
        """Each source's network, in ``names`` order (as ``contributions`` gives them)."""
        parts = [g.network for g in self.sources]
        if self.areas is not None:
            parts.append(self.areas.network)
        if not parts:
            return jnp.zeros((0,), jnp.int32)
        return jnp.concatenate(parts)[self.source_order]

    def source_network_np(self) -> np.ndarray:
        """:meth:`_source_network` on the host (the same integers; op by op in JAX it compiles
        eight kernels, per shape and process)."""
        parts = [np.asarray(g.network) for g in self.sources]
        if self.areas is not None:
            parts.append(np.asarray(self.areas.network))
        if not parts:
            return np.zeros((0,), np.int32)
        return np.concatenate(parts)[np.asarray(self.source_order)]

    def _rate(self, ugr_s, veil, alpha) -> GlareRatings:
        """The ratings from each view's ``Σ L² ω / p²`` and veiling luminance at dimmers
        ``alpha`` (the backgrounds scale with them)."""
        lb = self.background @ alpha.astype(self.background.dtype)
        lav = self.environment @ alpha.astype(self.environment.dtype)
        road = self.road @ alpha.astype(self.road.dtype) + self.road_fixed
        road_v = road[self.view_observer]
        has = jnp.asarray(self.has_road)[self.view_observer]
        return GlareRatings(
            ugr=ugr_of_sum(ugr_s, lb), gr=glare_rating(veil, lav),
            ti=jnp.where(has, threshold_increment(veil, road_v), 0.0),
            ugr_sum=ugr_s, background_cdm2=lb, veiling_cdm2=veil, environment_cdm2=lav,
            road_cdm2=road_v)


    def worst(self, values) -> Array:
        """The largest of per-view ``values`` over each observer's views (its fan)."""
        return jax.ops.segment_max(values, self.view_observer, num_segments=len(self.observers))

    def _terms(self, design, *, reduce: bool):
        alpha = jnp.asarray(design.dimmers)
        tilt = jnp.deg2rad(jnp.asarray(design.tilt_deg))
        pan = jnp.deg2rad(jnp.asarray(design.pan_deg))
        spin = jnp.deg2rad(jnp.asarray(design.spin_deg))
        level = jnp.asarray(design.level)
        obs = self.view_observer
        ugr_parts, veil_parts = [], []
        for g in self.sources:
            idx = g.index
            dt = g.towards_eye.dtype
            rot = g.frame @ aim_rotation(tilt[idx], pan[idx], spin[idx]).astype(dt)
            local = jnp.einsum("mji,omj->omi", rot, g.towards_eye)  # Rᵀ w: luminaire frame
            cd = g.distribution.intensity(local) * (g.scale * level[idx].astype(dt))[None]
            area = projected_area(g.opening, local)
            lum = cd / area  # cd/m² toward the eye
            omega = area * g.inv_d2
            a = alpha[g.network].astype(dt)[None]
            seen = g.visible[obs]
            lv = lum[obs] * a
            front = (g.cos_sigma > 0).astype(dt)  # sources behind the eye do not glare
            # seen through panes the luminance is τ L (ω unchanged): the term goes as τ²
            ugr_parts.append(lv * lv * omega[obs] * (seen * seen) * front
                             / (g.position * g.position))
            e_eye = cd[obs] * a * g.inv_d2[obs] * g.cos_sigma * seen  # lx across the sight
            veil_parts.append(_veil(e_eye, g.angle_deg))
        if self.areas is not None:
            ar = self.areas
            lv = ar.luminance[None] * alpha[ar.network].astype(ar.luminance.dtype)[None]
            omega = ar.solid_angle[obs]
            tau = ar.transmission[obs]
            front = (ar.cos_sigma > 0).astype(lv.dtype)
            ugr_parts.append(lv * lv * omega * (tau * tau) * front / (ar.position * ar.position))
            veil_parts.append(_veil(lv * omega * tau * ar.cos_sigma, ar.angle_deg))
        if not ugr_parts:
            zero = jnp.zeros((self.n_views, 0))
            ugr_parts, veil_parts = [zero], [zero]
        if reduce:
            return (sum(jnp.sum(u, axis=1) for u in ugr_parts),
                    sum(jnp.sum(v, axis=1) for v in veil_parts))
        order = self.source_order
        return (jnp.concatenate(ugr_parts, axis=1)[:, order],
                jnp.concatenate(veil_parts, axis=1)[:, order])


class DimmerGlare(eqx.Module):
    """A :class:`GlareModel`'s ratings at fixed aims and levels, for any dimmer vector.

    Every term scales with its own network's dimmer α_k — ``L² ω / p²`` with α_k², the
    veiling luminance, L_b, L_av and the road's luminance with α_k — so the per-view sums of
    each network at dimmer 1 are all a new dimmer vector needs: a (views × networks) product,
    no luminaire touched (exact; ``GlareModel.at_aims`` makes it)."""

    model: GlareModel
    ugr_terms: Float[Array, "views net"]
    veil_terms: Float[Array, "views net"]

    def __call__(self, dimmers) -> GlareRatings:
        """The ratings of every view at ``dimmers`` (one per network, 0–1)."""
        return _dimmer_ratings(self, dimmers)

    def ratings(self, dimmers) -> GlareRatings:
        """As calling it, not compiled (for tracing inside another transformation)."""
        alpha = jnp.asarray(dimmers, self.ugr_terms.dtype)
        return self.model._rate(self.ugr_terms @ (alpha * alpha), self.veil_terms @ alpha,
                                alpha)


@eqx.filter_jit
def _per_network(model: GlareModel, ugr_terms, veil_terms):
    """Per view, each network's sum of the per-source terms: one program (op by op, the
    network lookup and the one-hot product compiled ten kernels, ~0.5 s of a constrained
    design's first call, contended)."""
    onehot = jax.nn.one_hot(model._source_network(), model.background.shape[1],
                            dtype=ugr_terms.dtype)
    return ugr_terms @ onehot, veil_terms @ onehot


@eqx.filter_jit
def _dimmer_ratings(superposed: DimmerGlare, dimmers) -> GlareRatings:
    return superposed.ratings(dimmers)


def worst_ratings(model: GlareModel, design) -> dict[str, Array]:
    """``{"ugr", "gr", "ti"}``: each observer's worst rating over its directions at ``design``
    (pure JAX, traceable: the constraint functions of a design to ``ugr_max``, ``gr_max``,
    ``ti_max``; a Design with traced leaves differentiates through it)."""
    r = model.ratings(design)
    return {"ugr": model.worst(r.ugr), "gr": model.worst(r.gr), "ti": model.worst(r.ti)}


@eqx.filter_jit
def _ratings(model: GlareModel, design) -> GlareRatings:
    return model.ratings(design)


def _terms_of(model: GlareModel, design):
    return model._terms(design, reduce=False)


_contributions = eqx.filter_jit(_terms_of)
#: Most (view, source) pairs whose terms compile without LLVM's optimisations: the program runs
#: once per results, and optimising it costs more than it saves (the demo's 32 views × 230
#: fittings: compile 3.9 → 2.4 s, run 0.9 → 1.2 ms).
_SMALL_TERMS = 1 << 16


@functools.cache
def _contributions_small():
    return eqx.filter_jit(  # type: ignore[call-overload]
        _terms_of, compiler_options=_executables.unoptimised())


def _veil(e_eye, angle_deg):
    theta = jnp.maximum(angle_deg, VEILING_ANGLE_RANGE_DEG[0])
    return 10.0 * e_eye / (theta * theta)


def build_glare_model(scene, observers, lighting=None, *, rays: int = 512,
                      grid_lux: dict | None = None, shadows: bool = True,
                      source=None) -> GlareModel:
    """The :class:`GlareModel` of ``observers`` (:class:`~lumijax.glare.Observer`) in
    ``scene``, with the background from ``lighting`` (a :class:`~lumijax.lighting.
    LightingSolution`; None or without patches: L_b = L_av = 0, flagged by the results).

    ``grid_lux`` maps a grid name to its ``(networks, points)`` illuminance (lx) at dimmer 1,
    for the observers' ``road_grid``. Raises GeometryError naming the observer where an eye is
    inside a luminaire's luminous extent; warns (:class:`NearSourceWarning`) where it is
    closer than the luminaire's size, and (:class:`NoLuminousSizeWarning`) once per
    photometry without luminous dimensions that an observer sees.
    """
    observers = tuple(observers)
    k = len(scene.networks)
    net_index = {n: i for i, n in enumerate(scene.network_names)}
    eyes = np.array([o.eye for o in observers], np.float64).reshape(-1, 3)
    view_obs = np.concatenate([np.full(len(o.directions), i) for i, o in
                               enumerate(observers)]).astype(np.int32) if observers else (
        np.zeros(0, np.int32))
    forward = np.concatenate([o.directions for o in observers]) if observers else (
        np.zeros((0, 3)))
    caster = scene.raycaster if len(scene.triangles) else None
    seen_by = caster if shadows else None  # shadows=False: nothing hides a luminaire
    levels = np.ones(len(scene.luminaires)) if scene.levels is None else np.asarray(
        scene.levels, np.float64)

    by_phot: dict[str, list[int]] = {}
    for i, lum in enumerate(scene.luminaires):
        by_phot.setdefault(lum.photometry, []).append(i)
    sources = []
    for name, idx in by_phot.items():
        phot = scene.photometries[name]
        lums = [scene.luminaires[i] for i in idx]
        pos = np.array([lum.position for lum in lums])
        off = eyes[:, None, :] - pos[None]  # (obs, m, 3) luminaire → eye
        d2 = np.maximum(np.einsum("omk,omk->om", off, off), np.finfo(np.float64).tiny)
        dist = np.sqrt(d2)
        _check_near(observers, lums, dist, opening_size(phot.opening), source)
        w = off / dist[..., None]
        visible = np.ones(d2.shape)
        if seen_by is not None and len(observers):
            visible = _seen_fraction(caster, np.repeat(eyes, len(lums), axis=0),
                                     np.tile(pos, (len(observers), 1))).reshape(d2.shape)
        if phot.opening.is_point and len(observers) and visible.any():
            warnings.warn(f"photometry {name!r} gives no luminous dimensions: its glare is "
                          f"computed for a sphere of {opening_size(phot.opening):g} m "
                          "(lumijax.glare.POINT_DIAMETER_M)", NoLuminousSizeWarning,
                          stacklevel=2)
        p, cos_s, ang = _view_geometry(-w[view_obs], forward)
        base = np.array([lum.scale / lv if lv > 0 else (
            scene.rated_scales[i] if scene.rated_scales is not None else lum.scale)
            for lum, i, lv in zip(lums, idx, levels[idx], strict=True)])
        sources.append(_Sources(
            distribution=phot.distribution, opening=phot.opening,
            index=to_device(np.asarray(idx), jnp.int32),
            network=to_device(np.asarray([net_index[lum.network] for lum in lums]), jnp.int32),
            frame=to_device(np.array([lum.frame_rotation for lum in lums])),
            scale=to_device(base), towards_eye=to_device(w), inv_d2=to_device(1.0 / d2),
            visible=to_device(visible), position=to_device(p),
            cos_sigma=to_device(cos_s), angle_deg=to_device(ang)))

    areas = _area_sources(scene, eyes, view_obs, forward, seen_by, net_index)
    background, environment = _background(lighting, eyes[view_obs], forward, caster, rays, k)
    road, road_fixed = _road(scene, observers, grid_lux, caster, k, source)
    names = tuple(lum.name for lum in scene.luminaires) + tuple(a.name for a in
                                                               scene.area_sources)
    grouped = np.concatenate([np.asarray(i, np.int64) for i in by_phot.values()]
                             + [len(scene.luminaires) + np.arange(len(scene.area_sources))
                                if areas is not None else np.zeros(0, np.int64)])
    return GlareModel(
        source_order=to_device(np.argsort(grouped, kind="stable").astype(np.int32)),
        sources=tuple(sources), areas=areas, view_observer=to_device(view_obs),
        background=to_device(background), environment=to_device(environment),
        road=to_device(road), road_fixed=to_device(road_fixed),
        view_direction=to_device(forward), observers=tuple(o.name for o in observers),
        azimuths_deg=tuple(tuple(o.azimuths_deg) for o in observers),
        has_road=tuple(o.road_luminance_cdm2 is not None or o.road_grid is not None
                       for o in observers),
        names=names, n_luminaires=len(scene.luminaires))


def _view_geometry(to_source, forward):
    """Position index, cos σ and σ (deg) of unit eye → source directions ``(views, m, 3)``;
    sources behind the eye (σ ≥ 90°) get cos σ = 0 and so add nothing."""
    f = forward[:, None, :]
    p = position_index(to_source, f)
    sigma, _, _, _ = view_angles(to_source, f)
    cos_s = np.maximum(np.cos(np.radians(sigma)), 0.0)
    return p, np.where(sigma < 90.0, cos_s, 0.0), sigma


def _check_near(observers, lums, dist, size, source) -> None:
    """An eye within half a luminaire's size of its centre is in it (an error); within its
    size, the far-field ω = A/d² is rough (a warning)."""
    if not len(observers):
        return
    o, m = np.unravel_index(int(np.argmin(dist)), dist.shape)
    d = float(dist[o, m])
    obs, lum = observers[o], lums[m]
    if d < 0.5 * size:
        raise GeometryError(
            f"observer {obs.name!r}'s eye is {d:.3g} m from luminaire {lum.name!r}, inside its "
            f"luminous extent ({size:.3g} m): move the eye or the luminaire",
            file=source, key=f"{obs.key}.position" if obs.key else obs.name)
    if d < size:
        warnings.warn(f"observer {obs.name!r}'s eye is {d:.3g} m from luminaire {lum.name!r}, "
                      f"closer than its size ({size:.3g} m): its solid angle and position "
                      "index are rough", NearSourceWarning, stacklevel=3)


def _area_sources(scene, eyes, view_obs, forward, caster, net_index):
    if not scene.area_sources or not len(eyes):
        return None
    centre = np.array([a.origin + 0.5 * (a.u + a.v) for a in scene.area_sources])
    normal = np.array([a.normal for a in scene.area_sources])
    area = np.array([a.area for a in scene.area_sources])
    off = eyes[:, None, :] - centre[None]
    d2 = np.einsum("omk,omk->om", off, off)
    w = off / np.sqrt(d2)[..., None]
    cos_e = np.maximum(np.einsum("omk,mk->om", w, normal), 0.0)  # front faces only
    visible = np.ones(d2.shape)
    if caster is not None:
        visible = _seen_fraction(caster, np.repeat(eyes, len(centre), axis=0),
                                 np.tile(centre, (len(eyes), 1))).reshape(d2.shape)
    p, cos_s, ang = _view_geometry(-w[view_obs], forward)
    lum = np.array([a.exitance / math.pi for a in scene.area_sources])
    return _AreaSources(
        network=to_device(np.asarray([net_index[a.network] for a in scene.area_sources]),
                          jnp.int32),
        luminance=to_device(lum), solid_angle=to_device(area * cos_e / d2 * (visible > 0)),
        transmission=to_device(visible),
        position=to_device(p), cos_sigma=to_device(cos_s), angle_deg=to_device(ang))


def _seen_fraction(caster, eyes, targets) -> np.ndarray:
    """Per segment eye → source centre, the fraction of the source's luminance the eye sees:
    0 behind an opaque triangle, else the product of τ(θ) of the clear panes crossed
    (``GlazedCaster.transmission``, θ the line of sight's incidence on each pane); 1 or 0 for
    a caster without glass."""
    if hasattr(caster, "transmission"):
        return np.asarray(caster.transmission(eyes, targets), np.float64)
    return (~np.asarray(caster.occluded(eyes, targets))).astype(np.float64)


def _background(lighting, eyes, forward, caster, rays, k):
    """``(L_b, L_av)`` per view and network (cd/m²) from the coarse patches' radiosity."""
    n = len(eyes)
    if lighting is None or lighting.coarse.patches is None or caster is None or not n:
        return np.zeros((n, k)), np.zeros((n, k))
    from ..radiosity import build_gather

    gather = build_gather(eyes, forward, lighting.coarse.patches, caster, rays=rays, seed=7)
    e_ind = np.asarray(gather(to_device(np.asarray(lighting.coarse.radiosity, np.float64).T)),
                       np.float64)  # (views, net) lx
    cover = gather.coverage[:, None]
    background = e_ind / math.pi
    environment = np.where(cover > 0, e_ind / (math.pi * np.maximum(cover, 1e-300)), 0.0)
    return background, environment


def _road(scene, observers, grid_lux, caster, k, source):
    """Per observer, the road's average luminance: per network from its road grid
    (``mean ρ E / π``, ρ from the material under each point), or the given constant."""
    road = np.zeros((len(observers), k))
    fixed = np.zeros(len(observers))
    for i, o in enumerate(observers):
        if o.road_luminance_cdm2 is not None:
            fixed[i] = o.road_luminance_cdm2
        elif o.road_grid is not None:
            g = scene.grid(o.road_grid)
            rho = surface_reflectance(scene, g.points, g.normals, caster, source=source,
                                      key=f"{o.key}.road_grid")
            lux = np.asarray(grid_lux[o.road_grid], np.float64) if grid_lux else None
            if lux is None:
                raise GeometryError(f"no illuminance for road grid {o.road_grid!r}",
                                    key=f"{o.key}.road_grid")
            road[i] = (lux * rho[None]).mean(axis=1) / math.pi
    return road, fixed


def surface_reflectance(scene, points, normals, caster, *, source=None, key=None):
    """Luminous reflectance of the surface under each grid point (along −normal), from the
    surface's own material. GeometryError naming ``key`` where a point lies over nothing."""
    if caster is None:
        raise GeometryError("the road grid lies over no surface (the scene has none)",
                            file=source, key=key)
    n = np.asarray(normals, np.float64)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    lift = 1e-3 * caster.extent
    tri, dist = caster.first_hit(np.asarray(points) + lift * n, -n)
    if np.any(tri < 0) or np.any(dist > 10 * lift + 0.05 * caster.extent):
        bad = int(np.argmax((tri < 0) | (dist > 10 * lift + 0.05 * caster.extent)))
        raise GeometryError(f"road grid point {bad} lies over no surface: TI needs the road's "
                            "luminance, ρ E / π of the surface under the grid", file=source,
                            key=key)
    rho = np.array([m.luminous_reflectance for m in scene.materials])
    return rho[scene.triangles.material[tri]]
