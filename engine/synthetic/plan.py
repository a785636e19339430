"""Floor-plan description of a synthetic building and its true :class:`BuildingModel`.

A plan lists *rooms* (clear interior spaces: a polygon, a storey, an optional own ceiling
height), *doors* between two rooms or from a room to the outside, *windows* in exterior
walls, *storeys* (floor height and clear height), clutter boxes, and the wall and slab
thicknesses. Walls are not described: they are derived as the gap between neighbouring
rooms (interior walls, thickness = the gap) and a band of ``exterior_thickness`` around
the building, then split into straight pieces, one :class:`~engine.model.Shape` per piece
(:mod:`engine.synthetic.layout`, whose names this module re-exports).

:func:`build_truth` turns a plan into the true model: interior spaces, walls, floor and
ceiling slabs, exterior spaces, doors, windows, adjacency (spaces sharing a wall) and
connectivity (spaces joined by a door). :func:`rooms_from_partition` makes rooms from a
partition of the footprint into cells sharing edges, which is the easiest way to write a
plan with exact wall gaps at any angle. Neighbouring rooms should be ``interior_thickness``
apart (that is what :func:`rooms_from_partition` gives); a wider gap is still filled with
wall, but the piece is not recognised as the wall *between* the two rooms.

A plan round-trips through JSON (:meth:`FloorPlan.to_json` / :meth:`FloorPlan.from_json`),
which is what ``indoor synth plan.json -o DIR`` reads::

    {"schema": "indoor-floor-plan", "schema_version": 1, "name": "two rooms",
     "interior_thickness": 0.15, "exterior_thickness": 0.3, "slab_thickness": 0.3,
     "storeys": [{"floor_z": 0.0, "height": 2.7, "name": "Ground floor"}],
     "rooms": [{"name": "A", "polygon": [[0, 0], [4, 0], [4, 5], [0, 5]]},
               {"name": "B", "polygon": [[4.15, 0], [8, 0], [8, 5], [4.15, 5]],
                "ceiling_height": 2.5}],
     "doors": [{"rooms": ["A", "B"], "position": 0.5, "width": 0.9, "height": 2.1},
               {"rooms": ["A"], "exterior": true, "edge": 0, "position": 0.3, "open": false}],
     "windows": [{"room": "A", "edge": 3, "position": 0.5, "width": 1.2, "height": 1.4,
                  "sill": 0.9},
                 {"room": "B", "position": 0.6, "width": 1.5, "height": 1.3, "sill": 0.8}]}

Doors: ``"rooms"`` names two rooms (an interior door in the wall they share) or one room
(an exterior door; ``"exterior": true`` may say so explicitly). Windows and exterior doors
sit in the room's exterior wall: ``"edge"`` (optional) is the index ``k`` of the room
polygon's edge from vertex ``k`` to ``k + 1`` (in the order the polygon is written); the
opening's centre lies at ``"position"`` (0–1) along the parts of that edge whose other side
is outside, or, without ``"edge"``, along all such parts of the room's boundary taken end
to end in the polygon's order (see :func:`~engine.synthetic.layout.window_footprint`).
``"sill"`` and ``"height"`` (metres above the room's floor) give the window's vertical
extent; it must end below the room's ceiling.

Clutter is added by :func:`~engine.synthetic.furnish.furnish` when a plan has none.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, replace
from typing import Optional, Sequence

import shapely
from shapely.geometry import Polygon

from ..errors import FormatError, InputError
from ..fileutil import atomic_write_text
from .layout import (  # noqa: F401  (re-exported: the layout of a plan lives in .layout)
    _EPS,
    _MIN_INTERVAL,
    _MITRE,
    _OUTLINE_JOIN,
    _PROBE_MARGIN,
    OPENING_MARGIN,
    ExteriorStretch,
    PlanGeometry,
    WallPiece,
    _clean,
    _edge_frame,
    _polygons,
    _project_interval,
    _split_holes,
    _strip,
    build_truth,
    door_footprint,
    exterior_id,
    exterior_stretches,
    plan_geometry,
    window_footprint,
)

__all__ = [
    "PLAN_SCHEMA",
    "Room",
    "Door",
    "Window",
    "PlanStorey",
    "Clutter",
    "FloorPlan",
    "WallPiece",
    "PlanGeometry",
    "ExteriorStretch",
    "rooms_from_partition",
    "plan_geometry",
    "build_truth",
    "door_footprint",
    "window_footprint",
    "exterior_stretches",
    "exterior_id",
]

PLAN_SCHEMA = "indoor-floor-plan"
"""Value of the ``schema`` key of a floor-plan JSON file."""
PLAN_SCHEMA_VERSION = 1
"""Version of the floor-plan JSON layout."""

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
    """A door in the wall shared by two rooms, or in a room's exterior wall.

    Attributes
    ----------
    rooms : (str, str) or (str,)
        Names of the two rooms it joins; one name makes an exterior door (from that room
        to the outside).
    position : float
        Centre of the door as a fraction (0–1) of the shared stretch of wall, measured
        along the first room's boundary; clamped so the door fits. For an exterior door:
        along the room's exterior stretches, as for a :class:`Window`.
    width, height : float
        Clear opening, metres.
    open : bool
        An open door is a clear hole through the wall (with its reveals); a closed one
        has a leaf inside the wall thickness, recessed from both wall faces.
    edge : int or None
        Exterior doors only: index of the room polygon's edge that holds the door (None:
        anywhere on the room's exterior boundary, see :class:`Window`).
    """

    rooms: tuple
    position: float = 0.5
    width: float = 0.9
    height: float = 2.1
    open: bool = True
    edge: Optional[int] = None

    def __post_init__(self):
        object.__setattr__(self, "rooms", tuple(self.rooms))

    @property
    def exterior(self) -> bool:
        """True for a door from a room to the outside."""
        return len(self.rooms) == 1


@dataclass(frozen=True)
class Window:
    """A window: a hole through a room's exterior wall from ``sill`` to ``sill + height``
    above the room's floor, glazed in the middle of the wall thickness.

    Attributes
    ----------
    room : str
        Name of the room it lights.
    position : float
        Centre of the window as a fraction (0–1) along the room's exterior stretches (the
        parts of its boundary whose other side is outside), taken end to end in the order
        of the room's polygon, or only those of edge ``edge``; moved so the window fits
        (:func:`~engine.synthetic.layout.window_footprint`).
    width, height : float
        Clear opening, metres.
    sill : float
        Height of the opening's bottom above the room's floor, metres.
    edge : int or None
        Index ``k`` of the room polygon's edge (vertex ``k`` to ``k + 1``) that holds the
        window; None = anywhere on the room's exterior boundary.
    """

    room: str
    position: float = 0.5
    width: float = 1.2
    height: float = 1.4
    sill: float = 0.9
    edge: Optional[int] = None


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
    """A building as rooms, doors, windows and storeys; walls are derived (see module doc).

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
    windows : tuple of Window
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
    windows: tuple = ()

    def __post_init__(self):
        for k in ("storeys", "rooms", "doors", "clutter", "windows"):
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
            "doors": [_door_dict(d) for d in self.doors],
            "windows": [_window_dict(w) for w in self.windows],
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
                doors=tuple(_door_from(x, path) for x in d.get("doors", [])),
                windows=tuple(Window(str(w["room"]), float(w.get("position", 0.5)), float(w.get("width", 1.2)),
                                     float(w.get("height", 1.4)), float(w.get("sill", 0.9)), _edge_from(w))
                              for w in d.get("windows", [])),
                clutter=tuple(Clutter(str(c["kind"]), tuple(map(float, c["center"])), tuple(map(float, c["size"])),
                                      float(c.get("angle", 0.0)), str(c["room"]), float(c.get("z0", 0.0)))
                              for c in d.get("clutter", [])),
                interior_thickness=float(d.get("interior_thickness", 0.15)),
                exterior_thickness=float(d.get("exterior_thickness", 0.3)),
                slab_thickness=float(d.get("slab_thickness", 0.3)),
                exterior_margin=float(d.get("exterior_margin", 1.0)),
            ).validated(path)
        except InputError:
            raise
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
            if len(d.rooms) not in (1, 2) or any(n not in names for n in d.rooms):
                raise InputError(f"door {d.rooms!r} must join two rooms of the plan or lead from one "
                                 f"room to the outside", path)
            if not (d.width > 0 and d.height > 0 and math.isfinite(d.position)):
                raise InputError(f"door {d.rooms!r}: width and height must be positive, the position finite", path)
            if d.edge is not None:
                if len(d.rooms) != 1:
                    raise InputError(f"door {d.rooms!r}: only an exterior door (one room) takes an 'edge'", path)
                self._check_edge(d.edge, self.room(d.rooms[0]), f"door {d.rooms!r}", path)
        for w in self.windows:
            what = f"window in {w.room!r}"
            if w.room not in names:
                raise InputError(f"{what}: unknown room", path)
            room = self.room(w.room)
            clear = self.ceiling_z(room) - self.floor_z(room)
            if not all(math.isfinite(v) for v in (w.position, w.width, w.height, w.sill)):
                raise InputError(f"{what}: position, width, height and sill must be finite numbers", path)
            if not (w.width > 0 and w.height > 0 and w.sill >= 0):
                raise InputError(f"{what}: width and height must be positive and the sill not negative", path)
            if w.sill + w.height >= clear:
                raise InputError(f"{what}: sill + height = {w.sill + w.height:.2f} m reaches the ceiling "
                                 f"({clear:.2f} m above the floor)", path)
            if w.edge is not None:
                self._check_edge(w.edge, room, what, path)
        for c in self.clutter:
            if c.room not in names:
                raise InputError(f"clutter in unknown room {c.room!r}", path)
        if not (self.interior_thickness > 0 and self.exterior_thickness > 0 and self.slab_thickness > 0):
            raise InputError(f"plan {self.name!r}: thicknesses must be positive", path)
        return self

    @staticmethod
    def _check_edge(edge, room: Room, what: str, path) -> None:
        if isinstance(edge, bool) or not isinstance(edge, int) or not 0 <= edge < len(room.polygon):
            raise InputError(f"{what}: edge {edge!r} is not an edge index of room {room.name!r} "
                             f"(0..{len(room.polygon) - 1})", path)


def _door_dict(d: Door) -> dict:
    out = {"rooms": list(d.rooms), "position": d.position, "width": d.width, "height": d.height, "open": d.open}
    if d.exterior:
        out["exterior"] = True
    if d.edge is not None:
        out["edge"] = d.edge
    return out


def _window_dict(w: Window) -> dict:
    out = asdict(w)
    if w.edge is None:
        del out["edge"]
    return out


def _edge_from(x: dict) -> Optional[int]:
    e = x.get("edge")
    if e is None:
        return None
    if isinstance(e, bool) or not isinstance(e, (int, float)) or float(e) != int(e):
        raise ValueError(f"'edge' must be a whole number, not {e!r}")
    return int(e)


def _door_from(x: dict, path) -> Door:
    rooms = tuple(map(str, x["rooms"]))
    if "exterior" in x and bool(x["exterior"]) != (len(rooms) == 1):
        raise InputError(f"door {rooms!r}: 'exterior': {bool(x['exterior'])} needs "
                         f"{'one room' if x['exterior'] else 'two rooms'}", path)
    return Door(rooms, float(x.get("position", 0.5)), float(x.get("width", 0.9)), float(x.get("height", 2.1)),
                bool(x.get("open", True)), _edge_from(x))


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
