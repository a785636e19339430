"""Windows, exterior doors, closed door leaves and the surroundings of the scan simulator:
holes and reveals in the mesh, partly transparent glazing, points beyond the exterior wall
only through openings, recessed leaves, the truth's openings and the plan JSON."""
import math
from dataclasses import replace

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon
from shapely.ops import unary_union

from engine.errors import InputError
from engine.model import ShapeType
from engine.synthetic import (
    LABEL_CLUTTER,
    LABEL_DOOR,
    LABEL_GLASS,
    LABEL_NAMES,
    LABEL_OUTSIDE,
    LABEL_WALL,
    Door,
    FloorPlan,
    PlanStorey,
    Room,
    SceneMesh,
    Window,
    build_scene_mesh,
    build_truth,
    plan_geometry,
    preset,
    preset_plans,
    scan_mesh,
    window_footprint,
)
from engine.synthetic.mesh import DOOR_LEAF_RECESS, DOOR_LEAF_THICKNESS
from engine.synthetic.scan import ScanParams, simulate_scan

H = 2.7
"""Clear height of the test plans, metres."""


def _plan(door_open=False, windows=None, doors=None):
    """Rooms A (0..4 x 0..5) and B (4.15..8 x 0..5), a 0.15 m wall between them, 0.3 m outer
    walls. A's polygon edges: 0 south, 1 east (faces B), 2 north, 3 west."""
    rooms = (Room("A", [(0, 0), (4, 0), (4, 5), (0, 5)], furnished=False),
             Room("B", [(4.15, 0), (8, 0), (8, 5), (4.15, 5)], furnished=False))
    if windows is None:
        windows = (Window("A", 0.5, 1.2, 1.4, 0.9, edge=3), Window("A", 0.5, 1.5, 1.4, 0.9, edge=2),
                   Window("B", 0.5, 1.0, 1.2, 1.0, edge=1))
    if doors is None:
        doors = (Door(("A", "B"), 0.5, 0.9, 2.1, open=door_open), Door(("B",), 0.5, 1.0, 2.1, edge=0))
    return FloorPlan("openings", (PlanStorey(0.0, H),), rooms, doors, windows=windows,
                     interior_thickness=0.15, exterior_thickness=0.3).validated()


def _scene(mesh: SceneMesh, keep=None):
    import open3d as o3d

    tris = mesh.triangles if keep is None else mesh.triangles[keep]
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)), o3d.core.Tensor(tris.astype(np.uint32)))
    ids = np.arange(len(mesh.triangles)) if keep is None else np.flatnonzero(keep)
    return scene, o3d, ids


def _cast(scene_ids, origins, targets):
    """Hit distance and hit triangle index (-1: none) of rays from origins towards targets."""
    scene, o3d, ids = scene_ids
    o = np.asarray(origins, float).reshape(-1, 3)
    d = np.asarray(targets, float).reshape(-1, 3) - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ans = scene.cast_rays(o3d.core.Tensor(np.hstack([o, d]).astype(np.float32)))
    t = ans["t_hit"].numpy().astype(float)
    p = ans["primitive_ids"].numpy().astype(np.int64)
    return t, np.where(np.isfinite(t), ids[np.minimum(p, len(ids) - 1)], -1)


def _tri_areas(mesh):
    v = mesh.vertices[mesh.triangles]
    return np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1) / 2


