"""The drawing libraries imported in the background while the numbers are computed.

A run that draws (maps, views, the report) imports pyvista with VTK's rendering and
matplotlib the first time it draws: ~1.5 s of a cold ``lumijax demo`` (pyvista's plotting
1.2 s, matplotlib's figure and Agg canvas; contended), all of it on the critical path, after
the optimiser. :func:`start` imports them in a daemon thread when the run begins, so the
imports overlap the lighting's compiled kernels and ray casts (which release the GIL), and the
first picture finds them loaded; a run that writes a report also figures its photometries'
plane curves there first (the polar plots' and beam angles' lookups) and, once matplotlib is
in, draws their polar diagrams (matplotlib's object API, no pyplot state: ``_polar.
prerender``). Nothing else is drawn and no window or OpenGL context is made (those belong to
the thread that draws); the modules are the ones the first picture imports today (pyvista's
plotting brings ``matplotlib.pyplot`` with it), in the same order, then colour-science (the
views' tone mapping: ~0.5 s). An import that fails here is left for the drawing code to
report as it always has.

``LUMIJAX_PREWARM=0`` (or ``off``, ``false``, ``no``) turns it off.
"""

from __future__ import annotations

import atexit
import importlib
import os
import threading

__all__ = ["MODULES", "start"]

MODULES = (
    "pyvista",
    "pyvista.plotting",
    "vtkmodules.vtkRenderingOpenGL2",
    "matplotlib",
    "matplotlib.figure",
    "matplotlib.backends.backend_agg",
    "matplotlib.ticker",
    "matplotlib.colors",
    "colour",
)
"""What a drawing run imports on its first picture, in that order."""

_OFF = {"0", "off", "false", "no"}


def _prewarm(photometries) -> None:
    if photometries:
        from ._polar import prefetch

        try:
            prefetch(photometries)
        except Exception:  # the report figures them itself, and reports what fails
            pass
    for name in MODULES:
        try:
            importlib.import_module(name)
        except Exception:  # missing or broken: the drawing code reports it when it draws
            return
    if photometries:
        from ._polar import prerender

        prerender(photometries)


def start(photometries=None) -> threading.Thread | None:
    """Start importing :data:`MODULES` in a daemon thread, after figuring the report's plane
    curves of ``photometries`` (``{name: Photometry}``, a study's: ``_polar.prefetch``, one
    compiled lookup per table shape, which releases the GIL while it compiles); the thread, or
    None when turned off by ``$LUMIJAX_PREWARM``."""
    if os.environ.get("LUMIJAX_PREWARM", "1").strip().lower() in _OFF:
        return None
    t = threading.Thread(target=_prewarm, args=(photometries,), name="lumijax-prewarm",
                         daemon=True)
    t.start()
    # a run shorter than the imports waits for them at exit: a daemon thread stopped inside
    # an extension module's initialisation can crash the interpreter's shutdown
    atexit.register(t.join, 120)
    return t
