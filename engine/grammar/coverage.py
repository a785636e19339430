"""Alpha-shape coverage of cells, computed once per cell complex (docs/method.md §3.2).

The rjMCMC likelihood needs, for every candidate interior space (a union of cells), the
area of its ceiling covered by points, the covered area of its side faces and the area of
points lying *inside* it. All three are additive over cells and faces, so they are measured
once per cell and per face here and summed by the search (:mod:`.rjmcmc`):

* ``top[c]`` — area of the **alpha shape** of the ceiling points (horizontal points in the
  upper half of the storey), projected on x, y, clipped to cell ``c``'s footprint. The alpha
  shape of the whole storey is built once (Delaunay of the thinned points, triangles with
  circumradius < r_α, unioned), so a thin sliver cell inside a room is measured as covered;
  no per-cell Delaunay edge effects.
* ``face[f]`` — alpha-shape area of the wall points within the shape buffer δ of face ``f``
  (a vertical rectangle over a footprint edge), projected onto the face in (t, z), clipped
  to the face.
* ``inside[c]`` — area of wall and floor/ceiling points strictly inside cell ``c`` (farther
  than δ from its sides, floor and ceiling), measured as occupied voxels × voxel².
  (Departure: these points lie on no known plane, so an alpha shape has no natural plane
  to be drawn on; the voxel count is the area estimate the point-on-face index uses too.)

A face shared by two cells of one space is internal to it: its wall coverage then counts
as points inside the space (see :meth:`CellCoverage.space_terms`).

The adapter the search works on is :class:`CellSet`: cells as 2-D shapely polygons with a
z range, and faces (a footprint segment between two cells, or between a cell and the
outside, ``b = -1``).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from ..geometry.alpha import (adaptive_alpha, alpha_area, alpha_geometry, alpha_triangles, clipped_area,
                              local_alpha)
from ..geometry.alpha import thin_grid as thin_points
from ..geometry.sort import stable_argsort
from .params import CoverageParams

__all__ = ["adaptive_alpha", "local_alpha", "cell_heights", "alpha_triangles", "alpha_area", "alpha_geometry",
           "thin_points", "Face", "CellSet", "CellCoverage", "measure_coverage", "cellset_from_polygons"]

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- adapter
@dataclass(frozen=True, eq=False)
class Face:
    """A vertical face of the cell complex over a footprint edge.

    Attributes
    ----------
    a, b : int
        The cells on either side; ``b = -1`` on the boundary of the complex.
    segments : (k, 2, 2) float64
        The footprint segment(s) the face stands on (x, y metres); usually one.
    """

    a: int
    b: int
    segments: np.ndarray

    @property
    def length(self) -> float:
        """Total length of the face's footprint segments, metres."""
        return float(np.sum(np.linalg.norm(self.segments[:, 1] - self.segments[:, 0], axis=1)))