# ----------------------------------------------------------------------------- mesh
def test_window_is_a_hole_with_reveals_and_a_pane():
    plan = _plan()
    g = plan_geometry(plan)
    mesh = build_scene_mesh(plan, g, surroundings=False)
    opaque = _scene(mesh, mesh.labels != LABEL_GLASS)
    full = _scene(mesh)
    o = (2.0, 2.5, 1.6)  # in A, facing its west window (x = 0, y 1.9..3.1, z 0.9..2.3)
    t, _ = _cast(opaque, [o], [(-1, 2.5, 1.6)])
    assert math.isinf(t[0])  # through the hole: nothing behind it (no surroundings)
    # below the sill, beside the jamb, above the head: the wall face 2 m away
    horiz = _cast(opaque, [(2, 2.5, 0.5), (2, 3.3, 1.6), (2, 2.5, 2.5)], [(-1, 2.5, 0.5), (-1, 3.3, 1.6), (-1, 2.5, 2.5)])
    assert horiz[0] == pytest.approx([2.0, 2.0, 2.0], abs=1e-5)
    assert np.all(mesh.labels[horiz[1]] == LABEL_WALL)
    # the pane is in the middle of the 0.3 m wall
    tg, ig = _cast(full, [o], [(-1, 2.5, 1.6)])
    assert tg[0] == pytest.approx(2.15, abs=1e-5) and mesh.labels[ig[0]] == LABEL_GLASS
    # reveals from inside the hole: jambs 0.6 m to either side, sill 0.7 m down, head 0.7 m up
    p = (-0.07, 2.5, 1.6)
    tr, ir = _cast(opaque, [p] * 4, [(-0.07, 4, 1.6), (-0.07, 1, 1.6), (-0.07, 2.5, 0), (-0.07, 2.5, 3)])
    assert tr == pytest.approx([0.6, 0.6, 0.7, 0.7], abs=1e-5)
    host = g.windows[0][2]
    assert g.walls[host].exterior and np.all(mesh.wall_index[ir] == host) and np.all(mesh.labels[ir] == LABEL_WALL)
    # areas: A's west face is 5 x 2.7 m minus the 1.2 x 1.4 m hole; the pane fills the hole
    a = _tri_areas(mesh)
    west = np.all(np.abs(mesh.vertices[mesh.triangles][:, :, 0]) < 1e-9, axis=1)
    face = west & (mesh.room_index == 0) & (mesh.labels == LABEL_WALL)
    assert a[face].sum() == pytest.approx(5 * H - 1.2 * 1.4, abs=1e-6)
    glass = mesh.labels == LABEL_GLASS
    assert a[glass].sum() == pytest.approx(1.2 * 1.4 + 1.5 * 1.4 + 1.0 * 1.2, abs=1e-6)
    reveals = (mesh.room_index == -1) & (mesh.wall_index == host) & (mesh.labels == LABEL_WALL)
    assert a[reveals].sum() == pytest.approx(2 * 0.3 * 1.4 + 2 * 0.3 * 1.2, abs=1e-6)


def test_closed_door_leaf_is_recessed_and_open_door_is_clear():
    plan = _plan(door_open=False)
    mesh = build_scene_mesh(plan, surroundings=False)
    sc = _scene(mesh)
    # A's face at x = 4, B's at x = 4.15: the leaf's faces 3 cm and 7 cm behind A's face
    t, i = _cast(sc, [(2, 2.5, 1.0), (6, 2.5, 1.0), (2, 2.5, 2.3)], [(5, 2.5, 1.0), (3, 2.5, 1.0), (5, 2.5, 2.3)])
    assert t[:2] == pytest.approx([2.0 + DOOR_LEAF_RECESS, 1.85 + 0.15 - DOOR_LEAF_RECESS - DOOR_LEAF_THICKNESS],
                                  abs=1e-5)
    assert list(mesh.labels[i]) == [LABEL_DOOR, LABEL_DOOR, LABEL_WALL]  # above the door: the wall face
    assert t[2] == pytest.approx(2.0, abs=1e-5)
    open_mesh = build_scene_mesh(_plan(door_open=True), surroundings=False)
    t, i = _cast(_scene(open_mesh), [(2, 2.5, 1.0)], [(5, 2.5, 1.0)])
    assert t[0] == pytest.approx(6.0, abs=1e-5) and open_mesh.room_index[i[0]] == 1  # B's far wall
    assert not np.any(open_mesh.labels == LABEL_DOOR)
    # simulated points on the leaf, seen from both rooms: behind both wall faces
    params = ScanParams(target_points=60_000, sigma=0.002, surroundings=False)
    res = simulate_scan(plan, params, positions=[(2, 2.5, 1.5), (6, 2.5, 1.5)], rng=3)
    c = res.cloud
    leaf = c.fields["label"] == LABEL_DOOR
    x = c.xyz[leaf, 0]
    from_a = c.scan_index[leaf] == 0
    assert from_a.sum() > 200 and (~from_a).sum() > 200
    assert np.median(x[from_a]) == pytest.approx(4.0 + DOOR_LEAF_RECESS, abs=0.002)
    assert np.median(x[~from_a]) == pytest.approx(4.0 + DOOR_LEAF_RECESS + DOOR_LEAF_THICKNESS, abs=0.002)
    assert np.all((x > 4.0 + 0.015) & (x < 4.15 - 0.015))  # flush with neither face
    # nothing of B is seen from A through the closed door (B's east window leads outside only)
    xy = c.xyz[c.scan_index == 0]
    assert np.sum(xy[:, 0] > 4.2) == 0


