"""Bounded minimisation of ``f(x) = ½‖r(x)‖²`` with optimistix and jaxopt, step by step.

Every solver honours the box ``lo ≤ x ≤ hi`` exactly:

* ``"lbfgsb"`` (the default: scipy's L-BFGS-B, the reference Fortran code, driven by one
  compiled ``value_and_grad`` — one compilation, about one evaluation per step) and jaxopt's
  ``"jaxopt_lbfgsb"`` (the same method in JAX, every step on the device) and
  ``"projected_gradient"`` take the box natively;
* optimistix ``"levenberg_marquardt"``, ``"gauss_newton"``, ``"dogleg"`` (least squares on r)
  and ``"bfgs"`` (on f) solve for an unbounded z with ``x = lo + (hi − lo)·(1 + sin z)/2``, a
  map onto the box (MINUIT's transform): every z gives an x inside, so no step can leave it.
  Its derivative vanishes on the bounds, so a start on a bound is moved inside by 0.1 % of the
  range first.

Solvers are stepped one iteration at a time (each step compiled once) so that the objective
history is recorded; the returned point is clipped to the box, which changes it by at most
rounding. The point returned is the best one visited (``"gauss_newton"`` takes undamped
steps, which can overshoot when a bound is active: prefer ``"levenberg_marquardt"``, its damped
form, there).

Each method is a final :class:`AbstractOptimiser` (lineax's pattern: a solver is an object, not
a string); :data:`OPTIMISERS` is the registry of the names ``optimise.solver`` accepts, checked
against the schema's ``OptimiserName`` at import. Adding a method is one class and one line there
(and the name in the schema's ``Literal``).
"""

from __future__ import annotations

import abc
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._registry import Registry
from ..config._schema import OptimiserName

__all__ = ["SOLVERS", "OPTIMISERS", "DEFAULT_OPTIMISER", "AbstractOptimiser", "SolverRun",
           "minimise", "ScipyLBFGSB", "JaxoptLBFGSB", "ProjectedGradient", "LevenbergMarquardt",
           "GaussNewton", "Dogleg", "BFGS"]

_STALL = 5  # steps without relative decrease beyond the tolerance before giving up

Residuals = Callable[[Any, Any], Any]  # (x, args) -> r(x), a pure JAX function


@dataclass
class SolverRun:
    """Where a solver stopped: variables, ``f`` after each step (``history[0]`` at the start),
    steps taken and whether its own convergence test passed."""

    solver: str
    x: Any  # numpy after minimise() (clipped to the box); the solver's own array before
    history: list[float] = field(default_factory=list)
    iterations: int = 0
    converged: bool = False
    seconds: float = 0.0
    evaluations: int = 0  # objective (and gradient) evaluations, line searches included


class AbstractOptimiser(eqx.Module):
    """A bounded minimiser of ``½‖r(x)‖²``; ``name`` is its key in :data:`OPTIMISERS`."""

    name: eqx.AbstractClassVar[str]

    @abc.abstractmethod
    def run(self, residuals: Residuals, args, x0, lo, hi, max_steps: int,
            tolerance: float) -> SolverRun:
        """Minimise from ``x0`` (inside the box) and return the best point visited."""


def _value(residuals):
    def f(x, args):
        r = residuals(x, args)
        return 0.5 * jnp.sum(r * r)

    return f


def _stalled(history, tolerance) -> bool:
    if len(history) <= _STALL:
        return False
    old, new = history[-_STALL - 1], history[-1]
    return old - new <= tolerance * max(abs(old), 1e-30)


@functools.lru_cache(maxsize=16)
def _value_and_grad(residuals):
    """``(f, ∇f)`` compiled once per residual function (and per shape of its arguments)."""
    return jax.jit(jax.value_and_grad(_value(residuals)))


