"""Photometry: IES LM-63 and EULUMDAT files, symmetric expansion, continuous intensity lookup.

See ``docs/photometry.md`` for formats, conventions and formulas, and ``docs/conventions.md`` for
the luminaire frame in which :meth:`CandelaDistribution.intensity` takes its directions.
"""

from ._distribution import CandelaDistribution as CandelaDistribution
from ._opening import LuminousOpening as LuminousOpening
from ._parametric import (
    flood as flood,
    isotropic as isotropic,
    lambertian as lambertian,
    linear_washer as linear_washer,
    spot as spot,
)
from ._photometry import (
    LampSet as LampSet,
    Photometry as Photometry,
    TiltTable as TiltTable,
)
from ._read import read_photometry as read_photometry
from ._write import write_ies as write_ies

__all__ = [
    "CandelaDistribution",
    "LampSet",
    "LuminousOpening",
    "Photometry",
    "TiltTable",
    "flood",
    "isotropic",
    "lambertian",
    "linear_washer",
    "read_photometry",
    "spot",
    "write_ies",
]
