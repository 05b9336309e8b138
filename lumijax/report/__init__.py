"""Pictures and the report: false-colour iso-lux maps of grids (``_falsecolour``), realistic and
false-colour views of the lit surfaces (``_views``, ``_surfaces``, ``_tonemap``, ``_camera``),
polar candela plots (``_polar``), each grid's picture (``_gridplots``), the luminaire schedule
(``_schedule``), each network alone (``_networks``), the self-contained ``report.html``
(``_html``, with other layers' ``ReportSection``) and its PDF (``_pdf``).
Rendering imports pyvista lazily; see ``docs/report.md``."""

from ._camera import Camera, cameras_of, overview_camera
from ._falsecolour import DEFAULT_CMAP, falsecolour_map, lux_to_rgb, make_view, nice_levels
from ._gridplots import GridPicture, grid_picture, picture_kind
from ._html import grid_criteria, render_report, report_context, section_builders, write_report
from ._networks import NetworkPage, network_pages
from ._pdf import write_pdf
from ._polar import beam_angle_deg, polar_plot
from ._schedule import Schedule, ScheduleRow, luminaire_schedule
from ._sections import ReportSection
from ._surfaces import SurfaceLight, surface_light
from ._tonemap import auto_ev100, ev100, exposure_scale, tone_map
from ._views import (
    auto_exposure,
    beam_outline,
    fitting_colour,
    render_falsecolour_view,
    render_realistic,
    view_colours,
    write_png,
)
from ._vtk import write_patches_vtp
from ._write import ResultSet, write_results

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
