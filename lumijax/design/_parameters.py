"""The design's free variables as one flat vector with bounds, and the way back: the
optimiser's view of a :class:`~lumijax.design.Design` (Mitsuba 3's ``mi.traverse`` /
``SceneParameters`` in spirit)."""

from __future__ import annotations

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from ..errors import ConfigError
from ._design import Design, _traced

__all__ = ["DesignParameters", "traverse", "DESIGN_VARIABLES"]

DESIGN_VARIABLES = ("dimmers", "aims", "levels")
"""What :func:`traverse` can set free: network dimmers, luminaire tilt and pan, luminaire
levels (spin stays as designed)."""


class DesignParameters(eqx.Module):
    """The free variables of a design as one flat vector, with bounds (see :func:`traverse`).

    Layout ``x = [dimmers (networks), tilt (V), pan (V), level (V)]`` over the V luminaires of
    ``luminaires``; the tilt and pan blocks are present only with ``aims``, the level block
    only with ``levels`` — the layout ``lumijax.optimise``'s light models read. In ``x``,
    angles are **radians** (a step of 1 in an angle and in a dimmer are then of one size to
    the solver) and levels are factors on the ``start`` design's level (1 at the start, the
    factor the aim model scales the computed light by). A variable that is not free has
    ``lower == upper``.
    """

    start: Design
    x0: Float[np.ndarray, " x"]
    lower: Float[np.ndarray, " x"]
    upper: Float[np.ndarray, " x"]
    luminaires: tuple[int, ...] = eqx.field(static=True)
    aims: bool = eqx.field(static=True)
    levels: bool = eqx.field(static=True)

    @property
    def labels(self) -> tuple[str, ...]:
        """What each entry of ``x`` is: ``dimmers[n]``, ``tilt_rad[lum]``, ``pan_rad[lum]``,
        ``level[lum]``."""
        names = [self.start.luminaires[i] for i in self.luminaires]
        out = [f"dimmers[{n}]" for n in self.start.networks]
        if self.aims:
            out += [f"tilt_rad[{n}]" for n in names] + [f"pan_rad[{n}]" for n in names]
        if self.levels:
            out += [f"level[{n}]" for n in names]
        return tuple(out)

    @property
    def free(self) -> Float[np.ndarray, " x"]:
        """Which entries can move (``lower < upper``)."""
        return np.asarray(self.lower) < np.asarray(self.upper)

    def flatten(self, design: Design) -> Float[np.ndarray, " x"]:
        """``x`` of a design (of the same study)."""
        if not design.same_study(self.start):
            raise ConfigError("the design names other networks or luminaires than the one "
                              "these parameters were laid out for", key="design")
        idx = np.asarray(self.luminaires, int)
        parts = [np.asarray(design.dimmers, np.float64)]
        if self.aims:
            parts += [np.radians(np.asarray(design.tilt_deg)[idx]),
                      np.radians(np.asarray(design.pan_deg)[idx])]
        if self.levels:
            parts.append(np.asarray(design.level)[idx] / np.asarray(self.start.level)[idx])
        return np.concatenate(parts)

    def unflatten(self, x) -> Design:
        """The design at ``x``: the start design with the entries of ``x`` in their places.
        Traceable (``jax.numpy`` on a JAX array, numpy otherwise)."""
        xp = jnp if _traced(x) else np
        x = xp.asarray(x)
        s = self.start
        k, v = len(s.networks), len(self.luminaires)
        if x.shape != (k + v * (2 * self.aims + self.levels),):
            raise ConfigError(f"expected {len(self.x0)} variables ({', '.join(self.labels)}), "
                              f"got shape {x.shape}", key="design")
        idx = np.asarray(self.luminaires, int)

        def put(base, values):
            base = xp.asarray(base, x.dtype)
            return base.at[idx].set(values) if xp is jnp else _set(base, idx, values)

        def degrees(rad, start_deg):
            # an angle left where it started is the start's degrees exactly, not a round trip
            # through radians (unflatten(x0) is the start design, bit for bit)
            # (the correction is exact, Sterbenz, and carries no gradient)
            start_deg = xp.asarray(start_deg, x.dtype)[idx]
            deg = xp.degrees(rad)
            fix = xp.where(rad == xp.radians(start_deg), start_deg - deg, 0.0)
            return deg + (jax.lax.stop_gradient(fix) if xp is jnp else fix)

        tilt, pan, level = s.tilt_deg, s.pan_deg, s.level
        i = k
        if self.aims:
            tilt = put(tilt, degrees(x[i:i + v], s.tilt_deg))
            pan = put(pan, degrees(x[i + v:i + 2 * v], s.pan_deg))
            i += 2 * v
        if self.levels:
            level = put(level, xp.asarray(s.level)[idx] * x[i:i + v])
        return Design(x[:k], tilt, pan, s.spin_deg if xp is np else xp.asarray(s.spin_deg),
                      level, networks=s.networks, luminaires=s.luminaires)