@dataclass(frozen=True, eq=False)
class CellSet:
    """The cell complex of one storey as the rjMCMC search sees it (the adapter interface).

    Attributes
    ----------
    polygons : tuple of shapely Polygon
        2-D footprints of the cells, metres (x, y).
    z_range : (n, 2) float64
        Bottom and top z of every cell, metres.
    faces : tuple of Face
        Every footprint edge between two cells (shared edge longer than a minimum) and
        between a cell and the outside.
    """

    polygons: tuple
    z_range: np.ndarray
    faces: tuple

    def __len__(self) -> int:
        return len(self.polygons)

    @property
    def areas(self) -> np.ndarray:
        """(n,) float64 — footprint areas, m²."""
        return np.array([p.area for p in self.polygons])

    def neighbours(self) -> list[list[tuple[int, int]]]:
        """For each cell, its ``(other cell, face index)`` pairs (boundary faces excluded)."""
        out = [[] for _ in self.polygons]
        for fi, f in enumerate(self.faces):
            if f.b >= 0:
                out[f.a].append((f.b, fi))
                out[f.b].append((f.a, fi))
        return out

    def union(self, cells) -> object:
        """Union of the footprints of ``cells`` (indices), tolerant of gaps up to
        ``2 × 10 × _EDGE_TOL`` metres (the tolerance of the faces' outline test below): each
        footprint is grown by 1e-5 m, the union shrunk back. A vertex one cell kept and its
        neighbour dropped (merged slivers) leaves the two outlines a few µm apart along their
        shared edge, which a plain union keeps as two pieces; hairline holes (area ≤
        ``_HAIRLINE``) are dropped.

        Returns a shapely Polygon, or a MultiPolygon when the cells are not connected."""
        import shapely

        eps = 10 * _EDGE_TOL
        grown = shapely.buffer(np.array([self.polygons[c] for c in cells], dtype=object), eps, join_style="mitre")
        u = shapely.buffer(shapely.union_all(grown), -eps, join_style="mitre")
        parts = [shapely.Polygon(g.exterior, [r for r in g.interiors if shapely.Polygon(r).area > _HAIRLINE])
                 for g in getattr(u, "geoms", [u]) if g.geom_type == "Polygon"]
        return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)

    def thickness(self, c: int, fi: int) -> float:
        """How far cell ``c`` reaches from face ``fi``: the largest distance of its vertices
        to the line of the nearest of the face's segments, metres (the "vertex-to-surface
        distance" of the wall rule, docs/method.md §3.4)."""
        v = np.asarray(self.polygons[c].exterior.coords)[:-1, :2]
        out = math.inf
        for p, q in self.faces[fi].segments:
            d = q - p
            L = float(np.linalg.norm(d))
            if L == 0:
                dist = np.linalg.norm(v - p, axis=1)
            else:
                dist = np.abs((v - p) @ (np.array([-d[1], d[0]]) / L))
            out = min(out, float(dist.max()))
        return out

    def wall_thickness(self, c: int, faces, in_space) -> float:
        """The wall rule of docs/method.md §3.4 for cell ``c``: the smallest :meth:`thickness` of ``c``
        against those of its ``faces`` (face indices, e.g. from :meth:`cell_faces`) that it
        shares with a cell where ``in_space`` ((n,) bool) is True, metres; inf when there is
        none. ``c`` is a wall when this is at most the maximum wall thickness."""
        out = math.inf
        for fi in faces:
            f = self.faces[fi]
            other = f.b if f.a == c else f.a
            if other >= 0 and in_space[other]:
                out = min(out, self.thickness(c, fi))
        return out

    def cell_faces(self) -> list[list[int]]:
        """For each cell, the indices of all its faces (boundary ones included)."""
        out = [[] for _ in self.polygons]
        for fi, f in enumerate(self.faces):
            out[f.a].append(fi)
            if f.b >= 0:
                out[f.b].append(fi)
        return out


def _segments(geom) -> list[np.ndarray]:
    """(2, 2) segments of a (multi)line geometry."""
    import shapely

    out = []
    if geom.is_empty:
        return out
    for part in getattr(geom, "geoms", [geom]):
        if part.geom_type in ("LineString", "LinearRing"):
            c = np.asarray(part.coords)[:, :2]
            for i in range(len(c) - 1):
                if np.linalg.norm(c[i + 1] - c[i]) > 0:
                    out.append(c[i:i + 2].copy())
        elif part.geom_type in ("MultiLineString", "GeometryCollection"):
            out.extend(_segments(part))
        elif part.geom_type == "Polygon":
            out.extend(_segments(shapely.boundary(part)))
    return out


_EDGE_TOL = 1e-6
"""Two cell outlines closer than this (metres) share an edge."""
_HAIRLINE = 1e-4
"""A hole of a union of cells smaller than this (m²) is float noise: the arrangement
merges cells below ``min_cell_area`` (0.01 m²)."""


