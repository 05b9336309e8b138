"""The solve's stored export (lumijax/_export.py): a later call deserialises the program instead
of tracing it and gives the same bits; a corrupted, foreign or unwritable store warns and never
changes a number. The store is on only where the compilation cache is: here its folder is set
by hand (``_jit_cache._enabled``), so JAX's own cache is left as the suite has it."""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax import _export, _jit_cache
from lumijax.errors import LumijaxWarning
from lumijax.radiosity import solve_radiosity

pytestmark = pytest.mark.filterwarnings("error::lumijax.errors.LumijaxWarning")


@pytest.fixture
def store(tmp_path, monkeypatch):
    """An export folder under tmp_path, warnings reset (they are said once per process)."""
    monkeypatch.setattr(_jit_cache, "_enabled", tmp_path)
    monkeypatch.setattr(_export, "_warned", set())
    return tmp_path / "export"


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
    # the default method: GMRES's LAPACK custom calls are exported too
    op, rho, b0 = problem(cube_room)
    first = solve_radiosity(op, rho, b0)
    files = list(store.glob("radiosity_solve-*.ljxe"))
    assert len(files) == 1 and files[0].read_bytes().startswith(_export.MAGIC)
    again, traced = traces(lambda: solve_radiosity(op, rho, b0))
    assert "flat" not in traced and "_solve_body" not in traced  # deserialised, not traced
    assert np.array_equal(np.asarray(first.value), np.asarray(again.value))
    assert int(first.iterations) == int(again.iterations)
    assert bool(again.stats["closed"]) and again.result == first.result
    # against the store off: the same numbers bit for bit
    off = store_off(op, rho, b0)
    assert np.array_equal(np.asarray(off.value), np.asarray(first.value))
    assert float(off.residual) == float(first.residual)
    assert np.array_equal(np.asarray(off.escaped), np.asarray(first.escaped))


def test_shapes_and_settings_key_their_own_entries(store, cube_room):
    op, rho, b0 = problem(cube_room)
    solve_radiosity(op, rho, b0, solver="jacobi")
    solve_radiosity(op, rho, b0, solver="jacobi", rtol=1e-3)  # a static value
    solve_radiosity(op, rho, jnp.concatenate([b0, 2 * b0 + 1], axis=1), solver="jacobi")
    assert len(list(store.glob("*.ljxe"))) == 3
    # inside a trace nothing is stored: the jitted body
    jax.jit(lambda r: solve_radiosity(op, r, b0, solver="jacobi", throw=False).value)(rho)
    assert len(list(store.glob("*.ljxe"))) == 3


def test_a_damaged_entry_warns_and_is_rebuilt(store, cube_room):
    op, rho, b0 = problem(cube_room)
    want = np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value)
    (file,) = store.glob("*.ljxe")
    whole = file.read_bytes()
    damaged = {"corrupted": whole[:-7] + bytes([whole[-7] ^ 0xFF]) + whole[-6:],
               "foreign": b"PK\x03\x04 not an export at all" + bytes(64),
               "truncated": whole[: len(_export.MAGIC) + 5]}
    for why, data in damaged.items():
        _export._warned.clear()  # said once per process
        file.write_bytes(data)
        with pytest.warns(LumijaxWarning, match="ignored and rebuilt") as caught:
            got = np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value)
        assert str(file) in str(caught[0].message), why
        assert np.array_equal(got, want), why
        assert file.read_bytes().startswith(_export.MAGIC), why  # rebuilt whole
    # and read back without a word
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.array_equal(np.asarray(solve_radiosity(op, rho, b0, solver="jacobi").value),
                              want)


def test_an_unwritable_folder_warns_and_solves(store, cube_room):
    store.parent.mkdir(parents=True, exist_ok=True)
    store.write_text("a file where the folder should be")  # mkdir fails, even as root
    op, rho, b0 = problem(cube_room)
    with pytest.warns(LumijaxWarning, match="cannot write exported programs"):
        got = solve_radiosity(op, rho, b0, solver="jacobi")
    want = store_off(op, rho, b0, solver="jacobi")
    assert np.array_equal(np.asarray(got.value), np.asarray(want.value))
    assert store.is_file()


def test_the_key_refuses_what_it_cannot_pin_down():
    x = jnp.ones(3)
    leaves, treedef = jax.tree.flatten(x)
    assert _export._key("f", "c", treedef, (1.5, "refined"), leaves) is not None
    assert _export._key("f", "c", treedef, (lambda: 0,), leaves) is None  # repr with address
    k1 = _export._key("f", "c", treedef, (1.5,), leaves)
    k2 = _export._key("f", "c", treedef, (1.5000000000000002,), leaves)
    k3 = _export._key("f", "d", treedef, (1.5,), leaves)
    assert len({k1, k2, k3}) == 3
    assert _export.source_digest("radiosity/") != _export.source_digest("radiosity/_solve.py")
