"""Off-screen pyvista plotters kept for the next picture of the same size.

A new ``pv.Plotter`` makes a render window, and its first render creates an OpenGL context
and compiles its shaders: ~0.3 s of every map, view and network picture of a report (a cold
``lumijax demo`` drew 24 of them, each in a plotter of its own; contended). :func:`plotter`
lends one of the given size, blank: everything a picture adds is removed when it is handed
back (actors, 2-D text and labels among them, scalar bars and their slots, the orientation
axes, the camera, and its first-render state), so a picture drawn in a lent plotter is the one a new plotter draws, pixel
for pixel (``tests/report/test_plotters.py``). Every picture still sets its own background and
camera, as it did in a new plotter.

A plotter that cannot be reset, or one lent while another of its size is out (threads), is
closed instead of kept; at most :data:`MAX_KEPT` sizes are kept, all closed at exit.
``LUMIJAX_REUSE_PLOTTERS=0`` turns the reuse off (a new plotter per picture).
"""

from __future__ import annotations

import atexit
import contextlib
import os
import threading
from collections.abc import Iterator

__all__ = ["MAX_KEPT", "plotter", "close_all"]

MAX_KEPT = 4
"""Plotter sizes kept at once (a report draws at three or four sizes)."""

_lock = threading.Lock()
_kept: dict[tuple[int, int], object] = {}


def _reuse() -> bool:
    return os.environ.get("LUMIJAX_REUSE_PLOTTERS", "1").strip().lower() not in (
        "0", "off", "false", "no")


@contextlib.contextmanager
def plotter(size) -> Iterator[object]:
    """A blank off-screen ``pv.Plotter`` of ``size`` (width, height px) for one picture;
    kept for the next picture of that size when the block ends without an error."""
    import pyvista as pv

    key = (int(size[0]), int(size[1]))
    with _lock:
        pl = _kept.pop(key, None)
    if pl is None:
        pl = pv.Plotter(off_screen=True, window_size=list(key))
    ok = False
    try:
        yield pl
        ok = True
    finally:
        keep = ok and _reuse() and _blank(pl)
        if keep:
            with _lock:
                keep = key not in _kept and len(_kept) < MAX_KEPT
                if keep:
                    _kept[key] = pl
        if not keep:
            pl.close()


def _blank(pl) -> bool:
    """Remove everything a picture added, as a new plotter has it; False if that failed."""
    try:
        from pyvista.plotting.camera import Camera
        from pyvista.plotting.renderer import MAX_N_COLOR_BARS

        r = pl.renderer
        pl.clear_actors()  # meshes, points, text, point labels, rulers, scalar bar actors
        pl.scalar_bars.clear()
        r._scalar_bar_slots = set(range(MAX_N_COLOR_BARS))
        r._scalar_bar_slot_lookup = {}
        r._remove_axes_widget()
        r._camera = Camera(r)  # a fresh camera, as Renderer.__init__ makes it
        r.SetActiveCamera(r._camera)
        r.camera_set = False
        pl.mesh = None
        pl.mapper = None
        # as before its first picture: renders asked for while drawing are skipped and the
        # screenshot renders once, with the camera the picture set (a lent plotter otherwise
        # renders at add_mesh, and the screenshot returns that frame, not a new one)
        pl._first_time = True
        return True
    except Exception:  # a pyvista without these internals: a new plotter each time
        return False


def close_all() -> None:
    """Close every kept plotter (at exit; tests)."""
    with _lock:
        kept = list(_kept.values())
        _kept.clear()
    for pl in kept:
        with contextlib.suppress(Exception):
            pl.close()


atexit.register(close_all)
