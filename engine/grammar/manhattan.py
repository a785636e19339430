"""The Manhattan shape grammar (docs/method.md §2; thesis Ch. 3): the procedure.

Production order (thesis Fig. 3.6)::

    (place, adjacency)* → classify* → [manual reclassification] → connectivity*
      → (merge, containment, adjacency)* → [manual doors] → connectivity*

:func:`reconstruct_grammar` runs it on an aligned cloud (the grammar core, callable
without any preprocessing); :func:`manhattan_model` runs it on the shared preprocessing
(:mod:`engine.pipeline`) and returns a :class:`BuildingModel` in the aligned frame with
``model.transform`` mapping back to the input.

Parts are the placed cuboids, ids ``s<storey>_c<i>_<j>_<k>`` with ``grid=(i, j, k)``;
each stores the point-on-face index of its six faces (``ipof_f0`` … ``ipof_f5``, faces in
the order bottom, top, −y, +x, +y, −x) and ``ipof_top`` / ``ipof_sides``, and a log of the
rules that typed it.

Departures from the thesis (docs/method.md §2):

* Place: histogram peaks are measured in surface *area* (σ-cells), not raw counts, and
  only points whose normal is along the axis vote. A peak is a wall only if its surface
  reaches a ceiling under which it stands (:func:`_reaches_ceiling`): furniture faces
  would otherwise cut rooms into slices whose common faces look closed. Where no wall
  bounds the seen ceiling, the ceiling's seen extent bounds the grid.
* The ceiling (seen extent, "under a ceiling", top-face index) is the horizontal points
  within δ of its level *or* topmost in their ``level_cell`` cell and at most
  ``wall_top_band`` below it (:func:`.levels.ceiling_mask`): a terrestrial scan's ceiling reads
  lower far from the scanner; with ``ceiling_by_level`` any point on the level but a wall's
  top (:mod:`.levels`: sparse scan lines spoil normals). Its seen extent is that of its largest
  connected group of occupied cells (area, not a point percentile: the far end of a
  scan is sparse), and the grid ends there at the outermost weakly seen wall surface
  (≥ ``min_bound_wall_area``) reaching the ceiling height within ``max_wall_thickness``
  of that edge (:func:`.extent.closing_wall`: a far end wall seen only in patches); in an
  attic, the outermost wall whose top meets the roof planes (:func:`.roof.meets_roof`:
  a knee wall).
* Z cuts: the floor and every *ceiling level* of the storey (a level with nothing above
  it), so rooms get their own ceiling heights; desks and shelves (surfaces with something
  above and below) make no cut.
* Point-on-face index: covered share of the face (see :mod:`.ipof`). A wall face's counts
  too the points whose normal lies along no axis but leans its way (``faces_by_position``):
  on a sparse scan a wall is seen as scan lines far apart, and normals tilt about them.
* Classify: a thin cuboid is a wall only if its top is not seen and does not touch an
  interior shape; a cuboid thin in both directions (a wall junction, whose faces are
  hidden inside the walls) between at least two walls is a wall. A cuboid on the floor
  whose ceiling is seen only sparsely (``ipof_top_sparse``: each point covers its local
  spacing, up to ``ceiling_reach`` σ) over a seen floor is interior (:func:`.rules.classify`).
  A thin interior cuboid in a wall run with both long faces unseen whose top is seen only
  near the wall's faces (the ceiling's range noise) is a doorway (:func:`.passages.doorway_tops`).
"""
from __future__ import annotations

import logging
import time
from dataclasses import asdict, replace
from typing import Optional, Sequence

import numpy as np

from ..errors import EmptyCloudError, ReconstructionError
from ..geometry.normals import knn_normals
from ..geometry.spacing import estimate_spacing
from ..model import BuildingModel, Provenance, Shape, ShapeType, Storey
from ..pipeline import Prepared, align, full_cloud_normals, preprocess
from ..pointcloud import PointCloud
from ..progress import Progress
from ..segmentation.params import PreprocessParams
from .ends import UpperBand, free_wall_ends, heal_split_cells
from .geometry import box_of
from .levels import ceiling_mask
from .ipof import grid_face_index, local_radii
from .params import ManhattanParams, estimate_noise, params_from_data
from .passages import _SIDES, doorway_tops, enclosed_pockets, furniture_strips, room_slices, wide_passages
from .place import (StoreyFrame, detect_levels, given_frame, histogram_peaks, paired_faces, storey_chunks,
                    storey_frame, with_partner)
from .extent import FAR_POINTS, cell_lookup, closing_wall, scan_lines, seen_extent
from .roof import meets_roof, roof_planes, slope_spaces
from .rules import classify, derive_topology, reject_implausible_spaces
from .visibility import Views, seen_through

__all__ = ["manhattan_model", "reconstruct_manhattan", "reconstruct_grammar", "place_storey"]

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------- rule 1: place
_SORT_PLANES = 24
"""IPoF of the faces on more planes than this along one axis: the points are sorted along it
once and each plane's slab taken by bisection; fewer: each slab is a scan of the points."""

