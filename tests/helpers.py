"""Test helpers shared across areas (importable as ``helpers``: tests/ is on pytest's path
through tests/conftest.py), and the runtime type checker of the test run."""

from __future__ import annotations

from collections.abc import Callable, Iterable

import jax.numpy as jnp
import numpy as np
from beartype import BeartypeConf, beartype

__all__ = ["box_room", "central_difference", "typechecker"]

#: The runtime checker pyproject's ``--jaxtyping-packages`` applies: beartype with PEP 484's
#: numeric tower (an int is accepted where a float is annotated, as mypy reads it).
typechecker = beartype(conf=BeartypeConf(is_pep484_tower=True))


def central_difference(f: Callable, x, h: float = 1e-6,
                       indices: Iterable[int] | None = None) -> np.ndarray:
    """Central finite differences ``(f(x + h eₖ) − f(x − h eₖ)) / 2h`` of ``f`` at ``x``.

    An independent check of automatic derivatives: it calls ``f`` only, never its gradient, so
    it cannot share a bug with ``jax.grad``. ``x`` is perturbed along the flat indices
    ``indices`` (all of them by default) and handed to ``f`` as the kind of array it came as
    (a JAX array stays one). Returns float64 of shape ``(len(indices),) + shape of f(x)``, row
    ``k`` the derivative along ``indices[k]``; truncation error O(h²·f'''), rounding error
    O(ε·|f|/h).
    """
    as_jax = not isinstance(x, np.ndarray)
    x = np.asarray(x, np.float64)
    flat = range(x.size) if indices is None else list(indices)
    rows = []
    for k in flat:
        e = np.zeros(x.size)
        e[k] = h
        e = e.reshape(x.shape)
        hi, lo = (jnp.asarray(x + e) if as_jax else x + e), (jnp.asarray(x - e) if as_jax else x - e)
        rows.append((np.asarray(f(hi), np.float64) - np.asarray(f(lo), np.float64)) / (2 * h))
    return np.stack(rows)


def box_room(solver: str, *, name: str | None = None, networks: tuple[str, ...] = ("a", "b"),
             dimmer_a: float | None = 0.5, grid: str = "nu = 8\nnv = 6", extra: str = "") -> str:
    """The tests' one small study: a closed 4 × 3 × 3 m grey room (ρ 0.5), an isotropic
    2000 lm lamp per network at 2.5 m (A1 at x = 1 m on ``a``, B1 at x = 3 m on ``b``) and a
    floor grid 1 cm up. ``solver`` is the body of ``[solver]``; ``grid`` ends the floor grid."""
    study = "" if name is None else f'[study]\nname = "{name}"\n'
    nets = "".join(f"[networks.{n}]\n" + (f"dimmer = {dimmer_a}\n" if n == "a" and dimmer_a
                                           is not None else "") for n in networks)
    lums = "".join(f'[[luminaires]]\nname = "{n.upper()}1"\nphotometry = "iso"\n'
                   f"position = [{1 + 2 * i}, 1.5, 2.5]\nnetwork = \"{n}\"\n"
                   for i, n in enumerate(networks))
    return (f"\n{study}[solver]\n{solver.strip()}\n[materials.wall]\nreflectance = 0.5\n"
            '[photometry.iso]\nkind = "isotropic"\nflux_lm = 2000\n'
            f'{nets}[[geometry]]\nkind = "box"\nmin = [0, 0, 0]\nmax = [4, 3, 3]\n'
            f'normals = "inward"\nmaterial = "wall"\n{lums}'
            '[[grids]]\nname = "floor"\nkind = "plane"\norigin = [0, 0, 0.01]\n'
            f"u = [4, 0, 0]\nv = [0, 3, 0]\n{grid.strip()}\n{extra}")
