"""A glare rating as a hard constraint of the constrained design: one observer's worst UGR, GR
or TI (``lumijax.glare``) at the design the optimiser proposes (docs/optimise.md).

The rating is a pure JAX function of the :class:`~lumijax.design.Design`; the constraint reads
the design from the flat variables (``DesignParameters.unflatten``: dimmers, and the aims and
levels when they are free) and evaluates the study's :class:`~lumijax.glare.GlareModel` at it.
The background and environment luminances are those of the lit start scaled by the dimmers
(the model's own linear reading: exact for dimmers, the start's inter-reflected surroundings
when aims move).

The worst over an observer's directions is a maximum: the solver gets the conservative
log-sum-exp aggregate of ``_constraints`` (in units of the bound, so ``max ≤ smax ≤ max + ε``
rating points × bound); the exact check (``smooth=None``) is :func:`lumijax.glare.
worst_ratings` itself. Rated by superposition (dimmers only), the ceilings of all observers are
evaluated as one batch (``values_of``: the ratings ``vmap``-ed over the constraints, each
observer's worst a masked row), so the solver's compiled graph does not grow with them.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..design import DesignParameters
from ..glare import DimmerGlare, GlareModel, worst_ratings
from ._constraints import AbstractConstraint, DesignLight, Smooth, soft_max, soft_max_rows

__all__ = ["GlareConstraint", "GLARE_UNITS"]

#: The unit of each rating: UGR and GR are dimensionless, TI is in %.
GLARE_UNITS = {"ugr": "", "gr": "", "ti": "%"}


class GlareConstraint(AbstractConstraint):
    """``rating ≤ bound`` for one observer: ``rating`` one of ``"ugr"``, ``"gr"``, ``"ti"``,
    its worst over the observer's lines of sight (``views``, static indices into the model's
    views), at the design ``params.unflatten(light.x)``."""

    label: str = eqx.field(static=True)
    key: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    sense: int = eqx.field(static=True)
    bound: Float[Array, ""]
    model: GlareModel
    params: DesignParameters
    rating: str = eqx.field(static=True)
    observer: int = eqx.field(static=True)
    views: tuple[int, ...] = eqx.field(static=True)
    ref: float = eqx.field(static=True)
    #: With only the dimmers free: the model's terms at the start's aims and levels summed per
    #: network once (``GlareModel.at_aims``), so a proposal costs a (views × networks) product
    superposed: DimmerGlare | None = None

    def batch_key(self):
        if self.superposed is None:  # the full model (aims or levels move): alone
            return None
        leaves, tree = jax.tree_util.tree_flatten(self.superposed)
        shapes = tuple((a.shape, str(a.dtype)) for a in leaves)
        return (GlareConstraint, self.rating, tree, shapes)

    @classmethod
    def values_of(cls, group, light, smooth):
        # the same rating of every constraint's superposition (one vmap: the graph of one),
        # then each observer's views as a masked row of them
        stacked = jax.tree_util.tree_map(lambda *a: jnp.stack(a), *[c.superposed for c in group])
        alpha = jnp.asarray(light.alpha)
        rating = group[0].rating
        rated = jax.vmap(lambda s: getattr(s.ratings(alpha), rating))(stacked)  # (c, views)
        if smooth is None:  # the exact worst: GlareModel.worst of each row, at its observer
            worst = jax.vmap(lambda s, r: s.model.worst(r))(stacked, rated)  # (c, observers)
            return worst[np.arange(len(group)), np.array([c.observer for c in group])]
        count = np.array([len(c.views) for c in group])
        if np.any(count < 1):
            return super().values_of(group, light, smooth)
        views = np.zeros((len(group), int(count.max())), np.int32)
        for i, c in enumerate(group):
            views[i, :count[i]] = c.views
            views[i, count[i]:] = c.views[0]
        mask = np.arange(views.shape[1])[None, :] < count[:, None]
        r = jnp.take_along_axis(rated, jnp.asarray(views), axis=1)
        # in the ratings' precision, as ``value`` divides them by a Python float
        ref = np.array([c.scale for c in group], np.float64)
        return ref * soft_max_rows(r / ref[:, None].astype(r.dtype), mask, count, smooth)

    def value(self, light: DesignLight, smooth: Smooth) -> Float[Array, ""]:
        if self.superposed is not None:
            rated = getattr(self.superposed.ratings(jnp.asarray(light.alpha)), self.rating)
            if smooth is None:
                return self.model.worst(rated)[self.observer]
            r = rated[np.asarray(self.views)]
            ref = self.scale
            return ref * soft_max(r / ref, smooth)
        design = self.params.unflatten(jnp.asarray(light.x))
        if smooth is None:
            return worst_ratings(self.model, design)[self.rating][self.observer]
        r = getattr(self.model.ratings(design), self.rating)[np.asarray(self.views)]
        ref = self.scale
        return ref * soft_max(r / ref, smooth)
