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

__all__ = [
    "SCHEMA_VERSION",
    "ShapeType",
    "Scope",
    "Polyhedron",
    "Shape",
    "Storey",
    "Relation",
    "Surface",
    "Provenance",
    "BuildingModel",
]

SCHEMA_VERSION = 1
"""Version of the JSON layout written by :meth:`BuildingModel.to_dict`."""

_VERTICAL_NZ = 0.17364817766693033  # sin(10°): |n_z| below this is a vertical face


class ShapeType(str, enum.Enum):
    """Semantic type of a shape (SPEC.md §2: ∅, interior space, exterior space, wall)."""

    NONE = "none"
    INTERIOR = "interior"
    EXTERIOR = "exterior"
    WALL = "wall"
    DOOR = "door"
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


# ----------------------------------------------------------------------------- JSON checks
class _Malformed(ValueError):
    """A field of a model JSON has the wrong type or value; the message says where."""


_REQUIRED = object()


def _json_kind(v) -> str:
    """The JSON name of the type of ``v`` (for messages)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, (list, tuple)):
        return "an array"
    if isinstance(v, Mapping):
        return "an object"
    return type(v).__name__


def _obj(v, where: str) -> Mapping:
    if not isinstance(v, Mapping):
        raise _Malformed(f"{where} must be an object, not {_json_kind(v)}")
    return v


def _get(d: Mapping, key: str, where: str, default=_REQUIRED):
    if key in d:
        return d[key]
    if default is _REQUIRED:
        raise _Malformed(f"{where} has no {key!r}")
    return default


def _text(v, where: str, optional: bool = False):
    if v is None and optional:
        return None
    if not isinstance(v, str):
        raise _Malformed(f"{where} must be a string, not {_json_kind(v)}")
    return v


def _integer(v, where: str) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        if isinstance(v, float) and v.is_integer():
            return int(v)
        raise _Malformed(f"{where} must be a whole number, not {_json_kind(v)}")
    return int(v)


def _flag(v, where: str) -> bool:
    if isinstance(v, bool) or (isinstance(v, int) and v in (0, 1)):
        return bool(v)
    raise _Malformed(f"{where} must be true or false, not {_json_kind(v)}")


def _number(v, where: str, finite: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise _Malformed(f"{where} must be a number, not {_json_kind(v)}")
    x = float(v)
    if finite and not np.isfinite(x):
        raise _Malformed(f"{where} must be finite, not {x}")
    return x


def _array(v, where: str) -> list:
    if not isinstance(v, (list, tuple)):
        raise _Malformed(f"{where} must be an array, not {_json_kind(v)}")
    return list(v)


def _numbers(v, where: str, shape: tuple) -> np.ndarray:
    """float64 array of ``shape`` (-1 for any length) from nested arrays of finite numbers."""
    if not isinstance(v, (list, tuple, np.ndarray)):
        raise _Malformed(f"{where} must be an array, not {_json_kind(v)}")
    try:
        a = np.asarray(v)
    except ValueError:  # ragged
        raise _Malformed(f"{where} must be an array of shape {_shape_text(shape)} (rows differ in length)") \
            from None
    if a.size == 0 and -1 in shape:
        return np.zeros([0 if n == -1 else n for n in shape], dtype=np.float64)
    if a.dtype.kind not in "iuf":
        raise _Malformed(f"{where} must hold numbers only")
    if a.ndim != len(shape) or any(n != -1 and n != m for n, m in zip(shape, a.shape)):
        raise _Malformed(f"{where} must be an array of shape {_shape_text(shape)}, "
                         f"not {_shape_text(a.shape)}")
    a = a.astype(np.float64)
    if not np.isfinite(a).all():
        raise _Malformed(f"{where} holds non-finite numbers")
    return a


def _shape_text(shape) -> str:
    return "(" + ", ".join("n" if n == -1 else str(n) for n in shape) + ")"


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
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        if len(v) == 0:
            return cls(np.zeros(3), np.eye(3), np.zeros(3))
        zmin, zmax = v[:, 2].min(), v[:, 2].max()
        xy = v[:, :2]
        best = None
        try:
            from scipy.spatial import ConvexHull

            hull = xy[ConvexHull(xy).vertices] if len(xy) >= 3 else xy
        except Exception:  # collinear or too few points
            hull = xy
        edges = np.diff(np.vstack([hull, hull[:1]]), axis=0)
        angles = np.unique(np.round(np.mod(np.arctan2(edges[:, 1], edges[:, 0]), np.pi / 2), 9))
        if len(angles) == 0:
            angles = np.array([0.0])
        for a in angles:
            c, s = np.cos(a), np.sin(a)
            ax = np.array([[c, s], [-s, c]])
            p = hull @ ax.T
            lo, hi = p.min(axis=0), p.max(axis=0)
            area = float(np.prod(hi - lo))
            if best is None or area < best[0] - 1e-12:
                best = (area, ax, lo, hi)
        _, ax, lo, hi = best
        size2 = hi - lo
        if size2[0] < size2[1] - 1e-9:  # X along the longer side
            ax = np.array([ax[1], -ax[0]])
            p = hull @ ax.T
            lo, hi = p.min(axis=0), p.max(axis=0)
            size2 = hi - lo
        origin2 = ax.T @ lo
        axes = np.array([[ax[0, 0], ax[0, 1], 0.0], [ax[1, 0], ax[1, 1], 0.0], [0.0, 0.0, 1.0]])
        return cls(np.array([origin2[0], origin2[1], zmin]), axes, np.array([size2[0], size2[1], zmax - zmin]))

    def to_dict(self) -> dict:
        return {"origin": self.origin.tolist(), "axes": self.axes.tolist(), "size": self.size.tolist()}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "scope") -> "Scope":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = _obj(d, where)
        return cls(_numbers(_get(d, "origin", where), f"{where}.origin", (3,)),
                   _numbers(_get(d, "axes", where), f"{where}.axes", (3, 3)),
                   _numbers(_get(d, "size", where), f"{where}.size", (3,)))


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
        x, y = fp[:, 0], fp[:, 1]
        if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:
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
        v = self.face_vertices(i)
        w = np.roll(v, -1, axis=0)
        n = np.array([
            np.sum((v[:, 1] - w[:, 1]) * (v[:, 2] + w[:, 2])),
            np.sum((v[:, 2] - w[:, 2]) * (v[:, 0] + w[:, 0])),
            np.sum((v[:, 0] - w[:, 0]) * (v[:, 1] + w[:, 1])),
        ])
        norm = np.linalg.norm(n)
        return n / norm if norm > 0 else n

    def face_area(self, i: int) -> float:
        """Area of face ``i`` in m²."""
        v = self.face_vertices(i)
        w = np.roll(v, -1, axis=0)
        return float(np.linalg.norm(np.cross(v, w).sum(axis=0)) / 2)

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
        bottoms = [i for i in range(len(self.faces)) if self.face_normal(i)[2] < -0.999]
        tops = [i for i in range(len(self.faces)) if self.face_normal(i)[2] > 0.999]
        if len(bottoms) != 1 or len(tops) != 1:
            return None
        for i in range(len(self.faces)):
            if i not in (bottoms[0], tops[0]) and abs(self.face_normal(i)[2]) > 1e-6:
                return None
        b = self.face_vertices(bottoms[0])[::-1, :2]
        t = self.face_vertices(tops[0])[:, :2]
        if len(b) != len(t):
            return None
        return b

    def plan_area_perimeter(self) -> tuple[float, float]:
        """Area (m²) and perimeter (m) of the horizontal projection (the plan outline).

        A prism's footprint directly; any other solid (a room made of several parts, a
        sloped ceiling) through the union of its projected triangles. 0, 0 for an empty one.
        """
        from shapely.geometry import Polygon
        from shapely.ops import unary_union

        fp = self.footprint()
        if fp is not None:
            poly = Polygon(fp)
        else:
            v, t = self.triangles()
            tris = [Polygon(v[i, :2]) for i in t]
            poly = unary_union([p for p in tris if p.area > 0])
        if poly.is_empty:
            return 0.0, 0.0
        return float(poly.area), float(poly.length)

    def volume(self) -> float:
        """Enclosed volume in m³ (divergence theorem; faces must be closed and outward)."""
        vol = 0.0
        for f in self.faces:
            v = self.vertices[list(f)]
            for j in range(1, len(v) - 1):
                vol += float(np.dot(v[0], np.cross(v[j], v[j + 1])))
        return abs(vol) / 6.0

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """Fan-triangulated mesh: ``(vertices (n,3) float64, triangles (m,3) int64)``.

        Faces must be convex for a fan to be right; non-convex faces are triangulated
        by ear clipping on their plane.
        """
        tris = []
        for f in self.faces:
            tris.extend(_triangulate_face(self.vertices, f))
        return self.vertices, np.asarray(tris, dtype=np.int64).reshape(-1, 3)

    def to_dict(self) -> dict:
        return {"vertices": self.vertices.tolist(), "faces": [list(f) for f in self.faces]}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "geometry") -> "Polyhedron":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed
        (vertices not (n, 3) finite numbers, faces not polygons of at least 3 valid indices)."""
        d = _obj(d, where)
        v = _numbers(_get(d, "vertices", where), f"{where}.vertices", (-1, 3))
        faces = []
        for k, face in enumerate(_array(_get(d, "faces", where), f"{where}.faces")):
            w = f"{where}.faces[{k}]"
            idx = _array(face, w)
            if len(idx) < 3:
                raise _Malformed(f"{w} has {len(idx)} vertices; a face needs at least 3")
            if any(isinstance(i, bool) or not isinstance(i, (int, np.integer)) for i in idx):
                raise _Malformed(f"{w} must hold vertex indices (whole numbers)")
            lo, hi = min(idx), max(idx)
            if lo < 0 or hi >= len(v):
                bad = lo if lo < 0 else hi
                raise _Malformed(f"{w} has vertex index {bad}, out of range for {len(v)} vertices")
            faces.append(idx)
        return cls(v, faces)


