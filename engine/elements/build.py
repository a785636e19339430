"""The building-elements stage: a reconstruction's spaces → walls, slabs, exterior, openings.

:func:`building_elements` works on any :class:`BuildingModel` with interior spaces (either
method's result, a model after manual edits); with a scan it also finds the doors, doorless
openings and windows in the walls (:mod:`.openings`). It is idempotent: elements it made
before are replaced, and openings that came without a scan (inserted by hand, or found
earlier) move to the new wall that holds them.

The method's own walls and exteriors (thin cuboids, wall cells) stay in the model as
inactive parts: the grammar and the sub-space view read them; the walls an architect sees
are the runs.
"""
from __future__ import annotations

import logging
import time
from typing import Mapping, Optional

import numpy as np
import shapely
from shapely.geometry import Point, Polygon
from shapely.ops import unary_union

from ..geometry.polygon import polygon_parts
from ..model import BuildingModel, Polyhedron, Relation, Shape, ShapeType
from .params import ElementsParams, SlabParams
from .egress import elevated_doors
from .skylights import host_slab, roof_windows
from .thickness import PointGrid, reveal_depth
from .walls import WallRun, space_footprint, wall_runs

__all__ = ["ElementsParams", "building_elements", "ELEMENT_LOG"]

log = logging.getLogger(__name__)

ELEMENT_LOG = "elements"
"""First word of the log entry of every shape this stage makes (so a re-run replaces them)."""


def _made_here(s: Shape) -> bool:
    return bool(s.log) and str(s.log[0]).startswith(ELEMENT_LOG)


def _keyhole(poly: Polygon) -> np.ndarray:
    """A polygon with holes as one ring through zero-width slits (for a prism)."""
    ring = list(np.asarray(poly.exterior.coords)[:-1, :2])
    for hole in poly.interiors:
        h = np.asarray(hole.coords)[:-1, :2]
        R = np.asarray(ring)
        d = np.linalg.norm(R[:, None, :] - h[None, :, :], axis=2)
        i, j = np.unravel_index(int(np.argmin(d)), d.shape)
        hh = list(np.roll(h, -j, axis=0))
        ring = ring[:i + 1] + hh + [hh[0], ring[i]] + ring[i + 1:]
    return np.asarray(ring)


def _storey_spaces(model: BuildingModel) -> dict:
    out = {}
    for s in model.spaces:
        if s.parent is not None and s.parent in model and model[s.parent].type == ShapeType.INTERIOR:
            continue
        out.setdefault(s.storey, []).append(s)
    return out


def _span_sides(run_shape: Shape, u: float):
    """The spaces on the two sides of a wall run at ``u`` along it: those of the side span
    holding ``u``, else of the nearest one (a room whose footprint takes in its doorway
    leaves a gap in its span there: office_mw mobile at 1M points, a door then took the
    run's first room, 8 m away), else the run's."""
    spans = run_shape.attributes.get("side_spans", [])
    if spans:
        gap = [max(u0 - u, u - u1, 0.0) for u0, u1, _, _ in spans]
        _, _, left, right = spans[int(np.argmin(gap))]
        return left, right
    return tuple(run_shape.attributes.get("sides", (None, None)))


def _wall_shape(run: WallRun, k: int, z0: float, z1: float, exterior_id: str) -> Shape:
    def named(this, other):  # a missing side: the exterior, or the void an interior wall faces
        return this if this is not None else exterior_id if run.external or other is None else other
    left, right = run.sides()
    sides = [named(left, right), named(right, left)]
    spans = [[float(u0), float(u1), named(lft, rgt), named(rgt, lft)] for u0, u1, lft, rgt in run.spans]
    kind = "Exterior wall" if run.external else "Wall"
    return Shape(f"wall_s{run.storey}_{k:03d}", ShapeType.WALL, Polyhedron.prism(run.footprint(), z0, z1),
                 storey=run.storey, name=f"{kind} {run.storey}.{k + 1}", terminal=True,
                 attributes={"thickness": float(run.thickness), "height": float(z1 - z0),
                             "external": bool(run.external), "thickness_measured": bool(run.measured),
                             "axis_line": [[float(v) for v in run.a], [float(v) for v in run.b]],
                             "sides": sides, "side_spans": spans,
                             "floor_z": float(z0), "ceiling_z": float(z1)},
                 log=(f"{ELEMENT_LOG}: wall run {run.length:.2f} m, {run.thickness:.3f} m thick"
                      f"{' (exterior)' if run.external else ''}",))


