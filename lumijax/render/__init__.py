"""The view-dependent second pass (paper section 7): cameras (perspective, fisheye), a ray
tracer through Embree over the diffuse radiosity with specular reflection, clear transmission
and the light sources at their luminance, and luminance images in cd/m² (docs/render.md)."""

from ._cameras import (
    FISHEYE_PROJECTIONS as FISHEYE_PROJECTIONS,
    AbstractCamera as AbstractCamera,
    Fisheye as Fisheye,
    Perspective as Perspective,
)
from ._emitters import (
    Emitters as Emitters,
    emitters_of as emitters_of,
    opening_triangles as opening_triangles,
)
from ._image import SOURCE_FACTOR as SOURCE_FACTOR, LuminanceImage as LuminanceImage
from ._optics import (
    MIRROR_ROUGHNESS as MIRROR_ROUGHNESS,
    SPECULAR_LOBES as SPECULAR_LOBES,
    Optics as Optics,
    SpecularLobe as SpecularLobe,
    optics_of as optics_of,
)
from ._tracer import (
    Tracer as Tracer,
    TraceStats as TraceStats,
)
