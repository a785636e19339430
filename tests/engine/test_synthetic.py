"""Synthetic buildings: the truth is consistent, the scans lie on it, clutter occludes,
seeds reproduce, the presets have what they promise, the CLI writes its files."""
import argparse
from dataclasses import replace
import itertools
import json
import math
import os

import numpy as np
import pytest
from shapely.geometry import Polygon
from shapely.ops import unary_union

from engine.errors import Cancelled, InputError
from engine.model import BuildingModel, ShapeType
from engine.synthetic import (
    LABEL_CEILING,
    LABEL_CLUTTER,
    LABEL_DOOR,
    LABEL_FLOOR,
    LABEL_GLASS,
    LABEL_OUTSIDE,
    LABEL_WALL,
    PRESETS,
    Door,
    FloorPlan,
    PlanStorey,
    Room,
    build_scene_mesh,
    build_truth,
    plan_geometry,
    preset,
    preset_plans,
)
from engine.synthetic.scan import ScanParams, scanner_positions, simulate_scan
from engine.topology import space_graph

SMALL = 120_000


@pytest.fixture(scope="module")
def office():
    return preset("office_mw", seed=1, target_points=SMALL)


def _fp(shape):
    return Polygon(shape.footprint())


def _interior_mesh_scene(model):
    """Ray-casting scene of the true model's interior-space prisms (independent of the simulator)."""
    import open3d as o3d

    vs, ts, off = [], [], 0
    for s in model.spaces:
        v, t = s.geometry.triangles()
        vs.append(v)
        ts.append(t + off)
        off += len(v)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.vstack(vs).astype(np.float32)),
                        o3d.core.Tensor(np.vstack(ts).astype(np.uint32)))
    return scene, o3d


# ----------------------------------------------------------------------------- truth
@pytest.mark.parametrize("name", PRESETS)
def test_truth_is_consistent(name):
    for key, plan in preset_plans(name).items():
        m = build_truth(plan)
        assert len(m.storeys) == len(plan.storeys)
        for s in range(len(m.storeys)):
            spaces = [x for x in m.spaces if x.storey == s]
            walls = [x for x in m.walls if x.storey == s]
            assert spaces and walls
            # spaces and walls never overlap, and together they fill the building outline
            parts = [_fp(x) for x in spaces + walls]
            for a, b in itertools.combinations(parts, 2):
                assert a.intersection(b).area < 1e-6
            outline = [x for x in m.of_type(ShapeType.SLAB) if x.storey == s and x.attributes["kind"] == "floor"][0]
            assert abs(sum(p.area for p in parts) - _fp(outline).area) < 1e-4
            for w in walls:
                assert 0.1 <= w.attributes["thickness"] <= 0.31
                assert w.bounds[0, 2] == pytest.approx(m.storeys[s].floor_z)
        # every wall separates what it should: its rooms touch it along a real stretch
        for r in m.relations_of("adjacency"):
            wall = _fp(m[r.via])
            for sid in (r.a, r.b):
                assert wall.buffer(1e-3).intersection(_fp(m[sid]).boundary).length > 0.05, (name, key, r)
        # (an exterior door joins its room to the storey's exterior, which its wall bounds too)
        room_pairs = {frozenset((r.a, r.b)) for r in m.relations_of("adjacency")
                      if m[r.a].is_space and m[r.b].is_space}
        # doors lie inside a wall the two rooms they join both touch
        for d in m.doors:
            wall = m[d.parent]
            assert d.id in wall.children
            assert _fp(d).difference(_fp(wall)).area < 1e-6
            conn = [r for r in m.relations_of("connectivity") if r.via == d.id]
            assert len(conn) == 1
            assert frozenset((conn[0].a, conn[0].b)) in room_pairs
            assert frozenset(d.attributes["spaces"]) == frozenset((conn[0].a, conn[0].b))
            assert d.attributes["width"] == pytest.approx(
                np.sort(np.linalg.norm(np.diff(d.footprint(), axis=0, append=d.footprint()[:1]), axis=1))[-1])
        # the scanned surfaces: every wall face lies on a wall piece, every interior wall
        # piece shows faces to both of its rooms
        g = plan_geometry(plan)
        mesh = build_scene_mesh(plan, g)
        wall_tris = mesh.labels == LABEL_WALL
        assert np.all(mesh.wall_index[wall_tris] >= 0)
        tri = mesh.vertices[mesh.triangles]
        tri_area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1) / 2
        for k, w in enumerate(g.walls):
            on = mesh.wall_index == k
            rooms_seen = {plan.rooms[i].name for i in np.unique(mesh.room_index[on]) if i >= 0}
            assert rooms_seen >= set(w.rooms), (name, key, k, w.rooms, rooms_seen)
            for extra in rooms_seen - set(w.rooms):  # only the end of a wall at a junction
                i = plan.room_index(extra)
                length = tri_area[on & (mesh.room_index == i)].sum() / (plan.ceiling_z(plan.rooms[i]) -
                                                                         plan.floor_z(plan.rooms[i]))
                assert length < plan.exterior_thickness + 1e-6, (name, key, k, extra, length)
        # every room can be reached from every other room of its storey (doors or not)
        for s in range(len(m.storeys)):
            g = space_graph(m, "connectivity").subgraph([x.id for x in m.spaces if x.storey == s])
            import networkx as nx

            assert nx.is_connected(g), (name, key)


