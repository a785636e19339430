"""The rules of the shape grammar (docs/method.md §2), written so that they read like it.

A rule is ``antecedent → subsequent : condition``. Here:

* :func:`classify` — rule 2, ``A → A[type] : cond`` (wall / interior / exterior);
* :func:`part_relations` — rules 3 and 4 *before merging*: adjacency of shapes sharing a
  face, connectivity when the common face carries no surface (IPoF < τ);
* :func:`merge` — rule 5, connected interior (or exterior) parts become their union;
  wall parts in one line become one wall; rule 6 *containment* records parent/children;
* :func:`space_relations` — rules 3 and 4 *after merging*: spaces are adjacent when a
  wall lies between them and connected when that wall holds a door;
* :func:`derive_topology` — the production order after classification:
  connectivity* → (merge, containment, adjacency)* → doors → connectivity*.
  Manual reclassification and door insertion call it again, so everything downstream is
  re-derived from the parts and their stored point-on-face figures.

These functions work on any model whose parts (placed shapes) carry ``ipof_f<i>`` support
figures per face; the Manhattan grammar makes such parts, and the generic pipeline can.
"""
from __future__ import annotations

import logging
from collections import defaultdict
from typing import Optional

import numpy as np

from ..geometry.polygon import polygon_area
from ..model import BuildingModel, Relation, Shape, ShapeType
from .geometry import box_of, shared_faces, union_of_boxes

__all__ = ["classify", "part_relations", "merge", "space_relations", "derive_topology",
           "wall_with_openings", "is_part", "reject_implausible_spaces", "DEFAULT_TAU"]

log = logging.getLogger(__name__)

DEFAULT_TAU = 0.3
"""τ used when a model does not record its own (``provenance.parameters['tau']``)."""

_SPACE_TYPES = (ShapeType.INTERIOR, ShapeType.EXTERIOR)
_OPPOSITE = -0.99
"""Two faces face each other across a wall or door when their normals' dot product is
below this (antiparallel within ~8°)."""
_CORRIDOR_ASPECT, _CORRIDOR_WIDTH = 3.0, 2.5
"""Naming defaults when the model records no ``corridor_aspect`` / ``corridor_max_width``
(see ManhattanParams)."""


