"""The light sources as the view pass sees them: luminaires over their luminous openings and area
sources, as triangles a ray can hit, each with its luminance toward the ray's origin.

A luminaire's opening (its photometry's :class:`~lumijax.photometry.LuminousOpening`, centred
on its position, in its aimed frame) is drawn as a triangle proxy of the opening's shape:
flat openings as their rectangle or ellipse, spheres and ellipsoids as a faceted ellipsoid,
other solids as their box; a point source as a sphere of ``lumijax.glare.POINT_DIAMETER_M``
(what glare rates it as). Wherever a ray meets the proxy the luminance is glare's,
``L = I(ω) / A_p(ω)`` (cd/m²) with ω the direction toward the eye in the luminaire frame:
the photometry's candela at the aim and level and the opening's projected area
(:func:`lumijax.glare.projected_area`), so an image and the glare ratings see the same source.
Area sources are Lambertian rectangles of luminance M/π, dark from behind.
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import numpy as np
from jaxtyping import Float, Int

__all__ = ["Emitters", "emitters_of", "opening_triangles"]

#: XYZ of a source without a spectrum (Y = 1): D65 white, the neutral of the surface views.
_D65 = np.array([0.95047, 1.0, 1.08883])


def _ellipse(a: float, b: float, n: int = 24) -> np.ndarray:
    phi = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    # the n-gon through the ellipse would be (n/2) sin(2π/n)/π = 1.1 % smaller (n = 24): its
    # corners are pushed out so that its area is the opening's π a b, and a traced image's
    # (or a reflection's) solid angle of the source is the photometry's
    k = math.sqrt(math.pi / (0.5 * n * math.sin(2 * math.pi / n)))
    ring = np.stack([k * a * np.cos(phi), k * b * np.sin(phi), np.zeros(n)], axis=1)
    nxt = np.roll(ring, -1, axis=0)
    return np.stack([np.zeros((n, 3)), ring, nxt], axis=1)


def _ellipsoid(a: float, b: float, c: float, n_lat: int = 8, n_lon: int = 12) -> np.ndarray:
    th = np.linspace(0.0, np.pi, n_lat + 1)
    ph = np.linspace(0.0, 2 * np.pi, n_lon + 1)
    t, p = np.meshgrid(th, ph, indexing="ij")
    pts = np.stack([a * np.sin(t) * np.cos(p), b * np.sin(t) * np.sin(p), c * np.cos(t)], -1)
    q00, q01 = pts[:-1, :-1], pts[:-1, 1:]
    q10, q11 = pts[1:, :-1], pts[1:, 1:]
    tri = np.concatenate([np.stack([q00, q10, q11], -2), np.stack([q00, q11, q01], -2)])
    return tri.reshape(-1, 3, 3)


def _box(a: float, b: float, c: float) -> np.ndarray:
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5)
                        for z in (-0.5, 0.5)]) * [a, b, c]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.array([[corners[q[0]], corners[q[i]], corners[q[i + 1]]]
                     for q in quads for i in (1, 2)])


def opening_triangles(opening) -> Float[np.ndarray, "t 3 3"]:
    """Triangles (m, luminaire frame: axis −z, C0 +x) that draw ``opening``."""
    from ..glare import POINT_DIAMETER_M

    L, W, H = opening.length_m, opening.width_m, opening.height_m
    s = opening.shape
    if opening.is_point:
        r = POINT_DIAMETER_M / 2.0
        return _ellipsoid(r, r, r)
    if s == "rectangle":
        a, b = L / 2.0, W / 2.0
        quad = np.array([[-a, -b, 0.0], [a, -b, 0.0], [a, b, 0.0], [-a, b, 0.0]])
        return np.stack([quad[[0, 1, 2]], quad[[0, 2, 3]]])
    if s in ("disk", "circle", "ellipse"):
        return _ellipse(L / 2.0, W / 2.0)
    if s in ("vertical_circle", "vertical_ellipse"):  # in the y–z plane, facing C0
        e = _ellipse(W / 2.0, H / 2.0)
        return e[..., [2, 0, 1]]
    if s in ("sphere", "ellipsoid"):
        return _ellipsoid(L / 2.0, W / 2.0, H / 2.0)
    return _box(max(L, 1e-3), max(W, 1e-3), max(H, 1e-3))


class _Group(eqx.Module):
    """One photometry's luminaires."""

    distribution: object
    opening: object = eqx.field(static=True)
    rotation: Float[np.ndarray, "m 3 3"]  # luminaire → world
    scale: Float[np.ndarray, " m"]  # candela multiplier (Luminaire.scale: level included)
    network: Int[np.ndarray, " m"]
    colour: Float[np.ndarray, "m 3"]  # XYZ per cd/m² (Y = 1)
    offset: int = eqx.field(static=True)  # first owner index of the group


