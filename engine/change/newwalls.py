"""New walls fitted from the new points of change detection (docs/method.md §5).

Each candidate element of kind "wall" (a cluster of new points spanning floor to ceiling) is
seen in plan: its points are thinned on a 2 cm grid and vertical planes (2D lines) are found
by RANSAC, each refined by least squares. Two parallel lines 5–60 cm apart whose extents
overlap are the two faces of one wall: the axis is their mid-line, the thickness their
distance, the extent the union of theirs; a face seen from one side only gives a wall of the
model's usual thickness on the side where no floor is seen in front of it. Wall ends within
40 cm of another wall stop at its face; at an L corner of two new walls the longer one keeps
the corner. The openings of the
new walls are found by :func:`engine.elements.openings.detect_openings` on the whole scan.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..evaluation.coverage import thin_grid
from ..model import BuildingModel, Polyhedron, Scope, Shape, ShapeType

__all__ = ["WallFitParams", "fit_new_walls", "wall_shape", "new_openings"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WallFitParams:
    """Parameters of :func:`fit_new_walls` (SI units)."""

    grid: float = 0.02
    """Plan thinning grid, metres."""
    min_tolerance: float = 0.01
    """Smallest RANSAC inlier distance, metres (else ``sigmas`` × the noise σ)."""
    sigmas: float = 2.5
    iterations: int = 400
    min_extent: float = 0.4
    """Lines shorter than this are jambs or ends, not faces (metres)."""
    max_lines: int = 10
    remove_factor: float = 2.0
    """After a line is found, the points within this many tolerances of it are removed."""
    min_thickness: float = 0.05
    """Thinnest wall (metres; at least two tolerances)."""
    max_thickness: float = 0.6
    max_angle: float = float(np.radians(3.0))
    """Largest angle between the two faces of a wall, radians."""
    min_overlap: float = 0.3
    """Share of the shorter face that the two faces' extents must share."""
    extent_bin: float = 0.05
    extent_share: float = 0.3
    max_gap: float = 0.3
    """New points on a face's line extend it across gaps up to this, metres."""
    column: float = 0.1
    """Plan cell of the columns that may extend a face, metres."""
    column_share: float = 0.5
    """A face only grows over columns of new points spanning at least this share of the storey
    height (a wall, not the desk or shelf in front of it)."""
    snap: float = 0.4
    """Wall ends this close to another wall end on its face, metres."""
    default_thickness: float = 0.15
    """Thickness of a wall seen from one side when the model has no interior walls, metres."""
    min_single_extent: float = 1.0
    """An unpaired face this long is a wall seen from one side (default thickness), metres."""


def _ransac_lines(xy: np.ndarray, tol: float, p: WallFitParams, rng) -> list[dict]:
    """Lines (point, direction, inlier indices) found one after the other."""
    left = np.arange(len(xy))
    lines = []
    min_cells = max(int(p.min_extent / p.grid), 5)
    while len(left) >= min_cells and len(lines) < p.max_lines:
        pts = xy[left]
        best, best_n = None, 0
        i = rng.integers(0, len(pts), (p.iterations, 2))
        for a, b in i:
            d = pts[b] - pts[a]
            n = np.hypot(*d)
            if n < 0.1:
                continue
            nrm = np.array([-d[1], d[0]]) / n
            cnt = int(np.sum(np.abs((pts - pts[a]) @ nrm) <= tol))
            if cnt > best_n:
                best, best_n = (pts[a], nrm), cnt
        if best is None or best_n < min_cells:
            break
        inl = np.abs((pts - best[0]) @ best[1]) <= tol
        for _ in range(2):  # least-squares refinement
            c = pts[inl].mean(axis=0)
            w, v = np.linalg.eigh(np.cov((pts[inl] - c).T))
            nrm = v[:, 0]
            inl = np.abs((pts - c) @ nrm) <= tol
        c = pts[inl].mean(axis=0)
        d = np.array([nrm[1], -nrm[0]])
        ext = _extent((pts[inl] - c) @ d, p)
        if ext[1] - ext[0] >= p.min_extent:
            lines.append({"c": c, "d": d, "n": nrm, "ext": ext, "count": int(inl.sum())})
        # the noise tail of the face goes with it (else it comes back as a second line)
        left = left[~(np.abs((pts - c) @ nrm) <= p.remove_factor * tol)]
    return lines