def cellset_from_polygons(polygons: Sequence, z_range, min_face_length: float = 0.02) -> CellSet:
    """Build the adapter from 2-D cell footprints (a partition: no overlaps).

    Parameters
    ----------
    polygons : sequence of shapely Polygon — x, y metres.
    z_range : (n, 2) float64 or (2,) float64 for every cell — metres.
    min_face_length : shared edges shorter than this make no face, metres.

    Returns
    -------
    CellSet, with one face per pair of cells sharing an edge and one boundary face per
    cell whose outline is not fully shared.
    """
    import shapely

    polys = tuple(shapely.normalize(p) for p in polygons)
    n = len(polys)
    zr = np.asarray(z_range, dtype=np.float64)
    if zr.ndim == 1:
        zr = np.tile(zr, (n, 1))
    tree = shapely.STRtree(polys)
    bnd = [p.boundary for p in polys]
    faces, shared = [], [[] for _ in range(n)]
    grown = shapely.buffer(np.array(polys, dtype=object), 1e-7)
    pairs = tree.query(grown, predicate="intersects")
    for i, j in zip(*pairs):
        if j <= i:
            continue
        # with a tolerance: float noise and vertices dropped on one side only (merged
        # slivers) must not hide a shared edge
        inter = shapely.intersection(bnd[i], shapely.buffer(bnd[j], _EDGE_TOL, cap_style="flat"))
        if inter.is_empty or inter.length < min_face_length:
            continue
        segs = _segments(shapely.line_merge(inter) if inter.geom_type == "MultiLineString" else inter)
        if not segs:
            continue
        faces.append(Face(int(i), int(j), np.array(segs)))
        shared[i].append(inter)
        shared[j].append(inter)
    for i in range(n):
        rest = bnd[i]
        if shared[i]:
            rest = shapely.difference(rest, shapely.buffer(shapely.union_all(shared[i]), 10 * _EDGE_TOL))
        if rest.is_empty or rest.length < min_face_length:
            continue
        segs = [s for s in _segments(rest) if np.linalg.norm(s[1] - s[0]) >= 1e-6]
        if segs:
            faces.append(Face(int(i), -1, np.array(segs)))
    return CellSet(polys, zr, tuple(faces))


# --------------------------------------------------------------------------- coverage
@dataclass(frozen=True, eq=False)
class CellCoverage:
    """Coverage figures of a :class:`CellSet`, all in m².

    Attributes
    ----------
    area : (n,) float64 — footprint (top face) area of every cell.
    top : (n,) float64 — alpha-shape area of the ceiling points over every cell.
    inside : (n,) float64 — area of points strictly inside every cell.
    face : (f,) float64 — alpha-shape area of the wall points on every face.
    total_horizontal : float — Cov(hpoints): alpha-shape area of all ceiling points.
    total_vertical : float — Cov(vpoints): the wall coverage of all faces together.
    ceiling_z, floor_z : (n,) float64 — median z of the ceiling / floor points over every
        cell (NaN where none), metres.
    seen : (f,) bool or None — faces seen as walls (coverage ≥ ``min_wall_coverage`` of
        their band), the faces that block the ceiling's alpha shape; None: not measured.
    """

    area: np.ndarray
    top: np.ndarray
    inside: np.ndarray
    face: np.ndarray
    total_horizontal: float
    total_vertical: float
    ceiling_z: np.ndarray
    floor_z: np.ndarray
    seen: Optional[np.ndarray] = None


def _points_in_cells(polys, xy: np.ndarray) -> np.ndarray:
    """(m,) int64 index of the cell holding each point (-1: none)."""
    import shapely

    out = np.full(len(xy), -1, dtype=np.int64)
    if len(xy) == 0 or not polys:
        return out
    tree = shapely.STRtree(polys)
    pts = shapely.points(xy)
    ip, ic = tree.query(pts, predicate="intersects")
    out[ip] = ic  # a point on a shared edge goes to either cell
    return out


