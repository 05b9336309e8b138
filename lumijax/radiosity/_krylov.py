"""Krylov solves of ``(I − K) x = b`` on ``(P, ...)`` arrays, column by column, as lineax solvers.

Two :class:`lineax.AbstractLinearSolver` subclasses, so that ``lineax.linear_solve`` gives them
its implicit differentiation (the tangent and the adjoint are solved by the same method, the
adjoint with the transposed operator):

* :class:`ColumnBiCGStab`: BiCGStab with its scalars per column (axis 0 is the patch axis,
  every other index an independent problem), so a column that converges or breaks down is
  frozen without disturbing the others, and breakdown is judged relative to the vectors' norms.
  ``lineax.BiCGStab`` shares one set of scalars over the whole array and, without
  ``jax_enable_x64``, flags breakdown whenever ρ, α or ω is *below* 1e-16 — negative values
  included, which BiCGStab meets routinely: that is the "iterative breakdown after 4 operator
  products" of float32 studies (docs/radiosity.md, "Solver reliability").
* :class:`Refinement`: iterative refinement. The outer loop forms the true residual
  ``r = b − (I − K) x`` (in float64 when JAX has 64-bit enabled, whatever the operator's
  storage), runs the inner solver on ``r`` and adds the correction; an inner solve that does
  not halve the true residual counts as a failure, and after ``restarts`` failures the
  fallback solver takes over. Success is judged on the true residual only.

Tolerances are absolute max-norms per column, for columns scaled to unit maximum:
:class:`ColumnScaled` does that scaling around a solver, so that the tangent and adjoint solves
lineax derives (whose right-hand sides are a tangent or a cotangent, of any magnitude) meet the
same relative tolerance as the primal one.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np

from ._progress import report

__all__ = ["ColumnBiCGStab", "ColumnScaled", "Refinement", "column_max"]


def column_max(x) -> jax.Array:
    """``max_p |x[p, ...]|`` per column, keeping axis 0 (shape ``(1, ...)``)."""
    return jnp.max(jnp.abs(x), axis=0, keepdims=True)


def _dot(a, b) -> jax.Array:
    return jnp.sum(a * b, axis=0, keepdims=True)


class _Transposable(lx.AbstractLinearSolver):
    """State = the operator itself; transposing or conjugating the solver acts on it."""

    def init(self, operator, options: dict[str, Any]):
        if operator.in_structure() != operator.out_structure():
            raise ValueError("a radiosity system is square")
        return operator

    def transpose(self, state, options: dict[str, Any]):
        return state.transpose(), options

    def conj(self, state, options: dict[str, Any]):
        return lx.conj(state), options

    def assume_full_rank(self):
        return True  # I − ρF with ρ < 1 and row sums ≤ 1 is non-singular


class ColumnScaled(lx.AbstractLinearSolver):
    """``solver`` on every column scaled to unit max-norm, the result scaled back (exact: the
    system is linear). An absolute tolerance of ``solver`` becomes relative to each column.

    lineax solves the adjoint ``(I − K)ᵀ λ = g`` with the solver it was given: unscaled, a
    cotangent g far below 1 would already "meet" the absolute tolerance at λ = 0 and come back
    as zero (a zero gradient wherever the primal right-hand side is zero, so that its scale,
    taken from B₀, is 1)."""

    solver: lx.AbstractLinearSolver

    def init(self, operator, options: dict[str, Any]):
        return self.solver.init(operator, options)

    def compute(self, state, vector, options: dict[str, Any]):
        scale = column_max(vector)
        scale = jnp.where(scale > 0, scale, 1.0)
        x, result, stats = self.solver.compute(state, vector / scale, options)
        return x * scale, result, stats

    def transpose(self, state, options: dict[str, Any]):
        return self.solver.transpose(state, options)

    def conj(self, state, options: dict[str, Any]):
        return self.solver.conj(state, options)

    def assume_full_rank(self):
        return self.solver.assume_full_rank()


class ColumnBiCGStab(_Transposable):
    """BiCGStab on every column independently (``stats``: ``num_steps``, ``products``).

    A column stops when its recursive residual's max-norm is ≤ ``atol``; it is frozen as
    *broken* when a denominator loses all digits (|ρ| ≤ 10 ε ‖r₀‖‖r‖, |⟨r₀, v⟩| ≤ 10 ε ‖r₀‖‖v‖,
    or ⟨t, t⟩ = 0) or when its best residual has not improved for ``stall`` steps. Each step
    costs two products.
    """

    atol: float
    max_steps: int
    stall: int = 20
    progress: bool = False  # the worst active column's best residual to ``_progress`` a step

    def compute(self, state, vector, options: dict[str, Any]):
        op = state
        b = vector
        eps = 10 * jnp.finfo(b.dtype).eps
        tol = jnp.asarray(self.atol, b.dtype)
        x = jnp.zeros_like(b)
        r0 = b
        one = jnp.ones_like(column_max(b))
        norm0 = jnp.sqrt(_dot(r0, r0))
        best = column_max(b)
        done = best <= tol
        carry = dict(x=x, r=b, p=jnp.zeros_like(b), v=jnp.zeros_like(b), rho=one, alpha=one,
                     omega=one, done=done, broken=jnp.zeros_like(done), best=best,
                     since=jnp.zeros(done.shape, jnp.int32), k=jnp.asarray(0))

        def cond(c):
            return jnp.any(~c["done"] & ~c["broken"]) & (c["k"] < self.max_steps)

        def body(c):
            active = ~c["done"] & ~c["broken"]
            r = c["r"]
            rho = _dot(r0, r)
            bad = jnp.abs(rho) <= eps * norm0 * jnp.sqrt(_dot(r, r))
            beta = (rho / _safe(c["rho"])) * (c["alpha"] / _safe(c["omega"]))
            p = r + beta * (c["p"] - c["omega"] * c["v"])
            v = op.mv(p)
            r0v = _dot(r0, v)
            bad = bad | (jnp.abs(r0v) <= eps * norm0 * jnp.sqrt(_dot(v, v)))
            alpha = rho / _safe(r0v)
            s = r - alpha * v
            half = column_max(s) <= tol  # converged half way: x + αp, no second product needed
            t = op.mv(s)
            tt = _dot(t, t)
            omega = jnp.where(half, 0.0, _dot(t, s) / _safe(tt))
            bad = bad | (~half & (tt == 0))
            x_new = c["x"] + alpha * p + omega * s
            r_new = s - omega * t
            bad = bad | ~jnp.all(jnp.isfinite(x_new) & jnp.isfinite(r_new), axis=0, keepdims=True)
            norm = column_max(r_new)
            improved = norm < c["best"]
            since = jnp.where(improved, 0, c["since"] + 1)
            bad = bad | (since >= self.stall)
            step = active & ~bad
            keep = lambda new, old: jnp.where(step, new, old)  # noqa: E731
            if self.progress:
                left = step & (norm > tol)
                # due after convergence: the refinement's true residual and the solve's own,
                # two products, one step (BiCGStab alone: one product)
                report(jnp.max(jnp.where(left, jnp.minimum(norm, c["best"]), 0.0)), tol,
                       c["k"] + 1, tail=1)
            return dict(
                x=keep(x_new, c["x"]), r=keep(r_new, r), p=keep(p, c["p"]), v=keep(v, c["v"]),
                rho=keep(rho, c["rho"]), alpha=keep(alpha, c["alpha"]),
                omega=keep(omega, c["omega"]), done=c["done"] | (step & (norm <= tol)),
                broken=c["broken"] | (active & bad),
                best=keep(jnp.minimum(norm, c["best"]), c["best"]), since=since, k=c["k"] + 1,
            )

        c = jax.lax.while_loop(cond, body, carry)
        result = lx.RESULTS.where(
            jnp.all(c["done"]), lx.RESULTS.successful,
            lx.RESULTS.where(jnp.any(c["broken"]), lx.RESULTS.breakdown,
                             lx.RESULTS.max_steps_reached))
        return c["x"], result, {"num_steps": c["k"], "products": 2 * c["k"]}


def _safe(d):
    return jnp.where(d == 0, 1.0, d)


def _products(solver, stats) -> jax.Array:
    """Operator products an inner solve used (lineax's GMRES counts restart cycles)."""
    if "products" in stats:
        return stats["products"]
    if isinstance(solver, lx.GMRES):
        # lineax's first step only forms the residual; each later one is a restart cycle
        return 1 + jnp.maximum(stats["num_steps"] - 1, 0) * (solver.restart + 1)
    return stats["num_steps"]


def _int32(x):
    """``x`` as int32; a constant count (some solvers' step counts are not traced) cast on the
    host, since an eager cast of a constant compiles a kernel even inside a trace."""
    try:
        return np.int32(np.asarray(x))
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError):
        return jnp.asarray(x, jnp.int32)


