"""Element scores (engine.evaluation.elements): doors and windows matched by centre, exterior
wall coverage, slabs per storey, rooms, true wall runs, the door graph.

Scenes are the synthetic truths of the presets (no scan needed); perturbed copies have
figures derived from the plan's geometry (office_mw: rooms on a 0.15 m wall grid inside a
0.3 m exterior band; the clear outline is 17.85 m × 12.35 m).
"""
import json

import numpy as np
import pytest
from shapely.geometry import Polygon
from shapely.ops import unary_union

from engine.errors import InputError
from engine.evaluation import (ElementMatchParams, evaluate, evaluate_elements, exterior_outline,
                               true_wall_runs, write_evaluation_outputs)
from engine.geometry.transforms import apply_transform
from engine.geometry.polygon import polygon_parts
from engine.model import BuildingModel, Polyhedron, Relation, Shape, ShapeType, Storey
from engine.synthetic import build_truth, preset_plans

OFFICE_PERIMETER = 2 * (17.85 + 12.35)
"""Clear outline of office_mw: x 0.075 … 17.925, y −5.425 … 6.925 (metres)."""


def _truth(name):
    return build_truth(preset_plans(name)["truth"])


@pytest.fixture(scope="module")
def office():
    return _truth("office_mw")


def _room_id(model, name):
    return next(s.id for s in model.spaces if s.name == name)


def _door_between(model, a, b):
    ids = {_room_id(model, a), _room_id(model, b)}
    return next(r.via for r in model.relations_of("connectivity") if {r.a, r.b} == ids)


def _is_ext(w):
    return bool(w.attributes.get("external", w.attributes.get("exterior", False)))


def _south_wall_of_room_6(model):
    """The exterior wall piece along the south side of Room 6 (x 6 … 12, y −5.5)."""
    for w in model.walls:
        lo, hi = w.bounds
        if _is_ext(w) and abs(hi[1] + 5.425) < 1e-6 and 6.0 < (lo[0] + hi[0]) / 2 < 12.0:
            return w
    raise AssertionError("no exterior wall south of Room 6")


def _box_like(shape, dx=0.0, grow=0.0):
    """A copy of an axis-aligned door box moved by dx along x and widened by grow (metres)."""
    lo, hi = shape.bounds
    geo = Polyhedron.box((lo[0] + dx - grow / 2, lo[1], lo[2]), (hi[0] + dx + grow / 2, hi[1], hi[2]))
    attrs = dict(shape.attributes)
    if "width" in attrs:
        attrs["width"] = attrs["width"] + grow
    return Shape(shape.id, shape.type, geo, storey=shape.storey, name=shape.name, terminal=True,
                 parent=shape.parent, attributes=attrs)


def _check_perfect(r, truth):
    d = r["doors"]
    assert d["true"] == d["found"] == d["matched"] == len(truth.doors) > 0
    assert d["precision"] == d["recall"] == d["f1"] == 1.0
    assert d["width_error_max"] <= 1e-9 and d["width_within_tolerance"] == 1.0
    w = r["windows"]
    assert w["matched"] == w["true"] == w["found"]
    if w["true"]:
        assert w["precision"] == w["recall"] == 1.0
    assert r["exterior"]["external_share"] == pytest.approx(1.0, abs=1e-9)
    assert r["exterior"]["any_share"] == pytest.approx(1.0, abs=1e-9)
    # syn_house: 0.08 m, the plan of an L-shaped true piece (area over thickness) at the slanted corner
    assert r["exterior"]["inside_external_m"] <= 0.1
    assert all(p["floor"] and p["ceiling"] for p in r["slabs"]["per_storey"])
    assert r["slabs"]["floor_found"] == r["slabs"]["ceiling_found"] == len(truth.storeys)
    sp = r["spaces"]
    assert sp["model"] == sp["truth"] == sp["matched"] == len(truth.spaces)
    assert sp["mean_iou"] == pytest.approx(1.0, abs=1e-6)
    assert r["walls"]["model_runs"] == r["walls"]["truth_runs"]
    c = r["connectivity"]
    assert c["equal"] and c["missing"] == [] and c["extra"] == []
    assert c["truth_edges"] == c["model_edges"] >= len(truth.doors) - 1