# --------------------------------------------------------------------------- rule 2
def classify(support: dict, thin: bool, above_interior: bool, tau: float, *,
             on_floor: bool = False, min_evidence: float = 0.0) -> tuple[ShapeType, str]:
    """Rule 2, classify ``A → A[type]``.

    Parameters
    ----------
    support : the part's point-on-face figures (``ipof_sides``, ``ipof_top``).
    thin : its smaller horizontal size is at most the maximum wall thickness.
    above_interior : its top face touches a shape already typed interior.
    tau : τ.
    on_floor, min_evidence : the part stands on the storey's floor; a seen top with at most
        ``min_evidence`` of floor under it and of wall on its sides (all, or all but one under a
        partial top) is no room (below); 0 turns that off.

    Returns the type and the log line that says why.

    The conditions, in order:

    * thin, IPoF(sides) ≥ τ, IPoF(top) < τ and the top touches no interior shape →
      wall. (docs/method.md §2: thin and IPoF(sides) ≥ τ. The extra "top not seen" conditions keep
      a thin slice of a room between a wall and a cupboard, whose top is ceiling or the
      room above, from becoming a wall.)
    * IPoF(top) ≥ τ, or the top touches an interior shape → interior space; but a part on
      the floor whose top alone is seen — IPoF(bottom) at most ``min_evidence``, and no side
      above it (or one, under a partial top, IPoF(top) < 2τ: a wall running on past the
      glazing) — is exterior: the ceiling evidence is a window's head soffit in a glazed
      exterior wall, or an eave seen through the glazing, with no floor and no walls under it
      (issue 19: rooms never extend past the glazed envelope);
    * a part on the floor whose floor is seen (IPoF(bottom) ≥ τ, or above ``min_evidence``
      with at least two sides seen above it: a cabinet hides the floor) and whose ceiling is
      seen only sparsely — covered at least τ when each point covers a disc of its local
      spacing (``ipof_top_sparse``, ManhattanParams.ceiling_reach), not of σ — is interior: a
      ceiling seen from far away, at a grazing angle or over a cabinet, is there (issue 19:
      "not seen" is not "not there"); floor and sides keep a glazed wall's eave out;
    * otherwise → exterior space.
    """
    sides, top = support.get("ipof_sides", 0.0), support.get("ipof_top", 0.0)
    if thin and sides >= tau and top < tau and not above_interior:
        return ShapeType.WALL, (f"classify: thin, IPoF(sides)={sides:.2f} >= tau={tau:g}, "
                                f"IPoF(top)={top:.2f} < tau -> wall")
    if top >= tau:
        sides_seen = sum(support.get(f"ipof_f{q}", 1.0) > min_evidence for q in range(2, 6))
        if on_floor and min_evidence > 0 and support.get("ipof_bottom", 1.0) <= min_evidence and \
                (sides_seen == 0 or (sides_seen == 1 and top < 2 * tau)):
            return ShapeType.EXTERIOR, (f"classify: IPoF(top)={top:.2f} >= tau={tau:g} but no floor and "
                                        f"{sides_seen} side(s) seen (> {min_evidence:g}) -> exterior "
                                        "(a soffit or eave, not a room)")
        return ShapeType.INTERIOR, f"classify: IPoF(top)={top:.2f} >= tau={tau:g} -> interior"
    sparse, bottom = support.get("ipof_top_sparse", top), support.get("ipof_bottom", 0.0)
    sides_seen = sum(support.get(f"ipof_f{q}", 0.0) > min_evidence for q in range(2, 6))
    if on_floor and sparse >= tau and (bottom >= tau or (bottom > min_evidence and sides_seen >= 2)):
        return ShapeType.INTERIOR, (f"classify: IPoF(top)={top:.2f} < tau={tau:g} but the ceiling is seen "
                                    f"sparsely (IPoF at its local spacing {sparse:.2f}) over a seen floor "
                                    f"(IPoF(bottom)={bottom:.2f}, {sides_seen} side(s) seen) -> interior")
    if above_interior:
        return ShapeType.INTERIOR, (f"classify: IPoF(top)={top:.2f} < tau={tau:g} "
                                    "but top touches an interior shape -> interior")
    return ShapeType.EXTERIOR, f"classify: IPoF(top)={top:.2f} < tau={tau:g}" + (
        f", IPoF(sides)={sides:.2f}" if thin else "") + " -> exterior"


# --------------------------------------------------------------------------- helpers
def is_part(s: Shape) -> bool:
    """A placed shape (grammar part): a cuboid from the place rule or a cell."""
    return s.grid is not None or bool(s.attributes.get("part"))


def _open_boundary(a: Shape, fa: int, b: Shape, fb: int) -> bool:
    """The face shared by parts ``a`` and ``b`` is an open boundary between two spaces of an
    open plan (``attributes["open_face"]``, a passage under a beam)."""
    return a.attributes.get("open_face") == fa or b.attributes.get("open_face") == fb


def _joined(a: Shape, fa: int, b: Shape, fb: int) -> bool:
    """The face shared by parts ``a`` and ``b`` is furniture, not a wall (``attributes
    ["joined_faces"]``, set by :func:`reject_implausible_spaces`): their spaces are one."""
    return fa in a.attributes.get("joined_faces", ()) or fb in b.attributes.get("joined_faces", ())


def _face_ipof(s: Shape, face: int) -> float:
    return float(s.support.get(f"ipof_f{face}", 0.0))


class _UnionFind:
    def __init__(self, items):
        self.p = {i: i for i in items}

    def find(self, a):
        while self.p[a] != a:
            self.p[a] = self.p[self.p[a]]
            a = self.p[a]
        return a

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            if rb < ra:
                ra, rb = rb, ra
            self.p[rb] = ra

    def groups(self):
        g = defaultdict(list)
        for i in self.p:
            g[self.find(i)].append(i)
        return list(g.values())


