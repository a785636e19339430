"""Walls, openings and the true model derived from a :class:`~engine.synthetic.plan.FloorPlan`.

:func:`plan_geometry` derives the 2-D layout of a plan: per storey the building outline
(outer face of the exterior walls), the straight wall pieces (interior walls = the gaps
between neighbouring rooms, exterior walls = a band of ``exterior_thickness`` around the
building), the exterior space around it, and the footprint and host wall piece of every
door and window. :func:`build_truth` turns plan and layout into the true
:class:`~engine.model.BuildingModel` (the shared model conventions: walls with ``external``,
openings with ``kind`` / ``spaces``, one EXTERIOR shape ``exterior_s<k>`` per storey).

Openings in exterior walls (windows, exterior doors) are placed on the room's *exterior
stretches* (:func:`exterior_stretches`): the parts of its polygon edges whose other side
is outside the building, edge ``k`` running from ``room.polygon[k]`` to
``room.polygon[k + 1]`` in the order the plan gives the polygon. This module works on any
plan-like object and imports nothing from :mod:`engine.synthetic.plan` (which re-exports
its public names).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon, box
from shapely.ops import unary_union

from ..errors import InputError
from ..geometry.polygon import polygon_parts
from ..model import BuildingModel, Polyhedron, Provenance, Relation, Shape, ShapeType, Storey

__all__ = [
    "WallPiece",
    "PlanGeometry",
    "ExteriorStretch",
    "exterior_stretches",
    "plan_geometry",
    "build_truth",
    "door_footprint",
    "window_footprint",
    "exterior_id",
    "OPENING_MARGIN",
]

log = logging.getLogger(__name__)

_EPS = 1e-6
"""Geometric tolerance of the 2-D operations, metres."""
_MIN_INTERVAL = 0.05
"""Shared boundary shorter than this (metres) is not a wall between two spaces."""
_PROBE_MARGIN = 0.02
"""Extra depth (metres) of the probe strip that finds the room across a wall gap."""
_MITRE = dict(join_style="mitre", mitre_limit=10.0)
"""Sharp mitred offsets: shrinking cells keeps the wall gap exact at any corner angle."""
_OUTLINE_JOIN = dict(join_style="mitre", mitre_limit=2.0)
"""The building outline keeps right-angled (and blunter) corners square and bevels acute ones."""
OPENING_MARGIN = 0.05
"""A window or exterior door keeps at least this far from the ends of its exterior
stretch (the corners of the room), metres."""
EXTERIOR_SLIT = 1e-3
"""Width of the cut that opens each storey's exterior ring into one simple polygon, metres."""


def _edge_frame(p, q):
    """Unit direction, outward normal (for a CCW polygon) and length of edge p→q."""
    d = np.subtract(q, p)
    length = float(np.hypot(*d))
    d = d / length
    return d, np.array([d[1], -d[0]]), length


def _strip(p, q, depth, u0=0.0, u1=None) -> Polygon:
    """The rectangle on the outer side of edge p→q between params u0, u1, ``depth`` deep."""
    d, n, length = _edge_frame(p, q)
    u1 = length if u1 is None else u1
    a = np.asarray(p) + d * u0
    b = np.asarray(p) + d * u1
    return Polygon([tuple(a), tuple(b), tuple(b + n * depth), tuple(a + n * depth)])


def _project_interval(geom, p, d, length) -> Optional[tuple]:
    """[u0, u1] covered by ``geom``'s coordinates projected on the edge p + u d."""
    coords = []
    for g in getattr(geom, "geoms", [geom]):
        if g.is_empty:
            continue
        if isinstance(g, Polygon):
            coords.extend(g.exterior.coords)
        else:
            coords.extend(g.coords)
    if not coords:
        return None
    u = (np.asarray(coords) - np.asarray(p)) @ d
    u0, u1 = max(float(u.min()), 0.0), min(float(u.max()), length)
    return (u0, u1) if u1 - u0 > _EPS else None


