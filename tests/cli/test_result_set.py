"""A results folder is one consistent set: staged, swapped in as one step, locked, and what a
killed run leaves is cleaned by the next (issue 12 §5).

The writer runs on stand-in results (numpy only, no compute) so that a helper process can fork
one writer per kill point cheaply; each forked writer SIGKILLs itself at its step.
"""

from __future__ import annotations

import csv
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lumijax._atomic import FolderLock, exchange_paths
from lumijax.errors import OutputError
from lumijax.report import _write
from lumijax.report._write import write_results

sys.path.insert(0, str(Path(__file__).parent))
from stub_results import BASE_LUX, Stub  # noqa: E402


def _snapshot(out: Path) -> dict[str, str] | None:
    if not out.is_dir():
        return None
    return {str(p.relative_to(out)): p.read_text() for p in sorted(out.rglob("*")) if p.is_file()}


def _set_dimmer(files: dict[str, str]) -> float:
    """The one dimmer the whole set was written at, checked file by file against the lux a
    dimmer gives (lux = d × BASE_LUX, known here independently of the writer)."""
    res = json.loads(files["results.json"])
    d = res["dimmer"]
    assert sorted(files) == ["grids/floor.csv", "grids/wall.csv", "results.json"]
    for name, base in BASE_LUX.items():
        np.testing.assert_allclose(res["grids"][name]["illuminance_lux"], d * base, rtol=1e-12)
        rows = list(csv.DictReader(io.StringIO(files[f"grids/{name}.csv"])))
        np.testing.assert_allclose([float(r["lux"]) for r in rows], d * base, rtol=1e-5)
    return d


HELPER = '''
import json, os, signal, sys
from pathlib import Path
sys.path.insert(0, HERE)
from stub_results import Stub
from lumijax.report import _write as w

out, steps = Path(sys.argv[1]), json.loads(sys.argv[2])
exchange = w.exchange_paths

def snap():
    if not out.is_dir():
        return None
    return {str(p.relative_to(out)): p.read_text() for p in out.rglob("*") if p.is_file()}

def siblings():
    return sorted(p.name for p in out.parent.iterdir() if p.name != out.name)

report = []
for step, atomic_swap in steps:
    w.exchange_paths = exchange if atomic_swap else (lambda a, b: False)
    w.write_results(Stub(0.5), out, images=False)  # the old set
    pid = os.fork()
    if pid == 0:
        def hook(name):
            if name == step:
                os.kill(os.getpid(), signal.SIGKILL)
        w._step = hook
        w.write_results(Stub(0.1), out, images=False)
        os._exit(0)
    _, status = os.waitpid(pid, 0)
    entry = {"step": step, "killed": os.WIFSIGNALED(status), "files": snap(),
             "left": siblings()}
    with w.ResultSet(out):  # the next run: it cleans up before it writes anything
        pass
    entry["after_next_open"] = siblings()
    entry["files_after_next_open"] = snap()
    report.append(entry)
print(json.dumps(report))
'''.replace("HERE", repr(str(Path(__file__).parent)))

STEPS = ["wrote results.json", "wrote grids/floor.csv", "wrote grids/wall.csv", "synced",
         "kept", "swapped", "cleaned"]


