"""Radiosity solvers as objects, and the one registry of them (``[solver] method``).

A solver is an immutable :class:`AbstractRadiositySolver`: it is given the reflection operator
``K = ρF``, the right-hand side scaled to unit maximum per column, an absolute max-norm
tolerance and a budget of operator products, and returns the solution with a lineax result
code. Adding a method is one final class, one line in :data:`RADIOSITY_SOLVERS` and its name
in the schema's ``RadiosityMethodName`` (the registry refuses, at import, a name missing on
either side: ``lumijax/_registry.py`` says why the config cannot import the registry).

Measured products, time and true residuals of every method on the regression rooms:
``docs/radiosity.md``, "Solver reliability".
"""

from __future__ import annotations

import abc
import dataclasses
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx

from .._registry import Registry
from ..config._schema import RadiosityMethodName
from ._krylov import ColumnBiCGStab, ColumnScaled, Refinement
from ._operator import ReflectionOperator
from ._progress import report

__all__ = [
    "AbstractRadiositySolver",
    "AbstractKrylovSolver",
    "BiCGStab",
    "GMRES",
    "Refined",
    "Jacobi",
    "Southwell",
    "RADIOSITY_SOLVERS",
    "DEFAULT_RADIOSITY_SOLVER",
    "radiosity_solver",
]


class AbstractRadiositySolver(eqx.Module):
    """How ``(I − K) x = b`` is solved, for ``K = ρF`` and all columns of ``b`` at once."""

    differentiable: ClassVar[bool] = False

    @abc.abstractmethod
    def run(self, op: ReflectionOperator, b, atol: float, max_products: int):
        """Solve for ``x``; ``b`` has unit maximum per column and ``atol`` is the max-norm
        residual to reach per column. Returns ``(x, products, result, stats)``."""

    def reporting(self) -> AbstractRadiositySolver:
        """This solver telling :mod:`._progress` its worst residual after every step (the same
        arithmetic, one host callback a step); a method without such steps (GMRES: lineax's
        loop) returns itself."""
        return self

    def first_try(self) -> AbstractRadiositySolver | None:
        """A cheaper-to-compile solver to run first, outside any trace: where it does not
        succeed, this one runs (``radiosity._solve``, "Lazy fallback"); None: no such thing."""
        return None

    @property
    def reports(self) -> bool:
        """Whether :meth:`run` reports its steps (a program with host callbacks)."""
        return False

    def solves_directly(self) -> bool:
        """Whether a small solve outside any trace may be answered by an LU factorisation on
        the host instead (``radiosity._lu``): only a solver that promises the tolerance, not a
        method, says yes (the default's :attr:`Refined.direct`)."""
        return False


class _Stepwise(eqx.Module):
    """A solver whose own loop tells ``_progress`` each step when ``progress`` is set
    (BiCGStab, Jacobi, Southwell; listed first among their bases, so these methods win)."""

    progress: bool = False

    def reporting(self):
        return dataclasses.replace(self, progress=True)

    @property
    def reports(self) -> bool:
        return self.progress


class AbstractKrylovSolver(AbstractRadiositySolver):
    """A solver that is a lineax linear solver, differentiated implicitly by lineax (tangent
    and adjoint solves with the same method; the adjoint uses ``Kᵀ = Fᵀρ``)."""

    differentiable: ClassVar[bool] = True

    @abc.abstractmethod
    def linear_solver(self, atol: float, max_products: int) -> lx.AbstractLinearSolver:
        """The lineax solver reaching ``atol`` within about ``max_products`` products."""

    @abc.abstractmethod
    def products(self, stats: dict) -> jax.Array:
        """Operator products used, from the lineax solution's ``stats``."""

    def run(self, op, b, atol, max_products):
        system = lx.IdentityLinearOperator(op.in_structure()) - op
        sol = lx.linear_solve(system, b, ColumnScaled(self.linear_solver(atol, max_products)),
                              throw=False)
        x = jnp.where(jnp.all(jnp.isfinite(sol.value), axis=0, keepdims=True), sol.value, 0.0)
        return x, self.products(sol.stats), sol.result, dict(sol.stats)