# --------------------------------------------------------------------------- rules 3, 4
def part_relations(parts: list[Shape], tau: float, touching=None) -> tuple[list[Relation], list[tuple]]:
    """Rules 3 and 4 before merging.

    Adjacency ``{A1, A2} → {A1[adj], A2[adj]}`` when they share a face; connectivity when
    both are spaces of one type and the common face carries no surface,
    IPoF(common face) < τ. Returns the relations and the list of connected pairs.
    ``touching`` : the :func:`shared_faces` of ``parts`` when already known.
    """
    touching = shared_faces(parts) if touching is None else touching
    by_id = {s.id: s for s in parts}
    rel, connected = [], []
    for t in touching:
        a, b = by_id[t.a], by_id[t.b]
        if a.storey != b.storey:
            continue
        rel.append(Relation("adjacency", a.id, b.id))
        if a.type == b.type and a.type in _SPACE_TYPES:
            f = max(_face_ipof(a, t.fa), _face_ipof(b, t.fb))
            if _open_boundary(a, t.fa, b, t.fb):  # split there, connected without a wall
                if a.type == ShapeType.INTERIOR:
                    rel.append(Relation("connectivity", a.id, b.id))
            elif f < tau or _joined(a, t.fa, b, t.fb):
                connected.append((a.id, b.id))
                if a.type == ShapeType.INTERIOR:
                    rel.append(Relation("connectivity", a.id, b.id))
    return rel, connected


# --------------------------------------------------------------------------- rules 5, 6
def _plan_weighted(parts: list[Shape], key: str, default: float) -> float:
    """The mean of a support figure (``key``, ``default`` when missing) over ``parts``, each
    weighted by its plan area: the share of their plan it covers."""
    b = _bounds_union(parts)
    area = np.prod(b[:, 1, :2] - b[:, 0, :2], axis=1)
    values = [float(m.support.get(key, default)) for m in parts]
    return float(np.dot(area, values) / max(float(area.sum()), 1e-12))


def _bounds_union(shapes: list[Shape]) -> np.ndarray:
    return np.stack([s.bounds for s in shapes])


def _merge_walls(walls: list[Shape]) -> list[list[Shape]]:
    """Wall parts of one line: consecutive grid cuboids with the same thin interval."""
    groups, used = [], set()
    grid = [w for w in walls if w.grid is not None]
    for w in walls:
        if w.grid is None:
            groups.append([w])
            used.add(w.id)
    for axis in (0, 1):  # runs along y of parts thin in x, then runs along x
        run_axis = 1 - axis
        cells = {}
        for w in grid:
            if w.id in used:
                continue
            ta = w.attributes.get("thin_axis", axis)
            if ta not in (axis, 2):
                continue
            key = (w.storey, w.grid[axis], w.grid[2])
            cells.setdefault(key, {})[w.grid[run_axis]] = w
        for key, row in sorted(cells.items()):
            idx = sorted(row)
            run = []
            for j in idx:
                if run and j != run[-1].grid[run_axis] + 1:
                    groups.append(run)
                    run = []
                run.append(row[j])
            if run:
                groups.append(run)
            for w in row.values():
                used.add(w.id)
    return groups


