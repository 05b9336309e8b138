"""The verdict: which standard applies where, and per criterion the computed value, the limit,
pass or fail and the margin (docs/compliance.md).

:class:`ComplianceModel` holds the per-network light at dimmer 1 of every grid a criterion
reads, the maintenance factor of each network, the power model and the obtrusive-light terms;
:meth:`ComplianceModel.quantities` is a pure JAX function of the dimmer vector (maintained
values, differentiable, superposing), the constrained-design work's constraints.
:class:`Compliance` is that model judged at one dimmer vector (what results.json, the command
line and the report show).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..errors import ConfigError
from ..lighting import GATHER_RAYS
from . import _tables
from ._energy import PowerModel, leni_kwh_per_m2, power_model
from ._maintenance import network_maintenance
from ._obtrusive import intensity_toward, reflected_upward_flux, upward_flux

__all__ = ["Criterion", "ComplianceModel", "Compliance", "compliance_model",
           "evaluate_compliance"]


@dataclass(frozen=True)
class Criterion:
    """One requirement: ``quantity`` of ``area`` must be at least (``sense`` "min") or at most
    ("max") ``limit`` (``unit``). ``spec`` says how the quantity is computed (None: not
    computed, ``note`` says why)."""

    standard: str
    area: str
    quantity: str
    unit: str
    limit: float | None  # None: reported, not judged
    sense: str
    spec: tuple | None
    source: str = ""
    when: str = ""
    note: str = ""

    @property
    def key(self) -> str:
        return f"{self.area}.{self.quantity}" + (f" ({self.when})" if self.when else "")


class ComplianceModel(eqx.Module):
    """The compliance quantities as JAX functions of the dimmers (see module docstring)."""

    grids: dict  # name → (networks, points) lx at dimmer 1, initial
    weights: dict  # name → (points,) weights of a facade's luminance mean (ρ·a/π/Σa)
    mf: Float[Array, " net"]
    power: PowerModel | None
    ulr_up: Float[Array, " net"]
    ulr_total: Float[Array, " net"]
    ulr_reflected: Float[Array, " net"]  # lm at dimmer 1 reflected toward the sky
    intensity: dict  # sensitive point → (luminaires,) cd at dimmer 1
    lum_network: Array
    post_mask: Float[Array, " net"]
    post_value: Float[Array, " net"]
    glare: Any  # lumijax.glare.GlareModel of the study's observers, or None
    design: Any  # the Design whose dimmers the glare ratings are evaluated at (or None)
    criteria: tuple = eqx.field(static=True)
    areas_m2: dict = eqx.field(static=True)
    energy: Any = eqx.field(static=True)
    networks: tuple = eqx.field(static=True)

    def post_curfew(self, dimmers: Float[Array, " net"]) -> Float[Array, " net"]:
        """The dimmers after curfew: ``after_curfew``'s networks at its values, the others
        as ``dimmers``."""
        d = jnp.asarray(dimmers)
        return self.post_mask * self.post_value + (1.0 - self.post_mask) * d

    def quantities(self, dimmers: Float[Array, " net"], *, maintained: bool = True
                   ) -> dict[str, Float[Array, ""]]:
        """Every computed criterion's quantity at ``dimmers`` (maintained values, or initial
        with ``maintained=False``), keyed by :attr:`Criterion.key`."""
        d = jnp.asarray(dimmers)
        f = self.mf if maintained else jnp.ones_like(self.mf)
        out = {}
        # per phase (before / after curfew), each grid's light and the glare ratings are
        # computed once and shared by the criteria that read them (a building's areas all
        # read one glare model: one evaluation, not one per area)
        phases: dict[bool, dict] = {}
        for c in self.criteria:
            if c.spec is not None:
                post = c.when == "after curfew"
                if post not in phases:
                    phases[post] = {}
                dd = self.post_curfew(d) if post else d
                out[c.key] = self._quantity(c.spec, dd, f, phases[post])
        return out

    def _quantity(self, spec: tuple, d, f, cache: dict):
        kind = spec[0]
        w = d * f

        def lux(name):
            if name not in cache:
                cache[name] = w @ self.grids[name]
            return cache[name]

        if kind == "mean":
            return jnp.mean(lux(spec[1]))
        if kind == "u0":
            e = lux(spec[1])
            m = jnp.mean(e)
            return jnp.where(m > 0, jnp.min(e) / jnp.where(m > 0, m, 1.0), 0.0)
        if kind == "ratio":  # modelling Ēz/Ēh
            ez, eh = jnp.mean(lux(spec[1])), jnp.mean(lux(spec[2]))
            return jnp.where(eh > 0, ez / jnp.where(eh > 0, eh, 1.0), 0.0)
        if kind == "max":
            return jnp.max(lux(spec[1]))
        if kind == "min":
            return jnp.min(lux(spec[1]))
        if kind == "luminance":
            return jnp.sum(self.weights[spec[1]] * lux(spec[1]))
        if kind == "intensity":
            return jnp.max(self.intensity[spec[1]] * w[self.lum_network])
        if kind == "ulr":
            tot = jnp.sum(w * self.ulr_total)
            up = self.ulr_up + (self.ulr_reflected if spec[1:] == ("reflected",) else 0.0)
            return jnp.where(tot > 0, jnp.sum(w * up) / jnp.where(tot > 0, tot, 1.0), 0.0)
        if kind == "power_density":
            return self.power.total_w(d, spec[1]) / self.areas_m2[spec[2]]
        if kind == "leni":
            return leni_kwh_per_m2(self.power.total_w(d, spec[1]), self.areas_m2[spec[2]],
                                   self.energy)
        if kind in ("ugr", "gr"):  # the worst over the area's observers' views
            if ("glare",) not in cache:
                cache[("glare",)] = self.glare.ratings(self.design.replace(dimmers=w))
            r = cache[("glare",)]
            views = jnp.isin(self.glare.view_observer, jnp.asarray(spec[1]))
            return jnp.max(jnp.where(views, r.ugr if kind == "ugr" else r.gr, -jnp.inf))
        if kind == "constant":
            return jnp.asarray(spec[1])
        raise ValueError(f"unknown quantity {kind!r}")


@dataclass(frozen=True)
class Compliance:
    """The model judged at ``dimmers``: one row per criterion (docs/compliance.md)."""

    model: ComplianceModel = field(repr=False)
    dimmers: np.ndarray
    rows: tuple[dict, ...]

    @classmethod
    def judge(cls, model: ComplianceModel, dimmers) -> Compliance:
        d = np.asarray(dimmers, np.float64)
        values = {k: float(v) for k, v in model.quantities(jnp.asarray(d)).items()}
        initial = {k: float(v) for k, v in model.quantities(jnp.asarray(d),
                                                            maintained=False).items()}
        rows = []
        for c in model.criteria:
            row: dict[str, Any] = {"standard": c.standard, "area": c.area,
                                   "quantity": c.quantity, "unit": c.unit,
                                   "limit": c.limit, "sense": c.sense, "when": c.when,
                                   "source": c.source}
            if c.spec is None:
                row.update(value=None, initial=None, passed=None, margin=None,
                           status="not computed", note=c.note)
            elif c.limit is None:
                row.update(value=values[c.key], initial=initial[c.key], passed=None,
                           margin=None, status="reported", note=c.note)
            else:
                v = values[c.key]
                margin = v - c.limit if c.sense == "min" else c.limit - v
                # judged on the value as shown (4 significant figures): a limit met to
                # rounding, like an E0 zone's 0 lx, is met
                passed = bool(margin >= -1e-9 * max(abs(c.limit), 1.0))
                row.update(value=v, initial=initial[c.key], passed=passed, margin=margin,
                           margin_relative=(margin / c.limit) if c.limit else None,
                           status="pass" if passed else "fail", note=c.note)
            rows.append(row)
        return cls(model, d, tuple(rows))

    def at(self, dimmers) -> Compliance:
        """The same criteria judged at another dimmer vector (superposition, no solve)."""
        return Compliance.judge(self.model, dimmers)

    @property
    def compliant(self) -> bool:
        """True when every computed criterion passes (those not computed are listed apart)."""
        return all(r["passed"] is not False for r in self.rows)

    @property
    def not_computed(self) -> list[dict]:
        return [r for r in self.rows if r["status"] == "not computed"]

    def to_dict(self) -> dict[str, Any]:
        """The ``compliance`` entry of results.json."""
        return {
            "compliant": self.compliant,
            "maintenance_factor": {n: float(m) for n, m in zip(
                self.model.networks, np.asarray(self.model.mf), strict=True)},
            "criteria": [dict(r) for r in self.rows],
            "not_computed": [f"{r['area']}.{r['quantity']}" for r in self.not_computed],
        }

    def table(self) -> str:
        """The verdict as a fixed-width text table (the command line prints it)."""
        head = f"{'standard':<12} {'area':<20} {'criterion':<22} {'value':>10} " \
               f"{'limit':>16} {'result':<12}"
        lines = [head, "-" * len(head)]
        for r in self.rows:
            crit = r["quantity"] + (f" {r['when']}" if r["when"] else "")
            lim = "—" if r["limit"] is None else (
                ("≥ " if r["sense"] == "min" else "≤ ") + f"{r['limit']:.4g} {r['unit']}")
            val = "—" if r["value"] is None else f"{r['value']:.4g}"
            lines.append(f"{r['standard']:<12} {r['area']:<20} {crit:<22} {val:>10} "
                         f"{lim:>16} {r['status']:<12}")
        failed = [f"{r['area']}.{r['quantity']}" + (f" {r['when']}" if r["when"] else "")
                  for r in self.rows if r["passed"] is False]
        lines.append(f"not compliant: {len(failed)} criteria fail ({', '.join(failed)})"
                     if failed else "compliant: every computed criterion passes")
        if self.not_computed:
            lines.append("not computed: " + ", ".join(
                f"{r['area']}.{r['quantity']} ({r['note']})" for r in self.not_computed))
        return "\n".join(lines)


def _grid_names(cfg) -> dict[str, int]:
    return {g.name: i for i, g in enumerate(cfg.grids)}


def compliance_model(study, results) -> ComplianceModel:
    """The :class:`ComplianceModel` of a study's ``[compliance]`` table and its results."""
    from ..scene._standard_grids import surface_samples

    cfg = study.config
    comp = cfg.compliance
    src = cfg.source
    sc = results.lighting.scene if results.lighting is not None else study.scene
    names = tuple(results.networks)
    grids_idx = _grid_names(cfg)

    def need_grid(name, key, kinds=None):
        if name not in grids_idx:
            raise ConfigError(f"unknown grid {name!r}; grids: {', '.join(grids_idx) or 'none'}",
                              file=src, key=key)
        kind = cfg.grids[grids_idx[name]].kind
        if kinds is not None and kind not in kinds:
            raise ConfigError(f"grid {name!r} is a {kind} grid; expected {' or '.join(kinds)}",
                              file=src, key=key)
        if not len(results.grids[name].points):
            raise ConfigError(f"grid {name!r} has no points", file=src, key=key)
        return name

    grids: dict[str, Array] = {}
    weights: dict[str, Array] = {}
    areas_m2: dict[str, float] = {}
    criteria: list[Criterion] = []

    def use(name):
        grids[name] = jnp.asarray(results.grids[name].by_network_lux)
        return name

    for ai, a in enumerate(comp.areas):
        key = f"compliance.areas[{ai}]"
        task = use(need_grid(a.grid, f"{key}.grid"))
        if a.standard == "EN 13201-2":
            criteria.extend(_road_criteria(a, task))
            areas_m2[a.name] = a.area_m2 if a.area_m2 is not None else _grid_area(
                cfg.grids[grids_idx[task]], src, f"{key}.area_m2")
            continue
        table = _tables.EN12464_1 if a.standard == "EN 12464-1" else _tables.EN12464_2
        row = None
        if a.reference is not None:
            if a.reference not in table:
                raise ConfigError(f"{a.standard} has no transcribed row {a.reference!r} "
                                  f"(rows: {', '.join(table)}); give the values (em_lux, u0, "
                                  "...) instead", file=src, key=f"{key}.reference")
            row = table[a.reference]
        ref = f"{a.standard} {a.reference}" if row is not None else "given"

        def pick(given, from_row, ref=ref):
            return (given, "given") if given is not None else (
                (from_row, ref) if from_row is not None else (None, ""))

        em, em_src = pick(a.em_lux, row.em_lux if row else None)
        u0, u0_src = pick(a.u0, row.u0 if row else None)
        glare, g_src = pick(a.ugr_l if a.standard == "EN 12464-1" else a.gr_l,
                            row.glare if row else None)
        ra, ra_src = pick(a.ra, row.ra if row else None)
        ez, ez_src = pick(a.ez_lux, row.ez_lux if row else None)
        std = a.standard
        if em is None and u0 is None:
            raise ConfigError("no Ēm or U0 to judge: give 'reference' (a table row) or "
                              "'em_lux' / 'u0'", file=src, key=key)
        if em is not None:
            criteria.append(Criterion(std, a.name, "Em", "lx", em, "min", ("mean", task),
                                      em_src))
        if u0 is not None:
            criteria.append(Criterion(std, a.name, "U0", "", u0, "min", ("u0", task), u0_src))
        if glare is not None:
            gname = "UGR_L" if std == "EN 12464-1" else "GR_L"
            gspec, why = _glare_spec(results, a, "ugr" if std == "EN 12464-1" else "gr")
            criteria.append(Criterion(std, a.name, gname, "", glare, "max", gspec, g_src,
                                      note=why))
        if ra is not None:
            value, why = _ra(sc, a.networks)
            criteria.append(Criterion(std, a.name, "Ra", "", ra, "min",
                                      None if value is None else ("constant", value), ra_src,
                                      note=why))
        if ez is not None or a.cylindrical is not None:
            if a.cylindrical is None:
                criteria.append(Criterion(std, a.name, "Ez", "lx", ez, "min", None, ez_src,
                                          note="no 'cylindrical' sensor grid given"))
            else:
                cyl = use(need_grid(a.cylindrical, f"{key}.cylindrical", ("sensor",)))
                if cfg.grids[grids_idx[cyl]].sensor != "cylindrical":
                    raise ConfigError(f"grid {cyl!r} is a {cfg.grids[grids_idx[cyl]].sensor} "
                                      "sensor; Ēz needs a cylindrical one", file=src,
                                      key=f"{key}.cylindrical")
                if ez is not None:
                    criteria.append(Criterion(std, a.name, "Ez", "lx", ez, "min",
                                              ("mean", cyl), ez_src))
                if a.modelling is not None:
                    lo, hi = a.modelling
                    criteria.append(Criterion(std, a.name, "modelling Ez/Eh", "", lo, "min",
                                              ("ratio", cyl, task), "given"))
                    criteria.append(Criterion(std, a.name, "modelling Ez/Eh", "", hi, "max",
                                              ("ratio", cyl, task), "given"))
        if a.surrounding is not None:
            sur = use(need_grid(a.surrounding, f"{key}.surrounding"))
            criteria.append(Criterion(std, f"{a.name}.surrounding", "Em", "lx",
                                      _tables.surrounding_lux(em or 0.0), "min",
                                      ("mean", sur), "EN 12464-1:2011 Table 1"))
            criteria.append(Criterion(std, f"{a.name}.surrounding", "U0", "",
                                      _tables.SURROUNDING_U0, "min", ("u0", sur),
                                      "EN 12464-1:2011 4.3.1"))
            if a.background is not None:
                bg = use(need_grid(a.background, f"{key}.background"))
                criteria.append(Criterion(std, f"{a.name}.background", "Em", "lx",
                                          _tables.BACKGROUND_RATIO
                                          * _tables.surrounding_lux(em or 0.0), "min",
                                          ("mean", bg), "EN 12464-1:2011 4.3.2"))
                criteria.append(Criterion(std, f"{a.name}.background", "U0", "",
                                          _tables.BACKGROUND_U0, "min", ("u0", bg),
                                          "EN 12464-1:2011 4.3.2"))
        elif a.background is not None:
            raise ConfigError("'background' is judged against the immediate surrounding: give "
                              "'surrounding' too", file=src, key=f"{key}.background")
        areas_m2[a.name] = a.area_m2 if a.area_m2 is not None else _grid_area(
            cfg.grids[grids_idx[task]], src, f"{key}.area_m2")

    energy = comp.energy
    power = None
    if energy is not None or any(a.networks for a in comp.areas):
        power = power_model(study)
    if energy is not None:
        known = [v for v in areas_m2.values() if v is not None]
        area = energy.area_m2 if energy.area_m2 is not None else (
            sum(known) if known and len(known) == len(areas_m2) else None)
        if area is None:
            raise ConfigError("LENI needs a floor area: give 'area_m2' or an area to judge",
                              file=src, key="compliance.energy.area_m2")
        areas_m2["installation"] = float(area)
        why = (f"no input watts for {', '.join(power.missing[:3])}"
               + (" ..." if len(power.missing) > 3 else "")) if power.missing else ""
        spec = None if power.missing else ("leni", None, "installation")
        criteria.append(Criterion("EN 15193-1", "installation", "LENI", "kWh/(m²·a)",
                                  energy.leni_max,
                                  "max", spec, "given" if energy.leni_max else "(reported)",
                                  note=why))
        criteria.append(Criterion("EN 15193-1", "installation", "power density", "W/m²",
                                  energy.w_per_m2_max, "max",
                                  None if power.missing else (
                                      "power_density", None, "installation"),
                                  "given" if energy.w_per_m2_max else "(reported)", note=why))
        for a in comp.areas:
            if a.networks:
                if areas_m2[a.name] is None:
                    raise ConfigError(f"area {a.name!r}: its power density needs 'area_m2' "
                                      "(m²)", file=src, key=f"compliance.areas.{a.name}")
                idx = tuple(_network_index(names, n, src, f"compliance.areas.{a.name}.networks")
                            for n in a.networks)
                criteria.append(Criterion("EN 15193-1", a.name, "power density", "W/m²",
                                          energy.w_per_m2_max, "max",
                                          None if power.missing else (
                                              "power_density", idx, a.name),
                                          "given" if energy.w_per_m2_max else "(reported)",
                                          note=why))

    k = len(names)
    ulr_up = ulr_tot = ulr_refl = jnp.zeros(k)
    intensity: dict[str, Array] = {}
    post_mask = post_value = jnp.zeros(k)
    lum_net = jnp.asarray([names.index(lum.network) for lum in sc.luminaires], jnp.int32)
    ob = comp.obtrusive
    if ob is not None:
        lim = _tables.CIE150[ob.zone]
        zone = f"CIE 150:2017 Table 2, {ob.zone}"
        phases = [("before curfew" if ob.curfew else "", True)]
        if ob.curfew is not None:
            phases.append(("after curfew", False))
        if ob.after_curfew:
            mask = np.zeros(k)
            val = np.zeros(k)
            for n, v in ob.after_curfew.items():
                j = _network_index(names, n, src, f"compliance.obtrusive.after_curfew.{n}")
                mask[j], val[j] = 1.0, v
            post_mask, post_value = jnp.asarray(mask), jnp.asarray(val)
        for wi, wname in enumerate(ob.windows):
            use(need_grid(wname, f"compliance.obtrusive.windows[{wi}]"))
            for when, pre in phases:
                criteria.append(Criterion("CIE 150", wname, "Ev", "lx",
                                          lim.ev_pre if pre else lim.ev_post, "max",
                                          ("max", wname), zone, when))
        for s in ob.sensitive:
            intensity[s.name] = jnp.asarray(intensity_toward(sc, s.point))
            for when, pre in phases:
                criteria.append(Criterion("CIE 150", s.name, "I", "cd",
                                          lim.i_pre if pre else lim.i_post, "max",
                                          ("intensity", s.name), zone, when))
        if ob.upward_light and sc.luminaires:
            up, tot = upward_flux(sc)
            ulr_up = jnp.asarray(np.bincount(np.asarray(lum_net), up, minlength=k))
            ulr_tot = jnp.asarray(np.bincount(np.asarray(lum_net), tot, minlength=k))
            ulr_lim, ulr_src = (lim.ulr, zone) if ob.ulr_max is None else (ob.ulr_max, "given")
            criteria.append(Criterion("CIE 150", "installation", "ULR", "", ulr_lim, "max",
                                      ("ulr",), ulr_src, note="direct light only"))
            if ob.reflected_ulr != "off" and results.lighting is not None:
                ulr_refl = jnp.asarray(reflected_upward_flux(
                    results.lighting, rays=cfg.solver.gather_rays or GATHER_RAYS))
                criteria.append(Criterion(
                    "CIE 150", "installation", "ULR incl. reflected", "",
                    ulr_lim if ob.reflected_ulr == "judge" else None, "max",
                    ("ulr", "reflected"), ulr_src if ob.reflected_ulr == "judge" else
                    "(reported)",
                    note="direct + inter-reflected flux toward the sky, over the luminaires' "
                         "flux"))
        for fi, fname in enumerate(ob.facades):
            fkey = f"compliance.obtrusive.facades[{fi}]"
            use(need_grid(fname, fkey, ("surface",)))
            g = cfg.grids[grids_idx[fname]]
            item = [gg.name for gg in cfg.geometry].index(g.geometry)
            s = surface_samples(sc.triangles, item, g.offset_m, g.spacing)
            rho = np.array([m.luminous_reflectance for m in sc.materials])[s.material]
            weights[fname] = jnp.asarray(rho * s.area_m2 / (np.pi * s.area_m2.sum()))
            criteria.append(Criterion("CIE 150", fname, "Lb", "cd/m²", lim.lb, "max",
                                      ("luminance", fname), zone,
                                      "before curfew" if ob.curfew else ""))
    mf = jnp.asarray(network_maintenance(comp.maintenance, names, src))
    glare = results.glare.model if results.glare is not None else None
    return ComplianceModel(grids=grids, weights=weights, mf=mf, power=power, ulr_up=ulr_up,
                           ulr_total=ulr_tot, ulr_reflected=ulr_refl, intensity=intensity, lum_network=lum_net,
                           post_mask=post_mask, post_value=post_value, glare=glare,
                           design=results.design if glare is not None else None,
                           criteria=tuple(criteria), areas_m2=areas_m2, energy=energy,
                           networks=names)


