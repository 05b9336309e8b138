"""A named surface's luminance, as one observer sees it, as a hard constraint of the
constrained design (docs/glare.md, "Surfaces an observer sees"; docs/optimise.md).

The patches each observer sees of each named surface are fixed when the study is computed
(``lumijax.glare.SeenSurfaces``, from rays over the observer's field); the criterion is the
largest ``B / π`` (cd/m²) over them, B the patches' radiosity at the variables (linear in the
dimmers), aggregated softly in units of the bound as the other maxima are.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from ..errors import ConfigError
from ..glare import SeenSurfaces
from ._constraints import AbstractConstraint, soft_max

__all__ = ["SurfaceLuminance", "surface_constraints"]


class SurfaceLuminance(AbstractConstraint):
    """The largest luminance ``B / π`` (cd/m²) of named surface ``surface`` over the patches
    of it observer ``observer`` sees, ≤ ``bound``: a constrained design's hard constraint,
    aggregated softly in units of the bound (``soft_max``), linear in the radiosity."""

    label: str = eqx.field(static=True)
    key: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    sense: int = eqx.field(static=True)
    bound: Float[Array, ""]
    ref: float = eqx.field(static=True)
    patches: Int[Array, " n"]

    def value(self, light, smooth):
        ref = self.scale
        return ref * soft_max(light.b[self.patches] / (math.pi * ref), smooth)


def surface_constraints(seen: SeenSurfaces | None, *, observer=None, surface=None,
                        bound=None, key="observers", source=None) -> list[SurfaceLuminance]:
    """Hard constraints from ``seen``'s ``max_luminance_cdm2`` limits (``bound`` None), or one
    per observer (all, or ``observer``) for ``surface`` ≤ ``bound`` (an ``[[optimise.
    constraints]]`` entry); ConfigError naming ``key`` where the observer sees none of it."""
    if seen is None:
        if bound is None:
            return []
        raise ConfigError("a surface luminance constraint needs [[observers]] and the "
                          "radiosity patches they see", file=source, key=key)
    if bound is None:
        wanted = [(o, s, v, f"observers[{o}].max_luminance_cdm2.{seen.surfaces[s]}")
                  for o, s, v in seen.limits]
    else:
        if surface not in seen.surfaces:
            raise ConfigError(f"no named surface {surface!r} is seen by any observer; named "
                              f"surfaces seen: {', '.join(seen.surfaces) or 'none'}",
                              file=source, key=f"{key}.surface")
        if observer is not None and observer not in seen.observers:
            raise ConfigError(f"no observer named {observer!r}; observers: "
                              f"{', '.join(seen.observers)}", file=source, key=f"{key}.observer")
        s = seen.surfaces.index(surface)
        obs = range(len(seen.observers)) if observer is None else [
            seen.observers.index(observer)]
        wanted = [(o, s, float(bound), f"{key}.max") for o in obs
                  if len(seen.links_of(o, s)) or observer is not None]
        if not wanted:
            raise ConfigError(f"no observer sees any part of surface {surface!r}: its "
                              "luminance cannot be bounded", file=source, key=f"{key}.surface")
    out = []
    for o, s, v, k in wanted:
        patches = seen.links_of(o, s)
        if not len(patches):
            raise ConfigError(f"observer {seen.observers[o]!r} sees no part of surface "
                              f"{seen.surfaces[s]!r}: its luminance cannot be bounded",
                              file=source, key=k)
        out.append(SurfaceLuminance(
            label=f"observer {seen.observers[o]!r}: luminance of {seen.surfaces[s]!r}", key=k,
            unit="cd/m²", sense=-1, bound=jnp.asarray(v), ref=abs(v) if v else 1.0,
            patches=jnp.asarray(patches, jnp.int32)))
    return out
