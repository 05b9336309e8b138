"""The dimmer viewer: the solved scene with one slider per network (the paper's rheostats).

Moving a slider recombines the precomputed per-network solutions, ``B = Σ_k α_k B_k``: no solve,
only a weighted sum over the vertices and a tone map. The exposure stays where it was metered
at the start, so dimming a network darkens the picture, as it would through a fixed camera.
"""

from __future__ import annotations

import numpy as np

from ..report._camera import Camera, cameras_of
from ..report._falsecolour import DEFAULT_CMAP, N_COLOURS, _cmap, lux_to_rgb
from ..report._views import (
    BACKGROUND,
    _fittings,
    _place,
    auto_exposure,
    fitting_rgb,
    view_colours,
)

__all__ = ["DimmerViewer", "build_viewer", "MODES"]

MODES = ("realistic", "falsecolour")


class DimmerViewer:
    """A pyvista plotter showing a study's surfaces, recoloured as dimmers and mode change.

    Attributes
    ----------
    plotter
        The :class:`pyvista.Plotter` (off-screen or on a window).
    surface
        The :class:`lumijax.report.SurfaceLight` drawn.
    dimmers
        Current dimmer levels, one per network (``surface.networks`` order).
    ev
        Exposure (EV100) of the realistic mode, fixed at construction.
    mode
        ``"realistic"`` or ``"falsecolour"`` (luminance, log scale, cd/m²).
    """

    def __init__(self, study, surface, plotter, camera: Camera, dimmers, *,
                 ev: float | None = None, tone: str = "filmic") -> None:
        self.study, self.surface, self.plotter, self.camera = study, surface, plotter, camera
        self.networks = tuple(surface.networks)
        self.dimmers = np.array(dimmers, np.float64)
        self.tone = tone
        self.ev = float(ev) if ev is not None else auto_exposure(surface, self.dimmers, camera)
        self.mode = "realistic"
        # a fixed false-colour range: all networks at full, four decades down
        full = surface.luminance_at(np.ones(len(self.networks)))
        hi = float(np.percentile(full[full > 0], 99.5)) if np.any(full > 0) else 1.0
        self.clim = (hi * 1e-4, hi)
        self.mesh = surface.polydata()
        self.mesh.point_data["rgb"] = self.colours()
        self.fc_mesh = surface.polydata()
        self.fc_mesh.point_data["luminance"] = self._luminance()
        pl = plotter
        pl.set_background(BACKGROUND)
        self.actor = pl.add_mesh(self.mesh, scalars="rgb", rgb=True, lighting=False,
                                 culling="back", show_scalar_bar=False)
        self.fc_actor = pl.add_mesh(
            self.fc_mesh, scalars="luminance", cmap=_cmap(DEFAULT_CMAP), clim=self.clim,
            log_scale=True, n_colors=N_COLOURS, lighting=False, culling="back",
            scalar_bar_args=dict(title="Luminance (cd/m²)", vertical=True, position_x=0.88,
                                 position_y=0.25, width=0.04, height=0.6, color="white",
                                 fmt="%.3g"))
        self.fc_actor.SetVisibility(False)
        self.bar = pl.scalar_bar
        self.bar.SetVisibility(False)
        self.fittings = _fittings(pl, study.scene, self.dimmers, camera, markers=False)
        _place(pl, camera)

    def _luminance(self) -> np.ndarray:
        return np.maximum(self.surface.luminance_at(self.dimmers), self.clim[0])

    def colours(self) -> np.ndarray:
        """Vertex colours (uint8, (V, 3)) of the current mode and dimmers."""
        if self.mode == "falsecolour":
            rgb = lux_to_rgb(self.surface.luminance_at(self.dimmers), *self.clim, "log")
            return np.round(rgb * 255.0).astype(np.uint8)
        return view_colours(self.surface, self.dimmers, self.ev, self.tone)

    def _update(self) -> None:
        self.mesh.point_data["rgb"] = self.colours()
        self.fc_mesh.point_data["luminance"] = self._luminance()
        if self.fittings is not None:  # the fittings glow with their dimmer too
            lums = self.study.scene.luminaires
            self.fittings.point_data["rgb"] = fitting_rgb(
                self.study.scene, self.dimmers, self.fittings.n_points // len(lums))
            self.fittings.Modified()
        self.mesh.Modified()
        self.fc_mesh.Modified()
        self.plotter.render()

    def screenshot(self) -> np.ndarray:
        """The picture as it is now, (H, W, 3) uint8."""
        self.plotter.render()
        return np.asarray(self.plotter.screenshot(None, return_img=True))[..., :3]

    def set_dimmer(self, network: str, level: float) -> None:
        """Set one network's dimmer (0–1) and recolour."""
        if network not in self.networks:
            raise KeyError(f"no network {network!r}; networks: {', '.join(self.networks)}")
        self.dimmers[self.networks.index(network)] = float(np.clip(level, 0.0, 1.0))
        self._update()

    def set_mode(self, mode: str) -> None:
        """Show the realistic view or the false-colour luminance map."""
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        self.mode = mode
        fc = mode == "falsecolour"
        self.actor.SetVisibility(not fc)
        self.fc_actor.SetVisibility(fc)
        self.bar.SetVisibility(fc)
        self._update()

    def add_widgets(self) -> None:
        """Desktop controls: one slider per network down the left, a false-colour checkbox."""
        pl = self.plotter
        n = len(self.networks)
        for i, name in enumerate(self.networks):
            y = 0.92 - i * min(0.12, 0.8 / max(n, 1))
            pl.add_slider_widget(
                lambda v, name=name: self.set_dimmer(name, v), rng=[0.0, 1.0],
                value=float(self.dimmers[i]), title=name, pointa=(0.03, y), pointb=(0.27, y),
                style="modern", fmt="%.2f", title_height=0.02, color="white")
        pl.add_checkbox_button_widget(
            lambda on: self.set_mode("falsecolour" if on else "realistic"), value=False,
            position=(12, 12), size=30, color_on="#3b8bc2", color_off="#555555")
        pl.add_text("false colour (cd/m²)", position=(50, 18), font_size=10, color="white")


def build_viewer(study, results, *, off_screen: bool = False, window_size=(1280, 800),
                 camera: Camera | None = None, widgets: bool = True) -> DimmerViewer:
    """The viewer of computed ``results``: plotter, surfaces and (``widgets``) sliders.

    ``camera`` defaults to the study's first camera (or the automatic overview). Call
    ``viewer.plotter.show()`` to open the window.
    """
    import pyvista as pv

    from ..report._surfaces import surface_light

    cam = camera or cameras_of(study)[0]
    cam = cam.replace(size=tuple(window_size))
    surface = surface_light(results)
    design = results.design  # the one record of the design the results are lit at
    if design.same_study(study.design):  # the fittings drawn where the design aims them
        study = study.with_design(design)
    pl = pv.Plotter(off_screen=off_screen, window_size=list(window_size),
                    title=f"lumijax — {results.study}")
    viewer = DimmerViewer(study, surface, pl, cam, design.dimmers, tone=cam.tone,
                          ev=cam.exposure_ev)
    if widgets:
        viewer.add_widgets()
    return viewer
