"""A full numbers run's dimmer-only rerun (``lumijax._stored``): ``lumijax run --no-images
--no-report`` on a study that changed only its dimmers answers from the stored per-network
solution (results.json at every wavelength, the grids' CSV, patches.vtp) without importing JAX,
and writes what a full computation at those dimmers writes."""

from __future__ import annotations

import base64
import json
import os
import re
import zlib
from pathlib import Path

import numpy as np
import pytest
from helpers import box_room, run_in_new_process_without_jax

import lumijax
from lumijax import load_study
from lumijax._stored import solution_key
from lumijax.cli import main
from lumijax.config import load_config
from lumijax.report._vtk import write_patches_vtp

SOLVER = "target_patches = 150\ngather_rays = 32"
NUMBERS = ["--no-images", "--no-report"]


def _doc(out: Path) -> dict:
    return json.loads((out / "results.json").read_text())


def _numbers(value, path="") -> dict[str, float]:
    """Every number in a results.json document by its path; bools and strings as themselves
    (``timing_s`` and the run's own flags left out: they describe the run, not the light)."""
    if isinstance(value, dict):
        out: dict = {}
        for k, v in value.items():
            if path == "" and k == "timing_s" or k in ("solution_reused", "recorded_study",
                                                       "operator_cache_hit"):
                continue
            out.update(_numbers(v, f"{path}.{k}"))
        return out
    if isinstance(value, list):
        out = {}
        for i, v in enumerate(value):
            out.update(_numbers(v, f"{path}[{i}]"))
        return out
    return {path: value}


def _assert_same_numbers(a: dict, b: dict, rtol: float) -> None:
    na, nb = _numbers(a), _numbers(b)
    assert na.keys() == nb.keys()
    for k, va in na.items():
        vb = nb[k]
        if isinstance(va, float) or isinstance(vb, float):
            assert vb == pytest.approx(va, rel=rtol, abs=1e-300), k
        else:
            assert va == vb, k


def _vtp_arrays(path: Path) -> dict[str, np.ndarray]:
    """patches.vtp's arrays, decoded from the VTK XML format (one zlib block each behind a
    UInt64 header: VTK's layout, written independently of the reader here)."""
    types = {"Float64": "<f8", "Float32": "<f4", "Int64": "<i8", "Int32": "<i4", "UInt8": "u1"}
    out = {}
    for m in re.finditer(rb'<DataArray type="(\w+)" Name="([^"]+)"[^>]*format="binary">'
                         rb"([^<]*)</DataArray>", path.read_bytes()):
        kind, name, body = m.group(1).decode(), m.group(2).decode(), m.group(3)
        head = np.frombuffer(base64.b64decode(body[:44]), "<u8")  # 4 × 8 bytes in base64
        raw = zlib.decompress(base64.b64decode(body[44:])) if head[0] else b""
        out[name] = np.frombuffer(raw, types[kind])
    return out


def _write(study: Path, *, dimmer_a: float, extra_solver: str = "") -> None:
    study.parent.mkdir(exist_ok=True)
    study.write_text(box_room(SOLVER + extra_solver, dimmer_a=dimmer_a), encoding="utf-8")