def _extent(u: np.ndarray, p: WallFitParams) -> tuple[float, float]:
    """Robust extent of positions along a line: the outer bins (``extent_bin``) holding at least
    ``extent_share`` of the median occupied bin's count (noise from a perpendicular face at a corner
    reaches a few points past the end)."""
    lo = float(u.min())
    nb = max(int(np.ceil((float(u.max()) - lo) / p.extent_bin)), 1)
    cnt = np.bincount(np.clip(((u - lo) / p.extent_bin).astype(np.int64), 0, nb - 1), minlength=nb)
    full = np.flatnonzero(cnt >= p.extent_share * np.median(cnt[cnt > 0]))
    a, b = lo + full[0] * p.extent_bin, lo + (full[-1] + 1) * p.extent_bin
    # inside the end bins, to the outermost point
    return float(max(a, u[u >= a].min())), float(min(b, u[u <= b].max()))


def _pairs(lines: list[dict], p: WallFitParams, tol: float) -> list[tuple]:
    """Greedy pairs of parallel lines (faces of one wall), by overlap × the weaker line's point count;
    unpaired lines as (line, None)."""
    cand = []
    for i in range(len(lines)):
        for j in range(i + 1, len(lines)):
            a, b = lines[i], lines[j]
            if abs(a["n"] @ b["n"]) < np.cos(p.max_angle):
                continue
            sep = abs((b["c"] - a["c"]) @ a["n"])
            if not max(p.min_thickness, 2 * tol) <= sep <= p.max_thickness:
                continue
            ua = np.array(a["ext"])
            off = (b["c"] - a["c"]) @ a["d"]
            ub = np.sort(np.array(b["ext"]) * np.sign(b["d"] @ a["d"]) + off)
            ov = min(ua[1], ub[1]) - max(ua[0], ub[0])
            short = min(ua[1] - ua[0], ub[1] - ub[0])
            if ov >= p.min_overlap * short:  # scored by the overlap and the weaker face's support
                cand.append((ov * min(a["count"], b["count"]), i, j))
    used, out = set(), []
    for ov, i, j in sorted(cand, reverse=True):
        if i in used or j in used:
            continue
        used.update((i, j))
        out.append((lines[i], lines[j]))
    out += [(ln, None) for k, ln in enumerate(lines) if k not in used]
    return out


def _single(a: dict, thickness: float, xyz: np.ndarray, floor: Optional[float], ceiling: Optional[float],
            band: float) -> Optional[dict]:
    """A wall seen from one side: the body is on the side without floor or ceiling points in front
    of the face (None when both sides or neither show them)."""
    c, d, n = a["c"], a["d"], a["n"]
    u0, u1 = a["ext"]
    rel = xyz[:, :2] - c
    u, v = rel @ d, rel @ n
    sel = (u > u0 + 0.05) & (u < u1 - 0.05) & (np.abs(v) > 0.03) & (np.abs(v) < thickness)
    zs = [z for z in (floor, ceiling) if z is not None]
    if not zs:
        return None
    sel &= np.min([np.abs(xyz[:, 2] - z) for z in zs], axis=0) < band
    pos, neg = int(np.sum(sel & (v > 0))), int(np.sum(sel & (v < 0)))
    if max(pos, neg) < 10 or min(pos, neg) > 0.2 * max(pos, neg):
        return None
    side = -1.0 if pos > neg else 1.0  # the body is where the floor is not seen
    off = c @ n + side * thickness / 2
    base = n * off
    return {"axis": np.stack([base + (c @ d + u0) * d, base + (c @ d + u1) * d]), "thickness": float(thickness),
            "d": d, "n": n}


