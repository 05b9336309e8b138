"""Hard constraints of a design: each criterion a differentiable function of the light, with a
bound (docs/optimise.md, "Design to a standard").

A constraint reads a :class:`DesignLight` (the light at the variables: grid-point illuminance,
patch radiosity, dimmers, the flat variables) and gives one number in natural units (lx, cd/m²,
W, or dimensionless for U0 and a misfit) that must be ``≥`` or ``≤`` its ``bound``. The solver
sees the dimensionless **margin** ``sense · (value − bound) / scale`` (≥ 0 when met).

Minima and maxima over many points are not smooth; the solver gets a log-sum-exp aggregate
with a stated error bound and the final design is checked on the exact criterion
(``smooth=None``). With ``t = ε / ln N`` in units of the constraint's own reference level
(the bound for ``min``/``max``, the grid average for U0):

    max(v) ≤ smax(v) = t · ln Σ exp(v / t) ≤ max(v) + ε
    min(v) − ε ≤ smin(v) = −smax(−v) ≤ min(v)

so the aggregate is **conservative**: a design that meets the smooth constraint meets the exact
one, and the price of the smoothing is at most ε of the reference level (``[optimise]
smoothing``, 10⁻³ by default).

A new criterion (a glare rating, a compliance quantity) is one final subclass of
:class:`AbstractConstraint` with ``value``; :class:`FunctionConstraint` wraps any JAX function
of the :class:`DesignLight`; the glare ratings are ``_glare_constraint.GlareConstraint``.
"""

from __future__ import annotations

import abc
from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

__all__ = ["DesignLight", "AbstractConstraint", "GridAverage", "GridMinimum", "GridMaximum",
           "GridUniformity", "GridLuminance", "PatchLuminance", "TotalPower", "MapMisfit",
           "FunctionConstraint", "PowerModel", "soft_max", "soft_min", "reference"]


#: The aggregation's ε: a number, a traced scalar (one compilation for every ε), or None for
#: the exact criterion.
Smooth = float | Float[Array, ""] | None


def soft_max(v: Float[Array, " n"], eps: Smooth) -> Float[Array, ""]:
    """``max(v) ≤ soft_max(v, ε) ≤ max(v) + ε``; ``eps=None`` is the exact maximum."""
    if eps is None or v.size == 1:
        return jnp.max(v)
    t = eps / np.log(v.size)
    m = jnp.max(v)
    # shifted by the (gradient-free in effect) max: no overflow for small t
    return m + t * jnp.log(jnp.sum(jnp.exp((v - m) / t)))


def soft_min(v: Float[Array, " n"], eps: Smooth) -> Float[Array, ""]:
    """``min(v) − ε ≤ soft_min(v, ε) ≤ min(v)``; ``eps=None`` is the exact minimum."""
    return -soft_max(-v, eps)


class DesignLight(eqx.Module):
    """The light a design gives: ``e`` (lx, grid points in grid order), ``b`` (lm/m², patch
    radiosity, or None), ``alpha`` (network dimmers) and ``x`` (the flat variables)."""

    e: Float[Array, " points"]
    b: Float[Array, " patches"] | None
    alpha: Float[Array, " net"]
    x: Float[Array, " x"]


class PowerModel(eqx.Module):
    """Electrical power in use (W): ``Σ_k α_k (P_k + Σ_{l ∈ k} (level_l − 1) p_l)``.

    ``power`` is each network's ``power_w`` at dimmer 1 (else its flux / 100 lm/W, as the
    least-squares fit reads it); with levels, luminaire l draws ``p_l``, its flux share of its
    network's power, times its level factor (``x[level_start + j]``).
    """

    power: Float[Array, " net"]
    lum_network: Int[Array, " v"] | None = None
    lum_power: Float[Array, " v"] | None = None
    level_start: int | None = eqx.field(static=True, default=None)

    def __call__(self, light: DesignLight) -> Float[Array, ""]:
        per_net = self.power
        if self.level_start is not None:
            v = self.lum_power.shape[0]
            level = light.x[self.level_start:self.level_start + v]
            per_net = per_net + jnp.zeros_like(per_net).at[self.lum_network].add(
                (level - 1.0) * self.lum_power)
        return jnp.dot(light.alpha, per_net)


