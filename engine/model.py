"""``BuildingModel``: the one model type every consumer reads.

The reconstruction (Manhattan grammar, cells + rjMCMC), the synthetic ground truth, the IFC
reader, the Blender bridge, the evaluation and the change detection all produce or consume
this type. It holds:

* storeys (elevation, floor and ceiling heights);
* shapes — each with an id, a scope (oriented box), polyhedral geometry (vertices and
  polygonal faces), a type (interior space, wall, exterior, door, slab, none), a terminal
  flag, an active flag (merged parts stay in the model, inactive), parent/children
  (containment), support figures (point-on-face index, coverage, ...) and a log of the
  rules that produced it;
* relations — adjacency and connectivity between shapes (with the wall or door they go
  through, when there is one);
* the transform back to the input frame (alignment and offset removal undone);
* provenance (method, parameters, seed, timings, search trace).

The model is immutable: editing functions (reclassify, insert a door) return a new model,
so undo is trivial. Geometry is in metres, in the *aligned* frame of the reconstruction;
``to_input_frame`` maps points back.

JSON round trip: :meth:`BuildingModel.to_json` / :meth:`BuildingModel.from_json`, with
``SCHEMA_VERSION``.
"""
from __future__ import annotations

import enum
import json
import os
from dataclasses import dataclass, field, replace
from typing import Any, Iterable, Iterator, Mapping, Optional, Sequence

import numpy as np

from .errors import FormatError, InputError
from .fileutil import atomic_write_text
from .geometry.boxes import min_area_box
from .geometry.polygon import (area_3d, newell_normal, plan_area_perimeter, polyhedron_volume,
                               prism_footprint, signed_area, triangulate_faces)
from .geometry.transforms import to_input_frame
from .jsonfields import (Malformed, as_array, as_flag, as_integer, as_number, as_numbers, as_object, as_text,
                         error_text, json_kind, jsonable, member, parse_json)

__all__ = ["SCHEMA_VERSION", "ShapeType", "Scope", "Polyhedron", "Shape", "Storey", "Relation", "Surface",
           "Provenance", "BuildingModel"]

SCHEMA_VERSION = 1
"""Version of the JSON layout written by :meth:`BuildingModel.to_dict`."""

_VERTICAL_NZ = 0.17364817766693033  # sin(10°): |n_z| below this is a vertical face


class ShapeType(str, enum.Enum):
    """Semantic type of a shape (docs/method.md §2: ∅, interior space, exterior space, wall;
    and the building elements: doors (and doorless openings), windows, slabs)."""

    NONE = "none"
    INTERIOR = "interior"
    EXTERIOR = "exterior"
    WALL = "wall"
    DOOR = "door"
    WINDOW = "window"
    SLAB = "slab"

    @classmethod
    def parse(cls, value) -> "ShapeType":
        """Accept a ShapeType, its value or its name (case-insensitive)."""
        if isinstance(value, cls):
            return value
        v = str(value).strip().lower()
        for t in cls:
            if v in (t.value, t.name.lower()):
                return t
        raise ValueError(f"unknown shape type {value!r}; expected one of {[t.value for t in cls]}")


