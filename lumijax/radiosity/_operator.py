"""The block-sparse transport operator F and the lineax operator K = ρF built on it.

Storage (see ``docs/radiosity.md``): form factors are reciprocal, ``A_i F_ij = A_j F_ji``, so we
store the **symmetric** matrix ``G = diag(A) F`` (m²) and only its upper block pairs ``a ≤ b``.
Then ``F x = G x / A`` and ``Fᵀ x = G (x / A)``, and one stored block serves light both ways:
half the memory and half the memory traffic of storing F.

Blocks of similar padded size are stacked into *buckets* ``(n, sa, sb)``; a product is a
``lax.scan`` over chunks of pairs, each a batched dense matmul (BLAS) of gathered right-hand sides
followed by a scatter-add into the receiving patches. Padding rows/columns point at a dummy
patch ``P`` whose value is zero.
"""

from __future__ import annotations

import abc
import json
import weakref
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
from jaxtyping import Array, Float, Int, UInt

__all__ = [
    "AbstractBucket",
    "DenseBucket",
    "Bucket",
    "LowRankBucket",
    "SampledBucket",
    "Info",
    "TransportOperator",
    "ReflectionOperator",
    "densified",
    "dense_matrix",
    "DENSE_PATCHES",
]


class AbstractBucket(eqx.Module):
    """Stacked blocks of ``G = A F`` (m²) of one padded shape, and how to apply them.

    ``recv[k]``/``src[k]`` are the receiving and sending patches of pair k (padding: the zero
    patch P), ``recv_block``/``src_block`` their blocks (−1 where a side spans several), and
    ``chunk`` the pairs one step of the product's ``lax.scan`` takes. ``kind`` names the
    storage in the operator file (radiosity/_store.py).
    """

    # Every final bucket has the fields recv, src, recv_block, src_block, chunk and diagonal;
    # they are not declared here, since an annotation in an equinox Module's body would make it
    # a (leading) field of every subclass and reorder their constructors.
    kind: eqx.AbstractClassVar[str]
    #: Whether the bucket's part of G is symmetric (blocks serve both directions); a sampled
    #: bucket is not (ray estimates of A_i F_ij and A_j F_ji differ), so ``apply`` takes
    #: ``transpose`` and ``todense`` adds no mirror image.
    symmetric: ClassVar[bool] = True

    @abc.abstractmethod
    def apply(self, xext: Array, out: Array, only_block=None, block_of=None,
              transpose: bool = False) -> Array:
        """``out += G_bucket @ xext`` (both directions for off-diagonal pairs).

        ``xext``: the vector with the zero padding patch appended. With ``only_block``, chunks
        with no pair touching that block are skipped (``lax.cond``): the product with a vector
        zero outside the block, at the cost of its pairs only; ``block_of`` is each patch's
        block, −1 for the padding patch. ``transpose``: ``Gᵀ`` instead (the same for a
        symmetric bucket).
        """

    @abc.abstractmethod
    def todense(self) -> np.ndarray:
        """The stacked blocks ``G[recv[k]][:, src[k]]`` as float64, shape ``(n, sa, sb)``."""

    @property
    @abc.abstractmethod
    def nbytes(self) -> int:
        """Bytes of the stored values and their index arrays (padding included)."""

    @property
    @abc.abstractmethod
    def dtype(self) -> np.dtype:
        """The storage precision of the values (products compute in the vector's)."""


