"""Pictures and the report: false-colour iso-lux maps of grids (``_falsecolour``), realistic and
false-colour views of the lit surfaces (``_views``, ``_surfaces``, ``_tonemap``, ``_camera``),
polar candela plots (``_polar``), each grid's picture (``_gridplots``), the luminaire schedule
(``_schedule``), each network alone (``_networks``), the self-contained ``report.html``
(``_html``, with other layers' ``ReportSection``) and its PDF (``_pdf``).
Rendering imports pyvista lazily; see ``docs/report.md``."""

from .._lazy import lazy_names

# Imported on first use (PEP 562): most of the report needs JAX (the study, the design), and
# the command line's dimmer-only rerun writes results.json through ResultSet without it.
_LAZY = {
    "Camera": "._camera", "cameras_of": "._camera", "overview_camera": "._camera",
    "DEFAULT_CMAP": "._falsecolour", "falsecolour_map": "._falsecolour",
    "lux_to_rgb": "._falsecolour", "make_view": "._falsecolour", "nice_levels": "._falsecolour",
    "GridPicture": "._gridplots", "grid_picture": "._gridplots", "picture_kind": "._gridplots",
    "grid_criteria": "._html", "render_report": "._html", "report_context": "._html",
    "section_builders": "._html", "write_report": "._html", "NetworkPage": "._networks",
    "network_pages": "._networks", "write_pdf": "._pdf", "beam_angle_deg": "._polar",
    "polar_plot": "._polar", "Schedule": "._schedule", "ScheduleRow": "._schedule",
    "luminaire_schedule": "._schedule", "ReportSection": "._sections",
    "SurfaceLight": "._surfaces", "surface_light": "._surfaces", "auto_ev100": "._tonemap",
    "ev100": "._tonemap", "exposure_scale": "._tonemap", "tone_map": "._tonemap",
    "auto_exposure": "._views", "beam_outline": "._views", "fitting_colour": "._views",
    "render_falsecolour_view": "._views", "render_realistic": "._views", "view_colours": "._views",
    "write_png": "._views", "write_patches_vtp": "._vtk", "ResultSet": "._write",
    "write_results": "._write",
}

__all__ = [
    "falsecolour_map", "lux_to_rgb", "nice_levels", "make_view", "DEFAULT_CMAP",
    "Camera", "cameras_of", "overview_camera",
    "SurfaceLight", "surface_light",
    "ev100", "exposure_scale", "auto_ev100", "tone_map",
    "render_realistic", "render_falsecolour_view", "view_colours", "auto_exposure",
    "fitting_colour", "beam_outline", "write_png",
    "polar_plot", "beam_angle_deg",
    "write_report", "report_context", "render_report", "grid_criteria", "section_builders",
    "ReportSection", "write_pdf", "grid_picture", "picture_kind", "GridPicture",
    "luminaire_schedule", "Schedule", "ScheduleRow", "network_pages", "NetworkPage",
    "write_results", "write_patches_vtp", "ResultSet",
]


__getattr__, __dir__ = lazy_names(__name__, globals(), _LAZY)
del lazy_names
