"""Element-level scores of a reconstructed model against the truth: doors, windows, exterior
walls, slabs, rooms, wall runs and the door graph.

:func:`evaluate_elements` puts the model into the truth's frame (the same mechanism as
:func:`engine.evaluation.evaluate`: ``frame_transform`` of the two models'
``transform``/``offset``; wall ``axis_line`` attributes are moved too) and returns JSON-ready
figures:

* ``doors`` / ``windows`` — true, found and matched counts (one-to-one, Hungarian on the
  distance between the 3-D centres of the opening boxes, pairs farther than
  ``centre_tolerance`` never match), precision, recall, F1, mean / max absolute width error
  of the matched pairs and their share within ``width_tolerance``. Doorless openings
  (kind "opening") count as doors; a shape is a window when its type is WINDOW or its
  ``kind`` is "window". Widths come from ``attributes["width"]`` or, lacking it, the longer
  horizontal side of the opening's box.
* ``exterior`` — per truth storey, the length of the exterior boundary (the outer outline of
  the union of the true rooms' and interior walls' footprints, wall gaps closed) and the
  share of it lying within
  ``coverage_distance`` + half the thickness of a parallel model wall (flat-capped band
  around the wall's centre line): external walls only (``external`` True) and any wall;
  and ``inside_external_m``, the length of external walls' centre lines lying more than
  ``inside_margin`` inside the outline (interior walls called external).
* ``slabs`` — per truth storey with rooms, whether floor slabs (reaching within
  ``slab_z_tolerance`` of the floor height, not 1 m above it) and ceiling slabs (reaching
  1 m above the floor,
  starting between the floor and the storey top, ± ``slab_z_tolerance``: a ceiling, a
  sloped roof, or the floor slab of the storey above) cover at least ``slab_overlap`` of
  the storey footprint. Slabs count by their height whatever their ``kind`` (the kinds of
  the counted slabs are listed), so a model's ceiling slab under the storey above is that
  storey's floor too.
* ``spaces`` — model space count (``model``; ``model_rooms``: counted as the rooms are)
  vs the true room count, rooms matched and their mean IoU, as
  :func:`engine.evaluation.rooms.room_scores` counts them: true rooms joined without a wall
  (an open plan, FZK-Haus's kitchen and living room) are one room, and model spaces inside
  one open plan one space (FZK-Haus's hall split at its beam from the living room);
  ``truth_spaces`` / ``matched_spaces``: the true spaces one by one and those a model space
  matches by footprint IoU (they name the graph's nodes).
* ``walls`` — model wall count vs the *true wall runs*: the truth's wall pieces merged into
  straight runs (parallel within ``run_angle``, centre lines within ``run_offset``, thickness
  within ``run_thickness``, same storey, overlapping, touching within ``run_gap`` or joined
  through another wall's footprint, as at a T-junction); with ``seen``, those of the storeys
  a scan reached.
* ``connectivity`` — the room pairs joined by a door (the exterior is one node per storey) in
  the model and the truth, model rooms named after the true room they match (greedy by
  footprint IoU), the rooms of one open plan one node (as ``spaces`` counts them: a door into
  the Duplex's foyer is a door into its open plan with the living room and kitchen, whichever
  of them names the model's space); equal, missing and extra edges.

With ``seen`` (the true spaces a scan reaches), storeys without a seen space are not scored
for exterior walls, slabs, wall runs, doors and windows — save a window standing over a seen room, at
most 1.5 m above its top (a roof light filed under an unscanned roof level is seen from the
room under it) — and unseen spaces are neither counted as rooms
nor part of the outline: a door into one leads outside, to its storey's exterior node (a scan
sees a door into a closed, unscanned room as a door out of the scanned building).

Models lacking attributes fall back to geometry: wall axis and thickness from the footprint's
minimum-area box; ``external`` from ``exterior``, the wall's ``sides`` or adjacency
relations to an EXTERIOR shape.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Optional

import numpy as np
from scipy.optimize import linear_sum_assignment
from shapely.geometry import LineString, Point
from shapely.ops import unary_union

from ..errors import InputError
from ..geometry.boxes import box_sides
from ..model import BuildingModel, Shape, ShapeType
from .footprints import (_MITRE, _axis_attr, _exterior_adjacent, _in_truth_frame, _is_external, _plan,
                         _polygons, _storey_of, _truth_storey, _zrange, exterior_outline)
from .groups import DisjointSets
from .rooms import room_scores

__all__ = ["ElementMatchParams", "evaluate_elements", "true_wall_runs", "exterior_outline"]


_NO_MATCH = 1e6
"""Cost of an infeasible pair in the assignment (far above any sum of feasible distances)."""
_MIN_CEILING_ABOVE_FLOOR = 1.0
"""A ceiling slab reaches at least this far above the storey floor, metres."""


@dataclass(frozen=True)
class ElementMatchParams:
    """Tolerances of :func:`evaluate_elements` (SI units: metres, radians)."""

    centre_tolerance: float = 0.3
    """Largest distance between the 3-D centres of a matched model and true opening box, m."""
    width_tolerance: float = 0.10
    """A matched opening's width is right when within this of the truth, m."""
    coverage_distance: float = 0.3
    """The exterior boundary is covered within this + half the wall thickness of a wall's
    centre line, m."""
    coverage_gap: float = 0.25
    """Uncovered stretches of a boundary edge up to this long between covered ones count as
    covered (a junction square that belongs to an interior wall), m."""
    outline_closing: float = 0.3
    """Closing radius that fills the wall gaps between true rooms (gaps up to twice this), m."""
    inside_margin: float = 0.5
    """An external model wall's centre line deeper than this inside a storey's outline lies
    inside the building (an interior wall called external), m."""
    run_offset: float = 0.05
    """Wall pieces of one run have centre lines within this of each other, m."""
    run_angle: float = float(np.radians(2.0))
    """Wall pieces of one run are parallel within this, rad."""
    run_gap: float = 0.05
    """Collinear pieces at most this far apart along the line touch, m."""
    run_thickness: float = 0.05
    """Wall pieces of one run differ in thickness by at most this, m."""
    slab_z_tolerance: float = 0.3
    """Floor slabs reach within this of the storey floor; ceiling slabs start between the
    floor minus this and the storey top plus this, m."""
    slab_overlap: float = 0.5
    """A storey has a floor (ceiling) slab when slabs cover at least this share of its
    footprint."""
    room_min_iou: float = 0.3
    """Smallest footprint IoU of a model room matched with a true room."""

    def __post_init__(self):
        for k, v in asdict(self).items():
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InputError(f"ElementMatchParams.{k} must be a finite number >= 0, not {v!r}")
        if not 0 < self.slab_overlap <= 1 or not 0 < self.room_min_iou <= 1:
            raise InputError("ElementMatchParams.slab_overlap and room_min_iou must be in (0, 1]")