_polygons = polygon_parts


def _clean(poly: Polygon) -> Polygon:
    poly = poly.buffer(0).simplify(_EPS)
    return shapely.geometry.polygon.orient(poly, 1.0) if isinstance(poly, Polygon) else poly


def _split_holes(poly: Polygon) -> list[Polygon]:
    """Split a polygon with holes into hole-free polygons (cuts through hole centroids)."""
    if not poly.interiors:
        return [poly]
    hole = Polygon(poly.interiors[0])
    cx = hole.centroid.x
    minx, miny, maxx, maxy = poly.bounds
    left = box(minx - 1, miny - 1, cx, maxy + 1)
    right = box(cx, miny - 1, maxx + 1, maxy + 1)
    out = []
    for half in (left, right):
        for p in _polygons(poly.intersection(half)):
            if p.area > _EPS:
                out.extend(_split_holes(_clean(p)))
    return out


# ----------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class WallPiece:
    """One straight piece of wall (footprint polygon) found by :func:`plan_geometry`.

    ``rooms`` : names of the rooms it bounds; ``exterior`` : True for the outer band;
    ``thickness`` : metres.
    """

    polygon: Polygon
    storey: int
    thickness: float
    exterior: bool
    rooms: tuple


@dataclass(frozen=True)
class PlanGeometry:
    """2-D geometry derived from a plan, per storey.

    Attributes
    ----------
    outlines : tuple of Polygon
        Outer boundary of the building (outer face of the exterior walls) per storey.
    walls : tuple of WallPiece
    exteriors : tuple of (storey, Polygon)
        The exterior space around each storey (one entry per storey with rooms): the
        ring between the outline and a box ``exterior_margin`` beyond it, opened by a
        :data:`EXTERIOR_SLIT` wide cut at the outline's leftmost vertex so that it is one
        simple (hole-free) polygon.
    doors : tuple of (Door, Polygon, int)
        Each door with its footprint across the wall and the index of its wall piece.
        The footprint is ``[c - d w/2, c + d w/2, c + d w/2 + n t, c - d w/2 + n t]``
        (c its centre on the first room's wall face, d along the wall, n across it, t the
        wall thickness): edges 1→2 and 3→0 are the jambs.
    windows : tuple of (Window, Polygon, int)
        Each window with its footprint (same layout as a door's, from the room's face
        out to the building outline) and the index of its exterior wall piece.
    """

    outlines: tuple
    walls: tuple
    exteriors: tuple
    doors: tuple = field(default_factory=tuple)
    windows: tuple = field(default_factory=tuple)


@dataclass(frozen=True)
class ExteriorStretch:
    """A stretch of a room's polygon edge whose other side is outside the building.

    Attributes
    ----------
    edge : int
        Index of the edge in the room's polygon (from ``polygon[edge]`` to
        ``polygon[edge + 1]``, as the plan lists the vertices).
    start : (2,) float64
        The edge's first vertex, metres.
    direction : (2,) float64
        Unit vector along the edge.
    normal : (2,) float64
        Unit normal pointing out of the room (into the exterior wall).
    u0, u1 : float
        The stretch, metres along the edge from ``start``.
    """

    edge: int
    start: np.ndarray
    direction: np.ndarray
    normal: np.ndarray
    u0: float
    u1: float


def _storey_outline(plan, s: int, polys=None) -> Polygon:
    """Outer boundary of storey ``s``: the union of its rooms grown by the exterior thickness."""
    if polys is None:
        polys = [r.shape for r in plan.rooms if r.storey == s]
    outline = unary_union([p.buffer(plan.exterior_thickness, **_OUTLINE_JOIN) for p in polys])
    if not isinstance(outline, Polygon):
        raise InputError(f"storey {s} of plan {plan.name!r} is not one connected building")
    return _clean(Polygon(outline.exterior))


