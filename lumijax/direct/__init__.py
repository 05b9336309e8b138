"""Direct illuminance from luminaires and area sources, with shadows (docs/conventions.md)."""

from ..kernels import (
    pair_light as pair_light,
    point_illuminance as point_illuminance,
    quad_form_factors as quad_form_factors,
)
from ._direct import (
    DirectLighting as DirectLighting,
    direct_illuminance as direct_illuminance,
)
from ._pairs import (
    PairSet as PairSet,
    build_pairs as build_pairs,
    sub_source_offsets as sub_source_offsets,
    support_cosine as support_cosine,
)
from ._response import SENSOR_KINDS as SENSOR_KINDS, SensorResponse as SensorResponse
