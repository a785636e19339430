"""Geometry of the IFC writer: cleaned rings, door sizes, wall axes and frames, openings, slab
kinds, the common faces that become space boundaries (and their holes for the doors and windows
in them), and the IFC geometry items (placements, polylines, extruded solids, breps) built from
them. Metres, in the frame the file is written in."""
from __future__ import annotations

import logging
from typing import Optional

import numpy as np
from shapely.geometry import Polygon
from shapely.ops import unary_union

from ..geometry.planes import plane_frame
from ..geometry.polygon import newell_normal
from ..geometry.transforms import apply_transform
from ..model import BuildingModel, Polyhedron, Shape, ShapeType, Storey
from .common import PSET_SHAPE

log = logging.getLogger(__name__)

__all__ = ["default_storeys", "clean_ring", "door_size", "wall_axis", "axis_line", "wall_frame", "opening_geometry",
           "face_table", "common_face", "net_face", "plane_points", "slab_type", "union_rings", "axis2",
           "polyline", "solid", "BoundaryWriter"]

_SAME_POINT = 1e-9
"""Distance (m) under which two consecutive ring vertices are one."""


def default_storeys(model: BuildingModel) -> list:
    """One storey spanning every shape, for a model without storeys."""
    shapes = [s for s in model.shapes if s.type != ShapeType.NONE and len(s.geometry.vertices)]
    if not shapes:
        return [Storey(0, 0.0, 0.0, "Storey 0")]
    b = np.array([s.bounds for s in shapes])
    return [Storey(0, float(b[:, 0, 2].min()), float(b[:, 1, 2].max()), "Storey 0")]


def clean_ring(ring: np.ndarray, tol: float = _SAME_POINT) -> Optional[np.ndarray]:
    """Drop repeated consecutive vertices of a closed ring; None when fewer than 3 remain."""
    r = np.asarray(ring, dtype=np.float64)
    keep = np.linalg.norm(r - np.roll(r, 1, axis=0), axis=1) > tol
    r = r[keep]
    return r if len(r) >= 3 else None


def door_size(d: Shape) -> tuple[float, float]:
    """Width and height of a door, metres (its attributes, else its scope and bounds)."""
    b = d.geometry.bounds
    w = float(d.attributes.get("width", np.sort(d.scope.size[:2])[1]))
    h = float(d.attributes.get("height", b[1, 2] - b[0, 2]))
    return w, h


def wall_axis(s: Shape, g: Optional[Polyhedron] = None) -> Optional[np.ndarray]:
    """(2, 2) float64 — the wall's centre line (metres) along its longer horizontal side, from
    its scope; None for a wall without extent. (``g`` is not used: kept for callers.)"""
    sc = s.scope
    k = 0 if sc.size[0] >= sc.size[1] else 1
    if sc.size[k] <= 0:
        return None
    x, y = sc.axes[k, :2], sc.axes[1 - k, :2]
    o = sc.origin[:2] + y * sc.size[1 - k] / 2
    return np.array([o, o + x * sc.size[k]])


def axis_line(s: Shape, bake: Optional[np.ndarray] = None) -> Optional[np.ndarray]:
    """(2, 2) float64 — a wall's centre line (metres): its attribute ``axis_line`` (start,
    end), else :func:`wall_axis`; moved by ``bake`` (4, 4), the non-rigid model transform
    applied to the vertices, when given. None for a wall without extent."""
    axis = None
    raw = s.attributes.get("axis_line")
    if raw is not None:
        try:
            axis = np.asarray(raw, dtype=np.float64).reshape(2, 2)
        except (TypeError, ValueError):
            log.warning("wall %s: axis_line %r is not two points; using its scope", s.id, raw)
        if axis is not None and not np.all(np.isfinite(axis)):
            axis = None
    if axis is None:
        axis = wall_axis(s)
    if axis is not None and bake is not None:
        z = float(s.geometry.bounds[0, 2])
        axis = apply_transform(bake, np.column_stack([axis, [z, z]]))[:, :2]
    return axis


