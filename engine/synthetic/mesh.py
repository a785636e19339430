"""The triangle mesh a simulated scanner sees: a floor plan's building and its surroundings.

Inside: the floor, ceiling and wall faces of each room, with the holes of every door and
window cut out of the wall faces; in each hole the reveals (jambs, head, and the threshold
of a door or the sill surface of a window) inside the wall thickness; in a window the
glazing, a pane in the middle of the wall thickness (:data:`LABEL_GLASS`, partly
transparent in :func:`~engine.synthetic.scan.scan_mesh`); in a closed door a leaf
:data:`DOOR_LEAF_THICKNESS` thick whose face is :data:`DOOR_LEAF_RECESS` behind the first
room's wall face (flush with neither face); and the clutter boxes.

Outside (``surroundings=True``, only when the plan has a window or an exterior door,
since nothing else lets a ray out): the building's outer wall faces (LABEL_WALL, with the
same holes), the top faces of its roofs, a ground plane at the lowest floor level reaching
:data:`SURROUND_EXTENT` beyond the building, a neighbour's facade (a box) and a few trees
(a trunk and an octahedral crown) some metres away (all :data:`LABEL_OUTSIDE`), so rays
through windows and open exterior doors return points beyond the exterior wall and rays
that reach another part of the building stop at its outer faces.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon, box
from shapely.ops import unary_union

from .layout import _edge_frame, plan_geometry

__all__ = [
    "LABEL_WALL",
    "LABEL_FLOOR",
    "LABEL_CEILING",
    "LABEL_CLUTTER",
    "LABEL_OUTSIDE",
    "LABEL_GLASS",
    "LABEL_DOOR",
    "LABEL_NAMES",
    "SceneMesh",
    "build_scene_mesh",
    "DOOR_LEAF_THICKNESS",
    "DOOR_LEAF_RECESS",
    "SURROUND_EXTENT",
]

LABEL_WALL = 0
"""Truth label of points on walls (door and window reveals and the outer wall faces included)."""
LABEL_FLOOR = 1
"""Truth label of points on floors (door thresholds included)."""
LABEL_CEILING = 2
"""Truth label of points on ceilings."""
LABEL_CLUTTER = 3
"""Truth label of points on furniture."""
LABEL_OUTSIDE = 4
"""Truth label of points outside the building (ground, trees, the neighbour's facade, roof tops)."""
LABEL_GLASS = 5
"""Truth label of points on window glazing."""
LABEL_DOOR = 6
"""Truth label of points on closed door leaves."""
LABEL_NAMES = ("wall", "floor", "ceiling", "clutter", "outside", "glass", "door")
"""Name of each label value."""
TABLE_TOP = 0.04
"""Thickness of a table top, metres."""
TABLE_LEG = 0.05
"""Side of a table leg's square section, metres."""
TABLE_LEG_INSET = 0.1
"""Distance of a table leg from the table's corner (along the diagonal), metres."""
DOOR_LEAF_THICKNESS = 0.04
"""Thickness of a closed door's leaf, metres (at most a third of the wall thickness)."""
DOOR_LEAF_RECESS = 0.03
"""Depth of a closed door leaf's face behind the wall face of the door's first room, metres
(less in walls too thin for it)."""
SURROUND_EXTENT = 15.0
"""The ground plane reaches this far beyond the building's bounding box, metres."""
NEIGHBOUR_DISTANCE = 10.0
"""Distance of the neighbour's facade from the building's bounding box (north side), metres."""
NEIGHBOUR_HEIGHT = 12.0
"""Height of the neighbour's facade, metres."""
TREE_DISTANCE = 6.0
"""Distance of the row of trees from the building's bounding box (south, east, west), metres."""
TREE_SPACING = 7.0
"""Distance between neighbouring trees, metres."""
TREE_TRUNK = (0.4, 2.5)
"""Side of a tree trunk's square section and the height of the crown's bottom, metres."""
TREE_CROWN = (3.0, 3.0)
"""Width and height of a tree's crown (an octahedron above the trunk: no flat faces), metres."""


@dataclass(frozen=True)
class SceneMesh:
    """Triangle mesh of the visible surfaces.

    Attributes
    ----------
    vertices : (n, 3) float64, metres
    triangles : (m, 3) int32
    labels : (m,) int32 — LABEL_* of each triangle (LABEL_GLASS triangles are partly
        transparent to the scanner)
    wall_index : (m,) int32 — index of the wall piece (``PlanGeometry.walls``) a wall,
        reveal, glazing or door-leaf triangle lies on, -1 for other triangles
    room_index : (m,) int32 — index of the room (``FloorPlan.rooms``) whose face it is,
        -1 for reveals, outer wall faces, leaves, glazing, clutter and surroundings
    """

    vertices: np.ndarray
    triangles: np.ndarray
    labels: np.ndarray
    wall_index: np.ndarray
    room_index: np.ndarray


class _MeshBuilder:
    def __init__(self):
        self.v, self.t, self.lab, self.wall, self.room = [], [], [], [], []
        self.nv = 0

    def add(self, verts, tris, label, wall=-1, room=-1):
        verts = np.asarray(verts, dtype=np.float64).reshape(-1, 3)
        tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
        if len(tris) == 0:
            return
        self.v.append(verts)
        self.t.append(tris + self.nv)
        self.nv += len(verts)
        m = len(tris)
        self.lab.append(np.full(m, label, np.int32))
        self.wall.append(np.full(m, wall, np.int32))
        self.room.append(np.full(m, room, np.int32))

    def quad(self, a, b, c, d, label, wall=-1, room=-1):
        self.add([a, b, c, d], [[0, 1, 2], [0, 2, 3]], label, wall, room)

    def polygon(self, poly, z, label, room=-1, wall=-1):
        tris = shapely.constrained_delaunay_triangles(poly)
        vs = []
        for tri in getattr(tris, "geoms", []):
            c = np.asarray(tri.exterior.coords)[:3]
            vs.append(np.column_stack([c, np.full(3, z)]))
        if vs:
            v = np.vstack(vs)
            self.add(v, np.arange(len(v)).reshape(-1, 3), label, wall, room)

    def box(self, footprint, z0, z1, label):
        c = np.asarray(footprint.exterior.coords)[:4]
        lo = np.column_stack([c, np.full(4, z0)])
        hi = np.column_stack([c, np.full(4, z1)])
        v = np.vstack([lo, hi])
        tris = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]
        for k in range(4):
            a, b = k, (k + 1) % 4
            tris += [[a, b, 4 + b], [a, 4 + b, 4 + a]]
        self.add(v, tris, label)

    def build(self) -> SceneMesh:
        return SceneMesh(np.vstack(self.v), np.vstack(self.t).astype(np.int32), np.concatenate(self.lab),
                         np.concatenate(self.wall), np.concatenate(self.room))


