"""Floor-plan description of a synthetic building and its true :class:`BuildingModel`.

A plan lists *rooms* (clear interior spaces: a polygon, a storey, an optional own ceiling
height), *doors* between two rooms, *storeys* (floor height and clear height), clutter
boxes, and the wall and slab thicknesses. Walls are not described: they are derived as the
gap between neighbouring rooms (interior walls, thickness = the gap) and a band of
``exterior_thickness`` around the building, then split into straight pieces, one
:class:`~engine.model.Shape` per piece.

:func:`build_truth` turns a plan into the true model: interior spaces, walls, floor and
ceiling slabs, exterior spaces, doors, adjacency (spaces sharing a wall) and connectivity
(spaces joined by a door). :func:`rooms_from_partition` makes rooms from a partition of the
footprint into cells sharing edges, which is the easiest way to write a plan with exact
wall gaps at any angle. Neighbouring rooms should be ``interior_thickness`` apart (that is
what :func:`rooms_from_partition` gives); a wider gap is still filled with wall, but the
piece is not recognised as the wall *between* the two rooms.

A plan round-trips through JSON (:meth:`FloorPlan.to_json` / :meth:`FloorPlan.from_json`),
which is what ``indoor synth plan.json -o DIR`` reads::

    {"schema": "indoor-floor-plan", "schema_version": 1, "name": "two rooms",
     "interior_thickness": 0.15, "exterior_thickness": 0.3, "slab_thickness": 0.3,
     "storeys": [{"floor_z": 0.0, "height": 2.7, "name": "Ground floor"}],
     "rooms": [{"name": "A", "polygon": [[0, 0], [4, 0], [4, 5], [0, 5]]},
               {"name": "B", "polygon": [[4.15, 0], [8, 0], [8, 5], [4.15, 5]],
                "ceiling_height": 2.5}],
     "doors": [{"rooms": ["A", "B"], "position": 0.5, "width": 0.9, "height": 2.1}]}

Clutter is added by :func:`~engine.synthetic.furnish.furnish` when a plan has none.
"""
from __future__ import annotations

import json
import logging
import math
import os
from dataclasses import asdict, dataclass, field, replace
from typing import Optional, Sequence

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPolygon, Point, Polygon, box
from shapely.ops import unary_union

from ..errors import FormatError, InputError
from ..fileutil import atomic_write_text
from ..model import BuildingModel, Polyhedron, Provenance, Relation, Shape, ShapeType, Storey

__all__ = [
    "PLAN_SCHEMA",
    "Room",
    "Door",
    "PlanStorey",
    "Clutter",
    "FloorPlan",
    "WallPiece",
    "PlanGeometry",
    "rooms_from_partition",
    "plan_geometry",
    "build_truth",
    "door_footprint",
]

log = logging.getLogger(__name__)

PLAN_SCHEMA = "indoor-floor-plan"
"""Value of the ``schema`` key of a floor-plan JSON file."""
PLAN_SCHEMA_VERSION = 1
"""Version of the floor-plan JSON layout."""

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


# ----------------------------------------------------------------------------- plan types
@dataclass(frozen=True)
class Room:
    """A clear interior space.

    Attributes
    ----------
    name : str
        Unique name ("Room 1", "Corridor").
    polygon : tuple of (x, y)
        Outline of the clear space (wall faces), metres, any orientation, any angles,
        simple (no holes).
    storey : int
        Index into :attr:`FloorPlan.storeys`.
    ceiling_height : float or None
        Clear height above the storey floor, metres; None = the storey's height.
    scanned : bool
        False leaves the room without scanner positions (an unscanned room).
    furnished : bool
        Whether :func:`~engine.synthetic.furnish.furnish` puts clutter in it.
    """

    name: str
    polygon: tuple
    storey: int = 0
    ceiling_height: Optional[float] = None
    scanned: bool = True
    furnished: bool = True

    def __post_init__(self):
        pts = tuple((float(x), float(y)) for x, y in self.polygon)
        if len(pts) > 1 and pts[0] == pts[-1]:
            pts = pts[:-1]
        object.__setattr__(self, "polygon", pts)

    @property
    def shape(self) -> Polygon:
        """The outline as a counter-clockwise shapely polygon."""
        return shapely.geometry.polygon.orient(Polygon(self.polygon), 1.0)