def test_a_full_numbers_rerun_equals_a_full_computation_and_imports_no_jax(tmp_path):
    study = tmp_path / "study" / "study.toml"
    _write(study, dimmer_a=0.2)
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    assert "solution_reused" not in _doc(out)["solver"]
    _write(study, dimmer_a=0.7)
    # a new process, as a user runs it: it must answer without importing JAX at all
    rerun = run_in_new_process_without_jax(study, out, *NUMBERS)
    assert rerun["solver"]["solution_reused"] is True
    assert rerun["networks"]["a"]["dimmer"] == 0.7
    assert sorted(p.name for p in out.iterdir()) == ["grids", "patches.vtp", "results.json"]
    assert "xyz" in rerun["grids"]["floor"] and "cct_k" in rerun["grids"]["floor"]
    # the same study computed in full at 0.7 in a folder of its own (its own caches)
    fresh_study = tmp_path / "fresh" / "study.toml"
    _write(fresh_study, dimmer_a=0.7)
    fresh = tmp_path / "fresh-out"
    assert main(["run", str(fresh_study), "--out", str(fresh), *NUMBERS]) == 0
    assert "solution_reused" not in _doc(fresh)["solver"]
    _assert_same_numbers(_doc(fresh), rerun, rtol=1e-12)
    assert len(_numbers(rerun)) > 700  # 48 points: their lux, direct lux, XYZ, CCT, ...
    assert (out / "grids" / "floor.csv").read_text() == (fresh / "grids" / "floor.csv").read_text()
    assert (out / "patches.vtp").read_bytes() == (fresh / "patches.vtp").read_bytes()
    # patches.vtp as a run with no store writes it: the irradiance from one operator product
    # at the dimmers, not from the stored per-network products; the same light within the
    # operator's float32 rounding, every other array the same (the operator from the cache)
    res = lumijax.compute(load_study(fresh_study))
    write_patches_vtp(res.lighting, res.design.dimmers, tmp_path / "bare.vtp")
    a, b = _vtp_arrays(tmp_path / "bare.vtp"), _vtp_arrays(out / "patches.vtp")
    assert a.keys() == b.keys() and {"illuminance_lux", "xyz", "srgb"} <= a.keys()
    for name in a:
        if name == "illuminance_lux":
            np.testing.assert_allclose(b[name], a[name], rtol=1e-5, atol=1e-6 * a[name].max())
        else:
            np.testing.assert_array_equal(b[name], a[name], err_msg=name)


def test_quick_and_full_solutions_are_never_confused(tmp_path):
    # a study that asks for the photometric solve itself: --quick changes nothing in its
    # config, yet the --quick solution (no patches, no vtp) must not answer a full run
    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER + "\nspectral_samples = 0"), encoding="utf-8")
    cfg = load_config(study)
    assert solution_key(cfg, full=True) != solution_key(cfg)
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    assert "solution_reused" not in _doc(out)["solver"]
    assert (out / "patches.vtp").is_file()
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0
    assert _doc(out)["solver"]["solution_reused"] is True
    assert not (out / "patches.vtp").exists()
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    assert _doc(out)["solver"]["solution_reused"] is True
    assert (out / "patches.vtp").is_file()


