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

import hashlib
import json
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
from jaxtyping import Array, Float, Int

from ..errors import OutputError

__all__ = ["Bucket", "Info", "TransportOperator", "ReflectionOperator", "load_operator", "operator_key"]


class Bucket(eqx.Module):
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


class Info(dict):
    """Build statistics and settings: a dict that hashes by content (a static pytree field)."""

    def __hash__(self):  # type: ignore[override]
        return hash(json.dumps(self, sort_keys=True, default=str))


def _bucket_apply(bk: Bucket, xext: Array, out: Array, only_block=None) -> Array:
    """out += G_bucket @ xext (both directions for off-diagonal pairs).

    With ``only_block``, chunks with no pair touching that block are skipped (``lax.cond``):
    the product with a vector that is zero outside the block, at the cost of its pairs only.
    """
    n, sa, sb = bk.blocks.shape
    steps = n // bk.chunk
    d = bk.blocks.reshape(steps, bk.chunk, sa, sb)
    r = bk.recv.reshape(steps, bk.chunk, sa)
    s = bk.src.reshape(steps, bk.chunk, sb)
    rb = bk.recv_block.reshape(steps, bk.chunk)
    sbk = bk.src_block.reshape(steps, bk.chunk)

    def compute(acc, dk, rk, sk):
        dk = dk.astype(xext.dtype)  # float32 storage, computed in the solve's precision
        acc = acc.at[rk].add(jnp.einsum("nij,njc->nic", dk, xext[sk]))
        if not bk.diagonal:
            acc = acc.at[sk].add(jnp.einsum("nij,nic->njc", dk, xext[rk]))
        return acc

    def body(acc, xs):
        dk, rk, sk, rbk, sbkk = xs
        if only_block is None:
            return compute(acc, dk, rk, sk), None
        touches = jnp.any((rbk == only_block) | (sbkk == only_block))
        acc = jax.lax.cond(touches, compute, lambda acc, *_: acc, acc, dk, rk, sk)
        return acc, None

    out, _ = jax.lax.scan(body, out, (d, r, s, rb, sbk))
    return out


@eqx.filter_jit
def _gmul(op: TransportOperator, x, only_block):
    shape = x.shape
    x2 = x.reshape(shape[0], -1)
    xext = jnp.concatenate([x2, jnp.zeros((1, x2.shape[1]), x2.dtype)])
    out = jnp.zeros_like(xext)
    for bk in op.buckets:
        out = _bucket_apply(bk, xext, out, only_block)
    return out[:-1].reshape(shape)


class TransportOperator(eqx.Module):
    """Form factors ``F`` (dimensionless, rows: receivers) of a patch mesh, block-sparse.

    ``F_ij`` is the fraction of the flux leaving patch i (diffusely, from its front) that arrives
    on the front of patch j. Build with :func:`~lumijax.transport.build_operator`.
    """

    buckets: tuple[Bucket, ...]
    area: Float[Array, " patches"]
    block_of: Int[Array, " patches"]
    n_patches: int = eqx.field(static=True)
    n_blocks: int = eqx.field(static=True)
    info: Info = eqx.field(static=True)

    def gmul(self, x: Float[Array, "patches ..."], only_block=None) -> Float[Array, "patches ..."]:
        """``G x`` with ``G = diag(A) F`` symmetric (m² × unit of x)."""
        return _gmul(self, jnp.asarray(x), only_block)

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
        return self.gmul(x / self._area(x))

    def row_sums(self) -> Float[Array, " patches"]:
        """``Σ_j F_ij``: 1 in a closed enclosure; ``1 − row sum`` is the fraction escaping."""
        return self.matmul(jnp.ones((self.n_patches, 1), self.area.dtype))[:, 0]

    def todense(self) -> np.ndarray:
        """Dense ``F`` as a float64 numpy array (small meshes: tests and debugging)."""
        p = self.n_patches
        g = np.zeros((p + 1, p + 1))
        for bk in self.buckets:
            d = np.asarray(bk.blocks, np.float64)
            r, s = np.asarray(bk.recv), np.asarray(bk.src)
            for k in range(len(d)):
                g[np.ix_(r[k], s[k])] += d[k]
                if not bk.diagonal:
                    g[np.ix_(s[k], r[k])] += d[k].T
        return g[:p, :p] / np.asarray(self.area, np.float64)[:, None]

    @property
    def nbytes(self) -> int:
        return int(sum(bk.blocks.nbytes + bk.recv.nbytes + bk.src.nbytes for bk in self.buckets))

    # -- persistence: plain arrays, so the lead's cache can key and store them --------------------
    def save(self, path: str | Path) -> None:
        """Write the operator to ``path`` (``.npz``: plain arrays plus a JSON header)."""
        arrays = {"area": np.asarray(self.area), "block_of": np.asarray(self.block_of)}
        for k, bk in enumerate(self.buckets):
            for name in ("blocks", "recv", "src", "recv_block", "src_block"):
                arrays[f"b{k}_{name}"] = np.asarray(getattr(bk, name))
        head = {
            "format": "lumijax.transport/1",
            "n_patches": self.n_patches,
            "n_blocks": self.n_blocks,
            "buckets": [{"diagonal": bk.diagonal, "chunk": bk.chunk} for bk in self.buckets],
            "info": self.info,
        }
        arrays["header"] = np.frombuffer(json.dumps(head).encode(), np.uint8)
        try:
            with open(path, "wb") as f:
                np.savez(f, **arrays)
        except OSError as e:
            raise OutputError(f"cannot write the transport operator: {e}", file=path) from e