def _wall_from_pair(a: dict, b: dict) -> dict:
    n = a["n"]
    d = a["d"]
    bn = b["n"] if b["n"] @ n > 0 else -b["n"]
    n = (n + bn) / np.linalg.norm(n + bn)
    d = np.array([n[1], -n[0]])
    if d @ a["d"] < 0:
        d = -d
    oa, ob = a["c"] @ n, b["c"] @ n
    thick = abs(ob - oa)
    mid_off = (oa + ob) / 2
    ends = []
    for ln in (a, b):
        sgn = 1.0 if ln["d"] @ d > 0 else -1.0
        ends += [(ln["c"] + sgn * e * ln["d"]) @ d for e in ln["ext"]]
    u0, u1 = min(ends), max(ends)
    base = n * mid_off
    return {"axis": np.stack([base + u0 * d, base + u1 * d]), "thickness": float(thick), "d": d, "n": n}


def _duplicate(w: dict, o: dict) -> bool:
    """Whether wall ``w`` lies in (parallel, overlapping) wall ``o``."""
    if abs(w["d"] @ o["d"]) < np.cos(np.radians(10)):
        return False
    mid = w["axis"].mean(axis=0)
    if abs((mid - o["axis"][0]) @ o["n"]) > (w["thickness"] + o["thickness"]) / 2:
        return False
    u = (w["axis"] - o["axis"][0]) @ o["d"]
    lo, hi = sorted(((o["axis"][1] - o["axis"][0]) @ o["d"], 0.0))
    return min(u.max(), hi) - max(u.min(), lo) > 0.3 * (u.max() - u.min())


def _frame_of(shape: Shape) -> dict:
    from .elements import _wall_frame
    a, d, n, length, thick = _wall_frame(shape)
    return {"axis": np.stack([a, a + d * length]), "d": d, "n": n, "thickness": thick}


def _near(point: np.ndarray, o: dict, reach: float) -> bool:
    """Whether ``point`` lies within ``reach`` of wall ``o``'s body (across and along)."""
    length = float(np.linalg.norm(o["axis"][1] - o["axis"][0]))
    u = (point - o["axis"][0]) @ o["d"]
    v = (point - o["axis"][0]) @ o["n"]
    return abs(v) <= o["thickness"] / 2 + reach and -reach <= u <= length + reach


def _move_end(w: dict, e: int, o: dict, far: bool) -> None:
    """Put end ``e`` of wall ``w`` on a face of ``o``: the near face (toward w's other end) or the far one."""
    off = o["axis"][0] @ o["n"]
    side = np.sign(w["axis"][1 - e] @ o["n"] - off) or 1.0
    target = off + (-side if far else side) * o["thickness"] / 2
    den = w["d"] @ o["n"]
    w["axis"][e] = w["axis"][e] + (target - w["axis"][e] @ o["n"]) / den * w["d"]


def _snap_ends(walls: list[dict], model_walls: list[dict], reach: float) -> None:
    """End the new walls on the faces of the walls they run into.

    An end within ``reach`` of a model wall (or of a new wall's middle: a T) stops at its near face.
    Two new walls meeting at an L: the one found first (longer) runs to the other's far face, the
    other stops at its near face."""
    for k, w in enumerate(walls):
        for e in (0, 1):
            for o in model_walls:
                if abs(w["d"] @ o["d"]) < 0.5 and _near(w["axis"][e], o, reach):
                    _move_end(w, e, o, far=False)
                    break
    for k, w in enumerate(walls):
        for e in (0, 1):
            for j, o in enumerate(walls):
                if j == k or abs(w["d"] @ o["d"]) > 0.5 or not _near(w["axis"][e], o, reach):
                    continue
                corner = any(_near(o["axis"][f], w, reach) and np.linalg.norm(o["axis"][f] - w["axis"][e])
                             < w["thickness"] + o["thickness"] + 2 * reach for f in (0, 1))
                _move_end(w, e, o, far=corner and k < j)
                break


def wall_shape(wid: str, name: str, axis: np.ndarray, thickness: float, z0: float, z1: float, storey: int,
               **attributes) -> Shape:
    """A WALL shape (prism of the axis ± thickness/2 between z0 and z1) with axis_line and thickness."""
    axis = np.asarray(axis, dtype=np.float64).reshape(2, 2)
    d = axis[1] - axis[0]
    d = d / np.linalg.norm(d)
    n = np.array([-d[1], d[0]]) * thickness / 2
    fp = [axis[0] - n, axis[1] - n, axis[1] + n, axis[0] + n]
    g = Polyhedron.prism(fp, z0, z1)
    attrs = {"thickness": float(thickness), "height": float(z1 - z0), "external": False, "exterior": False,
             "axis_line": axis.tolist()}
    attrs.update(attributes)
    return Shape(id=wid, type=ShapeType.WALL, geometry=g, scope=Scope.of_points(g.vertices), storey=int(storey),
                 name=name, terminal=True, attributes=attrs)


