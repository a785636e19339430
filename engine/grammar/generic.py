"""The generic (non-Manhattan) method: cells + rjMCMC (docs/method.md §3, thesis Ch. 4).

:func:`generic_model` runs on the shared preprocessing (:func:`engine.pipeline.preprocess`:
working cloud, normals, clusters, storeys, wall planes; the cloud is levelled, not rotated:
walls may run in any direction), then per storey:

1. **place**: the wall planes' lines cut the storey's extent into 2-D cells
   (:func:`arrange_cells`), extruded between floor and ceiling (:func:`storey_cells`);
2. the coverage of every cell and face, measured once (:mod:`.coverage`);
3. the rjMCMC search for the interior spaces (:mod:`.rjmcmc`): the rules **merge**,
   **split**, **classify**, **declassify** are its moves;
4. walls and exterior (docs/method.md §3.4): an untyped cell next to a space whose vertices
   all lie within the maximum wall thickness of the shared face's line is a **wall**; the
   other cells are **exterior**;
5. adjacency / connectivity (:func:`.rules.derive_topology`).

Every space is a vertical prism over the union of its cells, from the median height of the
floor points to the median height of the ceiling points over it. Cells stay in the model as
inactive children of their space or wall (``attributes["cell"] = True``).
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, dataclass, field
from typing import Optional

import numpy as np
import shapely
from shapely.ops import polygonize

from ..errors import ReconstructionError
from ..model import BuildingModel, Polyhedron, Provenance, Shape, ShapeType, Storey
from ..pipeline import Prepared, preprocess
from ..pointcloud import PointCloud
from ..progress import Progress
from ..segmentation.params import PreprocessParams
from .coverage import CellSet, cellset_from_polygons, measure_coverage
from .levels import over_walls
from .params import CellParams, CoverageParams, GenericParams, ManhattanParams, params_from_data
from .place import Peak, _face_side_and_span, histogram_peaks, paired_faces
from .rjmcmc import SearchResult, search_spaces
from .rules import derive_topology

__all__ = ["GenericParams", "generic_model", "reconstruct_generic", "arrange_cells", "wall_lines",
           "storey_cells", "build_storey_shapes", "StoreyCells"]

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- cells
def wall_lines(planes, storey: int, params: CellParams = CellParams()) -> np.ndarray:
    """(k, 3) float64 lines ``(nx, ny, ρ)`` (``nx x + ny y = ρ``, metres) of the wall planes of
    one storey, near-duplicates merged (support-weighted)."""
    rows = []
    for pl in planes:
        if pl.kind != "wall" or (pl.storey not in (storey, -1)) or pl.area < params.min_wall_area:
            continue
        n = np.asarray(pl.normal[:2], float)
        nn = np.linalg.norm(n)
        if nn == 0:
            continue
        n, rho = n / nn, pl.offset / nn
        if n[0] < -1e-12 or (abs(n[0]) <= 1e-12 and n[1] < 0):
            n, rho = -n, -rho
        rows.append((n[0], n[1], rho, float(len(pl.support))))
    rows.sort(key=lambda r: -r[3])
    kept: list = []
    for nx, ny, rho, w in rows:
        for k in kept:
            ang = math.acos(min(1.0, abs(nx * k[0] + ny * k[1])))
            if ang < params.line_merge_angle and abs(rho - k[2] * (1 if nx * k[0] + ny * k[1] > 0 else -1)) \
                    < params.line_merge_distance:
                break
        else:
            kept.append((nx, ny, rho))
    return np.array(kept, dtype=np.float64).reshape(-1, 3)


def _directions(lines: np.ndarray, normals: np.ndarray, params: CellParams, mp: ManhattanParams):
    """Per wall direction of ``lines`` (k, 3): (which lines run along it, (k,) bool; its unit
    normal n, (2,); which points face it, (n,) bool), for directions at least 10 points face."""
    cos_t = math.cos(mp.normal_angle)
    done = np.zeros(len(lines), bool)
    for i in range(len(lines)):
        if done[i]:
            continue
        n = lines[i, :2]
        group = np.abs(lines[:, :2] @ n) >= math.cos(params.line_merge_angle)
        done |= group
        facing = np.abs(normals[:, :2] @ n) >= cos_t
        if int(facing.sum()) >= 10:
            yield group, n, facing


def second_faces(lines: np.ndarray, xyz: np.ndarray, normals: np.ndarray, oriented: bool,
                 params: CellParams = CellParams(), grammar: Optional[ManhattanParams] = None) -> np.ndarray:
    """``lines`` (k, 3) with the second faces of their walls added (docs/method.md §3.1).

    A wall seen strongly from one room and sparsely from the other (a side room the scan
    only passed through) has one plane: the lines give the room no face of its own on that
    side, its cell touches the other room's, and a space is never added next to another
    (the rjMCMC's moves join them), so the room was lost (hexagon_hall mobile at 100k
    points, seeds 8 and 9: a side room with most of its ceiling seen). Along each wall
    direction the storey's points facing it are histogrammed as the Manhattan grammar does
    along x and y, and a weaker surface behind a line is kept on the grammar's terms
    (:func:`.place.paired_faces`: at most a wall's thickness behind it, seen from the other
    side, along the same stretch, no line between). ``xyz`` (n, 3), ``normals`` (n, 3) the
    storey's working points; ``oriented``: the normals face their scanners."""
    if not params.second_faces or not len(lines) or len(xyz) < 10:
        return lines
    mp = params_from_data(xyz, grammar)
    out = [lines]
    for group, n, facing in _directions(lines, normals, params, mp):
        sign = np.where(lines[group, :2] @ n >= 0, 1.0, -1.0)
        pts = xyz[facing]
        t = pts[:, :2] @ n
        uv = np.column_stack([pts[:, :2] @ np.array([-n[1], n[0]]), pts[:, 2]])
        strong = sorted({round(float(r), 4) for r in lines[group, 2] * sign})
        peaks = [Peak(r, mp.min_wall_area) for r in strong]
        weak = histogram_peaks(t, uv, mp, mp.spacing, mp.min_paired_wall_area)
        sides = normals[facing, :2] @ n if oriented else None
        found = paired_faces(peaks, t, uv, sides, mp, mp.spacing, weak)
        new = [pk.position for pk in found if pk.position not in strong]
        if new:
            log.info("second faces behind wall lines (normal %s): %s", np.round(n, 3).tolist(),
                     np.round(new, 3).tolist())
            out.append(np.array([(n[0], n[1], r) for r in new], dtype=np.float64))
    return np.vstack(out)