def test_images_are_drawn_from_a_computation_which_then_answers_numbers_runs(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--no-report"]) == 0
    assert (out / "images" / "floor.png").is_file()
    # images need the scene: a second run with them computes again
    assert main(["run", str(study), "--out", str(out), "--no-report"]) == 0
    assert "solution_reused" not in _doc(out)["solver"]
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    assert _doc(out)["solver"]["solution_reused"] is True


def test_a_moved_luminaire_computes_again(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    before = np.asarray(_doc(out)["grids"]["floor"]["illuminance_lux"])
    study.write_text(box_room(SOLVER).replace("position = [1, 1.5, 2.5]",
                                              "position = [1.1, 1.5, 2.5]"), encoding="utf-8")
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    doc = _doc(out)
    assert "solution_reused" not in doc["solver"]
    after = np.asarray(doc["grids"]["floor"]["illuminance_lux"])
    # lamp A moved 0.1 m along x: the floor's light moved with it
    assert not np.allclose(after, before, rtol=1e-3)


#: Every kind of change that is not a dimmer, as an edit of the study's text.
CHANGES = {
    "flux": ("flux_lm = 2000", "flux_lm = 2100"),
    "position": ("position = [1, 1.5, 2.5]", "position = [1.1, 1.5, 2.5]"),
    "aim": ('network = "a"', 'network = "a"\naim = { tilt = 10.0 }'),
    "material": ("reflectance = 0.5", "reflectance = 0.6"),
    "grid": ("nu = 8", "nu = 9"),
    "solver": ("gather_rays = 32", "gather_rays = 64"),
}


@pytest.mark.parametrize("full", [False, True], ids=["quick", "full"])
def test_anything_but_a_dimmer_is_a_new_key(tmp_path, shared_photometry, full):
    study = tmp_path / "study.toml"
    text = box_room(SOLVER)
    study.write_text(text, encoding="utf-8")
    key = solution_key(load_config(study), full=full)
    study.write_text(text.replace("dimmer = 0.5", "dimmer = 0.9"), encoding="utf-8")
    assert solution_key(load_config(study), full=full) == key
    for name, (old, new) in CHANGES.items():
        assert text.count(old) >= 1, name
        study.write_text(text.replace(old, new, 1), encoding="utf-8")
        assert solution_key(load_config(study), full=full) != key, name
    # a photometry file's bytes, its name and every key the same
    real = (shared_photometry / "er_ITALO_1_5P5_S05_3.140-3M.IES").read_bytes()
    ies = tmp_path / "lamp.ies"
    ies.write_bytes(real)
    text = text.replace('kind = "isotropic"\nflux_lm = 2000', 'file = "lamp.ies"')
    study.write_text(text, encoding="utf-8")
    key = solution_key(load_config(study), full=full)
    ies.write_bytes(real.replace(b"\n", b"\r\n", 1))
    assert solution_key(load_config(study), full=full) != key


def test_a_cache_folder_keeps_the_newest_solutions_only(tmp_path):
    # solutions of studies since edited in other ways than dimmers are never read again
    from lumijax._stored import KEEP, load_solution, store_solution
    from lumijax.results import Results

    res = Results(study="s", grids={}, networks={"a": {"dimmer": 1.0}})
    keys = [f"{i:064x}" for i in range(KEEP + 3)]
    for i, key in enumerate(keys):
        path = store_solution(res, tmp_path, key)
        os.utime(path, (1e9 + i, 1e9 + i))  # the order they were written in, to the second
    kept = sorted(p.name for p in tmp_path.glob("solution-*.npz"))
    assert kept == sorted(f"solution-{k}.npz" for k in keys[-KEEP:])
    assert load_solution(tmp_path, keys[-1]).document["study"] == "s"
    assert load_solution(tmp_path, keys[0]) is None  # pruned: computed again, no warning


def test_a_corrupted_full_solution_is_recomputed_with_a_warning(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    expected = (out / "patches.vtp").read_bytes()
    (path,) = (tmp_path / ".lumijax-cache").glob("solution-*.npz")
    assert path.name == f"solution-{solution_key(load_config(study), full=True)}.npz"
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    capsys.readouterr()
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    printed = capsys.readouterr().out
    assert "stored solution" in printed and "digest" in printed
    assert "solution_reused" not in _doc(out)["solver"]
    assert (out / "patches.vtp").read_bytes() == expected
    # and the solution it stored again answers the next run
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    assert _doc(out)["solver"]["solution_reused"] is True


def test_a_study_whose_patches_are_too_large_to_keep_always_computes(tmp_path, monkeypatch):
    import lumijax._stored

    study = tmp_path / "study.toml"
    study.write_text(box_room(SOLVER), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
    key = solution_key(load_config(study), full=True)
    needed = tmp_path / ".lumijax-cache" / f"solution-{key}.npz"
    assert needed.is_file()
    needed.unlink()
    # this study's ~150 patches take more than 4 kB (their triangles alone: 150 × 9
    # coordinates): a cap of 4 kB stores nothing
    monkeypatch.setattr(lumijax._stored, "MAX_PATCH_BYTES", 4096)
    for _ in range(2):
        assert main(["run", str(study), "--out", str(out), *NUMBERS]) == 0
        assert "solution_reused" not in _doc(out)["solver"]
        assert (out / "patches.vtp").is_file()
    assert not needed.exists()