class AbstractConstraint(eqx.Module):
    """``value(light) ≥ bound`` (``sense = +1``) or ``≤ bound`` (``sense = −1``).

    ``label`` says what is bounded ("grid 'desk': U0"), ``key`` the config key it came from
    (errors and reports name it), ``unit`` its unit; ``bound`` is an array leaf, so a re-solve
    at a tightened bound compiles nothing.
    """

    label: eqx.AbstractVar[str]
    key: eqx.AbstractVar[str]
    unit: eqx.AbstractVar[str]
    sense: eqx.AbstractVar[int]
    bound: eqx.AbstractVar[Float[Array, ""]]

    @abc.abstractmethod
    def value(self, light: DesignLight, smooth: Smooth) -> Float[Array, ""]:
        """The criterion (natural units); ``smooth`` the aggregation's ε, None exact."""

    #: The constraint's reference level (natural units): what the margin is divided by and
    #: the unit of the aggregation's ε. Fixed when the constraint is made (the bound's size,
    #: 1 for a zero bound), so that a tightened bound changes nothing else.
    ref: eqx.AbstractVar[float]

    @property
    def scale(self) -> float:
        return self.ref

    def margin(self, light: DesignLight, smooth: Smooth) -> Float[Array, ""]:
        """``sense · (value − bound) / scale``: ≥ 0 when met, dimensionless."""
        return self.sense * (self.value(light, smooth) - self.bound) / self.scale

    @property
    def relation(self) -> str:
        return "≥" if self.sense > 0 else "≤"

    def with_bound(self, bound: float) -> AbstractConstraint:
        """The same constraint at another bound (same reference level)."""
        return eqx.tree_at(lambda c: c.bound, self, jnp.asarray(float(bound)))


def reference(bound: float) -> float:
    """The reference level of a bound: its size, 1 for a zero bound."""
    b = abs(float(bound))
    return b if b > 0 else 1.0


class _GridConstraint(AbstractConstraint):
    label: str = eqx.field(static=True)
    key: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    sense: int = eqx.field(static=True)
    bound: Float[Array, ""]
    start: int = eqx.field(static=True)
    stop: int = eqx.field(static=True)
    ref: float = eqx.field(static=True)

    def _e(self, light):
        return light.e[self.start:self.stop]


class GridAverage(_GridConstraint):
    """Eavg of a grid (lx): the maintained average Ēm of EN 12464-1."""

    def value(self, light, smooth):
        return jnp.mean(self._e(light))


class GridMinimum(_GridConstraint):
    """Emin of a grid (lx), aggregated softly in units of the bound."""

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_min(self._e(light) / ref, smooth)


class GridMaximum(_GridConstraint):
    """Emax of a grid (lx), aggregated softly in units of the bound."""

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_max(self._e(light) / ref, smooth)


class GridUniformity(_GridConstraint):
    """U0 = Emin / Eavg of a grid; the soft minimum is taken of E / Eavg (error ≤ ε in U0)."""

    def value(self, light, smooth):
        e = self._e(light)
        avg = jnp.mean(e)
        safe = jnp.where(avg > 0, avg, 1.0)
        return jnp.where(avg > 0, soft_min(e / safe, smooth), 0.0)


class GridLuminance(_GridConstraint):
    """Luminance ρ·Emax/π (cd/m²) of the (Lambertian) surface a grid lies on."""

    rho: float = eqx.field(static=True, default=0.0)

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_max(self.rho * self._e(light) / (np.pi * ref), smooth)


class MapMisfit(_GridConstraint):
    """RMS of ``E − T`` over the mean of the target map ``T`` (dimensionless)."""

    target: Float[Array, " n"] | None = None

    def value(self, light, smooth):
        d = self._e(light) - self.target
        ref = jnp.mean(self.target)
        return jnp.sqrt(jnp.mean(d * d) + 1e-30) / ref


class PatchLuminance(AbstractConstraint):
    """The brightest radiosity patch's luminance B/π (cd/m²)."""

    label: str = eqx.field(static=True)
    key: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    sense: int = eqx.field(static=True)
    bound: Float[Array, ""]
    ref: float = eqx.field(static=True)

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_max(light.b / (np.pi * ref), smooth)


class TotalPower(AbstractConstraint):
    """The installed power in use (W)."""

    label: str = eqx.field(static=True)
    key: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    sense: int = eqx.field(static=True)
    bound: Float[Array, ""]
    power: PowerModel
    ref: float = eqx.field(static=True)

    def value(self, light, smooth):
        return self.power(light)


class FunctionConstraint(AbstractConstraint):
    """Any criterion given as a JAX function of the :class:`DesignLight` (``fn(light, smooth)
    -> scalar``): the hook for the compliance quantities (the glare ratings have their own
    class, ``GlareConstraint``). ``fn`` is static: give a module-level function or an
    eqx.Module."""

    label: str = eqx.field(static=True)
    key: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    sense: int = eqx.field(static=True)
    bound: Float[Array, ""]
    fn: Callable = eqx.field(static=True)
    ref: float = eqx.field(static=True)

    def value(self, light, smooth):
        return jnp.asarray(self.fn(light, smooth))
