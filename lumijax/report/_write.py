"""Write a study's results as one consistent set: results.json, grids/NAME.csv, images/NAME.png,
patches.vtp, optimised.toml and (from the CLI) report.html.

A :class:`ResultSet` writes every file into a staging folder beside the output folder
(``<out>.staging-<pid>-<random>``) and swaps it in as one step: one ``renameat2(RENAME_EXCHANGE)``
on Linux, so ``<out>`` is at every instant either the complete old set or the complete new set,
whatever kills the process; elsewhere two renames (``<out>`` → ``<out>.old-…``, staging →
``<out>``), whose gap a later run repairs by putting the old set back. The output folder is
locked for the set's lifetime (:class:`~lumijax._atomic.FolderLock`, ``<out>.lock``): a second
run into it fails at once, naming the holder's pid. Under the lock, staging and old folders left
by killed runs are removed first (their writers cannot be alive: they held the lock).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from .._atomic import (
    FolderLock,
    exchange_paths,
    file_mode,
    fsync_dir,
    fsync_tree,
    is_temporary,
    remove_orphans,
)
from ..errors import LumijaxError, OutputError
from ..results import Results

__all__ = ["ResultSet", "write_results", "write_stored"]

#: What a run writes into its folder; a folder holding anything else is not replaced.
SET_NAMES = frozenset({"results.json", "optimised.toml", "grids", "images", "patches.vtp",
                       "report.html", "report.pdf"})
#: Carried from the old folder into the new one (the demo's operator cache lives there).
KEPT_NAMES = (".lumijax-cache",)


def _step(name: str) -> None:
    """Called at each step of writing a set; tests replace it to kill the process there."""


class ResultSet:
    """One run's output files, staged beside ``out`` and swapped in by :meth:`commit`.

    Use as a context manager::

        with ResultSet("out") as rs:
            write_results(results, rs)                 # into rs.staging
            write_report(study, results, rs.staging / "report.html")
            rs.commit()                                # the one step readers see

    Leaving the block without :meth:`commit` (an error, Ctrl-C) discards the staging folder and
    leaves ``out`` as it was. ``out`` must be absent, empty, or a folder lumijax wrote (only the
    names in :data:`SET_NAMES` and :data:`KEPT_NAMES`): a run replaces the whole folder, so a
    folder with other files in it is refused (:class:`OutputError`).
    """

    def __init__(self, out: str | Path) -> None:
        out = Path(out)
        # swap the folder a link points to, never the link itself
        self.out = out.resolve() if out.is_symlink() else Path(os.path.abspath(out))
        self.staging: Path | None = None
        self._lock = FolderLock(self.out)
        self.committed = False

    def __enter__(self) -> ResultSet:
        out = self.out
        if out.exists() and not out.is_dir():
            raise OutputError("not a folder", file=out)
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise OutputError(f"cannot create output folder: {e.strerror or e}",
                              file=out) from None
        self._lock.__enter__()
        try:
            try:
                self._recover()
                self._check_ours()
                self.staging = Path(tempfile.mkdtemp(
                    dir=out.parent, prefix=f"{out.name}.staging-{os.getpid()}-"))
                os.chmod(self.staging, 0o777 & ~_umask())  # mkdtemp's 0700 is for temp files
            except OSError as e:
                raise OutputError(f"cannot write results: {e.strerror or e}",
                                  file=out) from None
        except BaseException:
            self._lock.__exit__()
            raise
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self.staging is not None and not self.committed:
                shutil.rmtree(self.staging, ignore_errors=True)
        finally:
            self._lock.__exit__()

    def _siblings(self, kind: str) -> list[Path]:
        pat = re.compile(re.escape(self.out.name) + rf"\.{kind}-\d+-")
        try:
            return [p for p in self.out.parent.iterdir() if pat.match(p.name)]
        except OSError:
            return []

    def _recover(self) -> None:
        """Remove what killed runs left beside ``out``; put an old set back where a kill fell
        between the two renames of a non-atomic swap."""
        olds = self._siblings("old")
        if not self.out.exists() and olds:
            newest = max(olds, key=lambda p: p.stat().st_mtime)
            os.rename(newest, self.out)
            olds.remove(newest)
        for p in olds + self._siblings("staging"):
            shutil.rmtree(p, ignore_errors=True)
        if self.out.is_dir():
            remove_orphans(self.out)  # e.g. a report.html temporary of a killed `lumijax report`

    def _check_ours(self) -> None:
        if not self.out.is_dir():
            return
        for p in self.out.iterdir():
            if (p.name in SET_NAMES or p.name in KEPT_NAMES or p.name.startswith(".staging-")
                    or is_temporary(p.name)):
                continue  # (.staging-*: what lumijax < 0.2 left inside the folder)
            raise OutputError(f"holds {p.name!r}, which lumijax did not write: a run replaces "
                              "the whole folder, so give an empty or a new --out", file=self.out)

    def commit(self) -> None:
        """Swap the staged set in: ``out`` is the new set from the one atomic step on."""
        if self.staging is None or self.committed:
            raise OutputError("this result set is not open", file=self.out)
        staging, out = self.staging, self.out
        try:
            fsync_tree(staging)
            _step("synced")
            if out.is_dir():
                for name in KEPT_NAMES:
                    if (out / name).exists() and not (staging / name).exists():
                        os.rename(out / name, staging / name)
                _step("kept")
                if exchange_paths(staging, out):
                    old = staging  # now holds the old set
                else:  # two renames; _recover puts the old set back if a kill falls between
                    old = out.with_name(f"{out.name}.old-{os.getpid()}-{secrets.token_hex(4)}")
                    os.rename(out, old)
                    _step("moved-old")
                    os.rename(staging, out)
            else:
                os.rename(staging, out)
                old = None
            self.committed = True
            fsync_dir(out.parent)
            _step("swapped")
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
            _step("cleaned")
        except OSError as e:
            raise OutputError(f"cannot write results: {e.strerror or e}", file=out) from None


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _grid_csv(points: np.ndarray, lux: np.ndarray) -> str:
    rows = np.column_stack([points, lux])
    body = "\n".join(",".join(f"{x:.6g}" for x in r[:3]) + f",{r[3]:.6g}" for r in rows)
    return "x,y,z,lux\n" + body + "\n"


def _write_text(staging: Path, rel: str, text: str) -> None:
    (staging / rel).write_text(text, encoding="utf-8")
    _step(f"wrote {rel}")


def write_results(results: Results, out: str | Path | ResultSet, *, images: bool = True,
                  timings: dict[str, float] | None = None, patches: bool = True,
                  stored_patches: dict[str, np.ndarray] | _in_thread | None = None
                  ) -> dict[str, Path]:
    """Write results as one set and return the paths (in the output folder) of the files.

    ``out``: a folder (created if needed; the set is swapped in before this returns), or an open
    :class:`ResultSet` (the files are staged in it; its :meth:`~ResultSet.commit` swaps them in,
    with whatever else was staged, such as the report).

    Files: ``results.json`` (the documented contract, docs/results.md), ``grids/NAME.csv``
    (x, y, z in m; lux), ``optimised.toml`` (after an optimisation), ``patches.vtp`` (the
    radiosity patches and their light, when inter-reflection was computed) and, with
    ``images``, ``images/NAME.png`` false-colour iso-lux maps.

    ``timings``: a dict that gets ``images``, the seconds spent drawing them (``lumijax run
    --timings``). ``patches=False``: no ``patches.vtp`` (``lumijax run --quick``: the numbers
    the iterate loop reads, as a dimmer-only rerun writes them). ``stored_patches``: the
    arrays of patches.vtp kept for dimmer-only reruns (``report._vtk.patch_arrays``): the file
    is written from them, by the code a rerun writes it with, so the two are the same bytes
    (or an :class:`_in_thread` figuring them, waited for when the file is written).
    """
    if not isinstance(out, ResultSet):
        with ResultSet(out) as rs:
            paths = write_results(results, rs, images=images, timings=timings, patches=patches,
                                  stored_patches=stored_patches)
            rs.commit()
        return paths
    rs = out
    if rs.staging is None or rs.committed:
        raise OutputError("this result set is not open", file=rs.out)
    staging, out_dir = rs.staging, rs.out
    written: list[str] = []
    lighting = results.lighting
    vtp_lux = None
    if patches and stored_patches is None and lighting is not None and (
            lighting.coarse.patches is not None):
        # patches.vtp's irradiance is one compiled operator product (~1 s cold, most of it
        # XLA's compile, which releases the GIL): figured in a thread while results.json and
        # the maps are made, and waited for when the file is written
        vtp_lux = _in_thread(lighting.display_patch_illuminance_at,
                             np.asarray(results.design.dimmers, np.float64))
    try:
        _write_document(staging, results.to_dict(), written)
        if results.optimisation is not None:
            # the optimised study, its file paths relative to where it will live
            _write_text(staging, "optimised.toml", results.optimisation.config_text(out_dir))
            written.append("optimised.toml")
        _write_grids(staging, results.grids, written)
        t_images = time.perf_counter()
        if images and results.grids:
            from ._gridplots import grid_picture

            (staging / "images").mkdir(exist_ok=True)
            lit = results.lighting
            aims = [] if lit is None else [(lum.position, lum.axis)
                                           for lum in lit.scene.luminaires]
            for name, g in results.grids.items():
                # every grid draws something true: a map, a profile along its path, or a plan
                try:
                    pic = grid_picture(g, title=f"{results.study} — {name}", size=(1600, 1100),
                                       luminaires=aims)
                except LumijaxError as e:
                    raise OutputError(f"cannot draw the picture of grid {name!r}: {e.message}",
                                      file=out_dir) from None
                (staging / "images" / f"{name}.png").write_bytes(pic.png)
                written.append(f"images/{name}.png")
                _step(f"wrote images/{name}.png")
        if timings is not None:
            timings["images"] = time.perf_counter() - t_images
        if patches and stored_patches is not None:
            if isinstance(stored_patches, _in_thread):
                stored_patches = stored_patches.result()
            _write_stored_vtp(staging, stored_patches, results.design.dimmers, written)
        elif vtp_lux is not None:
            _write_vtp(staging, lighting, results.design.dimmers, written, vtp_lux.result())
    except OSError as e:
        raise OutputError(f"cannot write results: {e.strerror or e}", file=out_dir) from None
    return _published(staging, out_dir, written)


def write_stored(document: dict, grids: dict, rs: ResultSet,
                 patches: dict[str, np.ndarray] | None = None,
                 dimmers=None) -> dict[str, Path]:
    """Stage a dimmer-only rerun's numbers in ``rs`` (``lumijax._stored``): ``document`` as
    results.json, each :class:`~lumijax.results.GridResult` of ``grids`` as its CSV and, given
    a full run's ``patches`` arrays, patches.vtp at ``dimmers`` — what :func:`write_results`
    writes with ``images=False`` (and ``patches=False`` without them), by the same code."""
    if rs.staging is None or rs.committed:
        raise OutputError("this result set is not open", file=rs.out)
    written: list[str] = []
    try:
        _write_document(rs.staging, document, written)
        _write_grids(rs.staging, grids, written)
        if patches is not None:
            _write_stored_vtp(rs.staging, patches, dimmers, written)
    except OSError as e:
        raise OutputError(f"cannot write results: {e.strerror or e}", file=rs.out) from None
    return _published(rs.staging, rs.out, written)


def _write_document(staging: Path, document: dict, written: list[str]) -> None:
    _write_text(staging, "results.json", json.dumps(document, indent=1, allow_nan=False))
    written.append("results.json")


def _write_grids(staging: Path, grids: dict, written: list[str]) -> None:
    (staging / "grids").mkdir(exist_ok=True)
    for name, g in grids.items():
        _write_text(staging, f"grids/{name}.csv", _grid_csv(g.points, g.illuminance_lux))
        written.append(f"grids/{name}.csv")


class _in_thread:  # noqa: N801 (used as a function: _in_thread(fn, *args).result())
    """``fn(*args)`` in a daemon thread; :meth:`result` waits for it and returns it, or raises
    what it raised."""

    def __init__(self, fn, *args):
        self._out, self._err = None, None
        self._thread = threading.Thread(target=self._run, args=(fn, args), daemon=True,
                                        name="lumijax-write")
        self._thread.start()

    def _run(self, fn, args) -> None:
        try:
            self._out = fn(*args)
        except BaseException as e:  # re-raised in the caller's thread by result()
            self._err = e

    def result(self):
        self._thread.join()
        if self._err is not None:
            raise self._err
        return self._out


def _write_vtp(staging: Path, lighting, dimmers, written: list[str],
               illuminance=None) -> None:
    from ._vtk import write_patches_vtp

    write_patches_vtp(lighting, dimmers, staging / "patches.vtp", illuminance)
    written.append("patches.vtp")
    _step("wrote patches.vtp")


def _write_stored_vtp(staging: Path, patches: dict, dimmers, written: list[str]) -> None:
    from ._vtk import write_stored_patches_vtp

    write_stored_patches_vtp(patches, dimmers, staging / "patches.vtp")
    written.append("patches.vtp")
    _step("wrote patches.vtp")


def _published(staging: Path, out_dir: Path, written: list[str]) -> dict[str, Path]:
    for rel in written:
        with contextlib.suppress(OSError):
            os.chmod(staging / rel, file_mode())  # temp files are private; results are not
    return {rel: out_dir / rel for rel in written}
