"""The lighting solution of a study: direct and inter-reflected light, one solution per network.

Light adds linearly, so each network k is solved once at dimmer 1 and any dimmer vector α gives
``B = Σ_k α_k B_k`` exactly (the paper's equation 10). The pieces, in the order they are built:

1. the scene's triangles cut into patches and partitioned into blocks (``lumijax.radiosity``);
2. the transport operator F of the visible block pairs (``lumijax.radiosity``);
3. direct irradiance on every patch and every calculation point, per (network, spectrum)
   group (``lumijax.direct``, shadows by ray casting);
4. one batched solve ``(I − ρ(λ)F) B = ρ(λ) E_direct s(λ)`` for all groups and sample
   wavelengths at once (``lumijax.radiosity``);
5. gathering ``G B`` of the inter-reflected light onto the calculation points, and the
   reduction of the spectral values to lux and CIE XYZ.

Changing one luminaire re-shoots only its difference (paper section 6): see
:meth:`LightingSolution.replace_luminaire`.

A solution holds its light on patches as :class:`Level` records: ``coarse``, the operator's
patches (elements), and ``fine``, the finer patches a two-level solve gathered from them
(docs/radiosity.md, "Two levels"; None with one level): ``sol.coarse.radiosity``,
``sol.fine.patches``, and ``sol.display`` for the level to show and write.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from dataclasses import dataclass, field
from typing import NamedTuple, TypeVar

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from .. import _executables
from .._jit_cache import to_device
from ..direct import direct_illuminance
from ..radiosity import Patches, RadiositySolution, TransportOperator, near_light
from ..radiosity._gather import GatherOperator
from ..radiosity._sampled_gather import SampledGather
from ..scene import Scene
from ..spectral import Spectrum
from ._spectral import SpectralSetup, solve_spectral

__all__ = ["LightingSolution", "Level", "float64_scope"]

_T = TypeVar("_T")


def _corrected_matmul(transport, b) -> np.ndarray:
    """``F' b`` with the solve's row correction (:meth:`LightingSolution.patch_illuminance`).
    A small operator (one dense block, ``radiosity._operator.dense_matrix``) is applied on
    the host, a BLAS product with nothing to compile (the direct solve holds that matrix
    already); a larger one by one compiled program (its eager ops compiled a dozen in every
    process), with the operator's build statistics (a static field) dropped first: they
    differ by run and would key a new program each time."""
    from ..radiosity._operator import Info, dense_matrix
    from ..radiosity._solve import patch_bucket, row_correction

    g = dense_matrix(transport, patch_bucket(transport.n_patches))
    if g is None:
        return np.asarray(_corrected_matmul_kernel(dataclasses.replace(transport, info=Info()), b))
    host = np.asarray(b)  # its callers' radiosities: concrete already
    area = np.asarray(transport.area, np.float64)
    c, _ = row_correction(g.sum(axis=1, dtype=np.float64) / area)
    return ((g @ (host * c[:, None].astype(host.dtype))) / area[:, None]).astype(host.dtype)


def _small(transport, b) -> dict | None:
    """XLA's options for the product: a small solve's (``radiosity._solve.compiler_options``;
    it runs once per process: optimised, the demo's took 1.7 s to compile, 0.9 s without)."""
    from ..radiosity._solve import compiler_options

    return compiler_options(transport, b)


@_executables.stored("corrected_matmul", "lighting/_solution.py", "radiosity/", "kernels/",
                     options=_small)
def _corrected_matmul_kernel(transport, b):
    from ..radiosity import row_correction

    c, _ = row_correction(transport.row_sums())
    return transport.matmul(b * c.astype(b.dtype)[:, None])


@contextlib.contextmanager
def float64_scope(enable: bool = True):
    """JAX's x64 mode for the duration (``with`` or as a decorator), for float64 work only.

    JAX makes float64 arrays only with x64 on; lumijax does not flip that global setting as a
    side effect of ``compute`` or ``optimise`` (docs/conventions.md, "Precision"). A float64
    study is computed, and a fit runs, inside this scope; the arrays it makes stay float64
    and carry the precision after it (``transport.area.dtype``). ``enable=False`` leaves the
    caller's setting alone (a float32 study under a user's x64 runs as it always has).
    """
    if not enable:
        yield
        return
    with jax.enable_x64(True):
        yield


@dataclass(frozen=True, eq=False)
class Level:
    """Light on one level of patches, per network at dimmer 1.

    Attributes
    ----------
    patches
        The :class:`lumijax.radiosity.Patches` (None: no inter-reflection was computed).
    gather
        Coarse level: the patches → calculation points gather; fine level: the sparse map from
        the elements' radiosity to fine-patch irradiance (lx).
    rho
        Coarse: ``(patches,)`` luminous reflectance; fine: ``(fine, W)`` reflectance at the
        solve's sample wavelengths (dimensionless).
    patch_direct
        ``(networks, patches)`` direct irradiance (lx).
    radiosity
        ``(networks, patches)`` luminous radiosity B (lm/m²): reflected direct plus all bounces.
    radiosity_xyz
        ``(networks, 3, patches)`` CIE XYZ of the radiosity (Y = ``radiosity``), or None.
    patch_indirect
        ``(networks, patches)`` gathered inter-reflected irradiance (lx) of a fine level, or of
        the coarse one after a sampled transport's final gather (``radiosity._sampled_gather``);
        else None on the coarse level, where it is ``F·B``
        (:meth:`LightingSolution.patch_illuminance`).
    """

    patches: Patches | None
    gather: GatherOperator | None
    rho: np.ndarray | None
    patch_direct: Float[np.ndarray, "net patches"]
    radiosity: Float[np.ndarray, "net patches"]
    radiosity_xyz: Float[np.ndarray, "net 3 patches"] | None = None
    patch_indirect: Float[np.ndarray, "net patches"] | None = None

    @classmethod
    def unlit(cls, networks: int) -> Level:
        """The level of a solution without inter-reflection: no patches, nothing on them."""
        return cls(patches=None, gather=None, rho=None, patch_direct=np.zeros((networks, 0)),
                   radiosity=np.zeros((networks, 0)))


@dataclass(frozen=True, eq=False)
class LightingSolution:
    """Per-network light on patches and calculation points, at dimmer 1.

    Attributes
    ----------
    scene
        The :class:`lumijax.scene.Scene` solved.
    points, normals
        The calculation points of all grids, concatenated in grid order (m; unit normals).
    coarse
        Light on the operator's patches (:class:`Level`; no patches when inter-reflection is
        off or the scene has no surfaces).
    fine
        Light on the fine patches of a two-level solve, or None (one level).
    transport, spectral
        Form factors and the spectral set-up (None when inter-reflection is off).
    point_direct, point_indirect
        ``(networks, points)`` direct and inter-reflected illuminance (lx).
    point_xyz
        ``(networks, 3, points)`` CIE XYZ of the total illuminance (Y in lx), or None.
    solve_method, solve_tolerance, solve_max_steps
        The ``[solver]`` settings an incremental re-shot solves with.
    final_gather
        The sampled transport's final gather (``[solver] final_gather_rays``), which an
        incremental re-shot gathers through too: the same rows, so a re-shot luminaire's
        light adds exactly (and costs the gather's rays again: its light reaches every patch
        after a bounce); None without one.
    """

    scene: Scene
    points: Float[np.ndarray, "points 3"]
    normals: Float[np.ndarray, "points 3"]
    coarse: Level
    transport: TransportOperator | None
    spectral: SpectralSetup | None
    point_direct: Float[np.ndarray, "net points"]
    point_indirect: Float[np.ndarray, "net points"]
    point_xyz: Float[np.ndarray, "net 3 points"] | None
    solve_method: str = "refined"  # [solver] method
    solve_tolerance: float | None = None
    solve_max_steps: int = 1000
    stats: dict = field(default_factory=dict)
    fine: Level | None = None
    final_gather: SampledGather | None = None

    @property
    def display(self) -> Level:
        """The level to show and write: the fine one of a two-level solve, else the coarse."""
        return self.coarse if self.fine is None else self.fine

    @property
    def display_rho(self) -> Float[np.ndarray, " patches"] | None:
        """Luminous reflectance of the display patches."""
        if self.fine is None:
            return self.coarse.rho
        return np.array([m.luminous_reflectance for m in self.scene.materials])[
            self.fine.patches.material]

    def display_patch_illuminance(self) -> Float[np.ndarray, "net patches"]:
        """Irradiance on each display patch per network (lx): direct + inter-reflected."""
        if self.fine is None:
            return self.patch_illuminance()
        return self.fine.patch_direct + self.fine.patch_indirect

    def display_patch_illuminance_at(self, dimmers) -> Float[np.ndarray, " patches"]:
        """Irradiance on each display patch at a dimmer vector (lx): ``dimmers @
        display_patch_illuminance()``, with one operator product (the dimmed radiosity) instead
        of one per network, and the same shape as the row sums' product, so a process that
        writes ``patches.vtp`` compiles that product once, not twice."""
        d = np.asarray(dimmers, np.float64)
        if self.fine is not None or self.transport is None or self.coarse.patch_indirect is not None:
            return d @ self.display_patch_illuminance()
        with float64_scope(_float64(self)):
            b = to_device((d @ self.coarse.radiosity)[:, None], _dtype(self))
            fb = np.asarray(_corrected_matmul(self.transport, b))[:, 0]
        return d @ self.coarse.patch_direct + fb

    def display_radiosity_at(self, dimmers) -> Float[np.ndarray, " patches"]:
        """Radiosity of the display patches at any dimmer vector (lm/m²), exact, no solve."""
        return np.asarray(dimmers, np.float64) @ self.display.radiosity

    @property
    def point_total(self) -> Float[np.ndarray, "net points"]:
        """Direct plus inter-reflected illuminance per network at dimmer 1 (lx)."""
        return self.point_direct + self.point_indirect

    def radiosity_at(self, dimmers) -> Float[np.ndarray, " patches"]:
        """B = Σ α_k B_k (lm/m²): exact for any dimmer vector, no solve."""
        return np.asarray(dimmers, np.float64) @ self.coarse.radiosity

    def patch_illuminance(self) -> Float[np.ndarray, "net patches"]:
        """Irradiance on each patch per network (lx): direct + F'·B (luminous), with F' the
        row-corrected form factors the solve used (``radiosity.row_correction``), so that
        B = ρE holds patch by patch; after a sampled transport's final gather, the irradiance
        it gathered (``coarse.patch_indirect``), for which B = ρE holds too."""
        if self.transport is None:
            return self.coarse.patch_direct
        if self.coarse.patch_indirect is not None:
            return self.coarse.patch_direct + self.coarse.patch_indirect
        with float64_scope(_float64(self)):
            b = to_device(self.coarse.radiosity.T, _dtype(self))
            fb = np.asarray(_corrected_matmul(self.transport, b)).T
        return self.coarse.patch_direct + fb

    def replace_luminaire(self, index: int, luminaire) -> LightingSolution:
        """The solution with luminaire ``index`` replaced (moved, re-aimed, re-lamped, …).

        Only the difference is re-shot: the old and new luminaire's direct light on patches and
        points (that luminaire's candidate pairs only), one solve of ``(I − ρF) ΔB = ρ ΔE``
        over the sample wavelengths (one column per wavelength when network and spectrum stay,
        two otherwise), and one gather. The result equals a full re-solve up to the solver's
        tolerance (a luminaire's light on the patches is its own: ``radiosity.near_light``).
        The network and the spectrum may change too.
        """
        with float64_scope(_float64(self)):
            return self._replace_luminaire(index, luminaire)

    def _replace_luminaire(self, index: int, luminaire) -> LightingSolution:
        sc = self.scene
        old = sc.luminaires[index]
        lums = list(sc.luminaires)
        lums[index] = luminaire
        new_scene = dataclasses.replace(sc, luminaires=tuple(lums))
        names = sc.network_names
        t0 = time.perf_counter()
        coarse, fine = _copy(self.coarse), None if self.fine is None else _copy(self.fine)
        point_direct, point_indirect = self.point_direct.copy(), self.point_indirect.copy()
        point_xyz = None if self.point_xyz is None else self.point_xyz.copy()
        # direct light of the old and new luminaire alone (its candidate pairs only)
        deltas = []
        for lum, sign in ((old, -1.0), (luminaire, 1.0)):
            one = dataclasses.replace(
                sc, luminaires=(dataclasses.replace(lum, network=names[0]),), area_sources=())
            e_pts = sign * direct_illuminance(one, self.points, self.normals).by_network[0]
            e_fine = None if self.fine is None else sign * _sampled_direct(one, self.fine)
            if e_fine is not None:  # two levels: the elements' direct is the fine flux's mean
                from ..radiosity._final_gather import element_means

                e_patch = element_means(self.fine.patches, self.coarse.patches,
                                        e_fine[None])[0][0]
            elif self.coarse.patches is not None:
                e_patch = sign * _sampled_direct(one, self.coarse)
            else:
                e_patch = None
            deltas.append(_Delta(names.index(lum.network), lum.spectrum, e_pts, e_patch, e_fine))
        # same network and spectrum: one difference row, so one solve of W columns, not two
        a, b = deltas
        if a.network == b.network and a.spectrum is b.spectrum:
            deltas = [_Delta(a.network, a.spectrum, a.points + b.points,
                             None if a.patches is None else a.patches + b.patches,
                             None if a.fine is None else a.fine + b.fine)]
        for d in deltas:
            point_direct[d.network] += d.points
            if d.patches is not None:
                coarse.patch_direct[d.network] += d.patches
        if self.coarse.patches is not None:
            shot = shoot(self, np.stack([_needed(d.patches) for d in deltas]),
                         [d.spectrum for d in deltas], np.stack([d.points for d in deltas]))
            for q, d in enumerate(deltas):
                coarse.radiosity[d.network] += shot.radiosity[q]
                if coarse.patch_indirect is not None:
                    coarse.patch_indirect[d.network] += _needed(shot.patch_indirect)[q]
                point_indirect[d.network] += shot.point_indirect[q]
                if point_xyz is not None:
                    coarse.radiosity_xyz[d.network] += shot.radiosity_xyz[q]
                    point_xyz[d.network] += shot.point_xyz[q]
            if fine is not None:
                from ..radiosity._final_gather import fine_transmission, reflect_onto_fine

                rb, rxyz, rind = reflect_onto_fine(
                    fine.gather, fine.rho, np.stack([_needed(d.fine) for d in deltas]),
                    [self.spectral.weights(d.spectrum) for d in deltas], shot.value,
                    transmission=fine_transmission(self.spectral, self.coarse.patches,
                                                   fine.patches))
                for q, d in enumerate(deltas):
                    fine.patch_direct[d.network] += d.fine
                    fine.patch_indirect[d.network] += rind[q]
                    fine.radiosity[d.network] += rb[q]
                    if fine.radiosity_xyz is not None:
                        fine.radiosity_xyz[d.network] += rxyz[q]
        stats = dict(self.stats, incremental_s=time.perf_counter() - t0)
        return dataclasses.replace(self, scene=new_scene, coarse=coarse, fine=fine,
                                   point_direct=point_direct, point_indirect=point_indirect,
                                   point_xyz=point_xyz, stats=stats)


class _Delta(NamedTuple):
    """The change one luminaire makes: its network's index, spectrum and direct light (lx) on
    the points, the coarse patches and the fine patches (None where that level is absent)."""

    network: int
    spectrum: Spectrum | None
    points: np.ndarray
    patches: np.ndarray | None
    fine: np.ndarray | None


def _needed(value: _T | None) -> _T:
    """``value``, which the caller's level of inter-reflection guarantees is there."""
    assert value is not None, "a solution with patches has its gather, spectra and light"
    return value


def _copy(level: Level) -> Level:
    """The level with its per-network arrays copied (updated in place by a re-shot)."""
    def c(a):
        return None if a is None else np.array(a, copy=True)

    return dataclasses.replace(level, patch_direct=c(level.patch_direct),
                               radiosity=c(level.radiosity),
                               radiosity_xyz=c(level.radiosity_xyz),
                               patch_indirect=c(level.patch_indirect))


def _dtype(sol: LightingSolution):
    """The precision the solution was solved in, carried by its operator's arrays."""
    if sol.transport is None:
        return jnp.float64 if jax.config.read("jax_enable_x64") else jnp.float32
    return sol.transport.area.dtype


def _float64(sol: LightingSolution) -> bool:
    return sol.transport is not None and sol.transport.area.dtype == np.float64


@dataclass(frozen=True)
class Shot:
    """Light shot by a set of sources (one row each) into the scene.

    ``result`` carries the solve's figures (products, residual, result code, the escaped and
    created fractions); its ``value`` is empty, ``(patches, 0)``: the radiosity is ``value``
    (float64, spectrum applied), and keeping the solve's own float32 copy of every column
    beside it held a third more memory at the end of a large solve."""

    radiosity: Float[np.ndarray, "src patches"]
    radiosity_xyz: Float[np.ndarray, "src 3 patches"] | None
    point_indirect: Float[np.ndarray, "src points"]
    point_xyz: Float[np.ndarray, "src 3 points"] | None
    result: RadiositySolution
    timing_s: dict = field(default_factory=dict)
    value: Float[np.ndarray, "patches src w"] | None = None  # the spectral radiosity solved
    # the final gather's inter-reflected irradiance (lx) on the patches (None without one)
    patch_indirect: Float[np.ndarray, "src patches"] | None = None


def shoot(sol: LightingSolution, patch_direct, spectra, point_direct, progress=None,
          gather_progress=None) -> Shot:
    """Solve and gather the inter-reflected light of sources with these direct irradiances.

    Parameters
    ----------
    patch_direct, point_direct
        ``(src, patches)`` and ``(src, points)`` direct illuminance (lx), one row per source
        (group) with spectrum ``spectra[i]`` (None: the default).
    progress
        Called as ``progress(done, total)`` in solved columns (sources × wavelengths).
    gather_progress
        Called as ``progress(done, total)`` in patches by a sampled transport's final gather
        (``sol.final_gather``; module ``radiosity._sampled_gather``), which runs once over all
        the columns after the last batch is solved, before the gather onto the points.

    Sources are solved and gathered in batches of as many as the solve's memory budget takes
    (``radiosity._estimate.solve_column_batch``; one batch when all fit): each batch's B₀, its
    copies and its float64 answer exist only while it is solved, so the host holds the whole
    spectral radiosity once, not the five copies one solve of every column would make. The
    batches are as equal as the sources allow, and the progress counts each batch as an equal
    share of the columns: a product's time grows far less than its columns (a sampled product
    of 25–63 columns runs on 64: ``radiosity._operator._WIDE_ROWS``), so a short last batch
    counted by its columns made the bar's time left too short (docs/radiosity.md, "Column
    batches").
    """
    from ..radiosity._estimate import solve_column_batch
    from ..radiosity._solve import join_solutions

    sp, gather = _needed(sol.spectral), _needed(sol.coarse.gather)
    weights = [sp.weights(s) for s in spectra]
    s = np.stack([w[0] for w in weights])  # (src, W)
    h = np.stack([w[1] for w in weights])  # (src, 3, W)
    dtype = _dtype(sol)
    patch_direct = np.asarray(patch_direct)
    n_src, n_w = s.shape
    n = patch_direct.shape[1]
    per = max(1, solve_column_batch(n, n_src * n_w, np.dtype(dtype).itemsize) // n_w)
    n_batches = -(-n_src // per)
    bounds = [n_src * k // n_batches for k in range(n_batches + 1)]
    transmission = sp.transmission(sol.coarse.patches)
    spans = list(zip(bounds[:-1], bounds[1:], strict=True))
    b = None
    parts, solve_s, timing = [], 0.0, {}
    columns = n_src * n_w
    if progress is not None:
        progress(0, columns)
    for k, (lo, hi) in enumerate(spans):
        t = time.perf_counter()
        told = None if progress is None else (  # batch k is the k-th equal share
            lambda done, total, k=k: progress(columns * (k * total + done) // (n_batches * total),
                                              columns))
        b_k, res = solve_spectral(sol.transport, sp.rho, patch_direct[lo:hi], s[lo:hi], dtype,
                                  transmission=transmission, solver=sol.solve_method,
                                  rtol=sol.solve_tolerance, max_steps=sol.solve_max_steps,
                                  progress=told)  # (P, src, W)
        solve_s += time.perf_counter() - t
        if per >= n_src:
            b = b_k
        else:
            if b is None:
                b = np.empty((n, n_src, n_w), np.float64)
            b[:, lo:hi] = b_k
        # the figures only: b holds the values (class docstring)
        parts.append(dataclasses.replace(res, value=to_device(np.empty((n, 0), np.float32))))
        del b_k, res
    res = join_solutions(parts)
    b = _needed(b)
    indirect = None
    if sol.final_gather is not None:
        t = time.perf_counter()
        g = _gather_finally(sol, b, patch_direct, s, transmission, gather_progress)
        indirect = np.einsum("sw,psw->sp", h[:, 1], g)  # (src, P) lx, luminous
        timing["sampled_final_gather"] = time.perf_counter() - t
        del g
    t = time.perf_counter()
    e_ind = None
    for lo, hi in spans:  # the sources' batches again: one batch's float32 copy at a time
        e_k = np.asarray(gather(to_device(b[:, lo:hi], dtype)), np.float64)  # (N, src, W)
        if e_ind is None:
            e_ind = e_k if len(spans) == 1 else np.empty((e_k.shape[0], n_src, n_w))
        if len(spans) > 1:
            e_ind[:, lo:hi] = e_k
        del e_k
    gather_s = time.perf_counter() - t
    e_ind = _needed(e_ind)
    b_xyz = np.einsum("scw,psw->scp", h, b)  # (src, 3, P)
    ind_xyz = np.einsum("scw,nsw->scn", h, e_ind)  # (src, 3, N)
    colour = np.einsum("scw,sw->sc", h, s)  # XYZ of each source's light, Y = 1
    point_xyz = ind_xyz + colour[:, :, None] * np.asarray(point_direct)[:, None, :]
    spectral = sp.sampling is not None
    return Shot(
        radiosity=b_xyz[:, 1], radiosity_xyz=b_xyz if spectral else None,
        point_indirect=ind_xyz[:, 1], point_xyz=point_xyz if spectral else None, result=res,
        timing_s={"solve": solve_s, **timing, "gather": gather_s},
        value=b, patch_indirect=indirect,
    )


def _gather_finally(sol: LightingSolution, b, patch_direct, s, transmission, progress=None):
    """The sampled transport's final gather (``radiosity._sampled_gather``) of the solved
    ``b`` ``(P, src, W)`` (lm/m² per unit of Y), in place: ``H = E s + F_g (c b)``, then
    ``b = ρ H + τ H[partner]``. Returns ``F_g (c b)`` ``(P, src, W)`` (lx per unit of Y)."""
    from ..radiosity._solve import row_correction

    sp, patches = _needed(sol.spectral), _needed(sol.coarse.patches)
    n, n_src, n_w = b.shape
    # the light each patch passes on as the solve's corrected rows did (F_ij → F_ij c_j)
    c = np.asarray(row_correction(_needed(sol.transport).row_sums())[0], np.float64)
    g, _ = _needed(sol.final_gather)(patches, sol.scene.raycaster, b.reshape(n, -1),
                                     outgoing=c, progress=progress)
    g = g.reshape(n, n_src, n_w)
    e = np.asarray(patch_direct, np.float64).T  # (P, src) lx
    s = np.asarray(s, np.float64)
    rho = np.asarray(sp.rho, np.float64)  # (P, W)

    def total(rows):  # H: direct plus gathered irradiance, (rows, src, W)
        return e[rows, :, None] * s[None] + g[rows]

    tau, partner = ((None, None) if transmission is None else
                    (np.asarray(transmission[0], np.float64), np.asarray(transmission[1])))
    step = max(1, (1 << 22) // max(n_src * n_w, 1))  # rows a chunk: no patch-sized temporary
    for a in range(0, n, step):
        rows = np.arange(a, min(a + step, n))
        b[rows] = rho[rows, None, :] * total(rows)
        if tau is not None:
            b[rows] += tau[rows, None, :] * total(partner[rows])
    return g


def _sampled_direct(scene: Scene, level: Level) -> Float[np.ndarray, " patches"]:
    """``scene``'s (one network's) direct light on ``level``'s patches as the solve took it:
    the centroids', and the mean over the patch near a luminaire (``radiosity.near_light``)."""
    e = direct_illuminance(scene, level.patches.centroid, level.patches.normal).by_network[0]
    return e + near_light(scene, level.patches)[0][0]