def clutter_fronts(lines: np.ndarray, xyz: np.ndarray, normals: np.ndarray, oriented: bool,
                   params: CellParams = CellParams(),
                   grammar: Optional[ManhattanParams] = None) -> np.ndarray:
    """``lines`` (k, 3) without the fronts of furniture standing before a wall (docs/method.md §3.1).

    A shelf against a wall has a front plane like a wall's; its line cut the room along the
    whole wall, and where the strip behind it was seen too little (a side room the scan only
    looked into) the strip was left out of the room and its wall got a false door
    (hexagon_hall mobile at 100k points, held-out seeds 12 and 13: a side room 0.42 m
    short). A wall's two faces face away from each other; a line whose points face the same
    way as those of a parallel line at most a wall's thickness behind it, which runs on past
    both its ends and is longer, is no wall but clutter before that one. Oriented normals
    (scanner positions) only: without them the sides are not known."""
    if not params.clutter_fronts or not oriented or len(lines) < 2 or len(xyz) < 10:
        return lines
    mp = params_from_data(xyz, grammar)
    keep = np.ones(len(lines), bool)
    for group, n, facing in _directions(lines, normals, params, mp):
        group = np.flatnonzero(group)
        if len(group) < 2:
            continue
        pts = xyz[facing]
        t, along = pts[:, :2] @ n, pts[:, :2] @ np.array([-n[1], n[0]])
        sides = normals[facing, :2] @ n
        pos = lines[group, 2] * np.where(lines[group, :2] @ n >= 0, 1.0, -1.0)
        info = [_face_side_and_span(t, sides, along, float(r), mp.bin_size) for r in pos]
        for a, (ra, (sa, span_a)) in enumerate(zip(pos, info)):
            if sa == 0 or not span_a:
                continue
            for rb, (sb, span_b) in zip(pos, info):
                d = (rb - ra) * sa  # < 0: behind the face (it faces +sa)
                if sb != sa or len(span_b) < len(span_a) or not (
                        mp.min_interval <= -d <= mp.max_wall_thickness):
                    continue
                if min(span_b) < min(span_a) - 1 and max(span_b) > max(span_a) + 1:
                    keep[group[a]] = False
                    log.info("clutter front at %.3f before the wall at %.3f (normal %s)", ra, rb,
                             np.round(n, 3).tolist())
                    break
    return lines[keep]


