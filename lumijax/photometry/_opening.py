"""Luminous openings: the emitting shape and its size in metres, decoded from file conventions."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["LuminousOpening", "decode_ies_opening", "encode_ies_opening"]

# outlines round from below: length and width are the ellipse's diameters (area π/4·L·W)
_ROUND = ("disk", "circle", "ellipse", "sphere", "ellipsoid", "vertical_cylinder",
          "vertical_elliptical_cylinder")

SHAPES = ("point", "rectangle", "box", *_ROUND, "horizontal_cylinder_along",
          "horizontal_cylinder_across", "vertical_circle", "vertical_ellipse")


@dataclass(frozen=True)
class LuminousOpening:
    """The luminous opening of a luminaire, in its local frame (``docs/conventions.md``).

    Attributes
    ----------
    length_m
        Extent along C0 = ``+x_l`` (m); a diameter for round shapes.
    width_m
        Extent along C90 = ``+y_l`` (m); a diameter for round shapes.
    height_m
        Extent along ``z_l`` (m); 0 for flat openings.
    shape
        One of ``point``, ``rectangle``, ``box``, ``disk``/``circle`` (round, flat, horizontal),
        ``ellipse``, ``sphere``, ``ellipsoid``, ``vertical_cylinder``,
        ``vertical_elliptical_cylinder``, ``horizontal_cylinder_along`` (axis along C0),
        ``horizontal_cylinder_across`` (axis along C90), ``vertical_circle``/``vertical_ellipse``
        (a flat opening in the y–z plane facing C0; its diameters are ``width_m`` and
        ``height_m``).
    """

    length_m: float = 0.0
    width_m: float = 0.0
    height_m: float = 0.0
    shape: str = "point"

    @property
    def is_point(self) -> bool:
        """True when the opening has no extent (a point source)."""
        return self.length_m == 0.0 and self.width_m == 0.0 and self.height_m == 0.0

    @property
    def area_m2(self) -> float:
        """Area seen from straight below (γ = 0), m²; used for luminance and near-field splits."""
        if self.shape in _ROUND:
            return math.pi / 4.0 * self.length_m * self.width_m
        if self.shape in ("vertical_circle", "vertical_ellipse"):
            return 0.0
        return self.length_m * self.width_m


def _sgn(x: float) -> str:
    return "+" if x > 0 else ("-" if x < 0 else "0")


def decode_ies_opening(width: float, length: float, height: float, version: str, scale: float):
    """Shape and sizes from the signed IES ``width length height`` (FORMATS.md §1.6).

    ``version`` is ``"1986"``, ``"1991"``, ``"1995"``, ``"2002"`` or ``"2019"``; 1991 is read as
    1986 and 2019 as 2002, as ies2rad does. ``scale`` converts file units to metres. Returns
    ``(LuminousOpening, note)`` where ``note`` is a warning text for a sign pattern the version does
    not define (then the absolute values are used as a box or rectangle), else ``None``.
    """
    ver = {"1991": "1986", "2019": "2002"}.get(version, version)
    lv, wv, hv = length, width, height
    L, W, H = abs(lv) * scale, abs(wv) * scale, abs(hv) * scale
    key = _sgn(lv) + _sgn(wv) + _sgn(hv)
    common = {
        "000": ("point", 0.0, 0.0, 0.0),
        "++0": ("rectangle", L, W, 0.0),
        "+++": ("box", L, W, H),
        "0++": ("box", L, W, H),
        "+0+": ("box", L, W, H),
        "0-0": ("disk", W, W, 0.0),
    }
    by_version = {
        "1986": {
            "0-+": ("vertical_cylinder", W, W, H),
            "+-0": ("ellipse", L, W, 0.0),
            "+-+": ("ellipsoid", L, W, H),
        },
        "1995": {
            "0--": ("sphere", W, W, H),
            "0-+": ("vertical_cylinder", W, W, H),
            "+0-": ("horizontal_cylinder_along", L, H, H),
            "0+-": ("horizontal_cylinder_across", H, W, H),
            "-++": ("vertical_elliptical_cylinder", L, W, H),
            "+-+": ("vertical_elliptical_cylinder", L, W, H),
            "-+-": ("ellipsoid", L, W, H),
            "+--": ("ellipsoid", L, W, H),
        },
        "2002": {
            "--0": ("circle" if L == W else "ellipse", L, W, 0.0),
            "--+": ("vertical_cylinder" if L == W else "vertical_elliptical_cylinder", L, W, H),
            "---": ("sphere" if L == W == H else "ellipsoid", L, W, H),
            "+--": ("horizontal_cylinder_along", L, W, H),
            "-+-": ("horizontal_cylinder_across", L, W, H),
            "-0-": ("vertical_circle" if L == H else "vertical_ellipse", 0.0, L, H),
        },
    }
    table = {**common, **by_version.get(ver, {})}
    if key in table:
        shape, lm, wm, hm = table[key]
        return LuminousOpening(lm, wm, hm, shape), None
    shape = "box" if H > 0 else ("rectangle" if L > 0 or W > 0 else "point")
    note = (
        f"luminous opening width={width:g}, length={length:g}, height={height:g} has a sign "
        f"pattern that LM-63-{version} does not define; using the absolute values as a {shape}"
    )
    return LuminousOpening(L, W, H, shape), note


def encode_ies_opening(op: LuminousOpening) -> tuple[float, float, float]:
    """Signed ``(width, length, height)`` in metres for an LM-63-2002/2019 file."""
    L, W, H = op.length_m, op.width_m, op.height_m
    s = op.shape
    if s in ("point", "rectangle", "box"):
        return W, L, H
    if s in ("disk", "circle", "ellipse"):
        return -W, -L, 0.0
    if s in ("vertical_cylinder", "vertical_elliptical_cylinder"):
        return -W, -L, H
    if s in ("sphere", "ellipsoid"):
        return -W, -L, -H
    if s == "horizontal_cylinder_along":
        return -W, L, -H
    if s == "horizontal_cylinder_across":
        return W, -L, -H
    if s in ("vertical_circle", "vertical_ellipse"):
        return 0.0, -W, -H
    return W, L, H