def cell_heights(cells: CellSet, hw: np.ndarray):
    """Which cell holds each floor/ceiling point, and the cells' floor and ceiling heights.

    Parameters
    ----------
    cells : CellSet
    hw : (m, 3) float64 — floor/ceiling points, metres.

    Returns
    -------
    cell : (m,) int64 — cell of each point (-1: none).
    upper : (m,) bool — the point is in the upper half of its cell (a ceiling point).
    ceiling_z, floor_z : (n,) float64 — median height of the ceiling / floor points over
        each cell, metres (NaN where none).
    """
    n = len(cells)
    zmid = cells.z_range.mean(axis=1)
    hc = _points_in_cells(cells.polygons, hw[:, :2])
    ok = hc >= 0
    upper = np.zeros(len(hw), bool)
    upper[ok] = hw[ok, 2] > zmid[hc[ok]]
    ceiling_z = np.full(n, np.nan)
    floor_z = np.full(n, np.nan)
    lower = ok & ~upper
    for arr, mask in ((ceiling_z, upper), (floor_z, lower)):
        idx = hc[mask]
        z = hw[mask, 2]
        if len(idx):
            order = stable_argsort(idx)
            idx, z = idx[order], z[order]
            cuts = np.flatnonzero(np.diff(idx)) + 1
            for grp_i, grp_z in zip(np.split(idx, cuts), np.split(z, cuts)):
                arr[grp_i[0]] = _layer_height(grp_z)

    return hc, upper, ceiling_z, floor_z


_LAYER_BIN = 0.02
"""Bin of the height histogram that finds a cell's ceiling / floor layer, metres."""
_LAYER_HALF_WIDTH = 0.06
"""Points within this of the densest bin make the layer (about 3σ of mobile noise), metres."""


def _layer_height(z: np.ndarray) -> float:
    """Height of the densest horizontal layer among ``z`` (metres): the median of the points
    near the histogram peak, so table tops under a ceiling or over a floor do not pull it."""
    if len(z) < 3:
        return float(np.median(z))
    lo = float(z.min())
    k = np.floor((z - lo) / _LAYER_BIN).astype(np.int64)
    peak = lo + (np.argmax(np.bincount(k)) + 0.5) * _LAYER_BIN
    near = z[np.abs(z - peak) <= _LAYER_HALF_WIDTH]
    return float(np.median(near)) if len(near) else float(np.median(z))


def _face_band(f: Face, zr: np.ndarray, ceiling_z: np.ndarray, band: float) -> tuple:
    """(z0, z1) of the part of face ``f`` whose wall coverage is measured, metres."""
    cells = [f.a] if f.b < 0 else [f.a, f.b]
    z0 = float(min(zr[c, 0] for c in cells))
    z1 = float(max(zr[c, 1] for c in cells))
    if band <= 0:
        return z0, z1
    cz = [ceiling_z[c] for c in cells if np.isfinite(ceiling_z[c])]
    top = min(max(cz), z1) if cz else z1
    return max(z0, top - band), top


def _near_segment(vw: np.ndarray, tree, p: np.ndarray, q: np.ndarray, z0: float, z1: float,
                  buffer: float) -> tuple:
    """Wall points ``vw`` (``tree`` over their x, y) within ``buffer`` of the footprint segment
    p–q and between z0 and z1: their distance along it from p and their z (metres)."""
    d = q - p
    L = float(np.linalg.norm(d))
    empty = (np.zeros(0), np.zeros(0))
    if L <= 0:
        return empty
    u = d / L
    cand = tree.query_ball_point((p + q) / 2, L / 2 + buffer)
    if not cand:
        return empty
    c = vw[cand]
    rel = c[:, :2] - p
    t = rel @ u
    dist = np.abs(rel @ np.array([-u[1], u[0]]))
    sel = (dist <= buffer) & (t >= 0) & (t <= L) & (c[:, 2] >= z0) & (c[:, 2] <= z1)
    return t[sel], c[sel, 2]


def _straight(f: Face):
    """The one straight footprint segment (p, q) a face stands on (pieces under 0.1 mm aside:
    snapping leaves µm pieces), or None."""
    segs = [(p, q) for p, q in f.segments if np.linalg.norm(q - p) > 1e-4]
    return segs[0] if len(segs) == 1 else None


