"""``RayCaster.first_hit_local`` (rays in Embree's own float32 terms) against the closed form of
a ray meeting the walls of a box seen from inside, and against ``first_hit_uv``."""

from __future__ import annotations

import numpy as np
import trimesh

from lumijax.scene import RayCaster


def test_rays_in_embree_terms_hit_where_the_box_s_walls_are():
    box = trimesh.creation.box((4.0, 3.0, 2.0))
    box.apply_translation((1000.0, -500.0, 20.0))  # far from the origin: re-centring matters
    caster = RayCaster(box.triangles)
    rng = np.random.default_rng(3)
    o = box.bounds.mean(0) + rng.uniform(-0.9, 0.9, (2000, 3))
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    starts = (o - caster.origin + caster.epsilon * d).astype(np.float32)
    tri, dist, uv = caster.first_hit_local(starts, d.astype(np.float32))
    assert tri.dtype == np.int32 and np.all(tri >= 0)  # a closed box: every ray hits
    # the exit distance from inside an axis-aligned box, by slabs
    half = np.array([2.0, 1.5, 1.0])
    rel = o - box.bounds.mean(0)
    with np.errstate(divide="ignore"):
        exit_t = np.min(np.where(d > 0, (half - rel) / d, (-half - rel) / d), axis=1)
    np.testing.assert_allclose(dist + caster.epsilon, exit_t, atol=2e-4)
    tri64, dist64, uv64 = caster.first_hit_uv(o, d)
    assert np.mean(tri == tri64) > 0.999  # float32 starts: a ray on an edge may pick either side
    same = tri == tri64
    np.testing.assert_allclose(uv[same], uv64[same], atol=1e-4)


def test_a_caster_with_no_triangles_hits_nothing():
    caster = RayCaster(np.zeros((0, 3, 3)))
    tri, dist, uv = caster.first_hit_local(np.zeros((3, 3), np.float32),
                                           np.tile(np.float32([0, 0, 1]), (3, 1)))
    assert np.all(tri == -1) and np.all(dist >= 1e37) and np.all(uv == 0)


def test_read_only_rays_are_traced_in_place_or_copied_for_a_binding_that_wants_to_write():
    box = trimesh.creation.box((2.0, 2.0, 2.0))
    caster = RayCaster(box.triangles)
    starts = np.zeros((4, 3), np.float32) - caster.origin.astype(np.float32)
    d = np.tile(np.float32([0, 0, 1]), (4, 1))
    want = caster.first_hit_local(starts.copy(), d.copy())
    starts.flags.writeable = d.flags.writeable = False  # as a view of an XLA result is
    got = caster.first_hit_local(starts, d)
    assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))

    class Writing:  # embreex before 4: buffers declared without const
        def __init__(self, scene):
            self.scene, self.calls = scene, 0

        def run(self, o, dd, output):
            self.calls += 1
            if not (o.flags.writeable and dd.flags.writeable):
                raise ValueError("buffer source array is read-only")
            return self.scene.run(o, dd, output=output)

    caster._scene = old = Writing(caster._scene)
    got = caster.first_hit_local(starts, d)
    assert old.calls == 2 and all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))
