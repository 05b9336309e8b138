"""Perspective views of the lit surfaces: realistic (tone-mapped colour) and false colour.

Both draw the view-independent radiosity solution unlit (``lighting=False``): a pixel's colour
is the vertex colours interpolated, nothing else, so the picture is the numbers. Back faces are
culled: a room seen from outside opens like a doll's house.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from ._camera import Camera
from ._falsecolour import DEFAULT_CMAP, N_COLOURS, _cmap, _fmt, nice_levels
from ._png import png_bytes
from ._tonemap import auto_ev100, tone_map

__all__ = ["render_realistic", "render_falsecolour_view", "write_png", "in_view",
           "auto_exposure",
           "view_colours", "fitting_colour", "fitting_rgb", "beam_outline", "traced_xyz"]

BACKGROUND = "#15181e"  # a night sky: dark, slightly blue, so black shadows still read as shadow


def _plotter(size):
    """A blank off-screen plotter of ``size``, lent (``_plotters``: kept for the next view of
    that size, so its window and shaders are made once); use it as a context manager."""
    from ._plotters import plotter

    return plotter(size)


def _place(pl, cam: Camera) -> None:
    c = pl.camera
    c.position = tuple(cam.position)
    c.focal_point = tuple(cam.target)
    c.up = tuple(cam.up)
    c.view_angle = float(cam.fov_deg)  # VTK's view angle is the vertical field of view
    pl.renderer.ResetCameraClippingRange()


def _shot(pl) -> np.ndarray:
    pl.render()
    img = pl.screenshot(None, return_img=True, transparent_background=False)
    return np.asarray(img)[..., :3]


def view_colours(surface, dimmers, ev: float, tone: str = "filmic") -> np.ndarray:
    """Display sRGB (uint8, (V, 3)) of the surface vertices at ``dimmers`` and exposure ``ev``."""
    rgb = tone_map(surface.xyz_at(dimmers), ev, tone)
    return np.round(rgb * 255.0).astype(np.uint8)


def in_view(cam: Camera, points, normals) -> np.ndarray:
    """Which points the camera sees (inside its frame, in front of it, front face towards it);
    occlusion is not checked."""
    pos = np.asarray(cam.position, np.float64)
    f = np.asarray(cam.target, np.float64) - pos
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(cam.up, np.float64))
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = np.asarray(points, np.float64) - pos
    z = d @ f
    t = np.tan(np.radians(cam.fov_deg) / 2.0)
    aspect = cam.size[0] / cam.size[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = (d @ r) / z, (d @ u) / z
    facing = np.einsum("ij,ij->i", np.asarray(normals, np.float64), -d) > 0
    return (z > 0) & (np.abs(x) <= t * aspect) & (np.abs(y) <= t) & facing


def auto_exposure(surface, dimmers, cam: Camera | None = None) -> float:
    """Metered EV100 (``docs/report.md``): on the area-weighted median luminance of the lit
    surfaces in view, but at least EV(L95) − 2, so the brightest 5 % (the lit facade of a
    night scene) sit on the tone curve's shoulder instead of burning out."""
    lum = surface.luminance_at(dimmers)
    w = surface.vertex_area
    if cam is not None:
        seen = in_view(cam, surface.points, surface.normals)
        if np.any(seen & (lum > 0)):
            lum, w = lum[seen], w[seen]
    return max(auto_ev100(lum, w), auto_ev100(lum, w, quantile=0.95) - 2.0)


@functools.lru_cache(maxsize=64)
def _lamp_rgb(spectrum) -> np.ndarray:
    """Linear sRGB of a lamp's chromaticity, largest channel 1 (cached: integrating a spectrum
    takes a moment, and a study has few spectra but many luminaires)."""
    import colour

    from ..spectral import tristimulus

    lin = np.maximum(np.asarray(colour.XYZ_to_sRGB(tristimulus(spectrum),
                                                   apply_cctf_encoding=False)), 0.0)
    return lin / max(float(lin.max()), 1e-12)


