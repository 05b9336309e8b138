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
worst_ratings` itself.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..design import DesignParameters
from ..glare import DimmerGlare, GlareModel, worst_ratings
from ._constraints import AbstractConstraint, DesignLight, Smooth, soft_max

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
