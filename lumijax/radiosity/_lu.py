"""The direct solve of a small, concrete radiosity system on the host.

A new room whose padded patch count falls in a size class no earlier study compiled pays for
compiling the iterative solve (``radiosity_solve``, ≈ 0.6 s here, plus its tracing) before it
runs for a few milliseconds. Below :data:`DIRECT_WORK`, an LU factorisation of the dense
``I − ρF'`` (float64, NumPy's LAPACK) answers sooner and compiles nothing: the same system as
the iterative solve — the row correction ``F'`` and its change of variables, diffuse
transmission — judged on the same true residual, with the same escaped and created light. One
factorisation per distinct reflectance column (a grey room has one however many networks and
wavelengths share it), so the work is ``groups × P³``. Measured: ``docs/radiosity.md``,
"The direct solve of a small room".

Only for a solver that allows it (:attr:`~lumijax.radiosity.Refined.direct`, the default's),
only outside a trace (a traced solve — ``jit``, ``grad`` — stays the implicit-differentiated
Krylov solve) and only where the operator is one dense block (``_operator.dense_matrix``).
Where the residual misses the tolerance the caller runs the iterative solve as before.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DIRECT_WORK", "direct_groups", "direct_solve"]

DIRECT_WORK = 3 * 2048**3
"""Most ``groups × P³`` (distinct reflectance columns × patches cubed) solved directly: about
one LU of 2,950 patches, or three of 2,048, each ≈ 0.1–0.4 s here against ≈ 0.6–0.8 s of a
new size class's compile (docs/radiosity.md, "The direct solve of a small room")."""


def direct_groups(rho: np.ndarray, tau: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``(first, inverse)`` over the columns of ``rho`` (and ``tau``), ``(P, C)``: one
    factorisation per distinct column, ``inverse`` naming each column's."""
    key = rho if tau is None else np.concatenate([rho, tau])
    _, first, inverse = np.unique(key.T, axis=0, return_index=True, return_inverse=True)
    return first, inverse.reshape(-1)


def direct_solve(g: np.ndarray, area: np.ndarray, rho: np.ndarray, b0: np.ndarray,
                 tau: np.ndarray | None, partner: np.ndarray | None, correct_rows: bool,
                 groups: tuple[np.ndarray, np.ndarray] | None = None):
    """Solve ``(I − ρF' − τ P F') y = c B₀`` for every column, ``B = y / c``.

    ``g``: ``G = diag(A) F`` (m², ``(P, P)``); ``area`` (m²); ``rho``, ``b0`` and ``tau``
    ``(P, C)`` (B₀ in lm/m²); ``partner`` ``(P,)`` the transmitting patch's other side;
    ``groups``: :func:`direct_groups` of ``rho`` and ``tau`` where the caller has them (the
    row correction scales every column of a row alike, so they are the corrected system's).
    Returns ``(b, residual, escaped, created, row_max, closed)`` with ``b`` in B₀'s dtype,
    ``residual`` the worst column's relative max-norm residual of the returned values (float64
    arithmetic, as ``radiosity._solve``'s), ``escaped`` and ``created`` per column.
    """
    from ._solve import _flux_fractions, row_correction

    dtype = b0.dtype
    a = np.asarray(area, np.float64)
    f = np.asarray(g, np.float64) / a[:, None]
    rows = f.sum(axis=1)
    if correct_rows:
        c, closed = row_correction(rows)
    else:
        c, closed = np.ones_like(rows), np.asarray(False)
    rho_c = np.asarray(rho, np.float64) * c[:, None]
    tau_c = None if tau is None else np.asarray(tau, np.float64) * c[:, None]
    b0c = np.asarray(b0, np.float64) * c[:, None]
    first, inverse = direct_groups(rho, tau) if groups is None else groups
    y = np.empty(b0.shape, np.float64)
    system = np.empty_like(f)
    for k, j in enumerate(first):
        cols = np.flatnonzero(inverse == k)
        np.multiply(f, -rho_c[:, j, None], out=system)
        if tau_c is not None:
            system -= tau_c[:, j, None] * f[partner]
        system.flat[:: len(f) + 1] += 1.0
        y[:, cols] = np.linalg.solve(system, b0c[:, cols])
    # judged, as the iterative solve is, on the values returned (in B₀'s dtype)
    y = y.astype(dtype).astype(np.float64)
    fy = f @ y
    ky = rho_c * fy if tau_c is None else rho_c * fy + tau_c * fy[partner]
    residual = _relative(b0c - (y - ky), b0c)  # c = 1 without the correction
    b = (y / c[:, None]).astype(dtype)
    escaped, flux, total = _flux_fractions(a, b.astype(np.float64), rows * c)
    created = (flux * np.clip(rows - 1.0, 0.0, None)[:, None]).sum(axis=0) / total
    return b, residual, escaped.astype(dtype), created.astype(dtype), rows.max(), closed


def _relative(r: np.ndarray, b0: np.ndarray) -> float:
    """The worst column's ``‖r‖_∞ / ‖b0‖_∞`` (``‖r‖_∞`` where b0 is 0)."""
    num, den = np.abs(r).max(axis=0), np.abs(b0).max(axis=0)
    out = np.where(den > 0, num / np.where(den > 0, den, 1.0), num)
    return float(out.max()) if out.size else 0.0