def _storey_of(model: BuildingModel, z: float):
    for st in model.storeys:
        if st.floor_z - 0.5 <= z <= st.ceiling_z + 0.5:
            return st.index, st.floor_z, st.ceiling_z
    return 0, None, None


def _tall_columns(model: BuildingModel, xyz: np.ndarray, p: WallFitParams) -> np.ndarray:
    """(n,) bool — points in plan cells (``p.column``) whose points span at least
    ``p.column_share`` of the height of the storey they stand in."""
    key = np.floor(xyz[:, :2] / p.column).astype(np.int64)
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    zmin = np.full(inv.max() + 1, np.inf)
    zmax = np.full(inv.max() + 1, -np.inf)
    np.minimum.at(zmin, inv, xyz[:, 2])
    np.maximum.at(zmax, inv, xyz[:, 2])
    height = np.full(len(xyz), float(np.ptp(xyz[:, 2])) if len(xyz) else 0.0)
    for st in model.storeys:
        inside = (xyz[:, 2] >= st.floor_z - 0.5) & (xyz[:, 2] <= st.ceiling_z + 0.5)
        height[inside] = st.ceiling_z - st.floor_z
    return (zmax - zmin)[inv] >= p.column_share * height


def _grow(line: dict, all_xy: np.ndarray, tol: float, p: WallFitParams, walls=None) -> None:
    """Extend a line's extent over the new points of any cluster on it (a wall seen sparsely far
    from the scanners falls apart into several clusters), across gaps up to ``max_gap``, never
    through a model wall (``walls``: the union of their plan footprints)."""
    if len(all_xy) == 0:
        return
    rel = all_xy - line["c"]
    on = np.abs(rel @ line["n"]) <= tol
    u = rel[on] @ line["d"]
    lo, hi = line["ext"]
    gap = p.max_gap
    u = np.sort(u)
    # walk outwards from the extent while the next point is within the gap
    right = u[u > hi]
    steps = np.diff(np.concatenate([[hi], right]))
    cut = np.flatnonzero(steps > gap)
    if len(right):
        hi = float(right[cut[0] - 1]) if len(cut) and cut[0] > 0 else (hi if len(cut) else float(right[-1]))
    left = u[u < lo][::-1]
    steps = -np.diff(np.concatenate([[lo], left]))
    cut = np.flatnonzero(steps > gap)
    if len(left):
        lo = float(left[cut[0] - 1]) if len(cut) and cut[0] > 0 else (lo if len(cut) else float(left[-1]))
    if walls is not None and not walls.is_empty:
        import shapely
        from shapely.geometry import LineString
        a0, b0 = line["ext"]
        for end, start in ((hi, b0), (lo, a0)):
            if end == start:
                continue
            seg = LineString([line["c"] + start * line["d"], line["c"] + end * line["d"]])
            hit = seg.intersection(walls)
            if not hit.is_empty:
                pts = shapely.get_coordinates(hit)
                t = (pts - line["c"]) @ line["d"]
                if end > start:
                    hi = max(b0, float(t.min()))
                else:
                    lo = min(a0, float(t.max()))
    line["ext"] = (lo, hi)