def wall_with_openings(lo, hi, openings) -> "Polyhedron":  # noqa: F821
    """A box wall with door openings cut through it.

    ``lo``, ``hi`` : (3,) corners of the wall, metres; ``openings`` : list of (lo, hi)
    door boxes (clipped to the wall). Returns the boundary of wall minus openings.
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if not openings:
        return box_of(lo, hi)
    ops = [(np.maximum(np.asarray(a, float), lo), np.minimum(np.asarray(b, float), hi)) for a, b in openings]
    cuts = [np.unique(np.concatenate([[lo[k], hi[k]], *[[a[k], b[k]] for a, b in ops]])) for k in range(3)]
    cells = []
    for i in range(len(cuts[0]) - 1):
        for j in range(len(cuts[1]) - 1):
            for k in range(len(cuts[2]) - 1):
                c = np.array([(cuts[0][i] + cuts[0][i + 1]) / 2, (cuts[1][j] + cuts[1][j + 1]) / 2,
                              (cuts[2][k] + cuts[2][k + 1]) / 2])
                if any(np.all(c > a) and np.all(c < b) for a, b in ops):
                    continue
                cells.append([[cuts[0][i], cuts[1][j], cuts[2][k]], [cuts[0][i + 1], cuts[1][j + 1], cuts[2][k + 1]]])
    return union_of_boxes(np.array(cells))


def merge(parts: list[Shape], connected: list[tuple]) -> tuple[list[Shape], list[Shape]]:
    """Rule 5, merge ``{A1, A2} → B``, with rule 6, containment (B contains A1, A2).

    Connected interior parts become one interior space, connected exterior parts one
    exterior space, wall parts of one line one wall. Every merged shape is active and
    lists its parts as ``children``; the parts become inactive with ``parent`` set.
    Returns (merged shapes, updated parts).
    """
    by_id = {s.id: s for s in parts}
    uf = _UnionFind([s.id for s in parts if s.type in _SPACE_TYPES])
    for a, b in connected:
        if a in uf.p and b in uf.p:
            uf.union(a, b)
    merged, parent_of = [], {}
    for grp in uf.groups():
        members = sorted((by_id[i] for i in grp), key=lambda s: s.id)
        kind = members[0].type
        sid = ("space_" if kind == ShapeType.INTERIOR else "exterior_") + members[0].id
        merged.append(_merged_shape(sid, kind, members))
        for m in members:
            parent_of[m.id] = sid
    for run in _merge_walls([s for s in parts if s.type == ShapeType.WALL]):
        run = sorted(run, key=lambda s: s.id)
        sid = "wall_" + run[0].id
        merged.append(_merged_shape(sid, ShapeType.WALL, run))
        for m in run:
            parent_of[m.id] = sid
    new_parts = []
    for s in parts:
        p = parent_of.get(s.id)
        new_parts.append(s.with_(parent=p, active=p is None, children=()))
    return merged, new_parts


def _merged_shape(sid: str, kind: ShapeType, members: list[Shape]) -> Shape:
    b = _bounds_union(members)
    geom = union_of_boxes(b)
    lo, hi = b[:, 0].min(axis=0), b[:, 1].max(axis=0)
    attrs = {"merged": True, "floor_z": float(lo[2]), "ceiling_z": float(hi[2])}
    if kind == ShapeType.WALL:
        size = hi - lo
        axis = int(np.argmax(size[:2]))
        attrs.update(thickness=float(size[1 - axis]), axis=axis, height=float(size[2]))
    elif kind == ShapeType.INTERIOR:
        fp = geom.footprint()
        if fp is not None:
            attrs["area"] = polygon_area(fp)
        attrs["height"] = float(hi[2] - lo[2])
    line = f"merge: {len(members)} connected {kind.value} part(s) -> {sid}"
    return Shape(id=sid, type=kind, geometry=geom, storey=members[0].storey, terminal=True,
                 active=True, children=tuple(m.id for m in members), attributes=attrs, log=(line,))


# --------------------------------------------------------------------------- doors
def _attach_doors(walls: list[Shape], doors: list[Shape]) -> tuple[list[Shape], list[Shape]]:
    """Rule 6 for doors: each door is contained in the wall holding its centre; the
    wall's geometry gets the opening. Doors whose wall is gone are dropped (logged)."""
    out_walls, out_doors = {w.id: w for w in walls}, []
    holes = defaultdict(list)
    for d in doors:
        c = np.asarray(d.attributes.get("center", d.centroid), dtype=float)
        host = None
        for w in walls:
            lo, hi = w.bounds
            if np.all(c >= lo - 1e-6) and np.all(c <= hi + 1e-6):
                host = w
                break
        if host is None:
            log.warning("door %s: no wall holds it any more; dropped", d.id)
            continue
        out_doors.append(d.with_(parent=host.id, storey=host.storey))
        holes[host.id].append(d)
    for wid, ds in holes.items():
        w = out_walls[wid]
        lo, hi = w.bounds
        geom = wall_with_openings(lo, hi, [tuple(d.bounds) for d in ds])
        out_walls[wid] = w.with_(geometry=geom, scope=w.scope, children=w.children + tuple(d.id for d in ds),
                                 attributes={**w.attributes, "openings": [d.id for d in ds]})
    return list(out_walls.values()), out_doors


