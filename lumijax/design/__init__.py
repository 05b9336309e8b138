"""``lumijax.design``: the one owner of what a designer sets — network dimmers, luminaire aims
and levels (:class:`Design`) — and its flat view for the optimiser (:func:`traverse`)."""

from ._design import Design as Design
from ._parameters import (
    DESIGN_VARIABLES as DESIGN_VARIABLES,
    DesignParameters as DesignParameters,
    traverse as traverse,
)

__all__ = ["Design", "DesignParameters", "traverse", "DESIGN_VARIABLES"]