def arrange_cells(lines: np.ndarray, extent, params: CellParams = CellParams()) -> list:
    """2-D cells of the arrangement of lines inside a polygonal extent.

    Parameters
    ----------
    lines : (k, 3) float64 — ``(nx, ny, ρ)`` with unit ``(nx, ny)``, metres.
    extent : shapely Polygon — the region to partition (e.g. the storey's box).
    params : CellParams — cells below ``min_cell_area`` or ``min_cell_width`` (``2 × area /
        perimeter``) join the neighbour with the longest shared edge.

    Returns
    -------
    list of shapely Polygon — a partition of ``extent``; one polygon (the extent) when there
    are no lines.
    """
    minx, miny, maxx, maxy = extent.bounds
    R = 2.0 * math.hypot(maxx - minx, maxy - miny) + 1.0
    c = np.array([(minx + maxx) / 2, (miny + maxy) / 2])
    segs = [extent.exterior]
    for nx, ny, rho in np.asarray(lines, float).reshape(-1, 3):
        n = np.array([nx, ny])
        p0 = c + (rho - n @ c) * n
        d = np.array([-ny, nx])
        ln = shapely.LineString([p0 - R * d, p0 + R * d])
        cl = shapely.intersection(ln, extent)
        if not cl.is_empty:
            segs.append(cl)
    noded = shapely.union_all(segs)
    cells = [p for p in polygonize(noded) if p.area > 0 and extent.contains(p.representative_point())]
    return _merge_small(cells, params.min_cell_area, params.min_cell_width)


def _merge_small(cells: list, min_area: float, min_width: float) -> list:
    cells = list(cells)
    changed = True
    while changed and len(cells) > 1:
        changed = False
        areas = np.array([p.area for p in cells])
        widths = 2.0 * areas / np.maximum([p.length for p in cells], 1e-12)
        small = (areas < min_area) | (widths < min_width)
        order = np.argsort(np.where(small, areas, np.inf))
        for i in order:
            if not small[i]:
                break
            best, blen = None, 0.0
            for j, q in enumerate(cells):
                if j == i:
                    continue
                inter = shapely.intersection(cells[i].boundary, q.boundary)
                if inter.length > blen:
                    best, blen = j, inter.length
            if best is None:
                continue
            u = shapely.union_all([cells[best], cells[i]])
            if u.geom_type != "Polygon":
                continue
            cells[best] = shapely.simplify(u, 1e-9)
            cells.pop(i)
            changed = True
            break
    return cells


@dataclass(frozen=True, eq=False)
class StoreyCells:
    """The cells of one storey (``index`` in the preprocessing's storeys, ``lines`` the wall
    lines that cut them), then their coverage and search result (for the model builder)."""

    storey: Storey
    cells: CellSet
    coverage: object = None
    result: Optional[SearchResult] = None
    index: int = 0
    lines: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


# --------------------------------------------------------------------------- model
def _polygon_coords(poly) -> np.ndarray:

    poly = shapely.simplify(shapely.normalize(poly), 1e-7)
    return np.asarray(poly.exterior.coords)[:-1, :2]


def _weighted_median(v: np.ndarray, w: np.ndarray) -> float:
    """Area-weighted median of the cells' heights (a cell under a table does not tilt it)."""
    o = np.argsort(v)
    cw = np.cumsum(w[o])
    return float(v[o][np.searchsorted(cw, cw[-1] / 2)])