def _slabs(storey_geo: dict, model: BuildingModel, prm: SlabParams) -> list[Shape]:
    """Floor slab under and ceiling/roof slabs above each storey."""
    st = {s.index: s for s in model.storeys}
    order = sorted(storey_geo)
    shapes = []
    for pos, k in enumerate(order):
        outline, rooms, _ = storey_geo[k]
        floor = min(float(r.bounds[0, 2]) for r in rooms)
        above = order[pos + 1] if pos + 1 < len(order) else None
        below = order[pos - 1] if pos > 0 else None
        # the floor slab: thickness from the gap to the storey below when it was scanned
        t = prm.thickness
        if below is not None:
            ceil_below = max(float(r.bounds[1, 2]) for r in storey_geo[below][1])
            gap = floor - ceil_below
            if 0.02 < gap <= prm.max_gap:
                t = gap
        for poly in polygon_parts(outline):
            ring = _keyhole(poly) if len(poly.interiors) else np.asarray(poly.exterior.coords)[:-1, :2]
            sid = f"slab_s{k}_floor_{len(shapes):02d}"
            shapes.append(Shape(sid, ShapeType.SLAB, Polyhedron.prism(ring, floor - t, floor), storey=k,
                                name=f"Floor {st[k].name if k in st else k}", terminal=True,
                                attributes={"kind": "base" if below is None else "floor", "thickness": float(t),
                                            "thickness_measured": t != prm.thickness},
                                log=(f"{ELEMENT_LOG}: floor slab {t:.3f} m",)))
        if above is not None:
            floor_above = min(float(r.bounds[0, 2]) for r in storey_geo[above][1])
            ceil = max(float(r.bounds[1, 2]) for r in rooms)
            if 0.02 < floor_above - ceil <= prm.max_gap:
                continue  # the floor slab of the storey above closes this one
        # ceilings: one slab per ceiling level (rooms of different heights)
        levels = {}
        for r in rooms:
            top = float(r.bounds[1, 2])
            key = next((lv for lv in levels if abs(lv - top) <= prm.level_tolerance), top)
            levels.setdefault(key, []).append(r)
        for lv, rs in sorted(levels.items()):
            region = unary_union([storey_geo[k][2][r.id] for r in rs]).buffer(0)
            # reach over the walls around those rooms (within the outline)
            region = region.buffer(0.35, join_style="mitre").intersection(outline)
            for poly in polygon_parts(region):
                if poly.area < 0.05:
                    continue
                ring = _keyhole(poly) if len(poly.interiors) else np.asarray(poly.exterior.coords)[:-1, :2]
                kind = "roof" if above is None else "ceiling"
                sid = f"slab_s{k}_{kind}_{len(shapes):02d}"
                shapes.append(Shape(sid, ShapeType.SLAB, Polyhedron.prism(ring, lv, lv + prm.thickness),
                                    storey=k, name=f"{kind.capitalize()} {st[k].name if k in st else k}",
                                    terminal=True, attributes={"kind": kind, "thickness": float(prm.thickness),
                                                               "thickness_measured": False},
                                    log=(f"{ELEMENT_LOG}: {kind} slab at {lv:.3f} m",)))
    return shapes


def _exterior_shape(k: int, outline, z0: float, z1: float, old: list[str]) -> Shape:
    band = outline.buffer(1.0, join_style="mitre").difference(outline)
    polys = sorted(polygon_parts(band), key=lambda p: -p.area)
    ring = _keyhole(polys[0]) if polys else None
    geo = Polyhedron.prism(ring, z0, z1) if ring is not None else Polyhedron.box((0, 0, z0), (1e-3, 1e-3, z1))
    return Shape(f"exterior_s{k}", ShapeType.EXTERIOR, geo, storey=k, name=f"Exterior {k}", terminal=True,
                 children=tuple(old), log=(f"{ELEMENT_LOG}: exterior of storey {k}",))