def _intervals_on_edge(geoms, p, q, tol=1e-4, exact=False):
    """For each geometry, the [u0, u1] stretch of edge p→q it covers (or None), found with
    the geometry grown by ``tol``; ``exact`` takes the growth back off the ends inside the
    edge (right for openings, whose jambs are square to the edge)."""
    d, _, length = _edge_frame(p, q)
    line = LineString([p, q])
    out = []
    for g in geoms:
        hit = g.buffer(tol).intersection(line)
        if hit.is_empty or hit.length < 1e-3:
            out.append(None)
            continue
        cs = np.vstack([np.asarray(h.coords) for h in getattr(hit, "geoms", [hit])])
        u = (cs - np.asarray(p)) @ d
        u0, u1 = max(float(u.min()), 0.0), min(float(u.max()), length)
        if exact:
            u0, u1 = (u0 + tol if u0 > tol else u0), (u1 - tol if u1 < length - tol else u1)
        out.append((u0, u1))
    return out



@dataclass(frozen=True)
class _Opening:
    """A door or window hole: footprint corners ``c`` (4, 2) (see ``PlanGeometry.doors``),
    heights, wall piece, the rooms whose faces it cuts."""

    c: np.ndarray
    fp: object
    z0: float
    z1: float
    wall: int
    width: float
    window: bool
    closed: bool
    rooms: tuple
    storey: int

    @property
    def exterior(self) -> bool:
        return self.window or len(self.rooms) == 1


def _openings(plan, g) -> list[_Opening]:
    out = []
    for door, fp, w in g.doors:
        z = plan.floor_z(plan.room(door.rooms[0]))
        out.append(_Opening(np.asarray(fp.exterior.coords)[:4], fp, z, z + door.height, w, door.width, False,
                            not door.open, tuple(door.rooms), g.walls[w].storey))
    for win, fp, w in getattr(g, "windows", ()):
        z = plan.floor_z(plan.room(win.room)) + win.sill
        out.append(_Opening(np.asarray(fp.exterior.coords)[:4], fp, z, z + win.height, w, win.width, True,
                            False, (win.room,), g.walls[w].storey))
    return out