def _road_criteria(a, task: str) -> list[Criterion]:
    """EN 13201-2:2015's illuminance-method criteria of a road area of class ``road_class``
    (Ē ≥, and U0 ≥ for a C class; Emin ≥ and Ē ≤ 1.5 × the class's Ē for a P class); a given
    ``em_lux`` or ``u0`` replaces the class's value."""
    std = "EN 13201-2"
    row = _tables.EN13201_2[a.road_class]
    ref = f"EN 13201-2:2015 {a.road_class}"
    em = a.em_lux if a.em_lux is not None else row.em_lux
    out = [Criterion(std, a.name, "Em", "lx", em, "min", ("mean", task),
                     "given" if a.em_lux is not None else ref)]
    u0 = a.u0 if a.u0 is not None else row.u0
    if u0 is not None:
        out.append(Criterion(std, a.name, "U0", "", u0, "min", ("u0", task),
                             "given" if a.u0 is not None else ref))
    if row.emin_lux is not None:
        out.append(Criterion(std, a.name, "Emin", "lx", row.emin_lux, "min", ("min", task), ref))
        out.append(Criterion(std, a.name, "Em (uniformity cap)", "lx",
                             _tables.P_CLASS_MAX_RATIO * row.em_lux, "max", ("mean", task),
                             f"{ref}, Table 4 note: Ē ≤ 1.5 × the class's"))
    return out


