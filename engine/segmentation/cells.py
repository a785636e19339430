"""Cell decomposition: wall lines → 2D arrangement → 3D cells with adjacency (SPEC.md §3.1).

Method (per storey)
-------------------
1. *Wall lines.* Every wall plane of the storey with at least ``min_wall_area`` of support
   spanning at least ``min_wall_height_fraction`` of the storey height and reaching within
   ``max_top_gap`` of a ceiling (:func:`is_structural_wall`; furniture sides and tall
   shelves fail) is intersected with the floor: a 2D segment, the extent of its supporting points
   along the wall line.
2. *Extension, only as far as needed.* Segments are **not** extended to infinite lines
   (that multiplies the cells: n walls give O(n²) faces). Each end of a segment is
   extended along its line, at most ``max_extension``, to the **first** other wall line
   it meets whose segment passes within ``max_extension`` of the meeting point (two walls
   that both stop short of their common corner meet), and from there on through the
   following wall *segments* it crosses as long as each is within ``chain_gap`` of the
   previous one — the two faces of a wall, or a shelf face reaching the ceiling in front
   of an occluded corner, do not stop the wall short of the corner. This closes corners
   and T-junctions left open by occlusion and by door openings at wall ends. The end goes
   ``snap_overshoot`` past the last crossing so noding sees it. An end that meets no line
   within ``max_extension`` goes on (``far_extension``) to the first wall *segment* its
   ray crosses at any distance — a wall seen only in a short piece behind furniture still
   closes its room; otherwise it stays where the data put it: a dangling edge, which
   polygonize drops, so it makes no cell. Door openings in the middle of a wall are inside its segment (the segment spans
   the support's min..max), so rooms stay closed.
3. *Arrangement.* The segments and the building's extent (the x, y box of the storey's
   points grown by ``extent_margin``) are noded (``shapely.unary_union``) and polygonized
   (``shapely.ops.polygonize``); faces smaller than ``min_cell_area`` are merged into the
   neighbour they share the longest edge with.
4. *Extrusion.* The z levels of a storey are its floor and every ceiling height found
   among the horizontal planes (:func:`ceiling_levels`: planes at least
   ``min_ceiling_height`` above the floor with ``min_ceiling_area``, within 0.1 m merged) — rooms of
   different ceiling heights get cells of matching heights. Each 2D face is extruded
   between consecutive levels: one 3D cell per (face, layer).
5. *Adjacency.* Two cells of one layer sharing an edge longer than ``min_face_length`` are
   adjacent through a vertical face (segments + z range); a cell and the cell above it
   (same face, next layer) through a horizontal face. For a vertical face the wall plane
   lying on it (within ``wall_match_distance`` and ``wall_match_angle``) is recorded, with
   the share of the face covered by that plane's points (10 cm bins in length × height).
   Each cell also gets the coverage of its top and bottom by horizontal points — the
   ``Cov(top)`` the rjMCMC likelihood needs (SPEC.md §3.3), on a 10 cm grid rather than an
   alpha shape (documented departure: faster, same meaning at that resolution).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..errors import ReconstructionError
from ..model import Polyhedron, Shape, ShapeType, Storey
from ..pointcloud import PointCloud
from ..progress import Progress
from .params import CellParams
from .planes import Plane

__all__ = ["Cell", "CellFace", "CellComplex", "decompose_cells", "wall_segments", "is_structural_wall",
           "ceiling_levels"]

log = logging.getLogger(__name__)

_LEVEL_MERGE = 0.1
"""Ceiling heights closer than this (metres) are one z level."""
_GRID = 0.1
"""Grid cell (metres) of the coverage measures."""
_PARALLEL_EPS = 1e-9
"""|cross product| below this: two wall lines are parallel and never meet."""


@dataclass(frozen=True, eq=False)
class Cell:
    """A 3D cell: a vertical prism over a 2D face of the arrangement.

    Attributes
    ----------
    id : int
        Index in ``CellComplex.cells``.
    storey : int
        Storey index.
    face : int
        Index of its 2D face within the storey (cells stacked over one face share it).
    layer : int
        0 for the lowest z layer of the storey.
    polygon : (k, 2) float64
        Footprint, counter-clockwise, not closed, metres.
    z0, z1 : float
        Bottom and top heights, metres.
    area : float
        Footprint area, m².
    top_coverage, bottom_coverage : float
        Share (0–1) of the footprint's 10 cm grid cells that hold horizontal points within
        the storey's plane band of ``z1`` / ``z0`` — Cov(top)/|top| of SPEC.md §3.3.
    """

    id: int
    storey: int
    face: int
    layer: int
    polygon: np.ndarray
    z0: float
    z1: float
    area: float
    top_coverage: float = 0.0
    bottom_coverage: float = 0.0

    def polyhedron(self) -> Polyhedron:
        """The cell as :meth:`engine.model.Polyhedron.prism`."""
        return Polyhedron.prism(self.polygon, self.z0, self.z1)

    def shape(self, type=ShapeType.NONE, *, prefix: str = "cell", **changes) -> Shape:
        """An :class:`engine.model.Shape` of this cell (id ``f"{prefix}{id}"``) with the
        cell's figures in ``support`` and its storey/face/layer in ``attributes``."""
        kw = dict(id=f"{prefix}{self.id}", type=type, geometry=self.polyhedron(), storey=self.storey,
                  name=f"Cell {self.id}",
                  support={"top_coverage": self.top_coverage, "bottom_coverage": self.bottom_coverage},
                  attributes={"cell": self.id, "face": self.face, "layer": self.layer})
        kw.update(changes)
        return Shape(**kw)


