"""Glare: what an observer's eye sees of every luminaire and its surroundings, and the ratings
standards ask for (UGR, CIE 117; GR, CIE 112 / EN 12464-2; TI, CIE 140 / EN 13201-3) as pure
JAX functions of the design (docs/glare.md)."""

from ._area import (
    EDGE_ON_FRACTION as EDGE_ON_FRACTION,
    POINT_DIAMETER_M as POINT_DIAMETER_M,
    NoLuminousSizeWarning as NoLuminousSizeWarning,
    projected_area as projected_area,
)
from ._glare import Glare as Glare
from ._model import (
    DimmerGlare as DimmerGlare,
    GlareModel as GlareModel,
    GlareRatings as GlareRatings,
    NearSourceWarning as NearSourceWarning,
    build_glare_model as build_glare_model,
    worst_ratings as worst_ratings,
)
from ._observers import Observer as Observer, build_observers as build_observers
from ._position import (
    MAX_POSITION_INDEX as MAX_POSITION_INDEX,
    guth_index as guth_index,
    position_index as position_index,
)
from ._ratings import (
    SOLID_ANGLE_RANGE_SR as SOLID_ANGLE_RANGE_SR,
    glare_rating as glare_rating,
    threshold_increment as threshold_increment,
    ugr as ugr,
    veiling_luminance as veiling_luminance,
)
from ._surfaces import (
    FIELD_RAYS as FIELD_RAYS,
    SeenSurfaces as SeenSurfaces,
    build_seen_surfaces as build_seen_surfaces,
)
from ._table import (
    STANDARD_REFLECTANCES as STANDARD_REFLECTANCES,
    STANDARD_ROOMS as STANDARD_ROOMS,
    STANDARD_SPACING_H as STANDARD_SPACING_H,
    UGRTable as UGRTable,
    room_transfer_factors as room_transfer_factors,
    ugr_table as ugr_table,
)