def _number(v) -> Optional[float]:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def _wall_axis(s: Shape, model: BuildingModel) -> tuple[np.ndarray, np.ndarray, float]:
    """(start (2,), end (2,), thickness) of a wall, metres: the ``axis_line`` and
    ``thickness`` attributes; else from the footprint: direction of its longest edge, the
    line through its centroid (robust to slivers), its extent along that direction, and
    thickness = area / length."""
    t = _number(s.attributes.get("thickness"))
    line = _axis_attr(s)
    if line is not None and t is not None and t > 0:
        return line[0], line[1], t
    poly = _plan(s, model)
    parts = _polygons(poly)
    if not parts:
        sc = s.scope
        k = 0 if sc.size[0] >= sc.size[1] else 1
        d = _unit(sc.axes[k][:2])
        c, h = sc.center[:2], float(sc.size[k]) / 2
        short = float(sc.size[1 - k])
        return c - d * h, c + d * h, (t if t is not None and t > 0 else short)
    part = max(parts, key=lambda p: p.area)
    c = np.asarray(part.exterior.coords)
    e = np.diff(c, axis=0)
    k = int(np.argmax(np.linalg.norm(e, axis=1)))
    d = _unit(e[k])
    ctr = np.asarray(part.centroid.coords[0])
    u = (c - ctr) @ d
    length = float(u.max() - u.min())
    if line is not None:
        return line[0], line[1], float(poly.area) / max(float(np.linalg.norm(line[1] - line[0])), 1e-9)
    if t is None or t <= 0:
        t = float(poly.area) / max(length, 1e-9)
    return ctr + d * u.min(), ctr + d * u.max(), t


def _ratio(a, b) -> Optional[float]:
    return float(a) / float(b) if b else None


# ----------------------------------------------------------------------------- openings
def _openings(model: BuildingModel, window: bool) -> list[Shape]:
    out = []
    for s in model.of_type(ShapeType.DOOR, ShapeType.WINDOW):
        is_window = s.type == ShapeType.WINDOW or str(s.attributes.get("kind", "")).lower() == "window"
        if is_window == window:
            out.append(s)
    return out


