"""Two-level radiosity: solve on coarse elements, gather onto fine patches (final gather).

The inter-reflected field is smooth, the direct field is not. So the operator, the partition and
the solve run on coarse **elements** (about ``[solver] operator_patches``), and every fine
**patch** gets

* its own exact direct irradiance (``lumijax.direct`` on the fine centroids), and
* the irradiance of the coarse solution it sees, ``E_gath = Σ_j G_ij B_j``, by the same
  cosine-weighted ray gather used for calculation points (``build_gather``, piecewise-constant
  element radiosity),

then reflects both: ``B_fine(λ) = ρ_fine(λ) H(λ)``, ``H = E_direct s(λ) + E_gath(λ)``, per
emission group and sample wavelength; a fine patch of a diffuser (``kind = "diffuse"``) also
passes on what its other face receives, ``B_fine = ρ H + τ H[partner]``, the coupling of the
coarse solve (``_transmission.py``) on the fine faces. This is the classical two-pass final gather: its only approximations
are the one bounce from a coarse element (its radiosity is an area mean) and the ray sampling.
The stored fine gather is a sparse ``(fine patches × elements)`` map, so re-shooting a changed
luminaire (``replace_luminaire``) also updates the fine level without a ray. Its rays pass clear
panes (``GlazedCaster.first_hit_through``), a link weighing τ(θ) of each pane crossed, as the
gather onto grids does (docs/materials.md).

Memory is linear in the fine patch count: the gather is cast in chunks of fine patches and
applied as one sparse product, never as a dense ``(links, groups, wavelengths)`` array.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
from jaxtyping import Float

from ..kernels import length_tolerance
from ..parallel import Executor, current_executor
from ._gather import GatherOperator, merged_links, patch_of_hits

__all__ = ["FineLevel", "build_fine_gather", "element_direct", "final_gather",
           "fine_transmission", "reflect_onto_fine"]


@dataclass(frozen=True, eq=False)
class FineLevel:
    """Per-source light on the fine patches (one row per emission group or source row).

    Attributes
    ----------
    patches
        The fine :class:`lumijax.radiosity.Patches`.
    gather
        Sparse map from element radiosity to fine-patch irradiance (lx).
    rho
        ``(fine, W)`` reflectance at the solve's sample wavelengths.
    direct
        ``(src, fine)`` direct illuminance (lx).
    indirect
        ``(src, fine)`` gathered inter-reflected illuminance (lx, luminous).
    radiosity
        ``(src, fine)`` luminous radiosity (lm/m²).
    radiosity_xyz
        ``(src, 3, fine)`` CIE XYZ of the radiosity, or None (photometric solve).
    """

    patches: object
    gather: GatherOperator
    rho: Float[np.ndarray, "fine w"]
    direct: Float[np.ndarray, "src fine"]
    indirect: Float[np.ndarray, "src fine"]
    radiosity: Float[np.ndarray, "src fine"]
    radiosity_xyz: Float[np.ndarray, "src 3 fine"] | None
    timing_s: dict = field(default_factory=dict)


def build_fine_gather(fine, elements, caster, *, rays: int, chunk: int = 32_768,
                      executor: Executor | None = None) -> GatherOperator:
    """Gather map from the elements onto the fine patches' centroids, cast in chunks.

    Each chunk is merged on its own (links never cross points, so this is exact) and the
    links are stored as int32/float32: peak memory is one chunk's rays, not all of them.
    ``executor`` (:mod:`lumijax.parallel`; default the current one) casts the chunks; each
    gets the random generator's state at its start, so a cluster casts the same rays.
    """
    # a centroid lies on its own surface: start the rays a hair in front of it
    from ._gather import _cosine_directions, _frames

    eps = None if caster is None else caster.epsilon  # relative to the scene (RayCaster.EPSILON)
    lift = 10.0 * float(eps if eps is not None else length_tolerance(fine.vertices, 1e-6))
    origins = fine.centroid + lift * fine.normal
    rng = np.random.default_rng(0)
    local = _cosine_directions(rays)
    src = np.asarray(elements.source_triangle)
    tri_normals = np.zeros((int(src.max()) + 1 if len(src) else 0, 3))
    tri_normals[src] = elements.normal
    normals = np.asarray(fine.normal, np.float64)
    ex = current_executor() if executor is None else executor

    def spans():
        for s in range(0, fine.n, chunk):
            state = rng.bit_generator.state
            _frames(normals[s:s + chunk], rng)  # the generator where the next chunk starts
            yield s, state

    done = ex.map(_fine_chunk, spans(), shared=dict(
        origins=origins, normals=normals, local=local, elements=elements, caster=caster,
        tri_normals=tri_normals, rays=rays, chunk=chunk))
    pts, pat, wts = (list(x) for x in zip(*done, strict=True)) if fine.n else ([], [], [])
    return GatherOperator(n_points=fine.n, n_patches=elements.n, point=_cat(pts, np.int32),
                          patch=_cat(pat, np.int32), weight=_cat(wts, np.float32))


def _fine_chunk(span, *, origins, normals, local, elements, caster, tri_normals, rays, chunk):
    """The links of the fine patches ``span[0]`` onward (``chunk`` of them), on any process:
    ``(points, elements, weights)``; ``span[1]`` is the generator state they start at."""
    from ._gather import _frames

    s, state = span
    rng = np.random.default_rng()
    rng.bit_generator.state = state
    p = origins[s:s + chunk]
    frames = _frames(normals[s:s + chunk], rng)
    dirs = np.einsum("pij,rj->pri", frames, local).reshape(-1, 3)
    o = np.repeat(p, rays, axis=0)
    # clear panes pass the ray on, carrying τ(θ) of each (as build_gather's rays do); a plain
    # caster's rays carry 1
    tri, dist, carried = caster.first_hit_through(o, dirs)
    hit = tri >= 0
    # one-sided surfaces, as in build_gather: a back face blocks but sends nothing
    hit[hit] &= np.einsum("ij,ij->i", dirs[hit], tri_normals[tri[hit]]) < 0
    elem = patch_of_hits(elements, o[hit] + dirs[hit] * dist[hit, None], tri[hit])
    key = np.repeat(np.arange(len(p), dtype=np.int64), rays)[hit] * elements.n + elem
    uniq, counts = merged_links(key, carried[hit])
    return ((uniq // elements.n + s).astype(np.int32), (uniq % elements.n).astype(np.int32),
            (counts / rays).astype(np.float32))


def _cat(parts, dtype):
    return np.concatenate(parts) if parts else np.zeros(0, dtype)


def _sparse(gather: GatherOperator):
    from scipy.sparse import csr_matrix

    return csr_matrix((gather.weight.astype(np.float64), (gather.point, gather.patch)),
                      shape=(gather.n_points, gather.n_patches))


def reflect_onto_fine(
    gather: GatherOperator,
    rho: Float[np.ndarray, "fine w"],
    direct: Float[np.ndarray, "src fine"],
    weights: list,
    b_elements: Float[np.ndarray, "elements src w"],
    transmission: tuple | None = None,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """``(radiosity (src, fine), radiosity_xyz (src, 3, fine), indirect (src, fine))`` of rows
    with these direct irradiances, spectral weights ``(s, H)`` and element radiosities.

    ``transmission``: ``(tau (fine, W), partner (fine,))`` of :func:`fine_transmission` (None:
    no diffuser), so a diffuser's fine patch leaves ``ρ H + τ H[partner]`` (lm/m²)."""
    ne, nsrc, nw = b_elements.shape
    # one sparse product for every (source, wavelength) column: (fine, src·W)
    e = (_sparse(gather) @ np.asarray(b_elements, np.float64).reshape(ne, nsrc * nw))
    e = e.reshape(-1, nsrc, nw)
    s = np.stack([w[0] for w in weights])  # (src, W)
    h = np.stack([w[1] for w in weights])  # (src, 3, W)
    ind_xyz = np.einsum("scw,fsw->scf", h, e)
    e += np.asarray(direct, np.float64).T[:, :, None] * s[None]  # total irradiance, spectral
    b = e * rho[:, None, :]
    if transmission is not None:  # the other face's irradiance, passed on diffusely
        tau, partner = transmission
        b += np.asarray(tau, np.float64)[:, None, :] * e[np.asarray(partner)]
    b_xyz = np.einsum("scw,fsw->scf", h, b)
    return b_xyz[:, 1], b_xyz, ind_xyz[:, 1]


