"""The independent reference of ``benchmarks/small.py``: an exact-kernel radiosity of a box
room, written here in numpy (nothing from lumijax), for grey Lambertian surfaces lit by
isotropic point lamps.

Every face is cut into near-squares of a given size; B is constant per square (its mean); the
operator's entries are the exact point-to-square form factors (Lambert's contour formula)
averaged over 3 × 3 Gauss points of the receiving square; the points are read with each
square's B linear across it (``linear_gather``).

* **Convex rooms** (``reference`` without obstacles): one unknown per orbit of squares under
  the room's symmetries (``symmetries``: the cube's 48).
* **A room with one box inside** (``reference`` with ``case.obstacles``: the furnished room's
  table): no symmetry, every square an unknown, and the box's shadows exact. From a point x,
  the rays through a convex box fill a cone bounded by the planes through x and the box's
  silhouette edges (``cone_planes``); the part of a square inside that cone is a convex
  polygon, found by clipping the square by those planes (``clip_to_cone``), and its form
  factor (or, from a lamp, its solid angle) is a contour integral over the clipped outline —
  so F_visible = F(square) − F(square ∩ cone), and a square's direct light is
  I (Ω(square) − Ω(square ∩ cone)) / A, both exact. Checked as it runs: every Gauss point's
  factors over the closed room sum to 1 (exact visibility tiles its hemisphere), and the
  area-mean irradiance equals Φ / (S (1 − ρ)) for any closed room of one ρ.

Units: metres, lumens, lux.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np


def box_faces(lo, hi, size: float, inward: bool) -> list[dict]:
    """The six faces of the box lo..hi, each a grid of near-squares no wider than about
    ``size``: origin, edge steps du, dv (corners counter-clockwise about the face's normal,
    which points into the box when ``inward``, out of it otherwise), counts nu, nv."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    x, y, z = hi - lo
    spans = [  # origin offset, u, v of each face
        ((0, 0, 0), (0, y, 0), (x, 0, 0)), ((0, 0, z), (x, 0, 0), (0, y, 0)),
        ((0, 0, 0), (0, 0, z), (0, y, 0)), ((x, 0, 0), (0, y, 0), (0, 0, z)),
        ((0, 0, 0), (x, 0, 0), (0, 0, z)), ((0, y, 0), (0, 0, z), (x, 0, 0)),
    ]
    centre = (lo + hi) / 2
    faces = []
    for o, u, v in spans:
        o, u, v = lo + np.asarray(o, float), np.asarray(u, float), np.asarray(v, float)
        nrm = np.cross(u, v) / np.linalg.norm(np.cross(u, v))
        if (np.dot(centre - (o + (u + v) / 2), nrm) < 0) == inward:
            nrm, u, v = -nrm, v, u  # corners counter-clockwise about the wanted normal
        nu = max(1, round(np.linalg.norm(u) / size))
        nv = max(1, round(np.linalg.norm(v) / size))
        faces.append({"origin": o, "du": u / nu, "dv": v / nv, "nu": nu, "nv": nv,
                      "normal": nrm})
    return faces


def face_squares(face: dict):
    """A face's squares: corners (S, 4, 3) and the corner node indices (S, 4) into its grid
    nodes ((nu + 1)(nv + 1), 3), node (i, j) at i (nv + 1) + j."""
    o, du, dv, nu, nv = (face[k] for k in ("origin", "du", "dv", "nu", "nv"))
    i, j = np.meshgrid(np.arange(nu + 1), np.arange(nv + 1), indexing="ij")
    nodes = o + i.reshape(-1, 1) * du + j.reshape(-1, 1) * dv
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    i, j = i.ravel(), j.ravel()
    idx = np.stack([i * (nv + 1) + j, (i + 1) * (nv + 1) + j, (i + 1) * (nv + 1) + j + 1,
                    i * (nv + 1) + j + 1], axis=1)
    return nodes[idx], idx, nodes