def test_walls_separate_the_office_rooms():
    m = build_truth(preset_plans("office_mw")["truth"])
    names = {s.id: s.name for s in m.spaces}
    pairs = {frozenset((names[r.a], names[r.b])) for r in m.relations_of("adjacency")
             if r.a in names and r.b in names}
    expected = {frozenset(("Corridor", f"Room {k}")) for k in range(1, 8)}
    expected |= {frozenset((f"Room {a}", f"Room {a + 1}")) for a in (1, 2, 3, 5, 6)}
    assert pairs == expected
    assert len([d for d in m.doors if len(d.attributes["rooms"]) == 2]) == 8
    assert len([d for d in m.doors if len(d.attributes["rooms"]) == 1]) == 1  # the entrance
    ext = [w for w in m.walls if w.attributes["exterior"]]
    assert all(w.attributes["external"] == w.attributes["exterior"] for w in m.walls)
    assert all(w.attributes["thickness"] == pytest.approx(0.3) for w in ext)
    inner = [w for w in m.walls if not w.attributes["exterior"]]
    assert all(w.attributes["thickness"] == pytest.approx(0.15) for w in inner)
    # one Shape per straight piece: every wall footprint is a rectangle here
    for w in m.walls:
        assert len(w.footprint()) == 4
    m2 = type(m).from_json(m.to_json())
    assert m2.summary() == m.summary()


def test_non_manhattan_presets_have_angled_walls():
    for name in ("syn_house", "hexagon_hall"):
        m = build_truth(preset_plans(name)["truth"])
        angles = set()
        for w in m.walls:
            fp = w.footprint()
            e = np.diff(np.vstack([fp, fp[:1]]), axis=0)
            a = np.degrees(np.arctan2(e[:, 1], e[:, 0])) % 90
            angles |= {round(float(x), 1) for x in a if 0.5 < x < 89.5}
        assert len(angles) >= 2, name


def test_bad_plans_are_rejected():
    st = (PlanStorey(0.0, 2.5),)
    overlap = FloorPlan("bad", st, (Room("A", [(0, 0), (4, 0), (4, 4), (0, 4)]),
                                    Room("B", [(3, 0), (7, 0), (7, 4), (3, 4)])))
    with pytest.raises(InputError, match="overlap"):
        plan_geometry(overlap)
    far = FloorPlan("bad", st, (Room("A", [(0, 0), (4, 0), (4, 4), (0, 4)]),
                                Room("B", [(4.15, 0), (8, 0), (8, 4), (4.15, 4)])),
                    doors=(Door(("A", "B"), 0.5, width=5.0),))
    with pytest.raises(InputError, match="wide enough"):
        plan_geometry(far)
    with pytest.raises(InputError, match="unknown synthetic preset"):
        preset("no_such_building")
    with pytest.raises(InputError, match="noise"):
        preset("office_mw", noise="loud")