@pytest.mark.parametrize("name", ["office_mw", "two_storey_office", "syn_house"])
def test_truth_against_itself_is_perfect(name):
    truth = _truth(name)
    r = evaluate_elements(truth, truth)
    _check_perfect(r, truth)
    json.dumps(r)  # JSON-ready


def test_office_outline_and_wall_runs(office):
    outline = exterior_outline(office, 0)
    assert outline.length == pytest.approx(OFFICE_PERIMETER, abs=1e-6)
    assert outline.area == pytest.approx(17.85 * 12.35, abs=1e-6)
    runs = true_wall_runs(office)
    # corridor north and south (2), the 5 room-to-room walls, the 4 outer sides
    assert len(runs) == 11, runs
    sizes = sorted(len(g) for g in runs)
    assert sizes == [1, 1, 1, 1, 1, 3, 3, 3, 3, 4, 4], sizes
    r = evaluate_elements(office, office)
    assert r["walls"]["truth_runs"] == 11 and r["walls"]["truth_pieces"] == len(office.walls)
    assert r["walls"]["ratio"] == pytest.approx(len(office.walls) / 11)


def test_moved_copy_without_attributes_scores_the_same(office):
    """The model in another frame (30° yaw, a large offset; ``transform`` undoes it), walls per
    the shared conventions (axis_line, external) and doors without width attributes."""
    yaw = np.radians(30)
    m = np.eye(4)
    m[:3, :3] = [[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]
    m[:3, 3] = [120.0, -45.0, 1.5]
    shapes = []
    for s in office.shapes:
        v = apply_transform(m, s.geometry.vertices)
        attrs = dict(s.attributes)
        if s.type == ShapeType.WALL:
            lo, hi = s.bounds
            fp = Polygon(s.footprint())
            c = np.asarray(fp.centroid.coords[0])
            horiz = (hi[0] - lo[0]) >= (hi[1] - lo[1])
            half = ((hi[0] - lo[0]) if horiz else (hi[1] - lo[1])) / 2
            d = np.array([1.0, 0.0]) if horiz else np.array([0.0, 1.0])
            ends = np.array([[*(c - d * half), 0.0], [*(c + d * half), 0.0]])
            attrs["axis_line"] = apply_transform(m, ends)[:, :2].tolist()
            attrs["external"] = attrs.pop("exterior", False)
        if s.type == ShapeType.DOOR:
            attrs.pop("width", None)
        shapes.append(Shape(s.id, s.type, Polyhedron(v, s.geometry.faces), storey=s.storey, name=s.name,
                            terminal=s.terminal, parent=s.parent, children=s.children, attributes=attrs))
    moved = office.with_(shapes=tuple(shapes), transform=np.linalg.inv(m))
    r = evaluate_elements(moved, office)
    _check_perfect(r, office)
    assert r["doors"]["centre_error_mean"] <= 1e-9


def test_perturbed_copy_gives_the_expected_figures(office):
    """Drop a door, shift one 0.5 m along its wall, widen one by 0.2 m, remove an exterior wall."""
    drop = _door_between(office, "Room 1", "Room 2")
    shift = _door_between(office, "Room 4", "Corridor")
    widen = _door_between(office, "Room 1", "Corridor")
    wall = _south_wall_of_room_6(office)
    model = office.replace_shapes(_box_like(office[shift], dx=0.5), _box_like(office[widen], grow=0.2),
                                  remove={drop, wall.id})
    r = evaluate_elements(model, office)
    n = len(office.doors)
    d = r["doors"]
    assert (d["true"], d["found"], d["matched"]) == (n, n - 1, n - 2)
    assert d["precision"] == pytest.approx((n - 2) / (n - 1))
    assert d["recall"] == pytest.approx((n - 2) / n)
    assert d["f1"] == pytest.approx(2 * (n - 2) / (2 * n - 1))
    assert d["width_error_max"] == pytest.approx(0.2, abs=1e-9)
    assert d["width_error_mean"] == pytest.approx(0.2 / (n - 2), abs=1e-9)
    assert d["width_within_tolerance"] == pytest.approx((n - 3) / (n - 2))
    assert [shift, shift] not in d["pairs"] and [widen, widen] in d["pairs"]
    # exterior: the removed piece's stretch of the south outline is uncovered; the interior
    # wall between Room 6 and Room 7 still reaches the outline over its thickness (any wall)
    lo, hi = wall.bounds
    gap = hi[0] - lo[0]
    between = next(w for w in office.walls if not _is_ext(w) and lo[0] < w.bounds[0][0] < hi[0]
                   and w.bounds[0][1] < -5.4)
    covered_by_inner = min(hi[0], between.bounds[1][0]) - between.bounds[0][0]
    assert gap == pytest.approx(6.0, abs=1e-6) and covered_by_inner == pytest.approx(0.15, abs=1e-6)
    ex = r["exterior"]
    assert ex["boundary_m"] == pytest.approx(OFFICE_PERIMETER, abs=1e-6)
    assert ex["external_share"] == pytest.approx(1 - gap / OFFICE_PERIMETER, abs=1e-6)
    assert ex["any_share"] == pytest.approx(1 - (gap - covered_by_inner) / OFFICE_PERIMETER, abs=1e-6)
    # walls: one piece fewer; the south run now has a 6 m hole, so the model has 12 runs
    assert r["walls"]["model"] == len(office.walls) - 1
    assert (r["walls"]["truth_runs"], r["walls"]["model_runs"]) == (11, 12)
    c = r["connectivity"]
    pair = sorted([_room_id(office, "Room 1"), _room_id(office, "Room 2")])
    assert not c["equal"] and c["missing"] == [pair] and c["extra"] == []
    assert c["model_edges"] == c["truth_edges"] - 1
    # rooms and slabs are untouched
    assert r["spaces"]["matched"] == 8 and all(p["floor"] and p["ceiling"] for p in r["slabs"]["per_storey"])


def test_slabs_per_storey_two_storeys():
    truth = _truth("two_storey_office")
    st1 = truth.storeys[1]
    mid = next(s for s in truth.slabs
               if s.attributes["kind"] == "floor" and abs(s.bounds[1][2] - st1.floor_z) < 1e-6)
    roof = next(s for s in truth.slabs if s.attributes["kind"] == "roof")
    r = evaluate_elements(truth.replace_shapes(remove={mid.id}), truth)["slabs"]
    # the slab between the storeys is storey 1's floor and storey 0's ceiling
    assert [(p["floor"], p["ceiling"]) for p in r["per_storey"]] == [(True, False), (False, True)]
    assert r["per_storey"][0]["ceiling_share"] == 0.0
    # slabs without a kind count by their height
    kindless = truth.replace_shapes(*[s.with_(attributes={}) for s in truth.slabs])
    r = evaluate_elements(kindless, truth)["slabs"]
    assert [(p["floor"], p["ceiling"]) for p in r["per_storey"]] == [(True, True), (True, True)]
    # the same slab labelled storey 0's ceiling still is storey 1's floor; without the roof
    # storey 1 has no ceiling
    as_ceiling = mid.with_(attributes={**mid.attributes, "kind": "ceiling"})
    r = evaluate_elements(truth.replace_shapes(as_ceiling, remove={roof.id}), truth)["slabs"]
    assert [(p["floor"], p["ceiling"]) for p in r["per_storey"]] == [(True, True), (True, False)]
    assert r["per_storey"][1]["floor_kinds"] == ["ceiling"] and r["per_storey"][1]["ceiling_share"] == 0.0
    # half of storey 0's floor slab: share 0.5 of the footprint, still "found" at the default 0.5
    floor0 = next(s for s in truth.slabs if s.attributes["kind"] == "floor" and s.storey == 0)
    lo, hi = floor0.bounds
    outline = exterior_outline(truth, 0)
    xm = (outline.bounds[0] + outline.bounds[2]) / 2
    half = floor0.with_(geometry=Polyhedron.box(lo, (xm, hi[1], hi[2])), scope=None)
    r = evaluate_elements(truth.replace_shapes(half), truth, ElementMatchParams(slab_overlap=0.6))["slabs"]
    assert r["per_storey"][0]["floor_share"] == pytest.approx(0.5, abs=1e-6)
    assert not r["per_storey"][0]["floor"]


def test_external_flag_falls_back_to_sides_and_adjacency(office):
    ext_ids = {w.id for w in office.walls if _is_ext(w)}
    bare = office.replace_shapes(*[w.with_(attributes={"thickness": w.attributes["thickness"]})
                                   for w in office.walls])
    # the truth's adjacency relations name the exterior shapes: external is inferred
    r = evaluate_elements(bare, office)["exterior"]
    assert r["external_walls"] == len(ext_ids) and r["external_share"] == pytest.approx(1.0, abs=1e-9)
    # without relations or attributes nothing is external, but every wall still covers
    r = evaluate_elements(bare.with_(relations=()), office)["exterior"]
    assert r["external_walls"] == 0 and r["external_share"] == 0.0
    assert r["any_share"] == pytest.approx(1.0, abs=1e-9)
    # "sides" with a None side (the shared conventions) marks a wall external
    room = office.spaces[0].id
    sided = bare.with_(relations=()).replace_shapes(
        *[bare[w].with_(attributes={**bare[w].attributes, "sides": [room, None]}) for w in ext_ids])
    assert evaluate_elements(sided, office)["exterior"]["external_share"] == pytest.approx(1.0, abs=1e-9)


def test_an_interior_wall_called_external_is_counted_inside(office):
    """An external wall deep inside the outline (more than inside_margin) is an interior wall
    called external (Pset_WallCommon.IsExternal wrong): its centre line's length there is
    ``inside_external_m``; the exterior coverage does not change."""
    def length(w):
        lo, hi = w.bounds
        return float(max(hi[:2] - lo[:2]))

    inner = max((w for w in office.walls if not _is_ext(w)), key=length)
    length = length(inner)
    flipped = office.replace_shapes(inner.with_(attributes={**inner.attributes, "external": True}))
    r = evaluate_elements(flipped, office)["exterior"]
    # all of it counts but ends within the margin of the outline
    assert length - 2 * 0.5 - 0.35 <= r["inside_external_m"] <= length + 1e-6, r
    assert r["external_share"] == pytest.approx(1.0, abs=1e-9)
    assert evaluate_elements(office, office)["exterior"]["inside_external_m"] == 0.0


def test_windows_and_openings_are_told_apart(office):
    """A WINDOW shape and a DOOR of kind "window" are windows; kind "opening" is a door."""
    office = office.replace_shapes(remove={s.id for s in office.windows})
    wall = _south_wall_of_room_6(office)
    lo, hi = wall.bounds
    cx = (lo[0] + hi[0]) / 2

    def window(sid, x, width, kind_type=ShapeType.WINDOW, attrs=None):
        geo = Polyhedron.box((x - width / 2, lo[1], 0.9), (x + width / 2, hi[1], 2.1))
        return Shape(sid, kind_type, geo, storey=0, parent=wall.id, terminal=True,
                     attributes=attrs if attrs is not None else {"kind": "window", "width": width})

    truth = office.replace_shapes(window("win_a", cx - 1.5, 1.2), window("win_b", cx + 1.5, 1.2))
    model = office.replace_shapes(
        window("m_a", cx - 1.5 + 0.1, 1.25),  # matched: 0.1 m off, 5 cm wider
        window("m_b", cx + 1.5, 1.2, ShapeType.DOOR, {"kind": "window"}),  # a DOOR of kind window
        # an extra doorless opening
        window("m_c", cx, 1.0, ShapeType.DOOR, {"kind": "opening", "width": 1.0}))
    r = evaluate_elements(model, truth)
    w, d = r["windows"], r["doors"]
    assert (w["true"], w["found"], w["matched"]) == (2, 2, 2)
    assert w["width_error_max"] == pytest.approx(0.05, abs=1e-9)  # m_b: width from its box, 1.2
    assert w["width_within_tolerance"] == 1.0
    assert w["centre_error_mean"] == pytest.approx(0.05, abs=1e-9)
    n = len(office.doors)
    assert (d["true"], d["found"], d["matched"]) == (n, n + 1, n)
    assert d["precision"] == pytest.approx(n / (n + 1)) and d["recall"] == 1.0


def test_exterior_doors_join_the_storey_exterior(office):
    """A door whose spaces name an exterior shape (or a missing ``exterior_s0``) adds an edge
    to the storey's exterior node."""
    wall = _south_wall_of_room_6(office)
    lo, hi = wall.bounds
    room6 = _room_id(office, "Room 6")
    ext = next(s.id for s in office.of_type(ShapeType.EXTERIOR))
    geo = Polyhedron.box(((lo[0] + hi[0]) / 2 - 0.5, lo[1], 0.0), ((lo[0] + hi[0]) / 2 + 0.5, hi[1], 2.1))
    door = Shape("door_ext", ShapeType.DOOR, geo, storey=0, parent=wall.id, terminal=True,
                 attributes={"kind": "door", "width": 1.0, "spaces": [room6, "exterior_s0"]})
    truth = office.replace_shapes(door).with_(
        relations=office.relations + (Relation("connectivity", room6, ext, "door_ext"),))
    r = evaluate_elements(office.replace_shapes(door), truth)["connectivity"]
    assert r["equal"] and r["truth_edges"] == len(office.relations_of("connectivity")) + 1
    r = evaluate_elements(office, truth)["connectivity"]
    assert r["missing"] == [sorted([room6, "exterior_s0"])]


def test_model_rooms_are_matched_by_footprint_overlap(office):
    """Model rooms under other ids, one room split in two: the door graph is named after the
    true rooms; the unmatched half is a model-only node."""
    corridor = office[_room_id(office, "Corridor")]
    lo, hi = corridor.bounds
    xm = (lo[0] + hi[0]) / 2
    west = Shape("m_west", ShapeType.INTERIOR, Polyhedron.box(lo, (xm, hi[1], hi[2])), storey=0)
    east = Shape("m_east", ShapeType.INTERIOR, Polyhedron.box((xm, lo[1], lo[2]), hi), storey=0)
    rel = [r for r in office.relations if corridor.id not in (r.a, r.b)]
    for r in office.relations_of("connectivity"):
        if corridor.id in (r.a, r.b):
            door = office[r.via]
            side = "m_west" if door.centroid[0] < xm else "m_east"
            rel.append(Relation("connectivity", r.other(corridor.id), side, r.via))
    model = office.replace_shapes(west, east, remove={corridor.id}).with_(relations=tuple(rel))
    r = evaluate_elements(model, office)
    assert r["spaces"]["model"] == 9 and r["spaces"]["matched"] == 8
    assert ["m_east", corridor.id] in r["spaces"]["pairs"] or ["m_west", corridor.id] in r["spaces"]["pairs"]
    c = r["connectivity"]
    lost = "m_west" if ["m_east", corridor.id] in r["spaces"]["pairs"] else "m_east"
    n_lost = sum(1 for e in c["extra"] if f"model:{lost}" in e)
    assert n_lost == len(c["missing"]) >= 1 and not c["equal"]


def test_report_writes_the_element_scores(office, tmp_path):
    res = evaluate(office, office)
    el = evaluate_elements(office, office)
    paths = write_evaluation_outputs(res, tmp_path, elements=el)
    assert json.load(open(paths["elements"]))["doors"]["f1"] == 1.0
    assert json.load(open(paths["json"]))["elements"]["connectivity"]["equal"] is True


def test_bad_input():
    with pytest.raises(InputError):
        ElementMatchParams(centre_tolerance=-1)
    with pytest.raises(InputError):
        evaluate_elements("model.json", BuildingModel())


def _duplex_like():
    """Two flats side by side (x 0 … 4 and 4.7 … 8.7, y 0 … 6) behind a 0.7 m party wall,
    0.3 m outer walls; on storey 0 a stair hall (x 0 … 1, y 0 … 2, in flat A) rising
    through storey 1, whose room of flat A leaves it out (an L); storey 2 an attic room
    without walls under a roof light; one window in storey 0.
    Returns (truth, id of the attic room)."""
    st = (Storey(0, 0.0, 2.6, "Level 1"), Storey(1, 3.0, 5.6, "Level 2"), Storey(2, 6.0, 8.0, "Roof"))
    shapes, n = [], iter(range(100))

    def room(x0, y0, x1, y1, k, z1=None, name="room"):
        s = st[k]
        shapes.append(Shape(f"r{next(n)}", ShapeType.INTERIOR,
                            Polyhedron.box((x0, y0, s.floor_z), (x1, y1, s.ceiling_z if z1 is None else z1)),
                            storey=k, name=name, terminal=True))
        return shapes[-1].id

    def wall(x0, y0, x1, y1, k, external):
        s = st[k]
        box = Polyhedron.box((x0, y0, s.floor_z), (x1, y1, s.ceiling_z))
        shapes.append(Shape(f"w{next(n)}", ShapeType.WALL, box, storey=k, terminal=True,
                            attributes={"external": external}))

    for k in (0, 1):
        if k == 0:
            room(1, 0, 4, 6, 0, name="A")
            room(0, 0, 1, 2, 0, z1=5.6, name="stair")  # spans both storeys
            room(0, 2, 1, 6, 0, name="A hall")
        else:
            shapes.append(Shape(f"r{next(n)}", ShapeType.INTERIOR,
                                Polyhedron.prism([(1, 0), (4, 0), (4, 6), (0, 6), (0, 2), (1, 2)], 3.0, 5.6),
                                storey=1, name="A upstairs", terminal=True))
        room(4.7, 0, 8.7, 6, k, name="B")
        wall(4, 0, 4.7, 6, k, False)  # the party wall
        wall(-0.3, -0.3, 9.0, 0, k, True)
        wall(-0.3, 6, 9.0, 6.3, k, True)
        wall(-0.3, 0, 0, 6, k, True)
        wall(8.7, 0, 9.0, 6, k, True)
    attic = room(0, 0, 8.7, 6, 2, name="attic")
    for wid, lo, hi, k in (("win_a", (2.0, -0.3, 1.0), (3.0, 0.0, 2.2), 0),
                           ("roof_light", (3.0, 2.0, 7.5), (4.2, 3.2, 7.7), 2)):
        shapes.append(Shape(wid, ShapeType.WINDOW, Polyhedron.box(lo, hi), storey=k, terminal=True,
                            attributes={"kind": "window", "width": hi[0] - lo[0]}))
    return BuildingModel(shapes=tuple(shapes), storeys=st), attic


def test_outline_spans_party_walls_and_stair_voids_and_skips_unseen_storeys():
    truth, attic = _duplex_like()
    rect = 2 * (8.7 + 6.0)
    # the 0.7 m party wall is inside the building: one outline, not two flats' outlines
    for k in (0, 1):
        o = exterior_outline(truth, k)
        assert len(polygon_parts(o)) == 1
        assert o.length == pytest.approx(rect, abs=1e-6), k
        assert o.area == pytest.approx(8.7 * 6.0, abs=1e-6), k
    # storey 1: the stair hall from storey 0 fills the L's notch (a void, not the outside)
    r = evaluate_elements(truth, truth)
    assert [p["boundary_m"] for p in r["exterior"]["per_storey"]] == pytest.approx([rect, rect, rect])
    assert [p["external_share"] for p in r["exterior"]["per_storey"]] == pytest.approx([1.0, 1.0, 0.0])
    # the attic, never scanned (``seen`` leaves it out), has no boundary, slabs or room to find
    seen = {s.id for s in truth.spaces if s.id != attic}
    r = evaluate_elements(truth, truth, seen=seen)
    assert [p["boundary_m"] for p in r["exterior"]["per_storey"]] == pytest.approx([rect, rect, 0.0])
    assert r["exterior"]["external_share"] == pytest.approx(1.0, abs=1e-9)
    assert r["slabs"]["storeys"] == 2 and r["slabs"]["per_storey"][2]["floor"] is None
    assert r["spaces"]["truth_spaces"] == len(truth.spaces) - 1 == r["spaces"]["matched_spaces"]
    # flat A's storey-0 rooms meet without walls: one open plan, one room (4 rooms in all)
    assert r["spaces"]["truth"] == r["spaces"]["matched"] == 4
    # the model's spaces are counted as the rooms are: the open plan's two spaces one room,
    # the unscanned attic none (the raw count keeps every space)
    assert r["spaces"]["model_rooms"] == 4 and r["spaces"]["model"] == len(truth.spaces) == 7
    # ... nor windows (a roof light in the attic's roof): a model without it loses nothing
    assert evaluate_elements(truth, truth)["windows"]["true"] == 2
    r = evaluate_elements(truth.replace_shapes(remove={"roof_light"}), truth, seen=seen)
    assert r["windows"]["true"] == r["windows"]["matched"] == 1 and r["windows"]["f1"] == 1.0
    # ... but a roof light right over a seen room (0.4 m over flat B's upstairs ceiling,
    # filed under the unscanned roof level, as the Duplex's) is seen from that room: it counts
    sky = Shape("sky", ShapeType.WINDOW, Polyhedron.box((5.5, 2.0, 6.0), (6.6, 3.0, 6.2)), storey=2,
                terminal=True, attributes={"kind": "window", "width": 1.1})
    with_sky = truth.with_(shapes=truth.shapes + (sky,))
    r = evaluate_elements(truth.replace_shapes(remove={"roof_light"}), with_sky, seen=seen)
    assert r["windows"]["true"] == 2 and r["windows"]["matched"] == 1
    # a room never scanned (flat B upstairs) is no part of the scanned building's outline:
    # flat A and the party wall beside it remain
    b_up = next(s.id for s in truth.spaces if s.name == "B" and s.storey == 1)
    o = exterior_outline(truth, 1, seen=seen - {b_up})
    assert o.area == pytest.approx(4.7 * 6.0, abs=1e-6)
    assert o.length == pytest.approx(2 * (4.7 + 6.0), abs=1e-6)
    # a model without the party wall still covers the whole outline: it is no exterior boundary
    party = [w.id for w in truth.walls if not w.attributes["external"]]
    r = evaluate_elements(truth.replace_shapes(remove=set(party)), truth, seen=seen)
    assert r["exterior"]["any_share"] == pytest.approx(1.0, abs=1e-9)


def test_wall_runs_of_a_storey_no_scan_reached_are_not_counted():
    """With ``seen``, the true wall runs of storeys without a seen space are left out, as their
    exterior, slabs and openings are (the Duplex: foundation walls under its ground floor, the
    parapets and skylight shafts of its roof level — 19 of its 55 runs no scanner can see)."""
    from engine.evaluation.elements import true_wall_runs
    from engine.evaluation.footprints import _truth_storey

    truth, attic = _duplex_like()
    runs = true_wall_runs(truth)
    per = [_truth_storey(truth[r[0]], truth) for r in runs]
    assert evaluate_elements(truth, truth)["walls"]["truth_runs"] == len(runs)
    ground = {s.id for s in truth.spaces if _truth_storey(s, truth) == 0}
    r = evaluate_elements(truth, truth, seen=ground)["walls"]
    assert r["truth_runs"] == per.count(0) < len(runs)


def test_a_door_into_an_open_plan_is_a_door_into_the_whole_plan():
    """The Duplex's foyer, living room and kitchen of a flat are one open plan (one room in the
    room scores). A model that has them as one space names it after the living room (the
    best overlap), so its front door joined "Living Room" to the exterior while the truth's
    joins "Foyer": a missing and an extra edge for the same door. Open plans are one node of
    the graph as they are one room: equal."""
    import os

    from engine.evaluation.elements import _plan
    from engine.evaluation.rooms import room_scores
    from engine.ifc import read_ifc
    from scenes import DATA

    truth = read_ifc(os.path.join(DATA, "Duplex_A_20110907_architecture.ifc"))
    groups = [g for st in room_scores(truth, truth)["per_storey"] for g in st["true_group_ids"] if len(g) > 1]
    names = {s.id: s.name for s in truth.spaces}
    plan = next(g for g in groups if "Foyer" in {names[x] for x in g})
    assert {names[x] for x in plan} >= {"Foyer", "Living Room"}
    union = unary_union([_plan(truth[x], truth) for x in plan])
    z0 = min(truth[x].bounds[0, 2] for x in plan)
    z1 = max(truth[x].bounds[1, 2] for x in plan)
    merged = Shape("m_plan", ShapeType.INTERIOR, Polyhedron.prism(np.asarray(union.exterior.coords)[:-1], z0, z1),
                   storey=truth[plan[0]].storey)
    rel = tuple(Relation(r.kind, "m_plan" if r.a in plan else r.a, "m_plan" if r.b in plan else r.b, r.via)
                for r in truth.relations if not (r.a in plan and r.b in plan))
    doors = [d.with_(attributes={**d.attributes, "spaces": ["m_plan" if x in plan else x
                                                             for x in d.attributes.get("spaces", [])]})
             for d in truth.doors]
    model = truth.replace_shapes(merged, *doors, remove=set(plan)).with_(relations=rel)
    r = evaluate_elements(model, truth)
    assert ["m_plan", next(x for x in plan if names[x] == "Living Room")] in r["spaces"]["pairs"]
    c = r["connectivity"]
    assert c["equal"], c
    assert c["truth_edges"] == c["model_edges"] >= 6


def test_a_door_into_an_unseen_room_leads_outside(office):
    """An unscanned room (unscanned_room: a closed office no position sees) is no room to find
    and lies outside the scored outline; a model sees the door into it as a door out of the
    building. With ``seen`` the true edge goes to the storey's exterior node: equal; without,
    the edge to the room is missing (the one to the exterior is the corridor's front door's
    too)."""
    room = office[_room_id(office, "Room 6")]
    rel = [r for r in office.relations if room.id not in (r.a, r.b)]
    doors = []
    for r in office.relations_of("connectivity"):
        if room.id in (r.a, r.b):
            rel.append(Relation("connectivity", r.other(room.id), "exterior_s0", r.via))
            d = office[r.via]
            doors.append(d.with_(attributes={**d.attributes, "spaces": [r.other(room.id), "exterior_s0"]}))
    assert doors
    model = office.replace_shapes(*doors, remove={room.id}).with_(relations=tuple(rel))
    seen = {s.id for s in office.spaces} - {room.id}
    c = evaluate_elements(model, office, seen=seen)["connectivity"]
    assert c["equal"], c
    c = evaluate_elements(model, office)["connectivity"]
    assert not c["equal"] and c["missing"] == sorted(sorted([d.attributes["spaces"][0], room.id]) for d in doors)
