"""How much memory the transport operator will take, known before it is built.

The bound is the operator stored with every visible block pair dense: the same buckets,
padded block shapes and scan chunks that :func:`~lumijax.radiosity.build_operator` allocates,
so with the low-rank far field off it *is* ``TransportOperator.nbytes``, to the byte. The
compressed far field replaces a dense pair only by factors that take at most
``lowrank_max_fraction`` (½) of its block, so with it on the bound holds with room to spare
(measured in ``docs/radiosity.md``, "Memory estimate").

Two bounds, the cheap one first:

* **before partitioning** (``estimate_before_partition``): every block pair is assumed visible.
  The block sizes are exact (the partition cuts each group of n patches into ⌈n / max_block⌉
  blocks of equal size), so this is the dense operator of a scene where everything sees
  everything: tight for one open room, loose for many closed rooms;
* **after partitioning** (``estimate_from_partition``): only the visible pairs.

While building, the largest bucket exists twice for a moment (the host array and its device
copy), so what must fit is ``peak_bytes`` = stored + largest bucket.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import SolveError
from ._links import link_bytes

__all__ = [
    "OperatorEstimate",
    "available_memory_bytes",
    "block_sizes",
    "bound_sampled_memory",
    "sampled_rays_that_fit",
    "solve_column_batch",
    "solve_column_bytes",
    "check_operator_memory",
    "estimate_before_partition",
    "estimate_from_partition",
]

#: Above this many times the available memory, the all-pairs bound is refused without
#: partitioning: the occlusion culling would have to drop more than 97 % of all block pairs
#: (20 closed rooms keep 3 %), and the partition of such a mesh costs minutes of rays itself.
HOPELESS_RATIO = 30.0


@dataclass(frozen=True)
class OperatorEstimate:
    """Upper bound on the operator's memory (bytes), and what it was computed from."""

    patches: int
    blocks: int
    pairs: int
    stored_bytes: int
    """Bucket arrays with every counted pair dense (padding included), as ``nbytes`` counts."""
    peak_bytes: int
    """Stored bytes plus the largest bucket (its host copy while it is moved to the device)."""
    visible_only: bool
    """True when counted over the partition's visible pairs; False: every pair of blocks."""


def _ladder():
    from ._build import _LADDER, _chunking

    return _LADDER, _chunking


