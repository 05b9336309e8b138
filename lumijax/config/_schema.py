"""The study config schema: what a TOML study may say, with units and defaults.

Every model forbids unknown keys and is frozen: a validated config is a value, not a form to
fill in later. Paths are resolved against the config file's folder at validation time (through
the validation context), so the rest of lumijax never sees a relative path. The user reference
is ``docs/config.md``; keep the two in step.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    PrivateAttr,
    Tag,
    ValidationInfo,
    field_validator,
    model_validator,
)

__all__ = [
    "StudyConfig",
    "StudyInfo",
    "GroupConfig",
    "MaterialConfig",
    "BoxGeometry",
    "RectangleGeometry",
    "MeshGeometry",
    "FilePhotometry",
    "BuiltinPhotometry",
    "Aim",
    "PhotometricLuminaire",
    "AreaLuminaire",
    "NetworkConfig",
    "PlaneGrid",
    "PointsGrid",
    "SolverConfig",
]


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError("must be a finite number")
    return v


Finite = Annotated[float, AfterValidator(_finite)]
Positive = Annotated[float, Field(gt=0), AfterValidator(_finite)]
NonNegative = Annotated[float, Field(ge=0), AfterValidator(_finite)]
Vec3 = tuple[Finite, Finite, Finite]
Name = Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")]


def _resolve(path: str, info: ValidationInfo, *, must_exist: bool = True) -> Path:
    base = (info.context or {}).get("base_dir", Path.cwd())
    p = Path(path).expanduser()
    if not p.is_absolute():
        p = Path(base) / p
    p = p.resolve()
    if must_exist and not p.is_file():
        raise ValueError(f"file not found: {p}")
    return p


def _looks_like_file(text: str) -> bool:
    return text.lower().endswith((".csv", ".txt", ".spd")) or "/" in text or "\\" in text


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, str_strip_whitespace=True)


class StudyInfo(_Model):
    """``[study]``: what the study is called and about."""

    name: str = "untitled study"
    description: str = ""


class GroupConfig(_Model):
    """``[groups.NAME]``: a local frame, ``p_parent = translate + R·(scale ⊙ p)``."""

    parent: Name | None = None
    translate: Vec3 = (0.0, 0.0, 0.0)
    rotate: Vec3 = Field((0.0, 0.0, 0.0), description="degrees about x, then y, then z")
    scale: Finite | Vec3 = 1.0

    @field_validator("scale")
    @classmethod
    def _positive_scale(cls, v):
        vals = (v,) if isinstance(v, float | int) else v
        if any(s <= 0 for s in vals):
            raise ValueError("scale factors must be > 0")
        return v


class MaterialConfig(_Model):
    """``[materials.NAME]``: a diffuse reflectance, grey, spectral (CSV or named) or sRGB."""

    reflectance: Finite | str | Path | None = Field(
        None, description="grey value, CSV path (resolved to a Path) or dataset name"
    )
    srgb: Vec3 | None = None

    @field_validator("reflectance")
    @classmethod
    def _file(cls, v, info: ValidationInfo):
        return _resolve(v, info) if isinstance(v, str) and _looks_like_file(v) else v

    @model_validator(mode="after")
    def _one_of(self):
        if (self.reflectance is None) == (self.srgb is None):
            raise ValueError("give exactly one of 'reflectance' or 'srgb'")
        if isinstance(self.reflectance, float) and not 0.0 <= self.reflectance < 1.0:
            raise ValueError(
                f"reflectance must be in [0, 1): a diffuse surface cannot reflect more light "
                f"than it receives (got {self.reflectance})"
            )
        if self.srgb is not None and not all(0.0 <= c <= 1.0 for c in self.srgb):
            raise ValueError("srgb components must be in [0, 1]")
        return self


class _GeometryBase(_Model):
    name: str | None = None
    material: Name
    group: Name | None = None


class BoxGeometry(_GeometryBase):
    """``kind = "box"``: an axis-aligned box from ``min`` to ``max`` (m)."""

    kind: Literal["box"]
    min: Vec3
    max: Vec3
    normals: Literal["inward", "outward"] = "outward"

    @model_validator(mode="after")
    def _ordered(self):
        if any(hi <= lo for lo, hi in zip(self.min, self.max, strict=True)):
            raise ValueError(f"box 'max' {self.max} must exceed 'min' {self.min} on every axis")
        return self


class RectangleGeometry(_GeometryBase):
    """``kind = "rectangle"``: a one-sided quad ``origin, origin+u, origin+u+v, origin+v``."""

    kind: Literal["rectangle"]
    origin: Vec3
    u: Vec3
    v: Vec3


class MeshGeometry(_GeometryBase):
    """``kind = "mesh"``: any file trimesh reads (OBJ, PLY, STL, glTF/GLB, OFF …)."""

    kind: Literal["mesh"]
    file: Path
    units: Literal["m", "mm", "cm", "ft", "in"] = "m"
    flip_normals: bool = False

    @field_validator("file", mode="before")
    @classmethod
    def _file(cls, v, info: ValidationInfo):
        return _resolve(str(v), info)


Geometry = Annotated[BoxGeometry | RectangleGeometry | MeshGeometry, Field(discriminator="kind")]


class FilePhotometry(_Model):
    """``[photometry.NAME] file = "..."``: an IES LM-63 or EULUMDAT file (chosen by content)."""

    file: Path

    @field_validator("file", mode="before")
    @classmethod
    def _file(cls, v, info: ValidationInfo):
        return _resolve(str(v), info)


class BuiltinPhotometry(_Model):
    """``[photometry.NAME] kind = "isotropic" | "lambertian"`` with ``flux_lm``."""

    kind: Literal["isotropic", "lambertian"]
    flux_lm: Positive


class Aim(_Model):
    """Aim angles in degrees, applied spin, then tilt, then pan (docs/conventions.md)."""

    tilt: Finite = 0.0
    pan: Finite = 0.0
    spin: Finite = 0.0


class _LuminaireBase(_Model):
    name: Name
    network: Name
    group: Name | None = None
    spectrum: str | Path | None = Field(
        None, description="colour-science name, or CSV path (resolved to a Path)"
    )

    @field_validator("spectrum")
    @classmethod
    def _file(cls, v, info: ValidationInfo):
        return _resolve(v, info) if isinstance(v, str) and _looks_like_file(v) else v


class PhotometricLuminaire(_LuminaireBase):
    """A luminaire with measured or built-in photometry placed at ``position`` and aimed."""

    kind: Literal["photometric"] = "photometric"
    photometry: Name
    position: Vec3
    aim: Aim | None = None
    aim_at: Vec3 | None = None
    multiplier: NonNegative = 1.0
    maintenance_factor: Annotated[float, Field(gt=0, le=1)] = 1.0

    @model_validator(mode="after")
    def _aim(self):
        if self.aim_at is not None and self.aim is not None and (self.aim.tilt or self.aim.pan):
            raise ValueError("give 'aim_at' or 'aim.tilt'/'aim.pan', not both")
        if self.aim_at is not None and tuple(self.aim_at) == tuple(self.position):
            raise ValueError("'aim_at' is the luminaire's own position: no direction to aim")
        return self


class AreaLuminaire(_LuminaireBase):
    """``kind = "area"``: a Lambertian emitting rectangle (front face along u × v)."""

    kind: Literal["area"]
    origin: Vec3
    u: Vec3
    v: Vec3
    flux_lm: Positive
    maintenance_factor: Annotated[float, Field(gt=0, le=1)] = 1.0


def _luminaire_kind(v) -> str:
    # 'kind' is optional for the common case; an unknown kind is passed on so the error lists
    # the valid ones
    return v.get("kind", "photometric") if isinstance(v, dict) else getattr(v, "kind", None)


Luminaire = Annotated[
    Annotated[PhotometricLuminaire, Tag("photometric")] | Annotated[AreaLuminaire, Tag("area")],
    Discriminator(_luminaire_kind),
]


def _photometry_kind(v) -> str:
    has_file = ("file" in v) if isinstance(v, dict) else isinstance(v, FilePhotometry)
    return "file" if has_file else "builtin"


Photometry = Annotated[
    Annotated[FilePhotometry, Tag("file")] | Annotated[BuiltinPhotometry, Tag("builtin")],
    Discriminator(_photometry_kind),
]


class NetworkConfig(_Model):
    """``[networks.NAME]``: a dimmer circuit (the paper's rheostat)."""

    dimmer: Annotated[float, Field(ge=0, le=1)] = 1.0
    description: str = ""


class _GridBase(_Model):
    name: Name
    group: Name | None = None
    target_lux: NonNegative | None = None


class PlaneGrid(_GridBase):
    """``kind = "plane"``: cell-centred points on the parallelogram ``origin + s·u + t·v``."""

    kind: Literal["plane"]
    origin: Vec3
    u: Vec3
    v: Vec3
    nu: Annotated[int, Field(ge=1, le=100_000)] | None = None
    nv: Annotated[int, Field(ge=1, le=100_000)] | None = None
    spacing: Positive | None = None
    normal: Vec3 | None = None

    @model_validator(mode="after")
    def _counts(self):
        counts = (self.nu is not None, self.nv is not None)
        if self.spacing is None and counts != (True, True):
            raise ValueError("give both 'nu' and 'nv', or 'spacing'")
        if self.spacing is not None and any(counts):
            raise ValueError("give 'spacing' or 'nu'/'nv', not both")
        return self


class PointsGrid(_GridBase):
    """``kind = "points"``: explicit points with one normal each (or one for all)."""

    kind: Literal["points"]
    points: Annotated[list[Vec3], Field(min_length=1)]
    normals: list[Vec3] | Vec3 = (0.0, 0.0, 1.0)

    @model_validator(mode="after")
    def _match(self):
        if isinstance(self.normals, list) and len(self.normals) != len(self.points):
            raise ValueError(
                f"'normals' has {len(self.normals)} entries but 'points' has {len(self.points)}"
            )
        return self


Grid = Annotated[PlaneGrid | PointsGrid, Field(discriminator="kind")]


class SolverConfig(_Model):
    """``[solver]``: how inter-reflected light is computed (docs/config.md, docs/radiosity.md)."""

    indirect: bool = True
    patch_size: Positive | None = Field(None, description="m; default: automatic")
    target_patches: Annotated[int, Field(ge=10, le=10_000_000)] = 4_000
    max_block: Annotated[int, Field(ge=16, le=8192)] = 1024
    method: Literal["bicgstab", "gmres", "southwell", "jacobi"] = "bicgstab"
    tolerance: Annotated[float, Field(gt=0, lt=1)] | None = None
    max_iterations: Annotated[int, Field(ge=1)] = 1000
    gather_rays: Annotated[int, Field(ge=16, le=65536)] = 512
    precision: Literal["float32", "float64"] = "float32"
    spectral_samples: Annotated[int, Field(ge=0, le=64)] = 16
    cache: bool = True


class StudyConfig(_Model):
    """A whole study: the root of the TOML file."""

    study: StudyInfo = StudyInfo()
    groups: dict[Name, GroupConfig] = {}
    materials: dict[Name, MaterialConfig] = {}
    geometry: list[Geometry] = []
    photometry: dict[Name, Photometry] = {}
    luminaires: list[Luminaire] = []
    networks: dict[Name, NetworkConfig] = {}
    grids: list[Grid] = []
    solver: SolverConfig = SolverConfig()
    _source: Path | None = PrivateAttr(None)

    @property
    def source(self) -> Path | None:
        """The TOML file this config was read from (None when parsed from text)."""
        return self._source