class DenseBucket(AbstractBucket):
    """Stacked dense blocks of ``G = A F`` with one padded shape.

    ``blocks[k]`` holds ``G[recv[k]][:, src[k]]``; ``diagonal`` buckets hold full symmetric
    diagonal blocks (used once), the others upper off-diagonal pairs (used in both directions).
    """

    blocks: Float[Array, "n sa sb"]
    recv: Int[Array, "n sa"]
    src: Int[Array, "n sb"]
    recv_block: Int[Array, " n"]
    src_block: Int[Array, " n"]
    diagonal: bool = eqx.field(static=True)
    chunk: int = eqx.field(static=True)
    kind: ClassVar[str] = "dense"

    def apply(self, xext, out, only_block=None, block_of=None, transpose=False):
        n, sa, sb = self.blocks.shape
        steps = n // self.chunk
        d = self.blocks.reshape(steps, self.chunk, sa, sb)
        r = self.recv.reshape(steps, self.chunk, sa)
        s = self.src.reshape(steps, self.chunk, sb)
        rb = self.recv_block.reshape(steps, self.chunk)
        sbk = self.src_block.reshape(steps, self.chunk)

        def compute(acc, dk, rk, sk):
            dk = dk.astype(xext.dtype)  # float32 storage, computed in the solve's precision
            acc = acc.at[rk].add(jnp.einsum("nij,njc->nic", dk, xext[sk]))
            if not self.diagonal:
                acc = acc.at[sk].add(jnp.einsum("nij,nic->njc", dk, xext[rk]))
            return acc

        def body(acc, xs):
            dk, rk, sk, rbk, sbkk = xs
            if only_block is None:
                return compute(acc, dk, rk, sk), None
            # −1: a side spanning several blocks (the one block of :func:`densified`)
            touches = jnp.any((rbk == only_block) | (sbkk == only_block) | (rbk < 0) | (sbkk < 0))
            acc = jax.lax.cond(touches, compute, lambda acc, *_: acc, acc, dk, rk, sk)
            return acc, None

        out, _ = jax.lax.scan(body, out, (d, r, s, rb, sbk))
        return out

    def todense(self):
        return np.asarray(self.blocks, np.float64)

    @property
    def nbytes(self) -> int:
        return int(self.blocks.nbytes + self.recv.nbytes + self.src.nbytes)

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(self.blocks.dtype)


#: The dense bucket under its former name.
Bucket = DenseBucket


class LowRankBucket(AbstractBucket):
    """Stacked low-rank blocks ``G[recv[k]][:, src[k]] ≈ u[k] @ v[k].T`` of one padded shape.

    Well-separated pairs of clusters of blocks (used in both directions: the transposed block
    is ``v[k] @ u[k].T``, so the stored G stays exactly symmetric). ``recv_block`` and
    ``src_block`` name the block when a side is one block, and are −1 when it spans several.
    Padding rows and rank columns are zero.
    """

    u: Float[Array, "n sa r"]
    v: Float[Array, "n sb r"]
    recv: Int[Array, "n sa"]
    src: Int[Array, "n sb"]
    recv_block: Int[Array, " n"]
    src_block: Int[Array, " n"]
    chunk: int = eqx.field(static=True)
    # never a diagonal block (a block is not well separated from itself)
    diagonal: ClassVar[bool] = False  # type: ignore[misc]
    kind: ClassVar[str] = "lowrank"

    def apply(self, xext, out, only_block=None, block_of=None, transpose=False):
        n, sa, r = self.u.shape
        sb = self.v.shape[1]
        steps = n // self.chunk
        u = self.u.reshape(steps, self.chunk, sa, r)
        v = self.v.reshape(steps, self.chunk, sb, r)
        rr = self.recv.reshape(steps, self.chunk, sa)
        ss = self.src.reshape(steps, self.chunk, sb)

        def compute(acc, uk, vk, rk, sk):
            uk, vk = uk.astype(xext.dtype), vk.astype(xext.dtype)
            t = jnp.einsum("njr,njc->nrc", vk, xext[sk])
            acc = acc.at[rk].add(jnp.einsum("nir,nrc->nic", uk, t))
            t = jnp.einsum("nir,nic->nrc", uk, xext[rk])
            return acc.at[sk].add(jnp.einsum("njr,nrc->njc", vk, t))

        def body(acc, xs):
            uk, vk, rk, sk = xs
            if only_block is None:
                return compute(acc, uk, vk, rk, sk), None
            touches = jnp.any(block_of[rk] == only_block) | jnp.any(block_of[sk] == only_block)
            acc = jax.lax.cond(touches, compute, lambda acc, *_: acc, acc, uk, vk, rk, sk)
            return acc, None

        out, _ = jax.lax.scan(body, out, (u, v, rr, ss))
        return out

    def todense(self):
        u, v = np.asarray(self.u, np.float64), np.asarray(self.v, np.float64)
        return np.einsum("nir,njr->nij", u, v)

    @property
    def nbytes(self) -> int:
        return int(self.u.nbytes + self.v.nbytes + self.recv.nbytes + self.src.nbytes)

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(self.u.dtype)


