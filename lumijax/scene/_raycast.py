"""Occlusion and first-hit queries on the scene's triangles, through Embree (embreex).

Embree is the fastest CPU ray engine there is, and trimesh already depends on it; we call its
scene directly because trimesh's wrapper has no per-ray ``tfar`` (the segment length), which a
shadow ray needs. Queries are chunked so that memory stays flat whatever the ray count.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Bool, Float, Int

from ..errors import GeometryError

_CHUNK = 1 << 20  # rays per Embree call: large enough to amortise, small enough for memory


class RayCaster:
    """Shadow and first-hit rays against a fixed triangle soup.

    Parameters
    ----------
    triangles
        ``(T, 3, 3)`` vertex positions in metres.

    Notes
    -----
    Embree works in float32, whose spacing at 5·10⁶ m is 0.5 m. Triangles and ray origins are
    therefore re-centred on the centre of the scene's bounding box (``origin``) in float64
    first, then converted: every ray user (shadows, form factors, gathers, the aim model) gets
    the precision of a model at the origin wherever it sits. Each ray's origin is nudged along
    its direction by ``epsilon`` = ``EPSILON`` × the scene's extent, so that it does not hit the
    surface it starts on, in any unit: 40 µm in a 4 m room, 40 nm in a 4 mm model
    (docs/conventions.md, "Tolerances").
    """

    EPSILON = 1e-5
    """Ray offsets as a fraction of the scene's largest bounding-box side."""

    def __init__(self, triangles: Float[np.ndarray, "tri 3 3"]) -> None:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        tri = np.asarray(triangles, dtype=np.float64)
        if tri.ndim != 3 or tri.shape[1:] != (3, 3):
            raise GeometryError(f"triangles must have shape (T, 3, 3), got {tri.shape}")
        if not np.all(np.isfinite(tri)):
            raise GeometryError("triangles contain NaN or infinite coordinates")
        self.n_triangles = len(tri)
        if self.n_triangles:
            lo, hi = tri.reshape(-1, 3).min(0), tri.reshape(-1, 3).max(0)
        else:
            lo = hi = np.zeros(3)
        self._triangles = tri  # no copy for float64 input; what a pickle sends (__reduce__)
        self._digest: str | None = None
        self.origin = 0.5 * (lo + hi)
        self.extent = float(np.max(hi - lo)) if self.n_triangles else 1.0
        self.epsilon = max(self.EPSILON * self.extent, float(np.finfo(np.float64).tiny))
        self._scene = None
        if self.n_triangles:
            verts = (tri.reshape(-1, 3) - self.origin).astype(np.float32)
            faces = np.arange(len(verts), dtype=np.int32).reshape(-1, 3)
            self._scene = rtcore_scene.EmbreeScene()
            TriangleMesh(scene=self._scene, vertices=verts, indices=faces)

    @property
    def triangles(self) -> Float[np.ndarray, "tri 3 3"]:
        """The triangles it was built from (m, float64; not a copy: do not write to it)."""
        return self._triangles

    def __reduce__(self):
        # pickled as its triangles, so a Dask worker can hold one (docs/parallel.md); it
        # rebuilds the Embree scene once per process and content, not once per task
        from ..parallel import digest

        if self._digest is None:
            self._digest = digest(self._triangles)
        return (_unpickled_caster, (self._digest, self._triangles))

    def occluded(
        self,
        origins: Float[np.ndarray, "rays 3"],
        targets: Float[np.ndarray, "rays 3"],
    ) -> Bool[np.ndarray, " rays"]:
        """Whether the open segment from each origin to its target is blocked by a triangle.

        Both ends are pulled in by ``epsilon`` so that the surfaces a segment starts and ends on
        do not count as blockers.
        """
        origins = np.broadcast_to(np.asarray(origins, np.float64), np.shape(targets))
        targets = np.asarray(targets, np.float64)
        n = len(targets)
        out = np.zeros(n, dtype=bool)
        if self._scene is None or n == 0:
            return out
        for s in range(0, n, _CHUNK):
            o = origins[s : s + _CHUNK]
            d = targets[s : s + _CHUNK] - o
            length = np.linalg.norm(d, axis=1)
            d = d / np.where(length > 2 * self.epsilon, length, 1.0)[:, None]
            out[s : s + _CHUNK] = self._occluded_along(o, d, length)
        return out

    def occluded_along(
        self,
        origins: Float[np.ndarray, "rays 3"],
        directions: Float[np.ndarray, "rays 3"],
        lengths: Float[np.ndarray, " rays"],
    ) -> Bool[np.ndarray, " rays"]:
        """:meth:`occluded` of the segments from ``origins`` along unit ``directions`` for
        ``lengths`` (m): for a caller that has them already (the direct light's pairs), which
        :meth:`occluded` would compute again from the two ends."""
        n = len(lengths)
        out = np.zeros(n, dtype=bool)
        if self._scene is None or n == 0:
            return out
        for s in range(0, n, _CHUNK):
            out[s : s + _CHUNK] = self._occluded_along(
                origins[s : s + _CHUNK], directions[s : s + _CHUNK], lengths[s : s + _CHUNK])
        return out

    def _occluded_along(self, o, d, length) -> Bool[np.ndarray, " rays"]:
        ok = length > 2 * self.epsilon
        start = (o - self.origin) + self.epsilon * d
        tfar = np.where(ok, length - 2 * self.epsilon, 0.0)
        hit = self._scene.run(
            start.astype(np.float32),
            d.astype(np.float32),
            dists=tfar.astype(np.float32),
            query="OCCLUDED",
        )
        return (np.asarray(hit) >= 0) & ok

    #: Largest triangles × vertices the convexity test of :attr:`sees_everything` runs on
    #: (about a second of numpy at worst); beyond it the scene is treated as possibly occluding.
    CONVEX_TEST_LIMIT = 200_000_000

    @property
    def sees_everything(self) -> bool:
        """True when no triangle can block or dim a segment between two points of the scene's
        triangles: the scene is convex as seen from inside (every triangle's plane has every
        vertex on its non-negative side, along its normal: a plain box room with inward
        normals) and every triangle is opaque (no glazing). Then a segment between points of
        two triangles lies in every triangle's closed half-space, so it meets a triangle's
        plane only at an end (which rays ignore) or lies in that plane (where it faces
        nothing). Exact up to 10⁻⁹ of the scene's extent (``length_tolerance``); degenerate
        triangles have no plane and are skipped. Computed once per caster."""
        known = getattr(self, "_sees_everything", None)
        if known is None:
            known = self._sees_everything = self._convex_inside()
        return known

    def sees_everything_from(self, points: Float[np.ndarray, "points 3"]) -> bool:
        """:attr:`sees_everything`, and every one of ``points`` (m) lies in every triangle's
        closed half-space as well (inside the convex room): then no segment from a point to
        a point of a triangle is blocked either."""
        if not self.sees_everything:
            return False
        if self.n_triangles == 0:
            return True
        n, off, tol = self._planes()
        p = np.asarray(points, np.float64).reshape(-1, 3) - self.origin
        return not any(np.any(p[s:s + 256] @ n.T - off < -tol) for s in range(0, len(p), 256))

    def _planes(self):
        """Every non-degenerate triangle's unit normal and offset about :attr:`origin`, and the
        scene's length tolerance."""
        from ..kernels import length_tolerance

        tri = self._triangles - self.origin  # re-centred: site coordinates keep their digits
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(n, axis=1)
        planar = length > 0
        n = n[planar] / length[planar, None]
        return n, np.einsum("tc,tc->t", n, tri[planar, 0]), length_tolerance(self._triangles)

    def _convex_inside(self) -> bool:
        if self.glazing_key is not None or self.n_triangles == 0:
            return self.n_triangles == 0
        verts = np.unique((self._triangles - self.origin).reshape(-1, 3), axis=0)
        if self.n_triangles * len(verts) > self.CONVEX_TEST_LIMIT:
            return False
        n, off, tol = self._planes()
        for s in range(0, len(n), 256):  # a non-convex scene fails in its first chunks
            if np.any(verts @ n[s:s + 256].T - off[s:s + 256] < -tol):
                return False
        return True

    #: What, besides the triangles, changes what a ray carries (None: every triangle is opaque;
    #: a glazed caster's digest of its panes' transmittances). Part of an operator's cache key.
    glazing_key: str | None = None

    def transmission(
        self,
        origins: Float[np.ndarray, "rays 3"],
        targets: Float[np.ndarray, "rays 3"],
    ) -> Float[np.ndarray, " rays"]:
        """Fraction of light carried along each open segment: 0 blocked, 1 clear (every triangle
        is opaque here; ``lumijax.scene.GlazedCaster`` lets clear glass through)."""
        return np.where(self.occluded(origins, targets), 0.0, 1.0)

    def transmission_along(
        self,
        origins: Float[np.ndarray, "rays 3"],
        directions: Float[np.ndarray, "rays 3"],
        lengths: Float[np.ndarray, " rays"],
    ) -> Float[np.ndarray, " rays"]:
        """:meth:`transmission` of the segments from ``origins`` along unit ``directions``
        for ``lengths`` (m) (:meth:`occluded_along`)."""
        return np.where(self.occluded_along(origins, directions, lengths), 0.0, 1.0)

    def pair_transmission(
        self,
        origins: Float[np.ndarray, "rays 3"],
        targets: Float[np.ndarray, "rays 3"],
    ) -> Float[np.ndarray, " rays"]:
        """:meth:`transmission` of a form factor's visibility ray between two patches (the
        same here; a glazed caster also weighs an end that lies on a pane by the light the pane
        does not pass)."""
        return self.transmission(origins, targets)

    def first_hit_through(
        self,
        origins: Float[np.ndarray, "rays 3"],
        directions: Float[np.ndarray, "rays 3"],
    ) -> tuple[Int[np.ndarray, " rays"], Float[np.ndarray, " rays"], Float[np.ndarray, " rays"]]:
        """:meth:`first_hit` and the fraction of light carried to it (1 here; a glazed caster
        passes clear panes, multiplying τ(θ))."""
        tri, dist = self.first_hit(origins, directions)
        return tri, dist, np.ones(len(tri))

    def first_hit(
        self,
        origins: Float[np.ndarray, "rays 3"],
        directions: Float[np.ndarray, "rays 3"],
    ) -> tuple[Int[np.ndarray, " rays"], Float[np.ndarray, " rays"]]:
        """The first triangle hit along each ray (−1 for none) and its distance (inf for none)."""
        tri, dist, _ = self.first_hit_uv(origins, directions)
        return tri, dist

    def first_hit_uv(
        self,
        origins: Float[np.ndarray, "rays 3"],
        directions: Float[np.ndarray, "rays 3"],
    ) -> tuple[Int[np.ndarray, " rays"], Float[np.ndarray, " rays"], Float[np.ndarray, "rays 2"]]:
        """:meth:`first_hit` and the hit's barycentric ``(u, v)`` in its triangle (float32, as
        Embree computes them: the point is ``v0 + u (v1 − v0) + v (v2 − v0)``; 0 for none), so
        a caller mapping hits to sub-triangles needs no hit point."""
        origins = np.broadcast_to(np.asarray(origins, np.float64), np.shape(directions))
        directions = np.asarray(directions, np.float64)
        n = len(directions)
        tri = np.full(n, -1, dtype=np.int64)
        dist = np.full(n, np.inf)
        uv = np.zeros((n, 2), np.float32)
        if self._scene is None or n == 0:
            return tri, dist, uv
        for s in range(0, n, _CHUNK):
            d = directions[s : s + _CHUNK]
            d = d / np.linalg.norm(d, axis=1, keepdims=True)
            start = (origins[s : s + _CHUNK] - self.origin) + self.epsilon * d
            res = self._scene.run(
                start.astype(np.float32), d.astype(np.float32), output=1
            )
            prim = np.asarray(res["primID"], dtype=np.int64)
            t = np.asarray(res["tfar"], dtype=np.float64)
            hit = prim >= 0
            tri[s : s + _CHUNK] = np.where(hit, prim, -1)
            dist[s : s + _CHUNK] = np.where(hit, t + self.epsilon, np.inf)
            uv[s : s + _CHUNK, 0] = np.where(hit, res["u"], 0)
            uv[s : s + _CHUNK, 1] = np.where(hit, res["v"], 0)
        return tri, dist, uv

    def first_hit_local(
        self,
        starts: Float[np.ndarray, "rays 3"],
        directions: Float[np.ndarray, "rays 3"],
    ) -> tuple[Int[np.ndarray, " rays"], Float[np.ndarray, " rays"], Float[np.ndarray, "rays 2"]]:
        """:meth:`first_hit_uv` of rays already in Embree's terms: ``starts`` float32 in the
        caster's frame (the point minus :attr:`origin`, already nudged off its surface) and
        unit float32 ``directions``. Returns the triangle (int32, −1 none), the distance from
        the start (float32, m; 1e37 for none) and the barycentric ``(u, v)`` (0 for none).

        For a caller that makes millions of rays itself (the sampled transport): it skips the
        float64 re-centring, normalising and nudging, which took as long as Embree itself."""
        starts = np.ascontiguousarray(starts, np.float32)
        directions = np.ascontiguousarray(directions, np.float32)
        n = len(directions)
        if self._scene is None or n == 0:
            return np.full(n, -1, np.int32), np.full(n, 1e37, np.float32), np.zeros((n, 2),
                                                                                    np.float32)
        parts = [self._run_local(starts[s:s + _CHUNK], directions[s:s + _CHUNK])
                 for s in range(0, n, _CHUNK)]
        if len(parts) == 1:
            r = parts[0]
            return r["primID"], r["tfar"], np.stack([r["u"], r["v"]], axis=1)
        cat = {k: np.concatenate([r[k] for r in parts]) for k in ("primID", "tfar", "u", "v")}
        return cat["primID"], cat["tfar"], np.stack([cat["u"], cat["v"]], axis=1)

    def _run_local(self, starts, directions) -> dict:
        """One Embree query; read-only rays (a view of an XLA result: no copy) are copied
        only for a binding that wants them writable (embreex before 4 declares no const)."""
        try:
            return self._scene.run(starts, directions, output=1)
        except ValueError:
            if starts.flags.writeable and directions.flags.writeable:
                raise
            return self._scene.run(np.array(starts), np.array(directions), output=1)


def _unpickled_caster(key: str, triangles: np.ndarray) -> RayCaster:
    from ..parallel import worker_cached

    return worker_cached(("raycaster", key), lambda: RayCaster(triangles))