@dataclass(frozen=True)
class Door:
    """A door in the wall shared by two rooms.

    Attributes
    ----------
    rooms : (str, str)
        Names of the two rooms it joins.
    position : float
        Centre of the door as a fraction (0–1) of the shared stretch of wall, measured
        along the first room's boundary; clamped so the door fits.
    width, height : float
        Clear opening, metres.
    open : bool
        An open door lets scanner rays through; a closed one is part of the wall surface.
    """

    rooms: tuple
    position: float = 0.5
    width: float = 0.9
    height: float = 2.1
    open: bool = True


@dataclass(frozen=True)
class PlanStorey:
    """A storey of the plan.

    Attributes
    ----------
    floor_z : float
        Height of the finished floor, metres.
    height : float
        Clear floor-to-ceiling height of rooms without their own, metres. The storey's
        walls reach the highest ceiling of its rooms (at least this height).
    name : str
    """

    floor_z: float
    height: float
    name: str = ""


@dataclass(frozen=True)
class Clutter:
    """A piece of furniture: an oriented box standing on the floor (or raised).

    Attributes
    ----------
    kind : str
        "table" (a top plate on four legs), "shelf" or "cabinet" (solid boxes).
    center : (x, y)
        Centre of the footprint, metres.
    size : (sx, sy, sz)
        Extent along the box's own x and y axes and its height, metres.
    angle : float
        Rotation of the box's x axis from the world x axis, radians.
    room : str
        Name of the room it stands in.
    z0 : float
        Height of the box bottom above the room floor, metres.
    """

    kind: str
    center: tuple
    size: tuple
    angle: float
    room: str
    z0: float = 0.0

    def footprint(self) -> Polygon:
        """The box's footprint polygon (metres)."""
        sx, sy = self.size[0] / 2, self.size[1] / 2
        c, s = math.cos(self.angle), math.sin(self.angle)
        cx, cy = self.center
        corners = [(-sx, -sy), (sx, -sy), (sx, sy), (-sx, sy)]
        return Polygon([(cx + c * x - s * y, cy + s * x + c * y) for x, y in corners])