# ----------------------------------------------------------------------------- glazing
def test_glazing_returns_a_small_share_of_its_rays():
    """A 2 m x 2 m pane 2 m in front of the scanner and a wall 5 m away: 7 % of the rays that
    reach the pane return there, the others go on to the wall."""
    v = np.array([[2, -1, -1], [2, 1, -1], [2, 1, 1], [2, -1, 1],
                  [5, -10, -10], [5, 10, -10], [5, 10, 10], [5, -10, 10]], float)
    tris = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]], np.int32)
    mesh = SceneMesh(v, tris, np.array([LABEL_GLASS, LABEL_GLASS, LABEL_WALL, LABEL_WALL], np.int32),
                     np.full(4, -1, np.int32), np.full(4, -1, np.int32))
    params = ScanParams(angular_step=math.radians(0.25), sigma=0.001, min_elevation=math.radians(-60),
                        max_elevation=math.radians(60))
    for share in (0.07, 0.5):
        res = scan_mesh(mesh, np.zeros((1, 3)), replace(params, glass_return=share), rng=1)
        c = res.cloud
        glass = c.fields["label"] == LABEL_GLASS
        p = c.xyz
        behind = (~glass) & (np.abs(p[:, 1] * 2 / p[:, 0]) < 1) & (np.abs(p[:, 2] * 2 / p[:, 0]) < 1)
        n = glass.sum() + behind.sum()
        assert n > 20_000
        assert glass.sum() / n == pytest.approx(share, abs=0.01)  # binomial σ <= 0.0035
        assert np.all(np.abs(p[glass, 0] - 2.0) < 0.006)
    again = scan_mesh(mesh, np.zeros((1, 3)), params, rng=1)
    assert np.array_equal(again.cloud.xyz, scan_mesh(mesh, np.zeros((1, 3)), params, rng=1).cloud.xyz)
    # a reflectance tuple of the four old labels is completed from the defaults
    short = scan_mesh(mesh, np.zeros((1, 3)), ScanParams(angular_step=math.radians(1.0),
                                                        reflectance=(0.6, 0.35, 0.8, 0.45)), rng=1)
    assert np.all(short.cloud.intensity[short.cloud.fields["label"] == LABEL_GLASS] <= 0.1 + 1e-6)


# ----------------------------------------------------------------------------- outside
@pytest.fixture(scope="module")
def office():
    return preset("office_mw", seed=1, target_points=120_000)