def load_operator(path: str | Path) -> TransportOperator:
    """Read an operator written by :meth:`TransportOperator.save`."""
    with np.load(path) as z:
        head = json.loads(bytes(z["header"]).decode())
        if head.get("format") != "lumijax.transport/1":
            raise OutputError(f"not a lumijax transport operator: {head.get('format')!r}", file=path)
        buckets = tuple(
            Bucket(
                *(
                    jnp.asarray(z[f"b{k}_{name}"])
                    for name in ("blocks", "recv", "src", "recv_block", "src_block")
                ),
                diagonal=b["diagonal"],
                chunk=b["chunk"],
            )
            for k, b in enumerate(head["buckets"])
        )
        return TransportOperator(
            buckets,
            jnp.asarray(z["area"]),
            jnp.asarray(z["block_of"]),
            head["n_patches"],
            head["n_blocks"],
            Info(head["info"]),
        )


def operator_key(triangles, material, group, **settings) -> str:
    """A hex digest of geometry + meshing/form-factor settings, to key a cache of operators."""
    h = hashlib.sha256()
    for a in (triangles, material, group):
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    h.update(json.dumps(settings, sort_keys=True, default=str).encode())
    return h.hexdigest()


# -- K = ρF as a lineax operator ------------------------------------------------------------------


class ReflectionOperator(lx.AbstractLinearOperator):
    """``K x = ρ ⊙ (F x)`` on arrays of shape ``(P, ...)`` (columns: networks × wavelengths).

    ``rho`` is dimensionless reflectance, broadcastable against ``(P, ...)`` (a ``(P,)`` array
    applies to every column). ``transpose()`` gives ``Kᵀ x = Fᵀ (ρ ⊙ x)``.
    """

    transport: TransportOperator
    rho: Float[Array, "patches ..."]
    structure: jax.ShapeDtypeStruct = eqx.field(static=True)
    transposed: bool = eqx.field(static=True, default=False)

    def __init__(self, transport, rho, structure, transposed=False):
        self.transport = transport
        rho = jnp.asarray(rho, structure.dtype)
        if rho.ndim == 1:
            rho = rho.reshape((-1,) + (1,) * (len(structure.shape) - 1))
        self.rho = rho
        self.structure = structure
        self.transposed = transposed

    def mv(self, vector):
        if self.transposed:
            return self.transport.rmatmul(self.rho * vector)
        return self.rho * self.transport.matmul(vector)

    def as_matrix(self):
        n = int(np.prod(self.structure.shape))
        eye = jnp.eye(n, dtype=self.structure.dtype).reshape((n,) + self.structure.shape)
        cols = jax.vmap(self.mv)(eye)  # column k = K e_k
        return cols.reshape(n, n).T

    def transpose(self):
        return ReflectionOperator(self.transport, self.rho, self.structure, not self.transposed)

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