def _subtract(z0: float, z1: float, holes) -> list[tuple[float, float]]:
    """The parts of [z0, z1] outside every (a, b) of ``holes``."""
    out, z = [], z0
    for a, b in sorted(holes):
        if a > z + 1e-9:
            out.append((z, min(a, z1)))
        z = max(z, b)
        if z >= z1 - 1e-9:
            break
    if z < z1 - 1e-9:
        out.append((z, z1))
    return [(a, b) for a, b in out if b - a > 1e-9]


def _wall_face(mb, g, walls, openings, p, q, z0, z1, room=-1) -> None:
    """Quads of the vertical face along p→q from z0 to z1, split where the wall piece changes
    and holed by the openings whose footprint covers the stretch."""
    d, _, length = _edge_frame(p, q)
    w_iv = _intervals_on_edge([g.walls[k].polygon for k in walls], p, q)
    o_iv = _intervals_on_edge([o.fp for o in openings], p, q, exact=True)
    cuts = {0.0, length}
    for iv in w_iv + o_iv:
        if iv is not None:
            cuts.update(iv)
    cuts = np.array(sorted(c for c in cuts if -1e-9 <= c <= length + 1e-9))
    for a, b in zip(cuts[:-1], cuts[1:]):
        if b - a < 1e-6:
            continue
        mid = (a + b) / 2
        wall = -1
        for k, iv in zip(walls, w_iv):
            if iv is not None and iv[0] - 1e-9 <= mid <= iv[1] + 1e-9:
                wall = k
                break
        holes = [(o.z0, o.z1) for o, iv in zip(openings, o_iv)
                 if iv is not None and iv[0] - 1e-9 <= mid <= iv[1] + 1e-9 and iv[1] - iv[0] > o.width / 2]
        pa, pb = np.asarray(p) + d * a, np.asarray(p) + d * b
        for za, zb in _subtract(z0, z1, holes):
            mb.quad([*pa, za], [*pb, za], [*pb, zb], [*pa, zb], LABEL_WALL, wall, room)


def _reveals(mb, o: _Opening) -> None:
    """Jambs, head and threshold (door) or sill (window) of an opening; the glazing of a
    window; the leaf of a closed door."""
    c, z0, z1, w = o.c, o.z0, o.z1, o.wall
    for a, b in ((1, 2), (3, 0)):
        mb.quad([*c[a], z0], [*c[b], z0], [*c[b], z1], [*c[a], z1], LABEL_WALL, w)
    mb.polygon(o.fp, z1, LABEL_WALL, wall=w)
    if o.window:
        mb.polygon(o.fp, z0, LABEL_WALL, wall=w)
        m0, m1 = (c[0] + c[3]) / 2, (c[1] + c[2]) / 2
        mb.quad([*m0, z0], [*m1, z0], [*m1, z1], [*m0, z1], LABEL_GLASS, w)
        return
    mb.polygon(o.fp, z0, LABEL_FLOOR)
    if o.closed:
        across = c[3] - c[0]
        depth = float(np.linalg.norm(across))
        n = across / depth
        lt = min(DOOR_LEAF_THICKNESS, depth / 3)
        r = min(DOOR_LEAF_RECESS, (depth - lt) / 2)
        for off in (r, r + lt):
            a, b = c[0] + n * off, c[1] + n * off
            mb.quad([*a, z0], [*b, z0], [*b, z1], [*a, z1], LABEL_DOOR, w)


def _clutter(mb, plan) -> None:
    for item in plan.clutter:
        room = plan.room(item.room)
        zf = plan.floor_z(room) + item.z0
        fp = item.footprint()
        if item.kind == "table":
            mb.box(fp, zf + item.size[2] - TABLE_TOP, zf + item.size[2], LABEL_CLUTTER)
            cs = np.asarray(fp.exterior.coords)[:4]
            ctr = cs.mean(axis=0)
            for cc in cs:
                lc = cc + (ctr - cc) / np.linalg.norm(ctr - cc) * TABLE_LEG_INSET
                mb.box(Point(lc).buffer(TABLE_LEG / 2, cap_style="square"), zf,
                       zf + item.size[2] - TABLE_TOP, LABEL_CLUTTER)
        else:
            mb.box(fp, zf, zf + item.size[2], LABEL_CLUTTER)