def building_elements(model: BuildingModel, cloud=None, params: Optional[ElementsParams] = None) -> BuildingModel:
    """Walls as runs, slabs, one exterior per storey and (with a scan) openings.

    Parameters
    ----------
    model : BuildingModel with interior spaces (aligned frame).
    cloud : PointCloud or None — the scan in the *input* frame (``model.transform`` maps the
        model to it); None keeps the openings the model has.
    params : ElementsParams

    Returns the model with the element shapes and the room-level relations replaced.
    """
    prm = params or ElementsParams()
    t0 = time.perf_counter()
    detect = cloud is not None and prm.detect_openings
    keep, old_openings = [], []
    for s in model.shapes:
        if s.type in (ShapeType.DOOR, ShapeType.WINDOW):
            # openings found in an earlier run are found again when there is a scan
            if not (detect and s.attributes.get("detected", False)):
                old_openings.append(s)
            continue
        if _made_here(s):
            continue
        keep.append(s)
    made_ext = {s.id for s in model.shapes if s.type == ShapeType.EXTERIOR and _made_here(s)}
    model, keep = _free_exterior_ids(model, keep)
    base = model.with_(shapes=tuple(keep))
    by_storey = _storey_spaces(base)
    top_ids = {s.id for ss in by_storey.values() for s in ss}
    new_shapes, relations, walls = [], [], []
    storey_geo = {}
    old_ext = {}
    for s in base.shapes:
        if s.type == ShapeType.EXTERIOR and (s.active or s.parent in made_ext):
            old_ext.setdefault(s.storey, []).append(s.id)
    footprints = {}
    for k, spaces in sorted(by_storey.items()):
        fps = {}
        for s in spaces:
            g = space_footprint(base, s)
            if g is not None and not g.is_empty:
                fps[s.id] = g
        if fps:
            footprints[k] = fps
    xyz_model = _model_points(model, cloud) if cloud is not None else None
    scan = {k: _StoreyScan(xyz_model, by_storey[k], prm) for k in footprints} if xyz_model is not None else {}
    # thick gaps wait for the openings when there are any to find (one seen through into a
    # gap says it is no wall); without them the points alone decide
    per_storey = {k: _storey_walls(base, k, by_storey[k], fps, prm, old_ext.get(k, []),
                                   solid=scan[k].solid if k in scan and not detect else None,
                                   faces=scan[k].faces if k in scan else None)
                  for k, fps in footprints.items()}
    if not detect:
        xyz_model = None
    detected = []
    if xyz_model is not None:
        first = [w for st in per_storey.values() for w in st[0]]
        base_ext = base.with_(shapes=base.shapes + tuple(st[1] for st in per_storey.values()))
        grid = PointGrid(xyz_model)
        # exterior "doors" of an upper storey with nothing walkable beyond are windows
        lowest = min((float(st.floor_z) for st in base.storeys), default=None)
        detected = elevated_doors(_detect(base_ext, first, xyz_model, cloud, prm, footprints), first, grid,
                                  prm.openings, lowest)
        # interior walls end at their doorless openings (an open plan, not a hole in a
        # wall); exterior walls measured through their openings get that thickness
        breaks, detected = _breaks(first, detected)
        measured = _measured_exteriors(first, detected, grid, prm)
        # rooms farther apart than max_thickness: a thick wall where the gap is solid (empty
        # in the scan, and no opening into it seen through)
        seen = [o for o in detected
                if float((o.support or {}).get("seen_through", 0.0)) >= prm.openings.min_seen_through]
        for k in footprints:
            scan[k].openings = [Point(o.centroid[:2]) for o in seen if o.storey == k]
            per_storey[k] = _storey_walls(base, k, by_storey[k], footprints[k], prm, old_ext.get(k, []),
                                          measured.get(k), breaks.get(k, ()), scan[k].solid, scan[k].faces)
        # openings found in the faces of a gap that is a solid wall now were none
        detected = [o for o in detected if o.storey not in scan
                    or not any(r.contains(Point(o.centroid[:2])) for r in scan[o.storey].found)]
    for k, (st_walls, ext, rels, geo) in per_storey.items():
        new_shapes.extend(st_walls)
        walls.extend(st_walls)
        new_shapes.append(ext)
        relations.extend(rels)
        storey_geo[k] = geo
    slabs = _slabs(storey_geo, base, prm.slabs)
    new_shapes.extend(slabs)
    skylights = []
    if xyz_model is not None:  # holes in the roof over the rooms
        rooms = [(r.id, k, fps[r.id]) for k, fps in footprints.items() for r in by_storey[k] if r.id in fps]
        skylights = roof_windows([s for s in slabs if s.attributes.get("kind") == "roof"], rooms, xyz_model,
                                 {k: f"exterior_s{k}" for k in storey_geo}, prm.skylights)
    # the method's walls and exteriors become parts
    ext_parent = {sid: f"exterior_s{k}" for k, ids in old_ext.items() for sid in ids if k in storey_geo}
    shapes = []
    for s in base.shapes:
        if s.type == ShapeType.WALL and s.active:
            s = s.with_(active=False)
        elif s.id in ext_parent:
            s = s.with_(active=False, parent=ext_parent[s.id])
        shapes.append(s)
    out = base.with_(shapes=tuple(shapes) + tuple(new_shapes))
    # openings
    openings = _rehome(old_openings, walls, out)
    # a user's door (or one kept from before) wins over a detection at its place
    openings += [o for o in _rehome(detected, walls, out) if not _overlaps(o, openings)]
    openings += [o for o in skylights if not _overlaps(o, openings)]
    openings = [_with_spaces(o, out) for o in openings]
    kids = {}
    for o in openings:
        kids.setdefault(o.parent, []).append(o.id)
    out = out.replace_shapes(*[out[w].with_(children=tuple(kids.get(w, ()))) for w in kids if w in out])
    out = out.with_(shapes=out.shapes + tuple(openings))
    for o in openings:
        a, b = o.attributes.get("spaces", [None, None])[:2]
        if a is not None and b is not None and a != b:
            relations.append(Relation("connectivity", min(a, b), max(a, b), o.id)
                             if o.type == ShapeType.DOOR else Relation("adjacency", min(a, b), max(a, b), o.id))
    # room-level relations are the elements' now; part-level ones stay
    room_level = top_ids | {f"exterior_s{k}" for k in storey_geo} | set(ext_parent)
    kept = [r for r in model.relations if not (r.a in room_level and r.b in room_level)]
    relations = [r for r in relations if not (r.kind == "adjacency" and r.via in {o.id for o in openings})]
    out = out.with_(relations=tuple(kept + relations))
    prov = out.provenance
    timings = {**prov.timings, "elements": time.perf_counter() - t0}
    trace = {**prov.trace, "elements": {"walls": len(walls), "external": sum(bool(w.attributes["external"])
                                                                             for w in walls),
                                        "openings": len(openings)}}
    return out.with_(provenance=prov.__class__(prov.method, prov.parameters, prov.seed, timings, trace,
                                               prov.source, prov.software))