# ----------------------------------------------------------------------------- scans
@pytest.mark.parametrize("case", ["office_mw/tls", "syn_house/mobile", "hexagon_hall/0.01"])
def test_points_lie_on_true_surfaces(case, office):
    name, noise = case.split("/")
    sc = office if case == "office_mw/tls" else preset(name, seed=2, noise=noise, target_points=100_000)
    c, m = sc.cloud, sc.truth
    sigma = sc.noise_sigma
    assert sigma == {"tls": 0.005, "mobile": 0.02}.get(noise, 0.01)
    lab = c.fields["label"]
    assert c.fields["label"].dtype == np.int32
    expected = {LABEL_WALL, LABEL_FLOOR, LABEL_CEILING, LABEL_CLUTTER}
    expected |= {LABEL_OUTSIDE, LABEL_GLASS} if sc.plan.windows else set()  # through windows, on glazing
    expected |= {LABEL_DOOR} if not all(d.open for d in sc.plan.doors) else set()  # closed door leaves
    assert set(np.unique(lab)) == expected
    # range residual along each ray against the *truth model* (not the simulator's mesh):
    # points of walls/floors/ceilings in the room of their own scanner
    scene, o3d = _interior_mesh_scene(m)
    rooms = [(s, _fp(s)) for s in m.spaces]
    import shapely

    pos = c.scanner_positions
    own = np.zeros(len(c), bool)
    for s, fp in rooms:
        in_room = shapely.contains_xy(fp.buffer(-0.05), c.xyz[:, 0], c.xyz[:, 1])
        scan_in = shapely.contains_xy(fp, pos[:, 0], pos[:, 1])
        own |= in_room & scan_in[c.scan_index]
    sel = np.flatnonzero(own & (lab != LABEL_CLUTTER))
    assert len(sel) > 0.3 * len(c)
    o = pos[c.scan_index[sel]]
    v = c.xyz[sel] - o
    r = np.linalg.norm(v, axis=1)
    rays = np.hstack([o, v / r[:, None]]).astype(np.float32)
    t = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(np.float64)
    resid = r - t
    med = float(np.median(np.abs(resid)))
    assert med == pytest.approx(0.6745 * sigma, rel=0.08)
    assert abs(float(np.mean(resid))) < 0.1 * sigma
    # perpendicular distance to the nearest true surface: at most the range noise
    q = o3d.core.Tensor(c.xyz[sel].astype(np.float32))
    d = scene.compute_distance(q).numpy()
    assert 0.3 * sigma < float(np.median(d)) <= 0.6745 * sigma * 1.05
    assert float(np.quantile(d, 0.999)) < 5 * sigma
    # intensity: reflectance x cos(incidence), so floor points right below the scanner are bright
    assert c.intensity is not None and 0 <= c.intensity.min() and c.intensity.max() <= 1
    # labels agree with the orientation of the true surface the point is on
    tri = scene.compute_closest_points(q)["primitive_normals"].numpy()
    vertical = np.abs(tri[:, 2]) < 0.2
    assert np.mean(vertical == (lab[sel] == LABEL_WALL)) > 0.999
    fl = lab[sel] == LABEL_FLOOR
    assert np.all(np.abs(c.xyz[sel][fl, 2]) < 6 * sigma)


@pytest.mark.parametrize("name", ["office_mw", "syn_house", "hexagon_hall", "change_demo"])
def test_scanners_stand_in_free_floor(name):
    import shapely

    plan = preset(name, seed=4, target_points=1000).plan
    rooms = unary_union([r.shape.buffer(-0.1) for r in plan.rooms])
    furniture = unary_union([c.footprint() for c in plan.clutter])
    for mode in ("tls", "mobile"):
        pos = scanner_positions(plan, ScanParams(mode=mode))
        assert len(pos) > 0
        assert not np.any(shapely.contains_xy(furniture, pos[:, 0], pos[:, 1]))
        if mode == "tls":
            assert np.all(shapely.contains_xy(rooms, pos[:, 0], pos[:, 1]))
            scanned = [r for r in plan.rooms if r.scanned]
            for r in scanned:
                assert shapely.contains_xy(r.shape, pos[:, 0], pos[:, 1]).sum() >= 1, r.name
        assert np.allclose(pos[:, 2] - 1.5, [plan.storeys[0].floor_z] * len(pos)) or name == "two_storey_office"


