"""The objective: a weighted sum of squares of residuals, one family per goal.

``f(x) = ½ Σ r(x)²`` where every residual is dimensionless (divided by the goal's own level), so
that goals in lux, in cd/m² and in watts can be summed, and each family is divided by the square
root of its count, so that a 10⁴-point grid does not outweigh a 10-point one:

* target (per grid, weight w): a constant ``target_lux`` T is a level for the grid's average
  (the maintained average illuminance of EN 12464, Ēm), one residual ``√w · (mean(E) − T) / T``
  — evenness is the job of ``uniformity_min``; a ``target_csv`` map T is fitted point by point,
  ``√(w/N) · (E − T) / mean(T)``;
* limits (weight c = ``constraint_weight``), hinge² penalties that are exactly zero when the
  limit is met and have a continuous gradient:

  - ``min_lux``: ``√(c/N) · max(0, Emin − E) / Emin``;
  - ``uniformity_min`` (U0 = Emin/Eavg ≥ u ⟺ every E ≥ u·Eavg): ``√(c/N) · max(0, u − E/Eavg)``;
  - ``max_lux``: ``√(c/N) · max(0, E − Emax) / Emax``;
  - grid ``max_luminance_cdm2``: ``√(c/N) · max(0, ρE/π − Lmax) / Lmax``;
  - ``[optimise] max_luminance_cdm2`` on every patch, L = B/π: ``√(c/P) · max(0, L − Lmax)/Lmax``;

* energy (weight e = ``energy_weight``): ``√e · Σ α_k P_k / Σ P_k``, the used fraction of the
  installed power (squared in f: a least-squares solver needs a residual).

The penalties are soft: a limit that cannot be met together with a target ends up slightly
violated, by an amount that shrinks as ``constraint_weight`` grows; the optimiser reports every
goal it did not meet.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = ["Objective", "TERMS"]

TERMS = ("target", "min_lux", "uniformity_min", "max_lux", "max_luminance_cdm2",
         "patch_luminance", "energy")


class _GridTerm(eqx.Module):
    # Which goals a grid has is static (it decides the residuals' shape); their values are
    # array leaves, so a fit with other levels of the same kinds of goal compiles nothing.
    start: int = eqx.field(static=True)
    stop: int = eqx.field(static=True)
    average: bool = eqx.field(static=True)  # a constant target_lux: fit the mean, not each point
    target: Float[Array, " n"] | None
    target_ref: Float[Array, ""] | None
    weight: Float[Array, ""] | None
    min_lux: Float[Array, ""] | None
    max_lux: Float[Array, ""] | None
    uniformity_min: Float[Array, ""] | None
    max_luminance: Float[Array, ""] | None
    rho: Float[Array, ""] | None


def _hinge(v):
    return jnp.maximum(v, 0.0)


def _leaf(v, keep=True):
    """A scalar goal value as an array leaf, or None where the goal is absent."""
    return None if v is None or not keep else jnp.asarray(float(v))


class Objective(eqx.Module):
    """Residuals of every goal from the light at the variables (see the module docstring)."""

    grids: tuple[_GridTerm, ...]
    power: Float[Array, " net"]
    energy_weight: Float[Array, ""] | None
    constraint_weight: Float[Array, ""]
    patch_max_luminance: Float[Array, ""] | None
    terms: frozenset = eqx.field(static=True, default=frozenset(TERMS))

    @classmethod
    def build(cls, goals, power, *, energy_weight=0.0, constraint_weight=10.0,
              patch_max_luminance=None) -> Objective:
        grids = []
        for g in goals:
            has_target = g.target is not None and g.weight > 0
            ref = float(np.mean(g.target)) if g.target is not None else 1.0
            grids.append(_GridTerm(
                g.start, g.stop, g.target_kind == "target_lux",
                jnp.asarray(g.target) if has_target else None,
                _leaf(ref if ref > 0 else 1.0, has_target), _leaf(g.weight, has_target),
                _leaf(g.min_lux, g.min_lux is not None and g.min_lux > 0), _leaf(g.max_lux),
                _leaf(g.uniformity_min), _leaf(g.max_luminance_cdm2),
                _leaf(g.rho, g.max_luminance_cdm2 is not None),
            ))
        p = np.asarray(power, np.float64)
        p = p / p.sum() if p.sum() > 0 else p
        return cls(tuple(grids), jnp.asarray(p), _leaf(energy_weight, energy_weight > 0),
                   jnp.asarray(float(constraint_weight)), _leaf(patch_max_luminance))

    def only(self, *terms: str) -> Objective:
        """The same objective restricted to some residual families (for tests and reports)."""
        import dataclasses

        return dataclasses.replace(self, terms=frozenset(terms))

    def residuals(self, e: Float[Array, " points"], b: Float[Array, " patches"] | None,
                  alpha: Float[Array, " net"]) -> Float[Array, " r"]:
        c = self.constraint_weight
        out = []
        for g in self.grids:
            eg = e[g.start:g.stop]
            n = g.stop - g.start
            if g.target is not None and "target" in self.terms:
                if g.average:
                    out.append(jnp.sqrt(g.weight) * (jnp.mean(eg, keepdims=True)
                                                     - g.target_ref) / g.target_ref)
                else:
                    out.append(jnp.sqrt(g.weight / n) * (eg - g.target) / g.target_ref)
            if g.min_lux is not None and "min_lux" in self.terms:
                out.append(jnp.sqrt(c / n) * _hinge(g.min_lux - eg) / g.min_lux)
            if g.uniformity_min is not None and "uniformity_min" in self.terms:
                avg = jnp.mean(eg)
                safe = jnp.where(avg > 0, avg, 1.0)
                out.append(jnp.sqrt(c / n) * jnp.where(avg > 0,
                                                        _hinge(g.uniformity_min - eg / safe),
                                                        g.uniformity_min))
            if g.max_lux is not None and "max_lux" in self.terms:
                out.append(jnp.sqrt(c / n) * _hinge(eg - g.max_lux) / g.max_lux)
            if g.max_luminance is not None and "max_luminance_cdm2" in self.terms:
                lum = g.rho * eg / jnp.pi
                out.append(jnp.sqrt(c / n) * _hinge(lum - g.max_luminance) / g.max_luminance)
        if (self.patch_max_luminance is not None and b is not None and b.size
                and "patch_luminance" in self.terms):
            lmax = self.patch_max_luminance
            out.append(jnp.sqrt(c / b.size) * _hinge(b / jnp.pi - lmax) / lmax)
        if self.energy_weight is not None and "energy" in self.terms:
            out.append(jnp.sqrt(self.energy_weight) * jnp.dot(alpha, self.power)[None])
        if not out:
            return jnp.zeros(1, e.dtype)
        return jnp.concatenate(out)

    def value(self, e, b, alpha) -> Array:
        r = self.residuals(e, b, alpha)
        return 0.5 * jnp.sum(r * r)