def block_sizes(group_counts, max_block: int) -> np.ndarray:
    """Sizes of the partition's blocks, in block order, from the patches per group (in
    ``np.unique`` order of the groups): each group of n cut into ⌈n / max_block⌉ leaves by
    the same recursive halving as :func:`~lumijax.radiosity.partition`."""
    out: list[int] = []

    def cut(n: int, k: int) -> None:
        if k <= 1:
            out.append(n)
            return
        k1 = k // 2
        c = int(round(n * k1 / k))
        cut(c, k1)
        cut(n - c, k - k1)

    for n in group_counts:
        cut(int(n), -(-int(n) // max_block))
    return np.asarray(out, np.int64)


def _bytes(keys: dict, itemsize: int, max_bytes_per_step: int) -> tuple[int, int]:
    """(stored, largest bucket) bytes of dense buckets ``{(sa, sb, diagonal): pairs}``."""
    _, chunking = _ladder()
    stored = largest = 0
    for (sa, sb, _), n in keys.items():
        per_pair = sa * sb * itemsize
        _, total = chunking(int(n), per_pair, max_bytes_per_step)
        b = total * (per_pair + 4 * (sa + sb))  # blocks, then int32 receiver/source indices
        stored += b
        largest = max(largest, b)
    return stored, largest


def _pad_index(sizes: np.ndarray) -> np.ndarray:
    ladder, _ = _ladder()
    return np.searchsorted(ladder, sizes)


def estimate_before_partition(group_counts, *, max_block: int = 1024, itemsize: int = 4,
                              max_bytes_per_step: int = 1 << 26) -> OperatorEstimate:
    """The bound with every pair of blocks visible, from the patch count of each group.

    Counting ``a ≤ b`` pairs by padded shape takes O(blocks × ladder rungs), so a 10⁷-patch
    mesh is bounded in milliseconds without a pair list.
    """
    ladder, _ = _ladder()
    sizes = block_sizes(group_counts, max_block)
    idx = _pad_index(sizes)
    rungs = len(ladder)
    seen = np.zeros(rungs, np.int64)  # blocks so far by padded size: pairs (a < b)
    counts = np.zeros((rungs, rungs), np.int64)
    for j in idx:
        counts[:, j] += seen
        seen[j] += 1
    keys = {(int(ladder[a]), int(ladder[b]), False): int(counts[a, b])
            for a, b in zip(*np.nonzero(counts), strict=True)}
    for r, n in zip(*np.unique(idx, return_counts=True), strict=True):
        keys[(int(ladder[r]), int(ladder[r]), True)] = int(n)
    stored, largest = _bytes(keys, itemsize, max_bytes_per_step)
    nb = len(sizes)
    return OperatorEstimate(int(sizes.sum()), nb, nb * (nb + 1) // 2, stored, stored + largest,
                            visible_only=False)


def estimate_from_partition(part, *, itemsize: int = 4,
                            max_bytes_per_step: int = 1 << 26) -> OperatorEstimate:
    """The bound over the visible block pairs of a :class:`~lumijax.radiosity.Partition`."""
    ladder, _ = _ladder()
    padded = ladder[_pad_index(part.sizes)]
    a, b = part.pairs[:, 0], part.pairs[:, 1]
    code = np.stack([padded[a], padded[b], a == b], axis=1)
    uniq, n = np.unique(code, axis=0, return_counts=True)
    keys = {(int(u[0]), int(u[1]), bool(u[2])): int(c) for u, c in zip(uniq, n, strict=True)}
    stored, largest = _bytes(keys, itemsize, max_bytes_per_step)
    return OperatorEstimate(int(part.sizes.sum()), part.n_blocks, len(part.pairs), stored,
                            stored + largest, visible_only=True)


def available_memory_bytes() -> int:
    """Memory this process may still take (bytes): ``MemAvailable`` (Linux), else physical
    memory (``sysconf``). ``LUMIJAX_MEMORY_BYTES`` overrides it (a smaller share of a shared
    machine, or a test)."""
    env = os.environ.get("LUMIJAX_MEMORY_BYTES")
    if env:
        return int(float(env))
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 1 << 62  # unknown: do not refuse


def _gib(n: float) -> str:
    if n >= 2**40:
        return f"{n / 2**40:.3g} TiB"
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n / 2**10:.1f} KiB"


def _fitting_count(estimate: OperatorEstimate, group_counts, available: int, max_block: int,
                   itemsize: int) -> int:
    """Largest patch count, in 10 % steps down from the square-law guess, whose bound (this
    estimate scaled by the all-pairs bound of proportionally fewer patches per group) fits."""
    counts = np.asarray(group_counts, np.float64)
    ref = estimate_before_partition(counts.astype(np.int64), max_block=max_block,
                                    itemsize=itemsize).peak_bytes
    n = estimate.patches * math.sqrt(available / estimate.peak_bytes)
    while n >= 10:
        scaled = np.maximum(1, np.round(counts * n / counts.sum())).astype(np.int64)
        pre = estimate_before_partition(scaled, max_block=max_block, itemsize=itemsize)
        if estimate.peak_bytes * pre.peak_bytes / ref <= 0.9 * available:
            return int(n)
        n *= 0.9
    return int(n)


def check_operator_memory(estimate: OperatorEstimate, *, available: int | None = None,
                          triangles: int, two_levels: bool, file=None, group_counts=None,
                          max_block: int = 1024, itemsize: int = 4,
                          requested: int | None = None, patch_size: float | None = None,
                          remesh=None) -> None:
    """Raise a :class:`SolveError` before the build when ``estimate.peak_bytes`` exceeds the
    available memory, naming the ``[solver]`` settings that would fit.

    The bound grows about as the square of the patches (elements with two levels): the count
    suggested is the largest, from ``patches × √(available / peak)`` down, whose bound fits
    with 10 % to spare (``group_counts``: patches per group, to redo the block sizes; without
    them the square law alone). A patch is never larger than its triangle, so below the
    triangle count only a simpler mesh fits. ``requested``: the ``target_patches`` (or
    ``operator_patches``) that gave ``estimate.patches``, so that the setting named is scaled
    by what meshing made of it; ``patch_size``: the edge (m) the patches were cut at.
    ``remesh(requested) -> patches per group``: when given, the setting named is checked on
    the mesh it makes (meshing rounds a triangle's pieces up to ⌈L/s⌉², so a count is not
    always what a target asks), stepping down 10 % until its bound fits.
    """
    available = available_memory_bytes() if available is None else int(available)
    if estimate.peak_bytes <= available:
        return
    if group_counts is None:
        fit = int(0.9 * estimate.patches * math.sqrt(available / estimate.peak_bytes))
    else:
        fit = _fitting_count(estimate, group_counts, available, max_block, itemsize)
    what = "elements" if two_levels else "patches"
    ask = fit if requested is None else max(10, int(fit * requested / estimate.patches))
    if remesh is not None and requested is not None and group_counts is not None:
        ref = estimate_before_partition(group_counts, max_block=max_block,
                                        itemsize=itemsize).peak_bytes
        while ask >= 10:
            counts = remesh(ask)
            pre = estimate_before_partition(counts, max_block=max_block, itemsize=itemsize)
            if estimate.peak_bytes * pre.peak_bytes / ref <= 0.9 * available:
                fit = int(np.sum(counts))
                break
            ask = int(ask * 0.9)
        else:
            fit = 0  # not even 10 fits: only less geometry (or more memory) helps
    edge = ("" if patch_size is None else
            f" (patch_size ≥ {patch_size * math.sqrt(estimate.patches / max(fit, 1)):.3g} m)")
    counted = ("its visible block pairs" if estimate.visible_only
               else "every pair of its blocks")
    head = (f"the transport operator of {estimate.patches:,} {what} would need up to "
            f"{_gib(estimate.peak_bytes)} ({counted} dense, {estimate.blocks:,} blocks), and "
            f"{_gib(available)} of memory is available")
    if fit < triangles:
        fix = (f"; even one patch per triangle is {triangles:,} {what}, so no patch setting "
               f"fits: simplify the geometry to fewer than {max(fit, 1):,} triangles (decimate "
               "the mesh), or run where more memory is available")
    elif two_levels:
        fix = (f": set [solver] operator_patches = {ask:,} (or fewer; about {fit:,} elements) "
               "for coarser elements")
    else:
        fix = (f": set [solver] operator_patches = {ask:,} (two levels: the operator on about "
               f"{fit:,} coarser elements, direct light still on the fine patches), or "
               f"target_patches = {ask:,}{edge} for one coarser level")
    raise SolveError(head + fix, file=file, key="solver")


def bound_operator_memory(patches, *, max_block: int = 1024, itemsize: int = 4, caster=None,
                          triangles: int, two_levels: bool = False, file=None,
                          available: int | None = None, requested: int | None = None,
                          patch_size: float | None = None, remesh=None):
    """Check that the operator of ``patches`` fits before anything is built.

    The all-pairs bound first (milliseconds); only when it does not fit, and is not hopeless
    (:data:`HOPELESS_RATIO`), the partition (its occlusion rays) and the visible-pairs bound.
    Returns ``(estimate, partition)``: the partition when one was made (the build can reuse
    it), else ``None``. Raises :class:`SolveError` naming the settings that would fit
    (``requested``, ``patch_size``, ``remesh``: see :func:`check_operator_memory`).
    """
    available = available_memory_bytes() if available is None else int(available)
    _, counts = np.unique(patches.group, return_counts=True)
    est = estimate_before_partition(counts, max_block=max_block, itemsize=itemsize)
    if est.peak_bytes <= available:
        return est, None
    part = None
    if est.peak_bytes <= HOPELESS_RATIO * available:
        from ._partition import partition

        part = partition(patches, max_block=max_block, occluders=caster)
        est = estimate_from_partition(part, itemsize=itemsize)
    check_operator_memory(est, available=available, triangles=triangles, two_levels=two_levels,
                          file=file, group_counts=counts, max_block=max_block, itemsize=itemsize,
                          requested=requested, patch_size=patch_size, remesh=remesh)
    return est, part


#: Host bytes per patch of a mesh (vertices, centroid, normal, area, material, group, source).
PATCH_BYTES = 152


def patch_count(vertices, size: float, group=None):
    """Patches :func:`~lumijax.radiosity.mesh_patches` makes at edge ``size`` (m), counted in
    floats without meshing: ⌈longest edge / size⌉² per triangle (slivers, bisected instead,
    come within ⅓ of it). Per group (``np.unique`` order) when ``group`` is given."""
    v = np.asarray(vertices, np.float64)
    e = np.linalg.norm(np.roll(v, -1, axis=1) - v, axis=-1).max(axis=1)
    with np.errstate(over="ignore"):
        n = np.ceil(np.maximum(e / size, 1.0)) ** 2
    if group is None:
        return float(n.sum())
    _, inv = np.unique(group, return_inverse=True)
    return np.bincount(inv, weights=n)


def check_before_meshing(vertices, group, size: float, *, element_size: float | None = None,
                         itemsize: int = 4, max_block: int = 1024, file=None,
                         available: int | None = None, dense: bool = True) -> None:
    """Refuse, before any patch exists, a mesh whose patches alone would not fit, or whose
    operator is hopeless (:data:`HOPELESS_RATIO`) even before its blocks are counted: a
    ``patch_size`` of 1 nm on a room would otherwise be meshed until memory runs out.

    ``element_size``: the two-level element edge (m) when the operator is on elements.
    ``dense=False``: the operator is ray-sampled (linear in patches, :func:`bound_sampled_memory`
    bounds it after meshing), so only the mesh itself is checked here."""
    available = available_memory_bytes() if available is None else int(available)
    n_tri = len(vertices)
    fine = patch_count(vertices, size)
    if not PATCH_BYTES * fine <= available:
        n_fit = 0.5 * available / PATCH_BYTES
        if element_size is None and dense:  # one level: the operator, ~itemsize × P², too
            n_fit = min(n_fit, 0.5 * math.sqrt(available / itemsize))
        fit = math.sqrt(fine / n_fit) * size
        raise SolveError(
            f"patches of {size:.3g} m make about {fine:.3g} patches, {_gib(PATCH_BYTES * fine)} "
            f"for the mesh alone, and {_gib(available)} of memory is available: set [solver] "
            f"patch_size ≥ {fit:.3g} m (or a smaller target_patches)", file=file, key="solver")
    coarse = fine if element_size is None else patch_count(vertices, element_size)
    quick = itemsize * coarse * coarse / 2  # every pair, no padding: below the real bound
    if dense and quick > HOPELESS_RATIO * available:
        counts = patch_count(vertices, size if element_size is None else element_size, group)
        est = OperatorEstimate(int(coarse), int(-(-coarse // max_block)),
                               int((coarse / max_block) ** 2 / 2), int(quick), int(quick),
                               visible_only=False)
        check_operator_memory(est, available=available, triangles=n_tri,
                              two_levels=element_size is not None, file=file,
                              group_counts=None if counts.sum() > 1e7 else counts.astype(np.int64),
                              max_block=max_block, itemsize=itemsize,
                              patch_size=None if element_size is not None else size)


def bound_sampled_memory(n_patches: int, rays_per_patch: int, *, itemsize: int = 4,
                         available: int | None = None, file=None,
                         columns: int | None = None,
                         links_per_ray: float = 1.0) -> OperatorEstimate:
    """Bound the ray-sampled operator (``_sampled.py``) before its first ray, or refuse it.

    Every ray a distinct link is the most it can store: :func:`~._links.link_bytes` (8 bytes
    for a float32 operator) × rays × patches, held once (JAX adopts the host arrays the links
    are written into: ``_jit_cache.host_empty``). ``links_per_ray`` < 1: a share measured on
    the same scene with no more rays a patch (rays into the sky store nothing, and more rays
    merge more of their hits into one link, so the share only falls as rays are added).
    ``columns`` (networks × wavelengths): the solve that follows counts too,
    :func:`solve_memory_bytes` of its smallest batch beside the operator. Raises
    :class:`SolveError` naming the ``rays_per_patch`` that would fit."""
    available = available_memory_bytes() if available is None else int(available)
    stored = int(link_bytes(itemsize) * min(float(links_per_ray), 1.0) * int(n_patches)
                 * int(rays_per_patch))
    peak = stored
    if columns is not None:
        peak += solve_memory_bytes(n_patches, columns, 1, itemsize)
    est = OperatorEstimate(int(n_patches), 1, 0, stored, peak, visible_only=False)
    if est.peak_bytes > available:
        fit = sampled_rays_that_fit(n_patches, itemsize=itemsize, available=available,
                                    columns=columns, links_per_ray=links_per_ray, least=True)
        fix = (f"set [solver] rays_per_patch ≤ {fit:,}" if fit >= 16 else
               "set a larger [solver] patch_size (fewer patches)")
        solve = "" if columns is None else f" with the solve of {int(columns):,} columns"
        raise SolveError(
            f"the sampled transport of {n_patches:,} patches × {rays_per_patch:,} rays{solve} "
            f"would need up to {_gib(est.peak_bytes)}, and {_gib(available)} of memory is "
            f"available: {fix}", file=file, key="solver.rays_per_patch")
    return est


def sampled_rays_that_fit(n_patches: int, *, itemsize: int = 4, available: int | None = None,
                          columns: int | None = None, links_per_ray: float = 1.0,
                          least: bool = False) -> int:
    """The most rays a patch whose sampled operator fits beside the solve that follows: its
    bound (every ray a link, or ``links_per_ray`` of them), the solve's results (``columns``)
    and the :data:`SOLVE_SHARE` its batches of columns take (:func:`solve_column_batch`),
    within 90 % of ``available`` (default: this machine's). Reserving only the solve's least
    memory (one column a batch) let the links take what its batches then took as well: the
    LoD-3 courtyard at ≈ 1,850 rays held 17.8 GiB of a 16 GiB budget (session 34). ``least``:
    that least memory all the same — what :func:`bound_sampled_memory` accepts at all."""
    available = available_memory_bytes() if available is None else int(available)
    per_ray = link_bytes(itemsize) * min(float(links_per_ray), 1.0) * max(int(n_patches), 1)
    solve = 0.0 if columns is None else (solve_memory_bytes(n_patches, columns, 1, itemsize)
                                         if least else SOLVE_SHARE * available
                                         + solve_memory_bytes(n_patches, columns, 0, itemsize))
    return max(0, int((0.9 * available - solve) / per_ray))


#: Patch-length vectors of the solve's precision alive per column while it runs (BiCGStab's and
#: the refinement's state, the float64 true residual, the products' temporaries). Measured:
#: the solve + gather stage of the LoD-0 courtyard rose 2.64 GiB for 144 float32 columns of
#: 212,992 padded patches, 23.1 vectors a column (benchmarks/courtyard.py, session 9).
SOLVE_VECTORS = 24

#: Share of the available memory one batch of solve columns may take: the rest is for the
#: results gathered so far (float64, ``(patches, columns)``) and what the caller holds.
SOLVE_SHARE = 0.5


def solve_column_bytes(n_patches: int, itemsize: int) -> int:
    """Bytes one column of the radiosity solve takes while it runs (:data:`SOLVE_VECTORS`
    vectors of the padded patch count, ``radiosity.patch_bucket``)."""
    from ._solve import patch_bucket

    return SOLVE_VECTORS * int(itemsize) * patch_bucket(int(n_patches))


def solve_memory_bytes(n_patches: int, columns: int, batch: int, itemsize: int) -> int:
    """Bytes the solve of ``columns`` columns in batches of ``batch`` needs at its peak: one
    batch running, and every column's result on the host (float64, as
    ``lighting.solve_spectral`` keeps it, and the solve's own copy in its precision)."""
    return (min(int(batch), int(columns)) * solve_column_bytes(n_patches, itemsize)
            + int(columns) * int(n_patches) * (8 + int(itemsize)))


def solve_column_batch(n_patches: int, columns: int, itemsize: int, *,
                       available: int | None = None) -> int:
    """How many columns of the radiosity solve to run at once: as many as fit in
    :data:`SOLVE_SHARE` of the available memory (``LUMIJAX_MEMORY_BYTES`` overrides it), at
    least one. Raises :class:`SolveError` when one column and the results do not fit at all
    (a refusal, not an out-of-memory kill half way through)."""
    available = available_memory_bytes() if available is None else int(available)
    columns = max(int(columns), 1)
    per = solve_column_bytes(n_patches, itemsize)
    need = solve_memory_bytes(n_patches, columns, 1, itemsize)
    if need > available:
        raise SolveError(
            f"the radiosity solve of {columns:,} columns (networks × wavelengths) on "
            f"{int(n_patches):,} patches needs at least {_gib(need)} (one column at a time: "
            f"{_gib(per)}, and the results), and {_gib(available)} of memory is available: "
            "set a larger [solver] patch_size (fewer patches), fewer "
            "[solver] spectral_samples, or run where more memory is available", key="solver")
    return int(min(columns, max(1, int(SOLVE_SHARE * available) // per)))