def _free_intervals(facing, length) -> list:
    """The parts of [0, length] that no interval of ``facing`` covers."""
    free, u = [], 0.0
    for a, b in sorted(facing):
        if a > u + _EPS:
            free.append((u, a))
        u = max(u, b)
    if length > u + _EPS:
        free.append((u, length))
    return free


def exterior_stretches(plan, room) -> list[ExteriorStretch]:
    """The stretches of ``room``'s edges whose other side is outside the building, in the
    order of the room's polygon: the parts of each edge that face no other room across an
    interior wall gap and lie on the building's exterior wall band (the same rule
    :func:`plan_geometry` uses to make exterior wall pieces)."""
    t_int, t_ext = plan.interior_thickness, plan.exterior_thickness
    others = [r.shape for r in plan.rooms if r.storey == room.storey and r.name != room.name]
    outline = _storey_outline(plan, room.storey)
    pts = np.asarray(room.polygon, dtype=np.float64)
    x, y = pts[:, 0], pts[:, 1]
    ccw = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) > 0
    out = []
    for k in range(len(pts)):
        p, q = pts[k], pts[(k + 1) % len(pts)]
        length = float(np.hypot(*(q - p)))
        if length < 1e-9:
            continue
        d = (q - p) / length
        n = np.array([d[1], -d[0]]) if ccw else np.array([-d[1], d[0]])
        depth = t_int + _PROBE_MARGIN
        probe = Polygon([tuple(p), tuple(q), tuple(q + n * depth), tuple(p + n * depth)])
        facing = []
        for pj in others:
            hit = probe.intersection(pj)
            if hit.area <= _EPS:
                continue
            iv = _project_interval(hit, p, d, length)
            if iv is not None and iv[1] - iv[0] >= _MIN_INTERVAL:
                facing.append(iv)
        for a, b in _free_intervals(facing, length):
            if b - a < _EPS * 10:
                continue
            mid = p + d * (a + b) / 2 + n * (t_ext + _PROBE_MARGIN)
            if not outline.contains(Point(mid)):
                out.append(ExteriorStretch(k, p, d, n, float(a), float(b)))
    return out


def _place_exterior(plan, room_name: str, edge: Optional[int], position: float, width: float,
                    what: str) -> tuple[Polygon, np.ndarray, np.ndarray, float]:
    """Footprint of an opening ``width`` wide in the exterior wall of a room (see
    :func:`window_footprint`)."""
    try:
        room = plan.room(room_name)
    except KeyError:
        raise InputError(f"{what}: the plan has no room {room_name!r}") from None
    st = exterior_stretches(plan, room)
    if edge is not None:
        st = [s for s in st if s.edge == edge]
    half, m = width / 2, OPENING_MARGIN
    total = sum(s.u1 - s.u0 for s in st)
    target = float(np.clip(position, 0.0, 1.0)) * total
    best, start = None, 0.0
    for s in st:
        length = s.u1 - s.u0
        if length >= width + 2 * m - 1e-9:
            lo, hi = start + half + m, start + length - half - m
            x = float(np.clip(target, lo, max(lo, hi)))
            if best is None or abs(x - target) < best[0] - 1e-12:
                best = (abs(x - target), s, s.u0 + x - start)
        start += length
    if best is None:
        where = f"edge {edge} of room {room.name!r}" if edge is not None else f"room {room.name!r}"
        raise InputError(f"{what}: {where} has no exterior wall stretch wide enough for a "
                         f"{width:.2f} m opening")
    _, s, uc = best
    d, n, t = s.direction, s.normal, plan.exterior_thickness
    c = s.start + d * uc
    poly = Polygon([tuple(c - d * half), tuple(c + d * half), tuple(c + d * half + n * t),
                    tuple(c - d * half + n * t)])
    return poly, c, d, t


