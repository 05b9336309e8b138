"""A study's glare at one design: the ratings per observer and direction, the worst direction,
the luminaires that contribute most, and the results.json entry (docs/results.md, "glare")."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from ..errors import SolveError
from ._model import GlareModel, GlareRatings
from ._ratings import SOLID_ANGLE_RANGE_SR
from ._surfaces import SeenSurfaces

__all__ = ["Glare", "TOP_CONTRIBUTORS"]

#: How many luminaires results.json names per observer as the largest contributors.
TOP_CONTRIBUTORS = 5


@dataclass(frozen=True, eq=False)
class Glare:
    """The observers' :class:`GlareModel` at a design (a :class:`lumijax.design.Design`).

    ``ratings`` are the host (float64) :class:`GlareRatings` per view; ``at(design)`` is the
    same model at another design (exact: no ray, dimmers, aims and levels alike).
    ``surfaces`` (a :class:`~lumijax.glare.SeenSurfaces`, None without patches or named
    surfaces) with ``radiosity`` (``(networks, patches)`` lm/m² at dimmer 1) give the
    luminance of the named surfaces each observer sees, at the design's dimmers.

    Where ``at`` changes only the dimmers, the new record rates by superposition
    (``GlareModel.at_aims``: each network's terms at dimmer 1 summed once, ~0.3 ms for the
    courtyard's 800 views × 3,000 luminaires where the full model takes ~50 ms), exact.
    """

    model: GlareModel
    design: Any
    observers: tuple = ()
    surfaces: SeenSurfaces | None = None
    radiosity: np.ndarray | None = None
    #: Each network's terms at dimmer 1 and this record's aims and levels (a :class:`_Unit`,
    #: computed when first asked), shared by the records ``at`` makes at other dimmers
    unit: _Unit | None = None

    def at(self, design) -> Glare:
        """The same observers at ``design`` (exact: by superposition when only the dimmers
        differ from this record's design, else through the full model). Nothing is rated
        until the new record is asked (a constrained design lights its result with
        ``Results.at`` and reads no glare there unless it bounds it)."""
        if self.design.only_dimmers_differ(design):
            return dataclasses.replace(self, design=design, unit=self._unit)
        return dataclasses.replace(self, design=design, unit=None)

    @cached_property
    def _unit(self) -> _Unit:
        return self.unit if self.unit is not None else _Unit(self.model, self.design)

    @cached_property
    def ratings(self) -> GlareRatings:
        if self.unit is not None:
            rated = self.unit.superposed(np.asarray(self.design.dimmers, np.float64))
        else:
            rated = self.model(self.design)
        return GlareRatings(*(np.asarray(a, np.float64) for a in rated))

    @cached_property
    def _contributions(self) -> tuple[np.ndarray, np.ndarray]:
        if self.unit is not None:  # L² ω / p² scales with α², the veiling luminance with α
            u, v, net = self.unit.terms
            a = np.asarray(self.design.dimmers, np.float64)[net]
            return u * (a * a)[None], v * a[None]
        u, v = self.model.contributions(self.design)
        return np.asarray(u, np.float64), np.asarray(v, np.float64)

    def views_of(self, observer: int) -> np.ndarray:
        return np.flatnonzero(np.asarray(self.model.view_observer) == observer)

    def summary(self) -> list[dict[str, Any]]:
        """One row per observer: its worst UGR, GR and TI (None where not rated) and the
        azimuth (deg) of the worst GR direction; what ``lumijax run`` prints."""
        out = []
        for i, name in enumerate(self.model.observers):
            d = self._observer(i)
            out.append({"observer": name, "directions": len(d["directions"]),
                        **{r: d["worst"][r]["value"] if d["worst"].get(r) else None
                           for r in ("ugr", "gr", "ti")},
                        "worst_gr_azimuth_deg": (d["worst"]["gr"] or {}).get("azimuth_deg")})
        return out

    def to_dict(self) -> dict[str, Any]:
        """results.json's ``glare``: ``{observer: {...}}`` (docs/results.md)."""
        out = {name: self._observer(i) for i, name in enumerate(self.model.observers)}
        surfaces = self.surface_luminance()
        for name, entry in out.items():
            if surfaces is not None:
                entry["surfaces"] = surfaces.get(name, {})
        _check_finite(out, "glare")
        return out

    def surface_luminance(self) -> dict[str, dict[str, dict]] | None:
        """Per observer, each named surface it sees: its largest and mean luminance (cd/m²) at
        the design's dimmers, and its ``max_luminance_cdm2`` limit with whether it is met."""
        if self.surfaces is None or self.radiosity is None:
            return None
        b = np.asarray(self.design.dimmers, np.float64) @ np.asarray(self.radiosity, np.float64)
        return self.surfaces.to_dict(b)

    def _observer(self, i: int) -> dict[str, Any]:
        r = self.ratings
        m = self.model
        views = self.views_of(i)
        obs = self.observers[i] if i < len(self.observers) else None
        ugr_terms, veil_terms = self._contributions
        seen_omega = self._seen_solid_angles()
        dirs = []
        for j, v in enumerate(views):
            flags = []
            lb, lav = r.background_cdm2[v], r.environment_cdm2[v]
            if not lb > 0:
                flags.append("no_background")  # inter-reflection off: UGR undefined
            if not r.ugr_sum[v] > 0:
                flags.append("no_source_seen")
            small, large = seen_omega(v)
            if small:
                flags.append("small_sources")
            if large:
                flags.append("large_sources")
            entry = {
                "azimuth_deg": float(m.azimuths_deg[i][j]),
                "direction": [float(x) for x in np.asarray(m.view_direction)[v]],
                "ugr": float(r.ugr[v]) if lb > 0 else None,
                "gr": float(r.gr[v]) if lav > 0 else None,
                "background_cdm2": float(lb),
                "environment_cdm2": float(lav),
                "veiling_cdm2": float(r.veiling_cdm2[v]),
                "flags": flags,
            }
            if m.has_road[i]:
                entry["ti_percent"] = float(r.ti[v])
                entry["road_cdm2"] = float(r.road_cdm2[v])
            if small or large:
                entry["outside_ugr_range"] = sorted(set(small) | set(large))[:10]
            dirs.append(entry)
        worst: dict = {}
        for rating, key in (("ugr", "ugr"), ("gr", "gr"), ("ti", "ti_percent")):
            vals = [(d[key], j) for j, d in enumerate(dirs) if d.get(key) is not None]
            if not vals:
                worst[rating] = None
                continue
            value, j = max(vals)
            worst[rating] = {"value": value, "direction": j,
                             "azimuth_deg": dirs[j]["azimuth_deg"]}
        top = {}
        for rating, terms in (("ugr", ugr_terms), ("gr", veil_terms)):
            w = worst.get(rating)
            j = w["direction"] if w else 0
            row = terms[views[j]] if len(views) else np.zeros(0)
            total = float(row.sum())
            order = np.argsort(-row, kind="stable")[:TOP_CONTRIBUTORS]
            top[rating] = [{"name": m.names[q], "share": float(row[q] / total)}
                           for q in order if total > 0 and row[q] > 0]
        return {"eye": [] if obs is None else [float(x) for x in obs.eye],
                "directions": dirs, "worst": worst, "top_luminaires": top}

    def _seen_solid_angles(self):
        """For a view: the names of the seen luminaires whose solid angle is outside CIE 117's
        range (small, large)."""
        ugr_terms, _ = self._contributions
        omega = self._omega
        lo, hi = SOLID_ANGLE_RANGE_SR
        names = self.model.names

        def of(v):
            seen = ugr_terms[v] > 0
            small = [names[q] for q in np.flatnonzero(seen & (omega[v] < lo))]
            large = [names[q] for q in np.flatnonzero(seen & (omega[v] > hi))]
            return small, large

        return of

    @cached_property
    def _omega(self) -> np.ndarray:
        """Solid angle (sr) of every source as each view sees it, at the design."""
        return self._geometry[0]

    @cached_property
    def _geometry(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per view and source (``names`` order), at the design: solid angle (sr), position
        index, unit direction eye → source (world)."""
        import jax

        from ..scene._frames import aim_rotation
        from ._area import projected_area

        m, d = self.model, self.design
        obs = np.asarray(m.view_observer)
        n = len(m.names)
        omega = np.zeros((m.n_views, n))
        pos = np.ones((m.n_views, n))
        dirs = np.zeros((m.n_views, n, 3))
        tilt, pan, spin = (np.radians(np.asarray(getattr(d, f), np.float64))
                           for f in ("tilt_deg", "pan_deg", "spin_deg"))
        for g in m.sources:
            idx = np.asarray(g.index)
            rot = np.asarray(g.frame) @ np.asarray(aim_rotation(tilt[idx], pan[idx], spin[idx],
                                                                xp=np))
            w = np.asarray(g.towards_eye)
            local = np.einsum("mji,omj->omi", rot, w)
            # in the model's dtype, as jnp.asarray(local) gave it, but on the host (xp=np):
            # the same bits, and no eager kernel per shape (~25 in the demo's results)
            dt = jax.dtypes.canonicalize_dtype(np.float64)
            area = projected_area(g.opening, np.asarray(local, dt), xp=np)
            omega[:, idx] = (area * np.asarray(g.inv_d2))[obs]
            pos[:, idx] = np.asarray(g.position)
            dirs[:, idx] = -w[obs]
        if m.areas is not None:
            omega[:, m.n_luminaires:] = np.asarray(m.areas.solid_angle)[obs]
            pos[:, m.n_luminaires:] = np.asarray(m.areas.position)
        return omega, pos, dirs

    def seen_sources(self, view: int) -> list[dict[str, Any]]:
        """The sources view ``view`` rates (in front, not hidden, lit), brightest first: name,
        unit direction eye → source (world; zero for area sources), luminance (cd/m², at the
        design's dimmers), solid angle (sr) and position index."""
        terms = self._contributions[0][view]
        omega, pos, dirs = (a[view] for a in self._geometry)
        out = []
        for q in np.flatnonzero(terms > 0):
            lum = float(np.sqrt(terms[q] * pos[q] ** 2 / omega[q]))
            out.append({"name": self.model.names[q], "direction": dirs[q].tolist(),
                        "luminance_cdm2": lum, "solid_angle_sr": float(omega[q]),
                        "position_index": float(pos[q])})
        return sorted(out, key=lambda x: -x["luminance_cdm2"])


def _check_finite(value, key: str) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _check_finite(v, f"{key}.{k}")
    elif isinstance(value, list):
        for j, v in enumerate(value):
            _check_finite(v, f"{key}[{j}]")
    elif isinstance(value, float) and not np.isfinite(value):
        raise SolveError(f"{value} is not finite: the glare computation overflowed; check the "
                         "study's magnitudes (flux_lm, multiplier)", key=f"results.json: {key}")


class _Unit:
    """A :class:`GlareModel`'s terms at dimmer 1 and one design's aims and levels, each computed
    when first asked and then kept: ``superposed`` (a :class:`~lumijax.glare.DimmerGlare`, the
    ratings at any dimmers) and ``terms`` (per view and source, the UGR and veiling terms and
    each source's network), for the :class:`Glare` records of that design at other dimmers."""

    def __init__(self, model: GlareModel, design):
        self.model, self.design = model, design

    @cached_property
    def superposed(self):
        return self.model.at_aims(self.design)

    @cached_property
    def terms(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ones = self.design.replace(dimmers=np.ones(len(self.design.networks)))
        u, v = self.model.contributions(ones)
        return (np.asarray(u, np.float64), np.asarray(v, np.float64),
                self.model.source_network_np())