def _storey_walls(base: BuildingModel, k: int, spaces: list, fps: dict, prm: ElementsParams, old_ext: list,
                  measured=None, breaks=(), solid=None, faces=None):
    """One storey's wall shapes, exterior, relations and (outline, spaces, footprints)."""
    runs, open_pairs = wall_runs(fps, k, prm.walls, measured, breaks, solid, faces)
    z0 = min(float(s.bounds[0, 2]) for s in spaces)
    z1 = max(float(s.bounds[1, 2]) for s in spaces)
    ext_id = f"exterior_s{k}"
    walls = []
    for i, r in enumerate(runs):
        side_ids = [x for sp in r.spans for x in sp[2:] if x is not None]
        lo = min((float(base[x].bounds[0, 2]) for x in side_ids), default=z0)
        hi = max((float(base[x].bounds[1, 2]) for x in side_ids), default=z1)
        walls.append(_wall_shape(r, i, lo, hi, ext_id))
    id_of = {i: w.id for i, w in enumerate(walls)}
    for r, w in zip(runs, walls):
        w.attributes["joins"] = [{"wall": id_of[j], "at": at, "other_at": other} for j, at, other in r.joins]
    outline = unary_union(list(fps.values()) + [Polygon(w.footprint()) for w in walls])
    outline = outline.buffer(0.02, join_style="mitre").buffer(-0.02, join_style="mitre")
    ext = _exterior_shape(k, outline, z0, z1, old_ext)
    relations, seen = [], set()
    for w in walls:
        for _, _, a, b in w.attributes["side_spans"]:
            key = (min(a, b), max(a, b), w.id)
            if a != b and key not in seen:
                seen.add(key)
                relations.append(Relation("adjacency", key[0], key[1], w.id))
    for a, b in sorted(open_pairs):  # no wall between them: neighbours, and walkable
        relations.append(Relation("adjacency", a, b))
        relations.append(Relation("connectivity", a, b))
    return walls, ext, relations, (outline, spaces, fps)