def window_footprint(plan, window) -> tuple[Polygon, np.ndarray, np.ndarray, float]:
    """Footprint of a window through its room's exterior wall.

    The window's centre lies at ``window.position`` (0–1) along the room's exterior
    stretches (:func:`exterior_stretches`; only those of edge ``window.edge`` when it is
    set), taken end to end in the polygon's order, then moved along its stretch so the
    window keeps :data:`OPENING_MARGIN` from the stretch's ends; when the stretch there
    is too short, the nearest stretch that is long enough is used.

    Returns
    -------
    polygon : shapely Polygon — from the room's wall face to the outline, metres.
    centre : (2,) float64 — centre on the room's wall face, metres.
    direction : (2,) float64 — unit vector along the wall.
    depth : float — the exterior wall thickness, metres.

    Raises
    ------
    InputError
        Unknown room, or no exterior stretch wide enough.
    """
    return _place_exterior(plan, window.room, window.edge, window.position, window.width,
                           f"window in {window.room!r}")


def door_footprint(plan, door) -> tuple[Polygon, np.ndarray, np.ndarray, float]:
    """Footprint of a door across the wall gap between its two rooms, or, for an exterior
    door (one room), through the room's exterior wall (placed like a window, see
    :func:`window_footprint`).

    Returns
    -------
    polygon : shapely Polygon — the opening's footprint, metres.
    centre : (2,) float64 — door centre on the first room's wall face, metres.
    direction : (2,) float64 — unit vector along the wall.
    depth : float — wall thickness at the door, metres.

    Raises
    ------
    InputError
        When the rooms share no stretch of wall wide enough for the door.
    """
    if len(door.rooms) == 1:
        return _place_exterior(plan, door.rooms[0], getattr(door, "edge", None), door.position, door.width,
                               f"exterior door of {door.rooms[0]!r}")
    a, b = plan.room(door.rooms[0]), plan.room(door.rooms[1])
    if a.storey != b.storey:
        raise InputError(f"door between {a.name!r} and {b.name!r}: rooms on different storeys")
    pa, pb = a.shape, b.shape
    probe = plan.interior_thickness + plan.exterior_thickness
    best = None
    coords = list(pa.exterior.coords)
    for p, q in zip(coords[:-1], coords[1:]):
        d, n, length = _edge_frame(p, q)
        hit = _strip(p, q, probe).intersection(pb)
        if hit.area <= _EPS:
            continue
        iv = _project_interval(hit, p, d, length)
        if iv and (best is None or iv[1] - iv[0] > best[3][1] - best[3][0]):
            gap = float(pb.distance(LineString([p, q])))
            best = (p, d, n, iv, gap)
    if best is None or best[3][1] - best[3][0] < door.width:
        raise InputError(f"rooms {a.name!r} and {b.name!r} share no wall wide enough for a "
                         f"{door.width:.2f} m door")
    p, d, n, (u0, u1), gap = best
    half = door.width / 2
    uc = u0 + float(np.clip(door.position, 0.0, 1.0)) * (u1 - u0)
    uc = float(np.clip(uc, u0 + half, u1 - half))
    c = np.asarray(p) + d * uc
    poly = Polygon([tuple(c - d * half), tuple(c + d * half), tuple(c + d * half + n * gap),
                    tuple(c - d * half + n * gap)])
    return poly, c, d, gap