def _set(base: np.ndarray, idx, values) -> np.ndarray:
    out = np.array(base, np.float64)
    out[idx] = values
    return out


def traverse(
    design: Design,
    variables: Sequence[str] = ("dimmers",),
    *,
    luminaires: Sequence[int] = (),
    dimmer_bounds: tuple[float, float] = (0.0, 1.0),
    aim_bounds_deg: Sequence[tuple[tuple[float, float], tuple[float, float]]] | None = None,
    level_bounds: tuple[float, float] = (0.0, 1.0),
) -> DesignParameters:
    """Lay a design's free variables out flat, with bounds.

    Parameters
    ----------
    design
        The start.
    variables
        Any of :data:`DESIGN_VARIABLES`.
    luminaires
        Indices (into ``design.luminaires``) of the luminaires with aim and level entries.
    dimmer_bounds
        Every dimmer's box; the start is clipped into it. Without ``"dimmers"`` in
        ``variables`` the dimmers are pinned (``lower == upper``) at the clipped start.
    aim_bounds_deg
        Per luminaire of ``luminaires``: ``((tilt_lo, tilt_hi), (pan_lo, pan_hi))`` in degrees
        relative to its start aim (required with ``"aims"``).
    level_bounds
        The box of every level entry, a factor on the start level.

    Returns
    -------
    DesignParameters
        ``x0``, ``lower``, ``upper`` and ``unflatten(x) -> Design``.
    """
    unknown = [v for v in variables if v not in DESIGN_VARIABLES]
    if unknown:
        raise ConfigError(f"unknown design variable {unknown[0]!r}; expected one of "
                          f"{', '.join(DESIGN_VARIABLES)}", key="optimise.variables")
    for name, (lo, hi) in (("dimmer", dimmer_bounds), ("level", level_bounds)):
        if lo > hi:
            raise ConfigError(f"the {name} bounds [{lo}, {hi}] are empty (lower > upper)",
                              key=f"design.{name}_bounds")
    aims, levels = "aims" in variables, "levels" in variables
    idx = tuple(int(i) for i in luminaires) if (aims or levels) else ()
    lo_d, hi_d = dimmer_bounds
    x0 = [np.clip(np.asarray(design.dimmers, np.float64), lo_d, hi_d)]
    lower = [np.full(len(design.networks), lo_d, np.float64)]
    upper = [np.full(len(design.networks), hi_d, np.float64)]
    if "dimmers" not in variables:
        lower[0] = upper[0] = x0[0]
    if aims:
        if aim_bounds_deg is None or len(aim_bounds_deg) != len(idx):
            raise ConfigError(f"expected aim bounds for each of the {len(idx)} luminaires",
                              key="design.aim_bounds_deg")
        spans = np.radians(np.array(aim_bounds_deg, np.float64).reshape(-1, 4))
        for j, (comp, field) in enumerate((("tilt", design.tilt_deg), ("pan", design.pan_deg))):
            start = np.radians(np.asarray(field, np.float64)[list(idx)])
            lo, hi = spans[:, 2 * j], spans[:, 2 * j + 1]
            if np.any(lo > hi):
                bad = design.luminaires[idx[int(np.argmax(lo > hi))]]
                raise ConfigError(f"the {comp} range of luminaire {bad!r} is empty (lo > hi)",
                                  key="design.aim_bounds_deg")
            x0.append(start)
            lower.append(start + lo)
            upper.append(start + hi)
    if levels:
        x0.append(np.ones(len(idx)))
        lower.append(np.full(len(idx), level_bounds[0], np.float64))
        upper.append(np.full(len(idx), level_bounds[1], np.float64))
    return DesignParameters(design, np.concatenate(x0), np.concatenate(lower),
                            np.concatenate(upper), idx, aims, levels)