def test_mobile_noise_and_path(office):
    mob = preset("office_mw", seed=1, noise="mobile", target_points=SMALL)
    assert mob.noise_sigma == 0.02
    sp = mob.cloud.scanner_positions
    assert len(sp) > 5 * len(office.cloud.scanner_positions)
    step = np.linalg.norm(np.diff(sp[:, :2], axis=0), axis=1)
    assert np.median(step) == pytest.approx(0.5, abs=0.05)
    # the walk visits every room, moving from room to room through doors only
    import shapely

    rooms = unary_union([_fp(s) for s in mob.truth.spaces])
    doors = unary_union([_fp(d) for d in mob.truth.doors]).buffer(0.06)
    for s in mob.truth.spaces:
        assert shapely.contains_xy(_fp(s), sp[:, 0], sp[:, 1]).sum() >= 3, s.name
    mids = (sp[1:, :2] + sp[:-1, :2]) / 2
    assert np.all(shapely.contains_xy(rooms.union(doors), mids[:, 0], mids[:, 1]))
    crossings = sum(bool(shapely.contains_xy(d.buffer(0.3), sp[:, 0], sp[:, 1]).any()) for d in
                    [_fp(x) for x in mob.truth.doors])
    assert crossings >= len(mob.truth.spaces) - 1
    scene, o3d = _interior_mesh_scene(mob.truth)
    c = mob.cloud
    floor = (c.fields["label"] == LABEL_FLOOR) & (np.abs(c.xyz[:, 2]) < 0.2)
    z = c.xyz[floor, 2]
    # floor points: |z| is the noise times the cosine of the incidence angle
    assert 0.25 * 0.02 < float(np.median(np.abs(z))) < 0.6745 * 0.02 * 1.05
    assert len(c) == pytest.approx(SMALL, rel=0.15)


def test_point_count_follows_target_and_density_falls_with_range(office):
    assert len(office.cloud) == pytest.approx(SMALL, rel=0.1)
    c = office.cloud
    k = 0
    sel = c.scan_index == k
    rng_ = np.linalg.norm(c.xyz[sel] - c.scanner_positions[k], axis=1)
    floor = c.fields["label"][sel] == LABEL_FLOOR
    rr = np.hypot(*(c.xyz[sel][floor, :2] - c.scanner_positions[k, :2]).T)
    # floor points per m² between 1.0-1.5 m and 3.0-3.5 m from the scanner
    near = np.sum((rr > 1.0) & (rr < 1.5)) / (math.pi * (1.5 ** 2 - 1.0 ** 2))
    far = np.sum((rr > 3.0) & (rr < 3.5)) / (math.pi * (3.5 ** 2 - 3.0 ** 2))
    assert near > 4 * far
    assert rng_.max() <= 30.0


def test_same_seed_same_scan():
    a = preset("house_multi_height", seed=7, target_points=40_000)
    b = preset("house_multi_height", seed=7, target_points=40_000)
    c = preset("house_multi_height", seed=8, target_points=40_000)
    assert np.array_equal(a.cloud.xyz, b.cloud.xyz)
    assert np.array_equal(a.cloud.fields["label"], b.cloud.fields["label"])
    assert a.truth.to_json() == b.truth.to_json()
    assert len(a.plan.clutter) > 0 and a.plan.clutter == b.plan.clutter
    assert a.plan.clutter != c.plan.clutter
    assert not (len(a.cloud) == len(c.cloud) and np.allclose(a.cloud.xyz, c.cloud.xyz))


def test_clutter_hides_wall_area():
    plan = preset("office_mw", seed=3, target_points=1000).plan
    shelves = [k for k in plan.clutter if k.kind == "shelf"]
    assert len(shelves) >= 5
    params = ScanParams(target_points=150_000)
    pos = scanner_positions(plan, params)
    full = simulate_scan(plan, params, positions=pos, rng=5).cloud
    empty = simulate_scan(plan, params, positions=pos, rng=5, clutter=False).cloud

    def behind(cloud):
        wall = cloud.fields["label"] == LABEL_WALL
        n = 0
        import shapely

        for s in shelves:
            # the shelf's footprint, 10 cm shorter at each end, reaching 4 cm behind its back
            zone = replace(s, size=(s.size[0] - 0.2, s.size[1] + 0.08, s.size[2])).footprint()
            inside = shapely.contains_xy(zone, cloud.xyz[:, 0], cloud.xyz[:, 1])
            n += int(np.sum(wall & inside & (cloud.xyz[:, 2] < s.size[2] - 0.05)))
        return n

    hidden_full, hidden_empty = behind(full), behind(empty)
    assert hidden_empty > 500
    assert hidden_full < 0.02 * hidden_empty
    assert np.sum(full.fields["label"] == LABEL_WALL) < np.sum(empty.fields["label"] == LABEL_WALL)
    assert np.sum(empty.fields["label"] == LABEL_CLUTTER) == 0