def _opening_width(s: Shape) -> float:
    w = _number(s.attributes.get("width"))
    return w if w is not None and w > 0 else float(max(s.scope.size[0], s.scope.size[1]))


def _match_centres(a: np.ndarray, b: np.ndarray, tol: float) -> list[tuple[int, int, float]]:
    """One-to-one pairs (i, j, distance) of points a (n, 3) and b (m, 3) within ``tol``,
    minimising the summed distance of a largest set of pairs (Hungarian)."""
    if len(a) == 0 or len(b) == 0:
        return []
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    cost = np.where(d <= tol, d, _NO_MATCH)
    rows, cols = linear_sum_assignment(cost)
    return [(int(i), int(j), float(d[i, j])) for i, j in zip(rows, cols) if d[i, j] <= tol]


def _over_a_room(o: Shape, rooms: list, truth: BuildingModel, reach: float = 1.5) -> bool:
    """Whether opening ``o`` stands over one of ``rooms`` (true spaces): its centre inside the
    room's plan, its bottom at most ``reach`` metres over the room's top (a roof light seen
    from the room, whatever storey the model files it under)."""
    c = o.scope.center
    return any(0.0 <= float(o.bounds[0, 2]) - float(r.bounds[1, 2]) <= reach
               and _plan(r, truth).contains(Point(c[:2])) for r in rooms)


def _opening_scores(model: BuildingModel, truth: BuildingModel, window: bool,
                    params: ElementMatchParams, storeys: Optional[set] = None,
                    rooms: Optional[list] = None) -> dict:
    """``storeys``: the truth storeys scored (None: all); true openings of others are left
    out, unless they stand over one of ``rooms`` (:func:`_over_a_room`: the Duplex's roof lights,
    on its unscanned roof level, are seen from the rooms under them)."""
    found, true = _openings(model, window), _openings(truth, window)
    if storeys is not None:
        true = [s for s in true
                if _storey_of(s, truth) in storeys or bool(rooms and _over_a_room(s, rooms, truth))]
    cf = np.array([s.scope.center for s in found]).reshape(-1, 3)
    ct = np.array([s.scope.center for s in true]).reshape(-1, 3)
    pairs = _match_centres(cf, ct, params.centre_tolerance)
    err = np.array([abs(_opening_width(found[i]) - _opening_width(true[j])) for i, j, _ in pairs])
    n, nf, nt = len(pairs), len(found), len(true)
    return {
        "true": nt, "found": nf, "matched": n,
        "precision": _ratio(n, nf), "recall": _ratio(n, nt), "f1": _ratio(2 * n, nf + nt),
        "width_error_mean": float(err.mean()) if n else None,
        "width_error_max": float(err.max()) if n else None,
        "width_within_tolerance": float(np.mean(err <= params.width_tolerance + 1e-9)) if n else None,
        "centre_error_mean": float(np.mean([d for _, _, d in pairs])) if n else None,
        "pairs": [[found[i].id, true[j].id] for i, j, _ in pairs],
    }


# ----------------------------------------------------------------------------- outlines, coverage
def _edges(poly) -> list[LineString]:
    out = []
    for p in _polygons(poly):
        c = np.asarray(p.exterior.coords)
        for a, b in zip(c[:-1], c[1:]):
            if np.linalg.norm(b - a) > 1e-9:
                out.append(LineString([a, b]))
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), 1e-12)


def _union_length(iv: list[tuple[float, float]], bridge: float = 0.0) -> float:
    """Length of the union of 1-D intervals; gaps up to ``bridge`` between them count."""
    total, end = 0.0, -np.inf
    for a, b in sorted(iv):
        if b <= end:
            continue
        total += b - (a if a - end > bridge else end)
        end = b
    return total


