"""Stored executables (lumijax/_executables.py): a later call, in this process or a new one, loads
the program instead of tracing it and gives the same bits; a corrupted, foreign or unwritable
store warns and never changes a number. The store is on only where the compilation cache is:
here its folder is set by hand (``_jit_cache._enabled``) and JAX's own cache is a new one per
test (an executable JAX loads from its cache is never stored, so a shared one would decide
what a test sees)."""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax import _executables, _jit_cache
from lumijax.errors import LumijaxWarning
from lumijax.radiosity import Refined, solve_radiosity

pytestmark = pytest.mark.filterwarnings("error::lumijax.errors.LumijaxWarning")


@pytest.fixture
def store(tmp_path, monkeypatch):
    """A store under tmp_path, JAX's compilation cache new and empty, this process's loaded
    programs and warnings reset (they are said once per process)."""
    from jax._src import compilation_cache as cc

    monkeypatch.setattr(_jit_cache, "_enabled", tmp_path)
    monkeypatch.setattr(_executables, "_warned", set())
    monkeypatch.setattr(_executables, "_loaded", {})
    (tmp_path / "jax").mkdir()
    monkeypatch.setattr(cc, "_cache", _jit_cache.VerifiedFileCache(tmp_path / "jax"))
    return tmp_path / "executables"


def forget():
    """This process's loaded programs dropped: the next call reads the store."""
    _executables._loaded.clear()


def traces(fn):
    """``fn()``'s value and the names of the functions JAX traced for it."""
    names: list[str] = []

    def listen(event, duration, **kw):
        if event == "/jax/core/compile/jaxpr_trace_duration":
            names.append(kw.get("fun_name", "?"))

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        return fn(), names
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)


def problem(cube_room, columns=2):
    p, _, op = cube_room
    b0 = np.random.default_rng(1).uniform(0.0, 100.0, (p.n, columns))
    return op, jnp.full(p.n, 0.7), jnp.asarray(b0)


def store_off(op, rho, b0, **kw):
    """The same solve with the store off (the jitted body, as a library call runs it)."""
    with pytest.MonkeyPatch.context() as m:
        m.setattr(_jit_cache, "_enabled", None)
        return solve_radiosity(op, rho, b0, **kw)


def test_a_stored_solve_is_not_traced_again_and_gives_the_same_bits(store, cube_room):
    # the default method, iterating: GMRES's LAPACK custom calls are stored too
    op, rho, b0 = problem(cube_room)
    iterating = Refined(direct=False)
    first = solve_radiosity(op, rho, b0, solver=iterating)
    files = list(store.glob(f"radiosity_solve-*{_executables.SUFFIX}"))
    assert len(files) == 1 and files[0].read_bytes().startswith(_executables.MAGIC)
    forget()
    again, traced = traces(lambda: solve_radiosity(op, rho, b0, solver=iterating))
    assert "radiosity_solve" not in traced and "_solve_body" not in traced  # loaded, not traced
    assert np.array_equal(np.asarray(first.value), np.asarray(again.value))
    assert int(first.iterations) == int(again.iterations)
    assert bool(again.stats["closed"]) and again.result == first.result
    # against the store off: the same numbers bit for bit
    off = store_off(op, rho, b0, solver=iterating)
    assert np.array_equal(np.asarray(off.value), np.asarray(first.value))
    assert float(off.residual) == float(first.residual)
    assert np.array_equal(np.asarray(off.escaped), np.asarray(first.escaped))


def test_shapes_and_settings_key_their_own_entries(store, cube_room):
    op, rho, b0 = problem(cube_room)
    solve_radiosity(op, rho, b0, solver="jacobi")
    solve_radiosity(op, rho, b0, solver="jacobi", rtol=1e-3)  # a static value
    solve_radiosity(op, rho, jnp.concatenate([b0, 2 * b0 + 1], axis=1), solver="jacobi")
    assert len(list(store.glob(f"*{_executables.SUFFIX}"))) == 3
    # inside a trace nothing is stored: the jitted body
    jax.jit(lambda r: solve_radiosity(op, r, b0, solver="jacobi", throw=False).value)(rho)
    assert len(list(store.glob(f"*{_executables.SUFFIX}"))) == 3