def test_points_beyond_the_exterior_wall_come_through_openings(office):
    c, truth, plan = office.cloud, office.truth, office.plan
    lab = c.fields["label"]
    outline = Polygon([x for x in truth.slabs if x.attributes["kind"] == "floor"][0].footprint())
    out = lab == LABEL_OUTSIDE
    assert out.sum() > 500
    p = c.xyz[out]
    assert not np.any(shapely.contains_xy(outline.buffer(-0.01), p[:, 0], p[:, 1]))
    far = outline.exterior.distance(shapely.points(p[:, :2]))
    assert np.quantile(far, 0.9) > 5.0  # ground rings, trees, the neighbour's facade
    # each ray to an outside point leaves the building through a window or an exterior door
    g = plan_geometry(plan)
    holes = unary_union([fp for _, fp, _ in g.windows] + [fp for d, fp, _ in g.doors if d.exterior]).buffer(0.03)
    o = c.scanner_positions[c.scan_index[out]]
    rays = shapely.linestrings(np.stack([o[:, :2], p[:, :2]], axis=1))
    cross = shapely.intersection(rays, outline.exterior)
    assert np.all(shapely.within(cross, holes))
    # no point inside solid wall (walls minus their openings)
    solid = unary_union([w.polygon for w in g.walls]).difference(
        unary_union([fp for _, fp, _ in g.windows] + [fp for _, fp, _ in g.doors])).buffer(-0.03)  # 6 σ
    assert not np.any(shapely.contains_xy(solid, c.xyz[:, 0], c.xyz[:, 1]))
    # glass points sit on the panes, in the middle of the 0.3 m outer walls
    glass = c.xyz[lab == LABEL_GLASS]
    assert len(glass) > 50
    mids = [np.asarray(fp.exterior.coords)[:4] for _, fp, _ in g.windows]
    panes = unary_union([shapely.LineString([(q[0] + q[3]) / 2, (q[1] + q[2]) / 2]) for q in mids])
    assert np.quantile(panes.distance(shapely.points(glass[:, :2])), 0.99) < 0.02
    # without surroundings: nothing outside, nothing beyond the outline
    bare = simulate_scan(plan, ScanParams(target_points=60_000, surroundings=False), rng=2).cloud
    assert not np.any(bare.fields["label"] == LABEL_OUTSIDE)
    assert np.all(shapely.contains_xy(outline.buffer(0.03), bare.xyz[:, 0], bare.xyz[:, 1]))
    quiet = preset("office_mw", seed=1, target_points=30_000, surroundings=False)
    assert quiet.scan_params.surroundings is False and not np.any(quiet.cloud.fields["label"] == LABEL_OUTSIDE)


def test_outer_faces_of_a_concave_building_stop_rays():
    """L-shaped building: from A, rays through A's north window reach the east face of wing
    B; they stop there instead of entering B's wall."""
    rooms = (Room("A", [(0, 0), (6, 0), (6, 4), (0, 4)], furnished=False),
             Room("B", [(0, 4.15), (3, 4.15), (3, 10), (0, 10)], furnished=False))
    plan = FloorPlan("L", (PlanStorey(0.0, H),), rooms, (),
                     windows=(Window("A", 0.5, 1.2, 1.4, 0.9, edge=2),)).validated()
    fp = window_footprint(plan, plan.windows[0])[0]
    assert fp.bounds == pytest.approx((3.9, 4.0, 5.1, 4.3), abs=1e-9)
    res = simulate_scan(plan, ScanParams(angular_step=math.radians(0.3)), positions=[(4.5, 1.5, 1.5)], rng=0)
    c = res.cloud
    facade = (c.fields["label"] == LABEL_WALL) & (res.room_index == -1) & (c.xyz[:, 1] > 4.5)
    assert facade.sum() > 100
    assert np.abs(c.xyz[facade, 0] - 3.3).max() < 0.03
    # nothing inside wing B or its walls (below its roof, which rays may pass over)
    x, y, z = c.xyz.T
    assert not np.any((x > -0.3) & (x < 3.27) & (y > 4.4) & (y < 10.3) & (z < H))