def _covered_length(edges: list[LineString], walls, params: ElementMatchParams) -> float:
    """Length of the boundary edges alongside wall material: the projection onto each edge
    of the walls' plan (``walls``, one shapely geometry) within ``coverage_distance`` of it
    (a flat-capped band on both sides), gaps up to ``coverage_gap`` bridged. For a wall
    parallel to the edge this is "its centre line within coverage_distance + half its
    thickness"."""
    if walls.is_empty:
        return 0.0
    total = 0.0
    for e in edges:
        a, b = (np.asarray(p) for p in e.coords)
        length = float(np.linalg.norm(b - a))
        d = _unit(b - a)
        band = e.buffer(params.coverage_distance, cap_style="flat", join_style="mitre")
        hit = band.intersection(walls)
        iv = []
        for g in _polygons(hit):
            if g.area > 1e-12:
                u = (np.asarray(g.exterior.coords) - a) @ d
                iv.append((max(float(u.min()), 0.0), min(float(u.max()), length)))
        total += _union_length([x for x in iv if x[1] > x[0]], params.coverage_gap)
    return min(total, float(sum(e.length for e in edges)))


def _exterior_scores(model, truth, outlines, params) -> dict:
    per = []
    adjacent = _exterior_adjacent(model)
    walls = [(_storey_of(w, truth), _plan(w, model), _is_external(w, model, adjacent)) for w in model.walls]
    tot_b = tot_e = tot_a = tot_i = 0.0
    for k, outline in enumerate(outlines):
        edges = _edges(outline)
        length = float(sum(e.length for e in edges))
        mine = [(p, ext) for st, p, ext in walls if st == k]
        ext = _covered_length(edges, unary_union([p for p, e in mine if e]), params)
        any_ = _covered_length(edges, unary_union([p for p, _ in mine]), params)
        per.append({"storey": k, "boundary_m": length, "external_m": ext, "any_m": any_,
                    "external_share": _ratio(ext, length), "any_share": _ratio(any_, length)})
        inner = outline.buffer(-params.inside_margin, join_style="mitre") if not outline.is_empty else outline
        inside = float(sum(_length_inside(w, p, inner) for w, (st, p, e) in zip(model.walls, walls)
                           if st == k and e))
        per[-1]["inside_external_m"] = inside
        tot_b, tot_e, tot_a, tot_i = tot_b + length, tot_e + ext, tot_a + any_, tot_i + inside
    return {"boundary_m": tot_b, "external_share": _ratio(tot_e, tot_b), "any_share": _ratio(tot_a, tot_b),
            "external_walls": sum(1 for *_, e in walls if e), "inside_external_m": tot_i, "per_storey": per}


def _length_inside(w: Shape, plan, region) -> float:
    """Length of the wall lying in ``region``: its centre line's (``axis_line``), else its
    plan's area there over its thickness (an L-shaped truth piece has no one axis)."""
    if plan is None or plan.is_empty or region.is_empty:
        return 0.0
    a = _axis_attr(w)
    if a is not None:
        return float(LineString(a).intersection(region).length)
    t = w.attributes.get("thickness")
    if not isinstance(t, (int, float)) or not t > 0:
        t = box_sides(plan)[0]
    return float(plan.intersection(region).area / t) if t > 0 else 0.0


# ----------------------------------------------------------------------------- slabs
def _slab_scores(model, truth, outlines, params) -> dict:
    tol = params.slab_z_tolerance
    slabs = [(str(s.attributes.get("kind", "")).lower(), *_zrange(s), _plan(s, model)) for s in model.slabs]
    per = []
    for k, outline in enumerate(outlines):
        st = truth.storeys[k]
        area = float(outline.area)
        if area <= 0:  # a storey without rooms (a foundation level): nothing to cover
            per.append({"storey": k, "floor": None, "ceiling": None, "floor_share": None, "ceiling_share": None,
                        "floor_kinds": [], "ceiling_kinds": []})
            continue

        def share(chosen):
            u = unary_union([p for _, p in chosen])
            return float(outline.intersection(u).area) / area if chosen else 0.0

        high = st.floor_z + _MIN_CEILING_ABOVE_FLOOR
        floor = [(kind, p) for kind, z0, z1, p in slabs
                 if z1 < high and max(z0 - st.floor_z, st.floor_z - z1, 0.0) <= tol]
        ceil = [(kind, p) for kind, z0, z1, p in slabs
                if z1 >= high and st.floor_z - tol <= z0 <= st.ceiling_z + tol]
        fs, cs = share(floor), share(ceil)
        per.append({"storey": k, "floor": fs >= params.slab_overlap, "ceiling": cs >= params.slab_overlap,
                    "floor_share": fs, "ceiling_share": cs,
                    "floor_kinds": sorted({kd for kd, _ in floor}), "ceiling_kinds": sorted({kd for kd, _ in ceil})})
    used = [p for p in per if p["floor"] is not None]
    return {"model": len(slabs), "truth": len(truth.slabs),
            "floor_found": sum(p["floor"] for p in used), "ceiling_found": sum(p["ceiling"] for p in used),
            "storeys": len(used), "per_storey": per}


