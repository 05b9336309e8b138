"""Expansion of symmetric photometric tables to the full range of directions.

All functions work on float64 numpy arrays: ``h`` (ascending angles of the stored planes, deg),
``v`` (ascending angles within a plane, deg) and ``cd[h, v]``. They return new ``(h, v, cd)``.
Spacing may be non-uniform everywhere: mirrored angles are computed, never assumed.
"""

from __future__ import annotations

import numpy as np

__all__ = ["expand_type_c", "expand_type_ab", "type_c_symmetry"]


def type_c_symmetry(h: np.ndarray) -> str:
    """Name the LM-63 Type C symmetry that the first and last horizontal angle declare.

    Returns one of ``"rotational"`` (0–0), ``"quadrant"`` (0–90), ``"bilateral"`` (0–180),
    ``"bilateral_90_270"`` (90–270), ``"none"`` (0 to more than 180) or ``"unsupported"``.
    """
    first, last = float(h[0]), float(h[-1])
    if first == 0.0 and last == 0.0:
        return "rotational"
    if first == 0.0 and last == 90.0:
        return "quadrant"
    if first == 0.0 and last == 180.0:
        return "bilateral"
    if first == 90.0 and last == 270.0:
        return "bilateral_90_270"
    if first == 0.0 and 180.0 < last <= 360.0:
        return "none"
    return "unsupported"


def _assemble(targets: np.ndarray, sources: np.ndarray, h: np.ndarray, cd: np.ndarray):
    """Full-circle table whose plane at each target angle copies the stored plane at its source."""
    order = np.argsort(targets, kind="stable")
    targets, sources = targets[order], sources[order]
    keep = np.concatenate([[True], np.diff(targets) > 1e-9])
    targets, sources = targets[keep], sources[keep]
    idx = np.array([int(np.argmin(np.abs(h - s))) for s in sources])
    return targets, cd[idx]


def expand_type_c(h: np.ndarray, v: np.ndarray, cd: np.ndarray):
    """Expand a Type C table to C = 0…360 inclusive (the 360 plane repeats the 0 plane).

    Fill rules (FORMATS.md §1.5): 0–0 rotational; 0–90 ``I(C) = I(180−C) = I(180+C) = I(360−C)``;
    0–180 ``I(C) = I(360−C)``; 90–270 ``I(C) = I(180−C mod 360)``; 0–>180 none (a missing 360 plane
    is the 0 plane). Raises ``ValueError`` for other ranges.
    """
    h = np.asarray(h, dtype=np.float64)
    cd = np.asarray(cd, dtype=np.float64)
    kind = type_c_symmetry(h)
    if kind == "rotational":
        return np.array([0.0, 360.0]), v, np.repeat(cd[:1], 2, axis=0)
    if kind == "quadrant":
        t = np.concatenate([h, 180.0 - h, 180.0 + h, 360.0 - h])
        s = np.concatenate([h, h, h, h])
    elif kind == "bilateral":
        t = np.concatenate([h, 360.0 - h])
        s = np.concatenate([h, h])
    elif kind == "bilateral_90_270":
        t = np.concatenate([h, np.mod(180.0 - h, 360.0)])
        s = np.concatenate([h, h])
        # C0 = C360 is the mirror of C180; add it explicitly so both ends exist.
        t = np.concatenate([t, [360.0]])
        s = np.concatenate([s, [180.0]])
    elif kind == "none":
        t, s = h.copy(), h.copy()
        if h[-1] < 360.0:
            t = np.concatenate([t, [360.0]])
            s = np.concatenate([s, [0.0]])
    else:
        raise ValueError(
            f"horizontal angles {h[0]:g}…{h[-1]:g} do not declare a Type C symmetry "
            "(expected 0–0, 0–90, 0–180, 90–270 or 0–360)"
        )
    th, tcd = _assemble(t, s, h, cd)
    return th, v, tcd


def expand_type_ab(h: np.ndarray, v: np.ndarray, cd: np.ndarray):
    """Expand a Type A or B table: a range starting at 0 is mirrored to negative angles.

    Horizontal 0…90 means lateral symmetry ``I(−H, V) = I(H, V)``; vertical 0…90 means symmetry
    about the horizontal plane ``I(H, −V) = I(H, V)`` (FORMATS.md §1.5).
    """
    h = np.asarray(h, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    cd = np.asarray(cd, dtype=np.float64)
    if h[0] == 0.0 and h[-1] > 0.0:
        h = np.concatenate([-h[:0:-1], h])
        cd = np.concatenate([cd[:0:-1], cd], axis=0)
    if v[0] == 0.0 and v[-1] > 0.0:
        v = np.concatenate([-v[:0:-1], v])
        cd = np.concatenate([cd[:, :0:-1], cd], axis=1)
    if h.shape[0] < 2 or v.shape[0] < 2:
        raise ValueError("a Type A/B table needs at least two horizontal and two vertical angles")
    return h, v, cd