def _wide_mv(op, x):
    """``op.mv(x)`` for ``x`` wider than the operator's structure (lineax's composite
    operators refuse a dtype other than theirs; ours compute in the vector's precision)."""
    if isinstance(op, lx.AddLinearOperator):
        return _wide_mv(op.operator1, x) + _wide_mv(op.operator2, x)
    if isinstance(op, lx.NegLinearOperator):
        return -_wide_mv(op.operator, x)
    if isinstance(op, lx.IdentityLinearOperator):
        return x
    if isinstance(op, lx.TaggedLinearOperator):
        return _wide_mv(op.operator, x)
    from ._operator import ReflectionOperator

    if isinstance(op, ReflectionOperator):
        return op.mv(x)
    return op.mv(x.astype(op.in_structure().dtype)).astype(x.dtype)


class Refinement(_Transposable):
    """Iterative refinement around an inner Krylov solver, with a fallback solver.

    ``stats``: ``products`` (all operator products, residuals included), ``outer`` (true
    residuals formed), ``failures`` (inner solves that did not halve the true residual),
    ``fallback`` (whether the fallback solver was used). With ``fallback=None`` the loop stops
    where the fallback would have taken over (result: stagnation, unless the residual is met),
    and the program holds no fallback to compile.
    """

    inner: lx.AbstractLinearSolver
    fallback: lx.AbstractLinearSolver | None
    atol: float
    max_products: int
    restarts: int = 2
    max_outer: int = 12

    def compute(self, state, vector, options: dict[str, Any]):
        op = state
        b = vector
        wide = jnp.float64 if jax.config.read("jax_enable_x64") else b.dtype
        tol = jnp.asarray(self.atol, b.dtype)

        def residual(x):
            xw = x.astype(wide)
            return (b.astype(wide) - _wide_mv(op, xw)).astype(b.dtype)

        def cond(c):
            go_on = (c["norm"] > tol) & (c["outer"] < self.max_outer) & (
                c["products"] < self.max_products)
            if self.fallback is None:  # no fallback to take over: stop where it would
                go_on &= c["failures"] < self.restarts
            return go_on

        def body(c):
            r = c["r"]
            use_fallback = c["failures"] >= self.restarts

            def run(solver):
                def go(r):
                    d, _, stats = solver.compute(solver.init(op, {}), r, {})
                    return d, _int32(_products(solver, stats))
                return go

            if self.fallback is None:
                d, used = run(self.inner)(r)
            else:
                d, used = jax.lax.cond(use_fallback, run(self.fallback), run(self.inner), r)
            d = jnp.where(jnp.all(jnp.isfinite(d), axis=0, keepdims=True), d, 0.0)
            x_try = c["x"] + d
            r_try = residual(x_try)
            norm_try = jnp.max(column_max(r_try))
            better = norm_try < c["norm"]
            x = jnp.where(better, x_try, c["x"])
            r_new = jnp.where(better, r_try, r)
            failed = ~(norm_try <= 0.5 * c["norm"])
            return dict(
                x=x, r=r_new, norm=jnp.where(better, norm_try, c["norm"]),
                outer=c["outer"] + 1, products=c["products"] + used + 1,
                failures=c["failures"] + failed.astype(jnp.int32),
                # without a fallback, cond stops before use_fallback can be true here
                fallback=c["fallback"] | use_fallback,
            )

        x0 = jnp.zeros_like(b)
        carry = dict(x=x0, r=b, norm=jnp.max(column_max(b)), outer=jnp.asarray(0),
                     products=jnp.asarray(0, jnp.int32), failures=jnp.asarray(0, jnp.int32),
                     fallback=jnp.asarray(False))
        c = jax.lax.while_loop(cond, body, carry)
        result = lx.RESULTS.where(c["norm"] <= tol, lx.RESULTS.successful,
                                  lx.RESULTS.where(c["products"] >= self.max_products,
                                                   lx.RESULTS.max_steps_reached,
                                                   lx.RESULTS.stagnation))
        stats = {k: c[k] for k in ("products", "outer", "failures", "fallback")}
        return c["x"], result, stats

