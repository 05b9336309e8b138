"""The on-disk operator cache: keys, hits and misses, corruption, atomicity, no rays on a hit."""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import stat
import struct
import subprocess
import sys
import textwrap
import threading
import warnings
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from lumijax.errors import LumijaxWarning
from lumijax.radiosity import (
    FormFactorSettings,
    OperatorFileError,
    PartitionSettings,
    _cache,
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


# -- authentication and validation on load (issue 12 §4) -----------------------------------------

@pytest.fixture(autouse=True)
def _own_secret(tmp_path_factory, monkeypatch):
    """Each test its own cache secret file (never the user's ~/.config)."""
    home = tmp_path_factory.mktemp("config")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(home))
    monkeypatch.delenv("LUMIJAX_CACHE_SECRET", raising=False)
    return home / "lumijax" / "cache-secret"


def _split(data: bytes):
    """(header dict, payload bytes) of a container, by the documented layout."""
    (hl,) = struct.unpack("<Q", data[48:56])
    return json.loads(data[56 : 56 + hl]), data[56 + hl :]


def _pack(head: dict, payload: bytes, secret: bytes | None) -> bytes:
    """A container from parts, tagged as an attacker would: the old unkeyed SHA-256 layout
    (``secret=None``), or HMAC-SHA256 with a secret the test read itself."""
    hb = json.dumps(head).encode()
    hb += b" " * (-(len(hb) + 56) % 64)
    rest = struct.pack("<Q", len(hb)) + hb + payload
    tag = (hashlib.sha256(rest) if secret is None else
           hmac.new(secret, rest, hashlib.sha256)).digest()
    return b"LUMIJAX-TRANSPRT" + tag + rest


def _edit(payload: bytes, head: dict, name: str, fn) -> bytes:
    off, dt, shape = head["arrays"][name]
    a = np.frombuffer(payload, np.dtype(dt), int(np.prod(shape)), off).reshape(shape).copy()
    a = fn(a)
    out = bytearray(payload)
    out[off : off + a.nbytes] = a.tobytes()
    return bytes(out)


def test_secret_is_created_private_and_outside_the_cache(tmp_path, _own_secret):
    _get(tmp_path / "cache")
    st = _own_secret.stat()
    assert stat.S_IMODE(st.st_mode) == 0o600 and st.st_size == 32
    assert not (tmp_path / "cache" / "cache-secret").exists()


def test_resigned_file_is_rejected_and_rebuilt(tmp_path):
    """The attack of the issue: double every stored form factor, re-sign with SHA-256."""
    p = _patches()
    op, _ = _get(tmp_path, p)
    (path,) = tmp_path.iterdir()
    head, payload = _split(path.read_bytes())
    payload = _edit(payload, head, "b0_blocks", lambda a: a * 2)
    path.write_bytes(_pack(head, payload, secret=None))
    with pytest.raises(OperatorFileError, match="signature mismatch"):
        load_operator(path)
    with pytest.warns(LumijaxWarning, match="is corrupt.*signature.*; rebuilding"):
        op2, hit = _get(tmp_path, p)
    assert not hit
    np.testing.assert_array_equal(op2.matmul(_x(p.n)), op.matmul(_x(p.n)))


def test_file_signed_with_another_secret_is_rejected(tmp_path, monkeypatch):
    p = _patches()
    _get(tmp_path, p)
    monkeypatch.setenv("LUMIJAX_CACHE_SECRET", "someone else's secret, 32 chars")
    with pytest.warns(LumijaxWarning, match="signature"):
        assert not _get(tmp_path, p)[1]
    assert _get(tmp_path, p)[1]  # rewritten under this secret


