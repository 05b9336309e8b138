"""Every radiosity solver on a regression set of rooms, judged by an independent float64 solve.

The rooms are the ones the issue reported (a 6 × 5 × 3 m furnished room, a room with thin
finishes 1 mm proud of its walls, several networks, ρ up to 0.95); all three stand in one scene,
far apart and closed, so one operator and one compilation per method serve them all. The
reference is ``numpy.linalg.solve`` on the dense float64 matrix of the same form factors with
the row correction written out here (docs/radiosity.md, "Row sums"), and every residual is
recomputed in float64 by numpy: nothing the solvers report is trusted.
"""

from __future__ import annotations

import jax.numpy as jnp
import lineax as lx
import numpy as np
import pytest
import trimesh

from lumijax.radiosity import (
    GMRES,
    RADIOSITY_SOLVERS,
    BiCGStab,
    Refined,
    build_operator,
    mesh_patches,
    partition,
    solve_radiosity,
)

from .conftest import quad

RTOL = 1e-4


def _box(lo, hi, inward):
    m = trimesh.creation.box(bounds=np.array([lo, hi], float))
    if inward:
        m.invert()
    return m.triangles


def _rooms():
    """Triangles, group per triangle, ρ per triangle for two 'wavelengths', and point sources."""
    parts, rho = [], []

    def add(tri, r1, r2):
        parts.append(tri)
        rho.append(np.tile([r1, r2], (len(tri), 1)))

    # 1. furnished 6 × 5 × 3 m room: a table on the floor, a cabinet against a wall
    add(_box([0, 0, 0], [6, 5, 3], True), 0.8, 0.6)
    add(_box([2, 1.5, 0], [4, 2.5, 0.75], False), 0.5, 0.3)
    add(_box([0, 4.4, 0], [2, 5, 2], False), 0.6, 0.4)
    # 2. thin finishes 1 mm proud of the walls and floor, ρ 0.95
    x0 = 20.0
    add(_box([x0, 0, 0], [x0 + 4, 3, 2.5], True), 0.7, 0.5)
    add(quad([x0 + 0.001, 0.5, 0.5], [0, 0, 1.5], [0, 2, 0]), 0.95, 0.9)
    add(quad([x0 + 1, 0.001, 0.3], [2, 0, 0], [0, 0, 2]), 0.95, 0.9)
    add(quad([x0 + 1, 1, 0.001], [1.5, 0, 0], [0, 1.5, 0]), 0.95, 0.9)
    # 3. a bright room (ρ 0.95 walls) lit by two networks
    x1 = 40.0
    add(_box([x1, 0, 0], [x1 + 3, 3, 2.5], True), 0.95, 0.9)
    tri = np.concatenate(parts)
    rho = np.concatenate(rho)
    sources = [[1.5, 1.5, 2.5], [4.5, 3.0, 2.8], [x0 + 2, 1.5, 2.0], [x1 + 1, 1, 2],
               [x1 + 2, 2, 1]]
    return tri, rho, np.array(sources)