@dataclass(frozen=True)
class FloorPlan:
    """A building as rooms, doors and storeys; walls are derived (see module doc).

    Attributes
    ----------
    name : str
    storeys : tuple of PlanStorey
    rooms : tuple of Room
    doors : tuple of Door
    clutter : tuple of Clutter
    interior_thickness : float
        Nominal interior wall thickness, metres (the real one is the gap between rooms).
    exterior_thickness : float
        Thickness of the wall band around the building, metres.
    slab_thickness : float
        Thickness of floor and roof slabs, metres.
    exterior_margin : float
        How far the exterior space reaches beyond the outer walls, metres.
    """

    name: str
    storeys: tuple
    rooms: tuple
    doors: tuple = ()
    clutter: tuple = ()
    interior_thickness: float = 0.15
    exterior_thickness: float = 0.3
    slab_thickness: float = 0.3
    exterior_margin: float = 1.0

    def __post_init__(self):
        for k in ("storeys", "rooms", "doors", "clutter"):
            object.__setattr__(self, k, tuple(getattr(self, k)))

    def room(self, name: str) -> Room:
        for r in self.rooms:
            if r.name == name:
                return r
        raise KeyError(f"plan {self.name!r} has no room {name!r}")

    def room_index(self, name: str) -> int:
        for i, r in enumerate(self.rooms):
            if r.name == name:
                return i
        raise KeyError(f"plan {self.name!r} has no room {name!r}")

    def floor_z(self, room: Room) -> float:
        return self.storeys[room.storey].floor_z

    def ceiling_z(self, room: Room) -> float:
        st = self.storeys[room.storey]
        return st.floor_z + (st.height if room.ceiling_height is None else room.ceiling_height)

    def with_(self, **changes) -> "FloorPlan":
        return replace(self, **changes)

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        """JSON-ready description (``schema`` "indoor-floor-plan")."""
        return {
            "schema": PLAN_SCHEMA,
            "schema_version": PLAN_SCHEMA_VERSION,
            "name": self.name,
            "interior_thickness": self.interior_thickness,
            "exterior_thickness": self.exterior_thickness,
            "slab_thickness": self.slab_thickness,
            "exterior_margin": self.exterior_margin,
            "storeys": [asdict(s) for s in self.storeys],
            "rooms": [{**asdict(r), "polygon": [list(p) for p in r.polygon]} for r in self.rooms],
            "doors": [{**asdict(d), "rooms": list(d.rooms)} for d in self.doors],
            "clutter": [{**asdict(c), "center": list(c.center), "size": list(c.size)} for c in self.clutter],
        }

    @classmethod
    def from_dict(cls, d, path=None) -> "FloorPlan":
        """Inverse of :meth:`to_dict`; :class:`~engine.errors.FormatError` on bad content."""
        if not isinstance(d, dict) or d.get("schema") != PLAN_SCHEMA:
            raise FormatError(f"not a floor-plan JSON (no 'schema': '{PLAN_SCHEMA}')", path)
        try:
            return cls(
                name=str(d.get("name", "")),
                storeys=tuple(PlanStorey(float(s["floor_z"]), float(s["height"]), str(s.get("name", "")))
                              for s in d["storeys"]),
                rooms=tuple(Room(str(r["name"]), tuple(tuple(map(float, p)) for p in r["polygon"]),
                                 int(r.get("storey", 0)),
                                 None if r.get("ceiling_height") is None else float(r["ceiling_height"]),
                                 bool(r.get("scanned", True)), bool(r.get("furnished", True)))
                            for r in d["rooms"]),
                doors=tuple(Door(tuple(map(str, x["rooms"])), float(x.get("position", 0.5)),
                                 float(x.get("width", 0.9)), float(x.get("height", 2.1)), bool(x.get("open", True)))
                            for x in d.get("doors", [])),
                clutter=tuple(Clutter(str(c["kind"]), tuple(map(float, c["center"])), tuple(map(float, c["size"])),
                                      float(c.get("angle", 0.0)), str(c["room"]), float(c.get("z0", 0.0)))
                              for c in d.get("clutter", [])),
                interior_thickness=float(d.get("interior_thickness", 0.15)),
                exterior_thickness=float(d.get("exterior_thickness", 0.3)),
                slab_thickness=float(d.get("slab_thickness", 0.3)),
                exterior_margin=float(d.get("exterior_margin", 1.0)),
            ).validated(path)
        except (KeyError, TypeError, ValueError) as e:
            raise FormatError(f"malformed floor-plan JSON: {e!r}", path) from None

    def to_json(self, path=None, indent: Optional[int] = 1) -> str:
        """Serialise; when ``path`` is given, write atomically."""
        text = json.dumps(self.to_dict(), indent=indent)
        if path is not None:
            atomic_write_text(path, text)
        return text

    @classmethod
    def from_json(cls, path) -> "FloorPlan":
        """Read a plan written by :meth:`to_json` (InputError/FormatError on a bad file)."""
        path = os.fspath(path)
        if not os.path.exists(path):
            raise InputError("file not found", path)
        try:
            with open(path, encoding="utf-8") as f:
                d = json.load(f)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise FormatError(f"not readable as JSON: {e}", path) from None
        return cls.from_dict(d, path)

    def validated(self, path=None) -> "FloorPlan":
        """Check names, references and numbers; returns self or raises InputError."""
        names = [r.name for r in self.rooms]
        if not self.storeys or not self.rooms:
            raise InputError(f"plan {self.name!r} needs at least one storey and one room", path)
        if len(set(names)) != len(names):
            raise InputError(f"plan {self.name!r} has duplicate room names", path)
        for st in self.storeys:
            if not (math.isfinite(st.floor_z) and st.height > 0):
                raise InputError(f"plan {self.name!r}: storey heights must be positive", path)
        for r in self.rooms:
            if not 0 <= r.storey < len(self.storeys):
                raise InputError(f"room {r.name!r} refers to storey {r.storey}, which does not exist", path)
            if len(r.polygon) < 3 or not all(math.isfinite(v) for p in r.polygon for v in p):
                raise InputError(f"room {r.name!r} needs a polygon of at least 3 finite points", path)
            if r.ceiling_height is not None and not r.ceiling_height > 0:
                raise InputError(f"room {r.name!r}: ceiling height must be positive", path)
        for d in self.doors:
            if len(d.rooms) != 2 or any(n not in names for n in d.rooms):
                raise InputError(f"door {d.rooms!r} must join two rooms of the plan", path)
            if not (d.width > 0 and d.height > 0):
                raise InputError(f"door {d.rooms!r}: width and height must be positive", path)
        for c in self.clutter:
            if c.room not in names:
                raise InputError(f"clutter in unknown room {c.room!r}", path)
        if not (self.interior_thickness > 0 and self.exterior_thickness > 0 and self.slab_thickness > 0):
            raise InputError(f"plan {self.name!r}: thicknesses must be positive", path)
        return self