class Info(dict):
    """Build statistics and settings: a dict that hashes by content (a static pytree field)."""

    def __hash__(self):  # type: ignore[override]
        return hash(json.dumps(self, sort_keys=True, default=str))


_NARROW_ROWS, _WIDE_ROWS = 24, 64
"""A sampled product of more than ``_NARROW_ROWS`` and fewer than ``_WIDE_ROWS`` columns runs
on ``_WIDE_ROWS``, zero-padded, on the CPU: XLA:CPU gathers and scatter-adds rows of 60 or
more float32 at 17–22 ms a column, narrower ones at 41–46 ms (a 1.9·10⁵-patch courtyard,
2.4·10⁷ links: 48 columns 2.19 s, padded to 64 1.09 s; 32 columns 1.93 → 1.17 s; 16 columns
0.65 s, better left alone). docs/radiosity.md, "Sampled transport"."""


def _on_cpu() -> bool:
    return jax.default_backend() == "cpu"


class SampledBucket(AbstractBucket):
    """Ray-sampled links of ``G = A F``, one entry per (receiver, sender) pair a ray joined.

    ``weight[k] · scale[i] = A_i · hits(i → j) / N`` (m²) for link k of chunk c, ``i = base[c] +
    recv[k]``, ``j = src[k]``, N the rays cast from patch i (``_sampled.py``); ``scale`` holds
    one value a patch and one for the padding patch. Sorted by receiver, in whole chunks
    padded with zero weights (the layout, eight bytes a link, and its rounding:
    ``_links.py``). Not symmetric: the estimates of ``A_i F_ij`` and ``A_j F_ji`` come from
    different rays, so ``Gᵀ`` swaps the roles of receiver and sender. Build one from links
    with :meth:`from_links`.
    """

    weight: Float[Array, " n"]
    recv: UInt[Array, " n"]
    src: Int[Array, " n"]
    base: Int[Array, " chunks"]
    scale: Float[Array, " patches_and_padding"]
    chunk: int = eqx.field(static=True)
    diagonal: ClassVar[bool] = False  # type: ignore[misc]
    symmetric: ClassVar[bool] = False
    kind: ClassVar[str] = "sampled"

    @classmethod
    def from_links(cls, recv, src, weight, n_patches: int, dtype=np.float32) -> SampledBucket:
        """Links ``(recv, src, weight)`` (any order; weights in m², the padding patch is
        ``n_patches``) stored as the build stores them, for a ``dtype`` operator."""
        from .._jit_cache import to_device
        from ._links import pack_links

        *arrays, chunk = pack_links(recv, src, weight, n_patches, dtype)
        return cls(*(to_device(a) for a in arrays), chunk=chunk)

    def apply(self, xext, out, only_block=None, block_of=None, transpose=False):
        # only_block is a skip of work, not a different product (x is zero outside the
        # block): links are not grouped by block, so every chunk is computed
        steps = self.weight.shape[0] // self.chunk
        w = self.weight.reshape(steps, self.chunk)
        r = self.recv.reshape(steps, self.chunk)
        s = self.src.reshape(steps, self.chunk)
        # G = diag(scale) W: a patch's scale once, not once a link (W x, then scaled; Gᵀ x
        # = Wᵀ (scale x))
        scale = jnp.pad(self.scale.astype(xext.dtype),  # x may be padded past the patches
                        (0, xext.shape[0] - self.scale.shape[0]), constant_values=1)
        scale = scale.reshape((-1,) + (1,) * (xext.ndim - 1))
        if transpose:
            xext = xext * scale

        width = xext.shape[1] if xext.ndim == 2 else 0
        pad = _WIDE_ROWS - width if _NARROW_ROWS < width < _WIDE_ROWS and _on_cpu() else 0
        if pad:  # zero columns: every real column's arithmetic, and so its bits, unchanged
            xext = jnp.pad(xext, ((0, 0), (0, pad)))

        def body(acc, xs):
            wk, rk, sk, base = xs
            rk = base + rk.astype(jnp.int32)
            into, of = (sk, rk) if transpose else (rk, sk)
            contrib = wk.astype(xext.dtype).reshape((-1,) + (1,) * (xext.ndim - 1)) * xext[of]
            return acc.at[into].add(contrib, indices_are_sorted=not transpose), None

        acc, _ = jax.lax.scan(body, jnp.zeros((out.shape[0],) + xext.shape[1:], out.dtype),
                              (w, r, s, self.base))
        acc = acc[:, :width] if pad else acc
        return out + (acc if transpose else scale * acc)

    def links(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(recv, src, weight)`` of every stored link on the host: int64 patches (the padding
        ones included), float64 weights (m²)."""
        recv = np.repeat(np.asarray(self.base, np.int64), self.chunk) + np.asarray(self.recv)
        return (recv, np.asarray(self.src, np.int64),
                np.asarray(self.weight, np.float64) * np.asarray(self.scale, np.float64)[recv])

    def todense(self):
        return self.links()[2].reshape(-1, 1, 1)

    @property
    def nbytes(self) -> int:
        return int(sum(a.nbytes for a in (self.weight, self.recv, self.src, self.base,
                                          self.scale)))

    @property
    def dtype(self) -> np.dtype:
        """The precision of its products: float32 for float16 weights (a float32 study's)."""
        return np.result_type(np.dtype(self.weight.dtype), np.float32)


@eqx.filter_jit
def _gmul(op: TransportOperator, x, only_block, transpose=False):
    shape = x.shape
    x2 = x.reshape(shape[0], -1)
    xext = jnp.concatenate([x2, jnp.zeros((1, x2.shape[1]), x2.dtype)])
    out = jnp.zeros_like(xext)
    block_of = jnp.concatenate([op.block_of, jnp.full((1,), -1, op.block_of.dtype)])
    for bk in op.buckets:
        out = bk.apply(xext, out, only_block, block_of, transpose)
    return out[:-1].reshape(shape)


class TransportOperator(eqx.Module):
    """Form factors ``F`` (dimensionless, rows: receivers) of a patch mesh, block-sparse.

    ``F_ij`` is the fraction of the flux leaving patch i (diffusely, from its front) that arrives
    on the front of patch j. Build with :func:`~lumijax.radiosity.build_operator`.
    """

    buckets: tuple[AbstractBucket, ...]
    area: Float[Array, " patches"]
    block_of: Int[Array, " patches"]
    n_patches: int = eqx.field(static=True)
    n_blocks: int = eqx.field(static=True)
    info: Info = eqx.field(static=True)

    def gmul(self, x: Float[Array, "patches ..."], only_block=None,
             transpose: bool = False) -> Float[Array, "patches ..."]:
        """``G x`` with ``G = diag(A) F`` (m² × unit of x); symmetric unless sampled, and
        ``transpose`` gives ``Gᵀ x``."""
        return _gmul(self, jnp.asarray(x), only_block, bool(transpose))

    def matmul_from_block(self, x, block) -> Array:
        """``F x`` for x zero outside ``block`` (a traced int is fine): Southwell's shot."""
        return self.gmul(x, only_block=block) / self._area(x)

    def _area(self, x):
        return self.area.astype(x.dtype).reshape((-1,) + (1,) * (x.ndim - 1))

    def matmul(self, x: Float[Array, "patches ..."]) -> Float[Array, "patches ..."]:
        """``F x``: for radiosities x (lm/m²) the irradiance each patch receives from them (lx)."""
        return self.gmul(x) / self._area(x)

    def rmatmul(self, x: Float[Array, "patches ..."]) -> Float[Array, "patches ..."]:
        """``Fᵀ x``."""
        return self.gmul(x / self._area(x), transpose=True)

    def row_sums(self) -> Float[Array, " patches"]:
        """``Σ_j F_ij``: 1 in a closed enclosure; ``1 − row sum`` is the fraction escaping."""
        return self.matmul(jnp.ones((self.n_patches, 1), self.area.dtype))[:, 0]

    def todense(self) -> np.ndarray:
        """Dense ``F`` as a float64 numpy array (small meshes: tests and debugging)."""
        p = self.n_patches
        g = np.zeros((p + 1, p + 1))
        for bk in self.buckets:
            if isinstance(bk, SampledBucket):  # one link per entry: no mirror image
                r, s, w = bk.links()
                np.add.at(g, (r, s), w)
                continue
            d = bk.todense()
            r, s = np.asarray(bk.recv), np.asarray(bk.src)
            for k in range(len(d)):
                g[np.ix_(r[k], s[k])] += d[k]
                if not bk.diagonal:
                    g[np.ix_(s[k], r[k])] += d[k].T
        return g[:p, :p] / np.asarray(self.area, np.float64)[:, None]

    @property
    def nbytes(self) -> int:
        """Bytes of stored blocks and their index arrays (padding included)."""
        return int(sum(bk.nbytes for bk in self.buckets))

    @property
    def dense_nbytes(self) -> int:
        """Bytes in dense buckets (the near field)."""
        return int(sum(bk.nbytes for bk in self.buckets if bk.kind == "dense"))

    @property
    def lowrank_nbytes(self) -> int:
        """Bytes in low-rank buckets (the compressed far field)."""
        return int(sum(bk.nbytes for bk in self.buckets if bk.kind == "lowrank"))

    @property
    def sampled_nbytes(self) -> int:
        """Bytes in ray-sampled buckets (``[solver] transport = "sampled"``)."""
        return int(sum(bk.nbytes for bk in self.buckets if bk.kind == "sampled"))


#: The most patches (padded) whose operator :func:`densified` makes one dense block: 4,096²
#: values are 64 MiB in float32 (a float64 study's, 128 MiB), held while the operator lives.
DENSE_PATCHES = 4096


def densified(op: TransportOperator, n_patches: int | None = None) -> TransportOperator | None:
    """``op`` as one dense block of ``G`` over ``n_patches`` (≥ ``op.n_patches``; the rest
    exchange nothing), or None where that is not for it: more than :data:`DENSE_PATCHES`
    patches, a sampled (non-symmetric) bucket, or inside a JAX trace (:func:`_tracing`).

    A small study's solve compiles for far longer than it runs, and its program holds one
    ``lax.scan`` per bucket in every product; one block is one BLAS product, whose program
    is the same for every study with the same padded patch count (so a new study of that
    size reuses it from the compilation cache) and whose speed does not hang on LLVM's
    optimisation passes. Sums run in another order: the answer moves by rounding only.
    """
    n = op.n_patches if n_patches is None else int(n_patches)
    if not _densifies(op, n):
        return None
    kept = _DENSIFIED.get((id(op), n))
    if kept is not None and kept[0]() is op:  # the solve's, asked again by the patch product
        return kept[1]
    one = _densified(op, n)
    _DENSIFIED[(id(op), n)] = (weakref.ref(op), one)
    weakref.finalize(op, _DENSIFIED.pop, (id(op), n), None)  # kept as long as op lives
    return one


def dense_matrix(op: TransportOperator, n_patches: int | None = None) -> np.ndarray | None:
    """``G = diag(A) F`` (m²) of ``op``'s patches as one ``(P, P)`` host array in the blocks'
    dtype, or None where :func:`densified` would refuse. ``n_patches`` is the padded count a
    later :func:`densified` of the same operator would ask for: both then share one host
    array (the solve's direct path, ``radiosity._lu``, and the patch product read it
    here; a fallback to the compiled solve makes its block from it). Kept while ``op``
    lives; read-only."""
    n = op.n_patches if n_patches is None else int(n_patches)
    if not _densifies(op, n):
        return None
    p = op.n_patches
    made = _DENSIFIED.get((id(op), n))
    if made is not None and made[0]() is op:  # its block, a view of it (a copy off the CPU)
        return np.asarray(made[1].buckets[0].blocks)[0, :p, :p]
    return _host_g(op, n)[:p, :p]


def _densifies(op: TransportOperator, n: int) -> bool:
    return not (n > DENSE_PATCHES or n < op.n_patches
                or any(not bk.symmetric for bk in op.buckets) or _tracing())


def _tracing() -> bool:
    """Whether a JAX trace is being built here (a host array brought in becomes a tracer).
    A block made inside one would enter the program as a literal constant of up to 64 MiB,
    so a traced solve (``jit``, ``grad``) keeps the buckets."""
    return isinstance(jnp.asarray(np.zeros((), np.float32)), jax.core.Tracer)


#: ``(id(op), n)`` → (a weak reference to op, its :func:`densified`).
_DENSIFIED: dict[tuple[int, int], tuple[weakref.ref, TransportOperator]] = {}

#: ``(id(op), n)`` → (a weak reference to op, its ``G`` over ``n + 1`` patches, on the host).
_HOST_G: dict[tuple[int, int], tuple[weakref.ref, np.ndarray]] = {}


def _host_g(op: TransportOperator, n: int) -> np.ndarray:
    """``G`` over ``n + 1`` patches on the host (the last row and column: the padding patch
    the buckets point at), built once per operator and size for :func:`dense_matrix`."""
    kept = _HOST_G.get((id(op), n))
    if kept is not None and kept[0]() is op:
        return kept[1]
    g = _dense_g(op, n)
    g.flags.writeable = False
    _HOST_G[(id(op), n)] = (weakref.ref(op), g)
    weakref.finalize(op, _HOST_G.pop, (id(op), n), None)
    return g


def _dense_g(op: TransportOperator, n: int) -> np.ndarray:
    dtype = op.buckets[0].dtype if op.buckets else np.dtype(np.float32)
    g = np.zeros((n + 1, n + 1), dtype)  # the last row and column: the padding patch P
    for bk in op.buckets:
        r, s = _padded_to(np.asarray(bk.recv), op.n_patches, n), _padded_to(
            np.asarray(bk.src), op.n_patches, n)
        ranges = _ranges(r, n), _ranges(s, n)
        # on the host first: slicing a JAX array is an eager op (a kernel compiled)
        values = ((np.asarray(bk.blocks),) if isinstance(bk, DenseBucket)
                  else (np.asarray(bk.u), np.asarray(bk.v)))
        for k0 in range(0, len(r), 256):  # low-rank blocks formed a few at a time
            sl = slice(k0, k0 + 256)
            d = (values[0][sl] if len(values) == 1
                 else np.einsum("nir,njr->nij", values[0][sl], values[1][sl]))
            if ranges[0] is not None and ranges[1] is not None:
                # each side one run of patches (a partition's block): copies of whole slices,
                # a tenth of the indexed scatter's time (the demo's 3,490 patches: 25 ms)
                for k, dk in enumerate(d, start=k0):
                    (a, na), (b, nb) = ranges[0][k], ranges[1][k]
                    g[a:a + na, b:b + nb] = dk[:na, :nb]
                    if not bk.diagonal:
                        g[b:b + nb, a:a + na] = dk[:na, :nb].T
                continue
            # pairs cover disjoint entries (upper block pairs once), so indexing adds each
            # entry once; only the padding patch's row and column collide, and are dropped
            g[r[sl, :, None], s[sl, None, :]] += d
            if not bk.diagonal:
                g[s[sl, :, None], r[sl, None, :]] += np.swapaxes(d, 1, 2)
    return g


def _densified(op: TransportOperator, n: int) -> TransportOperator:
    kept = _HOST_G.get((id(op), n))  # the direct solve's, where it fell back to this one
    g = kept[1] if kept is not None and kept[0]() is op else _dense_g(op, n)
    ar = np.arange(n, dtype=np.int32)[None]
    spans = np.full(1, -1, np.int32)  # numpy, then a transfer: an eager jnp op compiles
    one = DenseBucket(*(jnp.asarray(x) for x in (g[None, :n, :n], ar, ar, spans, spans)),
                      diagonal=True, chunk=1)
    area = np.ones(n, np.asarray(op.area).dtype)
    area[: op.n_patches] = np.asarray(op.area)
    block_of = np.full(n, -1, np.asarray(op.block_of).dtype)
    block_of[: op.n_patches] = np.asarray(op.block_of)
    return TransportOperator((one,), jnp.asarray(area), jnp.asarray(block_of), n, op.n_blocks,
                             Info())


def _padded_to(index: np.ndarray, pad: int, n: int) -> np.ndarray:
    """Patch indices with the padding patch ``pad`` renumbered ``n``."""
    return np.where(index == pad, n, index)


def _ranges(index: np.ndarray, pad: int) -> list[tuple[int, int]] | None:
    """``(first, count)`` of each row's patches where every row is one run ``first,
    first + 1, …`` followed by padding ``pad``; else None."""
    count = (index != pad).sum(axis=1)
    step = np.arange(index.shape[1])
    run = np.where(step < count[:, None], index[:, :1] + step, pad)
    if not np.array_equal(index, run):
        return None
    return list(zip(index[:, 0].tolist(), count.tolist()))


# -- K = ρF as a lineax operator ------------------------------------------------------------------


class ReflectionOperator(lx.AbstractLinearOperator):
    """``K x = ρ ⊙ (F x)`` on arrays of shape ``(P, ...)`` (columns: networks × wavelengths).

    ``rho`` is dimensionless reflectance, broadcastable against ``(P, ...)`` (a ``(P,)`` array
    applies to every column). ``transpose()`` gives ``Kᵀ x = Fᵀ (ρ ⊙ x)``.

    With diffuse transmission (``tau``, shaped like ``rho``, and ``partner``, ``(P,)`` patch
    indices: ``_transmission.py``) ``K x = ρ ⊙ (F x) + τ ⊙ (F x)[partner]`` and
    ``Kᵀ x = Fᵀ (ρ ⊙ x + Σ_{i: partner[i] = j} τ_i x_i)``.
    """

    transport: TransportOperator
    rho: Float[Array, "patches ..."]
    structure: jax.ShapeDtypeStruct = eqx.field(static=True)
    transposed: bool = eqx.field(static=True, default=False)
    tau: Float[Array, "patches ..."] | None = None
    partner: Array | None = None

    def __init__(self, transport, rho, structure, transposed=False, tau=None, partner=None):
        self.transport = transport
        shape = (-1,) + (1,) * (len(structure.shape) - 1)
        rho = jnp.asarray(rho, structure.dtype)
        self.rho = rho.reshape(shape) if rho.ndim == 1 else rho
        if tau is not None:
            tau = jnp.asarray(tau, structure.dtype)
            tau = tau.reshape(shape) if tau.ndim == 1 else tau
            partner = jnp.asarray(partner, jnp.int32)
        self.tau, self.partner = tau, partner
        self.structure = structure
        self.transposed = transposed

    def mv(self, vector):
        if self.transposed:
            x = self.rho * vector
            if self.tau is not None:
                x = x.at[self.partner].add(self.tau * vector)
            return self.transport.rmatmul(x)
        y = self.transport.matmul(vector)
        if self.tau is not None:
            return self.rho * y + self.tau * y[self.partner]
        return self.rho * y

    def as_matrix(self):
        n = int(np.prod(self.structure.shape))
        eye = jnp.eye(n, dtype=self.structure.dtype).reshape((n,) + self.structure.shape)
        cols = jax.vmap(self.mv)(eye)  # column k = K e_k
        return cols.reshape(n, n).T

    def transpose(self):
        return ReflectionOperator(self.transport, self.rho, self.structure, not self.transposed,
                                  self.tau, self.partner)

    def in_structure(self):
        return self.structure

    def out_structure(self):
        return self.structure


@lx.linearise.register(ReflectionOperator)
@lx.materialise.register(ReflectionOperator)
@lx.conj.register(ReflectionOperator)
def _(op):
    return op  # already linear, matrix-free by design, and real


@lx.diagonal.register(ReflectionOperator)
def _(op):
    # F_ii = 0: a planar patch cannot see itself.
    return jnp.zeros(int(np.prod(op.structure.shape)), op.structure.dtype)


@lx.tridiagonal.register(ReflectionOperator)
def _(op):
    raise NotImplementedError("ReflectionOperator has no tridiagonal form")


for _check in (
    lx.is_symmetric,
    lx.is_diagonal,
    lx.is_tridiagonal,
    lx.has_unit_diagonal,
    lx.is_lower_triangular,
    lx.is_upper_triangular,
    lx.is_positive_semidefinite,
    lx.is_negative_semidefinite,
):
    # ρF is similar to a symmetric matrix but is not symmetric itself; no structure to exploit.
    _check.register(ReflectionOperator)(lambda op: False)