# --------------------------------------------------------------------------- rules 3, 4 after merge
def space_relations(parts: list[Shape], top: dict, doors: list[Shape],
                    touching=None) -> list[Relation]:
    """Rules 3 and 4 after merging.

    Adjacency: an interior space and another space (interior or exterior) with a wall
    between them (``via`` = the wall), or sharing a face directly. Connectivity: spaces
    whose common wall holds a door (``via`` = the door), recorded between the spaces and
    between the parts on either side of the door (so the sub-space graph passes through
    the door too).
    ``top`` maps a part id to its merged shape id.
    """
    touching = shared_faces(parts) if touching is None else touching
    by_id = {s.id: s for s in parts}
    rel = []
    # faces of wall parts, by side: wall part -> {face: [space parts]}
    sides = defaultdict(lambda: defaultdict(list))
    for t in touching:
        a, b = by_id[t.a], by_id[t.b]
        if a.storey != b.storey:
            continue
        for w, fw, s in ((a, t.fa, b), (b, t.fb, a)):
            if w.type == ShapeType.WALL and s.type in _SPACE_TYPES:
                sides[w.id][fw].append(s)
        if (a.type in _SPACE_TYPES and b.type in _SPACE_TYPES and ShapeType.INTERIOR in (a.type, b.type)
                and top[a.id] != top[b.id]):
            rel.append(Relation("adjacency", top[a.id], top[b.id]))
            if a.type == b.type and _open_boundary(a, t.fa, b, t.fb):
                rel.append(Relation("connectivity", top[a.id], top[b.id]))
    for wid, faces in sides.items():
        w = by_id[wid]
        normals = {f: w.geometry.face_normal(f) for f in faces}
        fl = list(faces)
        for i in range(len(fl)):
            for j in range(i + 1, len(fl)):
                if normals[fl[i]] @ normals[fl[j]] > _OPPOSITE:
                    continue
                for L in faces[fl[i]]:
                    for R in faces[fl[j]]:
                        if ShapeType.INTERIOR in (L.type, R.type) and top[L.id] != top[R.id]:
                            rel.append(Relation("adjacency", top[L.id], top[R.id], top[wid]))
    if doors:
        door_touch = shared_faces(list(doors) + [s for s in parts if s.type in _SPACE_TYPES])
        dsides = defaultdict(lambda: defaultdict(list))
        door_ids = {d.id: d for d in doors}
        for t in door_touch:
            if t.a in door_ids and t.b in by_id:
                dsides[t.a][t.fa].append(by_id[t.b])
            elif t.b in door_ids and t.a in by_id:
                dsides[t.b][t.fb].append(by_id[t.a])
        for did, faces in dsides.items():
            d = door_ids[did]
            fl = list(faces)
            for i in range(len(fl)):
                for j in range(i + 1, len(fl)):
                    if d.geometry.face_normal(fl[i]) @ d.geometry.face_normal(fl[j]) > _OPPOSITE:
                        continue
                    for L in faces[fl[i]]:
                        for R in faces[fl[j]]:
                            if L.id == R.id:
                                continue
                            rel.append(Relation("connectivity", L.id, R.id, did))
                            if top[L.id] != top[R.id]:
                                rel.append(Relation("connectivity", top[L.id], top[R.id], did))
    return rel


