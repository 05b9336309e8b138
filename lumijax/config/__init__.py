"""Study configs: TOML in, a validated and frozen :class:`StudyConfig` out (see docs/config.md)."""

from ._load import load_config as load_config, parse_config as parse_config
from ._schema import (
    Aim as Aim,
    AreaLuminaire as AreaLuminaire,
    BoxGeometry as BoxGeometry,
    BuiltinPhotometry as BuiltinPhotometry,
    FilePhotometry as FilePhotometry,
    GroupConfig as GroupConfig,
    MaterialConfig as MaterialConfig,
    MeshGeometry as MeshGeometry,
    NetworkConfig as NetworkConfig,
    PhotometricLuminaire as PhotometricLuminaire,
    PlaneGrid as PlaneGrid,
    PointsGrid as PointsGrid,
    RectangleGeometry as RectangleGeometry,
    SolverConfig as SolverConfig,
    StudyConfig as StudyConfig,
    StudyInfo as StudyInfo,
)
from ._targets import read_target_csv as read_target_csv