def wall_frame(axis: np.ndarray, z0: float) -> Optional[tuple]:
    """``(origin (3,), rotation (3, 3), length)`` of a wall placed on its axis: the origin at
    the axis start at height ``z0``, local x along the axis, y its +90° turn (the "left" side of
    the conventions), z up — the frame IFC's layer-set usage (AXIS2) and Axis refer to.
    None when the axis has no length (metres)."""
    a = np.asarray(axis, dtype=np.float64).reshape(2, 2)
    d = a[1] - a[0]
    length = float(np.hypot(d[0], d[1]))
    if not np.isfinite(length) or length <= _SAME_POINT:
        return None
    c, s = d / length
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.array([a[0, 0], a[0, 1], float(z0)]), rot, length


def slab_type(kind: str, zmin: float, zmax: float, storeys, gap: float) -> str:
    """IFC PredefinedType of a slab (FLOOR, ROOF or BASESLAB) from its ``kind`` attribute:
    floor → FLOOR, base → BASESLAB, roof → ROOF, ceiling → ROOF on top of the highest storey
    (``zmin`` within ``gap`` of its ceiling, metres) else FLOOR; without a kind, by height
    (under the lowest floor → BASESLAB, over the highest ceiling → ROOF)."""
    kind = str(kind or "").strip().lower()
    if kind == "roof":
        return "ROOF"
    if kind in ("base", "baseslab", "ground"):
        return "BASESLAB"
    if kind == "floor" or not storeys:
        return "FLOOR"
    lowest = min(st.floor_z for st in storeys)
    highest = max(st.ceiling_z for st in storeys)
    if kind != "ceiling" and zmax <= lowest + gap:
        return "BASESLAB"
    if zmin >= highest - gap:
        return "ROOF"
    return "FLOOR"


def opening_geometry(door: Shape, g: Polyhedron, wall_g: Polyhedron, margin: float) -> Polyhedron:
    """The door's box enlarged by ``margin`` beyond each side of the wall (metres)."""
    sc = door.scope
    ax = sc.axes
    # the horizontal scope axis closest to the wall's thin direction
    wsc = Shape("_w", ShapeType.WALL, wall_g).scope
    thin = wsc.axes[int(np.argmin(wsc.size[:2]))]
    k = int(np.argmax([abs(ax[0] @ thin), abs(ax[1] @ thin)]))
    lo = np.zeros(3)
    size = np.array(sc.size, dtype=np.float64)
    # reach through the whole wall thickness plus the margin
    wall_thick = float(np.min(wsc.size[:2]))
    centre_k = (sc.center - wsc.center) @ ax[k]
    half = max(size[k] / 2, wall_thick / 2 + abs(centre_k)) + margin
    lo[k] = size[k] / 2 - half
    size[k] = 2 * half
    corners2 = []
    base = sc.origin + ax.T @ lo
    for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
        corners2.append(base[:2] + ax[0, :2] * size[0] * a + ax[1, :2] * size[1] * b)
    zmin, zmax = g.bounds[:, 2]
    return Polyhedron.prism(np.array(corners2), zmin, zmax)


def slab_opening_geometry(g: Polyhedron, slab_g: Polyhedron, margin: float) -> Polyhedron:
    """A roof window's hole: its box's plan (``g``) through the slab (``slab_g``), ``margin``
    beyond either face."""
    b, sb = g.bounds, slab_g.bounds
    ring = [(b[0, 0], b[0, 1]), (b[1, 0], b[0, 1]), (b[1, 0], b[1, 1]), (b[0, 0], b[1, 1])]
    return Polyhedron.prism(np.array(ring), sb[0, 2] - margin, sb[1, 2] + margin)


def face_table(g: Polyhedron) -> tuple:
    """Every face of ``g``: (k, 3) unit outward normals, (k,) plane offsets ``n · v0`` and the
    list of (j, 3) vertices."""
    verts = [g.face_vertices(i) for i in range(len(g.faces))]
    normals = np.array([newell_normal(v) for v in verts]).reshape(-1, 3)
    offsets = np.array([float(n @ v[0]) for n, v in zip(normals, verts)])
    return normals, offsets, verts