def test_roof_of_a_lower_wing_stops_rays():
    """Storey 1 covers half of storey 0; from its east window rays fall on the lower roof."""
    rooms = (Room("A", [(0, 0), (6, 0), (6, 4), (0, 4)], furnished=False),
             Room("C", [(0, 0), (3, 0), (3, 4), (0, 4)], storey=1, furnished=False))
    plan = FloorPlan("steps", (PlanStorey(0.0, H), PlanStorey(H + 0.3, H)), rooms, (),
                     windows=(Window("C", 0.5, 1.5, 1.4, 0.9, edge=1),), slab_thickness=0.3).validated()
    res = simulate_scan(plan, ScanParams(angular_step=math.radians(0.3)), positions=[(1.5, 2.0, H + 0.3 + 1.5)],
                        rng=0)
    x, y, z = res.cloud.xyz.T
    lab = res.cloud.fields["label"]
    roof = (lab == LABEL_OUTSIDE) & (x > 3.35) & (x < 6.25) & (y > 0) & (y < 4)
    assert roof.sum() > 100
    assert np.abs(z[roof] - (H + 0.3)).max() < 0.03
    assert not np.any((x > -0.3) & (x < 6.3) & (y > -0.3) & (y < 4.3) & (z < H + 0.3 - 0.03))  # nothing in A


# ----------------------------------------------------------------------------- truth
def test_truth_has_windows_and_exterior_doors():
    plan = _plan()
    m = build_truth(plan)
    ids = {s.name: s.id for s in m.spaces}
    assert [s.id for s in m.of_type(ShapeType.EXTERIOR)] == ["exterior_s0"]
    assert [w.id for w in m.windows] == ["window_0", "window_1", "window_2"]
    for w, spec in zip(m.windows, plan.windows):
        wall = m[w.parent]
        a = w.attributes
        assert wall.attributes["external"] is True and w.id in wall.children
        assert Polygon(w.footprint()).difference(Polygon(wall.footprint())).area < 1e-9
        assert (a["width"], a["height"], a["sill"], a["kind"]) == (spec.width, spec.height, spec.sill, "window")
        assert a["spaces"] == [ids[spec.room], "exterior_s0"]
        assert w.bounds[:, 2] == pytest.approx([spec.sill, spec.sill + spec.height])
        sides = np.sort(np.linalg.norm(np.diff(w.footprint(), axis=0, append=w.footprint()[:1]), axis=1))
        assert sides == pytest.approx([0.3, 0.3, spec.width, spec.width])
    inner, outer = m.doors
    assert inner.attributes["kind"] == outer.attributes["kind"] == "door"
    assert inner.attributes["spaces"] == [ids["A"], ids["B"]] and inner.attributes["open"] is False
    assert m[inner.parent].attributes["external"] is False
    assert outer.attributes["spaces"] == [ids["B"], "exterior_s0"] and m[outer.parent].attributes["external"]
    assert Polygon(outer.footprint()).centroid.coords[0] == pytest.approx((6.075, -0.15), abs=1e-9)
    conn = {(frozenset((r.a, r.b)), r.via) for r in m.relations_of("connectivity")}
    assert conn == {(frozenset((ids["A"], ids["B"])), inner.id), (frozenset((ids["B"], "exterior_s0")), outer.id)}
    # every outer wall joins its room to the exterior
    for w in m.walls:
        outside = [r for r in m.relations_of("adjacency") if r.via == w.id and "exterior_s0" in (r.a, r.b)]
        assert bool(outside) == w.attributes["external"]


@pytest.mark.parametrize("name, n_windows", [("office_mw", 15), ("two_storey_office", 22), ("syn_house", 9),
                                             ("house_multi_height", 8)])