def _ro(a, dtype=np.float64, shape=None) -> np.ndarray:
    a = np.array(a, dtype=dtype)
    if shape is not None:
        a = a.reshape(shape)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Scope:
    """Oriented bounding box of a shape (thesis: corner P, axes X, Y, Z, size S).

    Attributes
    ----------
    origin : (3,) float64
        Corner P, metres.
    axes : (3, 3) float64
        Rows are the unit axes X, Y, Z (right-handed; Z is up for the shapes we make).
    size : (3,) float64
        Extent along each axis, metres (>= 0).
    """

    origin: np.ndarray
    axes: np.ndarray
    size: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "origin", _ro(self.origin, shape=3))
        object.__setattr__(self, "axes", _ro(self.axes, shape=(3, 3)))
        object.__setattr__(self, "size", _ro(self.size, shape=3))

    @property
    def center(self) -> np.ndarray:
        """(3,) float64 — centre of the box, metres."""
        return self.origin + self.axes.T @ (self.size / 2)

    @property
    def width(self) -> float:
        """Smaller horizontal side (used by the rjMCMC prior), metres."""
        return float(min(self.size[0], self.size[1]))

    @classmethod
    def of_points(cls, vertices: np.ndarray) -> "Scope":
        """The minimum-area oriented box of ``vertices`` about the z axis.

        ``vertices`` : (n, 3) float64. Degenerate input (no vertices) gives a zero box.
        """
        return cls(*min_area_box(vertices))

    def to_dict(self) -> dict:
        return {"origin": self.origin.tolist(), "axes": self.axes.tolist(), "size": self.size.tolist()}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "scope") -> "Scope":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = as_object(d, where)
        return cls(as_numbers(member(d, "origin", where), f"{where}.origin", (3,)),
                   as_numbers(member(d, "axes", where), f"{where}.axes", (3, 3)),
                   as_numbers(member(d, "size", where), f"{where}.size", (3,)))


@dataclass(frozen=True, eq=False)
class Polyhedron:
    """Boundary representation {V, F}.

    Attributes
    ----------
    vertices : (n, 3) float64
        Metres.
    faces : tuple of tuple of int
        Planar polygons, vertex indices in counter-clockwise order seen from outside
        (outward normals).
    """

    vertices: np.ndarray
    faces: tuple

    def __post_init__(self):
        object.__setattr__(self, "vertices", _ro(self.vertices, shape=(-1, 3)))
        object.__setattr__(self, "faces", tuple(tuple(int(i) for i in f) for f in self.faces))

    # -------------------------------------------------------------- builders
    @classmethod
    def prism(cls, footprint: Sequence[Sequence[float]], zmin: float, zmax: float) -> "Polyhedron":
        """A vertical prism over a simple polygon.

        ``footprint`` : (k, 2) float64, metres, any orientation (made counter-clockwise);
        a repeated closing vertex is dropped. Faces: bottom, top, then one side per edge
        (side ``i`` runs from footprint vertex ``i`` to ``i+1``).
        """
        fp = np.asarray(footprint, dtype=np.float64).reshape(-1, 2)
        if len(fp) > 1 and np.allclose(fp[0], fp[-1]):
            fp = fp[:-1]
        if len(fp) < 3:
            raise ValueError("a prism needs a footprint of at least 3 vertices")
        if signed_area(fp) < 0:
            fp = fp[::-1]
        k = len(fp)
        verts = np.vstack([np.column_stack([fp, np.full(k, zmin)]), np.column_stack([fp, np.full(k, zmax)])])
        bottom = tuple(range(k - 1, -1, -1))
        top = tuple(range(k, 2 * k))
        sides = tuple((i, (i + 1) % k, k + (i + 1) % k, k + i) for i in range(k))
        return cls(verts, (bottom, top) + sides)

    @classmethod
    def box(cls, lo: Sequence[float], hi: Sequence[float]) -> "Polyhedron":
        """Axis-aligned cuboid between corners ``lo`` and ``hi`` (metres)."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        return cls.prism([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], z0, z1)

    # -------------------------------------------------------------- queries
    def face_vertices(self, i: int) -> np.ndarray:
        """(k, 3) float64 — the vertices of face ``i``."""
        return self.vertices[list(self.faces[i])]

    def face_normal(self, i: int) -> np.ndarray:
        """(3,) float64 — unit outward normal of face ``i`` (Newell's method)."""
        return newell_normal(self.face_vertices(i))

    def face_area(self, i: int) -> float:
        """Area of face ``i`` in m²."""
        return area_3d(self.face_vertices(i))

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 — axis-aligned min and max corner."""
        if len(self.vertices) == 0:
            return np.zeros((2, 3))
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def footprint(self) -> Optional[np.ndarray]:
        """(k, 2) float64 counter-clockwise footprint if this is a vertical prism, else None.

        A prism here is what :meth:`prism` builds: a horizontal bottom face, a horizontal
        top face with the same outline, vertical sides.
        """
        return prism_footprint(self.vertices, self.faces)

    def plan_area_perimeter(self) -> tuple[float, float]:
        """Area (m²) and perimeter (m) of the horizontal projection (the plan outline).

        A prism's footprint directly; any other solid (a room made of several parts, a
        sloped ceiling) through the union of its projected triangles. 0, 0 for an empty one.
        """
        return plan_area_perimeter(self.vertices, self.faces)

    def volume(self) -> float:
        """Enclosed volume in m³ (divergence theorem; faces must be closed and outward)."""
        return polyhedron_volume(self.vertices, self.faces)

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """Fan-triangulated mesh: ``(vertices (n,3) float64, triangles (m,3) int64)``.

        Faces must be convex for a fan to be right; non-convex faces are triangulated
        by ear clipping on their plane.
        """
        return self.vertices, triangulate_faces(self.vertices, self.faces)

    def to_dict(self) -> dict:
        return {"vertices": self.vertices.tolist(), "faces": [list(f) for f in self.faces]}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "geometry") -> "Polyhedron":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed
        (vertices not (n, 3) finite numbers, faces not polygons of at least 3 valid indices)."""
        d = as_object(d, where)
        v = as_numbers(member(d, "vertices", where), f"{where}.vertices", (-1, 3))
        faces = []
        for k, face in enumerate(as_array(member(d, "faces", where), f"{where}.faces")):
            w = f"{where}.faces[{k}]"
            idx = as_array(face, w)
            if len(idx) < 3:
                raise Malformed(f"{w} has {len(idx)} vertices; a face needs at least 3")
            if any(isinstance(i, bool) or not isinstance(i, (int, np.integer)) for i in idx):
                raise Malformed(f"{w} must hold vertex indices (whole numbers)")
            lo, hi = min(idx), max(idx)
            if lo < 0 or hi >= len(v):
                bad = lo if lo < 0 else hi
                raise Malformed(f"{w} has vertex index {bad}, out of range for {len(v)} vertices")
            faces.append(idx)
        return cls(v, faces)