def build_storey_shapes(sc: StoreyCells, index: int, max_wall_thickness: float) -> list[Shape]:
    """Shapes of one storey: spaces, walls (docs/method.md §3.4), exterior, and the cells.

    Parameters
    ----------
    sc : StoreyCells
    index : storey index written on the shapes.
    max_wall_thickness : metres.

    Returns
    -------
    list of Shape — active spaces/walls/exterior, inactive cells (children).
    """

    cells, cov, res = sc.cells, sc.coverage, sc.result
    st = sc.storey
    n = len(cells)
    kind = np.full(n, "", dtype=object)
    owner = [None] * n
    shapes = []
    space_of = np.full(n, -1)
    for k, sp in enumerate(res.spaces):
        space_of[list(sp)] = k
    # --- interior spaces
    for k, sp in enumerate(res.spaces):
        sp = list(sp)
        poly = cells.union(sp)
        if poly.geom_type != "Polygon":
            poly = max(poly.geoms, key=lambda g: g.area)
        if len(poly.interiors):
            log.warning("storey %d space %d has a hole (an unselected cell inside); its outline is used",
                        index, k)
            poly = shapely.Polygon(poly.exterior)
        a = cov.area[sp]
        cz, fz = cov.ceiling_z[sp], cov.floor_z[sp]
        okc, okf = np.isfinite(cz), np.isfinite(fz)
        z1 = _weighted_median(cz[okc], a[okc]) if okc.any() else st.ceiling_z
        z0 = _weighted_median(fz[okf], a[okf]) if okf.any() else st.floor_z
        sid = f"s{index}_space{k}"
        top = float(cov.top[sp].sum())
        shapes.append(Shape(
            id=sid, type=ShapeType.INTERIOR, geometry=Polyhedron.prism(_polygon_coords(poly), z0, z1),
            storey=index, terminal=True, children=tuple(f"s{index}_cell{c}" for c in sorted(sp)),
            support={"coverage_top": top / max(float(a.sum()), 1e-12)},
            attributes={"area": float(poly.area), "height": z1 - z0, "floor_z": z0, "ceiling_z": z1,
                        "cells": len(sp), "merged": len(sp) > 1},
            log=(f"rjMCMC: {len(sp)} cell(s) -> interior space (ceiling coverage "
                 f"{top / max(float(a.sum()), 1e-12):.2f})",)))
        for c in sp:
            kind[c], owner[c] = "interior", sid
    # --- walls: untyped cells next to a space, thin w.r.t. the shared face
    nb = cells.neighbours()
    wall_no = 0
    for c in range(n):
        if space_of[c] >= 0:
            continue
        thick = cells.wall_thickness(c, [fi for _, fi in nb[c]], space_of >= 0)
        if thick > max_wall_thickness:
            continue
        wid = f"s{index}_wall{wall_no}"
        wall_no += 1
        shapes.append(Shape(
            id=wid, type=ShapeType.WALL,
            geometry=Polyhedron.prism(_polygon_coords(cells.polygons[c]), *cells.z_range[c]),
            storey=index, terminal=True, children=(f"s{index}_cell{c}",),
            attributes={"thickness": thick, "height": float(cells.z_range[c, 1] - cells.z_range[c, 0])},
            log=(f"walls (docs/method.md §3.4): untyped cell next to a space, vertices within {thick:.3f} m "
                 f"<= {max_wall_thickness:g} m of the shared face -> wall",)))
        kind[c], owner[c] = "wall", wid
    # --- exterior: connected groups of the remaining cells (hole-free unions), else per cell
    rest = [c for c in range(n) if not kind[c]]
    left = set(rest)
    ext_no = 0
    while left:
        seed = left.pop()
        comp, stack = [seed], [seed]
        while stack:
            c = stack.pop()
            for o, _ in nb[c]:
                if o in left:
                    left.discard(o)
                    comp.append(o)
                    stack.append(o)
        u = cells.union(comp)
        groups = [comp] if (u.geom_type == "Polygon" and not u.interiors) else [[c] for c in comp]
        for g in groups:
            poly = u if len(groups) == 1 else cells.polygons[g[0]]
            eid = f"s{index}_exterior{ext_no}"
            ext_no += 1
            shapes.append(Shape(
                id=eid, type=ShapeType.EXTERIOR,
                geometry=Polyhedron.prism(_polygon_coords(poly), st.floor_z, st.ceiling_z),
                storey=index, terminal=True, children=tuple(f"s{index}_cell{c}" for c in sorted(g)),
                log=("walls/exterior (docs/method.md §3.4): cell neither interior nor wall -> exterior",)))
            for c in g:
                kind[c], owner[c] = "exterior", eid
    # --- the cells themselves, inactive parts
    types = {"interior": ShapeType.INTERIOR, "wall": ShapeType.WALL, "exterior": ShapeType.EXTERIOR}
    for c in range(n):
        shapes.append(Shape(
            id=f"s{index}_cell{c}", type=types[kind[c]],
            geometry=Polyhedron.prism(_polygon_coords(cells.polygons[c]), *cells.z_range[c]),
            storey=index, terminal=False, active=False, parent=owner[c],
            support={"coverage_top": float(cov.top[c] / max(cov.area[c], 1e-12)),
                     "coverage_inside": float(cov.inside[c])},
            attributes={"cell": True},
            log=(f"place: cell {c} of the arrangement",)))
    return shapes