def plan_geometry(plan) -> PlanGeometry:
    """Derive outlines, wall pieces, the exterior spaces and the door and window footprints
    of a plan (see :class:`PlanGeometry`).

    Raises
    ------
    InputError
        Invalid or overlapping rooms, a storey that is not one building, a door or window
        that does not fit, or two openings of one wall that overlap.
    """
    t_int, t_ext = plan.interior_thickness, plan.exterior_thickness
    outlines, walls, exteriors = [], [], []
    for s in range(len(plan.storeys)):
        rooms = [r for r in plan.rooms if r.storey == s]
        if not rooms:
            outlines.append(Polygon())
            continue
        polys = [r.shape for r in rooms]
        for i, pi in enumerate(polys):
            if not pi.is_valid or pi.area <= _EPS:
                raise InputError(f"room {rooms[i].name!r} has an invalid polygon")
            for j in range(i):
                if pi.intersection(polys[j]).area > 1e-4:
                    raise InputError(f"rooms {rooms[i].name!r} and {rooms[j].name!r} overlap")
        outline = _storey_outline(plan, s, polys)
        outlines.append(outline)
        wall_region = outline.difference(unary_union(polys))
        pieces: list[list] = []  # [polygon, thickness, exterior, rooms]
        taken = Polygon()
        # pass 1: interior walls, found from the lower-index room of each pair
        facing_all = []
        for i, (room, pi) in enumerate(zip(rooms, polys)):
            coords = list(pi.exterior.coords)
            per_edge = []
            for p, q in zip(coords[:-1], coords[1:]):
                d, n, length = _edge_frame(p, q)
                probe = _strip(p, q, t_int + _PROBE_MARGIN)
                facing = []
                for j, pj in enumerate(polys):
                    if j == i:
                        continue
                    hit = probe.intersection(pj)
                    if hit.area <= _EPS:
                        continue
                    iv = _project_interval(hit, p, d, length)
                    if iv is None or iv[1] - iv[0] < _MIN_INTERVAL:
                        continue
                    facing.append(iv)
                    if i < j:
                        gap = float(pj.distance(LineString([p, q])))
                        rect = _strip(p, q, gap, *iv).intersection(wall_region).difference(taken)
                        for poly in _polygons(rect):
                            if poly.area > 1e-5:
                                pieces.append([_clean(poly), gap, False, {room.name, rooms[j].name}])
                                taken = taken.union(poly)
                per_edge.append((p, q, d, n, length, facing))
            facing_all.append(per_edge)
        # pass 2: exterior walls along the stretches that face the outside
        for i, (room, per_edge) in enumerate(zip(rooms, facing_all)):
            for p, q, d, n, length, facing in per_edge:
                for a, b in _free_intervals(facing, length):
                    if b - a < _EPS * 10:
                        continue
                    mid = np.asarray(p) + d * (a + b) / 2 + n * (t_ext + _PROBE_MARGIN)
                    if outline.contains(Point(mid)):
                        continue  # a junction gap: filled in pass 3
                    rect = _strip(p, q, t_ext, a, b).intersection(wall_region).difference(taken)
                    for poly in _polygons(rect):
                        if poly.area > 1e-5:
                            pieces.append([_clean(poly), t_ext, True, {room.name}])
                            taken = taken.union(poly)
        # pass 3: junction and corner leftovers join the neighbour they extend best
        left = wall_region.difference(taken)
        for poly in _polygons(left):
            if poly.area <= 1e-7:
                continue
            cands = []
            for k, pc in enumerate(pieces):
                shared = pc[0].buffer(1e-4).intersection(poly.boundary).length
                if shared <= 1e-4:
                    continue
                u = unary_union([pc[0], poly])
                if not isinstance(u, Polygon):
                    u = unary_union([pc[0].buffer(1e-7, **_MITRE), poly.buffer(1e-7, **_MITRE)])
                if not isinstance(u, Polygon):
                    continue
                cands.append((round(u.convex_hull.area - u.area, 6), -shared, k, u))
            if not cands:
                log.debug("wall leftover of %.4f m² joins no wall piece; kept on its own", poly.area)
                near = min(range(len(pieces)), key=lambda k: pieces[k][0].distance(poly)) if pieces else None
                if near is not None:
                    pieces.append([_clean(poly), pieces[near][1], pieces[near][2], set(pieces[near][3])])
                continue
            _, _, k, u = min(cands, key=lambda c: c[:3])
            pieces[k][0] = _clean(u)
        for poly, th, ext, names in pieces:
            for pp in _polygons(poly):
                for part in _split_holes(pp):
                    walls.append(WallPiece(part, s, float(th), bool(ext), tuple(sorted(names))))
        exteriors.append((s, _exterior_ring(outline, plan.exterior_margin)))
    doors = []
    for door in plan.doors:
        fp = door_footprint(plan, door)[0]
        what = (f"exterior door of {door.rooms[0]!r}" if len(door.rooms) == 1
                else f"door between {door.rooms[0]!r} and {door.rooms[1]!r}")
        doors.append((door, fp, _host_wall(walls, fp, plan.room(door.rooms[0]).storey, len(door.rooms) == 1, what)))
    windows = []
    for win in plan.windows:
        fp = window_footprint(plan, win)[0]
        windows.append((win, fp, _host_wall(walls, fp, plan.room(win.room).storey, True, f"window in {win.room!r}")))
    _check_overlaps(plan, doors, windows)
    return PlanGeometry(tuple(outlines), tuple(walls), tuple(exteriors), tuple(doors), tuple(windows))


