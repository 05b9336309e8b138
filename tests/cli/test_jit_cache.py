"""JAX's persistent compilation cache (lumijax/_jit_cache.py): where it lives, that a new
process reuses it, and that a corrupted, foreign or unwritable cache never stops a run.

JAX reads its cache setting once per process, so the end-to-end checks run in subprocesses;
JAX's own monitoring events (``/jax/compilation_cache/cache_hits``) say whether an executable
came from disk.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import jax
import jaxlib
import numpy as np
import pytest

from lumijax import _jit_cache
from lumijax._version import __version__
from lumijax.errors import LumijaxWarning

VERSIONS = f"jax-{jax.__version__}_jaxlib-{jaxlib.__version__}_lumijax-{__version__}"

# A kernel that takes long enough to compile to be written (min compile time set to 0 as well),
# and a value to check it by: x ↦ cos(x)·2 + 1 summed, at x = 0..9
PROGRAM = r"""
import json, sys, warnings
import jax, jax.numpy as jnp
warnings.simplefilter("always")
events = []
jax.monitoring.register_event_listener(lambda name, **kw: events.append(name))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
from lumijax._jit_cache import enable_compilation_cache
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    path = enable_compilation_cache()
    value = float(jax.jit(lambda x: jnp.sum(jnp.cos(x) * 2.0 + 1.0))(jnp.arange(10.0)))
print(json.dumps({"path": None if path is None else str(path), "value": value,
                  "hits": events.count("/jax/compilation_cache/cache_hits"),
                  "misses": events.count("/jax/compilation_cache/cache_misses"),
                  "warnings": [str(w.message) for w in caught]}))
"""

EXPECTED = float(np.sum(np.cos(np.arange(10.0)) * 2.0 + 1.0))


def run(env_value: str, program: str = PROGRAM) -> dict:
    env = dict(os.environ, LUMIJAX_JAX_CACHE=env_value, JAX_PLATFORMS="cpu")
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    env.pop("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", None)
    proc = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                          env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["value"] == pytest.approx(EXPECTED, rel=1e-6)
    return out


def test_default_folder_is_the_users_cache_keyed_by_versions(monkeypatch, tmp_path):
    monkeypatch.delenv("LUMIJAX_JAX_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert _jit_cache.cache_dir() == tmp_path / "xdg" / "lumijax" / "jax" / VERSIONS
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert _jit_cache.cache_dir() == tmp_path / "home" / ".cache" / "lumijax" / "jax" / VERSIONS
    monkeypatch.setenv("LUMIJAX_JAX_CACHE", str(tmp_path / "mine"))
    assert _jit_cache.cache_dir() == tmp_path / "mine" / VERSIONS
    for off in ("0", "off", "False", ""):
        monkeypatch.setenv("LUMIJAX_JAX_CACHE", off)
        assert _jit_cache.cache_dir() is None


def test_the_tests_never_write_the_users_cache():
    folder = Path(os.environ["LUMIJAX_JAX_CACHE"]).resolve()
    assert not folder.is_relative_to(Path.home() / ".cache")
    assert _jit_cache.cache_dir().is_relative_to(folder)


def test_entries_are_checked_and_a_bad_one_is_ignored_then_replaced(tmp_path):
    cache = _jit_cache.VerifiedFileCache(tmp_path)
    value = bytes(range(256)) * 100
    cache.put("k", value)
    assert cache.get("k") == value
    assert cache.get("missing") is None
    (file,) = tmp_path.glob("*.ljx")
    good = file.read_bytes()
    assert good != value  # stored with a header and a digest, not raw
    bad = bytearray(good)
    bad[-5] ^= 0xFF  # one flipped byte in the payload
    for damaged, why in ((bytes(bad), "corrupted"), (good[: len(good) // 2], "corrupted"),
                         (value, "foreign or truncated"), (b"", "foreign or truncated")):
        file.write_bytes(damaged)
        fresh = _jit_cache.VerifiedFileCache(tmp_path)  # warns once per process-level cache
        with pytest.warns(LumijaxWarning, match=why):
            assert fresh.get("k") is None
    fresh.put("k", value)  # what JAX does after recompiling
    assert fresh.get("k") == value


def test_concurrent_writers_never_show_a_reader_half_an_entry(tmp_path):
    cache = _jit_cache.VerifiedFileCache(tmp_path)
    value = os.urandom(4 << 20)
    cache.put("k", value)  # present from the start: every read must return it whole
    seen, stop = [], threading.Event()

    def read():
        while not stop.is_set():
            seen.append(cache.get("k"))

    def write():
        for _ in range(20):
            cache.put("k", value)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LumijaxWarning)  # a torn read: None, checked below
        threads = [threading.Thread(target=f) for f in (read, read, write, write)]
        for t in threads:
            t.start()
        for t in threads[2:]:
            t.join()
        stop.set()
        for t in threads[:2]:
            t.join()
    assert len(seen) > 10
    assert all(v == value for v in seen)
    assert [p.name for p in tmp_path.iterdir()] == [next(tmp_path.glob("*.ljx")).name]


def test_a_new_process_reuses_the_cache_and_recompiles_a_corrupted_one(tmp_path):
    root = tmp_path / "cache"
    first = run(str(root))
    assert first["path"] == str(root / VERSIONS)
    assert first["misses"] >= 1 and first["hits"] == 0 and first["warnings"] == []
    assert list((root / VERSIONS).glob("*.ljx"))
    second = run(str(root))
    assert second["hits"] >= 1 and second["misses"] == 0 and second["warnings"] == []
    for f in (root / VERSIONS).glob("*.ljx"):
        f.write_bytes(b"not a cache entry" * 10)
    third = run(str(root))
    assert third["hits"] == 0 and third["misses"] >= 1
    assert any("ignored and recompiled" in w for w in third["warnings"])


def test_even_a_kernel_that_compiles_in_milliseconds_is_kept(tmp_path):
    # JAX's threshold left as lumijax sets it: a warm small study compiled ~76 such kernels
    # (3 s of its 7 s of XLA time) when only those over 0.1 s were kept
    program = PROGRAM.replace('jax.config.update("jax_persistent_cache_min_compile_time_secs", '
                              '0.0)\n', "")
    assert program != PROGRAM
    root = tmp_path / "cache"
    assert run(str(root), program)["misses"] >= 1
    second = run(str(root), program)
    assert second["hits"] >= 1 and second["misses"] == 0


def test_an_unwritable_folder_runs_without_a_cache(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    out = run(str(blocker / "cache"))  # no folder can be made inside a file (even as root)
    assert out["path"] is None and out["hits"] == 0
    assert any("running without a persistent compilation cache" in w for w in out["warnings"])