@dataclass(frozen=True, eq=False)
class CellFace:
    """The face shared by two adjacent cells.

    Attributes
    ----------
    a, b : int
        Cell ids, ``a < b``.
    kind : str
        "vertical" (side by side in one layer) or "horizontal" (``b`` above ``a``).
    segments : (k, 2, 2) float64
        Vertical faces: the shared 2D edge(s) of the footprints, metres (usually k = 1).
        Horizontal faces: empty (0, 2, 2).
    polygon : (m, 2) float64 or None
        Horizontal faces: the shared footprint; None for vertical faces.
    z0, z1 : float
        z range of a vertical face; ``z0 == z1`` = the height of a horizontal face.
    length : float
        Total length of the segments (vertical) or area (horizontal), metres / m².
    wall_plane : int or None
        Id of the detected plane lying on the face (a wall plane for vertical faces — the
        one on the longest segment —, a horizontal plane for horizontal ones), None when no
        detected surface lies there — the rjMCMC's "no surface on the common face"
        (connectivity before merging).
    coverage : float
        Share (0–1) of the whole face covered by the points of the planes lying on it
        (length-weighted over the segments; 0 when no plane lies on it).
    segment_planes : tuple of (int or None)
        Vertical faces: the wall plane on each segment.
    segment_coverage : tuple of float
        Vertical faces: the coverage of each segment's rectangle by its wall plane's points.
    """

    a: int
    b: int
    kind: str
    segments: np.ndarray
    polygon: Optional[np.ndarray]
    z0: float
    z1: float
    length: float
    wall_plane: Optional[int] = None
    coverage: float = 0.0
    segment_planes: tuple = ()
    segment_coverage: tuple = ()