def common_face(space_g: Polyhedron, elem_g: Polyhedron, gap: float, min_cos: float, min_area: float,
                tables: Optional[dict] = None):
    """The largest common region of an outward space face and an anti-parallel element face.

    Faces bound each other when ``-n_space · n_element >= min_cos`` and their planes are at
    most ``gap`` apart (metres); regions smaller than ``min_area`` (m²) are ignored.
    ``tables`` caches :func:`face_table` by ``id`` of the polyhedron.

    Returns ``(polygon (k, 2) float64 in the plane frame, origin (3,), normal (3,), u (3,))``
    — the normal is the space face's outward normal — or None when the shapes do not touch.
    """
    sb, eb = space_g.bounds, elem_g.bounds
    if np.any(sb[0] > eb[1] + gap) or np.any(eb[0] > sb[1] + gap):
        return None
    best = None
    tables = {} if tables is None else tables
    for g in (space_g, elem_g):
        if id(g) not in tables:
            tables[id(g)] = face_table(g)
    ns, ds, vss = tables[id(space_g)]
    ne, _, ves = tables[id(elem_g)]
    if not len(ns) or not len(ne):
        return None
    # the pairs of faces anti-parallel and near: the element face's first vertex within
    # ``gap`` of the space face's plane
    v0 = np.array([v[0] for v in ves])
    near = (-(ns @ ne.T) >= min_cos) & (np.abs(ns @ v0.T - ds[:, None]) <= gap)
    near &= np.any(ns != 0, axis=1)[:, None]
    for i in np.flatnonzero(near.any(axis=1)):
        n, vs = ns[i], vss[i]
        u, w = plane_frame(n, flat_cos=1.0)  # u horizontal on every wall and sloped face
        w = w / np.linalg.norm(w)  # unit to the last digit: the boundary polygons are written as they are
        ps = Polygon(np.column_stack([(vs - vs[0]) @ u, (vs - vs[0]) @ w])).buffer(0)
        for j in np.flatnonzero(near[i]):
            ve = ves[j]
            pe = Polygon(np.column_stack([(ve - vs[0]) @ u, (ve - vs[0]) @ w])).buffer(0)
            inter = ps.intersection(pe)
            if inter.is_empty:
                continue
            parts = getattr(inter, "geoms", [inter])
            for part in parts:
                if part.geom_type != "Polygon" or part.area < min_area:
                    continue
                if best is None or part.area > best[0]:
                    ring = np.asarray(part.exterior.coords)[:-1]
                    best = (part.area, ring, vs[0].copy(), n, u)
    if best is None:
        return None
    return best[1], best[2], best[3], best[4]


def plane_points(common) -> np.ndarray:
    """(k, 3) float64 — the polygon of a :func:`common_face` result back in 3D (metres)."""
    poly2, origin, normal, u = common
    w = np.cross(normal, u)
    p = np.asarray(poly2, dtype=np.float64)
    return origin + p[:, :1] * u + p[:, 1:2] * w


def net_face(common, holes: list, min_area: float):
    """The polygon of ``common`` (a :func:`common_face` result) minus ``holes`` ((k, 3) 3D
    polygons near its plane: the faces of the doors and windows in a wall), metres.

    Returns ``(outer (k, 2), [inner (j, 2), ...])`` in the plane frame of ``common`` — the
    part with the largest area when the holes split the face (a full-height door) — or None
    when nothing of at least ``min_area`` (m²) is left.
    """
    poly2, origin, normal, u = common
    w = np.cross(normal, u)
    face = Polygon(poly2).buffer(0)
    cut = []
    for h in holes:
        q = np.asarray(h, dtype=np.float64) - origin
        ph = Polygon(np.column_stack([q @ u, q @ w])).buffer(0)
        if not ph.is_empty:
            cut.append(ph)
    if cut:
        face = face.difference(unary_union(cut))
    parts = [p for p in getattr(face, "geoms", [face]) if p.geom_type == "Polygon" and p.area >= min_area]
    if not parts:
        return None
    best = max(parts, key=lambda p: p.area)
    return (np.asarray(best.exterior.coords)[:-1],
            [np.asarray(r.coords)[:-1] for r in best.interiors])


def union_rings(footprints: list) -> list:
    """The rings (k, 2) (outer and inner) of the union of several footprints (metres)."""
    polys = [Polygon(fp).buffer(0) for fp in footprints if fp is not None and len(fp) >= 3]
    if not polys:
        return []
    u = unary_union(polys)
    out = []
    for p in getattr(u, "geoms", [u]):
        if p.geom_type != "Polygon" or p.is_empty:
            continue
        out.extend(np.asarray(r.coords)[:-1] for r in (p.exterior, *p.interiors))
    return out