def fitting_colour(luminaire, dimmer: float) -> np.ndarray:
    """sRGB (in [0, 1]) of a fitting's glowing face: its lamp's chromaticity, as bright as a
    display allows, fading to the dark body colour as its dimmer goes to 0."""
    import colour

    spectrum = luminaire.spectrum  # Luminaire and AreaSource both carry one (or None)
    lin = np.ones(3) if spectrum is None else _lamp_rgb(spectrum)
    body = np.full(3, 0.02)
    d = float(np.clip(dimmer, 0.0, 1.0))
    lin = body + (lin - body) * d ** 0.5  # perceptual fade: half-dimmed still glows
    return np.asarray(colour.cctf_encoding(np.clip(lin, 0, 1), function="sRGB"), np.float64)


def beam_outline(distribution, n_azimuth: int = 36) -> tuple[np.ndarray, np.ndarray]:
    """``(peak direction (3,), rim directions (n, 3))`` in the luminaire frame: around the
    direction of peak intensity, the angle at which intensity first falls to half the peak
    (the half-peak "beam angle" edge, IES LM-63's definition), per azimuth."""
    from ._polar import intensity_np

    peak, h, v = distribution.max_intensity()
    p = np.asarray(distribution.direction(h, v), np.float64)
    p = p / np.linalg.norm(p)
    a = np.array([1.0, 0.0, 0.0]) if abs(p[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(p, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(p, e1)
    theta = np.radians(np.linspace(0.0, 90.0, 361))
    phi = np.linspace(0.0, 2 * np.pi, n_azimuth, endpoint=False)
    ring = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2  # (A, 3)
    d = (np.cos(theta)[None, :, None] * p + np.sin(theta)[None, :, None] * ring[:, None, :])
    cd = intensity_np(distribution, d)
    below = cd < 0.5 * peak
    idx = np.where(below.any(axis=1), below.argmax(axis=1), len(theta) - 1)
    rim = d[np.arange(len(phi)), idx]
    return p, rim


def _template(poly) -> tuple[np.ndarray, np.ndarray]:
    """(points, triangles) of a pyvista source, triangulated."""
    t = poly.triangulate()
    return np.asarray(t.points, np.float64), np.asarray(t.faces).reshape(-1, 4)[:, 1:]


def _basis(axis) -> np.ndarray:
    """A rotation taking local +z to ``axis`` (columns: two perpendiculars and the axis)."""
    a = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(a, ref)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(a, e1), a])


def _merge(template, frames, scale: float):
    """Copies of a template mesh at each (position, rotation), scaled, as one PolyData."""
    import pyvista as pv

    pts, tri = template
    allp = np.concatenate([pos + scale * pts @ rot.T for pos, rot in frames])
    allt = np.concatenate([tri + i * len(pts) for i in range(len(frames))])
    return pv.PolyData(allp, faces=np.column_stack([np.full(len(allt), 3), allt]).ravel())


def fitting_rgb(scene, dimmers, n_points: int) -> np.ndarray:
    """Per-point uint8 colours of the merged fitting faces (``n_points`` per luminaire)."""
    level = dict(zip(scene.network_names, np.asarray(dimmers, np.float64), strict=True))
    # one colour per (lamp spectrum, network): a courtyard's 230 fittings have a dozen. The
    # spectrum is keyed by its content (Spectrum's hash), not its object: each luminaire of a
    # study holds its own copy, and sRGB's encoding per fitting took 0.8 s of a demo report
    seen: dict[tuple, np.ndarray] = {}
    keys = [(lum.spectrum, lum.network) for lum in scene.luminaires]
    for lum, key in zip(scene.luminaires, keys, strict=True):
        if key not in seen:
            seen[key] = fitting_colour(lum, level[lum.network])
    colours = np.stack([seen[key] for key in keys])
    return np.round(np.repeat(colours, n_points, axis=0) * 255).astype(np.uint8)


#: id(scene) → (scene, [(position, basis)] per luminaire); the scene is held, so its id stays
#: its own. A report draws one scene a dozen times (each network alone): the fittings' frames
#: (each a rotation built from the aim angles) are computed once.
_FRAMES: dict[int, tuple[object, list]] = {}


def _luminaire_frames(scene) -> list[tuple[np.ndarray, np.ndarray]]:
    hit = _FRAMES.get(id(scene))
    if hit is not None and hit[0] is scene:
        return hit[1]
    frames = [(np.asarray(lum.position, np.float64), _basis(lum.axis))
              for lum in scene.luminaires]
    if len(_FRAMES) >= 8:
        _FRAMES.pop(next(iter(_FRAMES)))
    _FRAMES[id(scene)] = (scene, frames)
    return frames


def _fittings(pl, scene, dimmers, cam: Camera, markers: bool, raycast: bool = True):
    """Luminaires as small glowing fittings (a dark can with a face in the lamp's colour),
    area sources as glowing rectangles; with ``markers``, aim lines and half-peak beam cones.
    Returns the merged faces mesh (None without luminaires), to recolour when dimmers move."""
    import pyvista as pv

    dist = float(np.linalg.norm(np.subtract(cam.position, cam.target)))
    r = float(np.clip(0.004 * dist, 0.03, 0.25))
    level = dict(zip(scene.network_names, np.asarray(dimmers, np.float64), strict=True))
    beams: dict[str, tuple] = {}
    faces = None
    if scene.luminaires:
        # one mesh for all cans and one for all faces: hundreds of actors draw slowly
        can_t = _template(pv.Cylinder(center=(0, 0, -0.6), direction=(0, 0, 1), radius=1.0,
                                      height=1.2, resolution=16))
        face_t = _template(pv.Disc(center=(0, 0, 1e-3), normal=(0, 0, 1), inner=0.0,
                                   outer=0.85, c_res=16))
        frames = _luminaire_frames(scene)
        cans = _merge(can_t, frames, r)
        faces = _merge(face_t, frames, r)
        faces.point_data["rgb"] = fitting_rgb(scene, dimmers, face_t[0].shape[0])
        pl.add_mesh(cans, color=(0.12, 0.12, 0.13), lighting=False)
        pl.add_mesh(faces, scalars="rgb", rgb=True, lighting=False, show_scalar_bar=False)
    for lum in scene.luminaires if markers else ():
        axis = lum.axis / np.linalg.norm(lum.axis)
        pos = np.asarray(lum.position, np.float64)
        length = 3.0 * dist / 10.0
        if raycast:
            _, hit = scene.raycaster.first_hit(pos[None], axis[None])
            if np.isfinite(hit[0]):
                length = float(hit[0])
        pl.add_mesh(pv.Line(pos, pos + axis * length), color="#ffd54a", line_width=2,
                    lighting=False)
        if lum.photometry not in beams:
            beams[lum.photometry] = beam_outline(scene.photometries[lum.photometry].distribution)
        _, rim = beams[lum.photometry]
        rim_world = pos + (rim @ lum.rotation.T) * length
        pts = np.vstack([pos, rim_world])
        n = len(rim_world)
        tris = np.column_stack([np.full(n, 3), np.zeros(n, int), 1 + np.arange(n),
                                1 + (np.arange(n) + 1) % n]).ravel()
        pl.add_mesh(pv.PolyData(pts, faces=tris), color="#ffd54a", opacity=0.18,
                    lighting=False)
        ring = np.column_stack([np.full(n, 2), 1 + np.arange(n), 1 + (np.arange(n) + 1) % n])
        pl.add_mesh(pv.PolyData(pts, lines=ring.ravel()), color="#ffd54a", line_width=1,
                    lighting=False)
    for a in scene.area_sources:
        quad = pv.PolyData(np.array([a.origin, a.origin + a.u, a.origin + a.u + a.v,
                                     a.origin + a.v]), faces=[4, 0, 1, 2, 3])
        pl.add_mesh(quad, color=fitting_colour(a, level[a.network]), lighting=False,
                    culling="back")
    return faces


def render_realistic(surface, cam: Camera, dimmers, scene=None, *, ev: float | None = None,
                     tone: str | None = None, markers: bool | None = None) -> tuple[np.ndarray,
                                                                                    float]:
    """A photo-like view: ``(image (H, W, 3) uint8, EV100 used)``.

    Exposure: ``ev``, else the camera's ``exposure_ev``, else metered (:func:`auto_exposure`).
    ``scene`` adds the luminaires (and, with ``markers``, their aim lines and beam cones).
    Where a material of ``scene`` is specular or clear, the view is traced instead
    (:func:`traced_xyz`, docs/render.md): reflections and glass shown, the luminaires at their
    own luminance, markers not drawn.
    """
    if ev is None:
        ev = cam.exposure_ev if cam.exposure_ev is not None else auto_exposure(
            surface, dimmers, cam)
    if scene is not None and surface.material is not None and _traced(scene):
        # specular or clear surfaces: the ray-traced second pass (lumijax.render)
        image = traced_image(surface, scene, cam, dimmers)
        rgb = tone_map(image.xyz.reshape(-1, 3), ev, tone or cam.tone).reshape(image.xyz.shape)
        out = np.round(np.clip(rgb, 0, 1) * 255.0).astype(np.uint8)
        sky = np.array([int(BACKGROUND[i:i + 2], 16) for i in (1, 3, 5)], np.uint8)
        out[~image.hit] = sky  # the raster's background where a ray meets nothing
        return out, float(ev)
    mesh = surface.polydata()
    mesh.point_data["rgb"] = view_colours(surface, dimmers, ev, tone or cam.tone)
    with _plotter(cam.size) as pl:
        pl.set_background(BACKGROUND)
        pl.add_mesh(mesh, scalars="rgb", rgb=True, lighting=False, culling="back",
                    show_scalar_bar=False)
        if scene is not None:
            _fittings(pl, scene, dimmers, cam, cam.markers if markers is None else markers)
        _place(pl, cam)
        return _shot(pl), float(ev)


def _traced(scene) -> bool:
    """Whether a scene's views need the traced pass: some material reflects specularly or
    passes light straight through (the raster draws diffuse radiosity exactly, and faster)."""
    from ..render import optics_of

    return optics_of(scene.materials).any_specular


@functools.lru_cache(maxsize=4)
def _tracer(surface, scene):
    from ..render import Tracer

    return Tracer.for_scene(scene, surface)


def traced_image(surface, scene, cam: Camera, dimmers):
    """The :class:`lumijax.render.LuminanceImage` of a perspective camera's view traced
    through ``scene`` (:class:`lumijax.render.Tracer`, depth 2): specular reflections, clear
    glass and the luminaires at their luminance included."""
    from ..render import Perspective

    view = Perspective(position=tuple(cam.position), target=tuple(cam.target),
                       up=tuple(cam.up), size=tuple(cam.size), fov_deg=float(cam.fov_deg))
    return _tracer(surface, scene).render(view, dimmers)


def traced_xyz(surface, scene, cam: Camera, dimmers) -> np.ndarray:
    """CIE XYZ (H, W, 3; Y in cd/m²) of :func:`traced_image`."""
    return traced_image(surface, scene, cam, dimmers).xyz


def _range(values: np.ndarray, scale: str) -> tuple[float, float]:
    v = values[np.isfinite(values)]
    hi = float(np.percentile(v, 99.5)) if v.size else 1.0
    hi = hi if hi > 0 else 1.0
    if scale == "log":
        pos = v[v > 0]
        lo = max(float(np.percentile(pos, 2)) if pos.size else hi * 1e-3, hi * 1e-3)
        return (lo, hi) if hi > lo else (hi / 10.0, hi)
    return 0.0, hi


def render_falsecolour_view(points_faces, values, cam: Camera, *, quantity: str = "luminance",
                            scale: str = "log", levels=None, clim=None, cmap=DEFAULT_CMAP,
                            title: str | None = None, frame: bool = True
                            ) -> tuple[np.ndarray, tuple[float, float]]:
    """A false-colour perspective view of per-vertex ``values`` on a surface.

    ``points_faces`` is a :class:`SurfaceLight` (or anything with ``polydata()``); ``values``
    are cd/m² (``quantity="luminance"``) or lx (``"illuminance"``), one per vertex. Returns
    ``(image, (vmin, vmax))``; a vertex's colour is :func:`lux_to_rgb` of its value on that
    range (log: values below vmin take the lowest colour). The scene is the camera's ``size``;
    with ``frame`` (default) a header band above it holds the title and a note of the scale and
    iso-lines, and a column to its right the colour bar (:func:`frame_view`): nothing is drawn
    over the scene. ``frame=False``: the scene alone.
    """
    vals = np.asarray(values, np.float64)
    mesh = points_faces.polydata()
    # normals follow the triangles' winding: the front faces, the only ones drawn
    mesh = mesh.compute_normals(cell_normals=True, point_normals=True, split_vertices=False,
                                consistent_normals=False, auto_orient_normals=False)
    if clim is not None:
        vmin, vmax = (float(c) for c in clim)
    else:  # the range of what the camera sees, not of every surface in the scene
        seen = in_view(cam, np.asarray(mesh.points), np.asarray(mesh.point_data["Normals"]))
        vmin, vmax = _range(vals[seen] if seen.any() else vals, scale)
    if levels is None:
        levels = nice_levels(vmin, vmax, scale, max_levels=7)
    levels = [float(x) for x in levels if vmin < float(x) < vmax]
    unit = "cd/m²" if quantity == "luminance" else "lx"
    name = "Luminance" if quantity == "luminance" else "Illuminance"
    mesh.point_data["value"] = np.maximum(vals, vmin) if scale == "log" else vals
    h = cam.size[1]
    with _plotter(cam.size) as pl:
        pl.set_background("white")
        pl.add_mesh(
            mesh, scalars="value", cmap=_cmap(cmap), clim=(vmin, vmax),
            log_scale=scale == "log", n_colors=N_COLOURS, interpolate_before_map=True,
            lighting=False, culling="back", show_scalar_bar=False)
        if levels:
            # lift the lines off the surface towards its front (the side drawn) so that the
            # surface never hides them, and contour only the faces turned to the camera:
            # lines are never culled, so those of back faces would show through
            centres = np.asarray(mesh.cell_centers().points)
            to_cam = np.asarray(cam.position, np.float64) - centres
            front = np.einsum("ij,ij->i", np.asarray(mesh.cell_data["Normals"]), to_cam) > 0
            lines = mesh.extract_cells(np.flatnonzero(front)).contour(levels, scalars="value")
            if lines.n_points:
                lift = 2e-3 * float(np.linalg.norm(np.subtract(cam.position, cam.target)))
                lines.points = np.asarray(lines.points) + lift * np.asarray(
                    lines.point_data["Normals"])
                pl.add_mesh(lines, color="black", line_width=max(2, h // 400), lighting=False)
        _place(pl, cam)
        scene = _shot(pl)
    if not frame:
        return scene, (vmin, vmax)
    from ._frame import frame_view

    note = f"{name} ({unit}), {'log' if scale == 'log' else 'linear'} scale"
    if levels:
        note += "; iso-lines at " + ", ".join(_fmt(x) for x in levels) + f" {unit}"
    img, _ = frame_view(scene, title=title, subtitle=note, label=f"{name} ({unit})",
                        clim=(vmin, vmax), scale=scale, cmap=_cmap(cmap), levels=levels)
    return img, (vmin, vmax)


def write_png(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write an image atomically as PNG."""
    path = Path(path)
    with atomic_path(path, what="image", suffix=".png") as tmp:
        Path(tmp).write_bytes(png_bytes(image))
    return path