def _exterior_ring(outline: Polygon, margin: float) -> Polygon:
    """The box ``margin`` beyond ``outline`` minus the building, cut open at the outline's
    leftmost vertex (a :data:`EXTERIOR_SLIT` wide slit to the box's left side) so that it
    is one simple polygon."""
    minx, miny, maxx, maxy = outline.bounds
    ring = box(minx - margin, miny - margin, maxx + margin, maxy + margin).difference(outline)
    cs = np.asarray(outline.exterior.coords)[:-1]
    vx, vy = min(map(tuple, cs))
    h = EXTERIOR_SLIT / 2
    cut = _polygons(_clean(ring.difference(box(minx - margin - 1.0, vy - h, vx + h, vy + h))))
    if len(cut) != 1 or cut[0].interiors:  # pragma: no cover - the leftmost vertex always opens the ring
        raise InputError("the exterior ring of the building could not be opened into one polygon")
    return cut[0]


def _host_wall(walls, fp: Polygon, storey: int, exterior: bool, what: str) -> int:
    """Index of the wall piece holding an opening's footprint (an exterior one for a window
    or an exterior door, which must then lie wholly inside it)."""
    cand = [(w.polygon.intersection(fp).area, k) for k, w in enumerate(walls)
            if w.storey == storey and (w.exterior or not exterior)]
    area, k = max(cand) if cand else (0.0, -1)
    if area <= 1e-4:
        raise InputError(f"{what} lies in no {'exterior ' if exterior else ''}wall")
    if exterior and fp.difference(walls[k].polygon).area > 1e-6:
        raise InputError(f"{what} does not fit in one exterior wall piece (move it away from the corner)")
    return k


def _check_overlaps(plan, doors, windows) -> None:
    """InputError when two openings of one wall piece overlap (in plan and in height)."""
    items = []
    for door, fp, k in doors:
        z = plan.floor_z(plan.room(door.rooms[0]))
        items.append((k, fp, z, z + door.height, f"door {'/'.join(door.rooms)}"))
    for win, fp, k in windows:
        z = plan.floor_z(plan.room(win.room)) + win.sill
        items.append((k, fp, z, z + win.height, f"window in {win.room!r}"))
    for i, a in enumerate(items):
        for b in items[:i]:
            if a[0] == b[0] and min(a[3], b[3]) - max(a[2], b[2]) > 1e-6 and a[1].intersection(b[1]).area > 1e-6:
                raise InputError(f"{a[4]} and {b[4]} overlap in the same wall")


# ----------------------------------------------------------------------------- truth model
def _prism(poly: Polygon, z0: float, z1: float) -> Polyhedron:
    return Polyhedron.prism(np.asarray(poly.exterior.coords)[:-1], z0, z1)


def _touch_length(a: Polygon, b: Polygon) -> float:
    return float(a.buffer(1e-3).intersection(b.boundary).length)


def exterior_id(storey: int) -> str:
    """Id of the EXTERIOR shape of a storey in the true model: ``exterior_s<k>``."""
    return f"exterior_s{storey}"


