"""The on-disk operator cache: keys, hits and misses, corruption, atomicity, no rays on a hit."""

from __future__ import annotations

import threading
import warnings

import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from lumijax.errors import LumijaxWarning
from lumijax.radiosity import (
    FormFactorSettings,
    OperatorFileError,
    PartitionSettings,
    _store,
    cache_path,
    cached_operator,
    load_operator,
    mesh_patches,
    operator_key,
    save_operator,
)
from lumijax.scene import _raycast


def _room(dx=0.0):
    m = trimesh.creation.box(extents=(3, 3, 2.5))
    m.apply_translation([dx, 0, 0])
    m.invert()
    return m.triangles


TRI = _room()
PS = PartitionSettings(max_block=256)


def _patches(tri=TRI, patch_size=1.5, material=None):
    return mesh_patches(tri, material=material, patch_size=patch_size)


def _get(tmp_path, p=None, tri=TRI, **kw):
    p = _patches() if p is None else p
    return cached_operator(p, tri, cache_dir=tmp_path, partition_settings=PS, **kw)


def _x(n):
    return jnp.asarray(np.random.default_rng(1).random((n, 2)), jnp.float32)


def _files(d):
    return sorted(f.name for f in d.iterdir())


def test_miss_then_hit_and_materials_are_not_in_the_key(tmp_path):
    p = _patches()
    op, hit = _get(tmp_path, p)
    assert not hit and len(_files(tmp_path)) == 1
    op2, hit2 = _get(tmp_path, p)
    assert hit2
    assert np.array_equal(op2.matmul(_x(p.n)), op.matmul(_x(p.n)))
    assert op2.info == op.info
    # Other materials (so other reflectances), same geometry: same key, a hit.
    other = _patches(material=np.arange(len(TRI)) % 3)
    assert _get(tmp_path, other)[1]


@pytest.mark.parametrize(
    "change",
    ["geometry", "patch_size", "form_factors", "partition", "dtype", "occluders"],
)
def test_anything_that_changes_F_misses(tmp_path, change):
    _get(tmp_path)
    kw, p, tri = {}, None, TRI
    if change == "geometry":
        tri = TRI.copy()
        tri[tri == tri.max()] += 0.1  # stretch the room
        p = _patches(tri)
    elif change == "patch_size":
        p = _patches(patch_size=1.4)
    elif change == "form_factors":
        kw["settings"] = FormFactorSettings(near_ratio=5.0)
    elif change == "partition":
        p = _patches()
        op, hit = cached_operator(p, TRI, cache_dir=tmp_path,
                                  partition_settings=PartitionSettings(max_block=64))
        assert not hit
        return
    elif change == "dtype":
        kw["dtype"] = np.float64
    elif change == "occluders":
        p = _patches()
        tri = np.concatenate([TRI, _room(10.0)])  # a second room far away: other shadows
    assert not _get(tmp_path, p, tri, **kw)[1]
    assert len(_files(tmp_path)) == 2


def test_hit_casts_no_rays(tmp_path, monkeypatch):
    p = _patches()
    op, _ = _get(tmp_path, p)

    def boom(*a, **k):
        raise AssertionError("a ray was cast on a cache hit")

    monkeypatch.setattr(_raycast.RayCaster, "__init__", boom)
    monkeypatch.setattr(_raycast.RayCaster, "occluded", boom)
    op2, hit = _get(tmp_path, p)
    assert hit
    assert np.array_equal(op2.matmul(_x(p.n)), op.matmul(_x(p.n)))


@pytest.mark.parametrize("damage", ["truncate", "flip_payload", "flip_header", "empty"])
def test_corrupt_file_warns_and_is_rebuilt(tmp_path, damage):
    p = _patches()
    op, _ = _get(tmp_path, p)
    (path,) = tmp_path.iterdir()
    data = bytearray(path.read_bytes())
    if damage == "truncate":
        data = data[: len(data) // 2]
    elif damage == "flip_payload":
        data[len(data) - 1000] ^= 0x10
    elif damage == "flip_header":
        data[70] ^= 0x01
    else:
        data = bytearray()
    path.write_bytes(bytes(data))
    with pytest.raises(OperatorFileError):
        load_operator(path)
    with pytest.warns(LumijaxWarning, match="is corrupt.*; rebuilding"):
        op2, hit = _get(tmp_path, p)
    assert not hit
    assert np.allclose(op2.matmul(_x(p.n)), op.matmul(_x(p.n)), rtol=0, atol=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _get(tmp_path, p)[1]  # rewritten: the next run hits, silently


def test_other_format_version_is_rebuilt_silently(tmp_path, monkeypatch):
    p = _patches()
    op, _ = _get(tmp_path, p)
    (path,) = tmp_path.iterdir()
    monkeypatch.setattr(_store, "FORMAT", "lumijax.transport/0")
    save_operator(path, op)  # same place, other format in its header
    monkeypatch.undo()
    with pytest.raises(OperatorFileError, match="format"):
        load_operator(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not _get(tmp_path, p)[1]
        assert _get(tmp_path, p)[1]


def test_concurrent_builders_leave_one_complete_file(tmp_path):
    p = _patches()
    (tmp_path / f".{cache_path(tmp_path, 'x').name}.abc.tmp").write_bytes(b"junk")  # stale temp
    out, errors = [], []

    def work():
        try:
            out.append(_get(tmp_path, p))
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    key = operator_key(p, occluders=TRI, partition=PS, form_factors=FormFactorSettings(),
                       dtype=np.dtype(np.float32))
    path = cache_path(tmp_path, key)
    files = [f for f in _files(tmp_path) if not f.endswith("abc.tmp")]
    assert files == [path.name]  # no temporary file left behind, one complete operator
    back = load_operator(path, key=key)
    assert np.array_equal(back.matmul(_x(p.n)), out[0][0].matmul(_x(p.n)))


def test_unwritable_cache_warns_and_still_returns_the_operator(tmp_path):
    blocker = tmp_path / "cache"
    blocker.write_text("a file where the folder should be")
    with pytest.warns(LumijaxWarning, match="cannot write cache file"):
        op, hit = _get(blocker)
    assert not hit and op.n_patches == _patches().n