def _triangulate_face(vertices: np.ndarray, face: Sequence[int]) -> list[tuple[int, int, int]]:
    idx = list(face)
    if len(idx) == 3:
        return [tuple(idx)]
    v = vertices[idx]
    w = np.roll(v, -1, axis=0)
    n = np.cross(v, w).sum(axis=0)
    # project to the plane's dominant axes
    drop = int(np.argmax(np.abs(n)))
    keep = [a for a in range(3) if a != drop]
    p = v[:, keep]
    sign = 1.0 if n[drop] >= 0 else -1.0
    rem = list(range(len(idx)))
    out = []
    guard = 0
    while len(rem) > 3 and guard < 10000:
        guard += 1
        m = len(rem)
        for j in range(m):
            a, b, c = rem[(j - 1) % m], rem[j], rem[(j + 1) % m]
            cross = (p[b, 0] - p[a, 0]) * (p[c, 1] - p[a, 1]) - (p[b, 1] - p[a, 1]) * (p[c, 0] - p[a, 0])
            if cross * sign <= 1e-15:
                continue
            inside = False
            for o in rem:
                if o in (a, b, c):
                    continue
                if _in_tri(p[o], p[a], p[b], p[c], sign):
                    inside = True
                    break
            if not inside:
                out.append((idx[a], idx[b], idx[c]))
                rem.pop(j)
                break
        else:  # degenerate: fall back to a fan
            break
    for j in range(1, len(rem) - 1):
        out.append((idx[rem[0]], idx[rem[j]], idx[rem[j + 1]]))
    return out