@dataclass(frozen=True, eq=False)
class CellComplex:
    """The space partition the rjMCMC searches (SPEC.md §3.3).

    Attributes
    ----------
    cells : tuple of Cell
    faces : tuple of CellFace
        Every adjacency, once (``a < b``).
    planes : tuple of Plane
        The planes the decomposition used (ids as in :func:`extract_planes`).
    storeys : tuple of Storey
    extents : dict int -> (4,) float64
        Per storey, the building's extent box (xmin, ymin, xmax, ymax), metres.
    segments : dict int -> (s, 2, 2) float64
        Per storey, the extended wall segments that made the arrangement, metres.
    segment_planes : dict int -> (s,) int64
        Per storey, the plane id of each segment.
    """

    cells: tuple
    faces: tuple
    planes: tuple
    storeys: tuple
    extents: dict = field(default_factory=dict)
    segments: dict = field(default_factory=dict)
    segment_planes: dict = field(default_factory=dict)

    def __post_init__(self):
        nb: dict[int, list[int]] = {c.id: [] for c in self.cells}
        index = {}
        for k, f in enumerate(self.faces):
            nb[f.a].append(f.b)
            nb[f.b].append(f.a)
            index[(f.a, f.b)] = k
        object.__setattr__(self, "_nb", nb)
        object.__setattr__(self, "_face_index", index)

    def __len__(self) -> int:
        return len(self.cells)

    def neighbours(self, cell_id: int, kind: Optional[str] = None) -> list[int]:
        """Ids of the cells adjacent to ``cell_id`` (optionally only through faces of ``kind``)."""
        out = self._nb[cell_id]
        if kind is None:
            return list(out)
        return [o for o in out if self.face_between(cell_id, o).kind == kind]

    def face_between(self, a: int, b: int) -> Optional[CellFace]:
        """The shared face of two cells, None when they are not adjacent."""
        k = self._face_index.get((min(a, b), max(a, b)))
        return None if k is None else self.faces[k]

    def cells_of_storey(self, storey: int) -> list[Cell]:
        return [c for c in self.cells if c.storey == storey]

    def graph(self):
        """A networkx Graph: nodes are cell ids (attribute ``cell``), edges carry ``face``."""
        import networkx as nx

        g = nx.Graph()
        for c in self.cells:
            g.add_node(c.id, cell=c)
        for f in self.faces:
            g.add_edge(f.a, f.b, face=f)
        return g

    def shapes(self, prefix: str = "cell") -> list[Shape]:
        """Every cell as an untyped (``ShapeType.NONE``) :class:`Shape`."""
        return [c.shape(prefix=prefix) for c in self.cells]

    def summary(self) -> dict:
        return {"cells": len(self.cells), "faces": len(self.faces),
                "faces_with_wall": sum(f.wall_plane is not None and f.kind == "vertical" for f in self.faces),
                "storeys": len(self.storeys), "planes": len(self.planes)}


# ----------------------------------------------------------------------------- helpers
def ceiling_levels(planes: Sequence[Plane], storey: Storey, params: CellParams = CellParams()) -> list:
    """Ceiling heights of a storey, ascending (metres): ``storey.ceiling_z`` and every
    horizontal plane of the storey at least ``min_ceiling_height`` above the floor, at most
    ``ceiling_margin`` above the storey ceiling, with ``min_ceiling_area``; heights closer
    than 0.1 m are one level."""
    zs = sorted([storey.ceiling_z] + [
        pl.offset for pl in planes
        if pl.kind == "horizontal" and pl.storey in (storey.index, -1)
        and storey.floor_z + params.min_ceiling_height <= pl.offset <= storey.ceiling_z + params.ceiling_margin
        and pl.area >= params.min_ceiling_area])
    levels = []
    for z in zs:
        if levels and z - levels[-1] < _LEVEL_MERGE:
            if z == storey.ceiling_z:
                levels[-1] = z
            continue
        levels.append(z)
    return levels


def is_structural_wall(pl: Plane, storey: Storey, params: CellParams = CellParams(),
                       levels: Optional[Sequence[float]] = None) -> bool:
    """True when a wall plane is cut into the storey's floor: at least ``min_wall_area`` of
    support reaching within ``max_top_gap`` of one of the ceiling ``levels`` and spanning
    ``min_wall_height_fraction`` of that ceiling's height above the floor (default: ``storey.ceiling_z``; pass
    :func:`ceiling_levels` for rooms of several heights). Furniture fails one of these."""
    if pl.kind != "wall" or pl.storey not in (storey.index, -1):
        return False
    levels = [storey.ceiling_z] if levels is None else levels
    if pl.area < params.min_wall_area:
        return False
    for z in levels:  # a ceiling the wall reaches, and a wall spanning enough of its height
        if pl.z_range[1] >= z - params.max_top_gap:
            span = min(pl.z_range[1], z) - max(pl.z_range[0], storey.floor_z)
            if span >= params.min_wall_height_fraction * max(z - storey.floor_z, 1e-9):
                return True
    return False


