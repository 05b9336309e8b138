"""Spectral sampling for the radiosity solve: the wavelength-domain segmentation of Fasse & Paul
(1995) §5.2 / Deville et al. (1994), and the uniform and Gaussian (Meyer 1988) samplings it is
compared with.

A :class:`SpectralSampling` is a small set of wavelengths λ_i and weights H (3 × n) such that

    XYZ = ∫ B(λ) (x̄, ȳ, z̄)(λ) K_m dλ  ≈  H @ B(λ_i)

for the spectral radiosity B of the scene, so the solve runs at the λ_i only. All integrals are
taken on the CIE 1 nm grid 360–830 nm (rectangle rule, Δλ = 1 nm: colour-science's
``"Integration"`` method), with the CIE 1931 2° CMFs of colour-science and K_m = 683.002 lm/W, so
Y is photometric. The algorithm and the node-allocation rule are described in
``docs/spectra.md``.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import SpectrumError
from ._photometric import K_M
from ._spectrum import Spectrum

__all__ = [
    "SpectralSampling",
    "segment",
    "uniform_sampling",
    "gauss_sampling",
    "photometric_normalisation",
    "reference_grid",
]

#: Emission lines narrower than this (nm, full base width) get a trapezoid interval.
LINE_MAX_WIDTH_NM = 10.0
#: A data point is an emission line when it exceeds the mean of its two neighbours by this
#: fraction of the spectrum's maximum (and is a local maximum).
LINE_THRESHOLD = 0.04
#: A data point is a gradient break ("strong change of gradient") when the change of slope
#: times the local spacing exceeds this fraction of the spectrum's maximum.
KNEE_THRESHOLD = 0.03
#: Intervals narrower than this (nm) are merged into a neighbour (line intervals excepted).
MIN_INTERVAL_NM = 8.0
#: Most Gauss–Legendre nodes in one smooth interval.
MAX_GAUSS_NODES = 6
#: A line carrying at least this fraction of the light gets a node at its peak data point.
LINE_MIN_SHARE = 0.03
#: Coordinate-descent moves (nm) of the refinement, one sweep per entry.
REFINE_STEPS_NM = (8.0, 4.0, 2.0)
#: The bounces k of the training integrands E·ρ^k used to rank intervals.
TRAINING_BOUNCES = (1, 3)


@functools.cache
def reference_grid() -> tuple[np.ndarray, np.ndarray]:
    """The 1 nm grid (360–830 nm) and the CIE 1931 2° CMFs on it, shape (3, 471), read-only."""
    from ._cie import observer_tables

    wl, _, cmf = observer_tables()
    wl = wl.copy()
    xyz = cmf.T.copy()
    wl.setflags(write=False)
    xyz.setflags(write=False)
    return wl, xyz


@dataclass(frozen=True, eq=False)
class SpectralSampling:
    """Sample wavelengths and tristimulus weights for a sampled spectral solve.

    Attributes
    ----------
    wavelengths_nm
        ``(n,)`` strictly increasing sample wavelengths λ_i (nm).
    weights_xyz
        ``(3, n)`` weights H in lm per (W/nm): for a spectral power (or irradiance, or exitance)
        ``E`` sampled at λ_i, ``weights_xyz @ E(λ_i)`` is CIE 1931 2° XYZ with Y in lm (lx,
        lm/m²).
    weights_v
        ``(n,)``: the Y row, the photometric weights (K_m V(λ) folded in).
    method
        ``"segmentation"``, ``"segmentation/emission-weighted"``, ``"uniform"`` or ``"gauss"``.
    intervals
        One ``(lo_nm, hi_nm, rule, n_nodes)`` per interval, for reports; ``rule`` is
        ``"trapezoid"`` (an emission line, nodes at the data points) or ``"gauss"``
        (Gauss–Legendre nodes).
    emission
        For an emission-weighted sampling (:meth:`for_emission`), the spectrum it is exact for.
    """

    wavelengths_nm: np.ndarray
    weights_xyz: np.ndarray
    weights_v: np.ndarray
    method: str
    intervals: tuple[tuple[float, float, str, int], ...] = ()
    emission: Spectrum | None = None
    _basis: tuple | None = None  # (node groups per interval) to rebuild weights

    @property
    def n(self) -> int:
        return int(self.wavelengths_nm.size)

    def tristimulus(self, values: object) -> np.ndarray:
        """XYZ of spectral values sampled at λ_i: ``(..., n) -> (..., 3)``."""
        v = np.asarray(values, dtype=np.float64)
        return v @ self.weights_xyz.T

    def for_emission(self, emission: Spectrum) -> SpectralSampling:
        """The same wavelengths with weights tailored to light of this emission spectrum.

        The radiosity of a network whose luminaires share one spectrum E is B(λ) = E(λ)·g(λ),
        with g smooth (reflectances and their products). These weights fold E in:
        ``H_ci = K_m Σ_λ c̄(λ) E(λ) ℓ_i(λ) / E(λ_i)``, so only g is interpolated: emission lines, however sharp and wherever they fall, are
        integrated exactly, and ``weights_v @ E(λ_i)`` is the exact 1 nm photometric integral
        of E. ℓ_i is the not-a-knot cubic-spline basis through the nodes (constant beyond the
        ends). Valid for radiosity from this spectrum only (one sampling per network spectrum,
        same wavelengths). Nodes where E is zero get weight 0.
        """
        if not isinstance(emission, Spectrum) or emission.kind != "emission":
            raise SpectrumError("for_emission needs an emission Spectrum")
        wl, cmf = reference_grid()
        h = _emission_weights(
            self.wavelengths_nm, cmf, emission.at(wl), emission.at(self.wavelengths_nm)
        )
        return SpectralSampling(
            self.wavelengths_nm,
            _ro(h),
            _ro(h[1]),
            self.method.split("/")[0] + "/emission-weighted",
            self.intervals,
            emission,
            self._basis,
        )


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64, copy=True)
    a.setflags(write=False)
    return a


# ----------------------------------------------------------------------------- bases
def _lagrange(nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Lagrange basis of ``nodes`` at ``x``: shape (m, len(x)); m = 1 is the constant."""
    m = nodes.size
    out = np.ones((m, x.size))
    for i in range(m):
        for j in range(m):
            if i != j:
                out[i] *= (x - nodes[j]) / (nodes[i] - nodes[j])
    return out