class Emitters(eqx.Module):
    """Source proxies: ``triangles`` (E, 3, 3) in world metres, ``owner`` (E,) the source of
    each (luminaires first, grouped by photometry, then area sources)."""

    triangles: Float[np.ndarray, "e 3 3"]
    owner: Int[np.ndarray, " e"]
    groups: tuple[_Group, ...]
    area_luminance: Float[np.ndarray, " a"]  # cd/m² at dimmer 1
    area_normal: Float[np.ndarray, "a 3"]
    area_network: Int[np.ndarray, " a"]
    area_colour: Float[np.ndarray, "a 3"]
    n_luminaires: int = eqx.field(static=True)

    def xyz(self, owner: np.ndarray, to_eye: np.ndarray, dimmers) -> Float[np.ndarray, "n 3"]:
        """XYZ (Y: luminance in cd/m²) of sources ``owner`` toward unit world directions
        ``to_eye`` (source → eye), at the networks' ``dimmers``."""
        alpha = np.asarray(dimmers, np.float64)
        out = np.zeros((len(owner), 3))
        for g in self.groups:
            sel = np.flatnonzero((owner >= g.offset) & (owner < g.offset + len(g.scale)))
            if not len(sel):
                continue
            i = owner[sel] - g.offset
            local = np.einsum("nji,nj->ni", g.rotation[i], to_eye[sel])  # Rᵀ w
            per_cd = _per_candela(g.distribution, g.opening, local)
            out[sel] = (per_cd * g.scale[i] * alpha[g.network[i]])[:, None] * g.colour[i]
        sel = np.flatnonzero(owner >= self.n_luminaires)
        if len(sel):
            a = owner[sel] - self.n_luminaires
            front = np.einsum("ij,ij->i", self.area_normal[a], to_eye[sel]) > 0
            lum = self.area_luminance[a] * alpha[self.area_network[a]] * front
            out[sel] = lum[:, None] * self.area_colour[a]
        return out


#: Rays per evaluation of a photometry toward the eye: every batch is padded to (or cut at)
#: this size, and the photometry is its padded table (CandelaDistribution.kernel), so JAX
#: compiles one shape for every photometry of a bucket, not one per batch or file.
_BATCH = 1 << 16


@functools.cache
def _luminance_fn():
    import equinox as eqx
    import jax.numpy as jnp

    from ..glare import projected_area

    @eqx.filter_jit
    def per_candela(distribution, opening, local):
        """I(ω)/A_p(ω) (cd/m² per unit scale) toward local directions."""
        return distribution.intensity(local) / projected_area(opening, local)

    return per_candela, jnp


def _per_candela(distribution, opening, local: np.ndarray) -> np.ndarray:
    """Luminance (cd/m²) of an opening toward ``local`` directions, per unit candela scale:
    the photometry's intensity over glare's projected area."""
    fn, jnp = _luminance_fn()
    out = np.empty(len(local))
    for s in range(0, len(local), _BATCH):
        part = local[s:s + _BATCH]
        n = len(part)
        pad = np.zeros((_BATCH, 3))
        pad[:, 2] = -1.0  # straight down: a harmless direction for the padding
        pad[:n] = part
        out[s:s + n] = np.asarray(fn(distribution.kernel, opening, jnp.asarray(pad)),
                                  np.float64)[:n]
    return out


@functools.lru_cache(maxsize=256)
def _colour(spectrum) -> np.ndarray:
    if spectrum is None:
        return _D65
    from ..spectral import tristimulus

    return np.asarray(tristimulus(spectrum), np.float64)


def emitters_of(scene) -> Emitters:
    """The :class:`Emitters` of a :class:`~lumijax.scene.Scene` at its aims and levels
    (``scene.with_design(design)`` for another design's)."""
    nets = {n: i for i, n in enumerate(scene.network_names)}
    tris, owner, groups = [], [], []
    by_phot: dict[str, list[int]] = {}
    for i, lum in enumerate(scene.luminaires):
        by_phot.setdefault(lum.photometry, []).append(i)
    offset = 0
    for name, idx in by_phot.items():
        phot = scene.photometries[name]
        lums = [scene.luminaires[i] for i in idx]
        rot = np.array([lum.rotation for lum in lums]).reshape(-1, 3, 3)
        local = opening_triangles(phot.opening)
        for j, lum in enumerate(lums):
            tris.append(np.asarray(lum.position) + local @ rot[j].T)
            owner.append(np.full(len(local), offset + j))
        groups.append(_Group(
            distribution=phot.distribution, opening=phot.opening, rotation=rot,
            scale=np.array([lum.scale for lum in lums]),
            network=np.array([nets[lum.network] for lum in lums], np.int64),
            colour=np.array([_colour(lum.spectrum) for lum in lums]).reshape(-1, 3),
            offset=offset))
        offset += len(lums)
    areas = scene.area_sources
    for k, a in enumerate(areas):
        o = np.asarray(a.origin, np.float64)
        quad = np.array([o, o + a.u, o + a.u + a.v, o + a.v])
        tris.append(np.stack([quad[[0, 1, 2]], quad[[0, 2, 3]]]))
        owner.append(np.full(2, offset + k))
    return Emitters(
        triangles=np.concatenate(tris) if tris else np.zeros((0, 3, 3)),
        owner=np.concatenate(owner).astype(np.int64) if owner else np.zeros(0, np.int64),
        groups=tuple(groups),
        area_luminance=np.array([a.exitance / math.pi for a in areas]),
        area_normal=np.array([a.normal for a in areas]).reshape(-1, 3),
        area_network=np.array([nets[a.network] for a in areas], np.int64),
        area_colour=np.array([_colour(a.spectrum) for a in areas]).reshape(-1, 3),
        n_luminaires=offset)