def wall_segments(walls: Sequence[Plane], params: CellParams = CellParams()) -> np.ndarray:
    """Extend each wall's segment to the first wall line it meets (see module doc).

    Parameters
    ----------
    walls : sequence of Plane (kind "wall")

    Returns
    -------
    (s, 2, 2) float64 — extended segments, metres, in the order of ``walls``.
    """
    segs = np.array([w.segment for w in walls], dtype=np.float64).reshape(-1, 2, 2)
    dirs = np.array([w.direction for w in walls]).reshape(-1, 2)
    todo = [(i, end) for i in range(len(walls)) for end in (0, 1)]
    out, left = _extend_pass(segs, segs, dirs, todo, params)
    # ends still dangling look again, now at the extended segments (two walls whose
    # corner only one of them reached in the first pass)
    out, _ = _extend_pass(out, out, dirs, left, params)
    return out


def _extend_pass(segs, targets, dirs, todo, params: CellParams):
    """Extend the ends ``todo`` ((segment, 0|1) pairs) of ``segs`` against the segments
    ``targets``; returns (new segments, ends that met nothing)."""
    out = segs.copy()
    m = len(segs)
    left = []
    for i, end in todo:
        p = segs[i, end]
        d = dirs[i]
        other = segs[i, 1 - end]
        if np.dot(p - other, d) < 0:  # make d point outwards of the segment
            d = -d
        hits = []  # (distance along the ray, crosses the other segment proper?)
        far = None  # nearest crossing of another segment beyond max_extension
        for j in range(m):
            if j == i:
                continue
            q0, q1 = targets[j]
            e = q1 - q0
            denom = d[0] * e[1] - d[1] * e[0]
            if abs(denom) < _PARALLEL_EPS:
                continue
            w = q0 - p
            s = (w[0] * e[1] - w[1] * e[0]) / denom  # along the ray
            t = (w[0] * d[1] - w[1] * d[0]) / denom  # along the other segment, 0..1
            ln = np.linalg.norm(e)
            if s > params.max_extension:
                tol = params.far_tolerance / max(ln, 1e-9)
                if -tol <= t <= 1 + tol and (far is None or s < far):
                    far = s
                continue
            if s < -params.snap_overshoot:
                continue  # behind the end: the segment already crosses that line
            if t < -params.max_extension / max(ln, 1e-9) or t > 1 + params.max_extension / max(ln, 1e-9):
                continue
            inside = params.snap_overshoot / max(ln, 1e-9)
            hits.append((s, -inside <= t <= 1 + inside))
        best = None
        if hits:
            hits.sort()
            best = hits[0][0]
            for s_next, proper in hits[1:]:  # go on through a chain of close walls
                if not proper or s_next - best > params.chain_gap:
                    break
                best = s_next
        if best is None and far is not None and params.far_extension:
            best = far
        if best is not None:
            out[i, end] = p + (best + params.snap_overshoot) * d
        else:
            left.append((i, end))
    return out, left


def _grid_occupancy(xy: np.ndarray, origin: np.ndarray, dims):
    occ = np.zeros(int(dims[0] * dims[1]), bool)
    if len(xy):
        q = np.floor((xy - origin) / _GRID).astype(np.int64)
        ok = (q[:, 0] >= 0) & (q[:, 1] >= 0) & (q[:, 0] < dims[0]) & (q[:, 1] < dims[1])
        occ[q[ok, 0] * dims[1] + q[ok, 1]] = True
    return occ


