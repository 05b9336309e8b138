"""Local frames (groups) and luminaire aims.

A frame is an affine map ``p ↦ linear · p + translation``. Group frames compose parent-first
(docs/conventions.md). Aim rotations are written in ``jax.numpy`` so the optimiser can
differentiate through them; everything else here is plain numpy, run once when a scene is built.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = ["Frame", "resolve_group_frames", "aim_rotation", "aim_angles_towards", "rotation_xyz"]


@dataclass(frozen=True)
class Frame:
    """An affine frame: ``world = linear @ local + translation`` (metres)."""

    linear: Float[np.ndarray, "3 3"]
    translation: Float[np.ndarray, "3"]

    @classmethod
    def identity(cls) -> Frame:
        return cls(np.eye(3), np.zeros(3))

    @property
    def rotation(self) -> Float[np.ndarray, "3 3"]:
        """The rotation part (polar decomposition), which is what turns directions and aims."""
        u, _, vt = np.linalg.svd(self.linear)
        r = u @ vt
        if np.linalg.det(r) < 0:  # a mirroring scale: keep a proper rotation for aims
            u[:, -1] *= -1
            r = u @ vt
        return r

    def compose(self, child: Frame) -> Frame:
        """The frame of ``child`` (given in self's coordinates) expressed in self's parent."""
        return Frame(self.linear @ child.linear, self.linear @ child.translation + self.translation)

    def points(self, p: Float[np.ndarray, "... 3"]) -> Float[np.ndarray, "... 3"]:
        return np.asarray(p, np.float64) @ self.linear.T + self.translation

    def vectors(self, v: Float[np.ndarray, "... 3"]) -> Float[np.ndarray, "... 3"]:
        """Edge vectors (u, v of a rectangle or grid): scaled and rotated, not translated."""
        return np.asarray(v, np.float64) @ self.linear.T

    def normals(self, n: Float[np.ndarray, "... 3"]) -> Float[np.ndarray, "... 3"]:
        """Surface normals transform by the inverse transpose, then are renormalised."""
        m = np.linalg.inv(self.linear).T
        out = np.asarray(n, np.float64) @ m.T
        return out / np.linalg.norm(out, axis=-1, keepdims=True)

    @property
    def flips_orientation(self) -> bool:
        return bool(np.linalg.det(self.linear) < 0)


def rotation_xyz(degrees: Float[np.ndarray, "3"]) -> Float[np.ndarray, "3 3"]:
    """``Rz · Ry · Rx`` for angles in degrees about x, then y, then z (fixed axes)."""
    rx, ry, rz = np.radians(np.asarray(degrees, np.float64))
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return mz @ my @ mx


def resolve_group_frames(groups: dict) -> dict[str, Frame]:
    """World frames of every ``[groups.NAME]`` (parents resolved; cycles were refused on load)."""
    local: dict[str, Frame] = {}
    for name, g in groups.items():
        scale = np.broadcast_to(np.asarray(g.scale, np.float64), (3,))
        local[name] = Frame(rotation_xyz(g.rotate) @ np.diag(scale), np.asarray(g.translate, float))
    world: dict[str, Frame] = {}

    def get(name: str) -> Frame:
        if name not in world:
            parent = groups[name].parent
            world[name] = local[name] if parent is None else get(parent).compose(local[name])
        return world[name]

    for name in groups:
        get(name)
    return world


def aim_rotation(
    tilt: Float[Array, "..."], pan: Float[Array, "..."], spin: Float[Array, "..."], *, xp=jnp
) -> Float[Array, "... 3 3"]:
    """Luminaire rotation ``Rz(pan) · Ry(−tilt) · Rz(spin)``; angles in **radians**.

    ``world = R @ local``. The photometric axis ``(0, 0, −1)`` maps to
    ``(sin tilt cos pan, sin tilt sin pan, −cos tilt)`` (docs/conventions.md). Differentiable
    with ``xp = jax.numpy`` (the default); ``xp = numpy`` for plain bookkeeping, which would
    otherwise pay JAX's per-operation dispatch on every luminaire.
    """
    tilt, pan, spin = xp.broadcast_arrays(*(xp.asarray(a) for a in (tilt, pan, spin)))
    ct, st = xp.cos(tilt), xp.sin(tilt)
    cp, sp = xp.cos(pan), xp.sin(pan)
    cs, ss = xp.cos(spin), xp.sin(spin)
    zero, one = xp.zeros_like(ct), xp.ones_like(ct)

    def stack(rows):
        return xp.stack([xp.stack(r, axis=-1) for r in rows], axis=-2)

    rz_pan = stack([[cp, -sp, zero], [sp, cp, zero], [zero, zero, one]])
    ry_tilt = stack([[ct, zero, -st], [zero, one, zero], [st, zero, ct]])  # Ry(−tilt)
    rz_spin = stack([[cs, -ss, zero], [ss, cs, zero], [zero, zero, one]])
    return rz_pan @ ry_tilt @ rz_spin


def aim_angles_towards(
    direction: Float[np.ndarray, "3"],
) -> tuple[float, float]:
    """Tilt and pan (degrees) that point the photometric axis along ``direction``.

    Straight down or up leaves pan free; it is then 0.
    """
    d = np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    tilt = float(np.degrees(np.arccos(np.clip(-d[2], -1.0, 1.0))))
    horizontal = float(np.hypot(d[0], d[1]))
    pan = float(np.degrees(np.arctan2(d[1], d[0]))) if horizontal > 1e-12 else 0.0
    return tilt, pan
