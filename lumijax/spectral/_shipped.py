"""Spectra lumijax ships so that building a scene does not import colour-science.

``lumijax/data/spectra.npz`` holds the Mallett & Yuksel (2019) sRGB basis (``mallett2019_*``,
380–780 nm at 5 nm, columns red, green, blue) and the CIE illuminants A, D50, D65 and FL11
(``illuminant_<name>_*``): the same numbers colour-science 0.4 ships as
``colour.recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019`` and ``colour.SDS_ILLUMINANTS[...]``
(the tests check them bitwise). Importing colour-science costs seconds per process (about 6.5 s
of a contended 8.4 s cold scene build), and the default study needs only these: an sRGB paving
albedo and illuminant A. Any other name still resolves through colour-science (``_names``).
"""

from __future__ import annotations

import functools
import re
from importlib import resources

import numpy as np

__all__ = ["mallett2019_basis", "shipped_emission", "srgb_decode", "SHIPPED_EMISSION"]

#: Display names of the shipped illuminants, as colour-science's registry names them, and the
#: extra names that registry also accepts for them ("F11" is the usual name of FL11).
SHIPPED_EMISSION: dict[str, tuple[str, ...]] = {"A": (), "D50": (), "D65": (), "FL11": ("F11",)}

#: Prefixes the registry ignores (``_names._lookup``), tried in the same order.
_PREFIXES = ("cieilluminant", "illuminant", "cie")


def _key(name: str) -> str:
    return re.sub(r"[\s_\-]+", "", name.casefold())  # the same rule as _names.normalise_name


_KEYS = {_key(n): display for display, extra in SHIPPED_EMISSION.items() for n in (display, *extra)}


def _read(*names: str) -> tuple[np.ndarray, ...]:
    path = resources.files("lumijax") / "data" / "spectra.npz"
    with resources.as_file(path) as p, np.load(p) as z:
        out = tuple(z[n].copy() for n in names)
    for a in out:
        a.setflags(write=False)
    return out


@functools.cache
def mallett2019_basis() -> tuple[np.ndarray, np.ndarray]:
    """``(wavelength_nm (81,), basis (81, 3))`` of Mallett & Yuksel (2019) for sRGB, read-only."""
    wl, basis = _read("mallett2019_wavelength_nm", "mallett2019_srgb_basis")
    return wl, basis


@functools.cache
def _illuminant(display: str) -> tuple[np.ndarray, np.ndarray]:
    wl, v = _read(f"illuminant_{display}_wavelength_nm", f"illuminant_{display}_values")
    return wl, v


def shipped_emission(name: str) -> tuple[str, np.ndarray, np.ndarray, str] | None:
    """``(display name, wavelengths_nm, values, source)`` of a shipped illuminant, or ``None``
    when ``name`` is not one (the caller then asks colour-science). Names are matched as the
    colour-science registry matches them: case, spaces, hyphens and underscores ignored, a
    leading ``"CIE"``/``"illuminant"`` ignored. The arrays are copies (callers may keep them)."""
    key = _key(name)
    display = _KEYS.get(key)
    if display is None:
        for prefix in _PREFIXES:
            if key.startswith(prefix) and key[len(prefix):] in _KEYS:
                display = _KEYS[key[len(prefix):]]
                break
    if display is None:
        return None
    wl, v = _illuminant(display)
    return display, wl.copy(), v.copy(), f"colour-science: SDS_ILLUMINANTS[{display!r}]"


#: Where the sRGB EOTF changes branch: colour-science compares the code value against the
#: *encoded* linear breakpoint, eotf_inverse_sRGB(0.0031308) = 0.0031308 · 12.92.
_SRGB_DECODE_BREAK = 0.0031308 * 12.92


def srgb_decode(v: np.ndarray) -> np.ndarray:
    """Linear values of sRGB code values in [0, 1] (IEC 61966-2-1 EOTF), as colour-science's
    ``cctf_decoding(v, function="sRGB")`` computes them."""
    a = np.asarray(v, dtype=np.float64)
    return np.where(_SRGB_DECODE_BREAK >= a, a / 12.92, np.abs((a + 0.055) / 1.055) ** 2.4)
