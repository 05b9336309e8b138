"""Test helpers shared across areas (importable as ``helpers``: tests/ is on pytest's path
through tests/conftest.py), and the runtime type checker of the test run.

A test writes its study with the builders below (``study_text(material(...), box(...),
lamp(...), plane_grid(...), table("solver", ...))``) rather than as TOML text: each builder
writes the lines a hand-written study would, so one study is a few lines and the studies of
different tests do not repeat one another."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterable

import jax.numpy as jnp
import numpy as np
from beartype import BeartypeConf, beartype

__all__ = ["area_lamp", "box", "box_room", "central_difference", "lamp", "material", "mesh",
           "network", "observer", "photometry", "pinhole_pixel", "plane_grid", "point_grid",
           "rectangle", "study_text", "table", "toml_value", "typechecker"]

#: The runtime checker pyproject's ``--jaxtyping-packages`` applies: beartype with PEP 484's
#: numeric tower (an int is accepted where a float is annotated, as mypy reads it).
typechecker = beartype(conf=BeartypeConf(is_pep484_tower=True))


def pinhole_pixel(cam, p, size: tuple[int, int]) -> tuple[int, int]:
    """(row, col) of world point ``p`` (m) in a ``size = (width, height)`` px image from camera
    ``cam`` (``position``, ``target``, ``up``, ``fov_deg``: the vertical field of view): an
    independent pinhole projection, so a picture test does not check the renderer against
    itself."""
    pos, tgt = np.array(cam.position), np.array(cam.target)
    f = (tgt - pos) / np.linalg.norm(tgt - pos)
    r = np.cross(f, cam.up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = np.asarray(p, float) - pos
    t = np.tan(np.radians(cam.fov_deg) / 2)
    x, y = (d @ r) / (d @ f) / t, (d @ u) / (d @ f) / t  # y in [-1, 1] over the height
    w, h = size
    return int(round(h / 2 - y * h / 2 - 0.5)), int(round(w / 2 + x * h / 2 - 0.5))


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


# Study text from parts. Each builder writes one TOML table, a key a line, in the order given,
# exactly the text a test would write out by hand: tests that edit the text (``str.replace``)
# or check an error's line number read the same lines. Values are Python values (numbers,
# strings, lists, numpy arrays, dicts as inline tables); a key given as None is left out.


def toml_value(v) -> str:
    """``v`` as a TOML value: numbers as Python writes them, lists as ``[a, b]``, dicts as
    inline tables ``{ k = v }``."""
    if isinstance(v, np.ndarray | np.generic):
        v = v.tolist()
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str | os.PathLike):
        return json.dumps(os.fspath(v))
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, list | tuple):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return repr(v)


def table(header: str, **keys) -> str:
    """``[header]`` (``[[header]]`` when written so) and its keys, one a line."""
    head = header if header.startswith("[") else f"[{header}]"
    return head + "\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in keys.items()
                                  if v is not None)


def study_text(*parts: str) -> str:
    """A study's text: its parts after one empty first line, as a triple-quoted study has."""
    return "\n" + "".join(parts)


def material(name: str, reflectance: float | None = None, **keys) -> str:
    return table(f"materials.{name}", reflectance=reflectance, **keys)


def photometry(name: str, kind: str | None = None, flux_lm: float | None = None, **keys) -> str:
    """A photometry: ``kind`` (isotropic, lambertian, …) of ``flux_lm`` lm, or ``file = …``."""
    return table(f"photometry.{name}", kind=kind, flux_lm=flux_lm, **keys)


def network(name: str, dimmer: float | None = None, **keys) -> str:
    return table(f"networks.{name}", dimmer=dimmer, **keys)


def box(lo, hi, material: str = "wall", normals: str | None = "inward", **keys) -> str:
    """A box geometry from corner ``lo`` to ``hi`` (m); ``keys`` follow ``material``."""
    return table("[[geometry]]", kind="box", min=lo, max=hi, normals=normals, material=material,
                 **keys)


def rectangle(origin, u, v, material: str = "wall", **keys) -> str:
    """A one-sided rectangle ``origin + s u + t v`` (m), facing ``u × v``."""
    return table("[[geometry]]", kind="rectangle", origin=origin, u=u, v=v, material=material,
                 **keys)


def mesh(file, material: str = "wall", **keys) -> str:
    """A mesh geometry read from ``file`` (any format trimesh reads)."""
    return table("[[geometry]]", kind="mesh", file=file, material=material, **keys)


def lamp(name: str, position, network: str = "n", photometry: str = "iso", **keys) -> str:
    """A photometric luminaire at ``position`` (m); ``keys`` (aim, spectrum, …) follow."""
    return table("[[luminaires]]", name=name, photometry=photometry, position=position,
                 network=network, **keys)


def area_lamp(name: str, origin, u, v, flux_lm: float, network: str = "n", **keys) -> str:
    """A Lambertian area luminaire ``origin + s u + t v`` (m) emitting ``flux_lm`` lm."""
    return table("[[luminaires]]", name=name, kind="area", origin=origin, u=u, v=v,
                 flux_lm=flux_lm, network=network, **keys)


def plane_grid(name: str, origin, u, v, nu: int | None = None, nv: int | None = None,
               **keys) -> str:
    """A plane grid ``origin + s u + t v`` (m) of ``nu × nv`` points."""
    return table("[[grids]]", name=name, kind="plane", origin=origin, u=u, v=v, nu=nu, nv=nv,
                 **keys)


def point_grid(name: str, pts, normals=None, **keys) -> str:
    """A grid of the listed points (m), facing ``normals`` (one, or one a point)."""
    return table("[[grids]]", name=name, kind="points", points=pts, normals=normals, **keys)


def observer(name: str, position, **keys) -> str:
    """A glare observer's eye at ``position`` (m); ``keys`` (direction, look_at, fan, …)."""
    return table("[[observers]]", name=name, position=position, **keys)


def run_in_new_process_without_jax(study, out, *args: str,
                                   without: tuple[str, ...] = ("jax",)) -> dict:
    """``lumijax run STUDY --out OUT *args`` in a new interpreter, as a user runs it, checked
    to exit 0 without ever importing JAX (or any module of ``without``); its results.json."""
    import subprocess
    import sys

    code = ("import sys; from lumijax.cli import main; "
            f"rc = main(['run', {str(study)!r}, '--out', {str(out)!r}, *{list(args)!r}]); "
            f"print('IMPORTED', [m for m in {list(without)!r} if m in sys.modules]); "
            "sys.exit(rc)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, env=dict(os.environ, JAX_PLATFORMS="cpu"))
    assert proc.returncode == 0, proc.stderr
    assert "IMPORTED []" in proc.stdout, proc.stdout
    with open(os.path.join(out, "results.json"), encoding="utf-8") as f:
        return json.load(f)