def fine_transmission(spectral, elements, fine) -> tuple | None:
    """``(tau (fine, W), partner (fine,))``: the diffuse transmittance of each fine patch at the
    solve's wavelengths (from the elements' table, as :func:`fine_reflectance`) and its other
    face among the fine patches (``back_partners``); None when no material transmits
    diffusely."""
    if getattr(spectral, "tau", None) is None:
        return None
    from ._transmission import back_partners

    tau = _by_material(spectral.tau, elements, fine)
    return tau, back_partners(fine, tau.max(axis=1) > 0)


def element_direct(gscene, fine, elements, *, progress=None):
    """``(fine, elements)`` direct light (:class:`lumijax.direct.DirectLighting`): on the fine
    patches, each luminaire's light on a patch near it the mean over the patch
    (:func:`~lumijax.radiosity.near_light`); each element gets the direct flux of the fine
    patches in it (those of the same source triangle whose nearest element centroid it is)
    over its area, so the direct flux the solve reflects is the fine one, not a centroid
    sample of a spot's edge. An element holding no fine centroid (possible only where the two
    cuts of a sliver differ) is sampled at its own centroid."""
    from ..direct import DirectLighting, direct_illuminance
    from ._patch_samples import near_light

    d_fine = direct_illuminance(gscene, fine.centroid, fine.normal, progress=progress)
    near, near_rays = near_light(gscene, fine)
    d_fine = dataclasses.replace(d_fine, by_network=d_fine.by_network + near,
                                 shadow_rays=d_fine.shadow_rays + near_rays)
    by, empty = element_means(fine, elements, d_fine.by_network)
    rays = d_fine.shadow_rays
    if empty.any():
        d_e = direct_illuminance(gscene, elements.centroid[empty], elements.normal[empty])
        by[:, empty] = d_e.by_network
        rays += d_e.shadow_rays
    return d_fine, DirectLighting(by_network=by, shadow_rays=rays)