# --------------------------------------------------------------------------- procedure
def derive_topology(model: BuildingModel, tau: Optional[float] = None) -> BuildingModel:
    """Re-derive everything downstream of classification; returns a new model.

    connectivity of parts → merge + containment → adjacency → doors (containment) →
    connectivity. Works from the parts' types and stored face figures, so it needs no
    point cloud: this is what a manual reclassification or door insertion re-runs.

    A model without parts (e.g. a ground-truth or IFC model) keeps its spaces and walls;
    only its relations are re-derived (walls between spaces, doors in walls).
    """
    if tau is None:
        tau = float(model.provenance.parameters.get("tau", DEFAULT_TAU)) if model.provenance else DEFAULT_TAU
    parts = [s for s in model.shapes if is_part(s)]
    doors = [s for s in model.shapes if s.type == ShapeType.DOOR]
    if parts:
        others = [s for s in model.shapes if not is_part(s) and not s.attributes.get("merged")
                  and s.type != ShapeType.DOOR]
        touching = shared_faces(parts)
        rel_parts, connected = part_relations(parts, tau, touching)
        merged, parts = merge(parts, connected)
        walls = [m for m in merged if m.type == ShapeType.WALL]
        walls, doors = _attach_doors(walls, doors)
        merged = [m for m in merged if m.type != ShapeType.WALL] + walls
        prm = model.provenance.parameters if model.provenance else {}
        merged = _name(merged, float(prm.get("corridor_aspect", _CORRIDOR_ASPECT)),
                       float(prm.get("corridor_max_width", _CORRIDOR_WIDTH)))
        top = {p.id: p.parent or p.id for p in parts}
        rel = rel_parts + space_relations(parts, top, doors, touching)
        shapes = parts + merged + doors + others
    else:
        units = [s for s in model.shapes if s.type in _SPACE_TYPES + (ShapeType.WALL,) and s.active]
        walls = [s for s in units if s.type == ShapeType.WALL]
        top = {s.id: s.id for s in units}
        rel = space_relations(units, top, [d for d in doors if d.active])
        shapes = list(model.shapes)
    order = {s.id: i for i, s in enumerate(model.shapes)}
    shapes.sort(key=lambda s: order.get(s.id, len(order)))
    return model.with_(shapes=tuple(shapes), relations=tuple(dict.fromkeys(rel)))


def _equivalent_width(area: float, perimeter: float) -> float:
    """Shorter side of the rectangle with this area and perimeter (√area when the shape is
    more compact than a square): how wide a plan is, for any outline."""
    h = perimeter / 2.0
    disc = h * h - 4.0 * area
    if area <= 0 or perimeter <= 0:
        return 0.0
    if disc <= 0:
        return float(np.sqrt(area))
    return float((h - np.sqrt(disc)) / 2.0)