def _poly_coverage(poly, occ, origin, dims) -> float:
    import shapely

    x0, y0, x1, y1 = poly.bounds
    i0 = max(int(np.floor((x0 - origin[0]) / _GRID)), 0)
    i1 = min(int(np.ceil((x1 - origin[0]) / _GRID)), int(dims[0]))
    j0 = max(int(np.floor((y0 - origin[1]) / _GRID)), 0)
    j1 = min(int(np.ceil((y1 - origin[1]) / _GRID)), int(dims[1]))
    if i1 <= i0 or j1 <= j0:
        return 0.0
    ii, jj = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1), indexing="ij")
    cx = origin[0] + (ii.ravel() + 0.5) * _GRID
    cy = origin[1] + (jj.ravel() + 0.5) * _GRID
    inside = shapely.contains_xy(poly, cx, cy)
    if not inside.any():
        return 0.0
    return float(occ[(ii.ravel() * dims[1] + jj.ravel())[inside]].mean())


def _merge_slivers(polys: list, min_area: float) -> list:
    import shapely

    polys = list(polys)
    changed = True
    while changed:
        changed = False
        small = [k for k, p in enumerate(polys) if p.area < min_area]
        for k in small:
            best, best_len = None, 0.0
            for j, q in enumerate(polys):
                if j == k:
                    continue
                shared = polys[k].boundary.intersection(q.boundary).length
                if shared > best_len:
                    best, best_len = j, shared
            if best is not None:
                polys[best] = shapely.union(polys[best], polys[k]).buffer(0)
                del polys[k]
                changed = True
                break
    return polys


def _split_holes(polys: list) -> list:
    """Cut faces with holes (the ring around a closed building) along a vertical line
    through each hole, so every cell is a simple polygon (a prism footprint)."""
    from shapely.geometry import LineString
    from shapely.ops import split

    out, todo = [], list(polys)
    while todo:
        g = todo.pop()
        if g.geom_type == "MultiPolygon":
            todo.extend(g.geoms)
            continue
        if not g.interiors:
            out.append(g)
            continue
        hx = np.asarray(g.interiors[0].coords)[:, 0]
        x = 0.5 * (hx.min() + hx.max())
        y0, y1 = g.bounds[1] - 1.0, g.bounds[3] + 1.0
        parts = split(g, LineString([(x, y0), (x, y1)]))
        todo.extend(pp for pp in parts.geoms if pp.area > 0)
    return out


def _segments_of(geom) -> np.ndarray:
    """(k, 2, 2) segments of a (multi)line geometry, consecutive collinear pieces joined."""
    from shapely.ops import linemerge

    if geom.is_empty:
        return np.zeros((0, 2, 2))
    lines = [g for g in getattr(geom, "geoms", [geom]) if g.geom_type in ("LineString", "MultiLineString")]
    if not lines:
        return np.zeros((0, 2, 2))
    merged = linemerge(lines) if len(lines) > 1 else lines[0]
    out = []
    for ln in getattr(merged, "geoms", [merged]):
        c = np.asarray(ln.coords)
        # a polyline along one straight wall: keep its end points; otherwise each piece
        for a, b in zip(c[:-1], c[1:]):
            out.append((a, b))
    segs = np.array(out, dtype=np.float64).reshape(-1, 2, 2)
    return _join_collinear(segs)


def _join_collinear(segs: np.ndarray) -> np.ndarray:
    if len(segs) <= 1:
        return segs
    out = [segs[0]]
    for s in segs[1:]:
        a, b = out[-1]
        d1, d2 = b - a, s[1] - s[0]
        cross = abs(d1[0] * d2[1] - d1[1] * d2[0])
        if np.allclose(b, s[0]) and cross <= 1e-9 * np.linalg.norm(d1) * np.linalg.norm(d2) and np.dot(d1, d2) > 0:
            out[-1] = np.array([a, s[1]])
        else:
            out.append(s)
    return np.array(out)


