"""A study's scene: everything in world space and SI units, built once from a validated config."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np
from jaxtyping import Float

from ..config import FilePhotometry, StudyConfig
from ..errors import ConfigError, GeometryError, LumijaxError
from ._elements import AreaSource, Grid, Luminaire, Material, Network, plane_grid_points
from ._frames import Frame, aim_angles_towards, resolve_group_frames
from ._geometry import (
    Triangles,
    box_triangles,
    check_triangles,
    load_mesh_triangles,
    place,
    rectangle_triangles,
)
from ._raycast import RayCaster
from ._two_sided import two_sided

__all__ = ["Scene", "build_scene"]


@dataclass(frozen=True, eq=False)
class Scene:
    """Geometry, materials, luminaires, networks and grids of one study, in world space."""

    name: str
    source: Path | None
    triangles: Triangles
    materials: tuple[Material, ...]
    groups: tuple[str, ...]
    photometries: dict = field(repr=False)
    luminaires: tuple[Luminaire, ...]
    area_sources: tuple[AreaSource, ...]
    networks: tuple[Network, ...]
    grids: tuple[Grid, ...]
    #: Each luminaire's level, a factor on its config multiplier (None: all 1, as configured).
    levels: Float[np.ndarray, " lum"] | None = None
    #: Each luminaire's multiplier × maintenance factor: its ``scale`` before level and TILT
    #: factor, so that a re-aimed or re-levelled luminaire's scale is rebuilt, not divided out.
    rated_scales: Float[np.ndarray, " lum"] | None = None

    @cached_property
    def raycaster(self) -> RayCaster:
        """Embree scene over all triangles (built on first use); clear glass passes light with
        its τ(θ) (``GlazedCaster``) when the scene has any."""
        tau = np.array([m.tau if m.clear else 0.0 for m in self.materials])
        per_triangle = tau[self.triangles.material] if len(tau) else np.zeros(0)
        if np.any(per_triangle > 0):
            from ._glass import GlazedCaster

            return GlazedCaster(self.triangles.vertices, per_triangle)
        return RayCaster(self.triangles.vertices)

    @property
    def network_names(self) -> tuple[str, ...]:
        return tuple(n.name for n in self.networks)

    @property
    def dimmers(self) -> np.ndarray:
        return np.array([n.dimmer for n in self.networks])

    def with_design(self, design) -> Scene:
        """This scene at another :class:`lumijax.design.Design`: the networks at its dimmers,
        the luminaires at its aims (degrees) and levels. No config text in between; geometry,
        materials and grids are shared (and the ray caster, once built). An LM-63 TILT factor
        follows the new aim, as when the scene is built."""
        if design.networks != self.network_names or design.luminaires != tuple(
                lum.name for lum in self.luminaires):
            raise ConfigError("the design names other networks or luminaires than the scene "
                              f"{self.name!r} (networks: {', '.join(self.network_names)})",
                              file=self.source, key="design")
        networks = tuple(replace(nw, dimmer=float(d))
                         for nw, d in zip(self.networks, design.dimmers, strict=True))
        old_levels = np.ones(len(self.luminaires)) if self.levels is None else self.levels
        lums = []
        for i, lum in enumerate(self.luminaires):
            aim = (float(design.tilt_deg[i]), float(design.pan_deg[i]),
                   float(design.spin_deg[i]))
            level = float(design.level[i])
            if aim == (lum.tilt, lum.pan, lum.spin) and level == old_levels[i]:
                lums.append(lum)
                continue
            phot = self.photometries[lum.photometry]
            if self.rated_scales is not None:
                rated = float(self.rated_scales[i])
            else:  # a scene built by hand: divide out what build_scene multiplied in
                rated = lum.scale / (old_levels[i] * _tilt_factor(lum, phot))
            moved = replace(lum, tilt=aim[0], pan=aim[1], spin=aim[2])
            lums.append(replace(moved, scale=rated * level * _tilt_factor(moved, phot)))
        levels = np.array(design.level, np.float64)
        levels.flags.writeable = False
        new = replace(self, networks=networks, luminaires=tuple(lums), levels=levels)
        if "raycaster" in self.__dict__:  # same triangles: keep the Embree scene
            new.__dict__["raycaster"] = self.__dict__["raycaster"]
        return new

    def grid(self, name: str) -> Grid:
        for g in self.grids:
            if g.name == name:
                return g
        raise KeyError(f"no grid named {name!r}; grids: {', '.join(g.name for g in self.grids)}")

    def network_flux_lm(self) -> dict[str, float]:
        """Each network's luminous flux at dimmer 1: Σ integrated flux × scale (lm)."""
        out = {n.name: 0.0 for n in self.networks}
        for lum in self.luminaires:
            out[lum.network] += self.photometries[lum.photometry].integrated_lm * lum.scale
        for a in self.area_sources:
            out[a.network] += a.flux_lm * a.maintenance_factor
        return out