def _bad_header(case, head, payload, n):
    if case == "json":
        return None, payload
    if case == "n_patches_str":
        head["n_patches"] = str(head["n_patches"])
    elif case == "chunk_bool":
        head["buckets"][0]["chunk"] = True
    elif case == "object_dtype":
        head["arrays"]["b0_recv"][1] = "|O"
    elif case == "big_endian":
        head["arrays"]["area"][1] = ">f8"
    elif case == "past_end":
        head["arrays"]["b0_src_block"][0] = len(payload) + 64
    elif case == "overlap":
        head["arrays"]["b0_src"][0] = head["arrays"]["b0_recv"][0]
    elif case == "shape":
        head["arrays"]["b0_recv"][2] = [1, 64]
    elif case == "extra_key":
        head["note"] = "x"
    elif case == "missing_array":
        del head["arrays"]["block_of"]
    elif case == "recv_out_of_range":  # the silent clamp: 14 % less light
        payload = _edit(payload, head, "b0_recv", lambda a: np.where(a == 5, n + 7, a))
    elif case == "src_negative":
        payload = _edit(payload, head, "b0_src", lambda a: np.where(a == 3, -2, a))
    elif case == "block_of":
        payload = _edit(payload, head, "block_of", lambda a: a + head["n_blocks"])
    elif case == "nan":
        payload = _edit(payload, head, "b0_blocks", lambda a: np.where(a > 0, np.nan, a))
    elif case == "area":
        payload = _edit(payload, head, "area", lambda a: -a)
    return head, payload


FIXED_SECRET = b"a test secret of 32 bytes, fixed"


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    """One operator file under FIXED_SECRET, built once for the validation cases."""
    d = tmp_path_factory.mktemp("pristine")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("LUMIJAX_CACHE_SECRET", FIXED_SECRET.decode())
        p = _patches()
        op, _ = _get(d, p)
    (path,) = d.iterdir()
    return p, op, path.name, path.read_bytes()


@pytest.mark.parametrize("case", [
    "json", "n_patches_str", "chunk_bool", "object_dtype", "big_endian", "past_end", "overlap",
    "shape", "extra_key", "missing_array", "recv_out_of_range", "src_negative", "block_of",
    "nan", "area",
])
def test_invalid_but_signed_file_is_rebuilt_never_read(tmp_path, monkeypatch, pristine, case):
    """Even a correctly tagged file (a writer's bug, a leaked secret) is validated field by
    field: an OperatorFileError and a rebuild, never a traceback or a clamped index."""
    monkeypatch.setenv("LUMIJAX_CACHE_SECRET", FIXED_SECRET.decode())
    p, op, name, data = pristine
    path = tmp_path / name
    head, payload = _split(data)
    head, payload = _bad_header(case, head, payload, p.n)
    secret = FIXED_SECRET
    if head is None:
        data = bytearray(_pack({"format": "x"}, payload, secret))
        data[56:70] = b'{"format": [1,'
        rest = bytes(data[48:])
        data[16:48] = hmac.new(secret, rest, hashlib.sha256).digest()
        path.write_bytes(bytes(data))
    else:
        path.write_bytes(_pack(head, payload, secret))
    with pytest.raises(OperatorFileError) as exc:
        load_operator(path)
    assert exc.value.reason == "corrupt" and str(path) in str(exc.value)
    if case not in ("json", "object_dtype", "recv_out_of_range"):
        return  # the rebuild is the same path for every case: shown on three
    with pytest.warns(LumijaxWarning, match="is corrupt"):
        op2, hit = _get(tmp_path, p)
    assert not hit
    np.testing.assert_array_equal(op2.matmul(_x(p.n)), op.matmul(_x(p.n)))


def test_file_of_another_key_is_not_used(tmp_path):
    p = _patches()
    _get(tmp_path, p)
    (path,) = tmp_path.iterdir()
    with pytest.raises(OperatorFileError) as exc:
        load_operator(path, key="0" * 64)
    assert exc.value.reason == "key"


