"""The luminaire schedule (bill of materials): one row per photometry, what a contractor orders.

Per photometry: how many luminaires use it, the manufacturer and catalogue number from the
file's own keywords (IES LM-63 ``[MANUFAC]``, ``[LUMCAT]``, ``[LUMINAIRE]``, ``[LAMP]``;
EULUMDAT's company, luminaire number, luminaire name and lamp set 1), the flux per luminaire
(lm, integrated from its candela table: the light the study computes with, before the config's
``multiplier`` and maintenance factor), the input power per luminaire (W, as the file states it),
the maintenance factors and networks of the luminaires that use it; and the totals. Area sources
get one row each.
"""

from __future__ import annotations

from dataclasses import dataclass

from .._study import Study
from ..config import AreaLuminaire, PhotometricLuminaire
from ..photometry import Photometry

__all__ = ["ScheduleRow", "Schedule", "luminaire_schedule"]


@dataclass(frozen=True)
class ScheduleRow:
    """One line of the schedule; flux in lm, power in W (``None``: the file does not say)."""

    name: str
    count: int
    manufacturer: str
    catalogue: str
    description: str
    lamp: str
    flux_lm: float
    watts: float | None
    maintenance_factors: tuple[float, ...]
    networks: tuple[str, ...]
    #: Σ over its luminaires of flux × multiplier (lm, at dimmer 1, before maintenance)
    total_flux_lm: float
    #: Σ over its luminaires of flux × multiplier × maintenance factor (lm, at dimmer 1)
    maintained_flux_lm: float
    total_watts: float | None


@dataclass(frozen=True)
class Schedule:
    """The schedule's rows and its totals (lm, W)."""

    rows: tuple[ScheduleRow, ...]

    @property
    def count(self) -> int:
        return sum(r.count for r in self.rows)

    @property
    def total_flux_lm(self) -> float:
        return sum(r.total_flux_lm for r in self.rows)

    @property
    def maintained_flux_lm(self) -> float:
        return sum(r.maintained_flux_lm for r in self.rows)

    @property
    def total_watts(self) -> float | None:
        """Σ of the rows' power; ``None`` when no row states one (rows without are left out)."""
        known = [r.total_watts for r in self.rows if r.total_watts is not None]
        return sum(known) if known else None

    @property
    def complete_power(self) -> bool:
        """Whether every row states its power (else the total is a lower bound)."""
        return all(r.total_watts is not None for r in self.rows)


def _first_line(text: str) -> str:
    return text.strip().splitlines()[0].strip().strip('"').strip() if text.strip() else ""


def _joined(text: str) -> str:
    return " ".join(line.strip() for line in text.strip().splitlines()).strip().strip('"')


def _keywords(p: Photometry) -> tuple[str, str, str, str]:
    """(manufacturer, catalogue number, description, lamp) from the file's keywords."""
    kw = p.keywords
    manufacturer = _first_line(kw.get("MANUFAC", "") or kw.get("COMPANY", ""))
    catalogue = _first_line(kw.get("LUMCAT", ""))
    description = _joined(kw.get("LUMINAIRE", ""))
    lamp = _joined(kw.get("LAMP", "") or kw.get("LAMPCAT", ""))
    if p.lamp_sets:  # EULUMDAT: set 1's lamps, as the flux is set 1's
        s = p.lamp_sets[0]
        lamp = f"{abs(s.count)} × {s.lamp_type.strip().strip(chr(34))}"
    return manufacturer, catalogue, description, lamp


def luminaire_schedule(study: Study) -> Schedule:
    """The :class:`Schedule` of a study's luminaires (module docstring)."""
    scene, cfg = study.scene, study.config
    rows = []
    for name, p in scene.photometries.items():
        used = [lum for lum in scene.luminaires if lum.photometry == name]
        if not used:
            continue
        entries = [cfg.luminaires[lum.config_index] for lum in used]
        entries = [e for e in entries if isinstance(e, PhotometricLuminaire)]
        flux = float(p.integrated_lm)
        mult = [e.multiplier for e in entries] or [1.0] * len(used)
        mf = [e.maintenance_factor for e in entries] or [1.0] * len(used)
        manufacturer, catalogue, description, lamp = _keywords(p)
        watts = None if p.input_watts is None or p.input_watts <= 0 else float(p.input_watts)
        rows.append(ScheduleRow(
            name=name, count=len(used), manufacturer=manufacturer, catalogue=catalogue,
            description=description, lamp=lamp, flux_lm=flux, watts=watts,
            maintenance_factors=tuple(sorted(set(mf))),
            networks=tuple(dict.fromkeys(lum.network for lum in used)),
            total_flux_lm=flux * sum(mult),
            maintained_flux_lm=flux * sum(m * f for m, f in zip(mult, mf, strict=True)),
            total_watts=None if watts is None else watts * len(used)))
    for a in scene.area_sources:
        entry = cfg.luminaires[a.config_index]
        mf = entry.maintenance_factor if isinstance(entry, AreaLuminaire) else 1.0
        rows.append(ScheduleRow(
            name=a.name, count=1, manufacturer="", catalogue="", description="area source",
            lamp="", flux_lm=float(a.flux_lm), watts=None, maintenance_factors=(mf,),
            networks=(a.network,), total_flux_lm=float(a.flux_lm),
            maintained_flux_lm=float(a.flux_lm) * mf, total_watts=None))
    return Schedule(tuple(rows))
