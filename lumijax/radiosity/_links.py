"""Ray-sampled links in eight bytes each: how a :class:`~lumijax.radiosity.SampledBucket` stores
``G = A F``.

A link ``(i, j, w)`` says that rays from patch i found patch j, with ``w = A_i F_ij`` (m²). A
10⁶-patch courtyard at 1,400 rays a patch (its 3 % noise) has ≈ 10⁹ of them, so the bytes of
one link decide what fits (issue 17). The links are sorted by receiver i and cut into chunks of
:data:`CHUNK` (one step of a product's scan); each link stores

- ``src``: the sender j, int32 (4 B);
- ``recv``: the receiver less its chunk's first, ``base`` (int32 a chunk), as uint16 (2 B);
- ``weight``: ``w / scale_i`` as float16 (2 B), ``scale`` one float32 a patch: ``A_i / N``
  (N the rays a patch), times the power of two that keeps the patch's largest stored value
  under 2¹⁵ where the hits would pass it.

A float64 operator keeps float64 weights and a scale of 1 (14 B a link). Against the int32 /
int32 / float32 links before (12 B), that is two thirds of the memory for the same rays.

Why a scale a patch: a cosine-sampled weight is ``A_i · hits / N``, so the stored value is the
hit count, a whole number float16 holds exactly up to 2,048 (and within 2⁻¹² above): a row
sums to ``hits / N`` to float32's rounding, and never passes 1. A weight scaled by a power of
two a chunk instead rounded all of a patch's equal weights the same way (rows of a closed box
summed to 1.0003). Aimed rays' multiple-importance weights and glass's transmittances are not
whole: each rounds by at most 2⁻¹² of itself (11-bit significand), errors of either sign over a
patch's links, far below the sampled operator's own noise (≥ 0.5 % RMS per patch even at
65,536 rays, docs/radiosity.md).

A chunk whose receivers would span more than 65,535 patches (a run of patches with no links,
such as roofs whose rays all leave for the sky) is closed early and its tail padded. Padding
links carry weight 0 from the zero patch (index ``n_patches``, whose value is 0) to the
chunk's base: they add nothing either way round.
"""

from __future__ import annotations

import numpy as np

from .._jit_cache import host_empty

__all__ = ["CHUNK", "SPAN", "LinkPacker", "link_bytes", "pack_links"]

#: Links per step of a product's scan: 2¹⁶ links × 144 columns × 4 bytes ≈ 38 MiB gathered.
CHUNK = 1 << 16

#: Receivers one chunk may span (its uint16 offsets).
SPAN = 1 << 16

#: The largest stored weight is under 2 to this (float16 holds up to 65,504).
_TOP = 15


def link_bytes(itemsize: int) -> int:
    """Bytes a stored link takes for an operator of ``itemsize``-byte floats (4 or 8)."""
    return 4 + 2 + (2 if int(itemsize) <= 4 else int(itemsize))