def _face_walls(seg_list: np.ndarray, z0, z1, walls: Sequence[Plane], xyz, params: CellParams):
    """For each segment of a vertical face: the wall plane lying on it and the share of the
    segment × [z0, z1] rectangle its points cover (None, 0.0 when no wall lies there)."""
    cos_a = np.cos(params.wall_match_angle)
    nz = max(int(np.ceil((z1 - z0) / params.coverage_bin)), 1)
    ids, covs = [], []
    for s in seg_list:
        L = float(np.linalg.norm(s[1] - s[0]))
        best, best_cov = None, 0.0
        if L > 0:
            u = (s[1] - s[0]) / L
            nt = max(int(np.ceil(L / params.coverage_bin)), 1)
            for w in walls:
                if abs(np.dot(w.direction, u)) < cos_a:
                    continue
                if np.max(np.abs(s @ w.normal[:2] - w.offset)) > params.wall_match_distance:
                    continue
                pts = xyz[w.support]
                t = (pts[:, :2] - s[0]) @ u
                ok = (t >= 0) & (t < L) & (pts[:, 2] >= z0) & (pts[:, 2] <= z1)
                ti = np.minimum((t[ok] / params.coverage_bin).astype(np.int64), nt - 1)
                zi = np.minimum(((pts[ok, 2] - z0) / params.coverage_bin).astype(np.int64), nz - 1)
                cov = len(np.unique(ti * nz + zi)) / (nt * nz)
                if best is None or cov > best_cov:
                    best, best_cov = w.id, float(cov)
        ids.append(best)
        covs.append(best_cov)
    return tuple(ids), tuple(covs)


