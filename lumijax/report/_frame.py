"""A rendered view framed by its texts and colour bar, none of them over the picture.

The scene keeps its own pixels (the camera's ``size``); a header band above it holds the title
and the subtitle, one line each, and a column to its right holds the colour bar with its
labels and units. So at any aspect ratio nothing covers the picture or another text: the
picture grows by the band and the column instead. A text too long for the width is set smaller,
then cut with an ellipsis.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["frame_view"]

_MIN_FONT_PX = 8


def _font_px(height: int) -> int:
    return max(11, int(round(height / 42)))


def _fit(fig, renderer, text, width_px: float, x_px: float, y_px: float, size_px: float,
         **kw):
    """Place one line of text with its top left at (x, y) pixels from the figure's top left,
    no wider than ``width_px``: smaller, then shortened, until it fits."""
    h = fig.bbox.height
    size = size_px
    t = fig.text(x_px / fig.bbox.width, 1 - y_px / h, text, ha="left", va="top",
                 fontsize=size * 0.72, **kw)
    while t.get_window_extent(renderer).width > width_px and size > _MIN_FONT_PX:
        size -= 1
        t.set_fontsize(size * 0.72)
    words = text
    while t.get_window_extent(renderer).width > width_px and len(words) > 1:
        words = words[:-2]
        t.set_text(words.rstrip() + "…")
    return t


def frame_view(scene: np.ndarray, *, title: str | None, subtitle: str, label: str,
               clim: tuple[float, float], scale: str, cmap, levels: Sequence[float] = ()
               ) -> tuple[np.ndarray, tuple[int, int]]:
    """``(picture (H', W', 3) uint8, (row, column) of the scene's top left)``: ``scene``
    (H, W, 3) under a header band with ``title`` and ``subtitle``, beside a vertical colour
    bar of ``cmap`` over ``clim`` (``scale`` ``"log"`` or ``"linear"``) titled ``label``,
    labelled at ``levels`` (else at round values)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LogNorm, Normalize
    from matplotlib.figure import Figure
    from matplotlib.ticker import FixedLocator, FuncFormatter

    from ._falsecolour import _fmt

    scene = np.asarray(scene, np.uint8)[..., :3]
    h, w = scene.shape[:2]
    fs = _font_px(max(h, 240))
    pad = int(round(0.6 * fs))
    header = pad + int(round(1.35 * (fs + 2))) + int(round(1.35 * (fs - 1))) + pad
    column = int(round(7.5 * fs))
    width, height = w + column, h + header
    fig = Figure(figsize=(width / 100.0, height / 100.0), dpi=100, facecolor="white")
    canvas = FigureCanvasAgg(fig)
    renderer = canvas.get_renderer()
    room = width - 2 * pad
    y = pad
    if title:
        _fit(fig, renderer, title, room, pad, y, fs + 2, color="black")
    y += int(round(1.35 * (fs + 2)))
    _fit(fig, renderer, subtitle, room, pad, y, fs - 1, color="#444444")
    # the bar: a strip at the column's left, the labels and the units to its right
    bar_w = max(10, int(round(1.1 * fs)))
    top, bottom = header + pad, height - pad
    x0 = w + pad
    cax = fig.add_axes((x0 / width, 1 - bottom / height, bar_w / width,
                        (bottom - top) / height))
    lo, hi = (float(c) for c in clim)
    norm = LogNorm(lo, hi) if scale == "log" else Normalize(lo, hi)
    bar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), cax=cax)
    if levels:
        bar.ax.yaxis.set_major_locator(FixedLocator([float(x) for x in levels]))
        bar.ax.yaxis.set_minor_locator(FixedLocator([]))
    bar.ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: _fmt(v)))
    bar.ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    bar.ax.tick_params(labelsize=(fs - 1) * 0.72, length=3)
    bar.set_label(label, fontsize=fs * 0.72)
    bar.outline.set_linewidth(0.6)
    canvas.draw()
    img = np.asarray(canvas.buffer_rgba())[..., :3].copy()
    img[header:header + h, :w] = scene
    return img, (header, 0)
