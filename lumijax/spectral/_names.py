"""Spectra shipped with colour-science, by name.

Lookup is case-insensitive and ignores spaces, hyphens and underscores (``"led b1"`` finds
``LED-B1``). A leading ``"CIE "`` or ``"illuminant "`` is ignored. The registry is built lazily so
that importing lumijax does not import colour-science, and illuminants E, A, D50, D65 and FL11
are answered without it (``_shipped``; same names, numbers and source strings).
"""

from __future__ import annotations

import difflib
import functools
import re
from collections.abc import Callable

import numpy as np

from ..errors import SpectrumError

__all__ = ["resolve", "available_names", "normalise_name"]

#: ColorChecker datasets of colour-science whose spectra cover 380–780 nm (the BabelColor
#: average stops at 730 nm and so does not qualify). The first is the default for bare patch names.
COLORCHECKER_DATASETS = ("ColorChecker N Ohta", "ISO 17321-1")

#: Short names for the neutral patches (their colour-science names carry densities).
_NEUTRAL_ALIASES = {
    "white 9.5 (.05 D)": "white",
    "neutral 8 (.23 D)": "neutral 8",
    "neutral 6.5 (.44 D)": "neutral 6.5",
    "neutral 5 (.70 D)": "neutral 5",
    "neutral 3.5 (1.05 D)": "neutral 3.5",
    "black 2 (1.5 D)": "black",
}

_Loader = Callable[[], object]  # returns a colour.SpectralDistribution


def normalise_name(name: str) -> str:
    """The lookup key of ``name``: case-folded, without spaces, hyphens and underscores."""
    return re.sub(r"[\s_\-]+", "", name.casefold())


class _Registry:
    """Maps lookup keys to (display name, loader, source) and keeps the names to suggest."""

    def __init__(self) -> None:
        self.entries: dict[str, tuple[str, _Loader, str]] = {}
        self.suggest: dict[str, str] = {}  # key -> display name for primary names

    def add(self, name: str, display: str, loader: _Loader, source: str, *, primary: bool):
        key = normalise_name(name)
        old = self.entries.get(key)
        if old is not None and old[0] != display:
            raise RuntimeError(f"spectrum name clash: {name!r} is {old[0]!r} and {display!r}")
        self.entries[key] = (display, loader, source)
        if primary:
            self.suggest[key] = name


@functools.cache
def _registry(kind: str) -> _Registry:
    import colour

    reg = _Registry()
    if kind == "emission":
        for table, label in (
            (colour.SDS_ILLUMINANTS, "SDS_ILLUMINANTS"),
            (colour.SDS_LIGHT_SOURCES, "SDS_LIGHT_SOURCES"),
        ):
            for key in list(table.keys()):
                loader = functools.partial(table.__getitem__, key)
                source = f"colour-science: {label}[{key!r}]"
                reg.add(key, key, loader, source, primary=True)
                m = re.fullmatch(r"FL(\d+(?:\.\d+)?)", key)
                if m:  # CIE F-series: "F11" is the usual name of FL11
                    reg.add(f"F{m.group(1)}", key, loader, source, primary=False)
        return reg

    # reflectance
    for dataset in COLORCHECKER_DATASETS:
        patches = colour.SDS_COLOURCHECKERS[dataset]
        for number, patch in enumerate(list(patches.keys()), start=1):
            loader = functools.partial(patches.__getitem__, patch)
            display = f"{dataset}/{patch}"
            source = f"colour-science: SDS_COLOURCHECKERS[{dataset!r}][{patch!r}]"
            default = dataset == COLORCHECKER_DATASETS[0]
            names = [f"{dataset}/{patch}", f"{dataset}/{number}"]
            if default:
                names += [patch, f"ColorChecker/{patch}", f"ColorChecker {number}"]
            short = _NEUTRAL_ALIASES.get(patch)
            if short is not None:
                names.append(f"{dataset}/{short}")
                if default:
                    names.append(short)
            for i, n in enumerate(names):
                reg.add(n, display, loader, source, primary=default and i in (0, 2))
    from colour.quality.datasets import SDS_TCS

    tcs = SDS_TCS["CIE 1995"]
    for sample in list(tcs.keys()):
        loader = functools.partial(tcs.__getitem__, sample)
        source = f"colour-science: SDS_TCS['CIE 1995'][{sample!r}]"
        reg.add(sample, sample, loader, source, primary=True)
        m = re.fullmatch(r"TCS0(\d)", sample)
        if m:
            reg.add(f"TCS{m.group(1)}", sample, loader, source, primary=False)
    return reg


def available_names(kind: str) -> list[str]:
    """The primary names :func:`resolve` accepts for ``kind`` (aliases not listed)."""
    return sorted(_registry(kind).suggest.values(), key=str.casefold)


def _lookup(reg: _Registry, name: str):
    key = normalise_name(name)
    if key in reg.entries:
        return reg.entries[key]
    for prefix in ("cieilluminant", "illuminant", "cie"):
        if key.startswith(prefix) and key[len(prefix) :] in reg.entries:
            return reg.entries[key[len(prefix) :]]
    return None


def _equal_energy(name: str, kind: str) -> tuple[str, np.ndarray, np.ndarray, str] | None:
    """CIE illuminant E exactly as colour-science ships it (100 at 360–830 nm every 5 nm), without
    importing colour-science: every material's luminous reflectance is taken under it."""
    if kind != "emission":
        return None
    key = normalise_name(name)
    if key not in ("e", "ciee", "illuminante", "cieilluminante"):
        return None
    wl = np.arange(360.0, 831.0, 5.0)
    return "E", wl, np.full(wl.shape, 100.0), "colour-science: SDS_ILLUMINANTS['E']"


def resolve(name: str, kind: str) -> tuple[str, np.ndarray, np.ndarray, str]:
    """``(display name, wavelengths_nm, values, source)`` of a named spectrum of ``kind``."""
    if not isinstance(name, str) or not name.strip():
        raise SpectrumError(f"a spectrum name must be a non-empty string, got {name!r}")
    fast = _equal_energy(name, kind)
    if fast is None and kind == "emission":
        # the illuminants studies name most (A, D65, ...) ship with lumijax: no colour import
        from ._shipped import shipped_emission

        fast = shipped_emission(name)
    if fast is not None:
        return fast
    reg = _registry(kind)
    hit = _lookup(reg, name)
    if hit is None:
        other = "reflectance" if kind == "emission" else "emission"
        other_hit = _lookup(_registry(other), name)
        if other_hit is not None:
            raise SpectrumError(
                f"{other_hit[0]!r} is a{'n' if other == 'emission' else ''} {other} spectrum, "
                f"not {kind}",
                key=f"spectrum {name!r}",
            )
        key = normalise_name(name)
        close = difflib.get_close_matches(key, list(reg.suggest), n=5, cutoff=0.5)
        if not close:  # fall back to aliases, reported by their display names
            close = difflib.get_close_matches(key, list(reg.entries), n=5, cutoff=0.5)
            shown = list(dict.fromkeys(reg.entries[k][0] for k in close))
        else:
            shown = [reg.suggest[k] for k in close]
        hint = f"; closest: {', '.join(shown)}" if shown else ""
        raise SpectrumError(
            f"unknown {kind} spectrum {name!r}{hint} (all names: docs/spectra.md)",
            key=f"spectrum {name!r}",
        )
    display, loader, source = hit
    sd = loader()
    wl = np.array(sd.wavelengths, dtype=np.float64)
    values = np.array(sd.values, dtype=np.float64)
    return display, wl, values, source
