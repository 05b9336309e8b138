"""The scene: geometry, materials, luminaires, networks and grids in world space (SI units)."""

from ._elements import (
    AreaSource as AreaSource,
    Grid as Grid,
    Luminaire as Luminaire,
    Material as Material,
    Network as Network,
    plane_grid_points as plane_grid_points,
)
from ._frames import (
    Frame as Frame,
    aim_angles_towards as aim_angles_towards,
    aim_rotation as aim_rotation,
    resolve_group_frames as resolve_group_frames,
    rotation_xyz as rotation_xyz,
)
from ._geometry import (
    Triangles as Triangles,
    box_triangles as box_triangles,
    rectangle_triangles as rectangle_triangles,
)
from ._glass import (
    GLASS_INDEX as GLASS_INDEX,
    MAX_CLEAR_TRANSMITTANCE as MAX_CLEAR_TRANSMITTANCE,
    GlazedCaster as GlazedCaster,
    glass_transmittance as glass_transmittance,
    internal_transmissivity as internal_transmissivity,
)
from ._raycast import RayCaster as RayCaster
from ._scene import Scene as Scene, build_scene as build_scene