def reject_implausible_spaces(model: BuildingModel, min_width: float, min_area: float, min_height: float,
                              tau: Optional[float] = None, *,
                              min_floor_evidence: float = 0.0, furniture_area: float = 0.0) -> BuildingModel:
    """Evidence rule for spaces (issue 19), a reclassification of parts followed by
    :func:`derive_topology`:

    * a merged interior space narrower than ``min_width`` (the smaller side of its box, or
      twice its area over its perimeter for other shapes) is the gap between the two faces of
      one wall (doubled wall lines, a party wall): its parts become wall;
    * one lower than ``min_height`` (a band between two ceiling levels) or smaller than
      ``min_area`` is not a room: its parts become exterior;
    * one standing on its storey's floor whose floor is seen under none of its parts (every
      part's bottom IPoF at most ``min_floor_evidence``; 0 turns this off) is the inside of
      furniture up to near the ceiling (a wardrobe whose front the grid cut at a wall line
      elsewhere; its top is the ceiling seen above it): its parts become exterior; so does
      one up to ``furniture_area`` whose floor is seen under at most ``min_floor_evidence`` of
      its footprint, its parts weighted by their area (a strip along a wardrobe's front
      catches the floor's noise). A room seen through a door shows some floor.

    Models without parts are returned unchanged.
    """
    parts = {s.id: s for s in model.shapes if is_part(s)}
    if not parts:
        return model
    by_grid = {(p.storey, p.grid): p for p in parts.values() if p.grid is not None}
    widths = {sp.id: _width(sp) for sp in model.spaces if sp.attributes.get("merged")}
    narrow = {sid for sid, w in widths.items() if w < min_width}
    new = []
    for sp in model.spaces:
        if not sp.attributes.get("merged"):
            continue
        members = [parts[c] for c in sp.children if c in parts]
        if not members:
            continue
        size = sp.scope.size
        area, _ = sp.geometry.plan_area_perimeter()
        width = widths[sp.id]
        height = float(sp.attributes.get("height", size[2]))
        if width < min_width:
            join = _strip_join(members, by_grid, tau if tau is not None else DEFAULT_TAU, min_floor_evidence,
                               min_width / 2, narrow)
            if join:
                new.extend(join)
                continue
            kind, why = ShapeType.WALL, f"{width:.2f} m wide < {min_width} m: the gap inside a wall"
        elif height < min_height or area < min_area:
            kind, why = ShapeType.EXTERIOR, f"{area:.2f} m², {height:.2f} m high: too small or low for a room"
        elif min_floor_evidence > 0 and _no_floor(members, area, min_floor_evidence, furniture_area):
            kind = ShapeType.EXTERIOR
            why = f"no floor seen under it (≤ {min_floor_evidence}): furniture, not a room"
        else:
            continue
        for m in members:
            new.append(m.with_(type=kind, log=tuple(m.log) + (f"evidence: {sp.id} {why} -> {kind.value}",)))
    if not new:
        return model
    log.info("evidence rule: %d part(s) of implausible spaces reclassified", len(new))
    return derive_topology(model.replace_shapes(*new), tau)


def _no_floor(members: list[Shape], area: float, min_floor: float, furniture_area: float) -> bool:
    """Whether a space of these parts stands on its storey's floor with no floor seen under
    it: no part's floor index above ``min_floor``, or, up to ``furniture_area`` m², their
    area-weighted mean at most that."""
    if any(m.grid is None or m.grid[2] != 0 for m in members):
        return False
    bottom = np.array([float(m.support.get("ipof_bottom", 1.0)) for m in members])
    if np.all(bottom <= min_floor):
        return True
    if area > furniture_area:
        return False
    return _plan_weighted(members, "ipof_bottom", 1.0) <= min_floor


def _width(sp: Shape) -> float:
    """A space's width: the smaller side of its box, or twice its area over its perimeter."""
    size = sp.scope.size
    area, perim = sp.geometry.plan_area_perimeter()
    return min(float(min(size[0], size[1])), _equivalent_width(area, perim))


