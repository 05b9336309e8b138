"""Pure JAX kernels shared by direct light and form factors: point-source pair illuminance, Lambert's
contour integral over triangles and quads, and the far-field form-factor kernel. No visibility here:
callers multiply by visibility from ray casting (see ``docs/conventions.md``). Also the geometric
tolerances every stage shares (relative to the model, never absolute metres: ``_tolerances.py``)."""

from ._direct import (
    offset_illuminance as offset_illuminance,
    pair_light as pair_light,
    point_illuminance as point_illuminance,
    quad_form_factors as quad_form_factors,
)
from ._form_factors import (
    far_g as far_g,
    form_factor_far as form_factor_far,
    form_factor_point_front_triangle as form_factor_point_front_triangle,
    form_factor_point_triangle as form_factor_point_triangle,
    triangle_spread as triangle_spread,
)
from ._tolerances import (
    length_tolerance as length_tolerance,
    rounding_length as rounding_length,
    triangle_shape as triangle_shape,
)