def _reaches_ceiling(pts: np.ndarray, axis: int, position: float, frame: StoreyFrame,
                     params: ManhattanParams, spacing: float, ceiling_cells=None, sorted_t=None,
                     between=(-np.inf, np.inf)) -> bool:
    """Is the vertical surface at ``position`` a wall, i.e. does it reach a ceiling?

    ``pts`` : (n, 3) points of the storey except those facing the other horizontal axis
    (near a ceiling the PCA normals of a wall are spoiled by the ceiling's points, so
    facing ``axis`` is not required; the walls the plane cuts through are left out).
    Walls run up to a ceiling; shelves, cabinets and tables stop short of it. The surface
    must cover at least ``min_wall_top_length`` (metres, counted in σ-cells along the wall)
    within ``wall_top_band`` below one of the storey's ceiling levels, under that ceiling
    (``ceiling_cells``: per ceiling level a membership test of its occupied ``level_cell``
    cells, or None). Departure from rule 1 (docs/method.md §2), which takes every peak:
    furniture faces would cut rooms into slices whose common faces look closed. ``between``:
    the slab's bounds, half-way to the neighbouring peaks (not a partition's points 8 cm off)."""
    w = max(1.5 * params.bin_size, params.shape_buffer / 2)
    lo, hi = max(position - w, between[0]), min(position + w, between[1])
    if sorted_t is not None:  # pts sorted along axis: take the slab by bisection
        q = pts[slice(*np.searchsorted(sorted_t, [lo, hi]))]
    else:
        q = pts[(pts[:, axis] >= lo) & (pts[:, axis] <= hi)]
    if len(q) == 0:
        return False
    o = 1 - axis
    if ceiling_cells is None:
        ceiling_cells = [None] * len(frame.ceilings)
    for (lo, hi), cells in zip(_top_bands(frame, params), ceiling_cells):
        band = (q[:, 2] >= lo) & (q[:, 2] <= hi)
        if cells is not None and band.any():
            # only under (or next to) that ceiling: a shelf in a high room must not reach
            # the ceiling level of a low room elsewhere
            k = np.floor(q[band][:, :2] / params.level_cell).astype(np.int64)
            hit = np.zeros(int(band.sum()), dtype=bool)
            r = max(1, int(np.ceil(params.wall_top_reach * spacing / params.level_cell)))
            for du, dv in np.ndindex(2 * r + 1, 2 * r + 1):
                hit |= cells(k + np.array([du - r, dv - r]))
            band[np.flatnonzero(band)[~hit]] = False
        if np.unique(np.floor(q[band, o] / spacing)).size * spacing >= params.min_wall_top_length:
            return True
    return False


def _top_bands(frame: StoreyFrame, params: ManhattanParams) -> list[tuple[float, float]]:
    """Per ceiling level, the z band (lo, hi) in which a wall must have points to reach it
    (:func:`_reaches_ceiling`): ``wall_top_band`` high, ``3 σ_noise`` under the level (clear
    of the noisy ceiling itself)."""
    lift = 3.0 * float(params.noise or 0.0)
    return [(c - lift - params.wall_top_band, c - lift) for c in frame.ceilings]


def _void_top(frame: StoreyFrame, params: ManhattanParams) -> float:
    """How high above a storey's top scan points tell that a column is open upwards, metres:
    ``void_height``, or the storey's own height plus ``void_floor_band`` when that is more
    (the ceiling of a void's upper part stands a storey's height above the top: 3.1 m in the
    Duplex's stair halls)."""
    own = float(frame.ceiling - frame.floor) + params.void_floor_band
    return float(frame.ceiling) + max(params.void_height, own)


def _or_void(cells, xyz: np.ndarray, normals: np.ndarray, frame: StoreyFrame, params: ManhattanParams):
    """The top ceiling's cell test widened to the cells open upwards (a double-height void,
    a stair hall): scan points above the storey's top (up to ``void_height``) and no
    floor of a storey above (no horizontal points within ``void_floor_band`` over the top),
    where a storey above exists (its floor covers at least ``min_space_area``).
    A wall bounding a void rises through the ceiling level, not to a ceiling; under a
    single scanner standing in the void it is the room's only wall evidence there."""
    top, d = float(frame.ceiling), float(params.shape_buffer)
    band = (xyz[:, 2] > top + 2 * d) & (xyz[:, 2] <= top + params.void_height)
    if not band.any():
        return cells
    hor = np.abs(normals[:, 2]) >= np.cos(params.normal_angle)
    upper = xyz[band & hor & (xyz[:, 2] <= top + params.void_floor_band), :2]
    c = params.level_cell
    if len(np.unique(np.floor(upper / c).astype(np.int64), axis=0)) * c * c < params.min_space_area:
        return cells  # no storey above (a top storey, an attic under its roof): no void
    above, floor = cell_lookup(xyz[band, :2], c), cell_lookup(upper, c)
    return lambda k: cells(k) | (above(k) & ~floor(k))


_LEVEL_CLEARANCE = 0.1
"""A wall face's points along no axis count only this far above the floor and below the
ceiling (metres): at the edges of those planes normals tilt too."""