def fit_new_walls(model: BuildingModel, xyz: np.ndarray, cluster: np.ndarray, elements: list, *,
                  sigma: float = 0.005, params: Optional[WallFitParams] = None, seed: int = 0,
                  new: Optional[np.ndarray] = None) -> list[dict]:
    """New walls from the candidate elements of kind "wall".

    Returns a list of dict: id ("new_wall_<k>"), name, axis_line ((2, 2) list, model frame),
    thickness, z0, z1, storey, length, cluster (element id), faces (2: paired; the faces'
    point counts), shape (:class:`~engine.model.Shape`).
    """
    p = params or WallFitParams()
    rng = np.random.default_rng(seed)
    tol = max(p.min_tolerance, p.sigmas * float(sigma))
    thick = [float(w.attributes.get("thickness", 0)) for w in model.walls
             if not w.attributes.get("external") and float(w.attributes.get("thickness", 0) or 0) > 0]
    thickness = float(np.median(thick)) if thick else p.default_thickness
    walls = []
    all_xy = np.zeros((0, 2))
    if new is not None and np.any(new):
        pts_new = xyz[new]
        all_xy = thin_grid(pts_new[_tall_columns(model, pts_new, p)][:, :2], p.grid)
    import shapely
    from shapely.geometry import Polygon
    fps = [w.footprint() for w in model.walls if w.active]
    obstacles = shapely.union_all([Polygon(f) for f in fps if f is not None and len(f) >= 3])
    for e in elements:
        if e["kind"] != "wall":
            continue
        pts = xyz[cluster == e["id"]]
        if len(pts) < 10:
            continue
        xy = thin_grid(pts[:, :2], p.grid)
        lines = _ransac_lines(xy, tol, p, rng)
        for ln in lines:
            _grow(ln, all_xy, tol, p, obstacles)
        st, floor, ceiling = _storey_of(model, float(pts[:, 2].mean()))
        for a, b in _pairs(lines, p, tol):
            if b is not None:
                w = _wall_from_pair(a, b)
            elif a["ext"][1] - a["ext"][0] >= p.min_single_extent:
                w = _single(a, thickness, xyz, floor, ceiling, max(tol, 0.03))
                if w is None or any(_duplicate(w, o) for o in walls):
                    continue
            else:
                continue
            w["cluster"] = e["id"]
            w["faces"] = [a["count"]] + ([b["count"]] if b is not None else [])
            w["z"] = (float(pts[:, 2].min()), float(pts[:, 2].max()))
            walls.append(w)
    # a wall inside a better-supported one (a door leaf or frame in its doorway, a second line
    # pair on the same wall) is not a wall
    kept = []
    for w in sorted(walls, key=lambda w: -sum(w["faces"])):
        if not any(_duplicate(w, o) for o in kept):
            kept.append(w)
    walls = sorted(kept, key=lambda w: -np.linalg.norm(w["axis"][1] - w["axis"][0]))
    old = [_frame_of(w) for w in model.walls if w.active]
    _snap_ends(walls, old, p.snap)
    out = []
    for k, w in enumerate(walls):
        st, z0, z1 = _storey_of(model, float(np.mean(w["z"])))
        if z0 is None:
            z0, z1 = w["z"]
        wid = f"new_wall_{k}"
        name = f"New wall {k + 1}"
        shape = wall_shape(wid, name, w["axis"], w["thickness"], z0, z1, st, new_in_scan=True)
        out.append({"id": wid, "name": name, "axis_line": w["axis"].tolist(), "thickness": w["thickness"],
                    "z0": float(z0), "z1": float(z1), "storey": int(st),
                    "length": float(np.linalg.norm(w["axis"][1] - w["axis"][0])), "cluster": int(w["cluster"]),
                    "faces": w["faces"], "shape": shape})
    log.info("new walls: %d fitted", len(out))
    return out


def new_openings(model: BuildingModel, walls: list, xyz: np.ndarray, *, normals=None, scan_index=None,
                 scanners=None) -> list[Shape]:
    """Doors and windows of the new walls (:func:`engine.elements.openings.detect_openings`)."""
    if not walls:
        return []
    from ..elements.openings import detect_openings
    shapes = [w["shape"] for w in walls]
    try:
        found = detect_openings(shapes, model.storeys, xyz, normals=normals, scan_index=scan_index,
                                scanner_positions=scanners)
    except Exception as e:  # opening detection is best effort here: the walls stand without
        log.warning("new walls: opening detection failed: %s", e)
        return []
    return [d.with_(id=f"new_{d.id}", name=f"New {(d.name or d.type.value).lower()}",  # not the model's "Door 1"
                    attributes={**d.attributes, "new_in_scan": True}) for d in found]