# --------------------------------------------------------------------------- IFC geometry items
def axis2(f, location, z=None, x=None):
    """IfcAxis2Placement3D at ``location`` with axes ``z`` and ``x`` (None: the parent's)."""
    return f.createIfcAxis2Placement3D(
        f.createIfcCartesianPoint([float(c) for c in location]),
        None if z is None else f.createIfcDirection([float(c) for c in z]),
        None if x is None else f.createIfcDirection([float(c) for c in x]))


def polyline(f, pts, closed: bool = True):
    """IfcPolyline through the 2D or 3D points ``pts`` (closed: back to the first)."""
    ps = [f.createIfcCartesianPoint([float(c) for c in q]) for q in pts]
    if closed:
        ps.append(ps[0])
    return f.createIfcPolyline(ps)


def solid(f, g: Polyhedron, origin, rot=None):
    """``(item, representation type)`` of polyhedron ``g`` in the local frame at ``origin``
    (3,) turned by ``rot`` (3, 3), i.e. ``p_local = rotᵀ (p - origin)``: an
    IfcExtrudedAreaSolid ("SweptSolid") for a vertical prism, else an IfcFacetedBrep ("Brep")."""
    rot = np.eye(3) if rot is None else np.asarray(rot, dtype=np.float64)
    origin = np.asarray(origin, dtype=np.float64)
    fp = g.footprint()
    zmin, zmax = g.bounds[:, 2]
    if fp is not None and zmax - zmin > 0 and abs(rot[2, 2] - 1.0) < 1e-12:
        ring = clean_ring((fp - origin[:2]) @ rot[:2, :2])
        if ring is not None:
            profile = f.createIfcArbitraryClosedProfileDef("AREA", None, polyline(f, ring))
            item = f.createIfcExtrudedAreaSolid(profile, axis2(f, (0.0, 0.0, zmin - origin[2])),
                                                f.createIfcDirection([0.0, 0.0, 1.0]), float(zmax - zmin))
            return item, "SweptSolid"
    pts = [f.createIfcCartesianPoint([float(c) for c in v]) for v in (g.vertices - origin) @ rot]
    faces = []
    for face in g.faces:
        idx = [i for k, i in enumerate(face) if i != face[k - 1]]  # drop repeated vertices
        if len(idx) >= 3:
            loop = f.createIfcPolyLoop([pts[i] for i in idx])
            faces.append(f.createIfcFace([f.createIfcFaceOuterBound(loop, True)]))
    return f.createIfcFacetedBrep(f.createIfcClosedShell(faces)), "Brep"