class LinkPacker:
    """Writes links, batch after batch in receiver order, straight into their stored form.

    ``unit``: each patch's scale before its power of two (``A_i / N`` for rays of weight
    ``A_i / N``); None: 1, so the power of two alone puts each patch's largest weight just
    under 2¹⁵. The arrays are reserved for ``most`` links (and the padding of chunks closed
    early) but only the pages written become resident, and they are aligned for JAX to adopt
    without a copy (:func:`~lumijax._jit_cache.host_empty`); more links than reserved move
    them into larger ones (a copy, which a good ``most`` avoids).
    """

    def __init__(self, most: int, n_patches: int, dtype=np.float32, unit=None) -> None:
        self.compact = np.dtype(dtype).itemsize <= 4
        self.zero = int(n_patches)
        self.recv = self.src = self.weight = np.zeros(0)
        self.base = np.zeros(0, np.int32)
        self.n = 0  # slots written, padding included
        self.links = 0  # links given
        # a chunk closed early wastes less than a chunk, and needs 65,536 receivers passed
        self._reserve(int(most) + CHUNK * (self.zero // SPAN + 2))
        self.unit = (None if unit is None or not self.compact
                     else np.asarray(unit, np.float64).reshape(self.zero))
        self.scale = np.ones(self.zero + 1, np.float32 if self.compact else np.float64)

    def _reserve(self, slots: int) -> None:
        """Room for ``slots`` slots in all (whole chunks), what is written kept."""
        steps = -(-slots // CHUNK)
        if steps <= len(self.base):
            return
        cap, n = steps * CHUNK, self.n
        for name, dtype in (("recv", np.uint16), ("src", np.int32),
                            ("weight", np.float16 if self.compact else np.float64)):
            new = host_empty(cap, dtype)
            new[:n] = getattr(self, name)[:n]
            setattr(self, name, new)
        self.base = np.concatenate([self.base, np.zeros(steps - len(self.base), np.int32)])

    def add(self, recv, src, weight) -> None:
        """Append links ``(recv, src, weight)``: ``recv`` ascending, none below the last batch's,
        and each patch's links in one batch (its scale is set from them)."""
        recv = np.asarray(recv, np.int64)
        weight = np.asarray(weight, np.float64)
        if self.compact and len(recv):
            weight = weight / self._scales(recv, weight)
        i, m = 0, len(recv)
        self.links += m
        while i < m:
            k, pos = divmod(self.n, CHUNK)
            if k == len(self.base):  # more links than reserved
                self._reserve(max(self.n + m - i, int(1.5 * self.n)) + CHUNK)
            if pos == 0:
                self.base[k] = recv[i]
            j = min(m, i + CHUNK - pos)
            off = recv[i:j] - self.base[k]
            far = np.flatnonzero(off >= SPAN)  # ascending: the first is where the span ends
            if far.size:
                j = i + int(far[0])
            w = slice(self.n, self.n + j - i)
            self.recv[w] = off[: j - i]
            self.src[w] = np.asarray(src[i:j], np.int32)
            self.weight[w] = weight[i:j]
            self.n += j - i
            i = j
            if far.size:
                self._pad(CHUNK)

    def _scales(self, recv, weight):
        """Set the scale of every patch in ``recv`` (sorted) and return each link's."""
        starts = np.flatnonzero(np.r_[True, recv[1:] != recv[:-1]])
        patch = recv[starts]
        unit = np.ones(len(patch)) if self.unit is None else self.unit[patch]
        top = np.maximum.reduceat(weight, starts) / unit
        e = np.frexp(np.where(top > 0, top, 1.0))[1] - _TOP
        if self.unit is not None:  # whole hit counts stay whole where they fit
            e = np.maximum(e, 0)
        scale = (unit * np.ldexp(1.0, e)).astype(np.float32)
        self.scale[patch] = scale
        return np.repeat(scale.astype(np.float64), np.diff(np.r_[starts, len(recv)]))

    def _pad(self, length: int) -> None:
        """Pad the open chunk to ``length`` slots."""
        k, pos = divmod(self.n, CHUNK)
        end = k * CHUNK + length
        self.recv[self.n:end] = 0
        self.src[self.n:end] = self.zero
        self.weight[self.n:end] = 0
        self.n = end

    def packed(self):
        """``(weight, recv, src, base, scale, chunk)``: whole chunks of at most :data:`CHUNK`
        links (one chunk as long as the links where they fit in one); ``scale`` one a patch
        and the padding patch's."""
        if self.n == 0:  # no link at all: one padding link
            self._pad(1)
            chunk = 1
        elif self.n < CHUNK:  # one chunk: as long as its links
            chunk = self.n
        else:
            if self.n % CHUNK:
                self._pad(CHUNK)
            chunk = CHUNK
        steps = self.n // chunk
        return (self.weight[: self.n], self.recv[: self.n], self.src[: self.n],
                self.base[:steps].copy(), self.scale, chunk)


def pack_links(recv, src, weight, n_patches: int, dtype=np.float32):
    """Links in any order packed as :class:`LinkPacker` stores them (``packed()``'s tuple)."""
    recv = np.asarray(recv)
    order = np.argsort(recv, kind="stable")
    packer = LinkPacker(len(recv), n_patches, dtype)
    packer.add(recv[order], np.asarray(src)[order], np.asarray(weight, np.float64)[order])
    return packer.packed()