def _name_shapes(shapes: list[Shape]) -> list[Shape]:
    counters: dict = {}
    out = []
    order = sorted(range(len(shapes)), key=lambda i: (shapes[i].storey, round(float(shapes[i].centroid[1]), 2),
                                                      round(float(shapes[i].centroid[0]), 2)))
    names = {}
    for i in order:
        s = shapes[i]
        if not s.active:
            continue
        label = {"interior": "Room", "wall": "Wall", "exterior": "Exterior"}.get(s.type.value, "Shape")
        counters[label] = counters.get(label, 0) + 1
        names[i] = f"{label} {counters[label]}"
    for i, s in enumerate(shapes):
        out.append(s.with_(name=names[i]) if i in names else s)
    return out


def assemble_model(storeys: list[StoreyCells], params: GenericParams, *, seed=None,
                   timings=None, source: str = "", prep_params: Optional[PreprocessParams] = None) -> BuildingModel:
    """A BuildingModel from the searched storeys, with topology (adjacency via walls)."""
    shapes = []
    for i, sc in enumerate(storeys):
        shapes.extend(build_storey_shapes(sc, i, params.search.max_wall_thickness))
    shapes = _name_shapes(shapes)
    trace = {f"storey_{i}": {**sc.result.trace, "log_posterior": sc.result.log_posterior,
                             "acceptance_rate": sc.result.acceptance_rate,
                             "iterations": sc.result.iterations, "spaces": len(sc.result.spaces)}
             for i, sc in enumerate(storeys)}
    prov = Provenance(method="generic", parameters=_params_dict(params, prep_params), seed=seed,
                      timings=dict(timings or {}), trace=trace, source=source)
    model = BuildingModel(shapes=tuple(shapes), storeys=tuple(sc.storey for sc in storeys), provenance=prov)
    return derive_topology(model)


def _params_dict(params: GenericParams, prep_params: Optional[PreprocessParams]) -> dict:
    out = asdict(params)
    if prep_params is not None:
        out["preprocess"] = asdict(prep_params)
    out["tau"] = 0.3
    return out


# --------------------------------------------------------------------------- pipeline
def _storey_mask(work: PointCloud, storeys: list, si: int, delta: float) -> np.ndarray:
    """Which working points belong to storey ``si``: from just below its floor to just below
    the next floor, so rooms of several ceiling heights belong to it."""
    top_z = storeys[si + 1].floor_z - delta if si + 1 < len(storeys) else np.inf
    return (work.xyz[:, 2] >= storeys[si].floor_z - delta) & (work.xyz[:, 2] <= top_z)