def test_unscanned_room_has_no_points():
    sc = preset("unscanned_room", seed=2, target_points=80_000)
    import shapely

    for s in sc.truth.spaces:
        fp = _fp(s).buffer(-0.02)
        n = int(np.sum(shapely.contains_xy(fp, sc.cloud.xyz[:, 0], sc.cloud.xyz[:, 1])))
        if s.name == "Room 3":
            assert n == 0
            assert s.attributes["scanned"] is False
        else:
            assert n > 1000
    door3 = [d for d in sc.truth.doors if "Room 3" in d.attributes["rooms"]][0]
    assert door3.attributes["open"] is False


def test_multi_height_ceilings_and_two_storeys():
    sc = preset("house_multi_height", seed=0, target_points=60_000)
    c = sc.cloud
    import shapely

    ceil = c.fields["label"] == LABEL_CEILING
    heights = {}
    for s in sc.truth.spaces:
        inside = shapely.contains_xy(_fp(s), c.xyz[:, 0], c.xyz[:, 1])
        heights[s.name] = float(np.median(c.xyz[ceil & inside, 2]))
        assert heights[s.name] == pytest.approx(s.bounds[1, 2], abs=0.005)
    assert len({round(h, 1) for h in heights.values()}) == 4
    two = preset("two_storey_office", seed=0, target_points=80_000)
    assert [s.floor_z for s in two.truth.storeys] == [0.0, 3.1]
    fl = two.cloud.xyz[two.cloud.fields["label"] == LABEL_FLOOR, 2]
    assert np.sum(np.abs(fl) < 0.05) > 1000 and np.sum(np.abs(fl - 3.1) < 0.05) > 1000
    assert {s.storey for s in two.truth.spaces} == {0, 1}


def test_eval_demo_variants():
    sc = preset("eval_demo", seed=0, target_points=30_000)
    assert set(sc.variants) == {"inacc", "incomp", "incorr"}
    room = [s for s in sc.truth.spaces if s.name == "Room 1"][0]
    assert room.bounds[1] - room.bounds[0] == pytest.approx([6, 9, 2.5])
    inacc_room = [s for s in sc.variants["inacc"].spaces if s.name == "Room 1"][0]
    lo, hi = inacc_room.bounds
    assert lo[:2] == pytest.approx([-0.05, -0.05], abs=1e-6)
    assert hi[:2] == pytest.approx([6.0, 9.05], abs=1e-5)  # the corridor side is not an outer wall
    corr = _fp([s for s in sc.variants["inacc"].spaces if s.name == "Corridor"][0])
    assert corr.bounds == pytest.approx((6.2, -0.05, 8.05, 9.05), abs=1e-5)
    assert [s.name for s in sc.variants["incomp"].spaces] == ["Room 1"]
    assert len(sc.variants["incorr"].spaces) == 3

    # wall-face areas of the spaces give the thesis's ratios (Fig. 5.10) by design
    def walls(m):
        return [x for x in m.surfaces() if x.kind == "wall"]

    def area(m):
        return sum(x.area for x in walls(m))

    ref = walls(sc.truth)
    def covers(x, r):  # x lies in r's plane and contains it
        return (np.allclose(x.normal, r.normal, atol=1e-9) and abs(x.offset - r.offset) < 1e-6
                and np.all(x.polygon.min(axis=0) <= r.polygon.min(axis=0) + 1e-6)
                and np.all(x.polygon.max(axis=0) >= r.polygon.max(axis=0) - 1e-6))

    same = sum(r.area for r in ref if any(covers(x, r) for x in walls(sc.variants["inacc"])))
    assert same / area(sc.truth) == pytest.approx(0.35, abs=0.01)
    assert area(sc.variants["incomp"]) / area(sc.truth) == pytest.approx(0.58, abs=0.01)
    assert area(sc.truth) / area(sc.variants["incorr"]) == pytest.approx(0.72, abs=0.01)


def test_change_demo():
    sc = preset("change_demo", seed=0, target_points=100_000)
    old, new = sc.truth, sc.variants["changed"]
    removed = [w for w in old.walls if w.attributes.get("removed_in_scan")]
    assert len(removed) == 1
    assert set(removed[0].attributes["rooms"]) == {"Room 1", "Room 2"}
    added = [w for w in new.walls if w.attributes.get("new_in_scan")]
    assert len(added) == 2
    isnew = sc.cloud.fields["new"]
    assert set(np.unique(isnew)) == {0, 1}
    pts = sc.cloud.xyz[isnew == 1]
    assert len(pts) > 1000
    zone = unary_union([_fp(w) for w in added]).buffer(0.05)
    import shapely

    assert np.all(shapely.contains_xy(zone, pts[:, 0], pts[:, 1]))
    # no point of the removed wall's faces: the space there is open now
    gone = _fp(removed[0])
    mid = gone.centroid
    near = np.hypot(sc.cloud.xyz[:, 0] - mid.x, sc.cloud.xyz[:, 1] - mid.y) < 0.5
    assert np.sum(near & (sc.cloud.fields["label"] == LABEL_WALL)) == 0


