"""The gather in closed form: a small grid's point-to-patch factors, without rays.

A calculation point's inter-reflected illuminance is ``E(x) = Σ_j ∫_j B(y) k(x, y) dy`` with
the point-to-area kernel ``k = cos θ_x cos θ_y / (π r²)`` times the view between. The ray
gather (``_gather.py``) estimates it with cosine-weighted rays, whose noise falls like 1/rays.
For a grid of few points in a study of few patches (points × patches ≤
:data:`EXACT_GATHER_PAIRS`) the sum is taken patch by patch:

* a patch nearer than :data:`NEAR_RATIO` of its longest edge by the contour integral in closed
  form (Lambert; the kernels of ``_build.py``, clipped to the point's front where its plane
  cuts them) over :data:`NEAR_CUTS`² sub-triangles;
* every other patch by the 7-point degree-5 rule for triangles (Strang & Fix 1973; Dunavant
  1985) on the kernel, its cosines clipped at 0 (a far patch cut by the point's plane is seen
  at grazing angles).

Each part's first moment ``∫ (y − c_j) k dy`` comes with it, so every patch is read linearly
across it through its slope (``_slopes.py``; the ray gather reads only the near ones), and
the links are the same kind of fixed sparse map ``E = G B``. The view: none to test where
the scene sees everything from the points (``RayCaster.sees_everything_from``: a convex
room, every point inside); else one ray from the point to each quadrature point or
sub-triangle centroid, carrying what a clear pane passes (``pair_transmission``, which also
weighs a pane's own patch by the light it does not pass, as the operator does).

Measured on the 4 m cube of ``benchmarks/small.py`` (1,728 patches, 100 points; against its
0.05 m numpy reference): RMS 0.0079 / 0.0155 % at ρ 0.2 / 0.5 with 4,096 rays, 0.0054 /
0.0123 % with 65,536, 0.0035 / 0.0111 % here (docs/radiosity.md, "The gather in closed form").
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float

from ..kernels._tolerances import rounding_length
from ._build import _CONTOUR_QUICK, _WHOLE, _contour_mean, _contour_start
from ._gather import GatherOperator, _with_slopes
from ._patches import Patches, subdivide_triangles
from ._slopes import PatchSlopes

__all__ = ["EXACT_GATHER_PAIRS", "build_exact_gather"]

#: Points × patches up to which a grid is gathered in closed form when ``[solver]
#: gather_rays`` is not set: small.py's office (100 points, 4,960 patches) within it.
EXACT_GATHER_PAIRS = 1 << 20

#: A patch nearer than this many of its longest edges (centroid to point) is integrated in
#: closed form over sub-triangles; the cube ρ 0.2 read 0.0040 / 0.0034 / 0.0031 % RMS at
#: 1 / 1.5 / 3 (gathers of 0.32 / 0.40 / 0.50 s, contended; docs/radiosity.md, "The gather
#: in closed form").
NEAR_RATIO = 1.5

#: Sub-triangles a side of a near patch is cut into (the moment converges like the pieces'
#: size squared: every patch of the cube by the contour over 2 × 2 read it 0.0055 %, over
#: 4 × 4 0.0029 %).
NEAR_CUTS = 4

#: Far pairs per numpy pass (bounds the (pairs, 7, 3) quadrature arrays to ≈ 25 MB).
_FAR_CHUNK = 1 << 17

# the symmetric 7-point degree-5 rule on the triangle: barycentric points and weights (sum 1)
_A1, _B1 = 0.059715871789770, 0.470142064105115
_A2, _B2 = 0.797426985353087, 0.101286507323456
_RULE = np.array([[1 / 3, 1 / 3, 1 / 3],
                  [_A1, _B1, _B1], [_B1, _A1, _B1], [_B1, _B1, _A1],
                  [_A2, _B2, _B2], [_B2, _A2, _B2], [_B2, _B2, _A2]])
_WEIGHT = np.array([0.225] + [0.132394152788506] * 3 + [0.125939180544827] * 3)


def build_exact_gather(
    points: Float[np.ndarray, "points 3"],
    normals: Float[np.ndarray, "points 3"],
    patches: Patches,
    caster,
    *,
    slopes: PatchSlopes | None = None,
) -> GatherOperator:
    """The gather of ``patches``' radiosity onto the points (m) with measuring-plane
    ``normals``, its factors integrated patch by patch (module docstring); the same
    :class:`GatherOperator` as :func:`~lumijax.radiosity.build_gather`, without its ray noise.

    ``caster``: the scene's :class:`lumijax.scene.RayCaster` (for the view between a point
    and a patch); ``slopes``: :func:`~lumijax.radiosity.patch_slopes` of ``patches`` (each
    patch read linearly across it), or None (constant)."""
    x = np.asarray(points, np.float64)
    nx = np.asarray(normals, np.float64)
    nx = nx / np.linalg.norm(nx, axis=1, keepdims=True)
    c, n, v = patches.centroid, patches.normal, patches.vertices
    tol = max(rounding_length(x), rounding_length(v)) if len(x) and patches.n else 0.0
    pi, pj = _facing(x, nx, patches, tol)
    view = None if caster is None or caster.sees_everything_from(x) else caster
    # a patch cut by the point's plane far away is seen at grazing angles, where the rule's
    # clipped cosine is as good as the contour's clipping; near, the contour clips exactly
    near = np.linalg.norm(c[pj] - x[pi], axis=1) < NEAR_RATIO * patches.diameter[pj]
    weight, moment = np.zeros(len(pi)), np.zeros((len(pi), 3))
    rows = np.flatnonzero(near)
    if len(rows):
        weight[rows], moment[rows] = _near(x[pi[rows]], nx[pi[rows]], v[pj[rows]], c[pj[rows]],
                                           tol, view)
    far = np.flatnonzero(~near)
    for s in range(0, len(far), _FAR_CHUNK):
        rows = far[s : s + _FAR_CHUNK]
        i, j = pi[rows], pj[rows]
        weight[rows], moment[rows] = _far(x[i], nx[i], v[j], c[j], n[j], patches.area[j], view)
    seen = weight > 0  # a patch wholly hidden (or seen edge-on) adds no link
    key = pi[seen].astype(np.int64) * patches.n + pj[seen]
    weight, moment = weight[seen], moment[seen]
    if slopes is not None:
        key, weight = _with_slopes(key, weight, moment, slopes, len(x) * patches.n)
    return GatherOperator(n_points=len(x), n_patches=patches.n,
                          point=(key // max(patches.n, 1)).astype(np.int32),
                          patch=(key % max(patches.n, 1)).astype(np.int32), weight=weight)


#: Points × patches per pass of the facing test (its (points, patches) arrays ≈ 40 MB).
_FACING_CHUNK = 1 << 20


def _facing(x, nx, patches: Patches, tol: float):
    """``(point, patch)`` pairs where the point lies in front of the patch (surfaces are
    one-sided) and some corner of the patch in front of the point's plane, by passes of
    :data:`_FACING_CHUNK` pairs."""
    c, n, v = patches.centroid, patches.normal, patches.vertices
    offset = np.einsum("pc,pc->p", c, n)[None]
    step = max(1, _FACING_CHUNK // max(patches.n, 1))
    found = []
    for s in range(0, len(x), step):
        xs, ns = x[s : s + step], nx[s : s + step]
        ahead = xs @ n.T - offset  # (S, P), m
        level = np.einsum("sc,sc->s", xs, ns)[:, None]
        corner = [ns @ v[:, k].T - level for k in range(3)]  # each corner's height, m
        i, j = np.nonzero((ahead > tol) & (np.maximum(np.maximum(*corner[:2]), corner[2]) > tol))
        found.append((i + s, j))
    if not found:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate([f[0] for f in found]), np.concatenate([f[1] for f in found])


def _near(x, nx, tri, centre, tol, view):
    """Factors and first moments (K,), (K, 3) of near pairs: the contour integral over
    :data:`NEAR_CUTS`² sub-triangles, each clipped to the point's front where it crosses the
    point's plane."""
    sub = subdivide_triangles(tri, NEAR_CUTS)  # (K, S, 3, 3)
    k, s = sub.shape[:2]
    sub = sub.reshape(-1, 3, 3)
    q = np.repeat(x, s, axis=0)
    nq = np.repeat(nx, s, axis=0)
    ahead = np.einsum("kvc,kc->kv", sub - q[:, None], nq)
    size = np.linalg.norm(sub[:, 0] - q, axis=1)
    whole = (ahead > np.maximum(tol, _WHOLE * size)[:, None]).all(axis=1)
    f = _contour_mean(_contour_start(q[:, None], nq, sub, _CONTOUR_QUICK, whole))
    mid = sub.mean(axis=1)
    if view is not None:
        f = f * view.pair_transmission(q, mid)
    f = f.reshape(k, s)
    return f.sum(axis=1), np.einsum("ks,ksc->kc", f, mid.reshape(k, s, 3) - centre[:, None])


def _far(x, nx, tri, centre, normal, area, view):
    """Factors and first moments (K,), (K, 3) of far pairs by the 7-point rule on the
    point-to-area kernel (per coordinate, (K, 7) arrays: no reductions over an axis of 3)."""
    y = [tri[:, :, k] @ _RULE.T for k in range(3)]  # the rule's points, (K, 7) each
    r = [y[k] - x[:, k, None] for k in range(3)]
    r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    cos_x = sum(r[k] * nx[:, k, None] for k in range(3))
    cos_y = -sum(r[k] * normal[:, k, None] for k in range(3))
    f = (np.clip(cos_x, 0.0, None) * np.clip(cos_y, 0.0, None) / (np.pi * r2 * r2)
         * (_WEIGHT * area[:, None]))
    if view is not None:
        f = f * view.pair_transmission(np.repeat(x, len(_WEIGHT), axis=0),
                                       np.stack(y, axis=2).reshape(-1, 3)).reshape(f.shape)
    moment = np.stack([np.einsum("kq,kq->k", f, y[k] - centre[:, k, None]) for k in range(3)],
                      axis=1)
    return f.sum(axis=1), moment