def _model_points(model: BuildingModel, cloud) -> np.ndarray:
    T = np.linalg.inv(model.transform)
    return cloud.xyz @ T[:3, :3].T + T[:3, 3]


class _StoreyScan:
    """What the scan says about the walls of one storey, from its points between the floor
    and the ceiling (± 5 cm) in a plan grid.

    ``solid(region)``: at most ``solid_share`` of the region's ``cell`` plan cells hold points,
    and no opening seen through (``openings``, centres) lies in it or in its faces; ``found``
    keeps the regions judged solid. ``faces(p, q, n)``: where two spaces touch along p–q, the
    two faces of a wall seen there (mid-height points on two planes parallel to p–q within
    ``face_search`` of it, each along ``face_coverage`` of it and over most of the height, apart
    by ``min_seen_thickness`` or more, emptier between them) as (offset of the axis along n,
    thickness), else None."""

    def __init__(self, xyz: np.ndarray, spaces: list, prm: ElementsParams, cell: float = 0.1):
        self.z0 = min(float(s.bounds[0, 2]) for s in spaces)
        self.z1 = max(float(s.bounds[1, 2]) for s in spaces)
        self.xyz, self.grid = xyz, None  # the storey's points are gridded when first asked for
        self.prm, self.cell = prm.walls, cell
        self.reach = prm.walls.solid_margin + 0.1
        self.openings = []
        self.found = []

    def _inside(self, region) -> np.ndarray:
        if self.grid is None:
            z = self.xyz[:, 2]
            self.pts = self.xyz[(z >= self.z0 - 0.05) & (z <= self.z1 + 0.05)]
            self.grid = PointGrid(self.pts)
        x0, y0, x1, y1 = region.bounds
        p = self.pts[self.grid.in_box(np.array([x0, y0]), np.array([x1, y1]))]
        return p[shapely.contains_xy(region, p[:, 0], p[:, 1])]

    def solid(self, region) -> bool:
        if region.area <= 0:
            return False
        near = region.buffer(self.reach, join_style="mitre")
        if any(near.contains(p) for p in self.openings):
            return False
        p = self._inside(region)[:, :2]
        cells = len(np.unique(np.floor(p / self.cell).astype(np.int64), axis=0)) if len(p) else 0
        if cells > self.prm.solid_share * max(region.area / self.cell ** 2, 1.0):
            return False
        self.found.append(near)
        return True

    def faces(self, p: np.ndarray, q: np.ndarray, n: np.ndarray) -> Optional[tuple]:
        length = float(np.linalg.norm(q - p))
        r = self.prm.face_search
        if length < 4 * self.cell:
            return None
        d = (q - p) / length
        pts = self._inside(Polygon([p - n * r, q - n * r, q + n * r, p + n * r]))
        pts = pts[(pts[:, 2] > self.z0 + 0.3) & (pts[:, 2] < self.z1 - 0.3)]
        rel = pts[:, :2] - p
        u, v = rel @ d, rel @ n
        keep = (u > 0.05) & (u < length - 0.05)
        u, v = u[keep], v[keep]
        if len(u) < 20:
            return None
        nu = max(1, int(length / self.cell))
        iu = np.clip((u / self.cell).astype(np.int64), 0, nu - 1)
        offsets = np.arange(-r + 0.015, r - 0.015 + 1e-9, 0.01)
        near = [np.abs(v - c) <= 0.015 for c in offsets]  # points on a plane at each offset
        count = np.array([m.sum() for m in near])
        # the share of the stretch's cells it holds points in, and of the heights
        cover = np.array([len(np.unique(iu[m])) / nu for m in near])
        z = pts[keep, 2]
        nz = max(1, int((self.z1 - self.z0 - 0.6) / self.cell))
        high = np.array([len(np.unique(np.clip(((z[m] - self.z0 - 0.3) / self.cell).astype(np.int64), 0, nz - 1)))
                         / nz for m in near])
        last = len(offsets) - 1
        # face planes: the densest offsets around, along the stretch and over most of the
        # height (a wall's face, not a rail or a shelf)
        peaks = [k for k in range(len(offsets)) if cover[k] >= self.prm.face_coverage and high[k] >= 0.6
                 and count[k] >= count[max(k - 1, 0)] and count[k] >= count[min(k + 1, last)]]
        best = None
        for ia, a in enumerate(peaks):
            for b in peaks[ia + 1:]:
                t = float(offsets[b] - offsets[a])
                if t < max(self.prm.min_thickness, self.prm.min_seen_thickness):
                    continue
                lo = min(count[a], count[b])
                # a wall's inside: a dip between its faces (whatever the noise), no plane in it
                # as dense as they are (a closed leaf in a doorway is far sparser)
                if count[a + 1:b].min() > 0.2 * lo or any(a < k < b and count[k] >= 0.5 * lo for k in peaks):
                    continue
                if best is None or lo > best[0]:
                    best = (lo, float(offsets[a] + offsets[b]) / 2, t)
        return None if best is None else best[1:]