# ----------------------------------------------------------------------------- helpers
def rooms_from_partition(cells: Sequence[tuple], thickness: float, **room_kw) -> list[Room]:
    """Rooms from a partition of the footprint into cells that share edges.

    Parameters
    ----------
    cells : sequence of (name, polygon) or (name, polygon, dict)
        ``polygon`` : (k, 2) metres — cells meet along common edges (wall centre lines);
        the dict holds further :class:`Room` fields (``ceiling_height``, ``storey``, ...).
    thickness : float
        Interior wall thickness, metres: each cell shrinks by half of it (mitred corners),
        so neighbouring rooms are exactly ``thickness`` apart at any angle.

    Returns
    -------
    list of Room
    """
    out = []
    for c in cells:
        name, poly = c[0], c[1]
        kw = dict(room_kw)
        if len(c) > 2:
            kw.update(c[2])
        shrunk = Polygon(poly).buffer(-thickness / 2, **_MITRE)
        if shrunk.is_empty or not isinstance(shrunk, Polygon):
            raise InputError(f"cell {name!r} vanishes or splits when shrunk by half a wall thickness")
        shrunk = shapely.geometry.polygon.orient(shrunk.simplify(_EPS), 1.0)
        out.append(Room(name, tuple(shrunk.exterior.coords), **kw))
    return out


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


def _polygons(geom) -> list[Polygon]:
    if geom is None or geom.is_empty:
        return []
    if isinstance(geom, Polygon):
        return [geom]
    if isinstance(geom, MultiPolygon):
        return list(geom.geoms)
    return [g for g in getattr(geom, "geoms", []) if isinstance(g, Polygon) and not g.is_empty]


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
        Hole-free pieces of the exterior space around each storey.
    doors : tuple of (Door, Polygon, int)
        Each door with its footprint across the wall and the index of its wall piece.
    """

    outlines: tuple
    walls: tuple
    exteriors: tuple
    doors: tuple = field(default_factory=tuple)


def door_footprint(plan: FloorPlan, door: Door) -> tuple[Polygon, np.ndarray, np.ndarray, float]:
    """Footprint of a door across the wall gap between its two rooms.

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


def plan_geometry(plan: FloorPlan) -> PlanGeometry:
    """Derive outlines, wall pieces, exterior pieces and door footprints from a plan."""
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
        outline = unary_union([p.buffer(t_ext, **_OUTLINE_JOIN) for p in polys])
        if not isinstance(outline, Polygon):
            raise InputError(f"storey {s} of plan {plan.name!r} is not one connected building")
        outline = _clean(Polygon(outline.exterior))
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
                free, u = [], 0.0
                for a, b in sorted(facing):
                    if a > u + _EPS:
                        free.append((u, a))
                    u = max(u, b)
                if length > u + _EPS:
                    free.append((u, length))
                for a, b in free:
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
        # exterior space: the box around the outline minus the building
        m = plan.exterior_margin
        minx, miny, maxx, maxy = outline.bounds
        ring = box(minx - m, miny - m, maxx + m, maxy + m).difference(outline)
        for p in _polygons(ring):
            for part in _split_holes(_clean(p)):
                exteriors.append((s, part))
    # doors
    doors = []
    for door in plan.doors:
        fp, c, _, _ = door_footprint(plan, door)
        st = plan.room(door.rooms[0]).storey
        cand = [(w.polygon.intersection(fp).area, k) for k, w in enumerate(walls) if w.storey == st]
        area, k = max(cand) if cand else (0.0, -1)
        if area <= 1e-4:
            raise InputError(f"door between {door.rooms[0]!r} and {door.rooms[1]!r} lies in no wall")
        doors.append((door, fp, k))
    return PlanGeometry(tuple(outlines), tuple(walls), tuple(exteriors), tuple(doors))