class ScipyLBFGSB(AbstractOptimiser):
    """scipy's L-BFGS-B on the compiled f and ∇f: the line search and the limited-memory
    update run in Fortran on 2 × steps floats, so nothing but f and ∇f is ever compiled."""

    name: ClassVar[str] = "lbfgsb"

    def run(self, residuals, args, x0, lo, hi, max_steps, tolerance):
        from scipy.optimize import minimize

        vg = _value_and_grad(residuals)
        dtype = x0.dtype
        evaluations = 0

        def fun(x):
            nonlocal evaluations
            evaluations += 1
            v, g = vg(jnp.asarray(x, dtype), args)
            return float(v), np.asarray(g, np.float64)

        f0 = fun(np.asarray(x0))[0]
        run = SolverRun(self.name, x0, [f0])
        best = [np.asarray(x0, np.float64), f0]

        def callback(intermediate_result):
            fx = float(intermediate_result.fun)
            run.history.append(fx)
            run.iterations += 1
            if fx < best[1]:
                best[:] = [np.array(intermediate_result.x), fx]
            if _stalled(run.history, tolerance):
                run.converged = True
                raise StopIteration

        res = minimize(fun, np.asarray(x0, np.float64), jac=True, method="L-BFGS-B",
                       bounds=list(zip(np.asarray(lo), np.asarray(hi), strict=True)),
                       callback=callback,
                       options=dict(maxiter=max_steps, maxfun=max(20 * max_steps, 100),
                                    gtol=tolerance, ftol=0.0, maxcor=10))
        # scipy's own test: the projected gradient below the tolerance (ftol = 0: the relative
        # decrease test is ours, _stalled, so that every solver stops alike)
        run.converged = run.converged or (res.status == 0 and run.iterations < max_steps)
        run.evaluations = evaluations
        run.x = best[0]
        return run


@functools.lru_cache(maxsize=16)
def _jaxopt_steps(optimiser: _AbstractJaxoptBox, residuals):
    """Compiled init/update/f of a jaxopt box solver, kept between calls. Step limit and
    tolerance are checked here in Python, not baked into the compiled step, so a fit with other
    settings, or other goal values of the same kinds, compiles nothing."""
    f = _value(residuals)
    opt = optimiser.make(f)
    return jax.jit(opt.init_state), jax.jit(opt.update), jax.jit(f)


class _AbstractJaxoptBox(AbstractOptimiser):
    """A jaxopt solver that takes the box natively, stepped from Python."""

    @abc.abstractmethod
    def make(self, f):
        """The jaxopt solver of ``f(x, args)``, without its own stopping test."""

    def run(self, residuals, args, x0, lo, hi, max_steps, tolerance):
        init, update, value = _jaxopt_steps(self, residuals)
        bounds = (lo, hi)
        state = init(x0, bounds, args)
        x = best = x0
        history = [float(value(x, args))]
        run = SolverRun(self.name, x, history)
        for i in range(max_steps):
            x_new, state = update(x, state, bounds, args)
            fx = float(value(x_new, args))
            if not np.isfinite(fx):
                break
            x = x_new
            history.append(fx)
            if fx < min(history[:-1]):
                best = x
            run.iterations = i + 1
            run.evaluations = run.iterations + 1
            if float(state.error) <= tolerance or _stalled(history, tolerance):
                run.converged = True
                break
        run.x = best
        return run


class JaxoptLBFGSB(_AbstractJaxoptBox):
    """jaxopt's L-BFGS-B: the same method as scipy's, every step on the device."""

    name: ClassVar[str] = "jaxopt_lbfgsb"

    def make(self, f):
        import jaxopt

        return jaxopt.LBFGSB(fun=f, maxiter=10**9, tol=0.0, jit=True)


class ProjectedGradient(_AbstractJaxoptBox):
    """jaxopt's projected gradient onto the box."""

    name: ClassVar[str] = "projected_gradient"

    def make(self, f):
        import jaxopt

        return jaxopt.ProjectedGradient(fun=f, projection=jaxopt.projection.projection_box,
                                        maxiter=10**9, tol=0.0, jit=True)


def _to_box(z, lo, hi):
    return lo + (hi - lo) * 0.5 * (1.0 + jnp.sin(z))


def _from_box(x, lo, hi):
    x, lo, hi = (np.asarray(a, np.float64) for a in (x, lo, hi))
    width = hi - lo
    inner = np.clip(x, lo + 1e-3 * width, hi - 1e-3 * width)
    s = np.where(width > 0, 2.0 * (inner - lo) / np.where(width > 0, width, 1.0) - 1.0, 0.0)
    return jnp.asarray(np.arcsin(np.clip(s, -1.0, 1.0)))


@functools.lru_cache(maxsize=16)
def _optimistix_steps(optimiser: _AbstractOptimistixMapped, residuals, tolerance):
    """Compiled init/step/terminate/value of an optimistix solver on z (x = box(z)), kept
    between calls. ``args`` are ``(model args, lo, hi)``."""
    solver = optimiser.make(tolerance)

    def r_of_z(z, a):
        return residuals(_to_box(z, a[1], a[2]), a[0])

    value = _value(r_of_z)
    if optimiser.least_squares:
        def fn(z, a):
            return r_of_z(z, a), None
    else:
        def fn(z, a):
            return value(z, a), None

    tags: frozenset[object] = frozenset()

    @eqx.filter_jit
    def init(z, a):
        f_struct, aux_struct = jax.eval_shape(fn, z, a)
        return solver.init(fn, z, a, {}, f_struct, aux_struct, tags)

    @eqx.filter_jit
    def step(z, s, a):
        z, s, _ = solver.step(fn, z, a, {}, s, tags)
        done, _ = solver.terminate(fn, z, a, {}, s, tags)
        return z, s, done, value(z, a)

    return init, step, jax.jit(value)


