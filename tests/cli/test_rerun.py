"""The iterate loop's dimmer-only rerun (``lumijax._stored``): ``lumijax run --quick`` on a
study that changed only its dimmers answers from the stored per-network solution, without
importing JAX, and gives what a fresh computation gives."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import box_room, mesh, run_in_new_process_without_jax, study_text

from lumijax._stored import solution_key, solution_path
from lumijax.cli import main
from lumijax.config import load_config

SOLVER = "target_patches = 150\ngather_rays = 32"


def _lux(out: Path) -> np.ndarray:
    return np.asarray(json.loads((out / "results.json").read_text())["grids"]["floor"]
                      ["illuminance_lux"])


def _doc(out: Path) -> dict:
    return json.loads((out / "results.json").read_text())


def test_a_dimmer_only_rerun_equals_a_fresh_computation_and_imports_no_jax(tmp_path):
    study = tmp_path / "study" / "study.toml"
    study.parent.mkdir()
    study.write_text(box_room(SOLVER, dimmer_a=0.5), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0
    assert "solution_reused" not in _doc(out)["solver"]
    study.write_text(box_room(SOLVER, dimmer_a=0.2), encoding="utf-8")
    # a new process, as a user runs it: it must answer without importing JAX at all, nor the
    # config's schema (the first run recorded the study file: lumijax._recorded)
    rerun = run_in_new_process_without_jax(study, out, "--quick",
                                           without=("jax", "pydantic", "lumijax.config"))
    assert rerun["solver"]["solution_reused"] is True
    assert rerun["solver"]["recorded_study"] is True
    assert rerun["networks"]["a"]["dimmer"] == 0.2
    assert sorted(p.name for p in out.iterdir()) == ["grids", "results.json"]
    # the independent answer: the same study computed from nothing (no cache at all)
    fresh_study = tmp_path / "fresh" / "study.toml"
    fresh_study.parent.mkdir()
    fresh_study.write_text(box_room(SOLVER + "\ncache = false", dimmer_a=0.2), encoding="utf-8")
    fresh = tmp_path / "fresh-out"
    assert main(["run", str(fresh_study), "--out", str(fresh), "--quick"]) == 0
    np.testing.assert_allclose(_lux(out), _lux(fresh), rtol=1e-6)
    f = _doc(fresh)["grids"]["floor"]
    r = rerun["grids"]["floor"]
    for key in ("avg", "min", "max", "u0"):
        assert r["stats"][key] == pytest.approx(f["stats"][key], rel=1e-6)
    np.testing.assert_allclose(r["direct_lux"], f["direct_lux"], rtol=1e-6)
    # the CSV carries the new lux too
    csv = np.loadtxt(out / "grids" / "floor.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(csv[:, 3], _lux(fresh), rtol=1e-5)


def test_anything_but_a_dimmer_computes_again(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0
    before = _lux(out)
    study.write_text(box_room(SOLVER).replace("reflectance = 0.5", "reflectance = 0.7"),
                     encoding="utf-8")
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0
    assert "solution_reused" not in _doc(out)["solver"]
    # more reflected light: the reflectance change was computed, not superposed
    assert _lux(out).mean() > 1.1 * before.mean()


def test_a_corrupted_stored_solution_is_recomputed_with_a_warning(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0
    expected = _lux(out)
    path = solution_path(tmp_path / ".lumijax-cache", solution_key(
        load_config(study).model_copy(update={"solver": load_config(study).solver.model_copy(
            update={"spectral_samples": 0})})))
    assert path.is_file()
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    capsys.readouterr()
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0
    printed = capsys.readouterr().out
    assert "stored solution" in printed and "digest" in printed
    assert "solution_reused" not in _doc(out)["solver"]
    np.testing.assert_allclose(_lux(out), expected, rtol=1e-6)


def test_the_key_ignores_dimmers_and_reads_the_files_a_config_names(tmp_path):
    obj = tmp_path / "tri.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", encoding="utf-8")
    text = box_room(SOLVER) + study_text(mesh("tri.obj"))
    study = tmp_path / "study.toml"
    study.write_text(text, encoding="utf-8")
    key = solution_key(load_config(study))
    study.write_text(text.replace("dimmer = 0.5", "dimmer = 0.9"), encoding="utf-8")
    assert solution_key(load_config(study)) == key
    assert solution_key(load_config(study), shadows=False) != key
    obj.write_text("v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n", encoding="utf-8")
    assert solution_key(load_config(study)) != key


def test_the_key_reads_the_environments_64_bit_switch(tmp_path, monkeypatch):
    # JAX_ENABLE_X64 makes the whole process 64-bit whatever [solver] precision says: a
    # solution computed under it must not answer a run without it, nor the other way round
    from lumijax._stored import code_digest

    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER), encoding="utf-8")
    monkeypatch.delenv("JAX_ENABLE_X64", raising=False)
    code_digest.cache_clear()
    key = solution_key(load_config(study))
    monkeypatch.setenv("JAX_ENABLE_X64", "1")
    code_digest.cache_clear()
    try:
        assert solution_key(load_config(study)) != key
    finally:
        code_digest.cache_clear()