def build_scene(cfg: StudyConfig) -> Scene:
    """Turn a validated config into a :class:`Scene`.

    Reads photometry, spectra and mesh files; every failure becomes a :class:`LumijaxError`
    naming the config file and key.
    """
    from .. import photometry as _phot
    from ..config._schema import MAX_MAGNITUDE
    read_photometry = _phot.read_photometry
    isotropic, lambertian = _phot.isotropic, _phot.lambertian

    src = cfg.source
    frames = resolve_group_frames(cfg.groups)
    group_names = tuple(cfg.groups)

    def frame_of(group: str | None) -> Frame:
        return Frame.identity() if group is None else frames[group]

    def rekey(e: LumijaxError, key: str) -> LumijaxError:
        # Keep the file a problem is in (a photometry or mesh file); name the config key too.
        if e.file is not None and src is not None and Path(e.file) != src:
            return type(e)(f"{e.message} (from {src}: {key})", file=e.file, line=e.line, key=e.key)
        return type(e)(e.message, file=src, key=key if e.key is None else f"{key}: {e.key}")

    materials = tuple(_material(name, m, src) for name, m in cfg.materials.items())
    material_index = {m.name: i for i, m in enumerate(materials)}

    verts, item, mat, grp, closed = [], [], [], [], []
    for i, g in enumerate(cfg.geometry):
        key = f"geometry[{i}]"
        frame = frame_of(g.group)
        is_closed = False
        if g.kind == "box":
            tri = box_triangles(g.min, g.max, inward=g.normals == "inward")
            is_closed = g.normals == "outward"
        elif g.kind == "rectangle":
            if np.linalg.norm(np.cross(g.u, g.v)) <= 1e-12 * np.linalg.norm(g.u) * np.linalg.norm(g.v):
                raise ConfigError("'u' and 'v' are parallel or zero: the rectangle has no area",
                                  file=src, key=key)
            tri = rectangle_triangles(g.origin, g.u, g.v)
        else:
            try:
                tri, is_closed = load_mesh_triangles(g.file, units=g.units, key=f"{key}.file")
                check_triangles(tri, key=f"{key}.file", file=g.file)
            except LumijaxError as e:
                raise rekey(e, f"{key}.file") from None
            if g.flip_normals:
                tri = tri[:, ::-1]
                is_closed = False
        tri = place(tri, frame)
        if not np.abs(tri).max(initial=0.0) <= MAX_MAGNITUDE:  # a mesh file's or a group's scale
            what = f"{g.file.name}: a vertex" if g.kind == "mesh" else "a vertex"
            raise GeometryError(f"{what} lies {np.abs(tri).max():.3g} m from the origin, beyond "
                                f"±{MAX_MAGNITUDE:g} m (check the mesh's units and the group's "
                                "scale)", file=src, key=f"{key}.file" if g.kind == "mesh" else key)
        verts.append(tri)
        n = len(tri)
        item.append(np.full(n, i))
        mat.append(np.full(n, material_index[g.material]))
        grp.append(np.full(n, -1 if g.group is None else group_names.index(g.group)))
        closed.append(is_closed)
    triangles = Triangles(
        vertices=np.concatenate(verts) if verts else np.zeros((0, 3, 3)),
        item=np.concatenate(item) if item else np.zeros(0, int),
        material=np.concatenate(mat) if mat else np.zeros(0, int),
        group=np.concatenate(grp) if grp else np.zeros(0, int),
        closed=np.array(closed, bool),
    )
    _warn_coincident(triangles, cfg, src)
    triangles = two_sided(triangles, materials, src)  # back faces of diffusers (_two_sided.py)

    photometries = {}
    for name, p in cfg.photometry.items():
        try:
            if isinstance(p, FilePhotometry):
                photometries[name] = read_photometry(p.file)
            elif p.kind == "isotropic":
                photometries[name] = isotropic(p.flux_lm, p.luminous_diameter_m)
            else:
                photometries[name] = lambertian(p.flux_lm, p.luminous_diameter_m)
        except LumijaxError as e:
            raise rekey(e, f"photometry.{name}") from None

    if cfg.networks:
        networks = tuple(Network(n, c.dimmer, c.description) for n, c in cfg.networks.items())
    else:  # no [networks] table: every network a luminaire names exists, at full output
        used = dict.fromkeys(lum.network for lum in cfg.luminaires)
        networks = tuple(Network(n) for n in used)

    luminaires, areas = [], []
    for i, lum in enumerate(cfg.luminaires):
        key = f"luminaires[{i}]"
        frame = frame_of(lum.group)
        spectrum = _spectrum(lum.spectrum, src, f"{key}.spectrum")
        if lum.kind == "area":
            u, v = frame.vectors(lum.u), frame.vectors(lum.v)
            if np.linalg.norm(np.cross(u, v)) <= 1e-12 * np.linalg.norm(u) * np.linalg.norm(v):
                raise ConfigError("'u' and 'v' are parallel or zero: the source has no area",
                                  file=src, key=key)
            areas.append(AreaSource(
                name=lum.name, origin=frame.points(lum.origin), u=u, v=v, flux_lm=lum.flux_lm,
                network=lum.network, maintenance_factor=lum.maintenance_factor,
                spectrum=spectrum, config_index=i,
            ))
            continue
        position = frame.points(lum.position)
        rot = frame.rotation
        spin = lum.aim.spin if lum.aim is not None else 0.0
        if lum.aim_at is not None:
            direction = rot.T @ (frame.points(lum.aim_at) - position)
            tilt, pan = aim_angles_towards(direction)
        else:
            tilt = lum.aim.tilt if lum.aim is not None else 0.0
            pan = lum.aim.pan if lum.aim is not None else 0.0
        placed = Luminaire(
            name=lum.name, photometry=lum.photometry, position=position, tilt=tilt, pan=pan,
            spin=spin, network=lum.network, scale=lum.multiplier * lum.maintenance_factor,
            frame_rotation=rot, spectrum=spectrum, config_index=i,
        )
        placed = replace(placed, scale=placed.scale * _tilt_factor(placed,
                                                                   photometries[lum.photometry]))
        luminaires.append(placed)

    from ._standard_grids import build_grids  # the standards' kinds (docs/compliance.md)

    grids = build_grids(cfg, triangles, frame_of, lambda g, fr, key: _grid(g, fr, src, key), src)

    scene = Scene(
        name=cfg.study.name, source=src, triangles=triangles, materials=materials,
        groups=group_names, photometries=photometries, luminaires=tuple(luminaires),
        area_sources=tuple(areas), networks=networks, grids=grids,
        rated_scales=np.array([lum.multiplier * lum.maintenance_factor for lum in cfg.luminaires
                               if lum.kind != "area"], np.float64),
    )
    _check_luminaires_outside_solids(scene, cfg, src)
    return scene