@dataclass(frozen=True, eq=False)
class Shape:
    """One shape of the grammar: a cuboid, a cell, a merged space, a wall, a door, a slab.

    Attributes
    ----------
    id : str
        Unique within the model.
    type : ShapeType
    geometry : Polyhedron
    scope : Scope
        Oriented bounding box (computed from the geometry when not given).
    storey : int
        Index into ``BuildingModel.storeys`` (-1 when it spans or belongs to none).
    name : str
        Human label ("Room 1", "Corridor", "Wall 12").
    terminal : bool
        A terminal shape takes no further rules (walls, exteriors, final spaces).
    active : bool
        False for parts of a merged shape: kept for fine-grained queries (sub-spaces),
        hidden from the room-level view.
    parent : str or None
        Containing shape (a merged space for its parts, a wall for its door).
    children : tuple of str
        Contained shapes.
    grid : tuple of int or None
        (i, j, k) histogram-interval indices of a Manhattan cuboid.
    support : dict of str -> float
        Figures from the data: ``ipof_top``, ``ipof_sides``, ``coverage``, ...
    attributes : dict
        Other facts (a door's ``width``/``height``/``sill``, a wall's ``thickness``, ...).
    log : tuple of str
        The rules that produced or changed this shape, in order, with their figures —
        so a person can see why a shape got its type.
    """

    id: str
    type: ShapeType
    geometry: Polyhedron
    scope: Optional[Scope] = None
    storey: int = 0
    name: str = ""
    terminal: bool = False
    active: bool = True
    parent: Optional[str] = None
    children: tuple = ()
    grid: Optional[tuple] = None
    support: Mapping[str, float] = field(default_factory=dict)
    attributes: Mapping[str, Any] = field(default_factory=dict)
    log: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "type", ShapeType.parse(self.type))
        if self.scope is None:
            object.__setattr__(self, "scope", Scope.of_points(self.geometry.vertices))
        object.__setattr__(self, "children", tuple(self.children))
        if self.grid is not None:
            object.__setattr__(self, "grid", tuple(int(g) for g in self.grid))
        object.__setattr__(self, "support", {k: float(v) for k, v in dict(self.support).items()})
        object.__setattr__(self, "attributes", dict(self.attributes))
        object.__setattr__(self, "log", tuple(self.log))

    def with_(self, **changes) -> "Shape":
        """A copy with some fields replaced."""
        return replace(self, **changes)

    def logged(self, entry: str, **changes) -> "Shape":
        """A copy with ``entry`` appended to the rule log (and other fields replaced)."""
        return replace(self, log=self.log + (entry,), **changes)

    @property
    def is_space(self) -> bool:
        return self.type in (ShapeType.INTERIOR, ShapeType.EXTERIOR)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 — axis-aligned min and max corner, metres."""
        return self.geometry.bounds

    @property
    def centroid(self) -> np.ndarray:
        """(3,) float64 — mean of the vertices, metres."""
        return self.geometry.vertices.mean(axis=0)

    def footprint(self) -> Optional[np.ndarray]:
        """(k, 2) float64 counter-clockwise footprint of a vertical prism, metres, else None."""
        return self.geometry.footprint()

    def to_dict(self) -> dict:
        return {
            "id": self.id,
            "type": self.type.value,
            "name": self.name,
            "storey": self.storey,
            "terminal": self.terminal,
            "active": self.active,
            "parent": self.parent,
            "children": list(self.children),
            "grid": None if self.grid is None else list(self.grid),
            "scope": self.scope.to_dict(),
            "geometry": self.geometry.to_dict(),
            "support": dict(self.support),
            "attributes": jsonable(self.attributes),
            "log": list(self.log),
        }

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "shape") -> "Shape":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = as_object(d, where)
        sid = as_text(member(d, "id", where), f"{where}.id")
        where = f"{where} ({sid!r})"
        kind = as_text(member(d, "type", where), f"{where}.type")
        try:
            kind = ShapeType.parse(kind)
        except ValueError as e:
            raise Malformed(f"{where}.type: {e}") from None
        scope = d.get("scope")
        grid = d.get("grid")
        support = as_object(d.get("support", {}), f"{where}.support")
        return cls(
            id=sid,
            type=kind,
            geometry=Polyhedron.from_dict(member(d, "geometry", where), f"{where}.geometry"),
            scope=Scope.from_dict(scope, f"{where}.scope") if scope else None,
            storey=as_integer(d.get("storey", 0), f"{where}.storey"),
            name=as_text(d.get("name", ""), f"{where}.name", optional=True) or "",
            terminal=as_flag(d.get("terminal", False), f"{where}.terminal"),
            active=as_flag(d.get("active", True), f"{where}.active"),
            parent=as_text(d.get("parent"), f"{where}.parent", optional=True),
            children=tuple(as_text(c, f"{where}.children[{i}]")
                           for i, c in enumerate(as_array(d.get("children", []), f"{where}.children"))),
            grid=None if grid is None else tuple(as_integer(g, f"{where}.grid[{i}]")
                                                 for i, g in enumerate(as_array(grid, f"{where}.grid"))),
            support={as_text(k, f"{where}.support key"): as_number(v, f"{where}.support[{k!r}]", finite=False)
                     for k, v in support.items()},
            attributes=as_object(d.get("attributes", {}), f"{where}.attributes"),
            log=tuple(as_text(e, f"{where}.log[{i}]")
                      for i, e in enumerate(as_array(d.get("log", []), f"{where}.log"))),
        )


@dataclass(frozen=True)
class Storey:
    """A storey: floor and ceiling heights in metres (aligned frame), and its elevation.

    ``elevation`` is the floor height written to IFC (usually ``floor_z`` in the input
    frame).
    """

    index: int
    floor_z: float
    ceiling_z: float
    name: str = ""
    elevation: Optional[float] = None

    @property
    def height(self) -> float:
        """Floor-to-ceiling height, metres."""
        return self.ceiling_z - self.floor_z

    def to_dict(self) -> dict:
        return {"index": self.index, "name": self.name, "floor_z": self.floor_z,
                "ceiling_z": self.ceiling_z, "elevation": self.elevation}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "storey") -> "Storey":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = as_object(d, where)
        elev = d.get("elevation")
        return cls(as_integer(member(d, "index", where), f"{where}.index"),
                   as_number(member(d, "floor_z", where), f"{where}.floor_z"),
                   as_number(member(d, "ceiling_z", where), f"{where}.ceiling_z"),
                   as_text(d.get("name", ""), f"{where}.name", optional=True) or "",
                   None if elev is None else as_number(elev, f"{where}.elevation"))


RELATION_KINDS = ("adjacency", "connectivity")


@dataclass(frozen=True)
class Relation:
    """A topological relation between two shapes (unordered).

    ``kind`` : "adjacency" (sharing a face, or a wall between two spaces) or
    "connectivity" (a person can walk from one to the other: an open common face, or a
    door). ``via`` : id of the wall (adjacency) or door (connectivity) between them, if any.
    """

    kind: str
    a: str
    b: str
    via: Optional[str] = None

    def __post_init__(self):
        if self.kind not in RELATION_KINDS:
            raise ValueError(f"unknown relation kind {self.kind!r}")
        if self.b < self.a:  # canonical order: unordered pair
            a, b = self.b, self.a
            object.__setattr__(self, "a", a)
            object.__setattr__(self, "b", b)

    def other(self, shape_id: str) -> str:
        return self.b if shape_id == self.a else self.a

    def to_dict(self) -> dict:
        return {"kind": self.kind, "a": self.a, "b": self.b, "via": self.via}


@dataclass(frozen=True, eq=False)
class Surface:
    """A planar face of a shape, labelled for comparison (evaluation, change detection).

    ``kind`` : "wall" (vertical), "floor" (faces down, the bottom of a space) or
    "ceiling" (faces up, the top of a space); for solid walls and slabs the labels follow
    the outward normal the same way. ``polygon`` : (k, 3) float64, metres.
    """

    shape_id: str
    face: int
    kind: str
    polygon: np.ndarray
    normal: np.ndarray
    storey: int
    shape_type: ShapeType

    @property
    def area(self) -> float:
        """Area in m²."""
        return area_3d(self.polygon)

    @property
    def offset(self) -> float:
        """ρ in ``nᵀp = ρ``, metres."""
        return float(self.normal @ self.polygon[0])


@dataclass(frozen=True)
class Provenance:
    """How a model was made: method, parameters, seed, timings, search trace."""

    method: str = ""
    parameters: Mapping[str, Any] = field(default_factory=dict)
    seed: Optional[int] = None
    timings: Mapping[str, float] = field(default_factory=dict)
    trace: Mapping[str, Any] = field(default_factory=dict)
    source: str = ""
    software: str = ""

    def to_dict(self) -> dict:
        return {"method": self.method, "parameters": jsonable(self.parameters), "seed": self.seed,
                "timings": dict(self.timings), "trace": jsonable(self.trace),
                "source": self.source, "software": self.software}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "provenance") -> "Provenance":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = as_object(d, where)
        seed = d.get("seed")
        timings = as_object(d.get("timings", {}), f"{where}.timings")
        return cls(as_text(d.get("method", ""), f"{where}.method", optional=True) or "",
                   as_object(d.get("parameters", {}), f"{where}.parameters"),
                   None if seed is None else as_integer(seed, f"{where}.seed"),
                   {as_text(k, f"{where}.timings key"): as_number(v, f"{where}.timings[{k!r}]", finite=False)
                    for k, v in timings.items()},
                   as_object(d.get("trace", {}) or {}, f"{where}.trace"),
                   as_text(d.get("source", ""), f"{where}.source", optional=True) or "",
                   as_text(d.get("software", ""), f"{where}.software", optional=True) or "")


@dataclass(frozen=True, eq=False)
class BuildingModel:
    """An indoor building model: storeys, shapes and their topology.

    Attributes
    ----------
    shapes : tuple of Shape
        Every shape, active or not, in a stable order.
    storeys : tuple of Storey
    relations : tuple of Relation
    transform : (4, 4) float64
        Maps the model's (aligned) frame to the input frame *after* offset removal:
        ``p_input = transform @ p_model``; the identity when nothing was aligned.
    offset : (3,) float64
        Global offset removed from the input (``p_file = p_input + offset``).
    provenance : Provenance
    name : str
    """

    shapes: tuple = ()
    storeys: tuple = ()
    relations: tuple = ()
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    provenance: Provenance = field(default_factory=Provenance)
    name: str = ""

    def __post_init__(self):
        shapes = tuple(self.shapes)
        ids = [s.id for s in shapes]
        if len(set(ids)) != len(ids):
            dup = sorted({i for i in ids if ids.count(i) > 1})
            raise ValueError(f"duplicate shape ids: {dup[:5]}")
        object.__setattr__(self, "shapes", shapes)
        object.__setattr__(self, "storeys", tuple(self.storeys))
        rel = tuple(dict.fromkeys(self.relations))  # drop duplicates, keep order
        object.__setattr__(self, "relations", rel)
        object.__setattr__(self, "transform", _ro(self.transform, shape=(4, 4)))
        object.__setattr__(self, "offset", _ro(self.offset, shape=3))
        object.__setattr__(self, "_index", {s.id: s for s in shapes})

    # ---------------------------------------------------------------- access
    def __getitem__(self, shape_id: str) -> Shape:
        try:
            return self._index[shape_id]
        except KeyError:
            raise KeyError(f"no shape with id {shape_id!r}") from None

    def __contains__(self, shape_id: str) -> bool:
        return shape_id in self._index

    def __iter__(self) -> Iterator[Shape]:
        return iter(self.shapes)

    def __len__(self) -> int:
        return len(self.shapes)

    def get(self, shape_id: str) -> Optional[Shape]:
        return self._index.get(shape_id)

    def of_type(self, *types, active: Optional[bool] = True) -> list[Shape]:
        """Shapes of the given types; ``active=None`` includes inactive parts too."""
        ts = {ShapeType.parse(t) for t in types}
        return [s for s in self.shapes if s.type in ts and (active is None or s.active == active)]

    @property
    def spaces(self) -> list[Shape]:
        """Active interior spaces (rooms, corridors)."""
        return self.of_type(ShapeType.INTERIOR)

    @property
    def walls(self) -> list[Shape]:
        return self.of_type(ShapeType.WALL)

    doors = property(lambda self: self.of_type(ShapeType.DOOR), doc="Active doors and doorless openings.")
    windows = property(lambda self: self.of_type(ShapeType.WINDOW), doc="Active windows.")
    slabs = property(lambda self: self.of_type(ShapeType.SLAB), doc="Active slabs.")

    def leaves(self, shape_id: str) -> list[Shape]:
        """The innermost parts of a shape (itself when it has no children of its type)."""
        s = self[shape_id]
        parts = [self[c] for c in s.children if c in self and self[c].type == s.type]
        if not parts:
            return [s]
        out = []
        for p in parts:
            out.extend(self.leaves(p.id))
        return out

    def top_level(self, shape_id: str) -> Shape:
        """The outermost shape of the same type containing ``shape_id`` (itself if none)."""
        s = self[shape_id]
        while s.parent is not None and s.parent in self and self[s.parent].type == s.type:
            s = self[s.parent]
        return s

    def relations_of(self, kind: str, shape_id: Optional[str] = None) -> list[Relation]:
        return [r for r in self.relations if r.kind == kind and (shape_id is None or shape_id in (r.a, r.b))]

    # ---------------------------------------------------------------- editing
    def with_(self, **changes) -> "BuildingModel":
        return replace(self, **changes)

    def replace_shapes(self, *shapes: Shape, remove: Iterable[str] = ()) -> "BuildingModel":
        """A new model with shapes replaced by id (new ids are appended) and some removed."""
        remove = set(remove)
        new = {s.id: s for s in shapes}
        out = [new.pop(s.id, s) for s in self.shapes if s.id not in remove]
        out.extend(new.values())
        return replace(self, shapes=tuple(out))

    # ---------------------------------------------------------------- geometry
    def to_input_frame(self, points: np.ndarray, include_offset: bool = False) -> np.ndarray:
        """Map (n, 3) model-frame points to the input frame (optionally adding the offset)."""
        return to_input_frame(points, self.transform, self.offset if include_offset else None)

    def surfaces(self, types: Iterable = (ShapeType.INTERIOR,), active: Optional[bool] = True,
                 leaves: bool = False) -> list[Surface]:
        """Planar faces of shapes, labelled wall/floor/ceiling by their outward normal.

        Parameters
        ----------
        types : shape types whose faces are wanted (default: interior spaces).
        active : True for the room-level view, None for every shape.
        leaves : when True, faces of the innermost parts (sub-spaces) instead of the
            merged spaces.
        """
        ts = {ShapeType.parse(t) for t in types}
        chosen = []
        for s in self.shapes:
            if s.type not in ts:
                continue
            if leaves:
                if any(c in self and self[c].type == s.type for c in s.children):
                    continue
            elif active is not None and s.active != active:
                continue
            chosen.append(s)
        out = []
        for s in chosen:
            g = s.geometry
            for i in range(len(g.faces)):
                n = g.face_normal(i)
                if abs(n[2]) <= _VERTICAL_NZ:
                    kind = "wall"
                elif n[2] > 0:
                    kind = "ceiling"
                else:
                    kind = "floor"
                out.append(Surface(s.id, i, kind, g.face_vertices(i), n, s.storey, s.type))
        return out

    # ---------------------------------------------------------------- JSON
    def to_dict(self) -> dict:
        return {
            "schema": "indoor-building-model",
            "schema_version": SCHEMA_VERSION,
            "name": self.name,
            "storeys": [s.to_dict() for s in self.storeys],
            "shapes": [s.to_dict() for s in self.shapes],
            "relations": [r.to_dict() for r in self.relations],
            "transform": self.transform.tolist(),
            "offset": self.offset.tolist(),
            "provenance": self.provenance.to_dict(),
        }

    @classmethod
    def from_dict(cls, d: Mapping, path: Optional[str | os.PathLike] = None) -> "BuildingModel":
        """Read :meth:`to_dict` output.

        Raises
        ------
        FormatError (naming ``path``) — ``d`` is not a model: not an object, no or another
        ``schema``, a newer ``schema_version``, a missing key, a value of the wrong type,
        geometry that is not a polyhedron (non-finite vertices, face indices out of range),
        duplicate shape ids.
        """
        if not isinstance(d, Mapping):
            raise FormatError(f"not a building-model JSON: the top level is {json_kind(d)}, not an object "
                              "with 'schema': 'indoor-building-model'", path)
        if d.get("schema") != "indoor-building-model":
            raise FormatError("not a building-model JSON (no 'schema': 'indoor-building-model')", path)
        v = d.get("schema_version")
        if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= SCHEMA_VERSION:
            raise FormatError(f"unsupported schema version {v!r} (this build reads up to {SCHEMA_VERSION})",
                              path)
        try:
            return cls._from_checked_dict(d)
        except (KeyError, TypeError, ValueError, IndexError) as e:
            raise FormatError(f"malformed building-model JSON: {error_text(e)}", path) from None

    @classmethod
    def _from_checked_dict(cls, d: Mapping) -> "BuildingModel":
        shapes = [Shape.from_dict(s, f"shapes[{i}]")
                  for i, s in enumerate(as_array(d.get("shapes", []), "shapes"))]
        storeys = [Storey.from_dict(s, f"storeys[{i}]")
                   for i, s in enumerate(as_array(d.get("storeys", []), "storeys"))]
        relations = []
        for i, r in enumerate(as_array(d.get("relations", []), "relations")):
            w = f"relations[{i}]"
            r = as_object(r, w)
            kind = as_text(member(r, "kind", w), f"{w}.kind")
            if kind not in RELATION_KINDS:
                raise Malformed(f"{w}.kind is {kind!r}; expected one of {list(RELATION_KINDS)}")
            a, b = as_text(member(r, "a", w), f"{w}.a"), as_text(member(r, "b", w), f"{w}.b")
            relations.append(Relation(kind, a, b, as_text(r.get("via"), f"{w}.via", optional=True)))
        transform = d.get("transform")
        offset = d.get("offset")
        return cls(
            shapes=tuple(shapes),
            storeys=tuple(storeys),
            relations=tuple(relations),
            transform=np.eye(4) if transform is None else as_numbers(transform, "transform", (4, 4)),
            offset=np.zeros(3) if offset is None else as_numbers(offset, "offset", (3,)),
            provenance=Provenance.from_dict(d.get("provenance") or {}),
            name=as_text(d.get("name", ""), "name", optional=True) or "",
        )

    def to_json(self, path: Optional[str | os.PathLike] = None, indent: Optional[int] = None) -> str:
        """Serialise; when ``path`` is given, write atomically (temporary name, then move)."""
        text = json.dumps(self.to_dict(), indent=indent)
        if path is not None:
            atomic_write_text(path, text)
        return text

    @classmethod
    def from_json(cls, source: str | os.PathLike) -> "BuildingModel":
        """Read a model from a JSON file path (or a JSON string starting with '{').

        Raises
        ------
        InputError — the file is missing, a folder or unreadable.
        FormatError (naming the file) — empty, not UTF-8, not JSON, truncated JSON, or JSON
        that is not a model (see :meth:`from_dict`).
        """
        if isinstance(source, str) and source.lstrip().startswith("{"):
            return cls.from_dict(parse_json(source, None))
        path = os.fspath(source)
        if not os.path.exists(path):
            raise InputError("file not found", path)
        if os.path.isdir(path):
            raise InputError("is a folder, not a file", path)
        try:
            with open(path, "rb") as f:
                data = f.read()
        except OSError as e:
            raise InputError(f"cannot read the file: {e.strerror or e}", path) from None
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise FormatError(f"not UTF-8 text (byte 0x{data[e.start]:02x} at offset {e.start}); "
                              "a model JSON is UTF-8", path) from None
        return cls.from_dict(parse_json(text, path), path)

    def summary(self) -> dict:
        """JSON-ready counts: storeys, spaces, walls, doors, relations."""
        return {
            "storeys": len(self.storeys),
            "spaces": len(self.spaces),
            "sub_spaces": len([s for s in self.of_type(ShapeType.INTERIOR, active=None)]),
            "walls": len(self.walls),
            "doors": len(self.doors),
            "windows": len(self.windows),
            "slabs": len(self.slabs),
            "exterior": len(self.of_type(ShapeType.EXTERIOR)),
            "adjacency": len(self.relations_of("adjacency")),
            "connectivity": len(self.relations_of("connectivity")),
        }
