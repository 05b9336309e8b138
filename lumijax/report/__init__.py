"""Reports: false-colour iso-lux maps (``_falsecolour``). Rendering imports pyvista lazily."""

from ._falsecolour import DEFAULT_CMAP, falsecolour_map, lux_to_rgb, make_view, nice_levels

__all__ = ["falsecolour_map", "lux_to_rgb", "nice_levels", "make_view", "DEFAULT_CMAP"]