def _storey_points(work: PointCloud, storeys: list, si: int, delta: float):
    """Working points of storey ``si`` (:func:`_storey_mask`) and |n_z| of their normals."""
    inz = _storey_mask(work, storeys, si, delta)
    return work.xyz[inz], np.abs(work.normals[inz, 2].astype(np.float64))


def storey_cells(prep: Prepared, params: GenericParams = GenericParams()) -> list:
    """The **place** rule per storey: wall lines cut the storey's extent (its points' box
    grown by ``cells.extent_margin``) into cells between floor and ceiling.

    Returns
    -------
    list of StoreyCells (``coverage`` and ``result`` None) for the storeys with points.
    """
    out = []
    delta = params.coverage.shape_buffer
    for si, st in enumerate(prep.storeys):
        xyz, _ = _storey_points(prep.working, prep.storeys, si, delta)
        if len(xyz) < 10:
            continue
        z_hi = max(st.ceiling_z, float(np.percentile(xyz[:, 2], 99.9)))
        margin = params.cells.extent_margin
        lo, hi = xyz[:, :2].min(axis=0) - margin, xyz[:, :2].max(axis=0) + margin
        lines = wall_lines(prep.planes, si, params.cells)
        if params.cells.second_faces or params.cells.clutter_fronts:
            w = prep.working
            inz = _storey_mask(w, prep.storeys, si, delta)
            sp = w.scanner_positions  # the preprocessing turned the normals toward their scanners
            oriented = (sp is not None and bool(np.isfinite(sp).all())
                        and (len(sp) == 1 or w.scan_index is not None))
            wx, wn = w.xyz[inz], w.normals[inz].astype(np.float64)
            mp = params_from_data(wx) if len(wx) >= 10 else None  # spacing and noise, once
            lines = clutter_fronts(lines, wx, wn, oriented, params.cells, mp)
            lines = second_faces(lines, wx, wn, oriented, params.cells, mp)
        polys = arrange_cells(lines, shapely.box(lo[0], lo[1], hi[0], hi[1]), params.cells)
        cells = cellset_from_polygons(polys, (st.floor_z, z_hi), params.cells.min_face_length)
        out.append(StoreyCells(st, cells, index=si, lines=lines))
    return out


def _near_ceiling_levels(z: np.ndarray, planes, storey: int, z0: float, z1: float,
                         params: CoverageParams) -> tuple[np.ndarray, np.ndarray]:
    """(n,) bool, False for upper-half points that are far from every large horizontal plane
    (door heads, shelf tops seen from below are not ceiling) — lower-half points and all
    points when no large plane is known stay True — and those planes' levels (z, metres)."""
    mid = (z0 + z1) / 2
    levels = [float(p.offset / p.normal[2]) for p in planes
              if p.kind == "horizontal" and p.storey in (storey, -1) and p.area >= params.min_ceiling_area
              and abs(p.normal[2]) > 0.5 and p.offset / p.normal[2] > mid]
    if not levels:
        return np.ones(len(z), bool), np.zeros(0)
    lv = np.asarray(levels)
    near = np.min(np.abs(z[:, None] - lv[None, :]), axis=1) <= params.ceiling_band
    return near | (z <= mid), lv


def _level_points(xyz: np.ndarray, nz: np.ndarray, levels, ceiling: np.ndarray,
                  params: CoverageParams) -> np.ndarray:
    """(n,) bool: the points within ``ceiling_band`` of a ceiling level that are not in
    ``ceiling`` (their normal too tilted to tell) and stand over no wall
    (:func:`.levels.over_walls`: a wall's top would cover the cell between its faces)."""
    out = np.zeros(len(xyz), bool)
    upright = nz < math.cos(params.coverage_angle)
    for lv in levels:
        at = ~ceiling & ~out & (np.abs(xyz[:, 2] - lv) <= params.ceiling_band)
        out |= at & ~over_walls(xyz, at, float(lv), upright, 2.0 * params.shape_buffer)
    return out


