"""The live viewer: sliders per network recombine the precomputed solutions (``lumijax view``).

``build_viewer`` makes the desktop pyvista window (testable off-screen); ``serve`` shows the same
in a browser through trame (the optional ``view`` extra). See ``docs/report.md``.
"""

from ._viewer import MODES, DimmerViewer, build_viewer
from ._web import TrameMissing, serve, web_app

__all__ = ["DimmerViewer", "build_viewer", "MODES", "serve", "web_app", "TrameMissing"]
