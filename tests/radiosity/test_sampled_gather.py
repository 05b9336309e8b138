"""The sampled transport's final gather (``radiosity/_sampled_gather.py``, ``[solver]
final_gather_rays``): streamed rows against the built ones, a closed room's exact light, the
noise against the block operator, and a study that gathers, reports and re-shoots."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest
import scipy.sparse as sp

from lumijax.radiosity import (
    SampledSettings,
    build_operator,
    build_sampled,
    gather_sampled,
    mesh_patches,
    partition,
    row_correction,
    solve_radiosity,
)
from lumijax.scene._raycast import RayCaster

from .test_noise import _low_lamp_box, _room
from .test_sampled import _furnished_triangles


def test_the_streamed_rows_are_the_rows_a_build_stores():
    tri = _furnished_triangles()
    p = mesh_patches(tri, patch_size=0.45)
    caster = RayCaster(tri)
    ss = SampledSettings(rays_per_patch=96, seed=5, batch=256)  # several batches
    r, s, w = build_sampled(p, tri, ss, caster=caster).buckets[0].links()
    keep = (r < p.n) & (s < p.n) & (w != 0)  # the layout's padding links carry nothing
    rng = np.random.default_rng(0)
    y, c = rng.uniform(0, 1, (p.n, 5)), rng.uniform(0.5, 1.0, p.n)
    want = sp.csr_matrix((w[keep] / p.area[r[keep]] * c[s[keep]], (r[keep], s[keep])),
                         shape=(p.n, p.n)) @ y
    got, counts = gather_sampled(p, caster, ss, y, outgoing=c)
    # the stored weights are whole hit counts under a float32 scale a patch: equal to float32
    np.testing.assert_allclose(got, want, rtol=2e-6, atol=1e-7 * np.abs(want).max())
    assert counts["rays"] == 96 * p.n and counts["links"] == int(keep.sum())
    with pytest.raises(ValueError, match="patches, columns"):
        gather_sampled(p, caster, ss, y[:-1])


def test_a_closed_room_lit_evenly_keeps_its_exact_light():
    import trimesh

    box = trimesh.creation.box(extents=(3.0, 2.0, 2.5))
    box.invert()  # faces inwards: a closed room, every ray meets a front face
    tri = np.asarray(box.triangles)
    p = mesh_patches(tri, patch_size=0.5)
    rho, e0 = 0.6, 100.0
    op = build_sampled(p, tri, SampledSettings(rays_per_patch=64, aimed_share=0.0))
    b0 = np.full((p.n, 1), rho * e0)
    b1 = np.asarray(solve_radiosity(op, jnp.full(p.n, rho, jnp.float32),
                                    jnp.asarray(b0, jnp.float32)).value, np.float64)
    c = np.asarray(row_correction(op.row_sums())[0], np.float64)
    g, _ = gather_sampled(p, RayCaster(tri), SampledSettings(rays_per_patch=256, seed=2),
                          b1, outgoing=c)
    # E + F_g B = E / (1 − ρ) on every patch of an evenly lit closed room, whatever the rays
    np.testing.assert_allclose(e0 + g[:, 0], e0 / (1 - rho), rtol=2e-4)


def test_a_coarse_operator_gathered_finely_reads_as_a_fine_one():
    tri, p, rho, b0 = _room()  # test_noise.py's: the furnished room under a downlight
    block = build_operator(p, partition(p, 512, occluders=tri), tri)
    caster = RayCaster(tri)
    b0 = jnp.asarray(b0[:, None], jnp.float32)
    a = p.area

    def solved(op):
        b = solve_radiosity(op, jnp.asarray(rho, jnp.float32), b0).value
        return np.asarray(b, np.float64), np.asarray(op.matmul(b), np.float64)[:, 0]

    def rms(e):  # per patch, relative to the field's (test_sampled.py's measure)
        return np.sqrt(np.sum(a * (e - ref) ** 2) / np.sum(a * ref**2))

    _, ref = solved(block)
    coarse = build_sampled(p, tri, SampledSettings(rays_per_patch=64, aimed_share=0.0),
                           caster=caster)
    b1, e1 = solved(coarse)
    fine = SampledSettings(rays_per_patch=1024, seed=2, aimed_share=0.0)
    c = np.asarray(row_correction(coarse.row_sums())[0], np.float64)
    g, _ = gather_sampled(p, caster, fine, b1, outgoing=c)
    e_fine = solved(build_sampled(p, tri, fine, caster=caster))[1]
    print(f"RMS per patch: 64 rays {rms(e1):.4f}, gathered with 1,024 {rms(g[:, 0]):.4f}, "
          f"1,024 rays {rms(e_fine):.4f}")
    # measured (aimed rays in docs/radiosity.md; cosine rays here): the 64-ray operator's own
    # noise halves and the gather reads within a few % of a whole 1,024-ray operator
    assert rms(g[:, 0]) < 0.6 * rms(e1)
    assert rms(g[:, 0]) < 1.15 * rms(e_fine)
    assert abs(np.sum(a * (g[:, 0] - ref)) / np.sum(a * ref)) < 0.01  # no bias


def test_a_study_gathers_finally_reports_and_reshoots(write_study):
    import lumijax
    from lumijax import load_study
    from lumijax.lighting import solve_lighting

    coarse = lumijax.compute(load_study(write_study(_low_lamp_box("sampled", 32),
                                                    "c.toml"))).lighting
    text = _low_lamp_box("sampled", 32).replace("rays_per_patch = 32",
                                               "rays_per_patch = 32\nfinal_gather_rays = 512")
    assert "final_gather_rays = 512" in text
    study = load_study(write_study(text, "g.toml"))
    sol = lumijax.compute(study).lighting
    noise, was = sol.stats["sampled_noise"], coarse.stats["sampled_noise"]
    assert sol.stats["final_gather_rays"] == 512 and noise["rays_per_patch"] == 512
    print(f"own noise per patch: 32 rays {was['rms']:.4f}, gathered with 512 {noise['rms']:.4f}")
    assert noise["rms"] < 0.5 * was["rms"]  # 1/√16 of it, by the rays
    assert sol.stats["timing_s"]["sampled_final_gather"] > 0
    from lumijax.report._html import _noise_text

    assert _noise_text(noise, 512).startswith("a final gather of 512 rays a patch, own noise ≈ ")
    # the patches' light is the gather's, for which B = ρ E holds patch by patch (luminous)
    e = sol.patch_illuminance()
    np.testing.assert_allclose(sol.coarse.radiosity, sol.coarse.rho * e, rtol=1e-9)
    assert not np.allclose(e, coarse.patch_illuminance(), rtol=1e-3)
    # a re-shot luminaire is gathered through the same rows (cosine rays: the same sample
    # whatever the light), so it agrees with a new solve to the solver's tolerance
    moved = dataclasses.replace(study.scene.luminaires[0], position=np.array([2.5, 1.2, 0.4]))
    fast = sol.replace_luminaire(0, moved)
    full = solve_lighting(fast.scene, sol.points, sol.normals,
                          lumijax._study.solver_settings(study))
    np.testing.assert_allclose(fast.point_total, full.point_total, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(fast.patch_illuminance(), full.patch_illuminance(),
                               rtol=2e-4, atol=1e-3)


@pytest.mark.parametrize("bad", [8, "many", 32])  # 32: no more than the operator's rays
def test_a_bad_final_gather_names_the_key(write_study, bad):
    from lumijax import load_study
    from lumijax.errors import LumijaxError

    text = _low_lamp_box("sampled", 32).replace("rays_per_patch = 32",
                                               f"rays_per_patch = 32\nfinal_gather_rays = {bad!r}")
    with pytest.raises(LumijaxError, match="final_gather_rays"):
        load_study(write_study(text.replace("'", '"')))
    blocks = _low_lamp_box("blocks", 32).replace("rays_per_patch = 32",
                                                 "rays_per_patch = 32\nfinal_gather_rays = 512")
    with pytest.raises(LumijaxError, match="final_gather_rays.*sampled"):
        load_study(write_study(blocks, "b.toml"))


def test_a_final_gather_has_its_own_seed_and_batches_of_a_builds_rays():
    from lumijax.radiosity import SampledGather

    op = SampledSettings(rays_per_patch=256, seed=7)
    g = SampledGather.of(op, 4096)
    # independent of the operator (seed) and of its noise estimate (seed + 1)
    assert g.settings.seed == 9 and g.rays_per_patch == 4096
    # as many rays a batch as a build's, whatever the gather's rays: memory O(batch)
    assert g.settings.batch * 4096 == op.batch * 256
    assert SampledGather.of(op, 64).settings.batch == op.batch  # never more patches
    assert SampledGather.of(op, 65536).settings.batch >= 16