class BiCGStab(_Stepwise, AbstractKrylovSolver):
    """BiCGStab per column with relative breakdown tests (:class:`ColumnBiCGStab`): fewest
    products on a good day; stops with ``RESULTS.breakdown`` on a bad one."""

    stall: int = 20

    def linear_solver(self, atol, max_products):
        return ColumnBiCGStab(atol=atol, max_steps=max(max_products // 2, 1), stall=self.stall,
                              progress=self.progress)

    def products(self, stats):
        return stats["products"]


class GMRES(AbstractKrylovSolver):
    """lineax's restarted GMRES (``restart`` products per cycle). One Krylov space over all
    columns together; never breaks down, but spends whole restart cycles."""

    restart: int = 10

    def linear_solver(self, atol, max_products):
        cycles = max((max_products - 1) // (self.restart + 1), 1) + 1
        return lx.GMRES(rtol=0.0, atol=atol, max_steps=cycles, restart=self.restart)

    def products(self, stats):
        # the first lineax step only forms the residual; each later one is a restart cycle
        return 1 + jnp.maximum(stats["num_steps"] - 1, 0) * (self.restart + 1)


class Refined(AbstractKrylovSolver):
    """The default: iterative refinement on the true residual (float64 when JAX has 64-bit
    enabled) around ``inner``, falling back to ``fallback`` after ``restarts`` inner solves
    that did not halve it (:class:`Refinement`). Succeeds only on the true residual.

    With ``direct`` (the default) a small room's solve outside any trace is an LU
    factorisation on the host instead, judged on the same residual (``radiosity._lu``: no
    program to compile); ``direct=False`` always iterates."""

    inner: AbstractKrylovSolver = BiCGStab()
    fallback: AbstractKrylovSolver | None = GMRES()  # None: stop where it would take over
    restarts: int = 2
    direct: bool = True

    def solves_directly(self) -> bool:
        return self.direct

    def linear_solver(self, atol, max_products):
        half = 0.5 * atol  # the inner target: one inner solve usually suffices
        return Refinement(
            inner=self.inner.linear_solver(half, max_products),
            fallback=(None if self.fallback is None
                      else self.fallback.linear_solver(half, max_products)),
            atol=atol, max_products=max_products, restarts=self.restarts,
        )

    def first_try(self) -> Refined | None:
        """This refinement without its fallback (no GMRES in its program: the furnished
        room's compiled in 1.10 s, not 1.30 s); None when it has none."""
        return None if self.fallback is None else dataclasses.replace(self, fallback=None)

    def products(self, stats):
        return stats["products"]

    def reporting(self):
        return dataclasses.replace(
            self, inner=self.inner.reporting(),
            fallback=None if self.fallback is None else self.fallback.reporting())

    @property
    def reports(self) -> bool:
        return self.inner.reports or (self.fallback is not None and self.fallback.reports)


class Jacobi(_Stepwise, AbstractRadiositySolver):
    """``x ← b + K x``: products grow like 1/(1 − ρ). Forward only, for comparison."""

    def run(self, op, b, atol, max_products):
        def cond(c):
            _, r, k = c
            return (r > atol) & (k < max_products)

        def body(c):
            x, _, k = c
            new = b + op.mv(x)
            r = jnp.max(jnp.abs(new - x))
            if self.progress:  # the solve's final residual is one more product
                report(r, atol, k + 1, tail=1)
            return new, r, k + 1

        x, r, k = jax.lax.while_loop(cond, body, (b, jnp.asarray(jnp.inf, b.dtype), 0))
        result = lx.RESULTS.where(r > atol, lx.RESULTS.max_steps_reached,
                                  lx.RESULTS.successful)
        return x, k, result, {}


class Southwell(_Stepwise, AbstractRadiositySolver):
    """Progressive shooting by blocks (Southwell relaxation on the block system), the paper's
    method. Forward only.

    The unshot exitance U starts at b; each shot takes the block with the largest unshot flux
    Σ A|U|, sends it through F (only pairs touching that block are computed), adds the reflected
    part to x and to U, and clears the block's U. Stops when the unshot flux is below ``atol``
    of the initial flux; ``max_products`` counts full sweeps (one shot per block).
    """

    def run(self, op, b, atol, max_products):
        tr = op.transport
        block_of = tr.block_of
        nb = tr.n_blocks
        area = tr.area.astype(b.dtype).reshape((-1,) + (1,) * (b.ndim - 1))
        total0 = jnp.sum(area * jnp.abs(b))
        mask_shape = (-1,) + (1,) * (b.ndim - 1)

        def flux(u):
            per_patch = jnp.sum(jnp.abs(u * area).reshape(u.shape[0], -1), axis=1)
            return jax.ops.segment_sum(per_patch, block_of, nb)

        def cond(c):
            _, u, k = c
            return (jnp.sum(flux(u)) > atol * total0) & (k < max_products * nb)

        def body(c):
            x, u, k = c
            blk = jnp.argmax(flux(u))
            shoot = jnp.where((block_of == blk).reshape(mask_shape), u, 0.0)
            dx = op.rho * tr.matmul_from_block(shoot, blk)
            u = u - shoot + dx
            if self.progress:  # a shot is a block's column of F: the final residual, nb shots
                report(jnp.sum(flux(u)) / total0, atol, k + 1, tail=nb)
            return x + dx, u, k + 1

        x, u, k = jax.lax.while_loop(cond, body, (b, b, 0))
        left = jnp.sum(flux(u)) > atol * total0
        result = lx.RESULTS.where(left, lx.RESULTS.max_steps_reached, lx.RESULTS.successful)
        return x, k, result, {"shots": k}


RADIOSITY_SOLVERS: Registry[type[AbstractRadiositySolver]] = Registry(
    "solver.method", RadiosityMethodName, {
        "refined": Refined,
        "bicgstab": BiCGStab,
        "gmres": GMRES,
        "southwell": Southwell,
        "jacobi": Jacobi,
    })
"""Every ``[solver] method`` by name (checked at import against the schema's
``RadiosityMethodName``); each class builds with its defaults."""

DEFAULT_RADIOSITY_SOLVER = "refined"


def radiosity_solver(solver: AbstractRadiositySolver | str) -> AbstractRadiositySolver:
    """The solver object for a registry name (or the object itself)."""
    if isinstance(solver, AbstractRadiositySolver):
        return solver
    return RADIOSITY_SOLVERS[solver]()  # an unknown name: ConfigError naming solver.method