def build_truth(plan, geometry: Optional[PlanGeometry] = None) -> BuildingModel:
    """The true :class:`BuildingModel` of a plan.

    Shapes: one INTERIOR prism per room (floor to its ceiling; ids ``space_<i>``); one
    WALL prism per wall piece (``wall_<k>``; ``attributes`` thickness, height, external
    (its other side is outside), exterior (the same, older name), rooms); SLAB prisms
    (``slab_<k>``: a floor slab under each storey's outline, a roof slab over the top
    storey, a ceiling slab over rooms lower than their storey); one EXTERIOR prism per
    storey (``exterior_s<k>``, :attr:`PlanGeometry.exteriors`); DOOR prisms across their
    wall (``door_<k>``, parent = the wall, ``attributes`` width, height, sill (0), open,
    kind "door", spaces [space, space or exterior id], rooms (names), confidence 1); WINDOW
    prisms (``window_<k>``, parent = the exterior wall, from sill to sill + height above
    the floor, ``attributes`` width, height, sill, kind "window", spaces [space, exterior
    id], room, confidence 1). Walls list their doors and windows as children.
    Relations: adjacency between spaces bounded by the same wall (``via`` = wall id; an
    exterior wall also joins its room to the storey's exterior), connectivity between
    the spaces a door joins (``via`` = door id; an exterior door joins its room to the
    storey's exterior).

    Parameters
    ----------
    plan : FloorPlan
    geometry : PlanGeometry, optional
        The result of :func:`plan_geometry` when already computed.
    """
    g = plan_geometry(plan) if geometry is None else geometry
    windows = getattr(g, "windows", ())
    shapes: list[Shape] = []
    rel: list[Relation] = []
    storeys = []
    for s, st in enumerate(plan.storeys):
        rooms = [r for r in plan.rooms if r.storey == s]
        top = max([plan.ceiling_z(r) for r in rooms] + [st.floor_z + st.height])
        storeys.append(Storey(s, st.floor_z, top, st.name or f"Storey {s}", st.floor_z))
    room_ids = {}
    for i, r in enumerate(plan.rooms):
        sid = f"space_{i}"
        room_ids[r.name] = sid
        shapes.append(Shape(sid, ShapeType.INTERIOR, _prism(r.shape, plan.floor_z(r), plan.ceiling_z(r)),
                            storey=r.storey, name=r.name, terminal=True,
                            attributes={"ceiling_height": plan.ceiling_z(r) - plan.floor_z(r),
                                        "scanned": r.scanned},
                            log=("synthetic: room of the floor plan",)))
    wall_ids = []
    children: dict[int, list[str]] = {}
    for k, (door, fp, w) in enumerate(g.doors):
        children.setdefault(w, []).append(f"door_{k}")
    for k, (win, fp, w) in enumerate(windows):
        children.setdefault(w, []).append(f"window_{k}")
    for k, w in enumerate(g.walls):
        st = storeys[w.storey]
        wid = f"wall_{k}"
        wall_ids.append(wid)
        shapes.append(Shape(wid, ShapeType.WALL, _prism(w.polygon, st.floor_z, st.ceiling_z),
                            storey=w.storey, name=f"Wall {k + 1}", terminal=True,
                            children=tuple(children.get(k, ())),
                            attributes={"thickness": w.thickness, "height": st.ceiling_z - st.floor_z,
                                        "external": w.exterior, "exterior": w.exterior,
                                        "rooms": list(w.rooms)},
                            log=("synthetic: wall derived from the room gaps",)))
    for k, (door, fp, w) in enumerate(g.doors):
        z0 = plan.floor_z(plan.room(door.rooms[0]))
        did = f"door_{k}"
        spaces = [room_ids[n] for n in door.rooms]
        if len(spaces) == 1:
            spaces.append(exterior_id(g.walls[w].storey))
        shapes.append(Shape(did, ShapeType.DOOR, _prism(fp, z0, z0 + door.height),
                            storey=g.walls[w].storey, name=f"Door {k + 1}", terminal=True,
                            parent=wall_ids[w],
                            attributes={"width": door.width, "height": door.height, "sill": 0.0,
                                        "open": door.open, "kind": "door", "spaces": spaces,
                                        "rooms": list(door.rooms), "confidence": 1.0},
                            log=("synthetic: door of the floor plan",)))
        rel.append(Relation("connectivity", spaces[0], spaces[1], did))
    for k, (win, fp, w) in enumerate(windows):
        z0 = plan.floor_z(plan.room(win.room)) + win.sill
        shapes.append(Shape(f"window_{k}", ShapeType.WINDOW, _prism(fp, z0, z0 + win.height),
                            storey=g.walls[w].storey, name=f"Window {k + 1}", terminal=True,
                            parent=wall_ids[w],
                            attributes={"width": win.width, "height": win.height, "sill": win.sill,
                                        "kind": "window",
                                        "spaces": [room_ids[win.room], exterior_id(g.walls[w].storey)],
                                        "room": win.room, "confidence": 1.0},
                            log=("synthetic: window of the floor plan",)))
    n_slab = 0
    t_s = plan.slab_thickness
    for s, st in enumerate(storeys):
        outline = g.outlines[s]
        if outline.is_empty:
            continue
        shapes.append(Shape(f"slab_{n_slab}", ShapeType.SLAB, _prism(outline, st.floor_z - t_s, st.floor_z),
                            storey=s, name=f"Floor slab {s}", terminal=True,
                            attributes={"kind": "floor", "thickness": t_s}))
        n_slab += 1
        above = storeys[s + 1] if s + 1 < len(storeys) else None
        if above is None or abs(above.floor_z - t_s - st.ceiling_z) > 1e-6:
            shapes.append(Shape(f"slab_{n_slab}", ShapeType.SLAB, _prism(outline, st.ceiling_z, st.ceiling_z + t_s),
                                storey=s, name=f"Roof slab {s}", terminal=True,
                                attributes={"kind": "roof", "thickness": t_s}))
            n_slab += 1
        for r in plan.rooms:
            if r.storey == s and plan.ceiling_z(r) < st.ceiling_z - 1e-6:
                cz = plan.ceiling_z(r)
                shapes.append(Shape(f"slab_{n_slab}", ShapeType.SLAB,
                                    _prism(r.shape, cz, min(cz + t_s, st.ceiling_z)),
                                    storey=s, name=f"Ceiling {r.name}", terminal=True,
                                    attributes={"kind": "ceiling", "thickness": min(t_s, st.ceiling_z - cz),
                                                "room": r.name}))
                n_slab += 1
    ext = {}
    for s, poly in g.exteriors:
        st = storeys[s]
        ext[s] = poly
        shapes.append(Shape(exterior_id(s), ShapeType.EXTERIOR, _prism(poly, st.floor_z, st.ceiling_z), storey=s,
                            name=f"Exterior {s}", terminal=True, log=("synthetic: outside the outer walls",)))
    # adjacency: the rooms each wall piece was derived from; an exterior wall also touches
    # the storey's exterior along more than a few centimetres
    for k, w in enumerate(g.walls):
        spaces = [room_ids[name] for name in w.rooms]
        outside = (w.exterior and w.storey in ext and _touch_length(w.polygon, ext[w.storey]) > _MIN_INTERVAL)
        for a in range(len(spaces)):
            for b in range(a + 1, len(spaces)):
                rel.append(Relation("adjacency", spaces[a], spaces[b], wall_ids[k]))
            if outside:
                rel.append(Relation("adjacency", spaces[a], exterior_id(w.storey), wall_ids[k]))
    return BuildingModel(shapes=tuple(shapes), storeys=tuple(storeys), relations=tuple(rel),
                         provenance=Provenance(method="synthetic", source=plan.name,
                                               parameters={"interior_thickness": plan.interior_thickness,
                                                           "exterior_thickness": plan.exterior_thickness,
                                                           "slab_thickness": plan.slab_thickness}),
                         name=plan.name)