def place_storey(xyz: np.ndarray, normals: np.ndarray, frame: StoreyFrame, storey: int,
                 params: ManhattanParams, spacing: float, oriented: bool = False,
                 roof: Optional[list] = None, views: Optional[Views] = None) -> list[Shape]:
    """Place, compute the point-on-face indices, and classify the cuboids of one storey.

    Parameters
    ----------
    xyz : (n, 3) float64 — aligned points, metres, z up.
    normals : (n, 3) float64 — unit normals (sign free unless ``oriented``).
    frame : the storey's floor and ceiling levels.
    storey : storey index. params : grammar parameters. spacing : σ, metres.
    oriented : the normals face their scanners. A wall's second face seen over little of its
        area still makes a cut (:func:`.place.paired_faces`), told from the sides its normals
        face, or without orientation from the side it is open to.
    roof : the roof planes of an attic storey (:func:`.roof.roof_planes`), or None; a knee wall the roof
        comes down onto closes the grid like a wall reaching the ceiling (:func:`.roof.meets_roof`).
    views : where the scan was taken from (:class:`.visibility.Views`), or None: exterior cuboids
        whose far walls were seen through them from inside may be rooms' parts
        (:func:`.visibility.seen_through`).

    Returns the classified parts (cuboids), not yet merged.
    """
    d = params.shape_buffer
    cos_t = np.cos(params.normal_angle)
    zc = frame.cuts
    inz = (xyz[:, 2] >= zc[0] - d) & (xyz[:, 2] <= zc[-1] + d)
    p, n = (xyz, np.abs(normals)) if inz.all() else (xyz[inz], np.abs(normals[inz]))
    along = [n[:, a] >= cos_t for a in range(3)]

    # place: peaks of x (points facing x) and y (points facing y) → intervals
    hor = along[2]
    on_ceiling = [ceiling_mask(p, hor, c, frame, params) for c in frame.ceilings]
    ceiling_cells = [cell_lookup(p[m][:, :2], params.level_cell) for m in on_ceiling]
    ceiling_cells[-1] = _or_void(ceiling_cells[-1], xyz, normals, frame, params)
    low = {}  # (axis, least area) -> the peaks of the points facing that axis: each histogram once

    def peaks_of(a, area):
        if (a, area) not in low:
            sel = along[a]
            uv = np.column_stack([p[sel, 1 - a], p[sel, 2]])
            low[a, area] = histogram_peaks(p[sel, a], uv, params, spacing, area)
        return low[a, area]

    raw, partners = [], ({}, {})  # second face -> the face it is the other side of, per axis
    for a in (0, 1):
        found = peaks_of(a, params.min_wall_area)
        sel = along[a]
        sa = (normals[inz, a] if not inz.all() else normals[:, a])[sel] if oriented else None
        raw.append(paired_faces(found, p[sel, a], np.column_stack([p[sel, 1 - a], p[sel, 2]]), sa,
                                params, spacing, weak=peaks_of(a, params.min_paired_wall_area),
                                partners=partners[a]))
    top_band = np.zeros(len(p), dtype=bool)  # the only points _reaches_ceiling reads
    for lo, hi in _top_bands(frame, params):
        top_band |= (p[:, 2] >= lo) & (p[:, 2] <= hi)
    extents = {}  # seen extents of the top ceiling, both axes
    cuts = []
    for a in (0, 1):
        o = 1 - a
        # the ceiling test looks at the points near the plane that are not on the
        # perpendicular walls it cuts through (their normals are spoiled near a ceiling)
        other = np.array([pk.position for pk in raw[o]])
        off = np.ones(len(p), dtype=bool)
        if len(other):
            j = np.clip(np.searchsorted(other, p[:, o]), 1, max(len(other) - 1, 1))
            dist = np.minimum(np.abs(p[:, o] - other[j - 1]), np.abs(p[:, o] - other[np.minimum(j, len(other) - 1)]))
            off = dist > d
        cand = p[off & ~along[o] & top_band]
        cand = cand[np.argsort(cand[:, a])]  # slices of it are counted: any order of ties
        pos = [pk.position for pk in raw[a]]  # a surface's points count for its nearest peak only
        mid = [-np.inf] + [(u + v) / 2 for u, v in zip(pos[:-1], pos[1:])] + [np.inf]
        up = {x: _reaches_ceiling(cand, a, x, frame, params, spacing, ceiling_cells, cand[:, a], mid[i:i + 2])
              for i, x in enumerate(pos)}
        peaks = [x for x in pos if up[x] or with_partner(x, partners[a], up)]
        # where no wall surface bounds the seen ceiling (a space seen through an opening,
        # a wall too far to get normals), the ceiling's seen extent bounds the grid
        # (first the top ceiling's extent, then that of every horizontal surface in the
        # upper half of the storey: lower ceilings, soffits seen beyond an opening)
        mid = (frame.floor + frame.ceiling) / 2
        weak = None
        for first, sel in ((True, on_ceiling[-1]), (False, hor & (p[:, 2] > mid))):
            if int(sel.sum()) < 10:
                continue
            if first:
                if not extents:
                    extents["lo"], extents["hi"], extents["plo"], extents["phi"] = seen_extent(
                        p[sel, :2], params.level_cell)
                lo_e, hi_e = float(extents["lo"][a]), float(extents["hi"][a])
                # how far it was seen: its points (the cells' edges overstate it by up to a cell,
                # and the head of a glazed opening in a 0.42 m wall then read as a room beyond it)
                lo_s, hi_s = float(extents["plo"][a]), float(extents["phi"][a])
            else:
                lo_e, hi_e = np.percentile(p[sel, a], [params.extent_percentile, 100 - params.extent_percentile])
                lo_s, hi_s = lo_e, hi_e
            lo_0, hi_0 = lo_e, hi_e
            if weak is None:  # sparsely seen surfaces facing a that reach a ceiling
                weak = [pk.position for pk in peaks_of(a, params.min_bound_wall_area)
                        if _reaches_ceiling(cand, a, pk.position, frame, params, spacing, None, cand[:, a])]
            t_max = params.max_wall_thickness
            lo_w = closing_wall(lo_e, -1, weak, t_max)
            hi_w = closing_wall(hi_e, +1, weak, t_max)
            if first and (lo_w == lo_e or hi_w == hi_e):
                # far from a single scanner the ceiling's scan lines lie further apart
                # than a cell, so its connected extent stops short: its points across the
                # seen extent reach on, and a weak wall there closes it
                # (within the wall thickness plus the step between its scan lines there:
                # the largest gap among its outermost points, at most another thickness)
                o0, o1 = float(extents["lo"][o]), float(extents["hi"][o])
                q = np.sort(p[sel][(p[sel, o] >= o0) & (p[sel, o] <= o1), a])
                q = q[(q >= lo_e - scan_lines(lo_e - q[q < lo_e][::-1], t_max))
                      & (q <= hi_e + scan_lines(q[q > hi_e] - hi_e, t_max))]
                k = min(FAR_POINTS, len(q))
                if lo_w == lo_e and q[0] < lo_e - t_max:
                    step = min(float(np.diff(q[:k]).max(initial=0.0)), t_max)
                    w = closing_wall(float(q[0]), -1, weak, t_max + step)
                    lo_w = w if w != float(q[0]) else lo_e
                if hi_w == hi_e and q[-1] > hi_e + t_max:
                    step = min(float(np.diff(q[-k:]).max(initial=0.0)), t_max)
                    w = closing_wall(float(q[-1]), +1, weak, t_max + step)
                    hi_w = w if w != float(q[-1]) else hi_e
                lo_e, hi_e = min(lo_e, lo_w), max(hi_e, hi_w)
            if first and roof:  # an attic: the outermost knee walls the roof comes down onto
                facing = p[along[a]]
                knee = [pk.position for pk in peaks_of(a, params.min_bound_wall_area) if meets_roof(
                    facing, roof, a, pk.position, half_width=max(1.5 * params.bin_size, d / 2),
                    reach=t_max, band=params.wall_top_band, cell=params.level_cell,
                    min_length=params.min_wall_top_length)]
                lo_w, hi_w = min([lo_w] + knee), max([hi_w] + knee)
                lo_e, hi_e = min(lo_e, lo_w), max(hi_e, hi_w)
            # the seen extent's own reach, or that of a wall or scan lines beyond it
            lo_d = lo_s if lo_e == lo_0 else min(lo_s, lo_e)
            hi_d = hi_s if hi_e == hi_0 else max(hi_s, hi_e)
            if not peaks or lo_d < peaks[0] - t_max:
                peaks.insert(0, lo_w)
            if hi_d > peaks[-1] + t_max:
                peaks.append(hi_w)
        if len(peaks) < 2:
            raise ReconstructionError(f"storey {storey}: fewer than two wall surfaces facing "
                                      f"{'xy'[a]} (found {len(peaks)}); is the cloud aligned?")
        cuts.append(np.array(peaks))
    upper = UpperBand(p, along, frame, params, spacing)
    extra = free_wall_ends(p, along, p[on_ceiling[0]][:, :2] if on_ceiling else p[:0, :2], cuts, frame,
                           params, upper)
    for a in (0, 1):
        if len(extra[a]):
            log.info("storey %d: free wall ends cut %s at %s", storey, "xy"[a],
                     np.round(np.sort(extra[a][:, 0]), 3).tolist())
            cuts[a] = np.sort(np.r_[cuts[a], extra[a][:, 0]])
    X, Y, Z = cuts[0], cuts[1], zc
    nx, ny, nz = len(X) - 1, len(Y) - 1, len(Z) - 1
    log.info("storey %d: %d x %d x %d cuboids (x cuts %d, y cuts %d, z cuts %s)",
             storey, nx, ny, nz, len(X), len(Y), np.round(Z, 3).tolist())

    # point-on-face index of every face of the grid, plane by plane
    margin = 2.0 * float(params.noise or 0.0)
    if params.faces_by_position:  # a wall face counts too the points along no axis leaning its way
        h = np.hypot(n[:, 0], n[:, 1])
        loose = (~along[0] & ~along[1] & ~along[2] & (h >= 0.1) & (p[:, 2] > Z[0] + _LEVEL_CLEARANCE)
                 & (p[:, 2] < Z[-1] - _LEVEL_CLEARANCE))

    def faces_on(axis, planes, u_edges, v_edges, ucol, vcol, skip=()):
        out = np.zeros((len(planes), len(u_edges) - 1, len(v_edges) - 1))
        sel = along[axis]
        if axis < 2 and params.faces_by_position:
            sel = sel | (loose & (n[:, axis] >= cos_t * h))
        sel = np.flatnonzero(sel)
        t = p[sel, axis]
        todo = [q for q in range(len(planes)) if q not in skip]
        if len(todo) > _SORT_PLANES:  # many planes: one sort, then bisection
            order = np.argsort(t)
            t, sel = t[order], sel[order]
        for q in todo:  # a wall's points count for the nearest plane (not a cut 5-10 cm off it too)
            w = planes[q]
            lo = w - d if axis == 2 or q == 0 else max(w - d, 0.5 * (planes[q - 1] + w))
            hi = w + d if axis == 2 or q == len(planes) - 1 else min(w + d, 0.5 * (w + planes[q + 1]))
            if len(todo) > _SORT_PLANES:
                i0, i1 = np.searchsorted(t, [lo, hi])
                on = sel[i0:i1]
            else:  # a few planes: a scan of the points each costs less than the sort
                on = sel[(t >= lo) & (t <= hi)]
            out[q] = grid_face_index(p[on][:, (ucol, vcol)], u_edges, v_edges, spacing, margin)
        return out

    FX = faces_on(0, X, Y, Z, 1, 2)  # (nx+1, ny, nz)
    FY = faces_on(1, Y, X, Z, 0, 2)  # (ny+1, nx, nz)
    # a ceiling's face: the points on that ceiling (below), not every horizontal point near it
    FZ = faces_on(2, Z, X, Y, 0, 1, skip=range(1, len(on_ceiling) + 1))  # (nz+1, nx, ny)
    for q, m in enumerate(on_ceiling):
        FZ[q + 1] = grid_face_index(p[m][:, :2], X, Y, spacing, margin)
    lowest = p[on_ceiling[0]][:, :2] if on_ceiling else p[:0, :2]
    sparse = _sparse_tops(lowest, FZ, X, Y, params, spacing, margin)

    # classify, top-down so that "top touches an interior shape" is known
    t_max = params.max_wall_thickness
    thin_x = np.diff(X) <= t_max
    thin_y = np.diff(Y) <= t_max
    types = np.empty((nx, ny, nz), dtype=object)
    shapes = {}
    for k in range(nz - 1, -1, -1):
        for i in range(nx):
            for j in range(ny):
                f = [FZ[k, i, j], FZ[k + 1, i, j], FY[j, i, k], FX[i + 1, j, k], FY[j + 1, i, k], FX[i, j, k]]
                sx, sy = (f[3] + f[5]) / 2, (f[2] + f[4]) / 2
                tx, ty = bool(thin_x[i]), bool(thin_y[j])
                if tx and ty:
                    sides, thin_axis = max(sx, sy), 2
                elif tx:
                    sides, thin_axis = sx, 0
                elif ty:
                    sides, thin_axis = sy, 1
                else:
                    sides, thin_axis = max(sx, sy), None
                support = {f"ipof_f{q}": float(v) for q, v in enumerate(f)}
                support.update(ipof_top=float(f[1]), ipof_bottom=float(f[0]), ipof_sides=float(sides))
                if k == 0 and (i, j) in sparse:
                    support["ipof_top_sparse"] = sparse[i, j]
                above = k + 1 < nz and types[i, j, k + 1] == ShapeType.INTERIOR
                typ, line = classify(support, tx or ty, above, params.tau, on_floor=k == 0,
                                     min_evidence=params.min_room_evidence)
                types[i, j, k] = typ
                sid = f"s{storey}_c{i:03d}_{j:03d}_{k:02d}"
                lo, hi = (X[i], Y[j], Z[k]), (X[i + 1], Y[j + 1], Z[k + 1])
                shapes[(i, j, k)] = Shape(
                    id=sid, type=typ, geometry=box_of(lo, hi), storey=storey, grid=(i, j, k),
                    terminal=typ != ShapeType.INTERIOR, support=support, attributes={"thin_axis": thin_axis},
                    log=(f"place: cuboid ({i},{j},{k}) from histogram intervals "
                         f"x[{X[i]:.3f},{X[i + 1]:.3f}] y[{Y[j]:.3f},{Y[j + 1]:.3f}] z[{Z[k]:.3f},{Z[k + 1]:.3f}]",
                         line))
    heal_split_cells(shapes, types, extra, X, Y, params)
    # wall junctions: a cuboid thin in both directions between walls (its faces are hidden
    # inside the walls, so its own index cannot be seen) continues them. Departure
    # from rule 2 of docs/method.md §2 (see the module docstring).
    for (i, j, k), s in list(shapes.items()):
        if s.type == ShapeType.WALL or s.attributes["thin_axis"] != 2:
            continue
        nb = [(i - 1, j, k), (i + 1, j, k), (i, j - 1, k), (i, j + 1, k)]
        walls = sum(1 for q in nb if q in shapes and types[q] == ShapeType.WALL)
        if walls >= 2:
            types[i, j, k] = ShapeType.WALL
            shapes[(i, j, k)] = s.logged(f"classify: wall junction, {walls} neighbouring walls -> wall",
                                         type=ShapeType.WALL, terminal=True)
    room_slices(shapes, types, params)
    doorway_tops(shapes, types, lowest, X, Y, params, spacing, margin)
    wide_passages(shapes, types, params, upper)
    enclosed_pockets(shapes, types, params, seen_through(shapes, types, xyz, normals, X, Y, frame, storey,
                                                         params, spacing, margin, views))
    furniture_strips(shapes, types, lowest, X, Y, params, margin)
    wide_passages(shapes, types, params, upper)  # pockets turned interior can flank a passage too
    _open_voids(shapes, types, xyz, normals, frame, params)
    return [shapes[key] for key in sorted(shapes)]