def _face_line(f: Face):
    """(angle in [0, π), offset, t0, t1) of a face standing on one straight footprint segment
    (:func:`_straight`), or None: the line's direction d at that angle, its normal
    n = (-d_y, d_x), the offset n·p and the segment's extent along d."""
    seg = _straight(f)
    if seg is None:
        return None
    p, q = seg
    d = (q - p) / np.linalg.norm(q - p)
    ang = math.atan2(d[1], d[0]) % math.pi
    if ang > math.pi - 1e-6:  # a horizontal line, whichever way it points
        ang = 0.0
    d = np.array([math.cos(ang), math.sin(ang)])
    n = np.array([-d[1], d[0]])
    t0, t1 = sorted((float(p @ d), float(q @ d)))
    return ang, float(n @ p), t0, t1


def _clusters(values: np.ndarray, tol: float) -> list:
    """Indices of ``values`` grouped where sorted neighbours lie within ``tol``."""
    if not len(values):
        return []
    o = np.argsort(values, kind="stable")
    cut = np.flatnonzero(np.diff(values[o]) > tol) + 1
    return np.split(o, cut)


def _true_runs(mask: np.ndarray) -> tuple:
    """Starts and stops of the runs of True in ``mask``."""
    m = np.r_[False, np.asarray(mask, bool), False].astype(np.int8)
    d = np.diff(m)
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def _collinear_runs(faces, angle_tol: float = 1e-3, offset_tol: float = 0.005, gap: float = 0.005) -> list:
    """Runs of faces standing on one line end to end: lists of face indices in order along
    it (single faces left out)."""
    fis, lines = [], []
    for fi, f in enumerate(faces):
        ln = _face_line(f)
        if ln is not None:
            fis.append(fi)
            lines.append(ln)
    if not lines:
        return []
    fis, L = np.asarray(fis), np.asarray(lines)
    runs = []
    for a in _clusters(L[:, 0], angle_tol):
        for b in _clusters(L[a, 1], offset_tol):
            idx = a[b][np.argsort(L[a[b], 2], kind="stable")]
            cur, end = [int(fis[idx[0]])], L[idx[0], 3]
            for k in idx[1:]:
                if L[k, 2] <= end + gap:
                    cur.append(int(fis[k]))
                    end = max(end, L[k, 3])
                else:
                    runs.append(cur)
                    cur, end = [int(fis[k])], L[k, 3]
            runs.append(cur)
    return [r for r in runs if len(r) > 1]


def _run_seen(cells: CellSet, vw: np.ndarray, tree, seen: np.ndarray, touched: np.ndarray, zr: np.ndarray,
              ceiling_z: np.ndarray, params: CoverageParams, r_alpha: float) -> np.ndarray:
    """(n_faces,) bool: pieces shorter than an alpha disc (2 r_α) covered
    ``min_wall_coverage`` by the alpha shape of the points of their chain — collinear faces
    end to end (one wall line, cut into pieces by the other lines of the arrangement), each
    seen or holding wall points in its band (``touched``), one seen on its own (the line is a
    seen wall). The chain's alpha shape joins the scan columns across the pieces' ends; a
    short piece measured on its own has the one or two columns that cross it, whose alpha
    shape has no area: the end of a partition where it meets a slanted wall (two 15 cm
    pieces, a column of points on each) read unseen, the ceiling's alpha shape bridged the
    wall there, and the rooms either side were one (syn_house, terrestrial at 100k points,
    seed 21). A piece without points breaks the chain: a doorway up to the ceiling, or the
    line running on past its wall."""
    out = np.zeros(len(cells.faces), dtype=bool)
    if tree is None:
        return out
    chains = []
    for run in _collinear_runs(cells.faces):
        ok = seen[run] | touched[run]
        for a, b in zip(*_true_runs(ok)):
            if b - a > 1 and seen[run[a:b]].any() and not seen[run[a:b]].all():
                chains.append(run[a:b])
    for run in chains:
        ang = _face_line(cells.faces[run[0]])[0]
        d = np.array([math.cos(ang), math.sin(ang)])
        tz, boxes = [], []
        for fi in run:
            f = cells.faces[fi]
            _, _, t0, t1 = _face_line(f)
            z0, z1 = _face_band(f, zr, ceiling_z, params.wall_band)
            boxes.append((t0, t1, z0, z1, params.min_wall_coverage * (t1 - t0) * (z1 - z0)))
            p, q = _straight(f)
            t, z = _near_segment(vw, tree, p, q, z0, z1, params.shape_buffer)
            tz.append(np.column_stack([p @ d + np.sign((q - p) @ d) * t, z]))  # along d
        pts = np.vstack(tz) if tz else np.zeros((0, 2))
        if len(pts) < 3:
            continue
        # across the pieces' ends, each piece's share of it; the plain r_α (not the one the
        # sparse ceiling's spacing widens) spans the gap between scan columns, not between two
        # walls crossing the line a room apart (hexagon_hall, terrestrial seed 7: a 0.9 m
        # stretch of a line through a side room's corner, one wall at each end, closed the
        # ceiling there)
        tri = alpha_triangles(pts, min(r_alpha, params.r_alpha))
        for fi, (t0, t1, z0, z1, nd) in zip(run, boxes):
            # only a piece shorter than an alpha disc: a longer one holds its own columns, and
            # a wall crossing the line at a shallow angle leaves points near it over a stretch
            # (syn_house mobile seed 19: 0.4 m of a slanted wall by a line's 2.5 m piece)
            out[fi] = t1 - t0 <= 2 * params.r_alpha and clipped_area(tri, ((t0, z0), (t1, z1))) >= nd
    return out