def _hats(nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Piecewise-linear (trapezoid) basis of ``nodes`` at ``x``, constant beyond the ends."""
    m = nodes.size
    eye = np.eye(m)
    return (
        np.stack([np.interp(x, nodes, eye[i]) for i in range(m)]) if m > 1 else np.ones((1, x.size))
    )


def _basis_at(kind: str, nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    return _hats(nodes, x) if kind == "trapezoid" else _lagrange(nodes, x)


def _weights(nodes_all, basis, cmf, e_grid=None, e_nodes=None) -> np.ndarray:
    """Product-integration weights (3, n) on the 1 nm grid.

    ``basis`` is a tuple of (lo, hi, kind, node indices) covering the grid with half-open
    intervals. Generic (``e_grid`` None): the basis interpolates the whole integrand. Emission
    weighted: it interpolates integrand / E and E is folded into the weights.
    """
    wl, _ = reference_grid()
    h = np.zeros((3, nodes_all.size))
    for lo, hi, kind, idx in basis:
        sel = (wl >= lo) & ((wl < hi) | (hi >= wl[-1]))
        if not np.any(sel):
            continue
        x = wl[sel]
        idx = np.asarray(idx)
        if e_grid is None:
            phi = _basis_at(kind, nodes_all[idx], x)
            h[:, idx] += K_M * cmf[:, sel] @ phi.T
            continue
        lit = e_nodes[idx] > 1e-12 * max(float(np.max(e_nodes)), 1e-300)
        if not np.any(lit):  # all nodes dark: generic weights on this interval
            phi = _basis_at(kind, nodes_all[idx], x)
            h[:, idx] += K_M * cmf[:, sel] @ phi.T
            continue
        j = idx[lit]
        phi = _basis_at(kind, nodes_all[j], x)
        h[:, j] += K_M * (cmf[:, sel] * e_grid[sel]) @ phi.T / e_nodes[j]
    return h


def _make(nodes_groups, method, intervals) -> SpectralSampling:
    """Assemble a sampling from per-interval node groups [(lo, hi, kind, nodes)]."""
    allnodes = np.concatenate([g[3] for g in nodes_groups])
    order = np.argsort(allnodes, kind="stable")
    nodes = allnodes[order]
    # merge coincident nodes (shared data points of adjacent trapezoid intervals)
    uniq, inv = np.unique(np.round(nodes, 9), return_inverse=True)
    pos = np.empty(allnodes.size, dtype=int)
    pos[order] = inv
    basis, k = [], 0
    for lo, hi, kind, nd in nodes_groups:
        basis.append((lo, hi, kind, tuple(pos[k : k + nd.size].tolist())))
        k += nd.size
    basis = tuple(basis)
    _, cmf = reference_grid()
    h = _weights(uniq, basis, cmf)
    return SpectralSampling(_ro(uniq), _ro(h), _ro(h[1]), method, tuple(intervals), None, basis)


# ------------------------------------------------------------------ classic samplings
def _check_n(n: object) -> int:
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or not 1 <= int(n) <= 471:
        raise SpectrumError(f"number of samples must be an integer in 1..471, got {n!r}")
    return int(n)


def uniform_sampling(n: int, lo: float = 380.0, hi: float = 780.0) -> SpectralSampling:
    """n samples at the centres of n equal bins of [lo, hi] nm; each weight is its bin's
    integral of the CMFs (the binned-CMF renderer). The bins at the ends absorb 360–lo and
    hi–830, so a flat spectrum is integrated exactly."""
    n = _check_n(n)
    edges = np.linspace(lo, hi, n + 1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    edges[0], edges[-1] = 360.0, 831.0
    groups = [(edges[i], edges[i + 1], "gauss", centres[i : i + 1]) for i in range(n)]
    return _make(groups, "uniform", [(g[0], g[1], "box", 1) for g in groups])


def gauss_sampling(n: int, lo: float = 380.0, hi: float = 780.0) -> SpectralSampling:
    """Meyer's (1988) Gaussian quadrature: n Gauss–Legendre nodes on [lo, hi] nm and weights
    H_i = K_m w_i c̄(λ_i) (the CMF sampled at the node times the Gauss weight)."""
    n = _check_n(n)
    x, w = np.polynomial.legendre.leggauss(n)
    nodes = 0.5 * (hi - lo) * x + 0.5 * (hi + lo)
    w = 0.5 * (hi - lo) * w
    wl, cmf = reference_grid()
    c = np.stack([np.interp(nodes, wl, cmf[i]) for i in range(3)])
    h = K_M * c * w
    return SpectralSampling(
        _ro(nodes), _ro(h), _ro(h[1]), "gauss", ((lo, hi, "gauss", n),), None, None
    )


# ------------------------------------------------------------------------ segmentation
def _as_list(spectra, kind: str, what: str) -> list[Spectrum]:
    if isinstance(spectra, Spectrum):
        spectra = [spectra]
    out = list(spectra)
    for s in out:
        if not isinstance(s, Spectrum):
            raise SpectrumError(f"{what} must be Spectrum objects, got {type(s).__name__}")
        if s.kind != kind:
            raise SpectrumError(
                f"{what} must be {kind} spectra, got a {s.kind} spectrum",
                key=f"spectrum {s.name!r}",
            )
    return out


def _irregularities(s: Spectrum) -> tuple[list[tuple[float, float, float]], list[float]]:
    """Emission lines (peak, left, right) and gradient breaks (nm) of one spectrum's data."""
    wl, v = s.wavelengths_nm, s.values
    keep = (wl >= 355.0) & (wl <= 835.0)
    wl, v = wl[keep], v[keep]
    if wl.size < 3:
        return [], []
    scale = float(np.max(v)) or 1.0
    slope = np.diff(v) / np.diff(wl)
    dl, dr = np.diff(wl)[:-1], np.diff(wl)[1:]
    dslope = np.abs(np.diff(slope)) * 0.5 * (dl + dr) / scale
    excess = (v[1:-1] - 0.5 * (v[:-2] + v[2:])) / scale
    lines, knees = [], []
    for i in range(1, wl.size - 1):
        j = i - 1
        is_peak = v[i] >= v[i - 1] and v[i] >= v[i + 1]
        if (
            s.kind == "emission"
            and is_peak
            and excess[j] > LINE_THRESHOLD
            and wl[i + 1] - wl[i - 1] <= LINE_MAX_WIDTH_NM + 1e-9
        ):
            lines.append((float(wl[i]), float(wl[i - 1]), float(wl[i + 1])))
        elif dslope[j] > KNEE_THRESHOLD:
            knees.append(float(wl[i]))
    return lines, knees


@dataclass
class _Interval:
    lo: float
    hi: float
    kind: str  # "trapezoid" | "gauss"
    peak: tuple[float, float, float] | None = None  # (peak, left, right) data points
    m: int = 1

    def nodes(self, m: int | None = None) -> np.ndarray:
        m = self.m if m is None else m
        if self.kind == "trapezoid":
            p, a, b = self.peak
            return np.array([p]) if m == 1 else np.array([a, p, b])
        x, _ = np.polynomial.legendre.leggauss(m)
        return 0.5 * (self.hi - self.lo) * x + 0.5 * (self.hi + self.lo)

    def next_m(self) -> int | None:
        if self.kind == "trapezoid":
            return 3 if self.m == 1 else None
        return self.m + 1 if self.m < MAX_GAUSS_NODES else None


def _spline(nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Cubic-spline (not-a-knot) interpolation basis of ``nodes`` at ``x``, shape (m, len(x));
    constant beyond the end nodes. Reproduces constants (the basis sums to 1). Two nodes:
    linear; three: the parabola; one: the constant.

    The same spline as scipy's ``CubicSpline(nodes, eye(m), bc_type="not-a-knot")`` (its
    equations, solved densely: m ≤ 64), without importing scipy.interpolate, which cost 0.9 s
    of every run that segments (contended).
    """
    m = nodes.size
    if m == 1:
        return np.ones((1, x.size))
    if m == 2:
        return _hats(nodes, x)
    y = np.eye(m)
    dx = np.diff(nodes)[:, None]
    slope = np.diff(y, axis=0) / dx  # (m - 1, m)
    a = np.zeros((m, m))
    b = np.empty((m, m))
    if m == 3:  # both not-a-knot conditions coincide: the parabola through the three nodes
        a[0, :2] = 1.0
        a[1] = dx[1, 0], 2.0 * (dx[0, 0] + dx[1, 0]), dx[0, 0]
        a[2, 1:] = 1.0
        b[0], b[1], b[2] = 2.0 * slope[0], 3.0 * (dx[0] * slope[1] + dx[1] * slope[0]), 2.0 * slope[1]
    else:  # first derivatives s: C² at the interior nodes, third derivative continuous at the
        # second and the last but one
        i = np.arange(1, m - 1)
        a[i, i] = 2.0 * (dx[:-1, 0] + dx[1:, 0])
        a[i, i + 1] = dx[:-1, 0]
        a[i, i - 1] = dx[1:, 0]
        b[1:-1] = 3.0 * (dx[1:] * slope[:-1] + dx[:-1] * slope[1:])
        d = nodes[2] - nodes[0]
        a[0, 0], a[0, 1] = dx[1, 0], d
        b[0] = ((dx[0] + 2.0 * d) * dx[1] * slope[0] + dx[0] ** 2 * slope[1]) / d
        d = nodes[-1] - nodes[-3]
        a[-1, -1], a[-1, -2] = dx[-2, 0], d
        b[-1] = (dx[-1] ** 2 * slope[-2] + (2.0 * d + dx[-1]) * dx[-2] * slope[-1]) / d
    s = np.linalg.solve(a, b)
    t = (s[:-1] + s[1:] - 2.0 * slope) / dx  # the Hermite cubic of each interval, power form
    c = (t / dx, (slope - s[:-1]) / dx - t, s[:-1], y[:-1])
    xc = np.clip(x, nodes[0], nodes[-1])
    k = np.clip(np.searchsorted(nodes, xc, side="right") - 1, 0, m - 2)
    h = (xc - nodes[k])[:, None]
    return (((c[0][k] * h + c[1][k]) * h + c[2][k]) * h + c[3][k]).T


def _emission_weights(nodes: np.ndarray, cmf: np.ndarray, e_grid: np.ndarray, e_nodes):
    """Weights (3, n) that fold the emission in: H_ci = K_m Σ c̄ E ℓ_i / E(λ_i), ℓ the spline
    basis of the nodes where E is not zero (dark nodes get weight 0)."""
    wl, _ = reference_grid()
    h = np.zeros((3, nodes.size))
    lit = e_nodes > 1e-9 * float(np.max(e_grid))
    if not np.any(lit):
        return h
    phi = _spline(nodes[lit], wl)
    h[:, lit] = K_M * (cmf * e_grid) @ phi.T / e_nodes[lit]
    return h


@functools.cache
def _probes() -> tuple[Spectrum, ...]:
    """The CIE 13.3 test colour samples: generic reflectances every segmentation trains on (from
    the shipped tables, the same as ``Spectrum.from_name("TCS01", "reflectance")``...)."""
    from ._cie import test_colour_samples

    wl, values = test_colour_samples()
    return tuple(
        Spectrum(wl, values[i - 1], "reflectance", f"TCS{i:02d}",
                 source=f"colour-science: SDS_TCS['CIE 1995']['TCS{i:02d}']")
        for i in range(1, 15)
    )


def segment(
    emissions: Sequence[Spectrum] | Spectrum,
    reflectances: Sequence[Spectrum] | Spectrum = (),
    *,
    max_samples: int = 16,
    bounces: Sequence[int] = TRAINING_BOUNCES,
) -> SpectralSampling:
    """The wavelength-domain segmentation (Deville et al. 1994; Fasse & Paul 1995 §5.2).

    1. **Irregularities.** On each spectrum's own data points: emission lines (a local maximum
       above the mean of its neighbours by :data:`LINE_THRESHOLD` of the maximum, base no wider
       than :data:`LINE_MAX_WIDTH_NM`) and gradient breaks (change of slope × spacing above
       :data:`KNEE_THRESHOLD` of the maximum) of every emission and reflectance.
    2. **Intervals.** The sorted breaks cut the 1 nm CIE domain 360–830 nm; each line is its own
       ``"trapezoid"`` interval between its neighbouring data points; the rest are ``"gauss"``
       intervals, narrower ones than :data:`MIN_INTERVAL_NM` merged into a neighbour. The parts
       where every emission times the CMFs is zero get no node (dropped).
    3. **Allocation** (at most ``max_samples`` nodes), greedy. Every interval starts with no
       node. A step adds nodes to the one interval where they lower the training error most
       per node: a line goes from none to its peak data point, then to its three data points
       (trapezoid); a smooth interval from m to m + 1 Gauss–Legendre nodes (at most
       :data:`MAX_GAUSS_NODES`). The training error is the 4-norm of CIELAB ΔE*ab, each
       emission's own white, of the emission-weighted colours (:meth:`SpectralSampling.for_emission`)
       of E·g for every emission E and g = 1 and ρ^k for every reflectance given and the 14 CIE
       13.3 test colour samples (k in ``bounces``) against their 1 nm integrals. It stops at
       the budget or when no step lowers the error.
    4. **Weights.** ``weights_xyz``: generic, for any spectrum — product integration of the
       CMFs against the piecewise-linear (trapezoid) interpolant through the nodes,
       ``H_ci = K_m Σ_λ c̄(λ) ℓ_i(λ)`` on the 1 nm grid. :meth:`SpectralSampling.for_emission`
       gives the weights to use for radiosity from one emission spectrum (much more accurate).
    """
    em = _as_list(emissions, "emission", "emissions")
    rf = _as_list(reflectances, "reflectance", "reflectances")
    if not em:
        raise SpectrumError("segment needs at least one emission spectrum")
    if (
        not isinstance(max_samples, (int, np.integer))
        or isinstance(max_samples, bool)
        or max_samples < 1
    ):
        raise SpectrumError(f"max_samples must be a positive integer, got {max_samples!r}")
    ks = [int(k) for k in bounces]
    if not ks or any(k < 1 for k in ks):
        raise SpectrumError(f"bounces must be positive integers, got {bounces!r}")

    from ._cie import xyz_to_lab, xyz_to_xy

    wl, cmf = reference_grid()
    csum = cmf.sum(axis=0)
    w = np.zeros_like(wl)
    egrid = []
    for s in em:
        e = s.at(wl)
        y = float(cmf[1] @ e)
        if not y > 0.0:
            raise SpectrumError(
                "emission spectrum has no luminance (zero where V(λ) > 0)",
                key=f"spectrum {s.name!r}",
            )
        egrid.append(e / y)
        w += e * csum / y
    egrid = np.stack(egrid)  # (J, G), each with Y = 1
    g = [np.ones_like(wl)]
    for r in list(rf) + list(_probes()):
        rv = r.at(wl)
        g += [rv**k for k in ks]
    g = np.stack(g)  # (T, G)
    ref = np.einsum("jg,tg,cg->jtc", egrid, g, cmf)  # (J, T, 3), white Y = 1
    white = (egrid @ cmf.T)[:, None, :]  # (J, 1, 3)
    xy_w = xyz_to_xy(white)
    ref_lab = xyz_to_lab(ref, xy_w)

    # 1-2. irregularities and intervals
    support = np.flatnonzero(w > 1e-9 * w.max())
    dom_lo, dom_hi = float(wl[support[0]]), float(wl[support[-1]]) + 1.0
    lines, knees = [], []
    for s in em + rf:
        ln, kn = _irregularities(s)
        lines += ln
        knees += kn
    lines = sorted(set(lines), key=lambda t: -float(np.sum(w[(wl >= t[1]) & (wl < t[2])])))
    chosen: list[tuple[float, float, float]] = []
    for t in lines:  # the strongest non-overlapping lines
        if dom_lo <= t[0] < dom_hi and all(t[2] <= c[1] or t[1] >= c[2] for c in chosen):
            chosen.append(t)
    chosen.sort()
    cuts = {dom_lo, dom_hi}
    for t in chosen:
        cuts |= {max(t[1], dom_lo), min(t[2], dom_hi)}
    for k in knees:
        if dom_lo < k < dom_hi and not any(c[1] < k < c[2] for c in chosen):
            cuts.add(k)
    cuts = sorted(cuts)
    ivs: list[_Interval] = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        line = next((c for c in chosen if c[1] >= a - 1e-9 and c[2] <= b + 1e-9), None)
        ivs.append(_Interval(a, b, "trapezoid", line) if line else _Interval(a, b, "gauss"))

    def share(iv):
        return float(np.sum(w[(wl >= iv.lo) & (wl < iv.hi)]))

    changed = True
    while changed and len(ivs) > 1:  # narrow smooth intervals merge into a smooth neighbour
        changed = False
        for i, iv in enumerate(ivs):
            if iv.kind == "gauss" and iv.hi - iv.lo < MIN_INTERVAL_NM:
                nb = [j for j in (i - 1, i + 1) if 0 <= j < len(ivs) and ivs[j].kind == "gauss"]
                if nb:
                    j = min(nb, key=lambda j: share(ivs[j]))
                    a, b = sorted((i, j))
                    ivs[a : b + 1] = [_Interval(ivs[a].lo, ivs[b].hi, "gauss")]
                    changed = True
                    break
    for iv in ivs:
        iv.m = 0

    # 3. nodes: the strongest lines at their peak data points, the rest spread evenly over the
    # lit domain, then refined by coordinate descent on the training error.
    def error(nodes):
        gn = np.stack([np.interp(nodes, wl, gi) for gi in g])  # (T, n)
        out = np.empty_like(ref)
        for j in range(len(em)):
            en = np.interp(nodes, wl, egrid[j])
            h = _emission_weights(nodes, cmf, egrid[j], en)
            out[j] = (gn * en) @ h.T / K_M
        de = np.linalg.norm(xyz_to_lab(out, xy_w) - ref_lab, axis=-1)
        return float(np.mean(de**4) ** 0.25)

    n = int(min(max_samples, dom_hi - dom_lo))
    line_share = sorted(
        ((share(iv), iv.peak[0]) for iv in ivs if iv.kind == "trapezoid"), reverse=True
    )
    fixed = [p for sh, p in line_share if sh >= LINE_MIN_SHARE * float(np.sum(w))][: n // 2]
    free = n - len(fixed)
    edges = np.linspace(dom_lo, dom_hi, free + 1)
    nodes = np.unique(np.concatenate([0.5 * (edges[:-1] + edges[1:]), fixed]))
    best = error(nodes)
    for step in REFINE_STEPS_NM:
        for i in range(nodes.size):
            if nodes[i] in fixed:
                continue
            lo = nodes[i - 1] if i > 0 else dom_lo
            hi = nodes[i + 1] if i + 1 < nodes.size else dom_hi
            for d in (-step, step):
                x = nodes[i] + d
                if not lo + 1.0 <= x <= hi - 1.0:
                    continue
                trial = nodes.copy()
                trial[i] = x
                e2 = error(trial)
                if e2 < best:
                    best, nodes = e2, trial
    ms = [int(np.sum((nodes >= iv.lo) & (nodes < iv.hi))) for iv in ivs]
    report = tuple((iv.lo, iv.hi, iv.kind, m) for iv, m in zip(ivs, ms))
    basis = ((float(wl[0]), float(wl[-1]) + 1.0, "trapezoid", tuple(range(nodes.size))),)
    h = _weights(nodes, basis, cmf)
    return SpectralSampling(_ro(nodes), _ro(h), _ro(h[1]), "segmentation", report, None, basis)


def photometric_normalisation(emission: Spectrum, sampling: SpectralSampling) -> float:
    """The factor f with ``sampling.weights_v @ (f · E(λ_i)) == 1`` (to rounding).

    Multiply a luminaire's sampled spectrum by ``f`` times its illuminance (lx, from the
    photometric data) and its sampled Y is that illuminance exactly, whatever the spectrum:
    photometry stays exact. Raises :class:`SpectrumError` if the sampled emission is invisible
    (Y = 0 at the samples).
    """
    if not isinstance(emission, Spectrum) or emission.kind != "emission":
        raise SpectrumError("photometric_normalisation needs an emission Spectrum")
    y = float(sampling.weights_v @ emission.at(sampling.wavelengths_nm))
    if not y > 0.0:
        raise SpectrumError(
            f"emission has no luminance at the {sampling.n} sample wavelengths "
            f"({sampling.method}): add samples where it emits",
            key=f"spectrum {emission.name!r}",
        )
    return 1.0 / y
