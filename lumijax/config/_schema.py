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

from .. import _dimmers
from ._design_goals import ConstrainedMethod, ConstraintConfig, DesignObjective

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
    "CameraConfig",
    "SolverConfig",
    "AimRange",
    "OptimiseConfig",
]


#: Largest magnitude of a coordinate, vector component or angle (m, or degrees): 10⁹ m is
#: beyond any site (geodetic coordinates are ~10⁷ m) and keeps areas (m²) and squared
#: distances far from float64 overflow; a larger number is a typo, not a model.
MAX_MAGNITUDE = 1e9


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError("must be a finite number")
    return v


def _bounded(v: float) -> float:
    if abs(v) > MAX_MAGNITUDE:
        raise ValueError(f"{v:g} is beyond ±{MAX_MAGNITUDE:g} (m for coordinates, degrees for "
                         "angles): a typo, not a model")
    return v


Finite = Annotated[float, AfterValidator(_finite), AfterValidator(_bounded)]
Positive = Annotated[float, Field(gt=0), AfterValidator(_finite)]
NonNegative = Annotated[float, Field(ge=0), AfterValidator(_finite)]

#: Largest illuminance a goal may ask for (lx): 10⁹ lx is ten thousand times direct sunlight. A
#: goal beyond it is a typo, and its square overflows the objective in float32/float64 fits.
MAX_LUX = 1e9
#: Largest luminance a goal may name (cd/m²): the sun's disc is about 1.6·10⁹ cd/m².
MAX_LUMINANCE_CDM2 = 1e10
#: Largest luminous flux of one source (lm): 10¹⁰ lm is ten thousand stadium floodlights.
MAX_FLUX_LM = 1e10
#: Most points one plane grid may have: 10⁸ points take ~5 GB for their coordinates alone.
MAX_GRID_POINTS = 100_000_000


def _at_most(limit: float, unit: str):
    def check(v: float | None) -> float | None:
        if v is not None and v > limit:
            raise ValueError(f"{v:g} {unit} is beyond the largest accepted value {limit:g} {unit}")
        return v

    return AfterValidator(check)


def grid_count(length_m: float, spacing_m: float) -> float:
    """Points along an edge of ``length_m`` at ``spacing_m`` (at least 1), as the scene counts
    them, in floats: inf when the spacing is too small to count, never an OverflowError."""
    n = length_m / spacing_m
    return max(1.0, float(round(n))) if math.isfinite(n) else math.inf


Lux = Annotated[float, Field(ge=0), AfterValidator(_finite), _at_most(MAX_LUX, "lx")]
PositiveLux = Annotated[float, Field(gt=0), AfterValidator(_finite), _at_most(MAX_LUX, "lx")]
Luminance = Annotated[float, Field(gt=0), AfterValidator(_finite),
                      _at_most(MAX_LUMINANCE_CDM2, "cd/m²")]
Flux = Annotated[float, Field(gt=0), AfterValidator(_finite), _at_most(MAX_FLUX_LM, "lm")]
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


def _ordered_range(v):
    if v is not None and v[0] > v[1]:
        raise ValueError(f"the range [{v[0]:g}, {v[1]:g}] is empty: its lower end must not "
                         "exceed its upper end")
    return v


Range = Annotated[tuple[Finite, Finite], AfterValidator(_ordered_range)]


class AimRange(_Model):
    """``aim_range_deg = { tilt = [lo, hi], pan = [lo, hi] }``: how far the optimiser may turn
    a luminaire's aim, in degrees relative to its config aim (``[0, 0]`` holds it fixed)."""

    tilt: Range | None = None
    pan: Range | None = None


class GroupConfig(_Model):
    """``[groups.NAME]``: a local frame, ``p_parent = translate + R·(scale ⊙ p)``."""

    parent: Name | None = None
    translate: Vec3 = (0.0, 0.0, 0.0)
    rotate: Vec3 = Field((0.0, 0.0, 0.0), description="degrees about x, then y, then z")
    scale: Finite | Vec3 = 1.0
    aim_range_deg: AimRange | None = None

    @field_validator("scale")
    @classmethod
    def _positive_scale(cls, v):
        vals = (v,) if isinstance(v, float | int) else v
        if any(s <= 0 for s in vals):
            raise ValueError("scale factors must be > 0")
        return v


