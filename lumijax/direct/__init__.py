"""Direct illuminance from luminaires and area sources, with shadows (docs/conventions.md)."""

from ..kernels import (
    point_illuminance as point_illuminance,
    quad_form_factors as quad_form_factors,
)
from ._direct import (
    DirectLighting as DirectLighting,
    direct_illuminance as direct_illuminance,
    sub_source_offsets as sub_source_offsets,
)