def _in_tri(q, a, b, c, sign) -> bool:
    def s(p1, p2, p3):
        return ((p2[0] - p1[0]) * (p3[1] - p1[1]) - (p2[1] - p1[1]) * (p3[0] - p1[0])) * sign

    return s(a, b, q) >= 0 and s(b, c, q) >= 0 and s(c, a, q) >= 0


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
        return self.geometry.bounds

    @property
    def centroid(self) -> np.ndarray:
        """(3,) float64 — mean of the vertices, metres."""
        return self.geometry.vertices.mean(axis=0)

    def footprint(self) -> Optional[np.ndarray]:
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
            "attributes": _jsonable(self.attributes),
            "log": list(self.log),
        }

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "shape") -> "Shape":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = _obj(d, where)
        sid = _text(_get(d, "id", where), f"{where}.id")
        where = f"{where} ({sid!r})"
        kind = _text(_get(d, "type", where), f"{where}.type")
        try:
            kind = ShapeType.parse(kind)
        except ValueError as e:
            raise _Malformed(f"{where}.type: {e}") from None
        scope = d.get("scope")
        grid = d.get("grid")
        support = _obj(d.get("support", {}), f"{where}.support")
        return cls(
            id=sid,
            type=kind,
            geometry=Polyhedron.from_dict(_get(d, "geometry", where), f"{where}.geometry"),
            scope=Scope.from_dict(scope, f"{where}.scope") if scope else None,
            storey=_integer(d.get("storey", 0), f"{where}.storey"),
            name=_text(d.get("name", ""), f"{where}.name", optional=True) or "",
            terminal=_flag(d.get("terminal", False), f"{where}.terminal"),
            active=_flag(d.get("active", True), f"{where}.active"),
            parent=_text(d.get("parent"), f"{where}.parent", optional=True),
            children=tuple(_text(c, f"{where}.children[{i}]")
                           for i, c in enumerate(_array(d.get("children", []), f"{where}.children"))),
            grid=None if grid is None else tuple(_integer(g, f"{where}.grid[{i}]")
                                                 for i, g in enumerate(_array(grid, f"{where}.grid"))),
            support={_text(k, f"{where}.support key"): _number(v, f"{where}.support[{k!r}]", finite=False)
                     for k, v in support.items()},
            attributes=_obj(d.get("attributes", {}), f"{where}.attributes"),
            log=tuple(_text(e, f"{where}.log[{i}]")
                      for i, e in enumerate(_array(d.get("log", []), f"{where}.log"))),
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
        return self.ceiling_z - self.floor_z

    def to_dict(self) -> dict:
        return {"index": self.index, "name": self.name, "floor_z": self.floor_z,
                "ceiling_z": self.ceiling_z, "elevation": self.elevation}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "storey") -> "Storey":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = _obj(d, where)
        elev = d.get("elevation")
        return cls(_integer(_get(d, "index", where), f"{where}.index"),
                   _number(_get(d, "floor_z", where), f"{where}.floor_z"),
                   _number(_get(d, "ceiling_z", where), f"{where}.ceiling_z"),
                   _text(d.get("name", ""), f"{where}.name", optional=True) or "",
                   None if elev is None else _number(elev, f"{where}.elevation"))


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
        v = self.polygon
        return float(np.linalg.norm(np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)) / 2)

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
        return {"method": self.method, "parameters": _jsonable(self.parameters), "seed": self.seed,
                "timings": dict(self.timings), "trace": _jsonable(self.trace),
                "source": self.source, "software": self.software}

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "provenance") -> "Provenance":
        """Read :meth:`to_dict` output; ``ValueError`` naming ``where`` when it is malformed."""
        d = _obj(d, where)
        seed = d.get("seed")
        timings = _obj(d.get("timings", {}), f"{where}.timings")
        return cls(_text(d.get("method", ""), f"{where}.method", optional=True) or "",
                   _obj(d.get("parameters", {}), f"{where}.parameters"),
                   None if seed is None else _integer(seed, f"{where}.seed"),
                   {_text(k, f"{where}.timings key"): _number(v, f"{where}.timings[{k!r}]", finite=False)
                    for k, v in timings.items()},
                   _obj(d.get("trace", {}) or {}, f"{where}.trace"),
                   _text(d.get("source", ""), f"{where}.source", optional=True) or "",
                   _text(d.get("software", ""), f"{where}.software", optional=True) or "")


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

    @property
    def doors(self) -> list[Shape]:
        return self.of_type(ShapeType.DOOR)

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
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        out = p @ self.transform[:3, :3].T + self.transform[:3, 3]
        return out + self.offset if include_offset else out

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

    # ---------------------------------------------------------------- graphs
    def graph(self, kind: str = "connectivity", level: str = "space", include_exterior: bool = True):
        """A networkx Graph of ``kind`` relations between spaces.

        ``level="space"``: nodes are active interior (and exterior) spaces; relations
        between their parts are lifted to them. ``level="subspace"``: nodes are the
        innermost parts (cuboids / cells) and only relations recorded between parts are
        used. Edge attributes ``via`` (wall or door) and ``weight`` (centroid distance, m);
        node attributes ``name``, ``type``, ``centroid``, ``storey``. Same as
        :func:`engine.topology.space_graph`.
        """
        from .topology.graph import space_graph

        return space_graph(self, kind, level, include_exterior=include_exterior)

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
            raise FormatError(f"not a building-model JSON: the top level is {_json_kind(d)}, not an object "
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
            raise FormatError(f"malformed building-model JSON: {_error_text(e)}", path) from None

    @classmethod
    def _from_checked_dict(cls, d: Mapping) -> "BuildingModel":
        shapes = [Shape.from_dict(s, f"shapes[{i}]")
                  for i, s in enumerate(_array(d.get("shapes", []), "shapes"))]
        storeys = [Storey.from_dict(s, f"storeys[{i}]")
                   for i, s in enumerate(_array(d.get("storeys", []), "storeys"))]
        relations = []
        for i, r in enumerate(_array(d.get("relations", []), "relations")):
            w = f"relations[{i}]"
            r = _obj(r, w)
            kind = _text(_get(r, "kind", w), f"{w}.kind")
            if kind not in RELATION_KINDS:
                raise _Malformed(f"{w}.kind is {kind!r}; expected one of {list(RELATION_KINDS)}")
            a, b = _text(_get(r, "a", w), f"{w}.a"), _text(_get(r, "b", w), f"{w}.b")
            relations.append(Relation(kind, a, b, _text(r.get("via"), f"{w}.via", optional=True)))
        transform = d.get("transform")
        offset = d.get("offset")
        return cls(
            shapes=tuple(shapes),
            storeys=tuple(storeys),
            relations=tuple(relations),
            transform=np.eye(4) if transform is None else _numbers(transform, "transform", (4, 4)),
            offset=np.zeros(3) if offset is None else _numbers(offset, "offset", (3,)),
            provenance=Provenance.from_dict(d.get("provenance") or {}),
            name=_text(d.get("name", ""), "name", optional=True) or "",
        )

    def to_json(self, path: Optional[str | os.PathLike] = None, indent: Optional[int] = None) -> str:
        """Serialise; when ``path`` is given, write atomically (temporary name, then move)."""
        text = json.dumps(self.to_dict(), indent=indent)
        if path is not None:
            from .fileutil import atomic_write_text

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
            return cls.from_dict(_parse_json(source, None))
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
        return cls.from_dict(_parse_json(text, path), path)

    def summary(self) -> dict:
        """JSON-ready counts: storeys, spaces, walls, doors, relations."""
        return {
            "storeys": len(self.storeys),
            "spaces": len(self.spaces),
            "sub_spaces": len([s for s in self.of_type(ShapeType.INTERIOR, active=None)]),
            "walls": len(self.walls),
            "doors": len(self.doors),
            "exterior": len(self.of_type(ShapeType.EXTERIOR)),
            "adjacency": len(self.relations_of("adjacency")),
            "connectivity": len(self.relations_of("connectivity")),
        }


def _parse_json(text: str, path) -> Any:
    """``json.loads(text)``; FormatError naming ``path`` (and the line) when it is not JSON."""
    if not text.strip():
        raise FormatError("the file is empty" if path is not None else "empty JSON text", path)
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        where = f"line {e.lineno} column {e.colno}"
        if e.pos >= len(text.rstrip()) or e.msg.startswith("Unterminated string"):
            raise FormatError(f"truncated JSON: the text ends inside a value ({e.msg} at {where})", path) \
                from None
        raise FormatError(f"not readable as JSON: {e.msg} at {where}", path) from None
    except RecursionError:
        raise FormatError("not readable as JSON: nested too deeply", path) from None


def _error_text(e: BaseException) -> str:
    """The message of a parsing error (a KeyError's is the bare key)."""
    if isinstance(e, KeyError):
        return f"missing key {e.args[0]!r}" if e.args else "missing key"
    return str(e) or e.__class__.__name__


def _jsonable(x):
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, enum.Enum):
        return x.value
    if hasattr(x, "__dataclass_fields__"):
        from dataclasses import asdict

        return _jsonable(asdict(x))
    return x