@pytest.fixture(scope="module")
def regression_rooms():
    tri, rho_tri, sources = _rooms()
    p = mesh_patches(tri, group=np.arange(len(tri)) // 12, patch_size=1.5)
    op = build_operator(p, partition(p, 512, occluders=tri), tri)
    rho = rho_tri[p.source_triangle]
    # unshadowed point-source irradiance (lx, 1000 lm each), one network per source
    d = sources[None] - p.centroid[:, None]
    r2 = np.sum(d * d, axis=-1)
    cos = np.clip(np.sum(d * p.normal[:, None], axis=-1) / np.sqrt(r2), 0, None)
    e = 1000.0 / (4 * np.pi) * cos / r2  # (P, networks)
    b0 = rho[:, None, :] * e[:, :, None]  # (P, networks, 2)
    fc, ref = _reference(op, rho, b0)
    return p, op, rho, b0, fc, ref


def _reference(op, rho, b0):
    """Dense float64: the row-corrected F (rows above 1 scaled to 1; these rooms are not all
    closed, so nothing else changes), solved by LAPACK."""
    f = op.todense()
    rows = f.sum(axis=1)
    c = np.where(rows > 0.01, np.minimum(rows, 1.0) / np.where(rows > 0.01, rows, 1.0), 1.0)
    fc = f * c[None, :]
    p, n, w = b0.shape
    ref = np.empty_like(b0)
    for k in range(w):
        a = np.eye(p) - rho[:, k, None] * fc
        ref[:, :, k] = np.linalg.solve(a, b0[:, :, k])
    return fc, ref


def _true_residual(fc, rho, b0, b):
    r = b0 - (b - rho[:, None, :] * np.einsum("ij,jnw->inw", fc, b))
    return float(np.max(np.abs(r).max(axis=0) / np.abs(b0).max(axis=0)))


@pytest.mark.parametrize("method", list(RADIOSITY_SOLVERS))
def test_every_method_solves_the_regression_rooms(regression_rooms, method):
    p, op, rho, b0, fc, ref = regression_rooms
    # by reciprocity, patch j now sends out Σ_i A_i F'_ij = A_j min(s_j, 1): never more
    sent = (p.area[:, None] * fc).sum(axis=0) / p.area
    assert sent.max() <= 1 + 1e-5
    sol = solve_radiosity(op, jnp.asarray(rho[:, None, :], jnp.float32),
                          jnp.asarray(b0, jnp.float32), solver=method, rtol=RTOL)
    b = np.asarray(sol.value, np.float64)
    assert sol.result == lx.RESULTS.successful
    res = _true_residual(fc, rho, b0, b)
    # Jacobi and Southwell stop on their update size, not a residual: 1/(1 − ρ) looser
    bound = RTOL * (2 if method in ("refined", "bicgstab", "gmres") else 40)
    assert res <= bound, (method, res)
    flux = np.abs(b - ref) * p.area[:, None, None]
    assert flux.sum() / (ref * p.area[:, None, None]).sum() < 2e-3, method
    assert np.all(np.asarray(sol.escaped) >= 0)


def test_thin_finishes_would_create_light_and_are_corrected(regression_rooms):
    # Rows above 1 exist in these rooms (the proud finishes): the solve reports how much light
    # they would have created, and the escaped fraction stays ≥ 0 (it was −0.15 … −0.29).
    p, op, rho, b0, fc, ref = regression_rooms
    rows = op.todense().sum(axis=1)
    assert rows.max() > 1.05
    sol = solve_radiosity(op, jnp.asarray(rho[:, None, :], jnp.float32),
                          jnp.asarray(b0, jnp.float32), rtol=RTOL)  # compiled above
    flux = p.area[:, None, None] * ref
    created = (flux * np.clip(rows - 1, 0, None)[:, None, None]).sum(0) / flux.sum(0)
    assert np.asarray(sol.stats["created"]) == pytest.approx(created, rel=2e-3)
    assert created.max() > 1e-3
    assert float(sol.stats["row_max"]) == pytest.approx(rows.max(), rel=1e-5)
    assert np.all(np.asarray(sol.escaped) >= 0)


def test_refined_recovers_when_its_inner_solver_breaks_down(regression_rooms):
    # An inner BiCGStab that gives up at once (stall = 0) fails every inner solve: after
    # `restarts` failures the GMRES fallback must finish the job, judged by numpy's residual.
    p, op, rho, b0, fc, _ = regression_rooms
    solver = Refined(inner=BiCGStab(stall=0), fallback=GMRES(), restarts=2, direct=False)
    sol = solve_radiosity(op, jnp.asarray(rho[:, None, :], jnp.float32),
                          jnp.asarray(b0, jnp.float32), solver=solver, rtol=RTOL)
    assert bool(sol.stats["fallback"])
    assert int(sol.stats["failures"]) >= 2
    assert _true_residual(fc, rho, b0, np.asarray(sol.value, np.float64)) <= 2 * RTOL


_NO_X64 = r'''
import json, sys
import numpy as np, jax, jax.numpy as jnp, lineax as lx, equinox as eqx
from lumijax.radiosity._krylov import ColumnBiCGStab, Refinement

rng = np.random.default_rng(58)  # a draw on which lineax.BiCGStab stops without x64
n = 60
a = rng.lognormal(0, 1.5, n)  # patch areas over three decades
g = rng.random((n, n)) * (rng.random((n, n)) < 0.3)
g = g + g.T
np.fill_diagonal(g, 0)
g *= a[:, None] * a[None]  # G = A F, symmetric (reciprocity)
f = g / a[:, None]
f /= f.sum(1, keepdims=True).max()  # rows ≤ 1
rho = rng.uniform(0.3, 0.95, n)
A = np.eye(n) - rho[:, None] * f
b = rng.random((n, 3)) * (rng.random((n, 3)) < 0.5)
b /= np.abs(b).max(0)
A32, b32 = jnp.asarray(A, jnp.float32), jnp.asarray(b, jnp.float32)
op = lx.FunctionLinearOperator(lambda x: A32 @ x, jax.ShapeDtypeStruct(b32.shape, jnp.float32))
out = {"x64": bool(jax.config.read("jax_enable_x64"))}
solvers = {
    "lineax": lx.BiCGStab(rtol=0.0, atol=1e-4, max_steps=500),
    "column": ColumnBiCGStab(atol=1e-4, max_steps=500),
    "refined": Refinement(inner=ColumnBiCGStab(atol=5e-5, max_steps=500),
                          fallback=lx.GMRES(rtol=0.0, atol=5e-5, max_steps=50, restart=10),
                          atol=1e-4, max_products=1000),
}
for name, solver in solvers.items():
    x = np.asarray(lx.linear_solve(op, b32, solver, throw=False).value, np.float64)
    out[name] = float(np.max(np.abs(b - A @ x)))  # true residual, float64, numpy
print(json.dumps(out))
'''


def test_float32_without_x64_converges_where_lineax_bicgstab_breaks_down():
    # The CLI's float32 studies run JAX without 64-bit, where lineax.BiCGStab calls any
    # negative ρ, α or ω a breakdown (the "breakdown after 4 operator products"). This
    # needs its own process: the suite runs with x64 on.
    import json
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    run = subprocess.run([sys.executable, "-c", _NO_X64], capture_output=True, text=True,
                         env=env, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out["x64"] is False
    assert out["lineax"] > 1e-4  # the failure the per-column BiCGStab was written for
    assert out["column"] <= 1e-4
    assert out["refined"] <= 1e-4
