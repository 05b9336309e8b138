"""How a receiver responds to light arriving from a direction: the planar cosine of a grid
point, and the sensors the lighting standards define (EN 12464-1, EN 13201-3, CIE 150).

A response ``R(u)`` is what a receiver reads per unit of normal illuminance ``I/d²`` (lx) of a
point source seen in the unit direction ``u`` (receiver → source): a point source gives
``E = I·R(u)/d²`` and a luminance field ``E = ∫ L(u)·R(u) dω``. With ``a`` the sensor's axis
(vertical for the standards' sensors), ``sin ε = |u − (u·a)a|`` and ``f`` a facing direction
(perpendicular to ``a``):

- planar: ``max(u·n, 0)`` (the cosine law);
- cylindrical (mean over a small vertical cylinder's curved side): ``sin ε / π``;
- semi-cylindrical (its half facing ``f``): ``(sin ε + u·f) / π`` = ``sin ε (1 + cos α)/π``;
- hemispherical (a small dome about ``a``): ``(1 + u·a) / 4``.

Each is derived from the projected area of the sensor's lit surface over its area (a cylinder
of radius r and height h shows ``2rh sin ε`` of its ``2πrh``); tests/compliance derives them
again by integrating over the surface. All give ``E = B`` in a uniform enclosure of radiosity
B: ``∫ R dω = π``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Float, Int

__all__ = ["SENSOR_KINDS", "SensorResponse"]

#: The sensor kinds, by code: the order of :attr:`SensorResponse.kind`.
SENSOR_KINDS = ("planar", "cylindrical", "semicylindrical", "hemispherical")


@dataclass(frozen=True)
class SensorResponse:
    """Per receiver: the kind (index into :data:`SENSOR_KINDS`), a unit axis and a unit facing
    direction (the normal of a planar receiver; ignored by cylindrical and hemispherical ones).
    """

    kind: Int[np.ndarray, " points"]
    axis: Float[np.ndarray, "points 3"]
    facing: Float[np.ndarray, "points 3"]

    @classmethod
    def uniform(cls, kind: str, n: int, axis=(0.0, 0.0, 1.0), facing=None) -> SensorResponse:
        """``n`` receivers of one kind with one axis and (optional) facing direction(s)."""
        code = SENSOR_KINDS.index(kind)
        a = np.broadcast_to(np.asarray(axis, np.float64), (n, 3))
        a = _unit(a)
        f = a if facing is None else np.broadcast_to(np.asarray(facing, np.float64), (n, 3))
        if kind == "semicylindrical":  # the half-cylinder faces across its axis
            f = f - np.einsum("ij,ij->i", f, a)[:, None] * a
        return cls(np.full(n, code, np.int32), a, _unit(f))

    def factor(self, w: Float[np.ndarray, "pairs 3"], receiver: Int[np.ndarray, " pairs"]
               ) -> Float[np.ndarray, " pairs"]:
        """``R(u)`` (dimensionless) for unit directions ``w`` source → receiver (``u = −w``) at
        the receivers ``receiver``."""
        u = -np.asarray(w, np.float64)
        kind = self.kind[receiver]
        a, f = self.axis[receiver], self.facing[receiver]
        ua = np.einsum("ij,ij->i", u, a)
        sin_e = np.sqrt(np.maximum(1.0 - ua * ua, 0.0))
        uf = np.einsum("ij,ij->i", u, f)
        out = np.select(
            [kind == 0, kind == 1, kind == 2, kind == 3],
            [np.maximum(uf, 0.0), sin_e / np.pi, np.maximum(sin_e + uf, 0.0) / np.pi,
             np.maximum(1.0 + ua, 0.0) / 4.0])
        return out


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return np.asarray(v / np.where(n > 0, n, 1.0), np.float64).copy()