def _glare_spec(results, area, kind: str) -> tuple[tuple | None, str]:
    """The glare quantity of ``area`` (its observers' worst UGR or GR, ``lumijax.glare``), or
    None and why it is not computed."""
    if not area.observers:
        return None, "no 'observers' given for the area (docs/glare.md)"
    glare = results.glare
    if glare is None:
        return None, "the study computed no glare ratings"
    names = glare.model.observers
    return ("ugr" if kind == "ugr" else "gr",
            tuple(names.index(o) for o in area.observers)), ""


def _network_index(names, n, src, key) -> int:
    if n not in names:
        raise ConfigError(f"unknown network {n!r}; networks: {', '.join(names)}", file=src,
                          key=key)
    return names.index(n)


def _grid_area(g, src, key) -> float | None:
    """Floor area (m²) of an area or plane grid's rectangle (less its border; None for other
    kinds, which need ``area_m2`` where an area is asked for)."""
    if g.kind not in ("plane", "area") or g.kind == "area" and g.exclude is not None:
        return None
    b = g.border_m if g.kind == "area" else 0.0
    cross = np.cross(g.u, g.v)
    lu, lv = np.linalg.norm(g.u), np.linalg.norm(g.v)
    return float(np.linalg.norm(cross) * max(lu - 2 * b, 0.0) * max(lv - 2 * b, 0.0)
                 / (lu * lv))


def _ra(scene, networks) -> tuple[float | None, str]:
    """The lowest CIE Ra (colour rendering index, CIE 13.3) of the luminaires on ``networks``
    (all), from their spectra; None where a luminaire has no spectrum."""
    import colour

    lums = [lum for lum in scene.luminaires if networks is None or lum.network in networks]
    if not lums:
        return None, "no luminaires"
    values = []
    for lum in lums:
        if lum.spectrum is None:
            return None, f"luminaire {lum.name!r} has no spectrum"
        values.append(float(colour.colour_rendering_index(lum.spectrum.to_colour())))
    return min(values), ""


def evaluate_compliance(study, results) -> Compliance | None:
    """The study's verdict at its results' dimmers (None without ``[compliance]``)."""
    if study.config.compliance is None:
        return None
    model = compliance_model(study, results)
    return Compliance.judge(model, results.design.dimmers)