# --------------------------------------------------------------------------- space boundaries
class BoundaryWriter:
    """The space boundaries of :class:`engine.ifc.writer._Writer` (a mixin: it uses the
    writer's file, entities, placements and identity helpers).

    Second-level boundaries (``IfcRelSpaceBoundary2ndLevel``), written in three passes: the
    relations through walls (and slabs) and the open plans (``IfcVirtualElement``); the
    one-sided boundaries of walls and slabs touching a space; the doors, windows and doorless
    openings between two spaces, each pair inside its wall's boundaries (``ParentBoundary``).
    The faces are kept and written last, the wall faces without the fillings in them.
    """

    def _ends(self, a, b):
        """(a, b) as the ids of their space entities (merged exteriors share one), or None
        unless both are written spaces and differ."""
        if a not in self.ent or b not in self.ent:
            return None
        if not (_is_space_entity(self.ent[a]) and _is_space_entity(self.ent[b])):
            return None
        a, b = self.canon.get(a, a), self.canon.get(b, b)
        return None if a == b else (a, b)

    def _outside(self, *ids) -> bool:
        return any(self.model[x].type == ShapeType.EXTERIOR for x in ids)

    def _boundaries(self):
        m, prm = self.model, self.params
        fills = {s.id for s in m.shapes if s.type in (ShapeType.DOOR, ShapeType.WINDOW) and s.id in self.ent}
        sides = {}  # {space, exterior} as named and as written -> the first wall between them ("sides")
        for s in m.walls:
            sd = s.attributes.get("sides")
            if s.id in self.ent and isinstance(sd, (list, tuple)) and len(sd) == 2 and None not in sd:
                pair = self._ends(*sd)
                if pair is not None:
                    sides.setdefault(frozenset(sd), s.id)
                    sides.setdefault(("as written", frozenset(pair)), s.id)
        done = set()
        # 1. relations through walls (and slabs), and open plans
        for r in m.relations:
            pair = self._ends(r.a, r.b)
            if pair is None or r.via in fills:
                continue
            a, b = pair
            ext = self._outside(a, b)
            via = r.via if r.via in self.ent and not _is_space_entity(self.ent[r.via]) else None
            if via is None and ext:  # never virtual: the wall between them, or nothing
                if r.kind == "adjacency":
                    via = sides.get(frozenset((r.a, r.b)), sides.get(("as written", frozenset(pair))))
                if via is None:
                    log.debug("relation %s %s-%s: no wall or door to the exterior, no boundary", r.kind, r.a, r.b)
                    continue
            elem = self.ent[via] if via is not None else self._virtual(r, a, b)
            if (a, b, elem.id()) in done or (b, a, elem.id()) in done:
                continue
            done.update(((a, b, elem.id()), (a, elem.id()), (b, elem.id())))
            self._pair(r.a, r.b, elem, via, "PHYSICAL" if via is not None else "VIRTUAL",
                       "EXTERNAL" if ext else "INTERNAL")
        # 2. one-sided boundaries of walls and slabs touching a space
        if prm.geometric_boundaries:
            spaces = [s for s in m.shapes if s.is_space and s.active and s.id in self.ent]
            elems = [s for s in m.shapes if s.type in (ShapeType.WALL, ShapeType.SLAB) and s.id in self.ent]
            eb = np.array([self.geom[w.id].bounds for w in elems]).reshape(-1, 2, 3)
            for s in spaces:
                sid = self.canon.get(s.id, s.id)
                sb = self.geom[s.id].bounds
                near = np.all(sb[0] <= eb[:, 1] + prm.boundary_gap, axis=1) & \
                    np.all(eb[:, 0] <= sb[1] + prm.boundary_gap, axis=1)
                for w in (elems[i] for i in np.flatnonzero(near)):
                    if (sid, self.ent[w.id].id()) in done:
                        continue
                    common = common_face(self.geom[s.id], self.geom[w.id], prm.boundary_gap, prm.boundary_cos,
                                         prm.min_boundary_area, self.tables)
                    if common is None:
                        continue
                    io = "EXTERNAL" if s.type == ShapeType.EXTERIOR else "NOTDEFINED"
                    bd = self._boundary(sid, self.ent[s.id], s.id, self.ent[w.id], w.id, "PHYSICAL", io, "2b",
                                        common)
                    self.wall_b.setdefault((sid, w.id), bd)
                    done.add((sid, self.ent[w.id].id()))
        # 3. doors, windows, doorless openings between two spaces, inside their wall's boundary
        through = {}
        for r in m.relations:
            if r.via in fills and self._ends(r.a, r.b) is not None:
                through.setdefault(r.via, []).append((r.a, r.b))
        for d in m.shapes:
            if d.id not in fills:
                continue
            pairs = list(through.get(d.id, ()))
            sp = d.attributes.get("spaces")
            if isinstance(sp, (list, tuple)) and len(sp) == 2 and self._ends(*sp) is not None:
                pairs.append(tuple(sp))
            elem = self.ent[d.id]
            phys = "VIRTUAL" if elem.is_a("IfcOpeningElement") else "PHYSICAL"
            seen = set()
            for ga, gb in pairs:
                a, b = self._ends(ga, gb)
                if frozenset((a, b)) not in seen:
                    seen.add(frozenset((a, b)))
                    self._pair(ga, gb, elem, d.id, phys, "EXTERNAL" if self._outside(a, b) else "INTERNAL",
                               wall=d.parent)
        self._connection_geometry()

    def _virtual(self, r, a, b):
        """The IfcVirtualElement of the open boundary between interior spaces ``a`` and ``b``."""
        m, key = self.model, ("virtual", a, b)
        if key not in self.ent:
            ve = self._root("IfcVirtualElement", key, name=f"Open boundary {m[a].name or a} | {m[b].name or b}")
            container = self._container_of(m[a])
            self._placement(ve, container, self.origin[self.ent[a].id()])
            self.contained.setdefault(container.id(), []).append(ve)
            self._pset(ve, PSET_SHAPE, {"ShapeId": f"open:{a}|{b}", "ShapeType": "virtual", "RelationKinds": r.kind})
            self.ent[key] = ve
        else:
            ps = _find_pset(self.ent[key], PSET_SHAPE)
            if ps is not None:
                kinds = sorted(set(ps.get("RelationKinds", "").split(",")) | {r.kind})
                self._pset_update(self.ent[key], PSET_SHAPE, {"RelationKinds": ",".join(k for k in kinds if k)})
        return self.ent[key]

    def _pair(self, ga, gb, elem, elem_shape, phys, io, wall=None):
        """The two boundaries of ``elem`` between the spaces of shapes ``ga`` and ``gb`` (their
        faces give the geometry), pointing at each other. A filling's (``wall``: the id of
        the wall it is in) has the wall's boundary of its space as parent and is cut out of it."""
        a, b = self._ends(ga, gb)
        out = []
        for g0, s0, s1 in ((ga, a, b), (gb, b, a)):
            bd = self._boundary(s0, self.ent[g0], g0, elem, elem_shape, phys, io, "2a", partner=s1)
            if wall is None:
                if elem_shape is not None:
                    self.wall_b[(s0, elem_shape, s1)] = bd
                    self.wall_b.setdefault((s0, elem_shape), bd)
            else:
                parent = self.wall_b.get((s0, wall, s1)) or self.wall_b.get((s0, wall))
                if parent is not None:
                    bd.ParentBoundary = parent
                    if bd.id() in self.faces and parent.id() in self.faces:
                        self.holes.setdefault(parent.id(), []).append(plane_points(self.faces[bd.id()][1]))
            out.append(bd)
        out[0].CorrespondingBoundary, out[1].CorrespondingBoundary = out[1], out[0]
        return out

    def _boundary(self, space_id, space, geom_id, elem, elem_shape, phys, io, level, common=None, partner=None):
        """The boundary of space ``space_id`` by ``elem`` (``geom_id``: the shape whose faces
        meet it); ``partner`` is the space on the other side for a relation's boundary (its
        key tells the two boundaries of one wall apart). Its face is kept for
        :meth:`_connection_geometry`."""
        b = self._rel("IfcRelSpaceBoundary2ndLevel", ("boundary", space_id, self._key(elem), partner),
                      Name="2ndLevel", Description=level, RelatingSpace=space, RelatedBuildingElement=elem,
                      PhysicalOrVirtualBoundary=phys, InternalOrExternalBoundary=io)
        if common is None and elem_shape is not None:
            prm = self.params
            common = common_face(self.geom[geom_id], self.geom[elem_shape], prm.boundary_gap,
                                 prm.boundary_cos, prm.min_boundary_area, self.tables)
        if common is not None:
            self.faces[b.id()] = (b, common, space)
        return b

    def _connection_geometry(self):
        """Each boundary's face (relative to its space) as an IfcCurveBoundedPlane; a wall's
        without the faces of the doors and windows in it (inner boundaries, or a notch)."""
        for bid, (b, common, space) in self.faces.items():
            outer, inner = common[0], []
            if bid in self.holes:
                net = net_face(common, self.holes[bid], self.params.min_boundary_area)
                if net is not None:
                    outer, inner = net
            f = self.f  # what api.boundary.assign_connection_geometry writes, 4x faster
            plane = f.createIfcPlane(axis2(f, common[1] - self.origin[space.id()], common[2], common[3]))
            b.ConnectionGeometry = f.createIfcConnectionSurfaceGeometry(f.createIfcCurveBoundedPlane(
                plane, polyline(f, _open_ring(outer)), [polyline(f, _open_ring(r)) for r in inner]), None)




def _open_ring(pts):
    """The ring ``pts`` (k, 2 or 3) without a last point repeating the first."""
    pts = np.asarray(pts, dtype=np.float64)
    return pts[:-1] if len(pts) > 1 and np.allclose(pts[0], pts[-1]) else pts


def _is_space_entity(e) -> bool:
    return e.is_a("IfcSpace") or e.is_a("IfcExternalSpatialElement")


def _find_pset(product, name):
    import ifcopenshell.util.element as ue

    return ue.get_psets(product).get(name)
