"""Solving the radiosity system ``(I − ρF) B = B₀`` for many right-hand sides at once.

Columns of ``B₀`` are independent problems (networks × wavelength samples); the operator acts on
the whole ``(P, ...)`` array, so every product is one batched dense matmul over all columns.
The method is a solver object (``_solvers.py``, registry :data:`RADIOSITY_SOLVERS`); the
default, :class:`Refined`, judges success on the true residual and recovers from Krylov
breakdown by itself (measured in ``docs/radiosity.md``, "Solver reliability").

Two things happen around every solve:

* **Row sums.** A discretised form-factor row may sum above 1 (patches meeting at close range,
  coincident surfaces): such a patch would pass on more light than it receives, and in a
  bright closed room that is amplified by 1/(1 − ρ). Each patch's outgoing light is rescaled
  to land in full and no more: ``F_ij → F_ij c_j`` with ``c_j = 1/s_j`` (``s_j = Σ_k F_jk``)
  when ``s_j > 1``, and for every patch in a *closed enclosure* (all rows of the patches that
  see anything within ``CLOSED_TOL`` of 1). By reciprocity ``Σ_i A_i F_ij = A_j s_j``, so the
  flux patch j sends out is then exactly ``A_j B_j min(s_j, 1)`` (``A_j B_j`` when closed):
  energy is conserved exactly, reciprocity only approximately (to the rows' deviation from 1).
  It is applied as a change of variables — ρ' = ρc, B₀' = cB₀, B = B'/c — so the operator is
  untouched and gradients flow through ρ as before.
* **Scaling.** Columns are scaled to unit maximum before the solve (the scale is a constant for
  autodiff, and the system is linear, so the answer and its derivatives are unchanged) so that
  one tolerance means the same thing for a bright and a dim network.

**Patch buckets.** The compiled solve sees the patch axis padded to :func:`patch_bucket` (a
multiple of 256, under 1/8 more above 4,096): padding patches have ρ = 0, B₀ = 0, area 1 and no
form factors, so they stay 0, see nothing (row sum 0: outside the closed test and the
correction) and carry no flux; the answer is cut back to the real patches. A new study of a
similar size then reuses the compiled ``_solve`` (XLA's persistent cache keys on shapes).

**Small solves.** A small study's solve compiles for longer than it runs: XLA:CPU spends
~2.6 s compiling the default solver's program (BiCGStab, the GMRES fallback, the
refinement's residuals) and ~0.03 s running it on 1,200 patches. A solve whose operator holds
at most :data:`SMALL_OPERATOR_BYTES` and whose ``b0`` at most :data:`SMALL_SOLVE` values
(padded patches × columns) is therefore compiled without LLVM's optimisation passes
(:func:`small_solve_options`). The operator's size decides because the unoptimised program's
extra run time grows with the entries each product reads, and less than in proportion with
the columns (a product over many columns amortises each entry). Measured in a new process
each, float32, unoptimised / optimised (session 19, alone; cold: compile and run, warm: the
stored executable's load and run):

============================  ===========  ===========  ===========  ===========
study (operator, b0)          cold s       warm s       chosen       why
                              unopt / opt  unopt / opt
============================  ===========  ===========  ===========  ===========
cube ρ 0.5 (13 MB, 1,792×1)   2.0 / 3.1    0.25 / 0.27  unoptimised  −1.0 s cold
furnished (13 MB, 2,304×1)    2.3 / 3.5    0.22 / 0.13  unoptimised  −1.2 s cold
office (63 MB, 5,120×4)       2.1 / 2.8    0.42 / 0.37  unoptimised  −0.7 s cold
demo (31 MB, 3,584×60)        4.1 / 6.6    0.81 / 0.60  unoptimised  −2.5 s cold
cube 10 k (231 MB, 10,240×1)  2.6 / 2.7    0.87 / 0.46  optimised    +0.4 s warm
============================  ===========  ===========  ===========  ===========

(Before session 19 the rule was b0's values alone, ≤ 65,536: the demo's solve was optimised
and the 10 k-patch cube's was not.)

Up to :data:`~lumijax.radiosity._operator.DENSE_PATCHES` padded patches (4,096: 64 MiB of
float32) the solve applies the operator as one dense block
(:func:`~lumijax.radiosity._operator.densified`): one BLAS product in place of a ``lax.scan``
per bucket in every product of the program, and a program that depends on the padded patch
count and the columns only, not on the study's block structure. Session 20, alternated runs
in new processes: the demo's solve stage, every cache empty, 2.71 / 2.58 s → 1.53 / 1.40 s;
the furnished room's solve compiled in 0.82 s against 1.09 s. Since then the small solve
also asks for XLA's older (LLVM IR) fusion emitters where XLA still has them
(:data:`lumijax._executables.LEGACY_EMITTERS`): the furnished room's solve, every cache
empty, compiled in 0.45–0.49 s against 1.0–1.1 s (three runs each). The answers agree to
rounding (largest difference 3·10⁻¹⁶ of the largest value in float64, 3·10⁻⁷ in float32, on
cube rooms).

**Direct solve.** Outside a trace, the default solver answers a small room (one dense block,
at most ``_lu.DIRECT_WORK`` of distinct reflectance columns × patches³) by one LU on the host
(``_lu.py``): no program compiled, the same residual, escaped and created light; where the
residual misses the tolerance, the iterative solve below runs as before.

**Lazy fallback.** The default solver (``Refined``: iterative refinement around BiCGStab, GMRES
taking over after two failed inner solves) is one program with both Krylov methods in it, and
GMRES is rarely needed. Outside a trace the solve therefore first runs the refinement without
its fallback (:meth:`~lumijax.radiosity.AbstractRadiositySolver.first_try`), which stops where
GMRES would take over; only if it stops so (not met, products left) is the whole solver
compiled and run, from the start (the products of both count). A first try that meets the
tolerance, or runs out of products, is the whole solver's answer: up to there the two take the
same steps. Inside a trace (``jit``, ``grad``) the one program with both is traced as before.
Without the fallback the furnished room's solve compiled in 1.10 s against 1.30 s
(unoptimised, float32; session 19).

**Distinct columns.** Two columns with the same reflectance and the same B₀ (in the solve's
precision) are the same problem: only the distinct ones are solved and the answer is broadcast
back to every column (``stats["columns_solved"]`` says how many were). A grey scene's sample
wavelengths are such copies once the spectral factor is taken out of B₀
(``lighting._spectral.solve_spectral``). Only concrete inputs are compared; under ``jit`` or
``grad`` every column is solved.

**Column batches.** The solve's memory grows with the columns (``_estimate.SOLVE_VECTORS``
patch vectors each): at 10⁶ patches × 288 columns all at once it would be ≈ 30 GiB. The
(distinct) columns are therefore solved in batches of ``_estimate.solve_column_batch`` (as
many as fit in half the available memory, ``LUMIJAX_MEMORY_BYTES``), each batch one call of the
same compiled solve: batches are made equal in size, the last padded with zero columns (which
stay zero and touch no other column's scalars), so one shape is compiled. Every column's
BiCGStab scalars are its own, so a batch changes no column's arithmetic; only the refinement's
outer stopping test and the GMRES fallback look at all the columns of a batch, and there a
column may take one more (tolerance-sized) correction than it would have alone. Under ``jit``
or ``grad`` the batches are traced one after the other and concatenated: the implicit
derivative of each is lineax's, as before.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
from jaxtyping import Array, Float, Int

from .. import _executables
from .._jit_cache import to_device
from ..errors import SolveError
from . import _progress
from ._krylov import column_max
from ._operator import Info, ReflectionOperator, TransportOperator, dense_matrix, densified
from ._solvers import (
    DEFAULT_RADIOSITY_SOLVER,
    RADIOSITY_SOLVERS,
    AbstractRadiositySolver,
    radiosity_solver,
)

__all__ = [
    "RadiositySolution",
    "solve_radiosity",
    "check_reflectance",
    "escaped_fraction",
    "row_correction",
    "distinct_columns",
    "CLOSED_TOL",
    "patch_bucket",
    "join_solutions",
]

CLOSED_TOL = 0.02
"""A scene is a closed enclosure when the row sum of every patch that sees anything (row sum
> ``BLIND_ROW``) is within this of 1; its rows are then normalised to exactly 1."""

BLIND_ROW = 0.01
"""Row sums at or below this belong to patches that see (almost) nothing — a face pressed
against another surface — and take no part in the closed test or the correction."""


class RadiositySolution(eqx.Module):
    """Result of :func:`solve_radiosity`.

    Attributes
    ----------
    value
        Radiosity (exitance) B, same shape and unit as B₀ (lm/m² for lumens).
    iterations
        Operator products used (Southwell: block shots).
    residual
        Achieved ``max_col ‖B₀ − (I − ρF')B‖_∞ / ‖B₀‖_∞`` (relative, per column, worst column)
        for the row-corrected F' the solve used.
    result
        A ``lineax.RESULTS`` code; ``RESULTS.successful`` when the tolerance was met.
    escaped
        Per column, the fraction of the flux leaving the surfaces that leaves the scene
        (``Σ A B (1 − min(s, 1)) / Σ A B``, s the row sums after correction): 0 in a closed
        room, never negative; information for open scenes.
    stats
        Method-specific counts, plus ``created``: per column, the fraction of the flux that
        rows summing above 1 would have created without the correction
        (``Σ A B max(s − 1, 0) / Σ A B``), ``row_max`` (largest row sum), ``closed`` and
        ``columns_solved`` (distinct columns solved, an int; module docstring).
    """

    value: Float[Array, "patches ..."]
    iterations: Int[Array, ""]
    residual: Float[Array, ""]
    result: lx.RESULTS
    escaped: Float[Array, "..."]
    stats: dict


def _concrete(x):
    try:
        return np.asarray(x)
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError):
        return None


def check_reflectance(transport: TransportOperator, rho) -> None:
    """Raise :class:`SolveError` unless 0 ≤ ρ < 1 everywhere (no-op on traced values)."""
    r = _concrete(rho)
    if r is None:
        return
    if not np.all(np.isfinite(r)):
        raise SolveError("reflectance contains NaN or infinite values")
    if np.any(r < 0):
        raise SolveError(f"reflectance must be ≥ 0, got a minimum of {r.min():.4g}")
    if np.any(r >= 1):
        rows = np.asarray(transport.row_sums())
        closed = float(np.mean(rows)) > 0.99
        where = "a closed enclosure" if closed else "the scene"
        raise SolveError(
            f"reflectance must be < 1, got a maximum of {r.max():.4g}: with ρ ≥ 1 {where} "
            "never absorbs the light it receives, so the radiosity system has no finite "
            "solution (mean form-factor row sum "
            f"{float(np.mean(rows)):.3f})",
            key="rho",
        )


def row_correction(
    rows: Float[Array, " patches"] | Float[np.ndarray, " patches"],
) -> tuple[Array | np.ndarray, Array | np.ndarray]:
    """``(c, closed)``: the per-patch factor ``c`` that rescales each patch's outgoing light
    (``F_ij → F_ij c_j``, module docstring) and whether the scene is a closed enclosure.

    ``rows`` are the form-factor row sums ``Σ_j F_ij`` (dimensionless); a NumPy array gives
    NumPy arrays (the direct solve, ``_lu``).
    """
    xp = np if isinstance(rows, np.ndarray) else jnp
    if xp is jnp:
        rows = jax.lax.stop_gradient(rows)
    seeing = rows > BLIND_ROW
    closed = xp.asarray(
        xp.all(xp.where(seeing, xp.abs(rows - 1.0) <= CLOSED_TOL, True)) & xp.any(seeing))
    target = xp.where(closed, 1.0, xp.minimum(rows, 1.0))
    c = xp.where(seeing, target / xp.where(seeing, rows, 1.0), 1.0)
    return c, closed


def escaped_fraction(transport: TransportOperator, b: Float[Array, "patches ..."]) -> Array:
    """Fraction of the exitance flux Σ A B that leaves the scene, per column (dimensionless),
    after the row correction of :func:`row_correction` (so never negative)."""
    rows = transport.row_sums()
    c, _ = row_correction(rows)
    return _flux_fractions(transport.area, b, rows * c)[0]


def _flux_fractions(area, b, rows_used):
    """``(escaped, flux, total)``: per column the fraction of the flux ``A|B|`` leaving the
    scene for the row sums the solve used, each patch's flux and the column's total (NumPy
    arrays in, NumPy out: the direct solve, ``_lu``)."""
    xp = np if isinstance(b, np.ndarray) else jnp
    if xp is jnp:
        b = jax.lax.stop_gradient(b)
    shape = (-1,) + (1,) * (b.ndim - 1)
    area = area.astype(b.dtype).reshape(shape)
    rows_used = rows_used.astype(b.dtype).reshape(shape)
    flux = area * xp.abs(b)
    total = xp.sum(flux, axis=0)
    total = xp.where(total != 0, total, 1.0)
    escaped = xp.sum(flux * xp.clip(1.0 - rows_used, 0.0, None), axis=0) / total
    return escaped, flux, total


def solve_radiosity(
    transport: TransportOperator,
    rho: Float[Array, "patches ..."],
    b0: Float[Array, "patches ..."],
    *,
    solver: AbstractRadiositySolver | str = DEFAULT_RADIOSITY_SOLVER,
    method: str | None = None,
    rtol: float | None = None,
    max_steps: int = 1000,
    correct_rows: bool = True,
    throw: bool = True,
    transmission: tuple | None = None,
    column_batch: int | None = None,
    progress=None,
) -> RadiositySolution:
    """Solve ``(I − ρF) B = B₀`` for all columns of ``B₀`` at once.

    Parameters
    ----------
    transport
        Form factors F from :func:`~lumijax.radiosity.build_operator`.
    rho
        Reflectance, dimensionless, 0 ≤ ρ < 1; ``(P,)`` (same for all columns) or any shape that
        broadcasts against ``B₀`` (e.g. ``(P, 1, W)`` for per-wavelength reflectance with
        ``B₀`` of shape ``(P, networks, W)``).
    b0
        Initial (reflected direct) exitance ``ρ E_direct`` (+ self-emission), lm/m², ``(P, ...)``.
    solver
        An :class:`AbstractRadiositySolver` or a name in :data:`RADIOSITY_SOLVERS` (the
        config's ``[solver] method``); default ``"refined"``.
    method
        The same as ``solver`` by name (kept for callers that pass the config's word).
    rtol
        Relative residual to reach, per column in the max norm (``[solver] tolerance``);
        default 1e-4 in float32 and 1e-9 in float64.
    max_steps
        Most operator products (``[solver] max_iterations``).
    correct_rows
        Rescale form-factor rows that sum above 1, and every row of a closed enclosure
        (module docstring). ``False`` solves with F as stored.
    throw
        Raise :class:`SolveError` if the tolerance is not met; otherwise report it in
        ``result``.
    transmission
        ``(tau, partner)`` for diffusely transmitting patches (``_transmission.py``): τ shaped
        like ``rho`` (0 where nothing is transmitted) and ``(P,)`` the other side's patch; the
        solve is then ``(I − ρF − τ P F) B = B₀``, with ``B₀ = ρ E + τ E[partner]`` the
        caller's. None: no transmission (the solve as above, bit for bit).
    column_batch
        Most columns solved at once (module docstring, "Column batches"); None: as many as
        fit in memory (``_estimate.solve_column_batch``).
    progress
        Called as ``progress(done, total)`` in columns of ``B₀`` after each batch (copies of a
        distinct column counted with it; None: nothing), and within a batch of at least
        :data:`REPORTED_SOLVE` values as its residual falls (``done`` the batch's share of
        columns times the fraction of the log residual covered, ``_progress``; GMRES only
        after each batch).
    """
    solver = radiosity_solver(method if method is not None else solver)
    check_reflectance(transport, rho)
    b0 = to_device(b0)  # host data: no eager kernel (a small study's run compiles dozens)
    if not jnp.issubdtype(b0.dtype, jnp.floating):
        b0 = b0.astype(jnp.result_type(float))
    if b0.shape[0] != transport.n_patches:
        raise SolveError(
            f"B₀ must have one row per patch ({transport.n_patches}), got shape {b0.shape}"
        )
    if rtol is None:
        rtol = 1e-9 if b0.dtype == jnp.float64 else 1e-4
    rho = to_device(rho)
    tau, partner = (None, None) if transmission is None else (
        to_device(transmission[0]), to_device(transmission[1], jnp.int32))
    # columns equal in ρ and B₀ but not in τ are not one column: τ joins the comparison
    columns = distinct_columns(rho, b0) if tau is None else distinct_columns(
        jnp.concatenate([_flat_columns(rho, b0), _flat_columns(tau, b0)]),
        jnp.concatenate([b0, b0]).reshape(2 * b0.shape[0], -1))
    args = (solver, float(rtol), int(max_steps), bool(correct_rows))
    if columns is None:  # traced: every column
        count = int(np.prod(b0.shape[1:], dtype=int))
        batch = _column_batch(column_batch, transport, count, b0.dtype)
        if batch >= count:
            b, iterations, residual, result, escaped, stats = _padded_solve(
                transport, rho, b0, solver, float(rtol), int(max_steps), bool(correct_rows),
                tau, partner)
        else:
            n = b0.shape[0]
            rho_f, b0_f = _flat_columns(rho, b0), b0.reshape(n, -1)
            tau_f = None if tau is None else _flat_columns(tau, b0)
            b, iterations, residual, result, escaped, stats = _batched_solve(
                transport, rho_f, b0_f, tau_f, partner, args, batch, progress, jnp)
            b = b.reshape(b0.shape)
            escaped = escaped.reshape(b0.shape[1:])
            stats = dict(stats, created=stats["created"].reshape(b0.shape[1:]))
        stats = dict(stats, columns_solved=count)
    else:
        # concrete: the columns picked and spread back in numpy (the same bits; eager jnp
        # gathers and reshapes would each compile a kernel per process)
        first, inverse = columns
        n = b0.shape[0]
        b0_h = np.asarray(b0)
        rho_u = _flat_columns(np.asarray(rho), b0_h, np)[:, first]
        tau_u = None if tau is None else _flat_columns(np.asarray(tau), b0_h, np)[:, first]
        batch = _column_batch(column_batch, transport, len(first), b0.dtype)
        count = len(inverse)
        told = None if progress is None else (  # in the caller's columns, copies included
            lambda done, total: progress(count * done // total, count))
        if told is not None and patch_bucket(n) * min(batch, len(first)) >= REPORTED_SOLVE:
            args = (solver.reporting(), *args[1:])  # progress from within each batch
        b0_u = b0_h.reshape(n, -1)[:, first]
        solved = (_direct(transport, rho_u, b0_u, tau_u, partner, float(rtol), bool(correct_rows))
                  if solver.solves_directly() else None)
        if solved is None:
            solved = _batched_solve(transport, rho_u, b0_u, tau_u, partner, args, batch, told,
                                    np)
        elif told is not None:
            told(1, 1)
        b_u, iterations, residual, result, escaped_u, stats = solved
        spread = not np.array_equal(inverse, np.arange(len(first)))  # spare a copy if all differ
        b = to_device((b_u[:, inverse] if spread else b_u).reshape(b0.shape))
        del b_u
        escaped = to_device(np.asarray(escaped_u)[inverse].reshape(b0.shape[1:]))
        created = np.asarray(stats["created"])[inverse].reshape(b0.shape[1:])
        stats = dict(stats, created=to_device(created), columns_solved=len(first))
    sol = RadiositySolution(b, iterations, residual, result, escaped,
                            {"direct": False, **stats})
    if throw:
        sol = _raise_if_failed(sol, solver, rtol, max_steps)
    return sol


def _direct(transport, rho, b0, tau, partner, rtol: float, correct_rows: bool):
    """:func:`_batched_solve`'s answer by an LU on the host (``_lu``), or None where that is
    not for this solve (not one dense block, more work than ``DIRECT_WORK``) or did not meet
    ``rtol`` (the iterative solve then runs as it would have)."""
    from ._lu import DIRECT_WORK, direct_groups, direct_solve

    n = transport.n_patches
    if float(n) ** 3 > DIRECT_WORK:  # first: grouping a large study's columns copies them
        return None
    groups = direct_groups(rho, tau)
    if len(groups[0]) * float(n) ** 3 > DIRECT_WORK:
        return None
    g = dense_matrix(transport, patch_bucket(n))
    if g is None:
        return None
    area = np.asarray(transport.area)
    b, residual, escaped, created, row_max, closed = direct_solve(
        g, area, rho, b0, tau, None if partner is None else np.asarray(partner), correct_rows,
        groups)
    if not residual <= rtol:  # NaN included
        return None
    dtype = b0.dtype
    stats = {"created": to_device(created), "row_max": to_device(np.asarray(row_max, dtype)),
             "closed": to_device(np.asarray(closed)), "direct": True}
    return (b, to_device(np.asarray(0, np.int32)), to_device(np.asarray(residual, dtype)),
            lx.RESULTS.successful, to_device(escaped), stats)


def _column_batch(column_batch, transport, count: int, dtype) -> int:
    """Columns per batch: the caller's, else as many as fit (``_estimate``)."""
    if column_batch is not None:
        if int(column_batch) < 1:
            raise SolveError(f"column_batch must be ≥ 1, got {column_batch}",
                             key="column_batch")
        return int(column_batch)
    from ._estimate import solve_column_batch

    return solve_column_batch(transport.n_patches, count, np.dtype(dtype).itemsize)


def _batched_solve(transport, rho, b0, tau, partner, args, batch: int, progress, xp):
    """:func:`_padded_solve` of the ``(P, C)`` columns in equal batches of at most ``batch``
    (module docstring, "Column batches"): ``xp=np`` for concrete columns (each batch's answer
    moved to one host array as it comes, so only one batch lives on the device), ``jnp``
    inside a trace. Per-column outputs concatenated, the rest the worst batch's."""
    count = b0.shape[1]
    n_batches = -(-count // max(int(batch), 1))
    size = -(-count // n_batches)
    pad = n_batches * size - count

    def padded(x, fill):
        if x is None or pad == 0:
            return x
        return xp.concatenate([x, xp.full((x.shape[0], pad), fill, x.dtype)], axis=1)

    solver, rtol, max_steps, correct_rows = args
    rho_p, b0_p, tau_p = padded(rho, 0), padded(b0, 0), padded(tau, 0)
    host = None if xp is jnp else np.empty(b0.shape, np.dtype(b0.dtype))
    values, parts = [], []
    for k in range(n_batches):
        lo, hi = k * size, min((k + 1) * size, count)
        cut = slice(lo, lo + size)
        within = contextlib.nullcontext() if progress is None or not solver.reports else (
            _progress.listening(lambda f, lo=lo, hi=hi: progress(lo + int(f * (hi - lo)), count)))
        with within:
            b, iterations, residual, result, escaped, stats = _padded_solve(
                transport, rho_p[:, cut], b0_p[:, cut], solver, rtol, max_steps, correct_rows,
                None if tau_p is None else tau_p[:, cut], partner)
        m = hi - lo

        def real(x, m=m):  # the batch's own columns (on the host: no eager kernel)
            x = x if host is None else np.asarray(x)
            return x if m == size else x[:m] if x.ndim == 1 else x[:, :m]

        if host is not None:
            host[:, lo:hi] = real(b)
        else:
            values.append(real(b))
        parts.append((iterations, residual, result, real(escaped),
                      {key: real(v) if key == "created" else v for key, v in stats.items()}))
        if progress is not None:
            progress(hi, count)
    value = host if host is not None else jnp.concatenate(values, axis=1)
    return (value, *_merge(parts))


def _merge(parts):
    """``(iterations, residual, result, escaped, stats)`` of column batches as one solve's:
    the most products and the worst residual and result; per-column arrays concatenated."""
    if len(parts) == 1:
        return parts[0]
    its, res, results, esc, stats = zip(*parts, strict=True)
    host = all(_concrete(x) is not None for x in (*its, *res, *esc))
    xp = np if host else jnp

    def worst(xs):
        out = xp.max(xp.stack([xp.asarray(_concrete(x) if host else x) for x in xs]), axis=0)
        return to_device(out) if host else out

    def cat(xs):
        out = xp.concatenate([xp.asarray(_concrete(x) if host else x) for x in xs])
        return to_device(out) if host else out

    result = results[0]
    for r in results[1:]:  # the first failure is the solve's
        result = lx.RESULTS.where(result == lx.RESULTS.successful, r, result)
    # a part solved directly carries fewer counts than an iterated one (``_direct``): where
    # join_solutions meets both, only the counts they share are merged
    merged = {key: (cat if key == "created" else worst)([s[key] for s in stats])
              for key in stats[0] if all(key in s for s in stats)}
    return worst(its), worst(res), result, cat(esc), merged


def join_solutions(parts: list[RadiositySolution]) -> RadiositySolution:
    """Solutions of consecutive slices of one set of columns (along the first column axis, as
    ``lighting.shoot`` batches its sources) as one: values and per-column figures
    concatenated, the most products and the worst residual and result, columns solved
    summed."""
    if len(parts) == 1:
        return parts[0]
    solved = sum(int(p.stats["columns_solved"]) for p in parts)
    iterations, residual, result, escaped, stats = _merge([
        (p.iterations, p.residual, p.result, p.escaped,
         {k: v for k, v in p.stats.items() if k != "columns_solved"}) for p in parts])
    host = [_concrete(p.value) for p in parts]
    value = (to_device(np.concatenate(host, axis=1)) if all(h is not None for h in host)
             else jnp.concatenate([p.value for p in parts], axis=1))
    return RadiositySolution(value, iterations, residual, result, escaped,
                             dict(stats, columns_solved=solved))


def _flat_columns(rho, b0, xp=jnp):
    """``rho`` broadcast to ``b0``'s shape, as ``(patches, columns)`` (rho as given: ``(P,)``
    is one value per patch for every column); ``xp=np`` for host arrays."""
    n = b0.shape[0]
    r = rho.reshape((n,) + (1,) * (b0.ndim - 1)) if rho.ndim == 1 else rho
    return xp.broadcast_to(r.astype(b0.dtype), b0.shape).reshape(n, -1)


def distinct_columns(rho, b0) -> tuple[np.ndarray, np.ndarray] | None:
    """``(first, inverse)``: the index of the first column of each distinct (ρ, B₀) column pair
    of ``b0`` flattened to ``(patches, columns)``, and for every column the distinct one it
    equals (bit for bit, in B₀'s precision), so ``x[:, first][:, inverse]`` rebuilds all of
    ``x``. None when the values are traced (nothing to compare)."""
    r, b = _concrete(rho), _concrete(b0)
    if r is None or b is None:
        return None
    n = b.shape[0]
    r = _flat_columns(r, b, np)
    b = b.reshape(n, -1)
    # hash each column (one pass, no (2P × C) sorted copy), then confirm equal bytes
    seen: dict[bytes, list[int]] = {}
    first: list[int] = []
    inverse = np.empty(b.shape[1], np.int64)
    for j in range(b.shape[1]):
        rj, bj = np.ascontiguousarray(r[:, j]), np.ascontiguousarray(b[:, j])
        key = hashlib.blake2b(rj.tobytes() + bj.tobytes(), digest_size=16).digest()
        for u in seen.get(key, ()):
            if np.array_equal(r[:, first[u]], rj) and np.array_equal(b[:, first[u]], bj):
                inverse[j] = u
                break
        else:
            seen.setdefault(key, []).append(len(first))
            inverse[j] = len(first)
            first.append(j)
    return np.asarray(first, np.int64), inverse


def patch_bucket(n: int) -> int:
    """The padded patch count the compiled solve sees for ``n`` patches: the next multiple of
    256, or of 2^(⌈log₂ n⌉ − 4) where that is larger (under n/8 of padding above 4,096; a
    small room's vectors stay small, the form-factor blocks cost the same either way)."""
    step = max(256, 1 << max(0, (int(n) - 1).bit_length() - 4))
    return -(-int(n) // step) * step


def _pad_rows(x, n, extra, value=0):
    if x is None:
        return None
    c = _concrete(x)
    if c is not None:  # numpy, then one transfer: eager jnp ops would each compile a kernel
        return to_device(np.concatenate([c, np.full((extra,) + c.shape[1:], value, c.dtype)]))
    x = jnp.asarray(x)
    return jnp.concatenate([x, jnp.full((extra,) + x.shape[1:], value, x.dtype)])


def _padded_solve(transport, rho, b0, solver, rtol, max_steps, correct_rows, tau, partner):
    """:func:`_solve` on the patch axis padded to :func:`patch_bucket` (module docstring)."""
    n = transport.n_patches
    extra = patch_bucket(n) - n
    padded = densified(transport, n + extra)  # a small study's: one block (module docstring)
    if padded is None and extra == 0:
        return _solve(transport, rho, b0, solver, rtol, max_steps, correct_rows, tau, partner)
    if padded is None:
        padded = dataclasses.replace(
            transport, area=_pad_rows(transport.area, n, extra, 1),
            block_of=_pad_rows(transport.block_of, n, extra, -1), n_patches=n + extra,
            info=Info())  # build statistics differ by study and would key a new compile

    def rows(x):  # per-patch arrays padded; other broadcastable shapes made per-patch first
        if x is None:
            return None
        c = _concrete(x)
        x = jnp.asarray(x) if c is None else c
        if x.ndim == 0 or x.shape[0] != n:
            x = jnp.broadcast_to(x, b0.shape) if c is None else np.broadcast_to(x, b0.shape)
        return _pad_rows(x, n, extra)

    b, iterations, residual, result, escaped, stats = _solve(
        padded, rows(rho), rows(b0), solver, rtol, max_steps, correct_rows, rows(tau),
        None if partner is None else _pad_rows(partner, n, extra))
    c = _concrete(b)  # outside a trace, the slice on the host (no eager kernel)
    return (b[:n] if c is None else to_device(c[:n])), iterations, residual, result, escaped, stats


def _solve(transport, rho, b0, solver, rtol, max_steps, correct_rows, tau=None, partner=None):
    """The compiled part of :func:`solve_radiosity` (once per shape and solver): in a run with
    the compilation cache on (the command line), through its stored executable
    (:mod:`lumijax._executables`: a new process neither traces nor lowers it again); else, and
    inside a trace, the jitted :func:`_solve_body`. The two give the same bits. Outside a
    trace the solver's :meth:`~AbstractRadiositySolver.first_try` runs first (module
    docstring, "Lazy fallback")."""
    args = (transport, rho, b0, solver, rtol, max_steps, correct_rows, tau, partner)
    # XLA takes options for a whole program only: inside a trace the caller's program decides
    traced = any(isinstance(x, jax.core.Tracer) for x in jax.tree.leaves(args))
    first = None if traced else solver.first_try()
    if first is None:
        return _solve_compiled(*args, traced=traced)
    out = _solve_compiled(transport, rho, b0, first, rtol, max_steps, correct_rows, tau,
                          partner, traced=False)
    # it stopped short of max_steps where the whole solver would go on (GMRES taking over);
    # met or out of products, the whole solver would have done the same steps. The codes are
    # compared on the host (an eager jnp comparison compiles a kernel per process).
    code = np.asarray(out[3]._value)
    done = (lx.RESULTS.successful, lx.RESULTS.max_steps_reached)
    if bool(np.all(np.isin(code, [np.asarray(r._value) for r in done]))):
        return out
    again = _solve_compiled(*args, traced=False)  # the whole solver, from the start
    return (again[0], again[1] + out[1], *again[2:])


def _solve_compiled(transport, rho, b0, solver, rtol, max_steps, correct_rows, tau, partner, *,
                    traced: bool):
    args = (transport, rho, b0, solver, rtol, max_steps, correct_rows, tau, partner)
    options = None if traced else compiler_options(transport, b0)
    if _executables.store_dir() is not None and not solver.reports:  # callbacks: not stored
        out = _executables.call("radiosity_solve", _solve_packed, args,
                           _executables.source_digest("radiosity/", "kernels/"),
                           compiler_options=options)
        if out is not None:
            stats = {k[6:]: v for k, v in out.items() if k.startswith("stats.")}
            result = eqx.tree_at(lambda r: r._value, lx.RESULTS.successful, out["result"])
            return (out["b"], out["iterations"], out["residual"], result, out["escaped"],
                    stats)
    return (_solve_jit if options is None else _solve_jit_small())(*args)


def compiler_options(transport, b0) -> dict | None:
    """XLA's options for one compiled program that applies ``transport`` to ``b0`` (padded
    patches × columns): :func:`small_solve_options` where compiling costs more than running
    (an operator of at most :data:`SMALL_OPERATOR_BYTES`, at most :data:`SMALL_SOLVE`
    values; module docstring, "Small solves"), else none. The solve and the patch output's
    product (``lighting._solution``) both ask here."""
    small = (transport.nbytes <= SMALL_OPERATOR_BYTES
             and int(np.prod(np.shape(b0))) <= SMALL_SOLVE)
    return small_solve_options() if small else None


def _solve_packed(*args) -> dict:
    """:func:`_solve_body` with its outputs as one flat dict of arrays (what
    :mod:`lumijax._executables` stores: lineax's RESULTS travels as its integer code)."""
    b, iterations, residual, result, escaped, stats = _solve_body(*args)
    return {"b": b, "iterations": iterations, "residual": residual, "result": result._value,
            "escaped": escaped, **{f"stats.{k}": jnp.asarray(v) for k, v in stats.items()}}


def _solve_body(transport, rho, b0, solver, rtol, max_steps, correct_rows, tau=None,
                partner=None):
    """The traced part of :func:`solve_radiosity`."""
    rows = transport.row_sums()
    shape = (-1,) + (1,) * (b0.ndim - 1)
    if correct_rows:
        c, closed = row_correction(rows)
    else:
        c, closed = jnp.ones_like(rows), jnp.asarray(False)
    c = c.astype(b0.dtype).reshape(shape)
    rho_c = jnp.asarray(rho, b0.dtype)
    rho_c = (rho_c.reshape(shape) if rho_c.ndim == 1 else rho_c) * c
    b0c = b0 * c
    # Per-column scale, constant for autodiff: B = s · solve(B₀ / s) for any s.
    scale = jax.lax.stop_gradient(column_max(b0c))
    scale = jnp.where(scale > 0, scale, 1.0)
    struct = jax.ShapeDtypeStruct(b0.shape, b0.dtype)
    if tau is not None:  # y = c B: row i of the transmitted term scales by c_i as ρ_i does
        tau = jnp.asarray(tau, b0.dtype)
        tau = (tau.reshape(shape) if tau.ndim == 1 else tau) * c
    op = ReflectionOperator(transport, rho_c, struct, tau=tau, partner=partner)
    x, iterations, result, stats = solver.run(op, b0c / scale, rtol, max_steps)
    y = x * scale
    residual = _residual(op, b0c, y) if correct_rows else _residual(op, b0, y)
    # A Krylov recurrence may flag breakdown on an exactly converged residual (a sphere's few
    # distinct eigenvalues; F = 0): the true residual of the returned B decides.
    result = lx.RESULTS.where(residual <= rtol, lx.RESULTS.successful, result)
    b = y / c
    used = rows.astype(b0.dtype).reshape(shape) * c
    escaped, flux, total = _flux_fractions(transport.area, b, used)
    excess = jnp.clip(rows.astype(b0.dtype).reshape(shape) - 1.0, 0.0, None)
    stats = dict(stats, created=jnp.sum(flux * excess, axis=0) / total,
                 row_max=jnp.max(rows), closed=closed)
    return b, jnp.asarray(iterations), residual, result, escaped, stats


SMALL_SOLVE = 1 << 18
"""Most values (padded patches × columns) of a solve compiled with
:func:`small_solve_options` (module docstring, "Small solves"): the largest measured, the
demo's 3,584 × 60, under it."""

SMALL_OPERATOR_BYTES = 128 << 20
"""Largest operator (``TransportOperator.nbytes``) of a solve compiled with
:func:`small_solve_options` (module docstring, "Small solves"): between the office's 63 MB
(unoptimised 0.7 s faster cold, 0.05 s slower warm) and the 10 k-patch cube's 231 MB (0.4 s
slower warm, no faster cold)."""

REPORTED_SOLVE = 1 << 22
"""Fewest values (padded patches × columns of a batch) of a solve whose solver reports its
steps when the caller asks for progress (``_progress``; ≈ 10⁵ patches × 40 columns, about a
second a product here): a smaller one is over before a report could help, and keeps its
stored executable (a program with host callbacks is not stored)."""

def small_solve_options() -> dict:
    """XLA's options for a small solve: LLVM's optimisation passes off, and XLA's older
    fusion emitters where it has them (:func:`lumijax._executables.unoptimised`)."""
    return _executables.unoptimised()


_solve_jit = eqx.filter_jit(_solve_body)


@functools.cache
def _solve_jit_small():
    # equinox passes keyword arguments on to jax.jit; its typed overloads do not list them
    return eqx.filter_jit(  # type: ignore[call-overload]
        _solve_body, compiler_options=small_solve_options())


def _residual(op: ReflectionOperator, b0, b):
    """Worst column's ``‖b0 − (I − K) b‖_∞ / ‖b0‖_∞``, in float64 when JAX has it."""
    wide = jnp.float64 if jax.config.read("jax_enable_x64") else b.dtype
    b0w, bw = b0.astype(wide), b.astype(wide)
    r = b0w - (bw - op.mv(bw))
    num, den = column_max(r), column_max(b0w)
    return jnp.max(jnp.where(den > 0, num / jnp.where(den > 0, den, 1.0), num)).astype(b.dtype)


_WHY = (
    (lx.RESULTS.breakdown, "the Krylov recurrence broke down"),
    (lx.RESULTS.max_steps_reached, "the budget of operator products ran out"),
    (lx.RESULTS.stagnation, "the residual stopped decreasing"),
)


def _name(solver: AbstractRadiositySolver) -> str:
    names = [k for k, v in RADIOSITY_SOLVERS.items() if type(solver) is v]
    return f'method = "{names[0]}"' if names else type(solver).__name__


def _raise_if_failed(sol: RadiositySolution, solver, rtol: float, max_steps: int):
    code, res = _concrete(getattr(sol.result, "_value", None)), _concrete(sol.residual)
    if code is not None and res is not None:  # on the host: eager jnp ops compile kernels
        failed = (code != np.asarray(lx.RESULTS.successful._value)) | (res > 10 * rtol)
        ok = np.asarray(~failed)
    else:
        failed = (sol.result != lx.RESULTS.successful) | (sol.residual > 10 * rtol)
        ok, res = _concrete(~failed), _concrete(sol.residual)
    hint = (f"raise [solver] max_iterations (now {max_steps}), loosen [solver] tolerance "
            f"(now {rtol:g}), or choose another [solver] method ({', '.join(RADIOSITY_SOLVERS)})")
    if ok is None or res is None:
        # Traced (jit/grad): a runtime check carried by the value, as lineax does.
        value = eqx.error_if(
            sol.value, failed,
            f"the radiosity solve ({_name(solver)}) did not reach [solver] tolerance = "
            f"{rtol:g}: {hint}")
        return eqx.tree_at(lambda s: s.value, sol, value)
    if not bool(ok):
        why = next((w for code, w in _WHY if bool(sol.result == code)),
                   "the residual is above tolerance")
        precision = ("; in float32 the attainable residual grows like 1/(1 − ρ): "
                     '[solver] precision = "float64" reaches further')
        raise SolveError(
            f"the radiosity solve ({_name(solver)}) did not converge: relative residual "
            f"{float(res):.3g} did not reach [solver] tolerance = {rtol:g} after "
            f"{int(_concrete(sol.iterations))} operator products ({why}). Check that "
            f"0 ≤ ρ < 1, or {hint}{precision if sol.value.dtype == jnp.float32 else ''}",
            key="solver",
        )
    return sol