def generic_model(prep: Prepared, params: GenericParams = GenericParams(), *, rng=None,
                  progress=None, should_stop=None) -> BuildingModel:
    """The generic method on preprocessed data (docs/method.md §3).

    Parameters
    ----------
    prep : Prepared — with planes (:func:`engine.pipeline.preprocess`).
    params : GenericParams
    rng : seed or Generator of the search (continues the preprocessing's Generator in
        :func:`engine.reconstruct.reconstruct`); same seed, same model.

    Returns
    -------
    BuildingModel
        Interior spaces (prisms over unions of cells), walls, exterior, the cells as inactive
        parts, adjacency; provenance "generic" with each storey's search trace
        (``provenance.trace["storey_<i>"]``) and timings.

    Raises
    ------
    ReconstructionError
        No storey with points.
    """
    seed = int(rng) if isinstance(rng, (int, np.integer)) else None
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    p = Progress.wrap(progress, should_stop)
    timings = dict(prep.timings)
    t0 = time.perf_counter()
    arranged = storey_cells(prep, params)
    timings["cells"] = time.perf_counter() - t0
    cov_p = params.coverage
    out = []
    t_cov = t_search = 0.0
    for k, sc in enumerate(arranged):
        p.check()
        a, b = 0.05 + 0.9 * k / len(arranged), 0.05 + 0.9 * (k + 1) / len(arranged)
        t1 = time.perf_counter()
        xyz, nz = _storey_points(prep.working, prep.storeys, sc.index, cov_p.shape_buffer)
        z_hi = float(sc.cells.z_range[:, 1].max()) if len(sc.cells) else sc.storey.ceiling_z
        hmask = nz >= math.cos(cov_p.coverage_angle)
        wmask = nz <= math.sin(cov_p.coverage_angle)
        near, levels = _near_ceiling_levels(xyz[:, 2], prep.planes, sc.index, sc.storey.floor_z, z_hi, cov_p)
        hmask &= near
        level = _level_points(xyz, nz, levels, hmask, cov_p) if cov_p.ceiling_by_level else None
        cov = measure_coverage(sc.cells, xyz[wmask], xyz[hmask], cov_p, should_check=p.check,
                               xyz_level=None if level is None else xyz[level])
        t_cov += time.perf_counter() - t1
        t1 = time.perf_counter()
        res = search_spaces(sc.cells, cov, params.search, rng=rng, progress=p.sub(a, b), should_stop=should_stop)
        t_search += time.perf_counter() - t1
        log.info("storey %d: %d wall lines, %d cells, %d spaces", sc.index, len(sc.lines), len(sc.cells),
                 len(res.spaces))
        out.append(StoreyCells(sc.storey, sc.cells, cov, res, index=sc.index, lines=sc.lines))
    if not out:
        raise ReconstructionError("no storey with points to reconstruct", prep.cloud.source or None)
    timings.update(coverage=t_cov, rjmcmc=t_search)
    t1 = time.perf_counter()
    model = assemble_model(out, params, seed=seed, timings=timings, source=prep.cloud.source or "",
                           prep_params=prep.params)
    timings["model"] = time.perf_counter() - t1
    timings["total"] = sum(v for k, v in timings.items() if k != "total")
    trace = {**model.provenance.trace, "cleaning": dict(prep.cleaning)}
    model = model.with_(provenance=Provenance(**{**model.provenance.__dict__, "timings": timings, "trace": trace}))
    p(1.0, "generic reconstruction done")
    return model


def reconstruct_generic(cloud: PointCloud, params: Optional[GenericParams] = None, *, rng=None,
                        progress=None, should_stop=None,
                        preprocess_params: PreprocessParams = PreprocessParams()) -> BuildingModel:
    """Scan (metres, z up) → model with the generic method: :func:`engine.pipeline.preprocess`
    then :func:`generic_model`, one Generator seeded by ``rng`` for both (as
    :func:`engine.reconstruct.reconstruct` does)."""
    p = Progress.wrap(progress, should_stop)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    prep = preprocess(cloud, preprocess_params, rng=gen, progress=p.sub(0.0, 0.5))
    model = generic_model(prep, params or GenericParams(), rng=gen, progress=p.sub(0.5, 1.0))
    if isinstance(rng, (int, np.integer)):
        model = model.with_(provenance=Provenance(**{**model.provenance.__dict__, "seed": int(rng)}))
    return model