def box_squares(room, size: float):
    """The inward faces of the room 0..room cut into near-squares: (corners (P, 4, 3),
    normals, areas)."""
    corners, normals = [], []
    for face in box_faces((0, 0, 0), room, size, inward=True):
        c = face_squares(face)[0]
        corners.append(c)
        normals.append(np.tile(face["normal"], (len(c), 1)))
    corners = np.concatenate(corners)
    areas = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                    corners[:, 3] - corners[:, 0]), axis=1)
    return corners, np.concatenate(normals), areas


def gauss_points(corners):
    """3 × 3 Gauss–Legendre points on each parallelogram (P, 4, 3) (corners 0, 1, 3 span it):
    points (P, 9, 3) and their weights (9,), summing to 1."""
    g, w = np.polynomial.legendre.leggauss(3)
    g, w = (g + 1) / 2, w / 2
    o, du, dv = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 3] - corners[:, 0]
    pts = (o[:, None, None] + g[None, :, None, None] * du[:, None, None]
           + g[None, None, :, None] * dv[:, None, None]).reshape(-1, 9, 3)
    return pts, np.outer(w, w).ravel()


def point_to_squares(x, n, corners, chunk: int = 0) -> np.ndarray:
    """Form factor from the differential areas (x, n) (S, 3) to every polygon (P, 4, 3), in
    closed form (Lambert): F = −Σ_k γ_k n·(r_k × r_k+1)/|r_k × r_k+1| / 2π for corners
    counter-clockwise about the polygon's normal (γ_k by ``atan2``, exact at the small angles
    of a far square); a polygon wholly behind the point's plane, or turning its back to the
    point, gives 0, one that the plane cuts is cut first (its corners behind moved along its
    edges to the plane: a rectangle cut parallel to two of its sides, as a box's walls are by
    the plane of points facing up or down; any other cut is refused). (S, P)."""
    chunk = chunk or max(1, 2 ** 19 // max(1, len(corners)))
    out = np.empty((len(x), len(corners)))
    own = np.cross(corners[:, 1] - corners[:, 0], corners[:, 3] - corners[:, 0])
    for s in range(0, len(x), chunk):
        r = corners[None] - x[s:s + chunk, None, None]  # (s, P, 4, 3)
        h = np.einsum("spkc,sc->spk", r, n[s:s + chunk])
        behind = h < 0
        # behind the point and facing away, the formula's two sign flips would make it count
        away = (np.einsum("spc,pc->sp", r[:, :, 0], own) >= 0) | behind.all(axis=-1)
        cut = behind & (behind.sum(axis=-1, keepdims=True) < 4)
        if cut.any():  # without the cut the part behind would count negative
            ahead = np.roll(h, -1, axis=2) >= 0
            h_to = np.where(ahead, np.roll(h, -1, axis=2), np.roll(h, 1, axis=2))
            if np.any(cut & (h_to < 0)):
                raise ValueError("a square cut obliquely by a point's plane")
            r_to = np.where(ahead[..., None], np.roll(r, -1, axis=2), np.roll(r, 1, axis=2))
            t = np.where(cut, h / np.where(cut, h - h_to, 1.0), 0.0)
            r += t[..., None] * (r_to - r)
        out[s:s + chunk] = np.where(away, 0.0, np.clip(
            contour(r, np.roll(r, -1, axis=2), n[s:s + chunk, None, None]).sum(axis=-1),
            0.0, None))
    return out


def contour(ra, rb, n) -> np.ndarray:
    """Each directed edge's term of Lambert's contour formula for the form factor from a
    differential area of normal n to a polygon: −γ n·(ra × rb) / |ra × rb| / 2π, for edge ends
    ra, rb (..., 3) relative to the point (γ the angle between them, by ``atan2``, exact for the
    small angles of a far polygon; a zero-length edge gives 0). Summed over a polygon's edges
    counter-clockwise about its normal, the factor (> 0 when it faces the point)."""
    with np.errstate(invalid="ignore"):  # a padded edge at the point: masked by the caller
        ra = ra / np.sqrt(np.einsum("...c,...c->...", ra, ra))[..., None]
        rb = rb / np.sqrt(np.einsum("...c,...c->...", rb, rb))[..., None]
    (ax, ay, az), (bx, by, bz) = np.moveaxis(ra, -1, 0), np.moveaxis(rb, -1, 0)
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    cn = np.sqrt(cx * cx + cy * cy + cz * cz)
    gamma = np.arctan2(cn, ax * bx + ay * by + az * bz)
    n = np.moveaxis(np.asarray(n, float), -1, 0)
    cdotn = cx * n[0] + cy * n[1] + cz * n[2]
    return -gamma * cdotn / np.where(cn > 0, cn, 1.0) / (2 * np.pi)


def direct(case, x, n) -> np.ndarray:
    """Closed-form direct illuminance (lx) of the isotropic lamps at points x with normals n
    (a convex room: nothing in between)."""
    e = np.zeros(len(x))
    for pos, flux, _ in case.lamps:
        d = np.asarray(pos) - x
        d2 = np.sum(d * d, axis=1)
        cos = np.sum(d * n, axis=1) / np.sqrt(d2)
        e += flux / (4 * np.pi) * np.clip(cos, 0.0, None) / d2
    return e


def symmetries(case) -> tuple:
    """The signed permutations about the room's centre that map the room and its lamps (with
    their flux) onto themselves: 48 for the cube with its lamp at the centre, 4 for the office
    (its rows mirror in x and y). Each is a 3 × 3 matrix acting on offsets from the centre;
    the radiosity (every dimmer at 1) is the same on every square of an orbit."""
    room = np.asarray(case.room, float)
    centre = room / 2

    def lamps(s):
        return {tuple(np.round([*((np.asarray(p) - centre) @ s.T + centre), f], 9))
                for p, f, _ in case.lamps}

    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            s = np.zeros((3, 3))
            s[range(3), perm] = signs
            if np.allclose(np.abs(s) @ room, room) and lamps(s) == lamps(np.eye(3)):
                out.append(s)
    return tuple(out)


@functools.lru_cache(maxsize=4)
def _orbit_operator(room: tuple, size: float, group: tuple):
    """The squares of a box, their orbits under ``group`` (flattened 3 × 3 matrices), Gauss
    points on one square of each orbit and the orbit-summed form factors K (R, R): K[o, o']
    = Σ over the squares j of orbit o' of F(representative of o → j). Any ρ and lamps with
    this symmetry share it."""
    corners, normals, areas = box_squares(room, size)
    centre, c = np.asarray(room, float) / 2, corners.mean(axis=1)
    index = {tuple(k): i for i, k in enumerate(np.round(c, 6))}
    first = np.arange(len(c))
    for flat in group:
        image = np.round((c - centre) @ np.reshape(flat, (3, 3)).T + centre, 6)
        first = np.minimum(first, [index[tuple(k)] for k in image])
    reps, orbit = np.unique(first, return_inverse=True)
    orbit = orbit.ravel()
    pts, wts = gauss_points(corners[reps])
    pts = pts.reshape(-1, 3)  # (R·9, 3)
    nrm = np.repeat(normals[reps], 9, axis=0)
    f = (point_to_squares(pts, nrm, corners).reshape(len(reps), 9, -1)
         * wts[None, :, None]).sum(axis=1)  # (R, P)
    k = np.stack([np.bincount(orbit, weights=row, minlength=len(reps)) for row in f])
    return corners, areas, orbit, pts, nrm, wts, k


def square_slopes(corners, b) -> np.ndarray:
    """Each square's gradient of ``b`` (P, 3) in its face: least squares over the squares of
    the same face among its 8 neighbours on the face's grid (fewer at the face's edges)."""
    c = corners.mean(axis=1)
    nrm = np.cross(corners[:, 1] - corners[:, 0], corners[:, 3] - corners[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    face = np.unique(np.round(np.c_[nrm, np.einsum("pc,pc->p", nrm, c)], 9), axis=0,
                     return_inverse=True)[1].ravel()
    g = np.zeros((len(b), 3))
    for f in np.unique(face):
        idx = np.flatnonzero(face == f)
        du = corners[idx[0], 1] - corners[idx[0], 0]
        dv = corners[idx[0], 3] - corners[idx[0], 0]
        rel = c[idx] - corners[idx, 0].min(axis=0)
        iu = np.round(rel @ du / (du @ du) - 0.5).astype(int)
        iv = np.round(rel @ dv / (dv @ dv) - 0.5).astype(int)
        grid = np.full((iu.max() + 1, iv.max() + 1), -1)
        grid[iu, iv] = np.arange(len(idx))
        normal, rhs = np.zeros((len(idx), 2, 2)), np.zeros((len(idx), 2))
        for step in itertools.product((-1, 0, 1), repeat=2):
            ju, jv = iu + step[0], iv + step[1]
            ok = ((ju >= 0) & (ju < grid.shape[0]) & (jv >= 0) & (jv < grid.shape[1])
                  & (step != (0, 0)))
            normal[ok] += np.outer(step, step)
            rhs[ok] += np.multiply(step, (b[idx][grid[ju[ok], jv[ok]]] - b[idx][ok])[:, None])
        # per grid step in u and v (a face one square wide has no slope across: pinv gives 0)
        coef = (np.linalg.pinv(normal) @ rhs[..., None])[..., 0]
        g[idx] = coef[:, :1] * du / (du @ du) + coef[:, 1:] * dv / (dv @ dv)
    return g


def linear_gather(x, n, corners, b, finest: float = 0.0125) -> np.ndarray:
    """Irradiance (lx) at points (x, n) from squares of radiosity ``b`` read linearly across
    each (``square_slopes``): every square as m × m sub-squares no wider than ``finest`` m,
    each at the linear B of its centre (exact for a linear B) times its exact point-to-square
    factor. On the cube's 0.1 m squares, 4 × 4 sub-squares read the points 0.019 % RMS away
    from 8 × 8 (0.0125 m), and cutting only the squares near the points that fine (1/16 of
    the distance, far squares read whole: constant) 0.0024 % away — the linear part of a far
    square's light is small per square but of one sign over many."""
    c, g = corners.mean(axis=1), square_slopes(corners, b)
    side = np.linalg.norm(corners[:, 1] - corners[:, 0], axis=1)
    cuts = np.ceil(side / finest - 1e-9).astype(int)
    e = np.zeros(len(x))
    for m in np.unique(cuts):
        sel = cuts == m
        a, du, dv = (corners[sel, 0], corners[sel, 1] - corners[sel, 0],
                     corners[sel, 3] - corners[sel, 0])
        for i in range(m):
            for j in range(m):
                sub = np.stack([a + (i * du + j * dv) / m, a + ((i + 1) * du + j * dv) / m,
                                a + ((i + 1) * du + (j + 1) * dv) / m,
                                a + (i * du + (j + 1) * dv) / m], axis=1)
                e += point_to_squares(x, n, sub) @ (
                    b[sel] + np.einsum("pc,pc->p", g[sel], sub.mean(axis=1) - c[sel]))
    return e


def convex_reference(case, size: float) -> dict:
    """The exact-kernel radiosity of a convex room at square size ``size`` (m): one unknown
    per orbit of squares under the room's symmetries (``symmetries``), the points read
    linearly (``linear_gather``)."""
    group = tuple(tuple(s.ravel()) for s in symmetries(case))
    corners, areas, orbit, pts, nrm, wts, k = _orbit_operator(tuple(case.room), size, group)
    e0 = (direct(case, pts, nrm).reshape(len(k), 9) * wts).sum(axis=1)
    b_orbit = np.linalg.solve(np.eye(len(k)) - case.rho * k, case.rho * e0)
    e_patch = (e0 + k @ b_orbit)[orbit]
    flux = sum(lamp[1] for lamp in case.lamps)
    s = float(areas.sum())
    e_pts = direct(case, case.points, case.normals) + linear_gather(
        case.points, case.normals, corners, b_orbit[orbit])
    return {"lux": e_pts, "squares": len(areas), "orbits": len(k), "symmetries": len(group),
            "mean_vs_closed_form": float(np.sum(areas * e_patch) / s
                                         / (flux / (s * (1 - case.rho))) - 1)}




# ------------------------------------------------------------------------------------------
# a room with one box inside: exact shadows


def cone_planes(x, lo, hi) -> np.ndarray:
    """The cone of rays from each point x (n, 3) through the box lo..hi (x outside it), as the
    unit normals m (n, 6, 3) of the planes through x and the box's silhouette edges: y is in
    the cone when m·(y − x) ≥ 0 for all six (a box seen from outside has 4 or 6 silhouette
    edges; unused rows are 0, which every y satisfies). An edge is on the silhouette when
    exactly one of its two faces faces x."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    sides = (lo, hi)
    front = [(x[:, k] < lo[k], x[:, k] > hi[k]) for k in range(3)]
    centre = (lo + hi) / 2
    planes, on = [], []
    for a in range(3):
        b, c = (k for k in range(3) if k != a)
        for sb, sc in itertools.product((0, 1), repeat=2):
            p, q = np.empty(3), np.empty(3)
            p[a], q[a] = lo[a], hi[a]
            p[b] = q[b] = sides[sb][b]
            p[c] = q[c] = sides[sc][c]
            m = np.cross(p - x, q - x)
            m *= np.sign(np.einsum("nc,nc->n", m, centre - x))[:, None]
            with np.errstate(invalid="ignore"):  # x on the edge's line: never a silhouette
                planes.append(m / np.linalg.norm(m, axis=1, keepdims=True))
            on.append(front[b][sb] ^ front[c][sc])
    m, on = np.stack(planes, axis=1), np.stack(on, axis=1)
    if np.any(on.sum(axis=1) > 6):
        raise ValueError("a point inside the box")
    order = np.argsort(~on, axis=1, kind="stable")[:, :6]
    return np.where(np.take_along_axis(on, order, axis=1)[..., None],
                    np.take_along_axis(m, order[..., None], axis=1), 0.0)


def clip_to_cone(corners, x, m):
    """The part of each convex polygon (M, V, 3) (corners in order) inside the cone
    ``cone_planes`` gave for x (M, 3): its outline as directed segments (a, b) (M, V + 6, 3)
    with a validity mask, clipped plane by plane — a segment wholly outside is dropped, one
    that crosses is cut at the plane, and the outline is closed along the plane from where it
    left to where it came back (a convex polygon leaves and re-enters at most once)."""
    a, b = corners, np.roll(corners, -1, axis=1)
    valid = np.ones(a.shape[:2], bool)
    rows = np.arange(len(a))
    for k in range(m.shape[1]):
        mk = m[:, k, None]
        ha = np.sum((a - x[:, None]) * mk, axis=-1)
        hb = np.sum((b - x[:, None]) * mk, axis=-1)
        ina, inb = ha >= 0, hb >= 0
        t = np.where(ina != inb, ha / np.where(ina != inb, ha - hb, 1.0), 0.0)
        cut = a + t[..., None] * (b - a)
        leave, enter = valid & ina & ~inb, valid & ~ina & inb
        b = np.where(leave[..., None], cut, b)
        a = np.where(enter[..., None], cut, a)
        valid &= ina | inb
        close = leave.any(axis=1) & enter.any(axis=1)
        a = np.concatenate([a, cut[rows, leave.argmax(axis=1)][:, None]], axis=1)
        b = np.concatenate([b, cut[rows, enter.argmax(axis=1)][:, None]], axis=1)
        valid = np.concatenate([valid, close[:, None]], axis=1)
    return a, b, valid


def solid_angle(eye, ref, a, b, valid) -> np.ndarray:
    """The solid angle (sr) a planar polygon subtends at ``eye`` (M, 3), from its outline's
    segments (a, b) (M, S, 3) (``valid`` (M, S)) and any point ``ref`` (M, 3) of its plane: the
    sum of the signed triangles (ref, a, b) (Van Oosterom & Strackee 1983), which adds like
    areas in the plane; its magnitude."""
    r1 = (ref - eye)[:, None]
    r2, r3 = a - eye[:, None], b - eye[:, None]
    n1, n2, n3 = (np.linalg.norm(r, axis=-1) for r in (r1, r2, r3))
    num = np.sum(r1 * np.cross(r2, r3), axis=-1)
    den = (n1 * n2 * n3 + np.sum(r1 * r2, axis=-1) * n3 + np.sum(r1 * r3, axis=-1) * n2
           + np.sum(r2 * r3, axis=-1) * n1)
    return np.abs(np.sum(np.where(valid, 2 * np.arctan2(num, den), 0.0), axis=1))


def _scene_squares(case, size: float):
    """The room's inward faces and the (one) box's outward faces as squares: corners (P, 4, 3),
    normals, areas, a mask of the box's squares, and the room's faces with their grids (node
    coordinates, each square's corner nodes, its first index in the whole)."""
    if len(case.obstacles) != 1:
        raise ValueError("the occluded reference takes one box inside the room")
    lo, hi = (np.asarray(v, float) for v in case.obstacles[0])
    room = box_faces((0, 0, 0), case.room, size, inward=True)
    corners, normals, on_box, grids = [], [], [], []
    start = 0
    for face, box in [(f, False) for f in room] + [
            (f, True) for f in box_faces(lo, hi, size, inward=False)]:
        c, idx, nodes = face_squares(face)
        if not box:
            grids.append({**face, "nodes": nodes, "idx": idx, "start": start})
        corners.append(c)
        normals.append(np.tile(face["normal"], (len(c), 1)))
        on_box.append(np.full(len(c), box))
        start += len(c)
    corners = np.concatenate(corners)
    areas = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                    corners[:, 3] - corners[:, 0]), axis=1)
    return corners, np.concatenate(normals), areas, np.concatenate(on_box), grids, (lo, hi)


def _box_shadows(f, x, n, corners, grids, box, batch: int = 1 << 17):
    """Take from the factors f (n, P) of points x (on the room's faces, normals n) what the box
    hides: a room square wholly inside the cone of rays from x through the box sees nothing,
    one partly inside loses the factor of its part inside (``clip_to_cone``). Candidates: the
    squares within the bounds of the face's part inside the cone, less those whose four
    corners are all inside."""
    m = cone_planes(x, *box)
    mx = np.einsum("nkc,nc->nk", m, x)
    for g in grids:
        nodes, idx, start = g["nodes"], g["idx"], g["start"]
        h = (m.reshape(-1, 3) @ nodes.T).reshape(len(x), 6, -1) - mx[..., None]
        inside = (h >= 0).all(axis=1)  # (n, nodes)
        # a point on this face (its own) sees none of it: nothing to hide
        own = np.abs((x - g["origin"]) @ g["normal"]) < 1e-9
        full = inside[:, idx].all(axis=-1) & ~own[:, None]  # (n, S)
        rect = np.stack([g["origin"], g["origin"] + g["nu"] * g["du"],
                         g["origin"] + g["nu"] * g["du"] + g["nv"] * g["dv"],
                         g["origin"] + g["nv"] * g["dv"]])
        a, b, valid = clip_to_cone(np.broadcast_to(rect, (len(x), 4, 3)), x, m)
        # the face's part inside the cone, in units of squares along du and dv
        ends = np.concatenate([a, b], axis=1) - g["origin"]
        ok = np.concatenate([valid, valid], axis=1)
        u = ends @ g["du"] / (g["du"] @ g["du"])
        v = ends @ g["dv"] / (g["dv"] @ g["dv"])
        u0, u1 = np.where(ok, u, np.inf).min(1), np.where(ok, u, -np.inf).max(1)
        v0, v1 = np.where(ok, v, np.inf).min(1), np.where(ok, v, -np.inf).max(1)
        iu, iv = idx[:, 0] // (g["nv"] + 1), idx[:, 0] % (g["nv"] + 1)
        near = (~own[:, None] & (iu[None] + 1 > u0[:, None]) & (iu[None] < u1[:, None])
                & (iv[None] + 1 > v0[:, None]) & (iv[None] < v1[:, None]))
        cols = f[:, start:start + len(idx)]  # a view
        cols[full] = 0.0
        pi, si = np.nonzero(near & ~full)
        for s in range(0, len(pi), batch):
            p, q = pi[s:s + batch], si[s:s + batch]
            a, b, valid = clip_to_cone(g["nodes"][idx[q]], x[p], m[p])
            part = np.where(valid, contour(a - x[p, None], b - x[p, None], n[p, None]), 0.0)
            if not np.isfinite(part).all():
                raise FloatingPointError("a clipped outline through its point")
            cols[p, q] = np.clip(cols[p, q] - part.sum(axis=1), 0.0, None)


def _square_direct(case, corners, normals, areas, on_box, box) -> np.ndarray:
    """Each square's mean direct illuminance (lx): per lamp, I (Ω of its lit part) / A, the box's
    shadow on the room's squares cut out exactly."""
    e = np.zeros(len(corners))
    centre = corners.mean(axis=1)
    for pos, flux, _ in case.lamps:
        eye = np.tile(np.asarray(pos, float), (len(corners), 1))
        lit = np.einsum("pc,pc->p", normals, eye - corners[:, 0]) > 0
        omega = solid_angle(eye, centre, corners, np.roll(corners, -1, axis=1),
                            np.ones(corners.shape[:2], bool))
        room = lit & ~on_box
        m = cone_planes(eye[room], *box)
        a, b, valid = clip_to_cone(corners[room], eye[room], m)
        omega[room] -= solid_angle(eye[room], centre[room], a, b, valid)
        e += np.where(lit, flux / (4 * np.pi) * omega / areas, 0.0)
    return e


def occluded_reference(case, size: float, chunk: int = 96) -> dict:
    """The exact-kernel radiosity of the room with one box inside, at square size ``size``
    (m): every square an unknown, the box's shadows exact; the points (which must see nothing
    of the box) read linearly. Returns the lux at the points and its checks."""
    corners, normals, areas, on_box, grids, box = _scene_squares(case, size)
    hidden = np.einsum("pc,bc->pb", case.normals,
                       np.array(list(itertools.product(*zip(*box)))))
    if np.any(hidden - np.einsum("pc,pc->p", case.normals, case.points)[:, None] > 0):
        raise ValueError("a point sees the box: the reference's gather has no visibility")
    pts, wts = gauss_points(corners)
    k = np.empty((len(corners), len(corners)))
    closure = 0.0
    for s in range(0, len(corners), chunk):
        rows = slice(s, min(s + chunk, len(corners)))
        x = pts[rows].reshape(-1, 3)
        n = np.repeat(normals[rows], 9, axis=0)
        f = point_to_squares(x, n, corners)
        room = ~np.repeat(on_box[rows], 9)
        if room.any():
            sub = f[room]
            _box_shadows(sub, x[room], n[room], corners, grids, box)
            f[room] = sub
        closure = max(closure, float(np.abs(f.sum(axis=1) - 1).max()))
        k[rows] = (f.reshape(-1, 9, len(corners)) * wts[None, :, None]).sum(axis=1)
    e0 = _square_direct(case, corners, normals, areas, on_box, box)
    b = np.linalg.solve(np.eye(len(k)) - case.rho * k, case.rho * e0)
    e_sq = e0 + k @ b
    flux = sum(lamp[1] for lamp in case.lamps)
    s = float(areas.sum())
    return {"lux": direct(case, case.points, case.normals)
            + linear_gather(case.points, case.normals, corners, b),
            "squares": len(areas), "closure": closure,
            "mean_vs_closed_form": float(np.sum(areas * e_sq) / s
                                         / (flux / (s * (1 - case.rho))) - 1)}


def reference(case, size: float) -> dict:
    """The numpy reference at square size ``size`` (m): ``convex_reference`` for an empty room,
    ``occluded_reference`` for a room with a box inside."""
    return occluded_reference(case, size) if case.obstacles else convex_reference(case, size)
