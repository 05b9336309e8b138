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

**Evaluated together.** :func:`constraint_values` (what the solver's programs trace) evaluates
constraints of one kind in one batch: the grid criteria as rows of a padded, masked gather of
their points, the glare ceilings rated by superposition as one ``vmap`` over observers. XLA on
the CPU compiles one kernel per fusion, and 21 constraints each traced alone made ~90 of them
(seconds of compilation for arithmetic on 10 dimmers × 1,104 points); a batch's graph does not
grow with the number of its constraints. A class opts in with ``batch_key`` and
``values_of`` (the same formula as its ``value``, row-wise; tests/optimise/
test_constraint_batch.py holds each batched class to its own ``value``); any other is
evaluated alone.
"""

from __future__ import annotations

import abc
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

__all__ = ["DesignLight", "AbstractConstraint", "GridAverage", "GridMinimum", "GridMaximum",
           "GridUniformity", "GridLuminance", "PatchLuminance", "TotalPower", "MapMisfit",
           "FunctionConstraint", "PowerModel", "soft_max", "soft_min", "soft_max_rows",
           "reference", "constraint_values", "constraint_margins"]


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


def soft_max_rows(v: Float[Array, "rows n"], mask, count: np.ndarray,
                  eps: Smooth) -> Float[Array, " rows"]:
    """:func:`soft_max` of each row of ``v`` over its entries where ``mask`` (``count[r]`` of
    them, host integers ≥ 1): the same bound per row, ``t = ε / ln count`` (a row of one entry,
    or ``eps=None``: the exact maximum). Masked entries must be finite (they are read, then
    ignored)."""
    m = jnp.max(jnp.where(mask, v, -jnp.inf), axis=1)
    if eps is None:
        return m
    count = np.asarray(count)
    t = (eps / np.log(np.maximum(count, 2)))[:, None]
    s = m + t[:, 0] * jnp.log(jnp.sum(jnp.where(mask, jnp.exp((v - m[:, None]) / t), 0.0),
                                      axis=1))
    return jnp.where(count == 1, m, s) if np.any(count == 1) else s


class DesignLight(eqx.Module):
    """The light a design gives: ``e`` (lx, grid points in grid order), ``b`` (lm/m², patch
    radiosity, or None), ``alpha`` (network dimmers) and ``x`` (the flat variables)."""

    e: Float[Array | np.ndarray, " points"]  # host arrays too: the lit design's exact light
    b: Float[Array | np.ndarray, " patches"] | None
    alpha: Float[Array | np.ndarray, " net"]
    x: Float[Array | np.ndarray, " x"]


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
        """``sense · (value − bound) / scale``: ≥ 0 when met, dimensionless (the solver's
        programs take the same formula for all constraints at once: :func:`constraint_margins`)."""
        return self.sense * (self.value(light, smooth) - self.bound) / self.scale

    def batch_key(self):
        """None (the default: evaluated alone), or a hashable key whose first item is the class
        whose :meth:`values_of` evaluates together every constraint of that key
        (:func:`constraint_values`). Called while tracing."""
        return None

    @classmethod
    def values_of(cls, group, light: DesignLight, smooth: Smooth) -> Float[Array, " c"]:
        """The values of ``group`` (constraints of one ``batch_key``), in its order: by
        default each constraint's :meth:`value`."""
        return jnp.stack([c.value(light, smooth) for c in group])

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


def constraint_values(constraints, light: DesignLight, smooth: Smooth) -> Float[Array, " m"]:
    """Every constraint's value (natural units), in order: those of one ``batch_key`` by its
    class's ``values_of`` together, the rest alone (module docstring)."""
    if not constraints:
        return jnp.zeros(0, light.x.dtype)
    groups: dict = {}
    for i, c in enumerate(constraints):
        k = c.batch_key()
        groups.setdefault(("alone", i) if k is None else k, []).append(i)
    order, parts = [], []
    for key, members in groups.items():
        group = [constraints[i] for i in members]
        v = key[0].values_of(group, light, smooth) if key[0] != "alone" else (
            jnp.reshape(group[0].value(light, smooth), (1,)))
        order += members
        parts.append(jnp.asarray(v, light.x.dtype))
    out = jnp.concatenate(parts)
    if order != list(range(len(order))):
        out = out[np.argsort(np.asarray(order))]
    return out


def constraint_margins(constraints, light: DesignLight, smooth: Smooth) -> Float[Array, " m"]:
    """Every constraint's margin ``sense · (value − bound) / scale`` (≥ 0 when met), from
    :func:`constraint_values`."""
    if not constraints:
        return jnp.zeros(0, light.x.dtype)
    v = constraint_values(constraints, light, smooth)
    sense = np.array([c.sense for c in constraints], np.float64)
    scale = np.array([c.scale for c in constraints], np.float64)
    bound = jnp.stack([jnp.asarray(c.bound, v.dtype) for c in constraints])
    return jnp.asarray(sense) * (v - bound) / jnp.asarray(scale)


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

    def _row(self) -> tuple[float | None, float] | None:
        """The criterion as a row of the batch (``values_of``): ``(a, b)`` for
        ``b · soft_max(a · E)`` over the grid's points (``a = None``: ``−1 / Eavg``, the U0 of
        the points), ``(0, 0)`` for their mean; None: not batched (evaluated alone)."""
        return None

    def batch_key(self):
        return None if self._row() is None else (_GridConstraint,)

    @classmethod
    def values_of(cls, group, light, smooth):
        # Every grid criterion is the mean of its grid's points or a scaled soft maximum of
        # them (_row), so all of them are one batch: each constraint a row of its points,
        # padded to the longest (the padding reads the row's first point and is masked out),
        # and one graph whatever the number of constraints and of their kinds
        start = np.array([c.start for c in group])
        count = np.array([c.stop - c.start for c in group])
        if np.any(count < 1):
            return super().values_of(group, light, smooth)
        col = jax.lax.broadcasted_iota(jnp.int32, (len(group), int(count.max())), 1)
        mask = col < count[:, None]
        e = light.e[jnp.where(mask, start[:, None] + col, start[:, None])]
        avg = jnp.sum(jnp.where(mask, e, 0.0), axis=1) / count
        rows = [c._row() for c in group]
        mean = np.array([r == (0.0, 0.0) for r in rows])
        if mean.all():
            return avg
        u0 = np.array([r[0] is None for r in rows])
        a_host = np.array([0.0 if r[0] is None else r[0] for r in rows])
        b = np.array([r[1] for r in rows])
        safe = jnp.where(avg > 0, avg, 1.0)
        a = jnp.where(u0, -1.0 / safe, a_host) if u0.any() else jnp.asarray(a_host)
        soft = b * soft_max_rows(e * a[:, None], mask, count, smooth)
        if u0.any():  # U0 of a dark grid is 0
            soft = jnp.where(u0 & ~(avg > 0), 0.0, soft)
        return jnp.where(mean, avg, soft) if mean.any() else soft


class GridAverage(_GridConstraint):
    """Eavg of a grid (lx): the maintained average Ēm of EN 12464-1."""

    def value(self, light, smooth):
        return jnp.mean(self._e(light))

    def _row(self):
        return (0.0, 0.0)


class GridMinimum(_GridConstraint):
    """Emin of a grid (lx), aggregated softly in units of the bound."""

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_min(self._e(light) / ref, smooth)

    def _row(self):
        return (-1.0 / self.scale, -self.scale)


class GridMaximum(_GridConstraint):
    """Emax of a grid (lx), aggregated softly in units of the bound."""

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_max(self._e(light) / ref, smooth)

    def _row(self):
        return (1.0 / self.scale, self.scale)


class GridUniformity(_GridConstraint):
    """U0 = Emin / Eavg of a grid; the soft minimum is taken of E / Eavg (error ≤ ε in U0)."""

    def value(self, light, smooth):
        e = self._e(light)
        avg = jnp.mean(e)
        safe = jnp.where(avg > 0, avg, 1.0)
        return jnp.where(avg > 0, soft_min(e / safe, smooth), 0.0)

    def _row(self):
        return (None, -1.0)


class GridLuminance(_GridConstraint):
    """Luminance ρ·Emax/π (cd/m²) of the (Lambertian) surface a grid lies on."""

    rho: float = eqx.field(static=True, default=0.0)

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_max(self.rho * self._e(light) / (np.pi * ref), smooth)

    def _row(self):
        return (self.rho / (np.pi * self.scale), self.scale)


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