def _sparse_tops(uv: np.ndarray, FZ: np.ndarray, X: np.ndarray, Y: np.ndarray, params: ManhattanParams,
                 spacing: float, margin: float) -> dict:
    """The sparse ceiling index (``ipof_top_sparse``, :func:`.rules.classify`) of the cuboids
    on the floor that it may turn interior — top not seen (IPoF < τ), some floor seen (IPoF >
    ``min_room_evidence``) — {(i, j): index}. Each ceiling point (``uv``, the lowest ceiling
    level's) covers a disc of its local spacing up to ``ceiling_reach`` σ, measured over the
    points around the cuboid too; only those cuboids are rasterised."""
    reach = params.ceiling_reach * spacing
    if reach <= spacing or len(uv) == 0 or len(FZ) < 2:
        return {}
    cand = np.argwhere((FZ[1] < params.tau) & (FZ[0] > params.min_room_evidence))
    if not len(cand):
        return {}
    uv = uv[np.argsort(uv[:, 0])]  # one sort: each cuboid slices its x range (rasters: any order)
    out = {}
    for i, j in cand:
        lo, hi = np.array([X[i], Y[j]]) - 2 * reach, np.array([X[i + 1], Y[j + 1]]) + 2 * reach
        a, b = np.searchsorted(uv[:, 0], lo[0], side="left"), np.searchsorted(uv[:, 0], hi[0], side="right")
        near = uv[a:b][(uv[a:b, 1] >= lo[1]) & (uv[a:b, 1] <= hi[1])]
        r = local_radii(near, spacing, reach)
        index = grid_face_index(near, X[i:i + 2], Y[j:j + 2], spacing, margin, radii=r)
        out[int(i), int(j)] = float(index[0, 0])
    return out