# ----------------------------------------------------------------------------- rooms, graph
def _match_rooms(model, truth, params) -> tuple[dict, dict]:
    """(model room id → true room id, true room id → IoU) by greedy footprint IoU, same storey."""
    tr = [(t.id, _truth_storey(t, truth), _plan(t, truth)) for t in truth.spaces]
    mr = [(m.id, _storey_of(m, truth), _plan(m, model)) for m in model.spaces]
    cand = []
    for tid, ts, tp in tr:
        for mid, ms, mp in mr:
            if ts != ms or not tp.intersects(mp):
                continue
            inter = float(tp.intersection(mp).area)
            if inter > 0:
                iou = inter / float(tp.union(mp).area)
                if iou >= params.room_min_iou:
                    cand.append((iou, tid, mid))
    cand.sort(key=lambda c: (-c[0], c[1], c[2]))
    m2t, ious = {}, {}
    for iou, tid, mid in cand:
        if tid in ious or mid in m2t:
            continue
        m2t[mid], ious[tid] = tid, iou
    return m2t, ious


def _door_edges(model: BuildingModel, truth: BuildingModel, room_name) -> set:
    """Unordered node pairs joined by an (active) door of ``model``."""
    doors = {d.id: d for d in _openings(model, False)}

    def node(sid, door):
        s = model.get(sid)
        if s is None:
            return f"exterior_s{_storey_of(door, truth)}" if str(sid).startswith("exterior") else None
        if s.type == ShapeType.EXTERIOR:
            return f"exterior_s{_storey_of(s, truth)}"
        if s.type == ShapeType.INTERIOR:
            return room_name(model.top_level(sid).id)
        return None

    edges = set()
    pairs = [(r.a, r.b, r.via) for r in model.relations_of("connectivity") if r.via in doors]
    seen = {v for _, _, v in pairs}
    for did, d in doors.items():
        sp = d.attributes.get("spaces")
        if did not in seen and isinstance(sp, (list, tuple)) and len(sp) == 2:
            pairs.append((str(sp[0]), str(sp[1]), did))
    for a, b, via in pairs:
        na, nb = node(a, doors[via]), node(b, doors[via])
        if na is not None and nb is not None and na != nb:
            edges.add(tuple(sorted((na, nb))))
    return edges


# ----------------------------------------------------------------------------- wall runs
def true_wall_runs(model: BuildingModel,
                   params: ElementMatchParams = ElementMatchParams()) -> list[list[str]]:
    """The model's active walls merged into straight runs: lists of wall ids, one per run.

    Two pieces join when on the same storey, parallel within ``run_angle``, with centre
    lines within ``run_offset`` of each other, thicknesses within ``run_thickness``, and
    their extents along the line overlap, touch within ``run_gap`` or are joined through
    the footprint of other walls (a T- or X-junction). Runs are the connected groups.
    """
    walls = model.walls
    n = len(walls)
    axes = [_wall_axis(w, model) for w in walls]
    fps = {}
    for w in walls:
        fps.setdefault(w.storey, []).append(_plan(w, model).buffer(params.run_gap / 2 + 1e-6))
    fill = {k: unary_union(v) for k, v in fps.items()}
    sets = DisjointSets(n)
    cos_t = math.cos(params.run_angle)
    for i in range(n):
        p0, p1, ti = axes[i]
        d = _unit(p1 - p0)
        nrm = np.array([-d[1], d[0]])
        ai = sorted((0.0, float((p1 - p0) @ d)))
        for j in range(i + 1, n):
            if walls[i].storey != walls[j].storey:
                continue
            q0, q1, tj = axes[j]
            if abs(ti - tj) > params.run_thickness or abs(float(_unit(q1 - q0) @ d)) < cos_t:
                continue
            if max(abs(float((q0 - p0) @ nrm)), abs(float((q1 - p0) @ nrm))) > params.run_offset:
                continue
            aj = sorted((float((q0 - p0) @ d), float((q1 - p0) @ d)))
            gap = max(aj[0] - ai[1], ai[0] - aj[1])
            if gap > params.run_gap:
                lo, hi = (ai[1], aj[0]) if aj[0] > ai[1] else (aj[1], ai[0])
                seg = LineString([p0 + d * lo, p0 + d * hi])
                if not fill[walls[i].storey].contains(seg):
                    continue
            sets.union(i, j)
    return sorted(([walls[i].id for i in g] for g in sets.groups()), key=lambda g: g[0])