def _surroundings(mb, plan, g, openings) -> None:
    """Outer wall faces of every storey, the exposed roof tops, the ground plane and the
    outdoor objects."""
    used = [s for s in range(len(plan.storeys)) if not g.outlines[s].is_empty]
    t_s = plan.slab_thickness
    floors = {s: plan.storeys[s].floor_z for s in used}
    tops = {s: max([plan.ceiling_z(r) for r in plan.rooms if r.storey == s]
                   + [plan.storeys[s].floor_z + plan.storeys[s].height]) for s in used}
    for s in used:
        below = any(abs(tops[o] + t_s - floors[s]) < 1e-6 for o in used if o != s)
        above = any(abs(tops[s] + t_s - floors[o]) < 1e-6 for o in used if o != s)
        z0 = floors[s] - (t_s if below else 0.0)
        z1 = tops[s] + (0.0 if above else t_s)
        roof = g.outlines[s].difference(unary_union(
            [g.outlines[o] for o in used if abs(tops[s] + t_s - floors[o]) < 1e-6] + [Polygon()]))
        for part in getattr(roof, "geoms", [roof]):
            if isinstance(part, Polygon) and part.area > 1e-6:
                mb.polygon(part, tops[s] + t_s, LABEL_OUTSIDE)
        walls = [k for k, w in enumerate(g.walls) if w.storey == s]
        ext = [o for o in openings if o.storey == s and o.exterior]
        coords = np.asarray(g.outlines[s].exterior.coords)
        for p, q in zip(coords[:-1], coords[1:]):
            _wall_face(mb, g, walls, ext, p, q, z0, z1)
    zg = min(floors.values())
    base = unary_union([g.outlines[s] for s in used if abs(floors[s] - zg) < 1e-6])
    minx, miny, maxx, maxy = unary_union([g.outlines[s] for s in used]).bounds
    e = SURROUND_EXTENT
    mb.polygon(box(minx - e, miny - e, maxx + e, maxy + e).difference(base), zg, LABEL_OUTSIDE)
    nd = NEIGHBOUR_DISTANCE
    mb.box(box(minx - 5.0, maxy + nd, maxx + 5.0, maxy + nd + 0.5), zg, zg + NEIGHBOUR_HEIGHT, LABEL_OUTSIDE)
    td, (ts, th), (cs, ch) = TREE_DISTANCE, TREE_TRUNK, TREE_CROWN
    spots = [(x, miny - td) for x in np.arange(minx, maxx + 1e-9, TREE_SPACING)]
    spots += [(xx, y) for xx in (minx - td, maxx + td) for y in np.arange(miny, maxy + 1e-9, TREE_SPACING)]
    for x, y in spots:
        zc = zg + th + ch / 2
        mb.box(box(x - ts / 2, y - ts / 2, x + ts / 2, y + ts / 2), zg, zc, LABEL_OUTSIDE)
        r = cs / 2
        v = [(x, y, zc + ch / 2), (x, y, zc - ch / 2), (x + r, y, zc), (x, y + r, zc), (x - r, y, zc), (x, y - r, zc)]
        mb.add(v, [[0, 2, 3], [0, 3, 4], [0, 4, 5], [0, 5, 2], [1, 3, 2], [1, 4, 3], [1, 5, 4], [1, 2, 5]], LABEL_OUTSIDE)


def build_scene_mesh(plan, geometry=None, *, clutter: bool = True, surroundings: bool = True) -> SceneMesh:
    """The triangle mesh a scanner inside ``plan`` sees (see module doc).

    Parameters
    ----------
    plan : FloorPlan
    geometry : PlanGeometry, optional
        :func:`~engine.synthetic.layout.plan_geometry` of the plan, when already computed.
    clutter : bool
        Include the plan's clutter boxes.
    surroundings : bool
        Include the outer wall faces, the ground and the outdoor boxes (only made when
        the plan has a window or an exterior door).
    """
    g = plan_geometry(plan) if geometry is None else geometry
    mb = _MeshBuilder()
    openings = _openings(plan, g)
    for i, room in enumerate(plan.rooms):
        poly = room.shape
        z0, z1 = plan.floor_z(room), plan.ceiling_z(room)
        mb.polygon(poly, z0, LABEL_FLOOR, i)
        mb.polygon(poly, z1, LABEL_CEILING, i)
        walls = [k for k, w in enumerate(g.walls) if w.storey == room.storey]
        mine = [o for o in openings if room.name in o.rooms]
        coords = np.asarray(poly.exterior.coords)
        for p, q in zip(coords[:-1], coords[1:]):
            _wall_face(mb, g, walls, mine, p, q, z0, z1, i)
    for o in openings:
        _reveals(mb, o)
    if clutter:
        _clutter(mb, plan)
    if surroundings and any(o.exterior for o in openings):
        _surroundings(mb, plan, g, openings)
    return mb.build()