def measure_coverage(cells: CellSet, xyz_wall: np.ndarray, xyz_horizontal: np.ndarray,
                     params: CoverageParams = CoverageParams(), *, should_check=None,
                     xyz_level=None) -> CellCoverage:
    """Measure the per-cell and per-face coverage once (see the module doc).

    Parameters
    ----------
    cells : CellSet
    xyz_wall : (n, 3) float64 — wall ("vertical") points, metres.
    xyz_horizontal : (m, 3) float64 — floor/ceiling points, metres.
    params : CoverageParams — δ (``shape_buffer``: points within δ of a face belong to it);
        r_α; the thinning grid (``coverage_grid``, also the voxel of the inside-area
        estimate); ``min_wall_coverage`` (a face covered this much is a seen wall that no
        ceiling alpha triangle may cross, so the ceiling never bridges a wall); ``wall_band``
        (wall coverage is measured in this band under the ceiling over the face: walls reach
        the ceiling, furniture rarely does; <= 0: the whole face); ``alpha_spacing_factor`` and
        ``r_alpha_max`` (the ceiling's alpha shape follows the local spacing of the ceiling
        points, :func:`local_alpha`, up to ``r_alpha_max``).
    should_check : optional callable polled between faces (cancellation).
    xyz_level : (k, 3) float64 — more ceiling points, metres (at a ceiling level but with a
        normal too tilted to tell, :attr:`CoverageParams.ceiling_by_level`), or None. They
        join the ceiling's alpha shape with the bound of the nearest ceiling point: points
        filling in a scan line would halve the spacing along it, not across it, and so
        shrink the bounds where the scan lines are far apart.

    Returns
    -------
    CellCoverage
    """
    import shapely
    from scipy.spatial import cKDTree

    shape_buffer, r_alpha, thin = params.shape_buffer, params.r_alpha, params.coverage_grid
    min_wall_coverage, wall_band = params.min_wall_coverage, params.wall_band
    alpha_spacing_factor, r_alpha_max = params.alpha_spacing_factor, params.r_alpha_max
    n = len(cells)
    area = cells.areas
    zr = cells.z_range
    hw = np.asarray(xyz_horizontal, dtype=np.float64).reshape(-1, 3)
    vw = np.asarray(xyz_wall, dtype=np.float64).reshape(-1, 3)
    hw = thin_points(hw, thin)
    vw = thin_points(vw, thin)
    r_alpha = adaptive_alpha(hw[:, :2], r_alpha, alpha_spacing_factor)

    # --- ceilings and floors: which cell holds each horizontal point
    hc, upper, ceiling_z, floor_z = cell_heights(cells, hw)

    # --- faces: wall points within δ of the face's footprint segment
    face = np.zeros(len(cells.faces))
    touched = np.zeros(len(cells.faces), dtype=bool)  # wall points within δ of the face, in its band
    tree = cKDTree(vw[:, :2]) if len(vw) else None
    for fi, f in enumerate(cells.faces):
        if should_check is not None and fi % 64 == 0:
            should_check()
        if tree is None:
            break
        z0, z1 = _face_band(f, zr, ceiling_z, wall_band)
        tot = 0.0
        for p, q in f.segments:
            t, z = _near_segment(vw, tree, p, q, z0, z1, shape_buffer)
            touched[fi] |= bool(len(t))
            if len(t) < 3:
                continue
            L = float(np.linalg.norm(q - p))
            tz = np.column_stack([t, z])
            tot += alpha_area(tz, r_alpha, clip=((0.0, z0), (L, z1)))
        face[fi] = tot
    total_v = float(face.sum())

    # faces seen as walls block the ceiling's alpha shape: no triangle may bridge a wall
    need = np.array([min_wall_coverage * f.length * np.diff(_face_band(f, zr, ceiling_z, wall_band))[0]
                     for f in cells.faces])
    seen = np.flatnonzero((face >= need) | _run_seen(cells, vw, tree, face >= need, touched, zr, ceiling_z,
                                                      params, r_alpha)).tolist()
    blockers = [s for fi in seen for s in cells.faces[fi].segments]
    seen_mask = np.zeros(len(cells.faces), dtype=bool)
    seen_mask[seen] = True
    ceil = thin_points(hw[upper][:, :2], thin)
    bounds = None
    if xyz_level is not None and len(xyz_level):
        extra = thin_points(np.asarray(xyz_level, dtype=np.float64).reshape(-1, 3)[:, :2], thin)
        bounds = np.full(len(ceil) + len(extra), float(r_alpha))
        if len(ceil) and r_alpha_max > r_alpha:
            bounds[:len(ceil)] = local_alpha(ceil, r_alpha, alpha_spacing_factor, r_alpha_max)
            bounds[len(ceil):] = bounds[:len(ceil)][cKDTree(ceil).query(extra)[1]]
        ceil = np.vstack([ceil, extra])
    geom = alpha_geometry(ceil, r_alpha, blockers=blockers, snap=shape_buffer,
                          local_factor=alpha_spacing_factor, r_max=r_alpha_max, bounds=bounds)
    total_h = float(geom.area)
    if geom.is_empty:
        top = np.zeros(n)
    else:
        shapely.prepare(geom)
        top = shapely.area(shapely.intersection(geom, np.array(cells.polygons, dtype=object)))
    # --- points strictly inside cells: voxel-occupancy area
    inside = np.zeros(n)
    allp = np.vstack([vw, hw]) if len(vw) + len(hw) else np.zeros((0, 3))
    if len(allp):
        shrunk = shapely.buffer(np.array(cells.polygons, dtype=object), -shape_buffer, join_style="mitre")
        valid = [i for i, s in enumerate(shrunk) if not s.is_empty]
        if valid:
            ci = _points_in_cells([shrunk[i] for i in valid], allp[:, :2])
            m = ci >= 0
            cell_of = np.full(len(allp), -1, dtype=np.int64)
            cell_of[m] = np.asarray(valid)[ci[m]]
            m &= (allp[:, 2] > zr[np.maximum(cell_of, 0), 0] + shape_buffer) & \
                 (allp[:, 2] < zr[np.maximum(cell_of, 0), 1] - shape_buffer)
            if m.any():
                keys = np.floor(allp[m] / thin).astype(np.int64)
                vox = np.unique(np.column_stack([cell_of[m], keys]), axis=0)
                inside = np.bincount(vox[:, 0], minlength=n).astype(np.float64) * thin * thin
    return CellCoverage(area=np.asarray(area, float), top=np.asarray(top, float), inside=inside,
                        face=face, total_horizontal=total_h, total_vertical=total_v,
                        ceiling_z=ceiling_z, floor_z=floor_z, seen=seen_mask)
