"""A study file's record (``lumijax._recorded``): a numbers run of a study that an earlier run
validated, dimmers aside, answers from the stored solution without the config's schema — and
anything the record cannot vouch for goes the validated way, which names what is wrong."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import box_room, mesh, run_in_new_process_without_jax, study_text

from lumijax import _dimmers
from lumijax._recorded import read_study, record_path
from lumijax.cli import main
from lumijax.config import NetworkConfig

SOLVER = "target_patches = 150\ngather_rays = 32"
QUICK = {"quick": True, "shadows": True, "optimise": True}
#: what the record's rerun must not import: JAX, the schema (pydantic) and the config package
UNVALIDATED = ("jax", "pydantic", "lumijax.config")


def _doc(out: Path) -> dict:
    return json.loads((out / "results.json").read_text())


def _lux(out: Path) -> np.ndarray:
    return np.asarray(_doc(out)["grids"]["floor"]["illuminance_lux"])


def _quick(study: Path, out: Path) -> None:
    assert main(["run", str(study), "--out", str(out), "--quick"]) == 0


def _computed(folder: Path, text: str) -> tuple[Path, Path]:
    """The study ``text`` written in ``folder`` and run once (``--quick``): (study, out)."""
    folder.mkdir(exist_ok=True)
    study, out = folder / "study.toml", folder / "out"
    study.write_text(text, encoding="utf-8")
    _quick(study, out)
    return study, out


def _records(folder: Path) -> list[Path]:
    return sorted((folder / ".lumijax-cache").glob("record-*.json"))


def test_an_unchanged_study_answers_from_its_record_as_it_computed(tmp_path):
    # (a dimmer changed: tests/cli/test_rerun.py, against a study computed from nothing)
    study, out = _computed(tmp_path / "study", box_room(SOLVER, dimmer_a=0.5))
    assert len(_records(study.parent)) == 1
    computed = _lux(out)
    same = run_in_new_process_without_jax(study, out, "--quick", without=UNVALIDATED)
    assert same["solver"]["recorded_study"] is True
    np.testing.assert_allclose(_lux(out), computed, rtol=1e-12)
    # a network whose table gives no dimmer is at the default (1), as the schema makes it
    study.write_text(box_room(SOLVER, dimmer_a=None), encoding="utf-8")
    _quick(study, out)
    assert _doc(out)["solver"]["recorded_study"] is True
    assert _doc(out)["networks"]["a"]["dimmer"] == 1.0
    assert len(_records(study.parent)) == 1  # one record for both: dimmers are not its key


def test_a_named_file_with_new_bytes_is_computed_again(tmp_path):
    obj = tmp_path / "panel.obj"
    obj.write_text("v 1 1 0.5\nv 3 1 0.5\nv 1 2 0.5\nf 1 2 3\n", encoding="utf-8")
    study, out = _computed(tmp_path, box_room(SOLVER) + study_text(mesh("panel.obj")))
    _quick(study, out)
    assert _doc(out)["solver"]["recorded_study"] is True
    before = _lux(out)
    # the same study file, a larger panel (over the floor: less light reaches it)
    obj.write_text("v 0.5 0.5 0.5\nv 3.5 0.5 0.5\nv 0.5 2.5 0.5\nf 1 2 3\n", encoding="utf-8")
    _quick(study, out)
    assert "solution_reused" not in _doc(out)["solver"]
    assert not np.allclose(_lux(out), before, rtol=1e-3)


@pytest.mark.parametrize("dimmer", ["1.5", "-0.1", "true", "nan", '"0.5"'])
def test_a_dimmer_the_record_cannot_vouch_for_goes_the_validated_way(tmp_path, capsys, dimmer):
    study, out = _computed(tmp_path, box_room(SOLVER))
    study.write_text(box_room(SOLVER).replace("dimmer = 0.5", f"dimmer = {dimmer}"),
                     encoding="utf-8")
    assert read_study(study, QUICK).key is None
    capsys.readouterr()
    rc = main(["run", str(study), "--out", str(out), "--quick"])
    # the schema's verdict: a number from 0 to 1 (pydantic reads the string "0.5" and the
    # boolean true as numbers: the record leaves that reading to it)
    if dimmer in ('"0.5"', "true"):
        assert rc == 0 and "recorded_study" not in _doc(out)["solver"]
        assert _doc(out)["networks"]["a"]["dimmer"] == {"true": 1.0}.get(dimmer, 0.5)
    else:
        assert rc == 1
        assert "networks.a.dimmer" in capsys.readouterr().err


def test_the_key_is_the_file_without_its_dimmers_and_the_runs_options(tmp_path):
    study = tmp_path / "study.toml"
    text = box_room(SOLVER)
    study.write_text(text, encoding="utf-8")
    first = read_study(study, QUICK)
    assert first.dimmers == {"a": 0.5, "b": 1.0} and first.text == text
    study.write_text(text.replace("dimmer = 0.5", "dimmer = 1"), encoding="utf-8")
    assert read_study(study, QUICK).key == first.key
    assert read_study(study, QUICK).dimmers == {"a": 1.0, "b": 1.0}
    for option in QUICK:
        assert read_study(study, {**QUICK, option: not QUICK[option]}).key != first.key
    # any other value, and the same tables in another order (the validated way decides)
    study.write_text(text.replace("flux_lm = 2000", "flux_lm = 2000.0"), encoding="utf-8")
    assert read_study(study, QUICK).key != first.key
    materials = "[materials.wall]\nreflectance = 0.5\n"
    photometry = '[photometry.iso]\nkind = "isotropic"\nflux_lm = 2000\n'
    assert materials + photometry in text
    study.write_text(text.replace(materials + photometry, photometry + materials),
                     encoding="utf-8")
    assert read_study(study, QUICK).key != first.key
    # the same text elsewhere: its relative paths would name other files
    moved = tmp_path / "elsewhere" / "study.toml"
    moved.parent.mkdir()
    moved.write_text(text, encoding="utf-8")
    assert read_study(moved, QUICK).key != first.key
    # no TOML: no key, and the validated way names the line
    study.write_text(text + "\n[broken\n", encoding="utf-8")
    assert read_study(study, QUICK).key is None
    assert read_study(tmp_path / "missing.toml", QUICK) is None


@pytest.mark.parametrize("damage", ["truncated", "another key", "not json"])
def test_a_damaged_record_is_ignored_with_a_warning_and_written_again(tmp_path, capsys, damage):
    study, out = _computed(tmp_path, box_room(SOLVER))
    expected = _lux(out)
    path = record_path(tmp_path / ".lumijax-cache", read_study(study, QUICK).key)
    text = path.read_text()
    path.write_text({"truncated": text[: len(text) // 2],
                     "another key": text.replace('"key": "', '"key": "0'),
                     "not json": "\x00\x01"}[damage])
    capsys.readouterr()
    _quick(study, out)
    assert "study record" in capsys.readouterr().out
    # answered the validated way, from the stored solution, which writes the record again
    assert _doc(out)["solver"]["solution_reused"] is True
    assert "recorded_study" not in _doc(out)["solver"]
    np.testing.assert_allclose(_lux(out), expected, rtol=1e-12)
    _quick(study, out)
    assert _doc(out)["solver"]["recorded_study"] is True


def test_the_records_dimmer_range_and_default_are_the_schemas():
    assert NetworkConfig().dimmer == _dimmers.DEFAULT
    for ok in (_dimmers.LOW, _dimmers.HIGH):
        assert NetworkConfig(dimmer=ok).dimmer == ok
    for bad in (np.nextafter(_dimmers.LOW, -1), np.nextafter(_dimmers.HIGH, 2)):
        with pytest.raises(ValueError):
            NetworkConfig(dimmer=float(bad))