class MaterialConfig(_Model):
    """``[materials.NAME]``: a diffuse reflectance (grey, spectral or sRGB), and optionally a
    specular reflectance with its Ward roughness and a transmittance (clear or diffuse).

    The energy balance ρ_d + ρ_s + τ ≤ 1 is checked here for grey values and per wavelength
    (spectra) when the scene is built (``lumijax.scene``), naming ``materials.NAME``.
    """

    reflectance: Finite | str | Path | None = Field(
        None, description="grey value, CSV path (resolved to a Path) or dataset name"
    )
    srgb: Vec3 | None = None
    specular: Finite | str | Path | None = Field(
        None, description="specular reflectance: grey value, CSV path or dataset name"
    )
    roughness: Positive | None = Field(
        None, description="Ward α (isotropic, rms slope); 0.05 when 'specular' is set"
    )
    transmittance: Finite | str | Path | None = Field(
        None, description="transmittance (normal incidence for clear glass): grey, CSV or name"
    )
    kind: Literal["clear", "diffuse"] | None = Field(
        None, description="how 'transmittance' passes light: clear (specular) or diffuse"
    )

    @field_validator("reflectance", "specular", "transmittance")
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
        for key in ("specular", "transmittance"):
            v = getattr(self, key)
            if isinstance(v, float) and not 0.0 <= v < 1.0:
                raise ValueError(f"{key} must be in [0, 1) (got {v})")
        if self.roughness is not None and self.specular is None:
            raise ValueError("'roughness' is the spread of a specular reflection: it needs "
                             "'specular'")
        if (self.transmittance is None) != (self.kind is None):
            raise ValueError("'transmittance' needs 'kind' (\"clear\" or \"diffuse\"), and "
                             "'kind' needs 'transmittance'")
        grey = [v for v in (self.reflectance, self.specular, self.transmittance)
                if isinstance(v, float)]
        if len(grey) >= 2 and sum(grey) > 1.0:
            raise ValueError(
                f"reflectance + specular + transmittance = {sum(grey):g} > 1: a surface cannot "
                "return more light than it receives"
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
    flux_lm: Flux
    #: The luminous opening's diameter (m): a sphere for ``isotropic``, a downward disk for
    #: ``lambertian`` (whose luminance is then Φ/(πA) from every direction). Glare ratings use
    #: it; without it the source is a point (docs/glare.md's minimum size).
    luminous_diameter_m: Positive | None = None


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
    multiplier: Annotated[NonNegative, _at_most(1e6, "(a scale factor)")] = 1.0
    maintenance_factor: Annotated[float, Field(gt=0, le=1)] = 1.0
    aim_range_deg: AimRange | None = None

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
    flux_lm: Flux
    maintenance_factor: Annotated[float, Field(gt=0, le=1)] = 1.0


def _luminaire_kind(v) -> str | None:
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

    dimmer: Annotated[float, Field(ge=_dimmers.LOW, le=_dimmers.HIGH)] = _dimmers.DEFAULT
    description: str = ""
    power_w: NonNegative | None = Field(None, description="W at dimmer 1 (energy term)")


class _GridBase(_Model):
    name: Name
    group: Name | None = None
    target_lux: Lux | None = None
    target_csv: Path | None = Field(None, description="CSV x,y,z,lux at the grid's points")
    target_weight: Annotated[NonNegative, _at_most(1e6, "(a relative weight)")] = 1.0
    min_lux: Lux | None = None
    max_lux: PositiveLux | None = None
    uniformity_min: Annotated[float, Field(gt=0, le=1)] | None = None
    max_luminance_cdm2: Luminance | None = None
    reflectance: Annotated[float, Field(ge=0, lt=1)] | None = None

    @field_validator("target_csv", mode="before")
    @classmethod
    def _csv(cls, v, info: ValidationInfo):
        return None if v is None else _resolve(str(v), info)

    @model_validator(mode="after")
    def _targets(self):
        if self.target_lux is not None and self.target_csv is not None:
            raise ValueError("give 'target_lux' or 'target_csv', not both")
        if self.min_lux is not None and self.max_lux is not None and self.min_lux > self.max_lux:
            raise ValueError(f"'min_lux' ({self.min_lux:g}) exceeds 'max_lux' "
                             f"({self.max_lux:g}): no illuminance can meet both")
        if self.max_luminance_cdm2 is not None and self.reflectance is None:
            raise ValueError("'max_luminance_cdm2' needs the grid's 'reflectance' "
                             "(luminance L = reflectance × E / π)")
        return self


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

    # Counted in floats: a tiny spacing must give a clear error, not an OverflowError. Field
    # validators (u and v, then nu, are validated first) so that the error names the key.
    @field_validator("spacing")
    @classmethod
    def _spacing_count(cls, v, info: ValidationInfo):
        edges = [info.data.get(k) for k in ("u", "v")]
        if v is None or None in edges:
            return v
        n = grid_count(math.hypot(*edges[0]), v) * grid_count(math.hypot(*edges[1]), v)
        if not n <= MAX_GRID_POINTS:
            many = f"about {n:.3g} points" if math.isfinite(n) else "more points than can be counted"
            raise ValueError(f"{v:g} m over u and v gives {many}, more than the "
                             f"{MAX_GRID_POINTS:.0e} a grid may have: use a coarser spacing (m)")
        return v

    @field_validator("nv")
    @classmethod
    def _nu_nv_count(cls, v, info: ValidationInfo):
        nu = info.data.get("nu")
        if v is not None and nu is not None and nu * v > MAX_GRID_POINTS:
            raise ValueError(f"nu × nv = {nu} × {v} = {nu * v:.3g} points, more than the "
                             f"{MAX_GRID_POINTS:.0e} a grid may have")
        return v


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


# the standards' grid kinds (docs/compliance.md) build on _GridBase, defined above
from ._compliance import AreaGrid, ComplianceConfig, SensorGrid, SurfaceGrid  # noqa: E402

Grid = Annotated[PlaneGrid | PointsGrid | SensorGrid | AreaGrid | SurfaceGrid,
                 Field(discriminator="kind")]


#: Names of the tone curves of ``report._tonemap.TONE_CURVES`` and of the optimisers of
#: ``optimise._solvers.OPTIMISERS`` (``"auto"``: the default one); each registry is checked
#: against its Literal at import (lumijax/_registry.py).
ToneCurveName = Literal["filmic", "reinhard", "clip"]
OptimiserName = Literal["auto", "lbfgsb", "jaxopt_lbfgsb", "projected_gradient",
                        "levenberg_marquardt", "gauss_newton", "dogleg", "bfgs"]
#: Names of ``radiosity._solvers.RADIOSITY_SOLVERS``, the ``[solver] method`` choices.
RadiosityMethodName = Literal["refined", "bicgstab", "gmres", "southwell", "jacobi"]


class CameraConfig(_Model):
    """``[cameras.NAME]``: a view of the scene for the report and the viewer (docs/report.md)."""

    position: Vec3
    target: Vec3
    up: Vec3 = (0.0, 0.0, 1.0)
    fov_deg: Annotated[float, Field(gt=0, lt=180)] = Field(50.0, description="vertical, deg")
    kind: Literal["realistic", "falsecolour"] = "realistic"
    quantity: Literal["luminance", "illuminance"] = "luminance"
    scale: Literal["linear", "log"] = "log"
    levels: list[Positive] | None = None
    exposure_ev: Finite | None = Field(None, description="EV at ISO 100; None: automatic")
    tone: ToneCurveName = "filmic"
    size: tuple[Annotated[int, Field(ge=64, le=8192)], Annotated[int, Field(ge=64, le=8192)]] = (
        1280, 800)
    markers: bool = False

    @model_validator(mode="after")
    def _geometry(self):
        d = [t - p for t, p in zip(self.target, self.position, strict=True)]
        n = math.sqrt(sum(x * x for x in d))
        if n == 0:
            raise ValueError("'target' is the camera's own position: no direction to look")
        up = math.sqrt(sum(x * x for x in self.up))
        cross = (d[1] * self.up[2] - d[2] * self.up[1], d[2] * self.up[0] - d[0] * self.up[2],
                 d[0] * self.up[1] - d[1] * self.up[0])
        if up == 0 or math.sqrt(sum(x * x for x in cross)) <= 1e-9 * n * up:
            raise ValueError("'up' must be a non-zero vector not parallel to target - position")
        return self


class SolverConfig(_Model):
    """``[solver]``: how inter-reflected light is computed (docs/config.md, docs/radiosity.md)."""

    indirect: bool = True
    patch_size: Positive | None = Field(None, description="m; default: automatic")
    # None: the count follows from ``accuracy`` (at most 4,000; docs/radiosity.md, "Patch
    # count against an accuracy target"); a number: about that many, as before the rule
    target_patches: Annotated[int, Field(ge=10, le=10_000_000)] | None = None
    accuracy: Annotated[float, Field(ge=1e-4, le=0.5)] = 0.01
    # None: by the patch count (lighting._settings.block_size: 384 up to 4,096, else 1,024)
    max_block: Annotated[int, Field(ge=16, le=8192)] | None = None
    method: RadiosityMethodName = "refined"
    tolerance: Annotated[float, Field(gt=0, lt=1)] | None = None
    max_iterations: Annotated[int, Field(ge=1)] = 1000
    # None: 512 a point, up to 4,096 on small grids (lighting._settings.gather_rays_for)
    gather_rays: Annotated[int, Field(ge=16, le=65536)] | None = None
    precision: Literal["float32", "float64"] = "float32"
    spectral_samples: Annotated[int, Field(ge=0, le=64)] = 16
    cache: bool = True
    refine: Annotated[int, Field(ge=0, le=6)] = 0
    refine_threshold: Annotated[float, Field(gt=0, le=1)] = 0.5
    operator_patches: Annotated[int, Field(ge=10, le=10_000_000)] | None = None
    # "blocks": the exact block operator; "sampled": ray-sampled form factors, O(P·rays)
    # memory for open scenes of 10⁵–10⁶ patches (docs/radiosity.md, "Sampled transport")
    transport: Literal["blocks", "sampled"] = "blocks"
    # "auto": 256, and a final gather of as many as ≈ 3 % noise per patch needs
    # (docs/radiosity.md, "Final gather of the sampled transport")
    rays_per_patch: Annotated[int, Field(ge=16, le=65536)] | Literal["auto"] = 256
    # of those, the share aimed at the directly lit patches (radiosity/_bright.py); 0: none
    aimed_share: Annotated[float, Field(ge=0, le=0.9)] = 0.25
    # rays a patch of the sampled transport's final gather (radiosity/_sampled_gather.py):
    # each patch's inter-reflected light cast once more, never stored; None: none ("auto"
    # rays_per_patch sets it to what ≈ 3 % per patch needs)
    final_gather_rays: Annotated[int, Field(ge=16, le=65536)] | None = None

    @model_validator(mode="after")
    def _final_gather_is_sampled(self):
        n = self.final_gather_rays
        if n is not None and self.transport != "sampled":
            raise ValueError("'final_gather_rays' gathers the sampled transport's light once "
                             "more: it needs transport = \"sampled\" (the block operator "
                             "has no noise to gather away)")
        # "auto" builds its operator at 256 rays (lighting._settings.AUTO_FIRST_RAYS)
        operator = 256 if self.rays_per_patch == "auto" else self.rays_per_patch
        if n is not None and n <= operator:
            raise ValueError(f"'final_gather_rays' = {n} is no more than the operator's "
                             f"{operator} rays a patch: a final gather of fewer rays would add "
                             "noise, not remove it; give more rays, or leave it out")
        return self


class OptimiseConfig(_Model):
    """``[optimise]``: fit dimmers (and aims) to the grids' targets (docs/optimise.md)."""

    variables: Annotated[list[Literal["dimmers", "aims", "levels"]], Field(min_length=1)] = [
        "dimmers"]
    solver: OptimiserName = "auto"
    max_steps: Annotated[int, Field(ge=1, le=100_000)] = 200
    tolerance: Annotated[float, Field(gt=0, lt=1)] = 1e-8
    dimmer_min: Annotated[float, Field(ge=0, le=1)] = 0.0
    energy_weight: Annotated[NonNegative, _at_most(1e6, "(a relative weight)")] = 0.0
    constraint_weight: Annotated[Positive, _at_most(1e6, "(a relative weight)")] = 10.0
    tilt_range_deg: Range = (-15.0, 15.0)
    pan_range_deg: Range = (-15.0, 15.0)
    max_luminance_cdm2: Luminance | None = None
    indirect: bool = True
    # a constrained design (docs/optimise.md, "Design to a standard"; the models are in
    # _design_goals.py): None keeps the least-squares fit above
    objective: DesignObjective | None = None
    method: ConstrainedMethod = "auto"
    constraints: list[ConstraintConfig] = []
    constraint_tolerance: Annotated[float, Field(gt=0, le=0.1)] = 1e-3
    smoothing: Annotated[float, Field(gt=0, le=0.1)] = 1e-3
    starts: Annotated[int, Field(ge=1, le=64)] = 1
    seed: Annotated[int, Field(ge=0)] = 0

    @model_validator(mode="after")
    def _constraints_need_an_objective(self):
        if self.constraints and self.objective is None:
            raise ValueError("'constraints' are hard constraints of a constrained design: "
                             "give 'objective' (\"power\" or \"misfit\") too")
        return self

    @field_validator("variables")
    @classmethod
    def _unique(cls, v):
        if len(set(v)) != len(v):
            raise ValueError(f"each variable may appear once, got {v}")
        return v


# after the field types it uses (_observers imports them from here)
from ._observers import ObserverConfig  # noqa: E402


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
    cameras: dict[Name, CameraConfig] = {}
    solver: SolverConfig = SolverConfig()
    optimise: OptimiseConfig | None = None
    compliance: ComplianceConfig | None = None
    observers: list[ObserverConfig] = []
    _source: Path | None = PrivateAttr(None)

    @property
    def source(self) -> Path | None:
        """The TOML file this config was read from (None when parsed from text)."""
        return self._source
