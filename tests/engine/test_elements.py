"""Wall runs, slabs and the exterior from spaces (engine.elements.build)."""
import math

import numpy as np
import pytest
from shapely.geometry import Point, Polygon
from shapely.ops import unary_union

from engine.elements.build import building_elements
from engine.elements.params import ElementsParams, WallRunParams
from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey

NO_SCAN = ElementsParams(detect_openings=False)


def _rot(xy, angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.asarray(xy, float) @ np.array([[c, s], [-s, c]])


def _model(rooms, angle=0.0, height=2.8):
    shapes = [Shape(f"room{k}", ShapeType.INTERIOR, Polyhedron.prism(_rot(fp, angle), 0.0, height), name=f"Room {k}",
                    terminal=True) for k, fp in enumerate(rooms)]
    return BuildingModel(shapes=tuple(shapes), storeys=(Storey(0, 0.0, height, "Ground"),))


def _rect(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _walls(m):
    return sorted(m.walls, key=lambda w: w.id)


@pytest.mark.parametrize("angle", [0.0, math.radians(30.0)])
def test_two_rooms_give_one_partition_and_four_exterior_runs(angle):
    m = building_elements(_model([_rect(0, 0, 4, 4), _rect(4.15, 0, 8.15, 4)], angle), params=NO_SCAN)
    inner = [w for w in m.walls if not w.attributes["external"]]
    outer = [w for w in m.walls if w.attributes["external"]]
    assert len(inner) == 1 and len(outer) == 4
    assert inner[0].attributes["thickness"] == pytest.approx(0.15, abs=0.005)
    assert sorted(inner[0].attributes["sides"]) == ["room0", "room1"]
    for w in outer:
        assert w.attributes["thickness"] == pytest.approx(0.3, abs=1e-6)
        assert "exterior_s0" in w.attributes["sides"]
    # the exterior walls close the building: the 0.3 m band around the rooms is covered
    rooms = unary_union([Polygon(_rot(_rect(0, 0, 8.15, 4), angle))])
    band = rooms.buffer(0.3, join_style="mitre").difference(rooms)
    cover = unary_union([Polygon(w.footprint()) for w in outer])
    assert band.difference(cover).area < 0.01 * band.area  # corners closed (butt joints)
    # no two walls overlap (butt joints, not overlaps), within 1 cm² of rounding
    polys = [Polygon(w.footprint()) for w in m.walls]
    overlap = sum(a.intersection(b).area for i, a in enumerate(polys) for b in polys[i + 1:])
    assert overlap < 1e-4
    joins = [(j["at"], j["other_at"]) for w in m.walls for j in w.attributes["joins"]]
    assert sum(1 for j in joins if "ATPATH" in j) == 2  # the partition meets both long walls
    assert sum(1 for j in joins if "ATPATH" not in j) == 4  # four corners
    assert len(m.of_type(ShapeType.EXTERIOR)) == 1
    kinds = sorted(s.attributes["kind"] for s in m.slabs)
    assert kinds == ["base", "roof"]
    rel = {(r.a, r.b, r.via) for r in m.relations if r.kind == "adjacency"}
    assert ("room0", "room1", inner[0].id) in rel
    assert {r.a for r in m.relations if r.b == "exterior_s0"} | {r.b for r in m.relations if r.a == "exterior_s0"} \
        >= {"room0", "room1"}


def test_rooms_that_touch_meet_without_a_wall():
    m = building_elements(_model([_rect(0, 0, 4, 4), _rect(4.0, 0, 8, 4)]), params=NO_SCAN)
    assert all(w.attributes["external"] for w in m.walls)
    assert ("room0", "room1", None) in {(r.a, r.b, r.via) for r in m.relations if r.kind == "adjacency"}
    # no wall between them: the rooms are walkable from one to the other
    assert ("room0", "room1", None) in {(r.a, r.b, r.via) for r in m.relations if r.kind == "connectivity"}


def test_a_party_wall_is_one_thick_wall():
    m = building_elements(_model([_rect(0, 0, 5, 6), _rect(5.6, 0, 10.6, 6)]), params=NO_SCAN)
    inner = [w for w in m.walls if not w.attributes["external"]]
    assert len(inner) == 1 and inner[0].attributes["thickness"] == pytest.approx(0.6, abs=0.005)
    # a gap wider than max_thickness is no wall between the rooms
    m2 = building_elements(_model([_rect(0, 0, 5, 6), _rect(5.6, 0, 10.6, 6)]),
                           params=ElementsParams(walls=WallRunParams(max_thickness=0.5), detect_openings=False))
    assert all(w.attributes["external"] for w in m2.walls)


def test_l_shaped_building_is_closed_at_the_concave_corner():
    rooms = [_rect(0, 0, 6, 4), _rect(0, 4.15, 3, 8)]
    m = building_elements(_model(rooms), params=NO_SCAN)
    outer = [w for w in m.walls if w.attributes["external"]]
    fp = unary_union([Polygon(r) for r in rooms] + [Polygon(w.footprint()) for w in m.walls if not w.attributes["external"]])
    band = fp.buffer(0.3, join_style="mitre").difference(fp)
    cover = unary_union([Polygon(w.footprint()) for w in outer])
    assert band.difference(cover).area < 0.02 * band.area
    assert len(outer) == 6  # an L has six sides


def test_rerun_is_idempotent_and_keeps_openings():
    m = building_elements(_model([_rect(0, 0, 4, 4), _rect(4.15, 0, 8.15, 4)]), params=NO_SCAN)
    wall = next(w for w in m.walls if not w.attributes["external"])
    door = Shape("door_1", ShapeType.DOOR, Polyhedron.box((4.0, 1.5, 0.0), (4.15, 2.4, 2.1)), parent=wall.id,
                 terminal=True, attributes={"width": 0.9, "height": 2.1, "sill": 0.0, "kind": "door"})
    m = m.with_(shapes=m.shapes + (door,))
    again = building_elements(m, params=NO_SCAN)
    assert len(again.walls) == len(m.walls)
    assert len(again.slabs) == len(m.slabs) and len(again.of_type(ShapeType.EXTERIOR)) == 1
    d = again["door_1"]
    assert d.parent in {w.id for w in again.walls}
    assert sorted(d.attributes["spaces"]) == ["room0", "room1"]
    assert ("room0", "room1", "door_1") in {(r.a, r.b, r.via) for r in again.relations if r.kind == "connectivity"}


def test_two_storeys_share_the_slab_between_them():
    s0 = Shape("a", ShapeType.INTERIOR, Polyhedron.prism(_rect(0, 0, 5, 5), 0.0, 2.7), storey=0, terminal=True)
    s1 = Shape("b", ShapeType.INTERIOR, Polyhedron.prism(_rect(0, 0, 5, 5), 3.0, 5.7), storey=1, terminal=True)
    m = BuildingModel(shapes=(s0, s1), storeys=(Storey(0, 0.0, 2.7), Storey(1, 3.0, 5.7)))
    e = building_elements(m, params=NO_SCAN)
    slabs = sorted(e.slabs, key=lambda s: s.bounds[0, 2])
    assert [s.attributes["kind"] for s in slabs] == ["base", "floor", "roof"]
    mid = slabs[1]
    assert mid.attributes["thickness"] == pytest.approx(0.3, abs=1e-6) and mid.attributes["thickness_measured"]
    assert mid.bounds[0, 2] == pytest.approx(2.7) and mid.bounds[1, 2] == pytest.approx(3.0)
    assert len(e.of_type(ShapeType.EXTERIOR)) == 2


def test_a_model_with_its_own_exterior_ids_and_detected_openings_rebuilds():
    rooms = _model([_rect(0, 0, 4, 4), _rect(4.15, 0, 8.15, 4)])
    ext = Shape("exterior_s0", ShapeType.EXTERIOR, Polyhedron.box((-2, -2, 0), (-1, -1, 2.8)), terminal=True)
    m = building_elements(rooms.with_(shapes=rooms.shapes + (ext,)), params=NO_SCAN)
    assert len(m.of_type(ShapeType.EXTERIOR)) == 1 and m["exterior_s0"].children == ("exterior_s0_part",)
    assert not m["exterior_s0_part"].active
    wall = next(w for w in m.walls if not w.attributes["external"])
    # a detected door in the old wall, 0.1 m off its axis and too thin: rebuilt across the new wall
    door = Shape("door_d", ShapeType.DOOR, Polyhedron.box((4.0, 1.5, 0.0), (4.1, 2.4, 2.1)), parent=wall.id,
                 terminal=True, attributes={"width": 0.9, "height": 2.1, "sill": 0.0, "kind": "door",
                                            "detected": True})
    again = building_elements(m.with_(shapes=m.shapes + (door,)), params=NO_SCAN)
    d = again["door_d"]
    lo, hi = d.bounds
    assert hi[0] - lo[0] == pytest.approx(0.15, abs=1e-6) and hi[1] - lo[1] == pytest.approx(0.9, abs=1e-6)
    assert lo[0] == pytest.approx(4.0, abs=1e-6)
    # twice more: still one exterior, the same parts
    third = building_elements(again, params=NO_SCAN)
    assert sorted(s.id for s in third.of_type(ShapeType.EXTERIOR, active=None)) == ["exterior_s0", "exterior_s0_part"]
    assert "door_d" in third


def _wall_with_window(u0, u1, sill, top):
    """An exterior wall run along x built with the default 0.3 m (axis y = -0.15, inner face
    y = 0, the room on the +y side) and a window from u0 to u1, z sill to top."""
    wall = Shape("w", ShapeType.WALL, Polyhedron.box((0, -0.3, 0), (6, 0, 2.8)), terminal=True,
                 attributes={"axis_line": [[0, -0.15], [6, -0.15]], "thickness": 0.3, "external": True,
                             "sides": ["r", "exterior_s0"]})
    win = Shape("o", ShapeType.WINDOW, Polyhedron.box((u0, -0.3, sill), (u1, 0, top)), terminal=True, parent="w",
                attributes={"width": u1 - u0, "sill": sill, "height": top - sill})
    return wall, win


def test_reveal_depth_measures_an_exterior_wall_through_its_window():
    from engine.elements.thickness import PointGrid, reveal_depth
    rng = np.random.default_rng(3)
    wall, win = _wall_with_window(2.0, 3.2, 0.9, 2.2)  # truly 0.45 m thick (outer face y = -0.45)
    n = 4000
    jamb = np.c_[rng.choice([2.0, 3.2], n), -rng.uniform(0, 0.45, n), rng.uniform(0.9, 2.2, n)]
    sill = np.c_[rng.uniform(2.0, 3.2, n), -rng.uniform(0, 0.45, n), np.full(n, 0.9)]
    face = np.c_[rng.uniform(0, 6, n), np.zeros(n), rng.uniform(0, 2.8, n)]
    face = face[~((face[:, 0] > 2) & (face[:, 0] < 3.2) & (face[:, 2] > 0.9) & (face[:, 2] < 2.2))]
    beyond = np.c_[rng.uniform(0, 6, 300), -rng.uniform(5, 10, 300), rng.uniform(0, 3, 300)]  # seen through it
    pts = np.vstack([jamb, sill, face, beyond]) + rng.normal(0, 0.003, (len(jamb) + len(sill) + len(face) + 300, 3))
    t = reveal_depth(wall, [win], PointGrid(pts), inner_side=1, max_thickness=0.7)
    assert t == pytest.approx(0.45, abs=0.02)
    # no reveal points: no measurement
    assert reveal_depth(wall, [win], PointGrid(np.vstack([face, beyond])), 1, 0.7) is None


def test_reveal_depth_behind_a_pane():
    """A pane 12 cm behind the inner face (FZK-Haus): the reveal seen in full ends there; its
    sparse part seen through the pane gives the 0.30 m wall; without that part the wall is not
    measured (it was 0.14 m, the frame's depth)."""
    from engine.elements.thickness import PointGrid, reveal_depth
    rng = np.random.default_rng(4)
    wall, win = _wall_with_window(2.0, 4.0, 0.9, 2.1)
    n = 600
    near = np.c_[rng.choice([2.0, 4.0], n), -rng.uniform(0.0, 0.13, n), rng.uniform(0.9, 2.1, n)]  # to the frame
    far = np.c_[rng.choice([2.0, 4.0], 40), -rng.uniform(0.14, 0.3, 40), rng.uniform(0.9, 2.1, 40)]  # through it
    pane = np.c_[rng.uniform(2.0, 4.0, 3000), rng.normal(-0.12, 0.003, 3000), rng.uniform(0.9, 2.1, 3000)]
    noise = lambda a: a + rng.normal(0, 0.003, a.shape)  # noqa: E731
    t = reveal_depth(wall, [win], PointGrid(noise(np.vstack([near, far, pane]))), inner_side=1, max_thickness=0.7)
    assert t == pytest.approx(0.30, abs=0.02)
    assert reveal_depth(wall, [win], PointGrid(noise(np.vstack([near, pane]))), 1, 0.7) is None
    # no pane (an open hole): the reveal runs on to the outer face
    assert reveal_depth(wall, [win], PointGrid(noise(np.vstack([near, far]))), 1, 0.7) == pytest.approx(0.30, abs=0.02)


@pytest.mark.parametrize("outside,lowest,kind", [
    ("terrace", None, "door"), ("ground_below", None, "window"), ("none", None, "door"),
    ("closed", None, "door"),
    ("terrace", 0.0, "door"), ("none", 0.0, "window"), ("closed", 0.0, "door"), ("none", 3.0, "door"),
    ("thick_sill", 0.0, "window"),
    ("none_unseen", 0.0, "window"), ("terrace_unseen", 0.0, "door"), ("none_unseen", 3.0, "door"),
    ("ground_below_unseen", None, "door")])
def test_exterior_door_with_nothing_walkable_beyond_is_a_window(outside, lowest, kind):
    """An upper storey's floor-to-ceiling window (floor at z = 3) looks like a door; beyond it
    the scan sees the ground 3 m below and nothing at its floor's level: a window. A terrace
    at the floor's level keeps it a door; so do no points beyond and a closed leaf. With the
    building's lowest floor known (``lowest``), seen through with nothing walkable beyond is
    enough 3 m above it, not on the lowest storey itself. A sill 8 cm up in a wall 0.25 m
    thicker than the first pass assumed (points at the floor's level just past the assumed
    outer face) is no terrace. 3 m above the lowest floor nothing need be seen through it
    ("_unseen": a scan without positions, whose stand-ins saw little through the Duplex's
    narrow level-2 windows): a balcony's floor just beyond would still show; on the lowest
    storey, or without the lowest floor, what is seen through decides."""
    from engine.elements.egress import elevated_doors
    unseen = outside.endswith("_unseen")
    outside = outside.removesuffix("_unseen")
    from engine.elements.thickness import PointGrid
    rng = np.random.default_rng(6)
    # exterior wall along x, room on the +y side (left of the axis), exterior on the right
    wall = Shape("w", ShapeType.WALL, Polyhedron.box((0, -0.3, 3), (6, 0, 5.8)), terminal=True, storey=1,
                 attributes={"axis_line": [[0, -0.15], [6, -0.15]], "thickness": 0.3, "external": True,
                             "sides": ["r", "exterior_s1"]})
    door = Shape("door_w_0", ShapeType.DOOR, Polyhedron.box((2, -0.3, 3), (2.8, 0, 5.2)), terminal=True,
                 parent="w", storey=1, name="Door 1", support={"seen_through": 0.2 if outside != "closed" and not unseen else 0.0},
                 attributes={"width": 0.8, "sill": 0.0, "height": 2.2, "kind": "door", "open": outside != "closed"})
    win = Shape("window_w_1", ShapeType.WINDOW, Polyhedron.box((4, -0.3, 4), (5, 0, 5)), terminal=True,
                parent="w", storey=1, name="Window 1", attributes={"width": 1.0, "sill": 1.0, "height": 1.0,
                                                                    "kind": "window"})
    room = np.c_[rng.uniform(0, 6, 3000), rng.uniform(0, 4, 3000), np.full(3000, 3.0)]
    beyond = {"terrace": np.c_[rng.uniform(1.5, 3.3, 200), -rng.uniform(0.5, 3, 200), np.full(200, 2.9)],
              "ground_below": np.c_[rng.uniform(0, 6, 200), -rng.uniform(2, 12, 200), np.zeros(200)],
              "none": np.zeros((0, 3)), "closed": np.c_[rng.uniform(0, 6, 200), -rng.uniform(2, 12, 200),
                                                        np.zeros(200)],
              "thick_sill": np.c_[rng.uniform(2.0, 2.8, 200), -rng.uniform(0.36, 0.55, 200),
                                  np.full(200, 3.08)]}[outside]
    out = elevated_doors([door, win], [wall], PointGrid(np.vstack([room, beyond])), lowest_floor=lowest)
    assert len(out) == 2 and out[1].type == ShapeType.WINDOW and out[1].id == "window_w_1"
    o = out[0]
    assert o.type.value == kind
    if kind == "window":
        assert o.id == "window_w_0" and o.attributes["kind"] == "window" and "open" not in o.attributes
        assert o.attributes["sill"] == 0.0 and o.attributes["height"] == 2.2 and "egress" in o.log[-1]
        assert sorted(s.name for s in out) == ["Window 1", "Window 2"]
    else:
        assert o is door


# ----------------------------------------------------------------------------- breaks and thick gaps
def _runs(fps, **kw):
    from engine.elements.walls import wall_runs

    return wall_runs({k: Polygon(v) for k, v in fps.items()}, 0, WallRunParams(), **kw)


def test_a_room_reaching_into_its_wall_along_a_doorway_gives_one_wall():
    """Two rooms either side of a 0.2 m wall; along 2.85 m of it (a doorway's stretch) one
    room's footprint reaches 7 cm into the wall: that piece is 0.13 m thick, beyond the runs'
    thickness tolerance, and made a second run over the same stretch, bridged by the wall's
    own run (hexagon_hall mobile 3: its door found in both). One run, 0.2 m thick."""
    fps = {"a": [(-4, 0), (-0.1, 0), (-0.1, 0.5), (-0.03, 0.5), (-0.03, 3.35), (-0.1, 3.35), (-0.1, 3.8),
                 (-4, 3.8)],
           "b": _rect(0.1, 0, 4, 3.8)}
    runs, _ = _runs(fps)
    inner = [r for r in runs if not r.external]
    assert len(inner) == 1, [(r.thickness, r.length) for r in inner]
    assert inner[0].thickness == pytest.approx(0.2, abs=0.01) and inner[0].length == pytest.approx(3.8, abs=0.1)


def test_a_partition_standing_free_in_one_space_is_a_wall():
    """One space wrapping round a 0.12 m partition that stops 3 m short of the far wall (the
    Duplex's living room and foyer, one open plan past the partition's end): the partition's
    two sides are edges of that one space facing each other; it is a wall with the space on
    both sides (it was dropped: the terrace door beside it lost the wall its shadow test
    needs, and the IFC a real wall). A slit wider than max_thickness is no wall."""
    for gap, walls in ((0.12, 1), (0.9, 0)):
        fps = {"a": [(0, 0), (3, 0), (3, 4), (3 + gap, 4), (3 + gap, 0), (6, 0), (6, 7), (0, 7)]}
        runs, _ = _runs(fps)
        inner = [r for r in runs if not r.external]
        assert len(inner) == walls, (gap, [(r.a, r.b, r.thickness) for r in inner])
        if walls:
            assert inner[0].thickness == pytest.approx(gap, abs=0.005) and inner[0].length == pytest.approx(4, abs=0.05)
            assert list(inner[0].sides()) == ["a", "a"]


def test_a_floor_to_ceiling_break_ends_the_wall_and_the_rooms_meet_there():
    """An 8 m partition interrupted over x 3–5.5 (a gap from floor to ceiling): two runs that
    stop at the break, and the two rooms meet without a wall there (an open plan)."""
    fps = {"a": _rect(0, 0, 8, 4), "b": _rect(0, 4.1, 8, 8)}
    runs, open_pairs = _runs(fps)
    inner = [r for r in runs if not r.external]
    assert len(inner) == 1 and inner[0].length == pytest.approx(8.0, abs=0.35) and not open_pairs
    brk = Polygon(_rect(3.0, 3.9, 5.5, 4.2))
    runs, open_pairs = _runs(fps, breaks=[brk])
    inner = sorted((r for r in runs if not r.external), key=lambda r: min(r.a[0], r.b[0]))
    assert len(inner) == 2, [(r.a, r.b) for r in inner]
    assert max(inner[0].a[0], inner[0].b[0]) == pytest.approx(3.0, abs=0.02)
    assert min(inner[1].a[0], inner[1].b[0]) == pytest.approx(5.5, abs=0.02)
    assert ("a", "b") in open_pairs
    assert all(not brk.buffer(-0.01).intersects(Polygon(r.footprint())) for r in runs)


def test_a_solid_gap_wider_than_max_thickness_is_one_thick_wall():
    """Rooms 0.9 m apart (more than max_thickness 0.7): a party wall when the scan says the gap
    is solid; else the gap is a void inside the building (a closet, a shaft, a strip behind
    furniture): an interior wall along each room's face and the envelope closed across the
    gap's ends (before: two exterior walls inside the building and no wall across the ends);
    no scan, no test: exterior walls."""
    fps = {"a": _rect(0, 0, 5, 6), "b": _rect(5.9, 0, 10.9, 6)}
    asked = []

    def solid(region):
        asked.append(region)
        return True

    runs, _ = _runs(fps, solid=solid)
    inner = [r for r in runs if not r.external]
    assert len(inner) == 1 and inner[0].thickness == pytest.approx(0.9, abs=0.005)
    assert sorted(inner[0].sides()) == ["a", "b"]
    # the region asked about is the gap's core, clear of the faces by solid_margin
    m = WallRunParams().solid_margin
    assert asked and asked[0].bounds[0] == pytest.approx(5.0 + m, abs=1e-6)
    assert asked[0].bounds[2] == pytest.approx(5.9 - m, abs=1e-6)
    runs, _ = _runs(fps, solid=lambda r: False)
    inner = sorted((r for r in runs if not r.external), key=lambda r: r.a[0])
    t = WallRunParams().void_wall_thickness
    assert len(inner) == 2 and all(r.thickness == pytest.approx(t) for r in inner)
    assert [float(r.a[0]) for r in inner] == pytest.approx([5.0 + t / 2, 5.9 - t / 2], abs=1e-6)
    assert [set(r.sides()) for r in inner] == [{"a", "b"}] * 2  # a door in one leads across the void
    outer = [Polygon(r.footprint()) for r in runs if r.external]
    for y in (-0.15, 6.15):  # the south and north envelope go on across the gap's ends
        assert any(p.contains(Point(5.45, y)) for p in outer), y
    assert not any(p.contains(Point(5.45, 3.0)) for p in outer)  # nothing exterior inside
    runs, _ = _runs(fps, solid=None)
    assert all(r.external for r in runs)
    # farther apart than max_solid_thickness: never asked, no wall between
    asked.clear()
    runs, _ = _runs({"a": _rect(0, 0, 5, 6), "b": _rect(6.5, 0, 11.5, 6)}, solid=solid)
    assert not asked and all(r.external for r in runs)


@pytest.mark.parametrize("hole", [1.0, 3.0])
def test_a_shaft_enclosed_by_rooms_has_interior_walls_a_courtyard_exterior_ones(hole):
    """Four rooms (0.2 m walls between them) around a square hole: a 1 m shaft (no wider than
    max_solid_thickness) lies inside the building, its faces get interior walls (before:
    exterior ones); a 3 m courtyard is outside, its faces get exterior walls. No scan."""
    h, g = hole / 2, hole / 2 + 4.0  # the hole is |x|, |y| < h
    fps = {"s": _rect(-g, -g, g, -h), "n": _rect(-g, h, g, g),
           "w": _rect(-g, -h + 0.2, -h, h - 0.2), "e": _rect(h, -h + 0.2, g, h - 0.2)}
    runs, _ = _runs(fps)
    facing = [r for r in runs if max(abs(float(v)) for v in 0.5 * (r.a + r.b)) < h + 0.35]
    assert facing, [(r.a, r.b) for r in runs]
    if hole < WallRunParams().max_solid_thickness:
        assert not any(r.external for r in facing)
        # named by their own room on both sides in the model: no adjacency to the exterior
        m = building_elements(_model([fps[k] for k in ("s", "n", "w", "e")]), params=NO_SCAN)
        inner = [w for w in m.walls if not w.attributes["external"]
                 and max(abs(float(v)) for v in np.mean(w.attributes["axis_line"], axis=0)) < h + 0.35]
        assert inner and all(len(set(w.attributes["sides"])) == 1 for w in inner)
        assert not any(r.via in {w.id for w in inner} and "exterior" in r.a + r.b for r in m.relations)
    else:
        assert all(r.external for r in facing)


def _gap_cloud(floor_in_gap: bool):
    """Points of two rooms 0.9 m apart: their floors, their faces 0.1 m inside the gap (the
    rooms stop short of the wall), and, when ``floor_in_gap``, floor points in the gap."""
    from engine.pointcloud import PointCloud

    rng = np.random.default_rng(0)
    floor = rng.uniform([0, 0, 0], [10.9, 6, 0], (40_000, 3))
    keep = (floor[:, 0] < 5.0) | (floor[:, 0] > 5.9) | floor_in_gap
    faces = [np.column_stack([np.full(4000, x), rng.uniform(0, 6, 4000), rng.uniform(0, 2.8, 4000)])
             for x in (5.1, 5.8)]
    xyz = np.vstack([floor[keep]] + faces) + rng.normal(0, 0.005, (int(keep.sum()) + 8000, 3))
    return PointCloud(xyz=xyz)


@pytest.mark.parametrize("floor_in_gap", [False, True])
def test_a_thick_wall_needs_an_empty_gap_in_the_scan(floor_in_gap):
    m = _model([_rect(0, 0, 5, 6), _rect(5.9, 0, 10.9, 6)])
    out = building_elements(m, _gap_cloud(floor_in_gap), params=NO_SCAN)
    inner = [w for w in out.walls if not w.attributes["external"]]
    if floor_in_gap:  # a space the reconstruction left out, not a wall: a wall along each room
        t = WallRunParams().void_wall_thickness
        assert len(inner) == 2 and all(w.attributes["thickness"] == pytest.approx(t) for w in inner)
    else:
        assert len(inner) == 1 and inner[0].attributes["thickness"] == pytest.approx(0.9, abs=0.01)


def _touching_cloud(wall: bool, rail: bool = False):
    """Two rooms that touch along x = 5 (the method's split cut through the wall between
    them). ``wall``: its faces at x = 4.97 and 5.10 (a 13 cm partition the rooms overlap);
    ``rail``: instead, two 1 m high planes there (a rail, a low cabinet)."""
    from engine.pointcloud import PointCloud

    rng = np.random.default_rng(1)
    floor = rng.uniform([0, 0, 0], [10, 6, 0], (40_000, 3))
    parts = [floor]
    if wall or rail:
        top = 2.8 if wall else 1.0
        parts += [np.column_stack([np.full(5000, x), rng.uniform(0, 6, 5000), rng.uniform(0, top, 5000)])
                  for x in (4.97, 5.10)]
    xyz = np.vstack(parts)
    return PointCloud(xyz=xyz + rng.normal(0, 0.005, xyz.shape))


@pytest.mark.parametrize("case", ["wall", "open", "rail"])
def test_rooms_touching_on_a_wall_seen_in_the_scan_keep_the_wall(case):
    m = _model([_rect(0, 0, 5, 6), _rect(5, 0, 10, 6)])
    out = building_elements(m, _touching_cloud(case == "wall", case == "rail"), params=NO_SCAN)
    inner = [w for w in out.walls if not w.attributes["external"]]
    rel = {(r.kind, r.a, r.b, r.via) for r in out.relations}
    if case == "wall":
        assert len(inner) == 1
        w = inner[0]
        assert w.attributes["thickness"] == pytest.approx(0.13, abs=0.02)
        assert float(np.mean(np.asarray(w.attributes["axis_line"])[:, 0])) == pytest.approx(5.035, abs=0.015)
        assert ("connectivity", "room0", "room1", None) not in rel
    else:  # nothing there, or no wall's height: an open plan
        assert inner == []
        assert ("connectivity", "room0", "room1", None) in rel


def test_an_opening_in_a_gap_of_its_walls_side_spans_takes_the_nearest_spans_rooms():
    """A wall run along a corridor with rooms on its other side, one span per room; a room
    whose footprint takes in its doorway leaves a gap in its span there. The door in that gap
    connects that room and the corridor — before, it took the run's first room, 8 m away
    (office_mw mobile at 1M points: the door graph wrong with every door found)."""
    from engine.elements.build import _with_spaces

    spans = [[0.0, 4.35, "room5", "corridor"], [4.5, 8.43, "room6", "corridor"],
             [9.0, 12.0, "room4", "corridor"], [12.42, 13.35, "room4", "corridor"],
             [13.5, 17.85, "room7", "corridor"]]
    wall = Shape("w", ShapeType.WALL, Polyhedron.prism([(0, 1.93), (18, 1.93), (18, 2.07), (0, 2.07)], 0, 3),
                 attributes={"axis_line": [[0.0, 2.0], [18.0, 2.0]], "sides": ["room5", "corridor"],
                             "side_spans": spans})
    model = BuildingModel(shapes=(wall,))

    def door(x):
        return Shape(f"d{x}", ShapeType.DOOR, Polyhedron.prism([(x - 0.45, 1.93), (x + 0.45, 1.93),
                                                                (x + 0.45, 2.07), (x - 0.45, 2.07)], 0, 2.1),
                     parent="w")

    assert _with_spaces(door(12.12), model).attributes["spaces"] == ["room4", "corridor"]  # in the gap
    assert _with_spaces(door(6.0), model).attributes["spaces"] == ["room6", "corridor"]  # in a span
    assert _with_spaces(door(8.7), model).attributes["spaces"] == ["room6", "corridor"]  # nearer room6's