def test_presets_have_windows_and_an_entrance(name, n_windows):
    plan = preset_plans(name)["truth"]
    m = build_truth(plan)
    assert len(m.windows) == n_windows
    outer = [d for d in m.doors if d.attributes["spaces"][1].startswith("exterior_s")]
    assert len(outer) == 1 and outer[0].storey == 0
    for w in m.windows:
        wall = m[w.parent]
        assert wall.attributes["external"] and Polygon(w.footprint()).within(Polygon(wall.footprint()).buffer(1e-9))
        assert 0.8 <= w.attributes["width"] <= 2.0 and 0.8 <= w.attributes["sill"] <= 1.0
        assert 1.2 <= w.attributes["height"] <= 1.5
    rooms_with_outer_wall = {r for w in m.walls if w.attributes["external"] for r in w.attributes["rooms"]}
    lit = {w.attributes["room"] for w in m.windows}
    assert lit <= rooms_with_outer_wall and len(lit) >= len(rooms_with_outer_wall) - 2  # corridors may stay dark
    if name == "office_mw":
        assert [d.attributes["rooms"] for d in m.doors if not d.attributes["open"]] == [["Room 1", "Room 2"]]
    mesh = build_scene_mesh(plan)
    assert np.isin([LABEL_GLASS, LABEL_OUTSIDE], mesh.labels).all()
    assert LABEL_NAMES[LABEL_OUTSIDE] == "outside" and LABEL_NAMES[LABEL_CLUTTER] == "clutter"


# ----------------------------------------------------------------------------- plan
def test_plan_json_round_trip_with_windows(tmp_path):
    plan = _plan(windows=(Window("A", 0.5, 1.2, 1.4, 0.9, edge=3), Window("B", 0.8, 1.5, 1.3, 0.8)))
    path = tmp_path / "plan.json"
    plan.to_json(path)
    back = FloorPlan.from_json(path)
    assert back == plan
    assert back.to_json() == plan.to_json()
    assert build_truth(back).to_json() == build_truth(plan).to_json()
    d = plan.to_dict()
    assert d["windows"][1] == {"room": "B", "position": 0.8, "width": 1.5, "height": 1.3, "sill": 0.8}
    assert d["doors"][1] == {"rooms": ["B"], "position": 0.5, "width": 1.0, "height": 2.1, "open": True,
                             "exterior": True, "edge": 0}


def test_window_placed_along_the_exterior_boundary():
    # A's exterior stretches in polygon order: south 4 m, north 4 m (from x = 4), west 5 m
    for pos, centre in ((0.0, (0.65, -0.15)), (0.5, (1.5, 5.15)), (1.0, (-0.15, 0.65))):
        fp = window_footprint(_plan(), Window("A", pos, 1.2))[0]
        assert fp.centroid.coords[0] == pytest.approx(centre, abs=1e-9), pos


@pytest.mark.parametrize("change, match", [
    (dict(windows=(Window("C", 0.5),)), "unknown room"),
    (dict(windows=(Window("A", 0.5, 1.2, 1.9, 0.9),)), "reaches the ceiling"),
    (dict(windows=(Window("A", 0.5, 1.2, 1.4, 0.9, edge=7),)), "not an edge index"),
    (dict(windows=(Window("A", 0.5, -1.0),)), "must be positive"),
    (dict(doors=(Door(("A", "B"), 0.5, edge=1),)), "only an exterior door"),
    (dict(doors=(Door(("A", "B", "C")),)), "must join two rooms"),
])
def test_bad_openings_are_rejected(change, match):
    base = _plan()
    with pytest.raises(InputError, match=match):
        base.with_(**change).validated()


def test_openings_that_do_not_fit_are_rejected():
    with pytest.raises(InputError, match="no exterior wall stretch"):
        plan_geometry(_plan(windows=(Window("A", 0.5, 1.2, edge=1),)))  # A's east edge faces B
    with pytest.raises(InputError, match="no exterior wall stretch"):
        plan_geometry(_plan(windows=(Window("A", 0.5, 4.5, edge=2),)))  # wider than the wall
    with pytest.raises(InputError, match="overlap"):
        plan_geometry(_plan(windows=(Window("A", 0.5, 1.2, edge=3), Window("A", 0.55, 1.2, edge=3))))
    two = _plan(windows=(Window("A", 0.5, 1.2, 1.0, 0.2, edge=3), Window("A", 0.5, 1.2, 0.8, 1.5, edge=3)))
    assert len(plan_geometry(two).windows) == 2  # one above the other
    with pytest.raises(InputError, match="exterior"):
        FloorPlan.from_dict({**_plan().to_dict(), "doors": [{"rooms": ["A", "B"], "exterior": True}]})