def _strip_join(members: list[Shape], by_grid: dict, tau: float, min_floor: float,
                open_width: float = np.inf, narrow: frozenset = frozenset()) -> list[Shape]:
    """A narrow space whose ceiling is seen over every part (IPoF(top) ≥ τ), whose floor
    shows (IPoF(bottom) above ``min_floor`` somewhere) and whose long sides are not both seen
    (IPoF ≥ τ) is no gap inside a wall — that has neither, or shows both of the wall's faces —
    but a strip of a room cut off by the front of furniture (a cabinet against a partition).
    Its parts join the interior parts of the same storey and top height across the face
    carrying less surface (``attributes["joined_faces"]``) — parts of a room, not of another
    narrow space (``narrow``: their ids; judged on their own, a 20 cm one beside a 30 cm strip
    became a wall and left the strip a 1.45 m² "Corridor", two_storey_office TLS 7 at 200k
    points). ``by_grid``: the model's parts by (storey, grid index). Returns the changed parts,
    [] when it is no such strip (or has no such neighbour)."""
    if not members or min_floor <= 0 or any(m.grid is None for m in members):
        return []
    if any(float(m.support.get("ipof_top", 0.0)) < tau for m in members) or \
            max(float(m.support.get("ipof_bottom", 0.0)) for m in members) <= min_floor:
        return []
    # both long sides seen: the two faces of one wall (its top and floor "seen" are the
    # ceiling's and floor's edges), not furniture in front of a wall — unless the ceiling is
    # seen over most of a strip (IPoF(top) ≥ 2τ, parts weighted by area) at least ``open_width`` wide,
    # which no edge spills over a wall's inside (two_storey_office at 200k points: a 0.5 m
    # strip behind a cabinet, its ceiling 0.71-0.93 seen, the partition behind it and the
    # cabinet's front both planes — a 0.7 m "wall" with a 4.7 m full-height "door" in it; the
    # edges do cover an 11 cm gap between two wall lines)
    b = _bounds_union(members)
    lo, hi = b[:, 0].min(axis=0), b[:, 1].max(axis=0)
    sides = (3, 5) if hi[0] - lo[0] <= hi[1] - lo[1] else (2, 4)
    # the share of the strip's plan whose ceiling is seen (the parts weighted by their area:
    # a 0.3 m part by the partition 0.52 seen and a 0.2 m one 0.84, two_storey_office TLS 5
    # at 100k points, is a strip 0.65 seen)
    top = _plan_weighted(members, "ipof_top", 0.0)
    open_top = float(min(hi[:2] - lo[:2])) >= open_width and top >= 2.0 * tau
    mine = {m.id for m in members}
    # faces 2..5: −y, +x, +y, −x
    steps = {2: (0, -1), 3: (1, 0), 4: (0, 1), 5: (-1, 0)}

    def outer(q):  # the strip's faces on side q (not those between two of its parts)
        di, dj = steps[q]
        return [_face_ipof(m, q) for m in members
                if getattr(by_grid.get((m.storey, (m.grid[0] + di, m.grid[1] + dj, m.grid[2]))), "id", None)
                not in mine] or [0.0]

    if not open_top and all(np.mean(outer(q)) >= tau for q in sides):
        return []
    best = None
    for q, (di, dj) in steps.items():
        score, n = 0.0, 0
        for m in members:
            i, j, k = m.grid
            nb = by_grid.get((m.storey, (i + di, j + dj, k)))
            if nb is None or nb.id in mine:
                continue
            if nb.type != ShapeType.INTERIOR or abs(float(nb.bounds[1, 2]) - float(m.bounds[1, 2])) > 0.05 \
                    or nb.parent in narrow:  # a room, not another narrow space (itself judged here)
                score, n = None, 0
                break
            score, n = score + _face_ipof(m, q), n + 1
        if score is not None and n and (best is None or score / n < best[1]):
            best = (q, score / n)
    if best is None:
        return []
    q, why = best[0], (f"evidence: a strip with its ceiling and floor seen, not a wall's inside: "
                       f"joins the room across face {best[0]} (IPoF {best[1]:.2f}, furniture)")
    return [m.with_(attributes={**m.attributes,
                                "joined_faces": tuple(sorted({*m.attributes.get("joined_faces", ()), q}))},
                    log=tuple(m.log) + (why,)) for m in members]


def _name(merged: list[Shape], corridor_aspect: float, corridor_width: float) -> list[Shape]:
    """Names: "Room n" / "Corridor" (long and narrow) / "Wall n" / "Exterior n", numbered by
    storey then position."""
    def key(s):
        c = s.centroid
        return (s.storey, round(float(c[1]), 2), round(float(c[0]), 2))

    out, counters = [], defaultdict(int)
    for s in sorted(merged, key=key):
        if s.type == ShapeType.INTERIOR:
            sz = s.scope.size
            long_, short = max(sz[0], sz[1]), min(sz[0], sz[1])
            if short > 0 and long_ / short >= corridor_aspect and short <= corridor_width:
                label = "Corridor"
            else:
                label = "Room"
        elif s.type == ShapeType.WALL:
            label = "Wall"
        else:
            label = "Exterior"
        counters[label] += 1
        n = counters[label]
        name = (label if n == 1 else f"{label} {n}") if label == "Corridor" else f"{label} {n}"
        out.append(s.with_(name=name))
    return out