class _AbstractOptimistixMapped(AbstractOptimiser):
    """An unbounded optimistix solver run on z with ``x = box(z)`` (the module docstring)."""

    #: True: the solver takes the residual vector (least squares); False: the scalar f.
    least_squares: eqx.AbstractClassVar[bool]

    @abc.abstractmethod
    def make(self, tolerance: float):
        """The optimistix solver at relative and absolute tolerance ``tolerance``."""

    def run(self, residuals, args, x0, lo, hi, max_steps, tolerance):
        init, step, value = _optimistix_steps(self, residuals, tolerance)
        a = (args, lo, hi)
        z = best = _from_box(x0, lo, hi)
        state = init(z, a)
        history = [float(value(z, a))]
        run = SolverRun(self.name, x0, history)
        for i in range(max_steps):
            z, state, done, fz = step(z, state, a)
            history.append(float(fz))
            if history[-1] < min(history[:-1]):
                best = z
            run.iterations = i + 1
            if bool(done) or _stalled(history, tolerance):
                run.converged = True
                break
        run.x = _to_box(best, lo, hi)
        return run


class LevenbergMarquardt(_AbstractOptimistixMapped):
    name: ClassVar[str] = "levenberg_marquardt"
    least_squares: ClassVar[bool] = True

    def make(self, tolerance):
        import optimistix as optx

        return optx.LevenbergMarquardt(rtol=tolerance, atol=tolerance)


class GaussNewton(_AbstractOptimistixMapped):
    name: ClassVar[str] = "gauss_newton"
    least_squares: ClassVar[bool] = True

    def make(self, tolerance):
        import optimistix as optx

        return optx.GaussNewton(rtol=tolerance, atol=tolerance)


class Dogleg(_AbstractOptimistixMapped):
    name: ClassVar[str] = "dogleg"
    least_squares: ClassVar[bool] = True

    def make(self, tolerance):
        import optimistix as optx

        return optx.Dogleg(rtol=tolerance, atol=tolerance)


class BFGS(_AbstractOptimistixMapped):
    name: ClassVar[str] = "bfgs"
    least_squares: ClassVar[bool] = False

    def make(self, tolerance):
        import optimistix as optx

        return optx.BFGS(rtol=tolerance, atol=tolerance)


#: The default of ``optimise.solver = "auto"``.
DEFAULT_OPTIMISER = "lbfgsb"
#: ``optimise.solver`` name -> optimiser class.
OPTIMISERS: Registry[type[AbstractOptimiser]] = Registry(
    "optimise.solver", OptimiserName,
    {cls.name: cls for cls in (ScipyLBFGSB, JaxoptLBFGSB, ProjectedGradient, LevenbergMarquardt,
                               GaussNewton, Dogleg, BFGS)},
    aliases={"auto": DEFAULT_OPTIMISER})
#: The optimisers' names, in registry order (no alias).
SOLVERS = tuple(OPTIMISERS)


def minimise(residuals: Residuals, args, x0, lo, hi, *,
             solver: str | AbstractOptimiser = DEFAULT_OPTIMISER, max_steps: int = 200,
             tolerance: float = 1e-8) -> SolverRun:
    """Minimise ``½‖residuals(x, args)‖²`` over ``lo ≤ x ≤ hi`` from ``x0``.

    ``residuals`` must be a pure JAX function; ``args`` a pytree (the light model and the
    objective), passed as an argument rather than closed over so that nothing large is baked
    into the compiled steps. ``solver``: an :class:`AbstractOptimiser` or its name in
    :data:`OPTIMISERS` (an unknown name is a ConfigError naming ``optimise.solver``).
    """
    optimiser = solver if isinstance(solver, AbstractOptimiser) else OPTIMISERS[solver]()
    t0 = time.perf_counter()
    x0, lo, hi = (jnp.asarray(a, jnp.result_type(float)) for a in (x0, lo, hi))
    x0 = jnp.clip(x0, lo, hi)
    if bool(jnp.all(lo == hi)):  # a box of one point: nothing to search (scipy has no status)
        run = SolverRun(optimiser.name, x0, [float(_value(residuals)(x0, args))], converged=True)
    else:
        run = optimiser.run(residuals, args, x0, lo, hi, max_steps, tolerance)
    run.x = np.clip(np.asarray(run.x, np.float64), np.asarray(lo), np.asarray(hi))
    run.seconds = time.perf_counter() - t0
    return run