def test_a_damaged_entry_warns_is_removed_and_changes_no_number(store, cube_room):
    op, rho, b0 = problem(cube_room)
    want = np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value)
    (file,) = store.glob(f"*{_executables.SUFFIX}")
    whole = file.read_bytes()
    damaged = {"corrupted": whole[:-7] + bytes([whole[-7] ^ 0xFF]) + whole[-6:],
               "foreign": b"PK\x03\x04 not an export at all" + bytes(64),
               "truncated": whole[: len(_executables.MAGIC) + 5]}
    for why, data in damaged.items():
        _executables._warned.clear()  # said once per process
        forget()
        file.write_bytes(data)
        with pytest.warns(LumijaxWarning, match="ignored and rebuilt") as caught:
            got = np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value)
        assert str(file) in str(caught[0].message), why
        assert np.array_equal(got, want), why
        # removed: JAX's cache holds the program, whose executable is not stored again
        assert not file.exists(), why
    # and read back without a word
    forget()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.array_equal(np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value),
                              want)


def test_an_unwritable_folder_warns_and_solves(store, cube_room):
    store.parent.mkdir(parents=True, exist_ok=True)
    store.write_text("a file where the folder should be")  # mkdir fails, even as root
    op, rho, b0 = problem(cube_room)
    with pytest.warns(LumijaxWarning, match="cannot write stored programs"):
        got = solve_radiosity(op, rho, b0, solver="jacobi")
    want = store_off(op, rho, b0, solver="jacobi")
    assert np.array_equal(np.asarray(got.value), np.asarray(want.value))
    assert store.is_file()


def test_the_key_refuses_what_it_cannot_pin_down():
    x = jnp.ones(3)
    leaves, treedef = jax.tree.flatten(x)
    assert _executables._key("f", "c", treedef, (1.5, "refined"), leaves) is not None
    assert _executables._key("f", "c", treedef, (lambda: 0,), leaves) is None  # repr with address
    k1 = _executables._key("f", "c", treedef, (1.5,), leaves)
    k2 = _executables._key("f", "c", treedef, (1.5000000000000002,), leaves)
    k3 = _executables._key("f", "d", treedef, (1.5,), leaves)
    assert len({k1, k2, k3}) == 3
    assert _executables.source_digest("radiosity/") != _executables.source_digest("radiosity/_solve.py")


def test_an_executable_from_jaxs_cache_is_not_stored(store, cube_room):
    # XLA:CPU 0.10 loses the code of an executable loaded from JAX's cache when it is
    # serialised again (a new process then fails: "Function ... not found"): such a compile
    # leaves the store as it is and the call gives the same bits
    op, rho, b0 = problem(cube_room)
    want = np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value)
    (file,) = store.glob(f"*{_executables.SUFFIX}")
    file.unlink()
    forget()
    got = np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value)
    assert np.array_equal(got, want)
    assert not list(store.glob(f"*{_executables.SUFFIX}"))


NEW_PROCESS = """
import json, sys, jax, numpy as np
jax.config.update("jax_enable_x64", True)
from lumijax._jit_cache import enable_compilation_cache
enable_compilation_cache()
import trimesh
from lumijax.radiosity import Refined, build_operator, mesh_patches, partition, solve_radiosity
names = []
jax.monitoring.register_event_duration_secs_listener(
    lambda e, d, **kw: names.append(kw.get("fun_name", "?"))
    if e == "/jax/core/compile/jaxpr_trace_duration" else None)
mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
mesh.invert()
p = mesh_patches(mesh.triangles, patch_size=0.15)
op = build_operator(p, partition(p, 512, occluders=mesh.triangles), mesh.triangles)
b0 = np.random.default_rng(1).uniform(0.0, 100.0, (p.n, 2))
out = solve_radiosity(op, np.full(p.n, 0.7), b0, solver=Refined(direct=False))
print(json.dumps({"b": np.asarray(out.value).tolist(), "traced": names}))
"""


def test_a_new_process_loads_the_stored_solve_and_gives_the_same_bits(tmp_path):
    # the store's point: a process that did not compile the program runs it (an executable
    # that loads in its own process can still lack its code in another)
    import json
    import os
    import subprocess
    import sys

    env = dict(os.environ, LUMIJAX_JAX_CACHE=str(tmp_path))
    runs = []
    for _ in range(2):
        proc = subprocess.run([sys.executable, "-c", NEW_PROCESS], env=env,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-3000:]
        runs.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    assert list(tmp_path.rglob(f"radiosity_solve-*{_executables.SUFFIX}"))
    assert "radiosity_solve" in runs[0]["traced"] and "radiosity_solve" not in runs[1]["traced"]
    assert runs[0]["b"] == runs[1]["b"]