def _tilt_factor(lum: Luminaire, phot) -> float:
    """LM-63 TILT: the lamp's output depends on its real tilt from straight down (1 without
    a TILT table)."""
    if phot.tilt is None:
        return 1.0
    world_tilt = float(np.degrees(np.arccos(np.clip(-lum.axis[2], -1.0, 1.0))))
    return float(phot.tilt.factor(world_tilt))


def _material(name: str, m, src) -> Material:
    from ..spectral import Spectrum, luminous_reflectance

    key = f"materials.{name}"

    def read(value, what: str):
        if value is None:
            return None
        if isinstance(value, float | int):
            return Spectrum.grey(float(value), name=f"{name} {what}")
        if isinstance(value, Path):
            return Spectrum.from_csv(value, "reflectance", name=f"{name} {what}")
        return Spectrum.from_name(value, "reflectance")

    try:
        if m.srgb is not None:
            refl = Spectrum.from_srgb(m.srgb, name=name)
        elif isinstance(m.reflectance, float | int):
            refl = Spectrum.grey(float(m.reflectance), name=name)
        elif isinstance(m.reflectance, Path):
            refl = Spectrum.from_csv(m.reflectance, "reflectance", name=name)
        else:
            refl = Spectrum.from_name(m.reflectance, "reflectance")
        spec = read(m.specular, "specular")
        trans = read(m.transmittance, "transmittance")
        white = Spectrum.from_name("E", "emission")
        rho = luminous_reflectance(refl, white)
        rho_s = 0.0 if spec is None else luminous_reflectance(spec, white)
        tau = 0.0 if trans is None else luminous_reflectance(trans, white)
    except LumijaxError as e:
        raise ConfigError(e.message, file=src if e.file is None else e.file, line=e.line,
                          key=key) from None
    if not rho < 1.0:
        raise ConfigError(f"reflectance must be < 1 (got {rho:.4f})", file=src, key=key)
    if spec is not None or trans is not None:
        _check_energy(refl, spec, trans, src, key)
    if m.kind == "clear":
        from ._glass import MAX_CLEAR_TRANSMITTANCE

        top = float(np.max(trans.values))
        if top > MAX_CLEAR_TRANSMITTANCE:
            raise ConfigError(
                f"clear glass transmits at most {MAX_CLEAR_TRANSMITTANCE:.4f} at normal "
                f"incidence (index 1.52, two surfaces, no absorption); got {top:.4f}: expected "
                "the pane's normal transmittance τ(0), or kind = \"diffuse\"",
                file=src, key=f"{key}.transmittance")
    return Material(
        name, refl, float(rho), specular=spec,
        roughness=0.05 if m.roughness is None else float(m.roughness),
        transmittance=trans, kind=m.kind, rho_s=float(rho_s), tau=float(tau),
    )