def _kill_at_each_step(tmp_path, steps):
    """One helper process; per (step, atomic swap?) an old set, then a forked writer of the
    new set killed at that step, then what the next run's opening of the folder leaves."""
    out = tmp_path / "sets" / "out"
    out.parent.mkdir()
    proc = subprocess.run([sys.executable, "-c", HELPER, str(out), json.dumps(steps)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.splitlines()[-1])


def test_kill_9_at_each_step_leaves_the_old_or_the_new_set(tmp_path):
    """kill -9 at every step of writing a set: ``out`` is always one complete set, at one
    dimmer, and the next run leaves no staging, old or lock file behind. With the two-rename
    fallback, a kill between them leaves no folder for a moment; the next run puts the old set
    back before anything else."""
    atomic = _can_exchange(tmp_path)
    steps = [[s, True] for s in STEPS] if atomic else []
    report = _kill_at_each_step(tmp_path, steps + [["moved-old", False], ["swapped", False]])
    seen = {}
    for e in report[: len(steps)]:
        assert e["killed"], e["step"]
        seen[e["step"]] = _set_dimmer(e["files"])  # complete and consistent, whatever the step
        assert e["after_next_open"] == []
        assert e["files_after_next_open"] == e["files"]  # cleaning never touches the set
    if atomic:  # before the swap the old set (0.5), from the swap on the new one (0.1)
        assert seen == {s: (0.1 if s in ("swapped", "cleaned") else 0.5) for s in STEPS}
        assert any(n.startswith("out.staging-") for e in report for n in e["left"])
    gap, after = report[len(steps):]
    assert gap["killed"] and gap["files"] is None
    assert any(n.startswith("out.old-") for n in gap["left"])
    assert _set_dimmer(gap["files_after_next_open"]) == 0.5 and gap["after_next_open"] == []
    assert _set_dimmer(after["files"]) == 0.1 and after["after_next_open"] == []


def _can_exchange(tmp_path) -> bool:
    a, b = tmp_path / "xa", tmp_path / "xb"
    a.mkdir()
    b.mkdir()
    (a / "a").touch()
    return exchange_paths(a, b) and (b / "a").exists()


def test_python_api_swaps_in_one_set_and_keeps_the_cache(tmp_path):
    out = tmp_path / "out"
    paths = write_results(Stub(0.5), out, images=False)
    assert set(paths) == {"results.json", "grids/floor.csv", "grids/wall.csv"}
    assert all(p.parent.is_relative_to(out) and p.is_file() for p in paths.values())
    (out / ".lumijax-cache").mkdir()
    (out / ".lumijax-cache" / "transport-k.lmjop").write_bytes(b"op")
    (out / "images").mkdir()
    (out / "images" / "stale.png").write_bytes(b"from an older run")
    write_results(Stub(0.25), out, images=False)
    files = _snapshot(out)
    assert files.pop(".lumijax-cache/transport-k.lmjop") == "op"  # carried over
    assert _set_dimmer(files) == 0.25  # nothing of the old set (images/stale.png) survives
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    mask = os.umask(0)
    os.umask(mask)
    assert (out.stat().st_mode & 0o777) == 0o777 & ~mask
    assert ((out / "results.json").stat().st_mode & 0o777) == 0o666 & ~mask


def test_a_folder_with_other_files_is_never_replaced(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("the user's own")
    with pytest.raises(OutputError, match="'notes.txt', which lumijax did not write") as exc:
        write_results(Stub(0.5), out, images=False)
    assert exc.value.file == str(out)
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


def test_a_second_writer_fails_fast_naming_the_holder(tmp_path):
    out = tmp_path / "out"
    with FolderLock(out):
        with pytest.raises(OutputError, match=rf"another lumijax run \(pid {os.getpid()}\)"):
            write_results(Stub(0.5), out, images=False)
    assert not out.exists()
    write_results(Stub(0.5), out, images=False)  # free again
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_lock_left_by_a_dead_process_is_taken_over(tmp_path):
    out = tmp_path / "out"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    (tmp_path / "out.lock").write_text(f"{dead}\n")
    write_results(Stub(0.5), out, images=False)
    assert _set_dimmer(_snapshot(out)) == 0.5 and not (tmp_path / "out.lock").exists()


def test_cli_run_holds_the_lock_before_it_computes(box_room, write_study, tmp_path, capsys,
                                                   monkeypatch):
    import lumijax._study

    def no_compute(*a, **k):
        raise AssertionError("computed although the folder was locked")

    monkeypatch.setattr(lumijax._study, "compute", no_compute)
    out = tmp_path / "out"
    with FolderLock(out):
        assert main_run(write_study(box_room), out) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"lumijax: error: {out}: another lumijax run (pid {os.getpid()})")


def main_run(cfg, out):
    from lumijax.cli import main

    return main(["run", str(cfg), "--out", str(out), "--no-report", "--no-images"])


def test_step_hook_is_a_no_op_by_default():
    assert _write._step("anything") is None


def test_a_new_folder_and_its_parents_are_created(tmp_path):
    out = tmp_path / "deep" / "er" / "out"
    write_results(Stub(1.0), out, images=False)
    assert sorted(p.name for p in out.parent.iterdir()) == ["out"]


def test_a_killed_report_writers_temporary_is_removed_not_refused(tmp_path):
    out = tmp_path / "out"
    write_results(Stub(0.5), out, images=False)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    orphan = out / f".report.html.lumijax-tmp-{dead}-x1y2.html"
    orphan.write_text("half a report")
    write_results(Stub(0.25), out, images=False)
    assert _set_dimmer(_snapshot(out)) == 0.25 and not orphan.exists()


def test_parent_folders_of_a_locked_folder_are_created(tmp_path):
    out = tmp_path / "a" / "b" / "out"
    with FolderLock(out):
        assert (tmp_path / "a" / "b" / "out.lock").read_text() == f"{os.getpid()}\n"
    assert sorted(p.name for p in (tmp_path / "a" / "b").iterdir()) == []
