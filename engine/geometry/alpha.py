"""Grid thinning and 2-D alpha shapes.

The alpha shape of a point set is the union of the Delaunay triangles whose circumradius is
below r_α. It measures how much of a surface the points cover: the grammar's coverage of
cells and faces (:mod:`engine.grammar.coverage`) and the point-on-face coverage of the
evaluation and the change detection (:mod:`engine.evaluation.coverage`) all use the
functions here.
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np
import shapely
from scipy.spatial import Delaunay, QhullError, cKDTree

from ..threads import thread_cap

__all__ = ["thin_grid", "local_alpha", "adaptive_alpha", "alpha_simplices", "alpha_triangles", "alpha_area",
           "clipped_area", "alpha_geometry", "triangle_areas"]

_ANCHORS = ("zero", "min")
_KEEPS = ("first", "last")


def thin_grid(pts: np.ndarray, cell: float, *, anchor: str = "zero", keep: str = "first") -> np.ndarray:
    """Keep one point per cell of a regular grid of ``cell`` metres.

    Parameters
    ----------
    pts : (n, d) float64 — metres.
    cell : grid size, metres (<= 0: no thinning).
    anchor : "zero" — grid lines at whole multiples of ``cell``; "min" — the grid starts at
        the points' minimum corner.
    keep : "first" — the first point met in each cell, in input order; "last" — the last
        point of each cell, in cell order (row-major).

    Returns
    -------
    (m, d) float64, m <= n. Empty in, empty out.
    """
    if anchor not in _ANCHORS:
        raise ValueError(f"anchor must be one of {_ANCHORS}, not {anchor!r}")
    if keep not in _KEEPS:
        raise ValueError(f"keep must be one of {_KEEPS}, not {keep!r}")
    pts = np.asarray(pts, dtype=np.float64)
    if cell <= 0 or len(pts) == 0:
        return pts
    base = pts - pts.min(axis=0) if anchor == "min" else pts
    keys = np.floor(base / cell).astype(np.int64)
    if keep == "first":
        _, first = np.unique(keys, axis=0, return_index=True)
        return pts[np.sort(first)]
    keys -= keys.min(axis=0)
    dims = keys.max(axis=0) + 1
    rep = np.full(int(np.prod(dims)), -1, dtype=np.int64)
    rep[np.ravel_multi_index(tuple(keys.T), tuple(dims))] = np.arange(len(pts))  # the last one wins
    return pts[rep[rep >= 0]]


def local_alpha(xy: np.ndarray, r_alpha: float, factor: float, r_max: float, k: int = 8) -> np.ndarray:
    """Per-point circumradius bounds that follow the local point spacing, metres.

    ``clip(factor × s_i, r_alpha, r_max)`` with ``s_i`` the median nearest-neighbour distance
    over point i and its ``k`` nearest neighbours: where a scan samples a surface sparsely
    (a room's edge far from a mobile path, a corridor's far end), a fixed r_α leaves most of
    the surface uncovered; the median over a neighbourhood keeps a stray point far from the
    others from getting a large bound. ``xy`` : (n, 2) float64 metres; returns (n,) float64.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) <= k or factor <= 0 or r_max <= r_alpha:
        return np.full(len(xy), float(r_alpha))
    d, nn = cKDTree(xy).query(xy, k=k + 1, workers=thread_cap())
    s = np.median(d[:, 1][nn], axis=1)
    return np.clip(factor * s, r_alpha, r_max)


def adaptive_alpha(xy: np.ndarray, r_alpha: float, factor: float, sample: int = 20_000) -> float:
    """``max(r_alpha, factor × median nearest-neighbour distance of xy)`` (metres).

    ``xy`` : (n, 2) float64 metres; a fixed sample of at most ``sample`` points is used."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if factor <= 0 or len(xy) < 3:
        return float(r_alpha)
    q = xy[:: max(1, len(xy) // sample)]
    d, _ = cKDTree(xy).query(q, k=2)
    return float(max(r_alpha, factor * np.median(d[:, 1])))


def alpha_simplices(xy: np.ndarray, r_alpha) -> np.ndarray:
    """(m, 3) int64 vertex indices of the alpha-shape triangles of ``xy`` (n, 2) metres.

    ``r_alpha`` is a float or an (n,) bound per point, metres (a triangle is kept under the
    smallest bound of its corners). Fewer than three points or collinear points: none."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 3:
        return np.zeros((0, 3), dtype=np.int64)
    try:
        tri = Delaunay(xy)
    except (QhullError, ValueError):
        return np.zeros((0, 3), dtype=np.int64)
    t = xy[tri.simplices]
    a = np.linalg.norm(t[:, 1] - t[:, 2], axis=1)
    b = np.linalg.norm(t[:, 0] - t[:, 2], axis=1)
    c = np.linalg.norm(t[:, 0] - t[:, 1], axis=1)
    area2 = np.abs((t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1])
                   - (t[:, 1, 1] - t[:, 0, 1]) * (t[:, 2, 0] - t[:, 0, 0]))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = a * b * c / (2.0 * area2)
    bound = np.asarray(r_alpha, dtype=np.float64)
    if bound.ndim:
        bound = bound[tri.simplices].min(axis=1)
    keep = np.isfinite(r) & (r < bound)
    return tri.simplices[keep].astype(np.int64)