def _breaks(walls: list[Shape], openings: list[Shape]) -> tuple[dict, list]:
    """({storey: [plan region]}, the other openings): the doorless openings of interior walls
    (gaps from the floor up to the ceiling, or wider than a door: under a beam or a
    bulkhead at most). The wall ends there and the two spaces meet without one; the region
    is the opening's footprint across the wall."""
    by_id = {w.id: w for w in walls}
    breaks, rest = {}, []
    for o in openings:
        w = by_id.get(o.parent)
        if w is None or w.attributes.get("external") or o.attributes.get("kind") != "opening":
            rest.append(o)
            continue
        fp = o.geometry.footprint()
        region = (Polygon(fp) if fp is not None else Polygon(o.geometry.vertices[:, :2]).convex_hull)
        breaks.setdefault(w.storey, []).append(region.buffer(0.05, join_style="mitre"))
    return breaks, rest


def _measured_exteriors(walls: list[Shape], openings: list[Shape], grid: PointGrid, prm: ElementsParams) -> dict:
    """{storey: [(region, thickness)]}: exterior walls whose openings' reveals give a thickness
    other than the default (by more than 2 cm); the region is the wall's footprint."""
    by_wall = {}
    for o in openings:
        by_wall.setdefault(o.parent, []).append(o)
    ext = [w for w in walls if w.attributes.get("external") and w.id in by_wall]
    if not ext:
        return {}
    out = {}
    for w in ext:
        left, right = w.attributes["sides"]
        inner = 1 if not str(left).startswith("exterior_s") else -1
        t = reveal_depth(w, by_wall[w.id], grid, inner, prm.walls.max_thickness)
        if t is None or abs(t - prm.walls.exterior_thickness) <= 0.02:
            continue
        out.setdefault(w.storey, []).append((Polygon(w.footprint()).buffer(0.05), t))
    return out


def _detect(model: BuildingModel, walls: list[Shape], xyz: np.ndarray, cloud, prm: ElementsParams,
            footprints: Mapping[int, Mapping[str, object]]) -> list[Shape]:
    from .openings import detect_openings

    T = np.linalg.inv(model.transform)
    normals = None if cloud.normals is None else cloud.normals @ T[:3, :3].T
    sp = cloud.scanner_positions
    pairs = None
    if sp is not None:
        sp = sp @ T[:3, :3].T + T[:3, 3]
    elif prm.viewpoints is not None:  # no scanner positions: stand-ins in the rooms
        from .viewpoints import occupancy, room_viewpoints, visible_pairs

        t0 = time.perf_counter()
        occ = occupancy(xyz, prm.viewpoints)
        sp = room_viewpoints(footprints, model.storeys, occ, prm.viewpoints)
        pairs = visible_pairs(xyz, sp, prm.viewpoints, occ)
        log.info("openings: %d stand-in scanners in the rooms, %d lines of sight (%.1f s)", len(sp),
                 len(pairs[0]), time.perf_counter() - t0)
    ext = {s.storey: s.id for s in model.of_type(ShapeType.EXTERIOR) if _made_here(s)}
    found = detect_openings(walls, model.storeys, xyz, normals, cloud.scan_index, sp, prm.openings, ext, pairs)
    out = []
    for o in found:
        o = o.with_(attributes={**o.attributes, "detected": True})
        if not _made_here(o):
            o = o.with_(log=(f"{ELEMENT_LOG}: {o.attributes.get('kind', o.type.value)} found in {o.parent}",)
                        + tuple(o.log))
        out.append(o)
    return out