# ----------------------------------------------------------------------------- CLI
def _mini_write_ply(path, cloud, *, binary=True, dtype="f8"):  # only if engine.io lacks one
    cols = [("x", cloud.xyz[:, 0]), ("y", cloud.xyz[:, 1]), ("z", cloud.xyz[:, 2])]
    cols += [(k, v) for k, v in cloud.fields.items()]
    dt = np.dtype([(k, "<f8" if v.dtype.kind == "f" else "<i4") for k, v in cols])
    arr = np.empty(len(cloud), dt)
    for k, v in cols:
        arr[k] = v
    props = "".join(f"property {'double' if dt[k].kind == 'f' else 'int'} {k}\n" for k, _ in cols)
    with open(path, "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(cloud)}\n{props}end_header\n".encode())
        f.write(arr.tobytes())


def test_cli_synth_writes_scan_truth_variants_and_png(tmp_path, monkeypatch):
    import engine.io
    from engine.cli.synth import add_synth

    if not hasattr(engine.io, "write_ply"):
        monkeypatch.setattr(engine.io, "write_ply", _mini_write_ply, raising=False)
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    add_synth(sub)
    args = parser.parse_args(["synth", "eval_demo", "-o", str(tmp_path), "--seed", "3", "--noise", "0.01",
                              "--points", "30000"])
    args.quiet, args.json = True, False
    assert args.func(args) == 0
    for f in ("eval_demo.ply", "eval_demo_truth.json", "eval_demo_inacc.json", "eval_demo_incomp.json",
              "eval_demo_incorr.json", "eval_demo_top.png", "eval_demo_truth.ifc", "eval_demo_incorr.ifc"):
        assert os.path.getsize(tmp_path / f) > 0
    m = BuildingModel.from_json(tmp_path / "eval_demo_truth.json")
    assert len(m.spaces) == 2
    with open(tmp_path / "eval_demo_top.png", "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    if hasattr(engine.io, "read_point_cloud") and engine.io.write_ply is not _mini_write_ply:
        cloud = engine.io.read_point_cloud(tmp_path / "eval_demo.ply")
        assert len(cloud) == pytest.approx(30_000, rel=0.15)
        assert set(np.unique(cloud.fields["label"])) <= {0, 1, 2, 3}
    bad = parser.parse_args(["synth", "nowhere", "-o", str(tmp_path)])
    bad.quiet, bad.json = True, False
    with pytest.raises(InputError):
        bad.func(bad)
    assert json.loads((tmp_path / "eval_demo_truth.json").read_text())["schema"] == "indoor-building-model"
    # the written plan (with its clutter) reads back and rebuilds the same truth and scan
    again = parser.parse_args(["synth", str(tmp_path / "eval_demo_plan.json"), "-o", str(tmp_path / "again"),
                               "--seed", "3", "--noise", "0.01", "--points", "30000", "--no-ifc", "--no-png"])
    again.quiet, again.json = True, False
    assert again.func(again) == 0
    assert (tmp_path / "again" / "eval_demo_truth.json").read_text() == (tmp_path / "eval_demo_truth.json").read_text()
    assert (tmp_path / "again" / "eval_demo.ply").read_bytes() == (tmp_path / "eval_demo.ply").read_bytes()
    broken = tmp_path / "broken.json"
    broken.write_text('{"schema": "indoor-floor-plan", "storeys": [], "rooms": []}')
    bad = parser.parse_args(["synth", str(broken), "-o", str(tmp_path)])
    bad.quiet, bad.json = True, False
    with pytest.raises(InputError, match="broken.json"):
        bad.func(bad)


def test_progress_and_cancel():
    seen = []
    preset("eval_demo", seed=0, target_points=5000, progress=lambda f, m: seen.append(f))
    assert seen[-1] == 1.0 and all(b >= a for a, b in zip(seen, seen[1:])) and len(seen) >= 3
    calls = []

    def stop():
        calls.append(1)
        return len(calls) > 2

    with pytest.raises(Cancelled):
        preset("eval_demo", seed=0, target_points=5000, should_stop=stop)