def alpha_triangles(xy: np.ndarray, r_alpha: float) -> np.ndarray:
    """Triangles of the 2-D alpha shape: Delaunay triangles with circumradius < ``r_alpha``.

    Parameters
    ----------
    xy : (n, 2) float64 — metres.
    r_alpha : float — metres.

    Returns
    -------
    (m, 3, 2) float64 — triangle corners, metres. Empty (0, 3, 2) for fewer than three
    points or collinear points.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return xy[alpha_simplices(xy, r_alpha)].reshape(-1, 3, 2)


def triangle_areas(t: np.ndarray) -> np.ndarray:
    """(m,) float64 areas (m²) of (m, 3, 2) triangles (metres)."""
    return 0.5 * np.abs((t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1])
                        - (t[:, 1, 1] - t[:, 0, 1]) * (t[:, 2, 0] - t[:, 0, 0]))


def alpha_area(xy: np.ndarray, r_alpha: float, clip: Optional[tuple] = None) -> float:
    """Area of the 2-D alpha shape of ``xy`` (m²).

    ``xy`` : (n, 2) float64 metres (thin it first with :func:`thin_grid` to bound the work);
    ``r_alpha`` : metres. ``clip`` : optional ``(lo (2,), hi (2,))`` box; triangles are
    clipped to it (exactly, with shapely) when some corner lies outside. Fewer than three
    points: 0.
    """
    return clipped_area(alpha_triangles(xy, r_alpha), clip)


def clipped_area(t: np.ndarray, clip: Optional[tuple] = None) -> float:
    """Area (m²) of triangles ``t`` ((k, 3, 2) metres) inside the ``clip`` box ``(lo (2,),
    hi (2,))`` (exactly, with shapely, for those with a corner outside), or in all."""
    if len(t) == 0:
        return 0.0
    if clip is not None:
        lo, hi = np.asarray(clip[0], float), np.asarray(clip[1], float)
        outside = np.any((t < lo - 1e-12) | (t > hi + 1e-12), axis=(1, 2))
        inner = t[~outside]
        total = float(np.sum(triangle_areas(inner)))
        if outside.any():
            box = shapely.box(lo[0], lo[1], hi[0], hi[1])
            polys = shapely.polygons(t[outside])
            total += float(np.sum(shapely.area(shapely.intersection(polys, box))))
        return total
    return float(np.sum(triangle_areas(t)))


def alpha_geometry(xy: np.ndarray, r_alpha: float, blockers: Sequence = (), snap: float = 0.0,
                   tolerance: float = 1e-9, local_factor: float = 0.0, r_max: float = 0.0, bounds=None):
    """The alpha shape of ``xy`` as one shapely (Multi)Polygon (union of its triangles).

    Parameters
    ----------
    xy : (n, 2) float64 — metres.
    r_alpha : circumradius bound, metres.
    blockers : sequence of (2, 2) segments (metres) no triangle may cross: a triangle with
        corners strictly on both sides of a blocker's line (beyond ``tolerance``) where it
        meets the segment is dropped — so the shape never bridges a wall.
    snap : points within this distance of a blocker (and within its extent) are moved onto
        it first, so the shape reaches the wall instead of stopping half a point spacing
        short of it (metres; 0: no snapping). The side most of them came from is the
        blocker's room side: a triangle meeting the blocker may then have no corner on the
        other side (this stops triangles between the snapped points of the two faces of a
        wall).

    local_factor, r_max : when ``r_max > r_alpha``, each point's bound is raised to
        ``local_factor`` × the local spacing, at most ``r_max`` (:func:`local_alpha`).
    bounds : (n,) float64 circumradius bound of each point, metres, instead of the two above;
        or None.

    Returns
    -------
    shapely geometry; an empty GeometryCollection when there is no triangle.
    """
    xy = np.array(xy, dtype=np.float64).reshape(-1, 2)
    segs = np.asarray(blockers, dtype=np.float64).reshape(-1, 2, 2)
    room_side = np.zeros(len(segs))
    if len(segs) and snap > 0 and len(xy):
        tree = cKDTree(xy)
        moves = []
        for k, (p, q) in enumerate(segs):
            d = q - p
            L = float(np.linalg.norm(d))
            if L <= 0:
                continue
            u = d / L
            idx = np.asarray(tree.query_ball_point((p + q) / 2, L / 2 + snap), dtype=np.int64)
            if len(idx) == 0:
                continue
            rel = xy[idx] - p
            t = rel @ u
            sd = rel @ np.array([-u[1], u[0]])
            m = (np.abs(sd) <= snap) & (t >= 0) & (t <= L)
            # the side the points came from (the room's side of this wall face)
            room_side[k] = np.sign(np.sum(np.sign(sd[m])))
            moves.append((idx[m], p + t[m, None] * u))
        for idx, proj in moves:
            xy[idx] = proj
    if bounds is not None:
        bound = np.asarray(bounds, dtype=np.float64).reshape(len(xy))
    else:
        bound = local_alpha(xy, r_alpha, local_factor, r_max) if r_max > r_alpha else r_alpha
    simp = alpha_simplices(xy, bound)
    if len(simp) == 0:
        return shapely.GeometryCollection()
    t = xy[simp]
    polys = shapely.polygons(t)
    if len(segs):
        lines = shapely.linestrings(segs)
        li, ti = shapely.STRtree(polys).query(lines, predicate="intersects")
        if len(li):
            p0 = segs[li, 0]
            d = segs[li, 1] - p0
            nrm = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
            sd = np.einsum("kij,kj->ki", t[ti] - p0[:, None, :], nrm)
            bad = (sd.max(axis=1) > tolerance) & (sd.min(axis=1) < -tolerance)
            # no corner on the far side of a face whose points came from one side
            side = room_side[li]
            bad |= (side != 0) & np.any(sd * side[:, None] < -tolerance, axis=1)
            keep = np.ones(len(polys), bool)
            keep[ti[bad]] = False
            polys = polys[keep]
        if len(polys) == 0:
            return shapely.GeometryCollection()
    try:  # Delaunay triangles form a valid coverage: fast path
        return shapely.coverage_union_all(polys)
    except Exception:  # pragma: no cover - older GEOS
        return shapely.union_all(polys)