def _check_energy(refl, spec, trans, src, key: str) -> None:
    """ρ_d + ρ_s + τ ≤ 1 at every wavelength of 360–830 nm and every sample of the three."""
    parts = [s for s in (refl, spec, trans) if s is not None]
    wl = np.unique(np.concatenate([np.arange(360.0, 831.0)]
                                  + [s.wavelengths_nm for s in parts]))
    wl = wl[(wl >= 360.0) & (wl <= 830.0)]
    total = sum(s.at(wl) for s in parts)
    # 1e-9: grey inputs like 0.1 + 0.2 + 0.7 sum to 1 + 1 ulp, which is still "≤ 1"
    over = np.flatnonzero(total > 1.0 + 1e-9)
    if len(over):
        raise ConfigError(
            f"reflectance + specular + transmittance > 1 from {wl[over[0]]:g} nm (up to "
            f"{total.max():.4f}): a surface cannot return more light than it receives "
            "(expected a sum ≤ 1 at every wavelength)", file=src, key=key)


def _spectrum(value, src, key):
    if value is None:
        return None
    from ..spectral import Spectrum

    try:
        if isinstance(value, Path):
            return Spectrum.from_csv(value, "emission")
        return Spectrum.from_name(value, "emission")
    except LumijaxError as e:
        raise ConfigError(e.message, file=src if e.file is None else e.file, line=e.line,
                          key=key) from None


