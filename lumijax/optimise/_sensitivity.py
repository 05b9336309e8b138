"""What moves the needle: derivatives of a criterion with respect to everything a designer can
change, by JAX autodiff (docs/optimise.md, "Sensitivities").

``sensitivity(study, results, "desk.u0")`` differentiates one criterion (``GRID.avg``, ``.min``,
``.max``, ``.u0`` — exact, not smoothed: at a tie the derivative is that of the point JAX picks)
with respect to

* each network's **dimmer** (exact superposition, ``E = Σ α_k E_k``),
* each photometric luminaire's **flux** (its level factor: ∂/∂(relative flux)), its **tilt** and
  **pan** (per degree; the aim model of ``_models.AimLight``: the direct stage's pairs at the
  start aims and the change of inter-reflection solved, differentiated through the rotation
  and, by implicit differentiation, the radiosity solve's adjoint) and its **maintenance
  factor** (light ∝ MF: ∂/∂MF = ∂/∂(relative flux) / MF),
* each material's **reflectance** (luminous ρ; the inter-reflected light
  ``G (I − ρF)⁻¹ ρ E_patch`` differentiated through the solve's adjoint, one solve), where the
  study has one level of patches.

Each row also carries an **effect**: the derivative times a reference change a designer might
make (dimmer −0.1, flux +10 %, aim +1°, maintenance factor −0.05, reflectance +0.05), and rows
are ranked by its size — the "what moves the needle" table.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ConfigError
from ..lighting._solution import float64_scope
from ._constraints import (
    DesignLight,
    GridAverage,
    GridMaximum,
    GridMinimum,
    GridUniformity,
)

__all__ = ["Sensitivity", "sensitivity", "what_moves_the_needle", "REFERENCE_CHANGES",
           "reflectance_light"]

#: The reference change of each kind of parameter an effect is quoted for.
REFERENCE_CHANGES = {"dimmer": -0.1, "flux": 0.1, "tilt": 1.0, "pan": 1.0,
                     "maintenance_factor": -0.05, "reflectance": 0.05}
_UNITS = {"dimmer": "per unit dimmer", "flux": "per unit relative flux",
          "tilt": "per degree", "pan": "per degree", "maintenance_factor": "per unit MF",
          "reflectance": "per unit reflectance"}
_CRITERIA = {"avg": (GridAverage, "lx"), "min": (GridMinimum, "lx"),
             "max": (GridMaximum, "lx"), "u0": (GridUniformity, "")}


@dataclass
class Sensitivity:
    """Derivatives of one criterion (``metric``, its ``value`` and ``unit`` at the results'
    design); ``rows`` ranked by the size of their effect."""

    metric: str
    value: float
    unit: str
    rows: list[dict] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"metric": self.metric, "value": self.value, "unit": self.unit,
                "rows": self.rows}

    def derivative(self, kind: str, name: str) -> float:
        """``∂metric/∂parameter`` of one row (kind ``dimmer``, ``flux``, …; its name)."""
        for r in self.rows:
            if r["kind"] == kind and r["name"] == name:
                return r["derivative"]
        raise KeyError(f"no {kind} parameter named {name!r}")

    def table(self, top: int | None = None) -> list[list[str]]:
        """Rows as text for a report: parameter, derivative, effect of the reference change."""
        u = f" {self.unit}" if self.unit else ""
        out = []
        for r in self.rows[:top]:
            out.append([f"{r['kind']} {r['name']}", f"{r['derivative']:.4g}{u} {r['per']}",
                        f"{r['change']:+g} → {r['effect']:+.4g}{u}"])
        return out


def _metric(results, metric: str):
    grid, _, crit = metric.rpartition(".")
    names = list(results.grids)
    if grid not in results.grids:
        raise ConfigError(f"no grid named {grid!r} (metric {metric!r}); grids: "
                          f"{', '.join(names)}", key="sensitivity.metric")
    if crit not in _CRITERIA:
        raise ConfigError(f"unknown criterion {crit!r} in {metric!r}; expected GRID."
                          f"{{{', '.join(_CRITERIA)}}}", key="sensitivity.metric")
    start = 0
    for n in names:
        if n == grid:
            break
        start += len(results.grids[n].points)
    cls, unit = _CRITERIA[crit]
    c = cls(label=metric, key="sensitivity.metric", unit=unit, sense=1,
            bound=jnp.asarray(0.0), ref=1.0, start=start,
            stop=start + len(results.grids[grid].points))
    return c, unit


def reflectance_light(lighting, dimmers):
    """``(materials, f)``: the materials on the patches and ``f(s) -> E`` (lx at the grid
    points), the light with each material's luminous reflectance scaled by ``s_m`` (1: as
    computed): direct light plus ``G (I − ρ(s)F)⁻¹ ρ(s) E_patch`` (with diffusers, the coupled
    solve of ``ρ(s) E + τ E[partner]``, as the forward one). None where the study has no
    single level of patches (no inter-reflection, or a two-level solve)."""
    from ..radiosity import solve_radiosity
    from ._models import coupled_b0, diffuse_coupling, operator_dtype, transmission_as

    coarse = lighting.coarse
    if (coarse.patches is None or lighting.transport is None or lighting.fine is not None
            or not coarse.radiosity.size):
        return None
    alpha = np.asarray(dimmers, np.float64)
    mat = np.asarray(coarse.patches.material)
    used = np.unique(mat)
    index = np.searchsorted(used, mat)
    rho0 = np.asarray(coarse.rho, np.float64)
    e_patch = alpha @ np.asarray(coarse.patch_direct, np.float64)
    direct = alpha @ np.asarray(lighting.point_direct, np.float64)
    g = coarse.gather
    dt = operator_dtype(lighting.transport)
    n = len(direct)
    point, patch, weight = (jnp.asarray(g.point), jnp.asarray(g.patch),
                            jnp.asarray(np.asarray(g.weight, np.float64)))
    coupling = diffuse_coupling(lighting)  # diffusers: the forward solve's τ coupling

    def f(s):
        rho = jnp.asarray(rho0) * s[jnp.asarray(index)]
        b0 = coupled_b0(rho, jnp.asarray(e_patch), coupling)
        b = solve_radiosity(lighting.transport, rho.astype(dt), b0.astype(dt)[:, None],
                            transmission=transmission_as(coupling, dt)).value[:, 0]
        b = b.astype(jnp.float64)
        return jnp.asarray(direct) + jax.ops.segment_sum(b[patch] * weight, point,
                                                         num_segments=n)

    return used, f


@float64_scope()
def sensitivity(study, results, metric: str, *, reflectances: bool = True,
                aims: bool = True) -> Sensitivity:
    """∂(metric)/∂(every dimmer, luminaire flux, aim and maintenance factor, material
    reflectance) at the results' design; see the module docstring. ``metric`` is
    ``"GRID.avg"``, ``".min"``, ``".max"`` or ``".u0"``."""
    from ._models import build_aim_light

    lighting = results.lighting
    if lighting is None:
        raise ConfigError("the results hold no lighting solution: sensitivities need the "
                          "results of lumijax.compute", key="sensitivity")
    c, unit = _metric(results, metric)
    design = results.design
    sc = lighting.scene
    alpha0 = np.asarray(design.dimmers, np.float64)
    k = len(alpha0)
    total = jnp.asarray(lighting.point_total, jnp.float64)

    def crit(e, alpha):
        return c.value(DesignLight(e, None, alpha, alpha), None)

    value, g_alpha = jax.value_and_grad(lambda a: crit(a @ total, a))(jnp.asarray(alpha0))
    rows = [dict(kind="dimmer", name=n, derivative=float(d)) for n, d in
            zip(design.networks, np.asarray(g_alpha), strict=True)]
    if sc.luminaires and aims:
        idx = list(range(len(sc.luminaires)))
        model = build_aim_light(lighting, idx, np.zeros(len(idx)), np.zeros(len(idx)),
                                aims=True, levels=True)
        v = len(idx)
        x0 = jnp.concatenate([jnp.asarray(alpha0), model.tilt0, model.pan0, jnp.ones(v)])

        at = _full_light(model, lighting, crit)

        g = np.asarray(jax.jit(jax.grad(at))(x0), np.float64)
        for j, lum in enumerate(sc.luminaires):
            rows.append(dict(kind="tilt", name=lum.name,
                             derivative=float(g[k + j]) * np.pi / 180))
            rows.append(dict(kind="pan", name=lum.name,
                             derivative=float(g[k + v + j]) * np.pi / 180))
            rows.append(dict(kind="flux", name=lum.name, derivative=float(g[k + 2 * v + j])))
            mf = float(study.config.luminaires[lum.config_index].maintenance_factor)
            rows.append(dict(kind="maintenance_factor", name=lum.name,
                             derivative=float(g[k + 2 * v + j]) / mf))
    if reflectances:
        made = reflectance_light(lighting, alpha0)
        if made is not None:
            used, f = made
            rho_m = [sc.materials[int(m)].luminous_reflectance for m in used]
            gs = np.asarray(jax.grad(lambda s: crit(f(s), jnp.asarray(alpha0)))(
                jnp.ones(len(used))), np.float64)
            for m, d, r in zip(used, gs, rho_m, strict=True):
                rows.append(dict(kind="reflectance", name=sc.materials[int(m)].name,
                                 derivative=float(d) / r if r > 0 else 0.0))
    for r in rows:
        r["change"] = REFERENCE_CHANGES[r["kind"]]
        r["effect"] = r["derivative"] * r["change"]
        r["per"] = _UNITS[r["kind"]]
    rows.sort(key=lambda r: -abs(r["effect"]))
    return Sensitivity(metric, float(value), unit, rows)


def _full_light(model, lighting, crit):
    """``x -> crit(E(x))`` with the inter-reflected light solved from the whole patch direct
    light at ``x``, not from its change: the solve's reverse-mode derivative is zero at a zero
    right-hand side (the change is zero at the start, where sensitivities are taken), so the
    aim model's own form would lose the inter-reflected part of every derivative there."""
    from ..radiosity import solve_radiosity
    from ._models import coupled_b0, operator_dtype, transmission_as

    n = model.n_points
    fixed_direct = jnp.asarray(np.asarray(lighting.point_direct, np.float64)
                               - (np.asarray(lighting.point_total, np.float64)
                                  - np.asarray(model.base, np.float64)))
    if model.transport is None:
        def at(x):
            e, _, alpha = model(x)
            return crit(e, alpha)

        return at
    coarse = lighting.coarse
    fixed_patch = jnp.asarray(np.asarray(coarse.patch_direct, np.float64)
                              - np.asarray(model.start_patch, np.float64))
    dt = operator_dtype(model.transport)

    def at(x):
        alpha, tilt, pan, level = model.split(x)
        weight = alpha[model.network] * level
        flat = model.direct(tilt, pan, weight)
        patch = alpha @ fixed_patch + model.patch_light(flat, tilt, pan, weight)
        b0 = coupled_b0(model.rho, patch, model.transmission)
        b = solve_radiosity(model.transport, model.rho.astype(dt), b0.astype(dt)[:, None],
                            rtol=model.rtol, transmission=transmission_as(model.transmission, dt)
                            ).value[:, 0].astype(jnp.float64)
        e = alpha @ fixed_direct + flat[:n] + jax.ops.segment_sum(
            b[model.gather_patch] * model.gather_weight, model.gather_point, num_segments=n)
        return crit(e, alpha)

    return at


def what_moves_the_needle(study, results, metrics=None, *, top: int = 10) -> list[dict]:
    """For the report and results.json: for each metric (default: every grid's Eavg and U0)
    its value and the ``top`` rows of :func:`sensitivity`, ranked by effect."""
    if metrics is None:
        metrics = [f"{g}.{c}" for g in results.grids for c in ("avg", "u0")]
    out = []
    for m in metrics:
        s = sensitivity(study, results, m)
        d = s.to_dict()
        d["rows"] = d["rows"][:top]
        out.append(d)
    return out