def test_another_lumijax_version_misses(tmp_path, monkeypatch):
    p = _patches()
    _get(tmp_path, p)
    key = operator_key(p, occluders=TRI, partition=PS, form_factors=FormFactorSettings(),
                       dtype=np.dtype(np.float32))
    _cache.code_version.cache_clear()
    monkeypatch.setattr(_cache, "__version__", "99.0")
    try:
        key2 = operator_key(p, occluders=TRI, partition=PS, form_factors=FormFactorSettings(),
                            dtype=np.dtype(np.float32))
        assert key2 != key and not _get(tmp_path, p)[1]
    finally:
        _cache.code_version.cache_clear()
    root = Path(_cache.__file__).resolve().parents[1]
    assert all((root / rel).is_file() for rel in _cache._F_MODULES)  # the list is not stale


def test_planted_fifo_does_not_hang_and_is_replaced(tmp_path):
    p = _patches()
    key = operator_key(p, occluders=TRI, partition=PS, form_factors=FormFactorSettings(),
                       dtype=np.dtype(np.float32))
    os.mkfifo(cache_path(tmp_path, key))
    with pytest.warns(LumijaxWarning, match="not a regular file"):
        assert not _get(tmp_path, p)[1]
    assert cache_path(tmp_path, key).is_file() and _get(tmp_path, p)[1]


@pytest.mark.parametrize("problem", ["readable_by_others", "short_env"])
def test_unsafe_secret_is_refused_and_nothing_is_cached(tmp_path, _own_secret, monkeypatch,
                                                          problem):
    if problem == "readable_by_others":
        _own_secret.parent.mkdir(parents=True)
        _own_secret.write_bytes(os.urandom(32))
        _own_secret.chmod(0o644)
    else:
        monkeypatch.setenv("LUMIJAX_CACHE_SECRET", "short")
    with pytest.warns(LumijaxWarning, match="no cache secret"):
        op, hit = _get(tmp_path / "c")
    assert not hit and op.n_patches == _patches().n
    assert not (tmp_path / "c").exists() or not list((tmp_path / "c").iterdir())


def test_write_killed_mid_way_leaves_an_orphan_the_next_run_removes(tmp_path, _own_secret):
    """kill -9 after the temporary file is written, before its rename: the next run finds the
    orphan (its writer's pid is dead) and deletes it; a live writer's temporary is kept."""
    _store.cache_secret()  # made here: the child is to die in the operator's write only
    script = textwrap.dedent(f"""
        import os, signal, sys
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        import test_cache as t
        from lumijax.radiosity import _store
        def die(fd):
            os.kill(os.getpid(), signal.SIGKILL)
        _store.os.fsync = die
        t._get(__import__("pathlib").Path({str(tmp_path)!r}))
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300, env={**os.environ, "XDG_CONFIG_HOME": str(
                              _own_secret.parent.parent)})
    assert proc.returncode == -9, proc.stderr
    orphans = [f for f in tmp_path.iterdir() if f.name.endswith(".tmp")]
    assert len(orphans) == 1 and orphans[0].stat().st_size > 10_000
    live = tmp_path / f".transport-x.lmjop.lumijax-tmp-{os.getpid()}-abc.tmp"
    live.write_bytes(b"a live writer's")
    assert not _get(tmp_path)[1]
    left = sorted(f.name for f in tmp_path.iterdir())
    assert left == sorted([live.name, next(f.name for f in tmp_path.iterdir()
                                           if f.suffix == ".lmjop")])


def test_a_format_5_file_from_before_the_keyed_tag_is_rebuilt_silently(tmp_path):
    """An upgrade: the old container (unkeyed SHA-256, format 5) is another format, not an
    attack: rebuilt without a warning."""
    p = _patches()
    _get(tmp_path, p)
    (path,) = tmp_path.iterdir()
    head, payload = _split(path.read_bytes())
    head["format"] = "lumijax.transport/5"
    path.write_bytes(_pack(head, payload, secret=None))
    with pytest.raises(OperatorFileError) as exc:
        load_operator(path)
    assert exc.value.reason == "format"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not _get(tmp_path, p)[1]
        assert _get(tmp_path, p)[1]
