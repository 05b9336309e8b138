"""The :class:`Spectrum` object and the validation every spectrum goes through.

A spectrum is a sampled function of wavelength (nm). Between samples it is interpolated linearly.
Outside its samples it is extrapolated by a rule that depends on its ``kind``:

* ``"emission"`` (a spectral power distribution, any linear unit): **zero** outside the data — a
  source emits nothing where it was not measured;
* ``"reflectance"`` (dimensionless, 0 ≤ ρ < 1): **constant**, the first/last sample continued — a
  surface does not stop reflecting where the spectrophotometer stopped.

Every spectrum must cover the visible range 380–780 nm. A gap of at most
:data:`MAX_EXTRAPOLATION_NM` at either end is bridged by the rule above with a
:class:`~lumijax.errors.LumijaxWarning`; a larger gap is a :class:`~lumijax.errors.SpectrumError`.
See ``docs/spectra.md``.
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from ..errors import LumijaxWarning, SpectrumError

__all__ = [
    "Spectrum",
    "Kind",
    "KINDS",
    "VISIBLE_NM",
    "MAX_EXTRAPOLATION_NM",
    "check_spectrum",
]

Kind = Literal["emission", "reflectance"]
KINDS: tuple[str, ...] = ("emission", "reflectance")

#: The wavelength range (nm) every spectrum must cover, ends included.
VISIBLE_NM: tuple[float, float] = (380.0, 780.0)

#: The largest gap (nm) at either end of :data:`VISIBLE_NM` that is bridged by extrapolation
#: (with a warning) rather than refused.
MAX_EXTRAPOLATION_NM: float = 20.0

_PKG_DIR = os.path.dirname(os.path.abspath(__file__))


def _warn(message: str) -> None:
    """Warn with :class:`LumijaxWarning`, attributed to the first caller outside this package."""
    frame = sys._getframe(1)
    level = 1
    while frame is not None and (
        os.path.dirname(os.path.abspath(frame.f_code.co_filename)) == _PKG_DIR
        or (frame.f_code.co_filename == "<string>" and frame.f_code.co_name == "__init__")
    ):
        frame = frame.f_back
        level += 1
    warnings.warn(message, LumijaxWarning, stacklevel=level)


def _check_kind(kind: object, key: str | None = None) -> str:
    if kind not in KINDS:
        raise SpectrumError(f"kind must be 'emission' or 'reflectance', got {kind!r}", key=key)
    return kind  # type: ignore[return-value]


def check_spectrum(
    wavelengths_nm: object,
    values: object,
    kind: str,
    *,
    name: str | None = None,
    file: str | Path | None = None,
    lines: Sequence[int] | None = None,
    warn: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Validate sampled spectral data and return it as two float64 arrays.

    Raises :class:`SpectrumError` naming ``file`` and, when ``lines`` (the 1-based source line of
    each sample) is given, the line of the first offending sample. The rules are listed in
    ``docs/spectra.md``.
    """
    key = f"spectrum {name!r}" if name else None
    _check_kind(kind, key)

    def fail(message: str, index: int | None = None) -> SpectrumError:
        line = None if (lines is None or index is None) else int(lines[index])
        return SpectrumError(message, file=file, line=line, key=key)

    try:
        wl = np.array(wavelengths_nm, dtype=np.float64)
        v = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise fail(f"wavelengths and values must be numbers ({exc})") from None
    if wl.ndim != 1 or v.ndim != 1:
        raise fail(f"wavelengths and values must be 1-D, got shapes {wl.shape} and {v.shape}")
    if wl.shape != v.shape:
        raise fail(f"{wl.size} wavelengths but {v.size} values: they must pair up one to one")
    if wl.size < 2:
        raise fail(f"a spectrum needs at least 2 samples, got {wl.size}")

    for arr, what in ((wl, "wavelength"), (v, "value")):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            i = int(bad[0])
            raise fail(f"{what} {arr[i]} at sample {i} is not a finite number", i)
    if wl[0] <= 0.0:
        raise fail(f"wavelength {wl[0]:g} nm at sample 0 is not positive", 0)
    steps = np.flatnonzero(np.diff(wl) <= 0.0)
    if steps.size:
        i = int(steps[0]) + 1
        how = "duplicates" if wl[i] == wl[i - 1] else "is smaller than"
        raise fail(
            f"wavelengths must be strictly increasing: {wl[i]:g} nm at sample {i} {how} "
            f"the previous {wl[i - 1]:g} nm",
            i,
        )
    neg = np.flatnonzero(v < 0.0)
    if neg.size:
        i = int(neg[0])
        raise fail(
            f"{kind} value {v[i]:g} at {wl[i]:g} nm is negative; spectral values must be >= 0", i
        )
    if kind == "reflectance":
        high = np.flatnonzero(v >= 1.0)
        if high.size:
            i = int(high[0])
            hint = " (percent? divide by 100)" if np.max(v) > 1.5 else ""
            raise fail(
                f"reflectance must be < 1: got {v[i]:g} at {wl[i]:g} nm{hint}; a diffuse "
                "surface cannot reflect more light than it receives",
                i,
            )
    elif not np.any(v > 0.0):
        raise fail("emission spectrum is zero everywhere: it emits no light")

    lo, hi = VISIBLE_NM
    gap_lo = max(0.0, wl[0] - lo)
    gap_hi = max(0.0, hi - wl[-1])
    if gap_lo > MAX_EXTRAPOLATION_NM or gap_hi > MAX_EXTRAPOLATION_NM:
        hint = " (are the wavelengths in nm?)" if wl[-1] < 10.0 else ""
        raise fail(
            f"data cover {wl[0]:g}-{wl[-1]:g} nm but a spectrum must cover {lo:g}-{hi:g} nm; "
            f"at most {MAX_EXTRAPOLATION_NM:g} nm missing at either end can be extrapolated{hint}"
        )
    if warn and (gap_lo > 0.0 or gap_hi > 0.0):
        rule = "as zero (emission)" if kind == "emission" else "as the end value (reflectance)"
        where = ""
        if file is not None:
            where = f"{file}: "
        elif key is not None:
            where = f"{key}: "
        _warn(
            f"{where}data cover {wl[0]:g}-{wl[-1]:g} nm, not all of {lo:g}-{hi:g} nm; "
            f"the missing {gap_lo:g} nm below and {gap_hi:g} nm above are extrapolated {rule}"
        )
    return wl, v


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Spectrum:
    """An immutable, validated spectral distribution.

    Parameters
    ----------
    wavelengths_nm
        Sample wavelengths in nm, strictly increasing (stored as read-only float64).
    values
        Values at those wavelengths: relative spectral power (emission, any linear unit) or
        reflectance in [0, 1) (reflectance).
    kind
        ``"emission"`` or ``"reflectance"``; it sets the validation and the extrapolation rule.
    name
        A label for messages and reports.
    source
        Where the data came from (a file path or ``"colour-science: ..."``), for messages.

    The photometric level of a luminaire is fixed by its photometry: an emission spectrum sets
    colour only, so its absolute scale never matters (see ``docs/conventions.md``).
    """

    wavelengths_nm: np.ndarray
    values: np.ndarray
    kind: Kind
    name: str = ""
    source: str | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        wl, v = check_spectrum(
            self.wavelengths_nm, self.values, self.kind, name=self.name or None, file=self.source
        )
        object.__setattr__(self, "wavelengths_nm", _frozen(wl))
        object.__setattr__(self, "values", _frozen(v))

    # ----------------------------------------------------------------- identity and display
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Spectrum):
            return NotImplemented
        return (
            self.kind == other.kind
            and self.name == other.name
            and np.array_equal(self.wavelengths_nm, other.wavelengths_nm)
            and np.array_equal(self.values, other.values)
        )

    def __hash__(self) -> int:
        return hash((self.kind, self.name, self.wavelengths_nm.tobytes(), self.values.tobytes()))

    def __repr__(self) -> str:
        wl = self.wavelengths_nm
        return f"Spectrum({self.name!r}, {self.kind}, {wl[0]:g}-{wl[-1]:g} nm, {wl.size} samples)"

    # ------------------------------------------------------------------------- evaluation
    def at(self, wavelengths_nm: object) -> np.ndarray:
        """Values at ``wavelengths_nm`` (any shape), by linear interpolation.

        Outside the data: zero for emission, the end value for reflectance. Never NaN.
        """
        x = np.asarray(wavelengths_nm, dtype=np.float64)
        if not np.all(np.isfinite(x)):
            raise SpectrumError(
                "wavelengths to evaluate at must be finite", key=f"spectrum {self.name!r}"
            )
        if self.kind == "emission":
            return np.interp(x, self.wavelengths_nm, self.values, left=0.0, right=0.0)
        return np.interp(x, self.wavelengths_nm, self.values)

    __call__ = at

    def resample(self, wavelengths_nm: object) -> Spectrum:
        """A new spectrum sampled at ``wavelengths_nm`` (see :meth:`at` for the rules).

        The result is validated like any spectrum, so the new grid must be strictly increasing and
        cover 380–780 nm (up to the allowed extrapolation). To evaluate on any grid without
        those rules, use :meth:`at`.
        """
        x = np.asarray(wavelengths_nm, dtype=np.float64)
        if x.ndim != 1:
            raise SpectrumError(
                f"resample needs a 1-D wavelength grid, got shape {x.shape}",
                key=f"spectrum {self.name!r}",
            )
        return Spectrum(x, self.at(x), self.kind, self.name, source=self.source)

    def to_colour(self):
        """This spectrum as a ``colour.SpectralDistribution`` (linear interpolator, and the same
        extrapolation rule as :meth:`at`)."""
        import colour
        from colour.algebra import Extrapolator, LinearInterpolator

        kwargs = {"method": "Constant"}
        if self.kind == "emission":
            kwargs.update(left=0.0, right=0.0)
        return colour.SpectralDistribution(
            np.array(self.values),
            domain=np.array(self.wavelengths_nm),
            name=self.name or self.kind,
            interpolator=LinearInterpolator,
            extrapolator=Extrapolator,
            extrapolator_kwargs=kwargs,
        )

    # ----------------------------------------------------------------------- constructors
    @classmethod
    def from_name(cls, name: str, kind: Kind = "emission") -> Spectrum:
        """A spectrum shipped with colour-science, by name (case-insensitive).

        Emission: any illuminant or light source of colour-science (``"A"``, ``"D65"``,
        ``"FL11"`` or ``"F11"``, ``"LED-B3"``, ``"HPS"``, ...). Reflectance: the 24 ColorChecker
        patches (``"dark skin"``, ``"ColorChecker N Ohta/dark skin"``, ``"ColorChecker 13"``,
        ``"white"``) and the CIE 13.3 test colour samples ``"TCS01"``…``"TCS14"``. Unknown
        names raise :class:`SpectrumError` listing the closest matches.
        """
        from ._names import resolve

        _check_kind(kind)
        display, wl, v, source = resolve(name, kind)
        return cls(wl, v, kind, display, source=source)

    @classmethod
    def from_csv(cls, path: str | Path, kind: Kind = "emission", *, name: str | None = None):
        """Read a spectrum from a CSV file with a header row.

        Columns ``wavelength_nm`` and ``value`` (emission) or ``reflectance`` (reflectance);
        other columns are ignored, ``#`` starts a comment line. Errors name the file and line.
        """
        from ._csv import read_csv

        _check_kind(kind)
        path = Path(path)
        wl, v, lines = read_csv(path, kind)
        label = path.stem if name is None else name
        check_spectrum(wl, v, kind, name=label, file=path, lines=lines, warn=False)
        return cls(wl, v, kind, label, source=str(path))

    def to_csv(self, path: str | Path) -> Path:
        """Write this spectrum as CSV readable by :meth:`from_csv` (exact round trip); atomic."""
        from ._csv import write_csv

        return write_csv(Path(path), self.wavelengths_nm, self.values, self.kind, self.name)

    @classmethod
    def grey(cls, rho: float, *, name: str | None = None) -> Spectrum:
        """A spectrally flat reflectance ``rho`` (0 ≤ rho < 1)."""
        r = np.asarray(rho, dtype=np.float64)
        if r.ndim != 0:
            raise SpectrumError(f"grey reflectance must be one number, got shape {r.shape}")
        r = float(r)
        label = f"grey {r:g}" if name is None else name
        return cls(np.array([360.0, 830.0]), np.array([r, r]), "reflectance", label)

    @classmethod
    def from_srgb(cls, rgb: Sequence[float] | np.ndarray, *, name: str | None = None) -> Spectrum:
        """A reflectance recovered from an sRGB albedo (gamma-encoded, each channel in [0, 1]).

        Uses Mallett & Yuksel (2019)'s spectral primary decomposition (the basis colour-science
        ships, bundled with lumijax so no colour import is needed): the
        spectrum is ``r·B_r + g·B_g + b·B_b`` for the *linear* sRGB channels and three basis
        spectra that are each within [0, 1] and sum to 1 at every wavelength. So the reflectance
        is bounded by the largest linear channel (a grey gives a flat spectrum equal to its
        linear value) and reproduces the sRGB colour under D65. Albedos that recover a
        reflectance reaching 1 (white ``(1, 1, 1)``) are refused.
        """
        # the basis ships with lumijax (bitwise colour-science's): importing colour costs seconds
        from ._shipped import mallett2019_basis, srgb_decode

        try:
            c = np.array(rgb, dtype=np.float64)
        except (TypeError, ValueError):
            raise SpectrumError(f"sRGB albedo must be 3 numbers, got {rgb!r}") from None
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise SpectrumError(f"sRGB albedo must be 3 finite numbers, got {rgb!r}")
        if np.any(c < 0.0) or np.any(c > 1.0):
            hint = " (8-bit values? divide by 255)" if np.max(c) > 1.0 else ""
            raise SpectrumError(f"sRGB albedo channels must be in [0, 1], got {rgb!r}{hint}")
        linear = srgb_decode(c)
        wl, basis = mallett2019_basis()
        # what colour.recovery.RGB_to_sd_Mallett2019 computes: RGB · basisᵀ per wavelength
        values = np.clip(np.dot(linear, np.transpose(basis)), 0.0, None)
        label = "sRGB({:.4g}, {:.4g}, {:.4g})".format(*c) if name is None else name
        if np.max(values) >= 1.0:
            raise SpectrumError(
                f"reflectance must be < 1: sRGB albedo {tuple(c.tolist())} recovers a "
                f"reflectance of {np.max(values):.4g}; a real surface reflects less than it "
                "receives, so use an albedo below white",
                key=f"spectrum {label!r}",
            )
        return cls(
            wl.copy(),
            values,
            "reflectance",
            label,
            source="colour-science: RGB_to_sd_Mallett2019",
        )
