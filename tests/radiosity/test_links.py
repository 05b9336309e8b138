"""The sampled links' eight-byte storage (radiosity/_links.py) against the links it was given:
the same pairs, weights within float16's rounding, products equal to SciPy's in float64."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest
import scipy.sparse as sparse

from lumijax.radiosity import SampledBucket, TransportOperator
from lumijax.radiosity._links import CHUNK, SPAN, link_bytes
from lumijax.radiosity._operator import Info


def _random_links(n_patches: int, seed: int = 0, scale: int = 1):
    """≈ 2.3 chunks of links (× ``scale``) whose receivers leave a gap wider than a chunk can
    span (patches with no links, as a roof's whose rays all leave for the sky), merged per
    pair."""
    rng = np.random.default_rng(seed)
    recv = np.r_[rng.integers(0, 1_000, 90_000 * scale),
                 rng.integers(1_000 + SPAN + 5, n_patches, 60_000 * scale)]
    src = rng.integers(0, n_patches, len(recv))
    key, inv = np.unique(recv * n_patches + src, return_inverse=True)
    weight = np.bincount(inv, weights=rng.exponential(1e-3, len(recv)))
    return key // n_patches, key % n_patches, weight


def _operator(bucket: SampledBucket, n: int) -> TransportOperator:
    return TransportOperator((bucket,), jnp.ones(n), jnp.zeros(n, jnp.int32), n, 1,
                             Info(patches=n, transport="sampled"))


def test_the_links_come_back_and_the_products_match_scipy():
    n = 140_000
    r, s, w = _random_links(n)
    bk = SampledBucket.from_links(r, s, w, n)
    assert bk.weight.dtype == jnp.float16 and bk.recv.dtype == jnp.uint16
    assert bk.chunk == CHUNK and len(bk.base) >= 3  # the gap closed one chunk early
    rr, ss, ww = bk.links()
    real = ww > 0
    order = np.lexsort((ss[real], rr[real]))
    assert np.array_equal(rr[real][order], r) and np.array_equal(ss[real][order], s)
    # float16's 11-bit significand: within 2⁻¹¹ of each weight (half that, rounded to nearest)
    assert np.max(np.abs(ww[real][order] / w - 1)) <= 2.0**-11
    assert np.all(ss[~real] == n)  # the padding comes from the zero patch
    g = sparse.csr_matrix((w, (r, s)), shape=(n, n))
    x = np.random.default_rng(1).random((n, 3))
    op = _operator(bk, n)
    got = np.asarray(op.gmul(jnp.asarray(x, jnp.float32)), np.float64)
    np.testing.assert_allclose(got, g @ x, rtol=2e-3, atol=1e-6)
    got_t = np.asarray(op.gmul(jnp.asarray(x, jnp.float32), transpose=True), np.float64)
    np.testing.assert_allclose(got_t, g.T @ x, rtol=2e-3, atol=1e-6)


def test_whole_hit_counts_are_stored_exactly():
    """A cosine ray's hit weighs A_i / N: with that unit the stored values are the counts, so
    a row of N hits sums to A_i exactly (to float32's rounding), never above."""
    from lumijax.radiosity._links import LinkPacker

    area = np.array([0.3, 1.7, 0.05])
    n_rays = 256
    recv = np.array([0, 0, 0, 1, 1, 2])
    hits = np.array([100, 100, 56, 255, 1, 256])
    packer = LinkPacker(6, 3, unit=area / n_rays)
    packer.add(recv, np.array([1, 2, 0, 0, 2, 1]), (area[recv] * hits / n_rays).astype(np.float32))
    w, rk, sk, base, scale, chunk = packer.packed()
    assert np.array_equal(w.astype(np.float64), hits)
    rows = np.bincount(recv, weights=w.astype(np.float64) * scale[recv].astype(np.float64))
    np.testing.assert_allclose(rows, area, rtol=1e-7)
    assert link_bytes(4) == 8 and link_bytes(8) == 14


def test_a_patch_with_more_hits_than_float16_holds_is_scaled_down():
    from lumijax.radiosity._links import LinkPacker

    packer = LinkPacker(2, 2, unit=np.ones(2))
    packer.add(np.array([0, 1]), np.array([1, 0]), np.array([70_000.0, 3.0]))
    w, _, _, _, scale, _ = packer.packed()  # 70,000 would be inf in float16 (max 65,504)
    assert scale[0] == 4 and w[0] == 17_500 and scale[1] == 1 and w[1] == 3


def test_no_links_is_one_padding_link():
    bk = SampledBucket.from_links(np.zeros(0, int), np.zeros(0, int), np.zeros(0), 5)
    x = jnp.ones((5, 2))
    assert bk.weight.shape == (1,) and float(np.abs(_operator(bk, 5).gmul(x)).max()) == 0


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_link_bytes_as_stored(dtype):
    r, s, w = _random_links(140_000, seed=2)
    bk = SampledBucket.from_links(r, s, w, 140_000, dtype=dtype)
    per_link = (bk.weight.dtype.itemsize + bk.recv.dtype.itemsize + bk.src.dtype.itemsize)
    itemsize = 8 if bk.weight.dtype == jnp.float64 else 4  # float32 under x64 off
    assert per_link == link_bytes(itemsize) or (itemsize == 4 and per_link == 8)


def test_more_links_than_reserved_move_into_larger_arrays():
    """Reserved for 1,000 links (and four chunks of padding), given 5·10⁵ in batches of whole
    patches (as the build gives them): the same arrays as packed at once."""
    from lumijax.radiosity._links import LinkPacker

    n = 140_000
    r, s, w = _random_links(n, seed=3, scale=4)
    whole = SampledBucket.from_links(r, s, w, n)
    packer = LinkPacker(1_000, n)
    reserved = len(packer.base)
    starts = np.flatnonzero(np.r_[True, r[1:] != r[:-1]])  # each patch's first link
    cuts = np.r_[starts[::5_000], len(r)]
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        packer.add(r[a:b], s[a:b], w[a:b])
    *arrays, chunk = packer.packed()
    assert chunk == whole.chunk and len(packer.base) > reserved
    for got, want in zip(arrays, (whole.weight, whole.recv, whole.src, whole.base, whole.scale),
                         strict=True):
        assert np.array_equal(np.asarray(got), np.asarray(want))
