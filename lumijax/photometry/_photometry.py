"""The loaded photometry of one luminaire: distribution, opening, header figures and provenance."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..errors import LumijaxWarning
from ._distribution import CandelaDistribution
from ._opening import LuminousOpening

__all__ = ["Photometry", "TiltTable", "LampSet"]


@dataclass(frozen=True)
class TiltTable:
    """An LM-63 tilt block: candela multipliers as a function of the installed tilt angle.

    Attributes
    ----------
    geometry
        Lamp-to-luminaire geometry code: 1 vertical lamp, 2 horizontal lamp that turns but does
        not tilt with the luminaire, 3 horizontal lamp that tilts with it.
    angles_deg
        Tilt angles (deg), ascending.
    factors
        Multipliers of the whole candela table at those angles (dimensionless).
    """

    geometry: int
    angles_deg: tuple[float, ...]
    factors: tuple[float, ...]

    def factor(self, tilt_deg: ArrayLike) -> Float[Array, "..."]:
        """Multiplier at ``tilt_deg`` (deg): linear between tabulated angles, held at the ends."""
        return jnp.interp(
            jnp.asarray(tilt_deg),
            jnp.asarray(self.angles_deg),
            jnp.asarray(self.factors),
        )


@dataclass(frozen=True)
class LampSet:
    """One EULUMDAT lamp set (lines 26a–26f).

    ``count`` is negative in files with absolute photometry; ``flux_lm`` is then the luminaire's
    flux rather than a lamp's.
    """

    count: int
    lamp_type: str
    flux_lm: float
    colour: str
    colour_rendering: str
    watts: float


@dataclass(frozen=True)
class Photometry:
    """Photometry of one luminaire as loaded from a file or generated.

    Attributes
    ----------
    distribution
        Absolute intensity (cd) on the full sphere.
    opening
        Luminous opening (m) in the luminaire frame.
    rated_lm
        The file's own statement of the luminaire's flux (lm), if it has one. EULUMDAT:
        LORL × lamp flux of lamp set 1 (absolute files: that flux). IES relative photometry:
        number of lamps × lumens per lamp, i.e. the lamp lumens. IES absolute photometry: ``None``.
    lamp_lm
        Rated lamp flux (lm): IES relative: lamps × lumens/lamp; EULUMDAT: set 1's flux; else None.
    lor
        Light output ratio as a fraction (EULUMDAT line 23 / 100); ``None`` for IES.
    integrated_lm
        Flux of the distribution (lm), integrated exactly for its interpolant in float64.
    input_watts
        Input power (W) as stated by the file, if any.
    tilt
        The ``TILT=INCLUDE`` (or ``TILT=<file>``) table, or ``None``. Not applied to the
        distribution: the multiplier depends on how the luminaire is installed.
    source
        Path the photometry was read from, or ``None`` for generated ones.
    format
        ``"ies"``, ``"ldt"`` or ``"builtin"``.
    version
        ``"1986"``, ``"1991"``, ``"1995"``, ``"2002"``, ``"2019"`` for IES; ``"eulumdat"``;
        ``"lumijax"`` for generated ones.
    keywords
        IES keywords (``[MORE]`` lines joined with newlines; free-text label lines under
        ``"LABEL"``); for EULUMDAT the text header lines under descriptive names.
    warnings
        Texts of the warnings issued on load (header/data mismatch and the like).
    lamp_sets
        Every EULUMDAT lamp set; empty for IES.
    """

    distribution: CandelaDistribution
    opening: LuminousOpening = field(default_factory=LuminousOpening)
    rated_lm: float | None = None
    lamp_lm: float | None = None
    lor: float | None = None
    integrated_lm: float = 0.0
    input_watts: float | None = None
    tilt: TiltTable | None = None
    source: Path | None = None
    format: str = "builtin"
    version: str = "lumijax"
    keywords: Any = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    lamp_sets: tuple[LampSet, ...] = ()

    def __post_init__(self) -> None:
        # A read-only view: a Photometry is a value, shared between luminaires.
        object.__setattr__(self, "keywords", MappingProxyType(dict(self.keywords)))

    @property
    def name(self) -> str:
        """A short human name: the luminaire keyword, the catalogue number or the file stem."""
        for key in ("LUMINAIRE", "LUMCAT"):
            text = self.keywords.get(key, "").strip()
            if text:
                return text.splitlines()[0]
        return self.source.stem if self.source is not None else "luminaire"


def integrate_np(photometric_type: str, h, v, cd) -> float:
    """Float64 flux (lm) of a table, after the same pole tying as the distribution."""
    from ._distribution import flux_weights

    w = flux_weights(photometric_type, np.asarray(h, np.float64), np.asarray(v, np.float64), np)
    return float(np.sum(w * np.asarray(cd, np.float64)))


def check_header_flux(
    *,
    fmt: str,
    source: Path,
    integrated_lm: float,
    rated_lm: float | None,
    absolute: bool,
) -> str | None:
    """Compare the header's flux with the data's and warn (``LumijaxWarning``) on a mismatch.

    EULUMDAT: more than 1 % apart from LORL × lamp flux. IES relative photometry: the data carry
    more than 101 % of the lamp lumens (LOR > 100 %). Returns the warning text or ``None``.
    """
    if rated_lm is None or rated_lm <= 0:
        return None
    msg = None
    if fmt == "ldt":
        if abs(integrated_lm - rated_lm) > 0.01 * rated_lm:
            what = "the luminaire flux" if absolute else "LORL × lamp flux of lamp set 1"
            msg = (
                f"{source}: the intensity table integrates to {integrated_lm:.1f} lm but the "
                f"header states {rated_lm:.1f} lm ({what}), "
                f"{100.0 * (integrated_lm / rated_lm - 1.0):+.1f} %; the table is used as given"
            )
    elif fmt == "ies" and not absolute and integrated_lm > 1.01 * rated_lm:
        msg = (
            f"{source}: the candela table integrates to {integrated_lm:.1f} lm, more than the "
            f"{rated_lm:.1f} lm of lamp lumens in the header (LOR "
            f"{100.0 * integrated_lm / rated_lm:.1f} % > 100 %); the candela values are used as given"
        )
    if msg is not None:
        warnings.warn(msg, LumijaxWarning, stacklevel=4)
    return msg