def _open_voids(shapes: dict, types: np.ndarray, xyz: np.ndarray, normals: np.ndarray, frame: StoreyFrame,
                params: ManhattanParams) -> None:
    """Rooms whose ceiling is not there (a double-height void, a stair hall open to the
    floor above) or is seen only through openings (issue 19), in place.

    An exterior cuboid of the top z layer with floor evidence (IPoF(bottom) ≥ τ) whose column
    is open upwards — scan points above its top (up to :func:`_void_top`; a thin cuboid, up to
    ``void_height``) cover at least τ of its footprint while no floor of a storey above does
    (horizontal points within ``void_floor_band`` above the top cover less than τ; less than
    1 − τ for a thin cuboid under the slab's edge) — is interior when its walls close it:
    every side face is seen (IPoF ≥ τ) or touches an interior, wall or another such cuboid (a
    fixed point: candidates with an open side drop out until none does; a thin cuboid's short
    sides, :func:`_seen_beside`). A thin candidate whose long faces are unseen, between such
    a cuboid and another or a room, joins them (another room's wall line cut it across the
    void). Those parts get ``attributes["ceiling_seen"] = False``.
    """
    nx, ny, nz = types.shape
    k = nz - 1
    tau = params.tau
    cand = {(i, j) for i in range(nx) for j in range(ny)
            if types[i, j, k] == ShapeType.EXTERIOR and shapes[(i, j, k)].support.get("ipof_bottom", 0.0) >= tau}
    if not cand:
        return
    top = float(frame.ceiling)
    d = float(params.shape_buffer)
    band = (xyz[:, 2] > top + 2 * d) & (xyz[:, 2] <= _void_top(frame, params))
    if not band.any():
        return
    cell = params.level_cell
    hor = np.abs(normals[:, 2]) >= np.cos(params.normal_angle)
    upper_floor = band & hor & (xyz[:, 2] <= top + params.void_floor_band)
    near = band & (xyz[:, 2] <= top + params.void_height)
    # a wide cuboid looks up to the ceiling of a void's upper part; a thin one (a wall's
    # strip, its cells wider than it) sees that ceiling beside the wall above it: void_height
    above_cells = {False: cell_lookup(xyz[band, :2], cell), True: cell_lookup(xyz[near, :2], cell)}
    floor_cells = cell_lookup(xyz[upper_floor, :2], cell)
    open_up = set()
    for (i, j) in cand:
        b = shapes[(i, j, k)].bounds
        lo, hi = np.floor((b[0, :2] + d) / cell).astype(np.int64), np.floor((b[1, :2] - d) / cell).astype(np.int64)
        if np.any(hi < lo):
            continue
        gx, gy = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij")
        cells = np.column_stack([gx.ravel(), gy.ravel()])
        # a thin cuboid (under the edge of the slab above) may be partly covered
        thin = shapes[(i, j, k)].attributes.get("thin_axis") is not None
        if above_cells[thin](cells).mean() >= tau and \
                floor_cells(cells).mean() < (1.0 - tau if thin else tau):
            open_up.add((i, j))
    # a strip another wall line cut across a void (no wall seen along it), between a part of
    # the void and another part or a room, is part of it
    for (i, j) in sorted(cand - open_up):
        s = shapes[(i, j, k)]
        ax = s.attributes.get("thin_axis")
        if ax not in (0, 1) or max(s.support.get(f"ipof_f{f}", 0.0) for f in ((3, 5), (2, 4))[ax]) >= tau:
            continue
        beside = _across((i, j), ax)
        room = [0 <= q[0] < nx and 0 <= q[1] < ny and types[q[0], q[1], k] == ShapeType.INTERIOR
                for q in beside]
        if any(q in open_up for q in beside) and all(q in open_up or r for q, r in zip(beside, room)):
            open_up.add((i, j))
    closed_types = (ShapeType.INTERIOR, ShapeType.WALL)
    changed = True
    while changed:
        changed = False
        for (i, j) in sorted(open_up):
            sup = shapes[(i, j, k)].support
            thin = shapes[(i, j, k)].attributes.get("thin_axis")
            for f, di, dj in _SIDES:
                if sup.get(f"ipof_f{f}", 0.0) >= tau or _seen_beside(shapes, (i, j, k), f, thin, tau):
                    continue
                q = (i + di, j + dj)
                if not (0 <= q[0] < nx and 0 <= q[1] < ny):
                    break
                if q in open_up or types[q[0], q[1], k] in closed_types:
                    continue
                break
            else:
                continue
            open_up.discard((i, j))
            changed = True
    for (i, j) in open_up:
        s = shapes[(i, j, k)]
        types[i, j, k] = ShapeType.INTERIOR
        shapes[(i, j, k)] = s.logged("classify: floor seen, ceiling absent or seen only through openings, open "
                                     "upwards and closed by walls -> interior (lower confidence)",
                                     type=ShapeType.INTERIOR, terminal=False,
                                     attributes={**s.attributes, "ceiling_seen": False})