def decompose_cells(cloud: PointCloud, planes: Sequence[Plane], storeys: Sequence[Storey],
                    params: CellParams = CellParams(), *, labels: Optional[np.ndarray] = None,
                    progress=None, should_stop=None) -> CellComplex:
    """The 3D cell complex of every storey (see module doc).

    Parameters
    ----------
    cloud : PointCloud
        The aligned working cloud the planes were extracted from (their ``support`` indexes
        it), metres.
    planes : sequence of Plane
        From :func:`extract_planes` (with ``storeys``, so each plane has its storey).
    storeys : sequence of Storey
        From :func:`detect_storeys`.
    params : CellParams
    labels : (n,) int8, optional
        Point clusters; horizontal points (for the top/bottom coverage) are taken from the
        horizontal planes' supports when None.

    Returns
    -------
    CellComplex

    Raises
    ------
    ReconstructionError
        A storey has no usable wall plane, or its arrangement has no face.
    """
    import shapely
    from shapely.geometry import LineString, MultiLineString, box
    from shapely.ops import polygonize

    p = Progress.wrap(progress, should_stop)
    name = cloud.source or "point cloud"
    xyz = cloud.xyz
    cells, faces = [], []
    extents, segments, seg_planes = {}, {}, {}
    for si, st in enumerate(storeys):
        p(si / max(len(storeys), 1), f"cells of storey {st.index}")
        idx = st.index
        sp = [pl for pl in planes if pl.storey in (idx, -1)]
        ceilings = ceiling_levels(sp, st, params)
        walls = [pl for pl in sp if is_structural_wall(pl, st, params, ceilings)]
        if not walls:
            raise ReconstructionError(f"{name}: storey {idx} has no wall plane to partition its floor")
        zin = (xyz[:, 2] >= st.floor_z - _LEVEL_MERGE) & (xyz[:, 2] <= st.ceiling_z + _LEVEL_MERGE)
        if not zin.any():
            raise ReconstructionError(f"{name}: storey {idx} holds no points")
        lo = xyz[zin, :2].min(axis=0) - params.extent_margin
        hi = xyz[zin, :2].max(axis=0) + params.extent_margin
        ext = box(lo[0], lo[1], hi[0], hi[1])
        extents[idx] = np.array([lo[0], lo[1], hi[0], hi[1]])
        segs = wall_segments(walls, params)
        segments[idx] = segs
        seg_planes[idx] = np.array([w.id for w in walls], np.int64)
        lines = [LineString(s) for s in segs] + [ext.exterior]
        noded = shapely.unary_union(MultiLineString([np.asarray(g.coords) for g in lines]))
        noded = noded.intersection(ext.buffer(1e-9))
        polys = [g for g in polygonize(noded) if g.area > 0]
        polys = _split_holes(_merge_slivers(polys, params.min_cell_area))
        if not polys:
            raise ReconstructionError(f"{name}: the wall lines of storey {idx} enclose no cell")
        hor = [pl for pl in sp if pl.kind == "horizontal"]
        levels = [st.floor_z] + ceilings
        # coverage grids of horizontal points per level
        origin = lo
        dims = (int(np.ceil((hi[0] - lo[0]) / _GRID)) + 1, int(np.ceil((hi[1] - lo[1]) / _GRID)) + 1)
        occ_at = {}
        for z in levels:
            near = [pl for pl in hor if abs(pl.offset - z) <= max(pl.band, _LEVEL_MERGE / 2)]
            sup = np.concatenate([pl.support for pl in near]) if near else np.zeros(0, np.int64)
            occ_at[z] = _grid_occupancy(xyz[sup, :2], origin, dims)
        base = len(cells)
        nf = len(polys)
        for k in range(len(levels) - 1):
            z0, z1 = levels[k], levels[k + 1]
            for f, poly in enumerate(polys):
                poly = shapely.geometry.polygon.orient(poly, 1.0)
                coords = np.asarray(poly.exterior.coords)[:-1]
                cells.append(Cell(id=len(cells), storey=idx, face=f, layer=k, polygon=coords, z0=float(z0),
                                  z1=float(z1), area=float(poly.area),
                                  top_coverage=_poly_coverage(poly, occ_at[z1], origin, dims),
                                  bottom_coverage=_poly_coverage(poly, occ_at[z0], origin, dims)))
        # adjacency in the plane
        tree = shapely.STRtree(polys)
        pairs = tree.query(polys, predicate="intersects")
        p.check()
        for f, g in zip(*pairs):
            if f >= g:
                continue
            shared = polys[f].boundary.intersection(polys[g].boundary)
            if shared.length < params.min_face_length:
                continue
            seg_list = _segments_of(shared)
            if len(seg_list) == 0:
                continue
            for k in range(len(levels) - 1):
                z0, z1 = levels[k], levels[k + 1]
                ids, covs = _face_walls(seg_list, z0, z1, walls, xyz, params)
                lens = np.linalg.norm(seg_list[:, 1] - seg_list[:, 0], axis=1)
                main = int(np.argmax(lens))
                a, b = base + k * nf + f, base + k * nf + g
                faces.append(CellFace(a=a, b=b, kind="vertical", segments=seg_list, polygon=None,
                                      z0=float(z0), z1=float(z1), length=float(lens.sum()),
                                      wall_plane=ids[main], coverage=float(np.dot(lens, covs) / lens.sum()),
                                      segment_planes=ids, segment_coverage=covs))
        # stacked cells
        for k in range(1, len(levels) - 1):
            z = levels[k]
            near = [pl for pl in hor if abs(pl.offset - z) <= max(pl.band, _LEVEL_MERGE / 2)]
            for f, poly in enumerate(polys):
                a, b = base + (k - 1) * nf + f, base + k * nf + f
                cov = cells[a].top_coverage
                faces.append(CellFace(a=a, b=b, kind="horizontal", segments=np.zeros((0, 2, 2)),
                                      polygon=cells[a].polygon, z0=float(z), z1=float(z),
                                      length=float(poly.area),
                                      wall_plane=(max(near, key=lambda pl: pl.area).id if near and cov > 0 else None),
                                      coverage=cov))
        log.info("%s: storey %d: %d walls -> %d faces x %d layers", name, idx, len(walls), nf, len(levels) - 1)
    p(1.0, f"{len(cells)} cells")
    return CellComplex(cells=tuple(cells), faces=tuple(faces), planes=tuple(planes), storeys=tuple(storeys),
                       extents=extents, segments=segments, segment_planes=seg_planes)