def _rehome(openings: list[Shape], walls: list[Shape], model: BuildingModel) -> list[Shape]:
    """Openings kept from before, each rebuilt in the new wall that holds its centre (its
    box across the new wall's thickness, at its width, sill and height)."""
    out = []
    plans = {w.id: Polygon(w.footprint()) for w in walls} if openings else {}  # once, not per opening
    slabs = [s for s in model.shapes if s.type == ShapeType.SLAB] if openings else []
    for o in openings:
        if o.attributes.get("skylight"):  # in the roof slab over it
            slab = host_slab(o, slabs)
            if slab is None:
                log.warning("roof window %s lies in no roof slab any more; dropped", o.id)
            else:
                out.append(o.with_(parent=slab.id, storey=slab.storey))
            continue
        c = o.centroid
        best = None
        for w in walls:
            if w.storey != o.storey:
                continue
            d = plans[w.id].distance(Point(c[:2]))
            if best is None or d < best[0]:
                best = (d, w)
        if best is None or best[0] > 0.3:
            log.warning("opening %s lies in no wall any more; dropped", o.id)
            continue
        w = best[1]
        a, b = (np.asarray(p, float) for p in w.attributes["axis_line"])
        d = (b - a) / max(float(np.linalg.norm(b - a)), 1e-12)
        u = float(d @ (c[:2] - a))
        width = float(o.attributes.get("width", np.sort(o.scope.size[:2])[1]))
        lo, hi = o.bounds[:, 2]
        floor = float(w.attributes.get("floor_z", w.bounds[0, 2]))
        sill = float(o.attributes.get("sill", lo - floor))
        height = float(o.attributes.get("height", hi - lo))
        geo = opening_box(a, d, float(w.attributes["thickness"]), u, width, floor + sill, floor + sill + height)
        out.append(o.with_(parent=w.id, storey=w.storey, geometry=geo, scope=None,
                           attributes={**o.attributes, "width": width, "sill": sill, "height": height}))
    return out


def opening_box(a: np.ndarray, d: np.ndarray, thickness: float, u: float, width: float, z0: float,
                z1: float) -> Polyhedron:
    """The box of an opening centred ``u`` metres along a wall axis (start ``a``, unit
    direction ``d``), ``width`` along it, through the wall's ``thickness``, from ``z0`` to ``z1``."""
    n = np.array([-d[1], d[0]]) * thickness / 2
    p0, p1 = a + d * (u - width / 2), a + d * (u + width / 2)
    return Polyhedron.prism(np.array([p0 - n, p1 - n, p1 + n, p0 + n]), z0, z1)


def _overlaps(o: Shape, others: list[Shape]) -> bool:
    """Whether an opening overlaps (in plan and height) an opening of ``others`` in its wall."""
    ob = o.bounds
    for q in others:
        if q.parent != o.parent:
            continue
        qb = q.bounds
        if np.all(ob[0] < qb[1]) and np.all(qb[0] < ob[1]):
            return True
    return False


def _free_exterior_ids(model: BuildingModel, keep: list[Shape]):
    """Rename exterior shapes not made here whose id is one this stage gives
    (``exterior_s<k>``), so that the stage's exterior can take it."""
    taken = {s.id for s in keep if s.type == ShapeType.EXTERIOR and not _made_here(s)
             and s.id == f"exterior_s{s.storey}"}
    if not taken:
        return model, keep
    ids = {s.id for s in model.shapes}
    new = {}
    for t in taken:
        k, n = f"{t}_part", 0
        while k in ids:
            n += 1
            k = f"{t}_part{n}"
        new[t] = k
    ren = (lambda x: new.get(x, x))
    keep = [s.with_(id=ren(s.id), parent=None if s.parent is None else ren(s.parent),
                    children=tuple(ren(c) for c in s.children)) for s in keep]
    rel = tuple(Relation(r.kind, ren(r.a), ren(r.b), None if r.via is None else ren(r.via)) for r in model.relations)
    return model.with_(relations=rel), keep


def _with_spaces(o: Shape, model: BuildingModel) -> Shape:
    """The opening's two spaces from its wall's sides at its centre."""
    if o.parent is None or o.parent not in model:
        return o
    w = model[o.parent]
    ax = w.attributes.get("axis_line")
    if ax is None:
        return o
    a, b = np.asarray(ax[0], float), np.asarray(ax[1], float)
    d = (b - a) / max(float(np.linalg.norm(b - a)), 1e-12)
    u = float(d @ (o.centroid[:2] - a))
    left, right = _span_sides(w, u)
    return o.with_(attributes={**o.attributes, "spaces": [left, right]})