def _seen_beside(shapes: dict, key: tuple, f: int, thin, tau: float) -> bool:
    """A thin cuboid's short side face ``f`` (2–5: −y, +x, +y, −x) counts as seen when the
    cuboids either side of it across its thin axis see theirs: its own IPoF over a strip a
    wall's thickness wide is too few points to say (the Duplex's stair hall, cut by another
    room's wall line: 0.26 of a 12 cm strip of the exterior wall seen, 0.75 and 0.88 beside it)."""
    if thin not in (0, 1) or (f in (3, 5)) == (thin == 0):
        return False
    return all(q in shapes and shapes[q].support.get(f"ipof_f{f}", 0.0) >= tau for q in _across(key, thin))


def _across(key: tuple, axis: int) -> list:
    """The two grid keys (i, j[, k]) either side of ``key`` along ``axis`` (0: i, 1: j)."""
    lo, hi = list(key), list(key)
    lo[axis] -= 1
    hi[axis] += 1
    return [tuple(lo), tuple(hi)]


# --------------------------------------------------------------------------- the procedure
def reconstruct_grammar(cloud: PointCloud, params: Optional[ManhattanParams] = None,
                        storeys: Optional[Sequence] = None, *, progress=None, should_stop=None,
                        transform=None) -> BuildingModel:
    """Run the grammar on an **aligned** cloud (walls along x and y, z up).

    Parameters
    ----------
    cloud : PointCloud — aligned; normals are estimated when missing.
    params : grammar parameters; None or missing σ/δ/bin are chosen from the data.
    storeys : optional storeys (``engine.model.Storey`` or (floor_z, ceiling_z) pairs,
        metres); None finds them from slabs and floor/ceiling levels.
    transform : (4, 4) float64 aligned → input frame stored in the model (identity).

    Returns the model: parts, merged spaces, walls, exteriors, relations.
    """
    p = Progress.wrap(progress, should_stop)
    t0 = time.perf_counter()
    if cloud.n < 10:
        raise EmptyCloudError("too few points for a reconstruction", cloud.source or None)
    xyz = cloud.xyz
    params = _complete_params(xyz, params)
    spacing = float(params.spacing)
    timings = {}
    sp = cloud.scanner_positions
    # the preprocessing turns each normal toward its scanner when the scan says where they were
    oriented = (cloud.normals is not None and sp is not None and bool(np.isfinite(sp).all())
                and (len(sp) == 1 or (len(sp) > 1 and cloud.scan_index is not None)))
    views = Views(sp, cloud.scan_index) if sp is not None and len(sp) and bool(np.isfinite(sp).all()) \
        else Views()
    if cloud.normals is not None:
        normals = cloud.normals.astype(np.float64)
    else:
        normals = knn_normals(xyz, params.normal_neighbours)
        timings["normals"] = time.perf_counter() - t0
    p(0.2, "levels and storeys")
    t1 = time.perf_counter()
    hor = np.abs(normals[:, 2]) >= np.cos(params.normal_angle)
    frames = []
    if storeys is None:
        chunks = storey_chunks(xyz[:, 2], xyz[:, :2], params, spacing)
    else:
        # each storey from just below its floor to just below the next floor, so that
        # ceilings higher than the storey's main ceiling are found too
        fl = sorted((s.floor_z, s.ceiling_z) if hasattr(s, "floor_z") else (float(s[0]), float(s[1]))
                    for s in storeys)
        m = params.min_slab_thickness / 2  # below the floor, not into the slab under it
        top = float(xyz[:, 2].max())
        chunks = [(lo - m, (fl[i + 1][0] - m) if i + 1 < len(fl) else max(top, hi + m))
                  for i, (lo, hi) in enumerate(fl)]
    for i, (lo, hi) in enumerate(chunks):
        m = hor & (xyz[:, 2] >= lo) & (xyz[:, 2] <= hi)
        levels = detect_levels(xyz[m], params, spacing)
        fr = storey_frame(levels, params)
        if fr is None and storeys is not None:
            fr = given_frame(levels, fl[i], params)
        if fr is not None:
            frames.append(fr)
    if not frames:
        raise ReconstructionError("no floor and ceiling found (no two horizontal levels at least "
                                  f"{params.min_storey_height} m apart)", cloud.source or None)
    log.info("storeys: %s", [(round(f.floor, 3), [round(c, 3) for c in f.ceilings]) for f in frames])
    timings["levels"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    parts, model_storeys = [], []
    T = np.eye(4) if transform is None else np.asarray(transform, dtype=np.float64)
    sloped, roofs = [], {}
    for si, fr in enumerate(frames):
        p(0.3 + 0.5 * si / len(frames), f"storey {si}: place and classify")
        sx, sn, under = _with_sloped_ceiling(xyz, normals, fr, params)
        if sx is not xyz:
            sloped.append(si)
            roofs[si] = roof_planes(xyz[under], normals[under], spacing=spacing, buffer=params.shape_buffer,
                                    min_roof_area=params.min_roof_area)
        parts.extend(place_storey(sx, sn, fr, si, params, spacing, oriented=oriented,
                                  roof=roofs.get(si), views=views))
        elev = float((T @ np.array([0.0, 0.0, fr.floor, 1.0]))[2] + cloud.offset[2])
        model_storeys.append(Storey(si, fr.floor, fr.ceiling, f"Storey {si}", elev))
    timings["place_classify"] = time.perf_counter() - t2
    p(0.85, "merge and topology")
    t3 = time.perf_counter()
    model = BuildingModel(shapes=tuple(parts), storeys=tuple(model_storeys), transform=T, offset=cloud.offset,
                          provenance=Provenance(method="manhattan", parameters=params.to_dict(),
                                                source=cloud.source, software="indoor engine"),
                          name=cloud.source or "manhattan model")
    model = derive_topology(model, params.tau)
    n_spaces = len(model.spaces)
    model = reject_implausible_spaces(model, params.min_space_width, params.min_space_area,
                                      params.min_space_height, params.tau,
                                      min_floor_evidence=params.min_room_evidence,
                                      furniture_area=params.max_furniture_area)
    model = _ceiling_confidence(model)
    for si, fits in roofs.items():
        model = slope_spaces(model, si, fits, spacing=spacing)
    timings["topology"] = time.perf_counter() - t3
    model = model.with_(provenance=Provenance(
        method="manhattan", parameters=params.to_dict(), timings=timings,
        trace={"storeys": [{"floor": f.floor, "ceilings": list(f.ceilings)} for f in frames],
               "cuboids": len(parts), "sloped_storeys": sloped,
               "roof_planes": {si: len(f) for si, f in roofs.items()},
               "evidence": {"spaces_before": n_spaces, "spaces_after": len(model.spaces)}},
        source=cloud.source, software="indoor engine"))
    p(1.0, "done")
    return model


def _with_sloped_ceiling(xyz: np.ndarray, normals: np.ndarray, frame: StoreyFrame, params: ManhattanParams):
    """(xyz, normals, under): the points with the roof undersides of an attic storey projected
    onto its top, and the indices of those undersides (None for other storeys).

    A storey whose top is sloped (pitched roof slabs, no flat ceiling over most of it) has
    more sloped points (``sloped_normal_min`` ≤ |n_z| < cos θ) in its upper half than
    horizontal points at its ceiling levels there: those sloped points are copied onto the top level
    (normal up), so the grammar sees the ceiling that covers the rooms under the roof and
    the storey's grid reaches the roof's seen extent (every sloped point higher than
    ``sloped_min_height`` above the floor, down to the eaves, over the storey's floor).
    Other storeys: the input unchanged. (:func:`~engine.grammar.roof.slope_spaces` cuts the
    rooms by the roof planes afterwards.)
    """
    cos_t = np.cos(params.normal_angle)
    nz = np.abs(normals[:, 2])
    d = float(params.shape_buffer)
    top = frame.ceiling
    upper = (xyz[:, 2] > frame.floor + 0.5 * (top - frame.floor)) & (xyz[:, 2] <= top + d)
    slope = upper & (nz >= params.sloped_normal_min) & (nz < cos_t)
    # flat ceilings at any of the storey's ceiling levels in its upper half: a storey whose
    # rooms have flat ceilings under a small higher one (a hallway 0.3 m higher, a stair
    # hall) is no attic, however many tilted normals its wall tops have
    flat = upper & (nz >= cos_t) & np.any([np.abs(xyz[:, 2] - c) <= d for c in frame.ceilings], axis=0)
    ns, nf = int(slope.sum()), int(flat.sum())
    if ns <= params.sloped_ceiling_ratio * max(nf, 1):
        return xyz, normals, None
    log.info("storey at z = %.2f: sloped top (%d sloped, %d flat points at %.2f m); roof undersides "
             "projected onto the top", frame.floor, ns, nf, top)
    low = (xyz[:, 2] > frame.floor + params.sloped_min_height) & (xyz[:, 2] <= top + d)
    under = np.flatnonzero(low & (nz >= params.sloped_normal_min) & (nz < cos_t))  # down to the eaves
    cell = params.level_cell  # only over the storey's floor (not the roof seen from outside)
    on_floor = cell_lookup(xyz[(np.abs(xyz[:, 2] - frame.floor) <= d) & (nz >= cos_t), :2], cell)
    under = under[on_floor(np.floor(xyz[under, :2] / cell).astype(np.int64))]
    q = xyz[under].copy()
    q[:, 2] = top
    up = np.zeros_like(q)
    up[:, 2] = 1.0
    return np.vstack([xyz, q]), np.vstack([normals, up]), under


def _ceiling_confidence(model: BuildingModel) -> BuildingModel:
    """Spaces with parts whose ceiling was not seen (:func:`_open_voids`) get
    ``attributes["ceiling_seen"]`` (the seen share of their footprint) and a lower
    ``attributes["confidence"]`` = 0.5 + 0.5 · that share (1 otherwise)."""
    new = []
    for sp in model.spaces:
        parts = [model[c] for c in sp.children if c in model]
        if not any(p.attributes.get("ceiling_seen") is False for p in parts):
            continue
        area = np.array([p.geometry.plan_area_perimeter()[0] for p in parts])
        seen = np.array([p.attributes.get("ceiling_seen") is not False for p in parts])
        share = float(area[seen].sum() / area.sum()) if area.sum() > 0 else 0.0
        new.append(sp.with_(attributes={**sp.attributes, "ceiling_seen": round(share, 3),
                                        "confidence": round(0.5 + 0.5 * share, 3)}))
    return model.replace_shapes(*new) if new else model


def _complete_params(xyz, params):
    if params is None or not params.complete:
        return params_from_data(xyz, params)
    return params


# --------------------------------------------------------------------------- the method
def manhattan_model(prep: Prepared, params: Optional[ManhattanParams] = None, *, rng=None,
                    progress=None, should_stop=None) -> BuildingModel:
    """The Manhattan method on preprocessed data (docs/method.md §2).

    The grammar reads the normal of every input point: they are estimated on the full cloud
    (when it has none) and fix the Manhattan alignment (:func:`engine.pipeline.align`). The
    grammar runs on the full cloud in the aligned frame, per storey of the preprocessing (its
    own level analysis when those are a fallback), and finds every ceiling level inside each
    storey itself.

    Parameters
    ----------
    prep : Prepared
    params : ManhattanParams or None (σ, δ, bin chosen from the data: :func:`params_from_data`).
    rng : seed or Generator (alignment restarts, spacing/noise sampling).

    Returns
    -------
    BuildingModel in the aligned frame; ``model.transform`` maps it to the input frame.
    """
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    p = Progress.wrap(progress, should_stop)
    t0 = time.perf_counter()
    seed = int(rng.integers(2**31))
    p(0.0, "Manhattan alignment")
    base = params or ManhattanParams()
    tree = prep.cloud_tree()  # one k-d tree of the full cloud: spacing, normals' fallback, noise
    spacing = prep.spacing if prep.spacing is not None else estimate_spacing(prep.cloud.xyz, tree=tree)
    prep = align(replace(prep, tree=tree), rng=seed, cloud=full_cloud_normals(prep.cloud, prep.params, spacing,
                                                                              tree=tree, voxel=prep.voxel))
    aligned = prep.cloud.transformed(np.linalg.inv(prep.transform))  # with normals (align)
    storeys = prep.storeys if prep.storeys_found else None
    if base.spacing is None:
        base = base.with_(spacing=spacing)  # measured once
    if base.noise is None:  # rotation-free: the input frame's tree serves (params_from_data's sample)
        base = base.with_(noise=estimate_noise(prep.cloud.xyz, rng=seed, tree=tree))
    params = base if base.complete else params_from_data(aligned.xyz, base, rng=seed)
    t_pre = time.perf_counter() - t0
    p.check()
    model = reconstruct_grammar(aligned, params, storeys, progress=p.sub(0.1, 1.0), transform=prep.transform)
    timings = {**prep.timings, "align_and_normals": t_pre, **model.provenance.timings}
    return model.with_(provenance=Provenance(
        method="manhattan", parameters={**params.to_dict(), "preprocess": asdict(prep.params)}, seed=seed,
        timings=timings, trace={**model.provenance.trace, "cleaning": dict(prep.cleaning)},
        source=prep.cloud.source, software="indoor engine"))


def reconstruct_manhattan(cloud: PointCloud, params: Optional[ManhattanParams] = None, *, rng=None,
                          progress=None, should_stop=None,
                          preprocess_params: PreprocessParams = PreprocessParams()) -> BuildingModel:
    """Scan (metres, z roughly up) → Manhattan model: :func:`engine.pipeline.preprocess`
    (without planes) then :func:`manhattan_model`, one Generator seeded by ``rng``."""
    if cloud.n < 10:
        raise EmptyCloudError("too few points for a reconstruction", cloud.source or None)
    p = Progress.wrap(progress, should_stop)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    prep = preprocess(cloud, preprocess_params, rng=gen, planes=False, full_normals=True, progress=p.sub(0.0, 0.2))
    return manhattan_model(prep, params, rng=gen, progress=p.sub(0.2, 1.0))