# ----------------------------------------------------------------------------- entry point
def evaluate_elements(model: BuildingModel, truth: BuildingModel,
                      params: ElementMatchParams = ElementMatchParams(), *,
                      seen: Optional[set] = None) -> dict:
    """Score a model's building elements against the truth (see the module doc).

    Parameters
    ----------
    model : BuildingModel
        The reconstruction (any frame; its ``transform``/``offset`` bring it into the
        truth's frame).
    truth : BuildingModel
        The true model (e.g. ``engine.synthetic.preset(...).truth``).
    params : ElementMatchParams
    seen : set, optional
        Ids of the true spaces the scan reaches (:func:`engine.evaluation.rooms.scanned_spaces`).
        A storey none of whose spaces was seen (an IFC roof level no ray enters) has no
        exterior boundary, slabs, doors or windows to score, save windows over a seen room
        (a roof light seen from below); unseen spaces do
        not count as rooms to find, nor are they part of a storey's outline (a door into one
        leads to the storey's exterior node of the door graph). None: every space counts.

    Returns
    -------
    dict
        JSON-ready: ``doors``, ``windows``, ``exterior``, ``slabs``, ``spaces``, ``walls``,
        ``connectivity``, ``params``. Shares and ratios are None when undefined (0/0).

    Raises
    ------
    InputError
        ``model`` or ``truth`` is not a BuildingModel.
    """
    if not isinstance(model, BuildingModel) or not isinstance(truth, BuildingModel):
        raise InputError("evaluate_elements needs two BuildingModel objects (model, truth)")
    plans = room_scores(model, truth, seen=seen)  # open plans merged (issue 19)
    model = _in_truth_frame(model, truth)
    rooms = [s for s in truth.spaces if seen is None or s.id in seen]
    scored = {_truth_storey(s, truth) for s in rooms}
    outlines = [exterior_outline(truth, k, params.outline_closing, seen) for k in range(len(truth.storeys))]
    m2t, ious = _match_rooms(model, truth, params)
    # the rooms of one open plan are one node, as the room scores count them
    group = {t: min(g) for st in plans["per_storey"] for g in st.get("true_group_ids", ()) for t in g}
    truth_edges = _door_edges(truth, truth, lambda sid: group.get(sid, sid) if seen is None or sid in seen
                              else f"exterior_s{_storey_of(truth[sid], truth)}")
    model_edges = _door_edges(model, truth, lambda sid: group.get(m2t[sid], m2t[sid]) if sid in m2t
                              else f"model:{sid}")
    # a storey no scan reached has no walls to find (the Duplex's foundations and roof parapets)
    truth_runs = [r for r in true_wall_runs(truth, params)
                  if seen is None or _truth_storey(truth[r[0]], truth) in scored]
    model_runs = true_wall_runs(model, params)
    n_true_rooms = len(rooms)
    ious = {t: v for t, v in ious.items() if seen is None or t in seen}
    return {
        "doors": _opening_scores(model, truth, False, params, None if seen is None else scored),
        "windows": _opening_scores(model, truth, True, params, None if seen is None else scored, rooms),
        "exterior": _exterior_scores(model, truth, outlines, params),
        "slabs": _slab_scores(model, truth, outlines, params),
        "spaces": {"model": len(model.spaces), "model_rooms": plans["model"], "truth": plans["true"],
                   "ratio": _ratio(len(model.spaces), plans["true"]), "matched": plans["matched"],
                   "mean_iou": None if plans["matched"] == 0 else float(plans["mean_iou"]),
                   "truth_spaces": n_true_rooms, "matched_spaces": len(ious),
                   "pairs": sorted([m, t] for m, t in m2t.items())},
        "walls": {"model": len(model.walls), "model_runs": len(model_runs), "truth_pieces": len(truth.walls),
                  "truth_runs": len(truth_runs), "ratio": _ratio(len(model.walls), len(truth_runs))},
        "connectivity": {"truth_edges": len(truth_edges), "model_edges": len(model_edges),
                         "equal": model_edges == truth_edges,
                         "missing": [list(e) for e in sorted(truth_edges - model_edges)],
                         "extra": [list(e) for e in sorted(model_edges - truth_edges)]},
        "params": asdict(params),
    }