def _grid(g, frame: Frame, src, key: str) -> Grid:
    if g.kind == "points":
        pts = frame.points(np.asarray(g.points, np.float64))
        normals = np.broadcast_to(np.asarray(g.normals, np.float64), np.shape(g.points))
        if np.any(np.linalg.norm(normals, axis=1) == 0):
            raise ConfigError("a normal is the zero vector", file=src, key=f"{key}.normals")
        return Grid(g.name, pts, frame.normals(normals).copy(), target_lux=g.target_lux)
    u, v = frame.vectors(g.u), frame.vectors(g.v)
    cross = np.cross(u, v)
    if np.linalg.norm(cross) <= 1e-12 * np.linalg.norm(u) * np.linalg.norm(v):  # any unit
        raise ConfigError("'u' and 'v' are parallel or zero: the grid has no area",
                          file=src, key=key)
    from ..config._schema import MAX_GRID_POINTS, grid_count

    if g.spacing is not None:  # in world metres: a group's scale changes the count
        fu, fv = (grid_count(float(np.linalg.norm(e)), g.spacing) for e in (u, v))
    else:
        fu, fv = float(g.nu), float(g.nv)
    if not fu * fv <= MAX_GRID_POINTS:
        raise ConfigError(f"about {fu * fv:.3g} points, more than the {MAX_GRID_POINTS:.0e} a grid "
                          "may have; use a coarser 'spacing' (m) or smaller 'nu'/'nv'",
                          file=src, key=f"{key}.spacing" if g.spacing is not None else key)
    nu, nv = int(fu), int(fv)
    origin = frame.points(g.origin)
    if g.normal is not None:
        if np.linalg.norm(g.normal) == 0:
            raise ConfigError("'normal' is the zero vector", file=src, key=f"{key}.normal")
        n = frame.normals(np.asarray(g.normal, np.float64))
    else:
        n = cross / np.linalg.norm(cross)
    pts = plane_grid_points(origin, u, v, nu, nv)
    return Grid(g.name, pts, np.broadcast_to(n, pts.shape).copy(), shape=(nu, nv),
                origin=origin, u=u, v=v, target_lux=g.target_lux)


def _warn_coincident(tri, cfg: StudyConfig, src) -> None:
    """Warn of same-facing coincident surfaces of two geometry items (``_coplanar``)."""
    import warnings

    from ..errors import LumijaxWarning
    from ._coplanar import coincident_surfaces

    def name(i: int) -> str:
        g = cfg.geometry[i]
        label = f"geometry[{i}]" if g.name is None else f"geometry {g.name!r} (geometry[{i}])"
        return f"{label}, a {g.kind}"

    for c in coincident_surfaces(tri.vertices, tri.item):
        # the item listed later usually is the one laid on the other (a rug on a floor)
        warnings.warn(
            f"{src}: {name(c.b)} lies on {name(c.a)} ({c.area_m2:.2f} m² coincident, facing "
            "the same way): light is counted twice; remove one or offset it by ≥ 1 mm",
            LumijaxWarning, stacklevel=3,
        )


def _check_luminaires_outside_solids(scene: Scene, cfg: StudyConfig, src) -> None:
    """A light inside a closed solid lights nothing: almost surely a placement error."""
    tri = scene.triangles
    closed_items = np.flatnonzero(tri.closed)
    if not len(closed_items) or not scene.luminaires:
        return
    from ._inside import inside_closed

    positions = np.array([lum.position for lum in scene.luminaires])
    for item in closed_items:
        v = tri.vertices[tri.item == item]
        lo, hi = v.reshape(-1, 3).min(axis=0), v.reshape(-1, 3).max(axis=0)
        cand = np.flatnonzero(np.all((positions > lo) & (positions < hi), axis=1))
        if not len(cand):
            continue
        inside = inside_closed(v, positions[cand])
        if inside.any():
            lum = scene.luminaires[cand[int(np.argmax(inside))]]
            raise GeometryError(
                f"luminaire {lum.name!r} at {np.round(lum.position, 4).tolist()} is inside the "
                f"closed solid geometry[{item}]: it would light nothing. Move it outside, or use "
                "normals = \"inward\" if that box is a room",
                file=src,
                key=f"luminaires[{lum.config_index}].position",
            )