# ----------------------------------------------------------------------------- truth model
def _prism(poly: Polygon, z0: float, z1: float) -> Polyhedron:
    return Polyhedron.prism(np.asarray(poly.exterior.coords)[:-1], z0, z1)


def _touch_length(a: Polygon, b: Polygon) -> float:
    return float(a.buffer(1e-3).intersection(b.boundary).length)


def build_truth(plan: FloorPlan, geometry: Optional[PlanGeometry] = None) -> BuildingModel:
    """The true :class:`BuildingModel` of a plan.

    Shapes: one INTERIOR prism per room (floor to its ceiling; ids ``space_<i>``), one
    WALL prism per wall piece (``wall_<k>``, ``attributes["thickness"]``, storey height),
    SLAB prisms (``slab_<k>``: a floor slab under each storey's outline, a roof slab over
    the top storey, a ceiling slab over rooms lower than their storey), EXTERIOR prisms
    around each storey (``exterior_<s>_<k>``), DOOR prisms across their wall
    (``door_<k>``, parent = the wall, ``attributes`` width/height/sill/open).
    Relations: adjacency between spaces bounded by the same wall (``via`` = wall id),
    connectivity between rooms joined by a door (``via`` = door id).

    Parameters
    ----------
    plan : FloorPlan
    geometry : PlanGeometry, optional
        The result of :func:`plan_geometry` when already computed.
    """
    g = plan_geometry(plan) if geometry is None else geometry
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
    door_children: dict[int, list[str]] = {}
    for k, (door, fp, w) in enumerate(g.doors):
        door_children.setdefault(w, []).append(f"door_{k}")
    for k, w in enumerate(g.walls):
        st = storeys[w.storey]
        wid = f"wall_{k}"
        wall_ids.append(wid)
        shapes.append(Shape(wid, ShapeType.WALL, _prism(w.polygon, st.floor_z, st.ceiling_z),
                            storey=w.storey, name=f"Wall {k + 1}", terminal=True,
                            children=tuple(door_children.get(k, ())),
                            attributes={"thickness": w.thickness, "exterior": w.exterior,
                                        "rooms": list(w.rooms)},
                            log=("synthetic: wall derived from the room gaps",)))
    for k, (door, fp, w) in enumerate(g.doors):
        z0 = plan.floor_z(plan.room(door.rooms[0]))
        did = f"door_{k}"
        shapes.append(Shape(did, ShapeType.DOOR, _prism(fp, z0, z0 + door.height),
                            storey=g.walls[w].storey, name=f"Door {k + 1}", terminal=True,
                            parent=wall_ids[w],
                            attributes={"width": door.width, "height": door.height, "sill": 0.0,
                                        "open": door.open, "rooms": list(door.rooms)},
                            log=("synthetic: door of the floor plan",)))
        rel.append(Relation("connectivity", room_ids[door.rooms[0]], room_ids[door.rooms[1]], did))
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
    ext_ids = []
    for k, (s, poly) in enumerate(g.exteriors):
        st = storeys[s]
        eid = f"exterior_{s}_{k}"
        ext_ids.append((eid, s, poly))
        shapes.append(Shape(eid, ShapeType.EXTERIOR, _prism(poly, st.floor_z, st.ceiling_z), storey=s,
                            name="Exterior", terminal=True, log=("synthetic: outside the outer walls",)))
    # adjacency: the rooms each wall piece was derived from; exterior walls also touch
    # the exterior pieces along more than a few centimetres
    for k, w in enumerate(g.walls):
        spaces = [room_ids[name] for name in w.rooms]
        outside = [eid for eid, s, poly in ext_ids
                   if w.exterior and s == w.storey and _touch_length(w.polygon, poly) > _MIN_INTERVAL]
        for a in range(len(spaces)):
            for b in range(a + 1, len(spaces)):
                rel.append(Relation("adjacency", spaces[a], spaces[b], wall_ids[k]))
            for e in outside:
                rel.append(Relation("adjacency", spaces[a], e, wall_ids[k]))
    return BuildingModel(shapes=tuple(shapes), storeys=tuple(storeys), relations=tuple(rel),
                         provenance=Provenance(method="synthetic", source=plan.name,
                                               parameters={"interior_thickness": plan.interior_thickness,
                                                           "exterior_thickness": plan.exterior_thickness,
                                                           "slab_thickness": plan.slab_thickness}),
                         name=plan.name)