def element_means(fine, elements, values: Float[np.ndarray, "src fine"]):
    """``(src, elements)`` flux of fine-patch irradiances per element over its area, and the
    elements that hold no fine patch. Dividing by the element's own area, not the fine area
    assigned to it, keeps Σ A_e E_e equal to the fine flux exactly (both tile each triangle)."""
    owner = element_of(fine, elements)
    area = np.bincount(owner, weights=fine.area, minlength=elements.n)
    by = np.stack([np.bincount(owner, weights=fine.area * row, minlength=elements.n)
                   for row in np.asarray(values)]).reshape(-1, elements.n)
    return by / elements.area, area <= 0


def element_of(fine, elements) -> np.ndarray:
    """Index of the element holding each fine patch (same source triangle, nearest centroid)."""
    return patch_of_hits(elements, fine.centroid, np.asarray(fine.source_triangle))


def final_gather(
    fine,
    elements,
    caster,
    spectral,
    spectra: list,
    b_elements: Float[np.ndarray, "elements src w"],
    direct: Float[np.ndarray, "src fine"],
    *,
    rays: int,
) -> FineLevel:
    """The fine level of a two-level solve (see the module docstring).

    Parameters
    ----------
    fine, elements
        Fine patches and the coarse elements the operator was solved on (same triangles).
    spectral
        The elements' :class:`~lumijax.lighting._spectral.SpectralSetup`; its wavelengths are
        reused, so fine and coarse columns line up.
    spectra
        The spectrum of each emission group (None: default).
    b_elements
        ``(elements, groups, W)`` spectral radiosity of the solve.
    direct
        ``(groups, fine)`` direct illuminance on the fine patches (lx).
    """
    timing = {}
    t = time.perf_counter()
    gather = build_fine_gather(fine, elements, caster, rays=rays)
    timing["fine_gather_rays"] = time.perf_counter() - t
    t = time.perf_counter()
    rho = fine_reflectance(spectral, elements, fine)
    weights = [spectral.weights(sp) for sp in spectra]
    radiosity, b_xyz, indirect = reflect_onto_fine(
        gather, rho, direct, weights, b_elements,
        transmission=fine_transmission(spectral, elements, fine))
    timing["fine_reflect"] = time.perf_counter() - t
    return FineLevel(
        patches=fine, gather=gather, rho=rho, direct=np.asarray(direct), indirect=indirect,
        radiosity=radiosity, radiosity_xyz=b_xyz if spectral.sampling is not None else None,
        timing_s=timing,
    )


def fine_reflectance(spectral, elements, fine) -> Float[np.ndarray, "fine w"]:
    """Per-fine-patch reflectance at the solve's wavelengths, taken from the elements' table
    (both levels cut the same triangles, so every material is on some element)."""
    return _by_material(spectral.rho, elements, fine)


def _by_material(values, elements, fine) -> np.ndarray:
    """``(fine, W)``: the elements' per-patch ``values`` (elements, W), looked up by material."""
    n_mat = int(max(np.max(elements.material, initial=-1), np.max(fine.material, initial=-1))) + 1
    table = np.zeros((n_mat, values.shape[1]))
    table[elements.material] = values
    return table[fine.material]
