"""The add-on's Review and fix, Topology, Changes and Evaluate sections, inside Blender.

Models are the true models of engine.synthetic presets (known rooms, walls, doors), put in
the scene with the bridge, so the operators are tested without a reconstruction run.
"""
import importlib
import json
import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

import blender_util as bu  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def office():
    return bu.engine_module("synthetic").preset("office_mw", seed=1, target_points=20_000)


@pytest.fixture
def office_scene(addon, office):
    scene = bu.fresh_scene()
    addon.bridge.model_to_objects(office.truth, scene=scene)
    return scene


def _objects(coll_name, scene=None):
    scene = scene or bpy.context.scene
    top = scene.collection.children["Indoor Model"]
    coll = top.children.get(coll_name)
    return [] if coll is None else list(coll.objects)


def _by_shape(shape_id):
    return next(o for o in bpy.data.objects if o.get("indoor_shape_id") == shape_id)


def _select(*objs, active=None):
    vl = bpy.context.view_layer
    for o in vl.objects.selected:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    vl.objects.active = active or objs[-1]


def _edges(model, kind):
    topology = bu.engine_module("topology")
    return {tuple(sorted(e)) for e in topology.space_graph(model, kind).edges}


def _unconnected_neighbours(model):
    """(wall id, space a, space b) of a wall between two adjacent spaces without a door."""
    conn = _edges(model, "connectivity")
    for r in model.relations:
        if r.kind != "adjacency" or r.via is None or r.via not in model:
            continue
        a, b = model.top_level(r.a).id, model.top_level(r.b).id
        if a != b and model[a].type.value == model[b].type.value == "interior" and \
                tuple(sorted((a, b))) not in conn and model[r.via].type.value == "wall":
            return r.via, a, b
    raise AssertionError("office_mw has no adjacent unconnected rooms")


# --------------------------------------------------------------------------- registration
def test_sections_in_work_order_and_operators_undoable(addon):
    labels = [c.bl_label for c in addon.panels.CLASSES]
    assert labels == ["Import scan", "Reconstruct", "Review and fix", "Topology", "Evaluate", "Changes",
                      "Export"]
    for op in ("reclassify", "insert_door", "revert_edit", "show_graph", "shortest_path", "detect_changes",
               "evaluate"):
        cls = getattr(bpy.types, "INDOOR_OT_" + op)
        assert {"REGISTER", "UNDO"} <= set(cls.bl_options), op
    addon.unregister()
    try:
        for cls in addon.CLASSES:
            assert not cls.is_registered, cls
        assert not hasattr(bpy.types, "INDOOR_OT_shortest_path")
        assert not hasattr(bpy.types.Scene, "indoor")
    finally:
        addon.register()


# --------------------------------------------------------------------------- Review and fix
def test_reclassify_room_changes_collections_and_topology(office_scene, addon, office):
    model = addon.bridge.stored_model()
    n_spaces, n_ext = len(_objects("Spaces")), len(_objects("Exterior"))
    assert n_spaces == len(model.spaces) == 8
    room = next(s for s in model.spaces if s.name == "Room 3")
    conn_before = _edges(model, "connectivity")
    assert any(room.id in e for e in conn_before)
    _select(_by_shape(room.id))
    assert bpy.ops.indoor.reclassify(type="exterior") == {"FINISHED"}
    new = addon.bridge.stored_model()
    expect = bu.engine_module("topology").reclassify(model, [room.id], "exterior")
    assert [(s.id, s.type, s.active) for s in new.shapes] == [(s.id, s.type, s.active) for s in expect.shapes]
    assert len(_objects("Spaces")) == n_spaces - 1 == len(new.spaces)
    assert len(_objects("Exterior")) == n_ext + 1
    assert _by_shape(room.id).users_collection[0].name == "Exterior"
    assert not any(room.id in e for e in _edges(new, "connectivity"))
    # the add-on's own restore path gives back the model before the edit
    assert addon.bridge.history_length() == 1
    assert bpy.ops.indoor.revert_edit() == {"FINISHED"}
    assert addon.bridge.stored_model().to_json() == model.to_json()
    assert len(_objects("Spaces")) == n_spaces and len(_objects("Exterior")) == n_ext
    assert addon.bridge.history_length() == 0
    assert not bpy.ops.indoor.revert_edit.poll()


def test_insert_door_at_cursor_connects_rooms_and_undo_restores(office_scene, addon):
    model = addon.bridge.stored_model()
    wall_id, a, b = _unconnected_neighbours(model)
    wall = _by_shape(wall_id)
    n_doors = len(_objects("Doors"))
    # the 3D cursor at the wall's centre (scene frame = model.transform applied)
    t = np.asarray(model.transform)
    centre = t[:3, :3] @ model[wall_id].centroid + t[:3, 3]
    bpy.context.scene.cursor.location = centre
    _select(wall)
    bpy.ops.ed.undo_push(message="before door")
    assert bpy.ops.indoor.insert_door(width=1.0, height=2.0, position_mode="CURSOR") == {"FINISHED"}
    new = addon.bridge.stored_model()
    assert len(new.doors) == len(model.doors) + 1 == len(_objects("Doors")) == n_doors + 1
    door = next(d for d in new.doors if d.id not in model)
    assert door.parent == model.top_level(wall_id).id
    length = model[wall_id].bounds[1] - model[wall_id].bounds[0]
    axis = int(np.argmax(length[:2]))
    assert door.attributes["position"] == pytest.approx(length[axis] / 2, abs=1e-6)
    assert door.attributes["width"] == 1.0 and door.attributes["height"] == 2.0
    assert tuple(sorted((a, b))) in _edges(new, "connectivity")
    # Blender's undo restores the model and the objects. Headless, operators called from Python
    # push no undo step themselves (the window manager does that for UI calls of UNDO operators),
    # so the test pushes the step the UI would push after the operator.
    bpy.ops.ed.undo_push(message="Insert Door")
    assert bpy.ops.ed.undo() == {"FINISHED"}
    back = addon.bridge.stored_model()
    assert back.to_json() == model.to_json()
    assert len(_objects("Doors")) == n_doors
    assert tuple(sorted((a, b))) not in _edges(back, "connectivity")


def test_insert_door_by_value_and_failure_leaves_scene(office_scene, addon):
    model = addon.bridge.stored_model()
    wall_id, _, _ = _unconnected_neighbours(model)
    _select(_by_shape(wall_id))
    before = bu.scene_state()
    text = model.to_json()
    with pytest.raises(RuntimeError, match="does not fit"):
        bpy.ops.indoor.insert_door(width=0.9, height=2.0, position_mode="VALUE", position=0.1)
    with pytest.raises(RuntimeError, match="does not fit"):
        bpy.ops.indoor.insert_door(width=0.9, height=5.0, position_mode="VALUE", position=1.5)
    assert bu.scene_state() == before and addon.bridge.stored_model().to_json() == text
    res = bpy.ops.indoor.insert_door(width=0.8, height=2.0, position_mode="VALUE", position=1.5)
    assert res == {"FINISHED"}
    door = next(d for d in addon.bridge.stored_model().doors if d.id not in model)
    assert door.attributes["position"] == pytest.approx(1.5)


# --------------------------------------------------------------------------- Topology
def test_graph_curves_join_space_centres(office_scene, addon):
    model = addon.bridge.stored_model()
    for kind in ("adjacency", "connectivity"):
        assert bpy.ops.indoor.show_graph(kind=kind) == {"FINISHED"}
        obj = bpy.data.objects[addon.bridge.GRAPH_OBJECTS[kind]]
        assert obj.users_collection[0].name == "Topology"
        edges = _edges(model, kind)
        assert sorted(obj["indoor_edges"]) == sorted(f"{a}|{b}" for a, b in edges)
        assert len(obj.data.splines) == len(edges) > 0
        for (a_b, pts) in zip(obj["indoor_edges"], addon.bridge.spline_points(obj)):
            a, b = a_b.split("|")
            np.testing.assert_allclose(pts, [model[a].centroid, model[b].centroid], atol=1e-5)
    assert len(_edges(model, "adjacency")) > len(_edges(model, "connectivity"))
    assert bpy.ops.indoor.show_graph(kind="adjacency") == {"FINISHED"}  # toggled off
    assert bpy.data.objects.get("Adjacency graph") is None
    assert bpy.data.objects.get("Connectivity graph") is not None
    # an edit redraws the shown graph: the new door adds a connectivity edge
    wall_id, a, b = _unconnected_neighbours(model)
    _select(_by_shape(wall_id))
    n = len(bpy.data.objects["Connectivity graph"].data.splines)
    bpy.ops.indoor.insert_door(position_mode="VALUE", position=1.0)
    assert len(bpy.data.objects["Connectivity graph"].data.splines) == n + 1


def test_shortest_path_between_selected_spaces(office_scene, addon):
    model = addon.bridge.stored_model()
    topology = bu.engine_module("topology")
    r1 = next(s for s in model.spaces if s.name == "Room 1")
    r5 = next(s for s in model.spaces if s.name == "Room 5")
    _select(_by_shape(r1.id), _by_shape(r5.id), active=_by_shape(r5.id))
    assert bpy.ops.indoor.shortest_path() == {"FINISHED"}
    expect = topology.shortest_path(model, r1.id, r5.id)
    settings = bpy.context.scene.indoor
    assert settings.path_text == topology.describe_path(model, expect)
    names = settings.path_text.split(" → ")
    assert names[0] == "Room 1" and names[-1] == "Room 5" and len(names) >= 3
    assert settings.path_length == pytest.approx(expect.length, rel=1e-6)
    curve = bpy.data.objects["Shortest path"]
    pts = addon.bridge.spline_points(curve)[0]
    np.testing.assert_allclose(pts[0], r1.centroid, atol=1e-5)
    np.testing.assert_allclose(pts[-1], r5.centroid, atol=1e-5)
    assert list(curve["indoor_spaces"]) == list(expect.spaces)
    # one selected space is an error that changes nothing
    _select(_by_shape(r1.id))
    with pytest.raises(RuntimeError, match="two spaces"):
        bpy.ops.indoor.shortest_path()
    assert settings.path_text == topology.describe_path(model, expect)


# --------------------------------------------------------------------------- Changes
@pytest.fixture(scope="module")
def change_demo():
    return bu.engine_module("synthetic").preset("change_demo", seed=0, target_points=80_000)


def _attr(mesh, name, prop="value"):
    a = mesh.attributes[name]
    out = np.empty(len(a.data), dtype=np.int32 if a.data_type == "INT" else np.float32)
    a.data.foreach_get(prop, out)
    return out


def test_detect_changes_on_active_scan(addon, change_demo):
    scene = bu.fresh_scene()
    bridge = addon.bridge
    bridge.model_to_objects(change_demo.truth, scene=scene)
    scan = bridge.point_cloud_to_object(change_demo.cloud, name="new scan")
    _select(scan)
    assert bpy.ops.indoor.detect_changes(use_active=True) == {"FINISHED"}
    change = bu.engine_module("change")
    expect = change.detect_changes(change_demo.truth, bridge.object_to_cloud(scan))
    mesh = scan.data
    # the engine's result, to float precision: two ICP runs (open3d, multithreaded) may differ
    # in the last bits, so a point lying at the distance threshold r may fall on the other
    # side of it; at most 1 in 10 000 points may differ in type (measured: none)
    got_type = _attr(mesh, "change_type")
    assert len(got_type) == len(expect.point_type)
    assert np.count_nonzero(got_type != expect.point_type) <= 1e-4 * len(got_type)
    np.testing.assert_allclose(_attr(mesh, "change_distance"), expect.distance.astype(np.float32), rtol=0, atol=1e-6)
    assert mesh.attributes["change_type"].domain == "POINT"
    # the synthetic truth: points of new structure are mostly classified new, old ones existing
    is_new = change_demo.cloud.fields["new"].astype(bool)
    assert np.mean(expect.point_type[is_new] == 1) > 0.8
    assert np.mean(expect.point_type[~is_new] == 0) > 0.9
    # colours: new red, existing grey; the points material reads the active colour attribute
    rgba = np.empty(len(mesh.vertices) * 4, np.float32)
    mesh.attributes["change_type_color"].data.foreach_get("color_srgb", rgba)
    rgb = rgba.reshape(-1, 4)[:, :3]
    np.testing.assert_allclose(rgb[expect.point_type == 1][0], bridge.TYPE_COLORS_CHANGE[1], atol=1 / 255)
    np.testing.assert_allclose(rgb[expect.point_type == 0][0], bridge.TYPE_COLORS_CHANGE[0], atol=1 / 255)
    assert mesh.color_attributes.active_color.name == "change_type_color"
    mat = bpy.data.materials["Indoor Changes"]
    assert mat.node_tree.nodes["Change colour"].attribute_name == "change_type_color"
    scene.indoor.change_color_mode = "DISTANCE"  # the panel's switch
    assert mesh.color_attributes.active_color.name == "change_distance_color"
    assert mat.node_tree.nodes["Change colour"].attribute_name == "change_distance_color"
    # surfaces coloured by coverage, redundant ones flagged
    faces = list(scene.collection.children["Changes"].objects)
    assert len(faces) == len(expect.coverage_keys)
    cov = dict(zip(expect.coverage_keys, expect.coverage))
    same_points = np.array_equal(got_type, expect.point_type)  # then the faces' members agree too
    for o in faces:
        if same_points:
            assert o["coverage"] == pytest.approx(cov[o["indoor_patch"]])
        assert o["indoor_flagged"] == (o["indoor_patch"] in expect.redundant)
        assert _attr(o.data, "coverage")[0] == pytest.approx(o["coverage"], abs=1e-6)
    assert sum(o["indoor_flagged"] for o in faces) == len(expect.redundant) >= 1
    summary = json.loads(scene.indoor.change_summary)
    # the summary counts the operator's own points (the mesh attribute), not the second run's
    assert summary["new"] == int(np.sum(got_type == 1)) and summary["redundant"] == expect.redundant
    # the model's elements coloured by status: the removed partition is the one wall "not installed"
    gone = [e for e in expect.element_status if e["status"] == "not installed" and e["type"] == "wall"]
    assert len(gone) == 1
    flagged = bridge.objects_with_status("not installed", scene)
    walls = [o for o in flagged if o["indoor_type"] == "wall"]
    assert [o[bridge.shapes.SHAPE_PROP] for o in walls] == [gone[0]["id"]]
    assert tuple(walls[0].color) == pytest.approx(bridge.STATUS_COLORS["not installed"])
    assert summary["statuses"]["not installed"] >= 1 and summary["statuses"]["installed"] >= 10
    # the fitted walls are objects of their own, status "new"; each topic names its object
    new = list(scene.collection.children[bridge.NEW_ELEMENTS_COLLECTION].objects)
    assert sum(o["indoor_type"] == "wall" for o in new) == len(expect.new_walls) == summary["statuses"]["new"] >= 1
    assert {t["status"] for t in summary["topics"]} == {"not installed", "new"}
    assert all(t["object"] in bpy.data.objects for t in summary["topics"])
    assert next(t for t in summary["topics"] if t["status"] == "not installed")["object"] == walls[0].name
    # select by status: exactly those objects
    assert bpy.ops.indoor.select_by_status(status="not installed") == {"FINISHED"}
    assert set(bpy.context.selected_objects) == set(flagged)
    assert bpy.ops.indoor.select_by_status(status="new") == {"FINISHED"}
    assert {o.name for o in bpy.context.selected_objects} == {o.name for o in new}


def test_detect_changes_from_file_and_bad_file_leaves_scene(addon, change_demo, tmp_path):
    scene = bu.fresh_scene()
    addon.bridge.model_to_objects(change_demo.truth, scene=scene)
    bad = tmp_path / "broken.ply"
    bad.write_bytes(b"ply\nformat nonsense\n")
    before = bu.scene_state()
    with pytest.raises(RuntimeError, match="broken.ply"):
        bpy.ops.indoor.detect_changes(filepath=str(bad))
    assert bu.scene_state() == before and scene.indoor.change_summary == ""
    # a scan file: imported as a point mesh that carries the change attributes
    sub = change_demo.cloud.subset(np.arange(0, len(change_demo.cloud), 4))
    good = tmp_path / "newer.ply"
    bu.engine_module("io").write_ply(str(good), sub)
    assert bpy.ops.indoor.detect_changes(filepath=str(good)) == {"FINISHED"}
    obj = bpy.data.objects["newer"]
    assert obj.users_collection[0].name == "Scan" and len(obj.data.vertices) == len(sub)
    t = _attr(obj.data, "change_type")
    assert json.loads(scene.indoor.change_summary)["new"] == int(t.sum()) > 0
    is_new = sub.fields["new"].astype(bool)
    assert np.mean(t[is_new] == 1) > 0.8 and np.mean(t[~is_new] == 0) > 0.9


def test_a_bug_in_detect_changes_leaves_no_new_scan(addon, change_demo, tmp_path, monkeypatch):
    """A failure that is not an engine error (a bug), after the scan file became an object and the
    overlay was drawn, removes that object and everything else the operator made."""
    scene = bu.fresh_scene()
    addon.bridge.model_to_objects(change_demo.truth, scene=scene)
    sub = change_demo.cloud.subset(np.arange(0, len(change_demo.cloud), 8))
    good = tmp_path / "newer.ply"
    bu.engine_module("io").write_ply(str(good), sub)
    before = bu.scene_state()
    draw = addon.bridge.change_overlay

    def buggy(obj, result, model, **kw):
        draw(obj, result, model, **kw)
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(addon.bridge, "change_overlay", buggy)
    with pytest.raises(RuntimeError) as e:
        bpy.ops.indoor.detect_changes(filepath=str(good))
    assert "internal error: ZeroDivisionError" in str(e.value) and "Traceback" not in str(e.value)
    assert bu.scene_state() == before and bpy.data.objects.get("newer") is None
    assert scene.indoor.change_summary == ""
    monkeypatch.setattr(addon.bridge, "change_overlay", draw)

    def engine_bug(*a, **k):
        raise KeyError("registration")

    # the operator imports engine.change when it runs: patch it there
    change = importlib.import_module(addon.__name__.rsplit(".", 1)[0] + ".engine.change")
    monkeypatch.setattr(change, "detect_changes", engine_bug)
    with pytest.raises(RuntimeError, match="internal error: KeyError"):
        bpy.ops.indoor.detect_changes(filepath=str(good))
    assert bu.scene_state() == before and scene.indoor.change_summary == ""


def test_blend_reopens_with_model_history_and_overlays(office_scene, addon, tmp_path):
    model = addon.bridge.stored_model()
    wall_id, a, b = _unconnected_neighbours(model)
    _select(_by_shape(wall_id))
    bpy.ops.indoor.insert_door(position_mode="VALUE", position=1.0)
    bpy.ops.indoor.show_graph(kind="connectivity")
    edited = addon.bridge.stored_model().to_json()
    path = str(tmp_path / "edited.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bu.fresh_scene()
    assert addon.bridge.stored_model() is None
    bpy.ops.wm.open_mainfile(filepath=path)
    assert addon.bridge.stored_model().to_json() == edited
    assert len(_objects("Doors")) == len(model.doors) + 1
    assert len(bpy.data.objects["Connectivity graph"].data.splines) == len(_edges(model, "connectivity")) + 1
    assert bpy.ops.indoor.revert_edit() == {"FINISHED"}  # the history survives the save
    assert addon.bridge.stored_model().to_json() == model.to_json()
    assert len(bpy.data.objects["Connectivity graph"].data.splines) == len(_edges(model, "connectivity"))


# --------------------------------------------------------------------------- Evaluate
def test_evaluate_extra_room_flags_redundant_sources(addon, tmp_path):
    demo = bu.engine_module("synthetic").preset("eval_demo", seed=0, target_points=5_000)
    scene = bu.fresh_scene()
    addon.bridge.model_to_objects(demo.variants["incorr"], scene=scene)  # a room that is not there
    ref = tmp_path / "truth.json"
    ref.write_text(demo.truth.to_json())
    assert bpy.ops.indoor.evaluate(filepath=str(ref)) == {"FINISHED"}
    expect = bu.engine_module("evaluation").evaluate(demo.variants["incorr"], demo.truth)
    summary = json.loads(scene.indoor.eval_summary)
    assert summary["redundant"] == expect.redundant and len(expect.redundant) >= 1
    assert summary["correctness"] < 0.95
    src = [o for o in scene.collection.children["Evaluation"].objects if o.name.startswith("Source ")]
    assert len(src) == len(expect.source)
    assert {o["indoor_patch"] for o in src if o["indoor_flagged"]} == set(expect.redundant)


def test_evaluate_against_reference_file(addon, tmp_path):
    demo = bu.engine_module("synthetic").preset("eval_demo", seed=0, target_points=5_000)
    scene = bu.fresh_scene()
    addon.bridge.model_to_objects(demo.variants["incomp"], scene=scene)  # the corridor is missing
    ref = tmp_path / "truth.json"
    ref.write_text(demo.truth.to_json())
    assert bpy.ops.indoor.evaluate(filepath=str(ref), out_dir=str(tmp_path / "eval")) == {"FINISHED"}
    ev = bu.engine_module("evaluation")
    expect = ev.evaluate(demo.variants["incomp"], demo.truth)
    summary = json.loads(scene.indoor.eval_summary)
    li = expect.localisation_index
    assert summary["completeness"] == pytest.approx(expect.curves["all"]["completeness"][li])
    assert summary["correctness"] == pytest.approx(expect.curves["all"]["correctness"][li])
    assert summary["missing"] == expect.missing and len(expect.missing) >= 1
    assert summary["completeness"] < 0.9 and summary["correctness"] > 0.95
    img = bpy.data.images[addon.bridge.EVALUATION_IMAGE]
    assert img.packed_file is not None and tuple(img.size) == (1200, 380)
    objs = list(scene.collection.children["Evaluation"].objects)
    ref_objs = [o for o in objs if o.name.startswith("Reference ")]
    assert len(ref_objs) == int(np.sum(expect.visible))
    assert {o["indoor_patch"] for o in ref_objs if o["indoor_flagged"]} == set(expect.missing)
    for o in ref_objs:  # missing surfaces are red
        if o["indoor_flagged"]:
            assert o.color[0] > 0.8 and o.color[1] < 0.5
    assert os.path.exists(tmp_path / "eval" / "curves.png")


def test_evaluate_bad_reference_leaves_scene(addon, tmp_path):
    demo = bu.engine_module("synthetic").preset("eval_demo", seed=0, target_points=5_000)
    scene = bu.fresh_scene()
    addon.bridge.model_to_objects(demo.truth, scene=scene)
    bad = tmp_path / "nothing.ifc"
    bad.write_text("not ifc")
    before = bu.scene_state()
    with pytest.raises(RuntimeError, match="nothing.ifc"):
        bpy.ops.indoor.evaluate(filepath=str(bad))
    assert bu.scene_state() == before and scene.indoor.eval_summary == ""


# --------------------------------------------------------------------------- modal reconstruct
def _drive_modal(addon, job, event_types):
    """Run INDOOR_OT_reconstruct.modal the way the window manager would (timer events)."""
    import time
    from types import SimpleNamespace

    op_cls = addon.operators.INDOOR_OT_reconstruct
    wm = bpy.context.window_manager
    reports = []
    fake = SimpleNamespace(method=job.method, seed=job.seed, _object_name="office", _job=job,
                           report=lambda kind, msg: reports.append((set(kind), msg)))
    fake._finish = lambda ctx: op_cls._finish(fake, ctx)
    fake._timer = wm.event_timer_add(0.1, window=bpy.context.window)
    wm.progress_begin(0, 1000)
    bpy.context.scene.indoor.running = True
    seen, state, k = [], {"RUNNING_MODAL"}, 0
    while state == {"RUNNING_MODAL"}:
        etype = event_types[min(k, len(event_types) - 1)]
        state = op_cls.modal(fake, bpy.context, SimpleNamespace(type=etype))
        seen.append(bpy.context.scene.indoor.progress)
        k += 1
        time.sleep(0.02)
    return state, reports, seen


def test_modal_reconstruct_progress_and_cancel(addon, office):
    scene = bu.fresh_scene()
    bridge = addon.bridge
    obj = bridge.point_cloud_to_object(office.cloud, name="office")
    ReconstructJob = bu.engine_module("background").ReconstructJob
    # cancelled (Esc) right away: the engine stops at its next check, the scene is unchanged
    before = bu.scene_state()
    job = ReconstructJob(bridge.object_to_cloud(obj), "manhattan", 0).start()
    state, reports, _ = _drive_modal(addon, job, ["ESC", "TIMER"])
    assert state == {"CANCELLED"} and job.cancelled and job.model is None
    assert reports and reports[-1][0] == {"WARNING"} and "cancelled" in reports[-1][1]
    assert bu.scene_state() == before and "Indoor Model.json" not in bpy.data.texts
    assert not scene.indoor.running
    # a full run: progress rises to 1 and the objects are built on the main thread at the end
    job = ReconstructJob(bridge.object_to_cloud(obj), "manhattan", 0).start()
    state, reports, seen = _drive_modal(addon, job, ["TIMER"])
    assert state == {"FINISHED"} and job.error is None, reports
    assert all(b >= a for a, b in zip(seen, seen[1:])) and seen[-1] == pytest.approx(1.0)
    model = bridge.stored_model()
    assert [s.id for s in model.shapes] == [s.id for s in job.model.shapes]
    assert len(_objects("Spaces", scene)) == len(model.spaces) >= 2
    assert not scene.indoor.running and reports[-1][0] == {"INFO"}


# --------------------------------------------------------------------------- panels
class _FakeLayout:
    """Records what a panel draws (labels, operators, properties); any layout call works."""

    def __init__(self, log):
        self._log = log

    def __getattr__(self, name):
        def call(*args, **kw):
            self._log.append((name, args, kw))
            return _FakeLayout(self._log)
        return call

    def __setattr__(self, key, value):
        object.__setattr__(self, key, value)


def test_panels_only_read_cached_data(addon, office, monkeypatch):
    scene = bu.fresh_scene()
    bridge = addon.bridge
    bridge.model_to_objects(office.truth, scene=scene)
    model = bridge.stored_model()
    r1, r5 = (next(s for s in model.spaces if s.name == n) for n in ("Room 1", "Room 5"))
    assert bpy.ops.indoor.shortest_path(start=r1.id, end=r5.id) == {"FINISHED"}
    bpy.ops.indoor.show_graph(kind="connectivity")
    scene.indoor.change_summary = json.dumps({"scan": "s", "points": 10, "existing": 7, "new": 3,
                                              "new_share": 0.3,
                                              "distance_threshold_m": 0.05, "surfaces": 4, "redundant": ["a"],
                                              "new_elements": 1, "new_walls": 1,
                                              "statuses": {"installed": 9, "not installed": 1, "new": 2},
                                              "topics": [{"title": "IfcWall Wall 3: not installed",
                                                          "status": "not installed", "guid": "g",
                                                          "object": "Wall 3"}]})
    scene.indoor.eval_summary = json.dumps({"buffer_m": 0.05, "completeness": 0.8, "correctness": 0.9,
                                            "accuracy_m": 0.01, "missing": ["x"], "redundant": []})
    _select(_by_shape(r1.id))

    def forbidden(*a, **k):
        raise AssertionError("a panel computed something")

    engine = bu.engine_module()
    for mod, names in (("topology", ("shortest_path", "space_graph", "reclassify", "insert_door")),
                       ("change", ("detect_changes",)), ("evaluation", ("evaluate", "load_model")),
                       ("reconstruct", ("reconstruct",))):
        m = bu.engine_module(mod)
        for n in names:
            monkeypatch.setattr(m, n, forbidden)
    monkeypatch.setattr(bridge, "stored_model", forbidden)
    monkeypatch.setattr(engine.model.BuildingModel, "from_json", forbidden)
    drawn = {}
    for cls in addon.panels.CLASSES:
        log = []
        fake = type("P", (), {"layout": _FakeLayout(log)})()
        cls.draw(fake, bpy.context)
        drawn[cls.bl_label] = [a[0] for name, a, kw in log if name == "label" and a] + \
            [kw.get("text", "") for name, a, kw in log if name in ("label", "progress")]
    topo = " ".join(drawn["Topology"])
    assert "Room 1" in topo and "Room 5" in topo and "m centre to centre" in topo
    assert any("3 new of 10" in t for t in drawn["Changes"])
    assert any("grey: existing" in t for t in drawn["Changes"])
    assert any("red: not installed  1" in t for t in drawn["Changes"])
    assert any("IfcWall Wall 3: not installed → Wall 3" in t for t in drawn["Changes"])
    assert any("Completeness 80.0%" in t for t in drawn["Evaluate"])
    assert any("Room 1" in t for t in drawn["Review and fix"])


# --------------------------------------------------------------------------- Export
def test_export_opens_in_bonsai_only_when_installed(addon, office, tmp_path):
    scene = bu.fresh_scene()
    addon.bridge.model_to_objects(office.truth, scene=scene)
    path = tmp_path / "m.ifc"
    assert not addon.operators.bonsai_available()
    assert bpy.ops.indoor.export_ifc(filepath=str(path), open_in_bonsai=True) == {"FINISHED"}
    import ifcopenshell

    f = ifcopenshell.open(str(path))
    assert len(f.by_type("IfcSpace")) >= len(office.truth.spaces)
    opened = []

    class BIM_OT_load_project(bpy.types.Operator):  # stands in for Bonsai's operator
        bl_idname = "bim.load_project"
        bl_label = "Load Project"
        filepath: bpy.props.StringProperty()

        def execute(self, context):
            opened.append(self.filepath)
            return {"FINISHED"}

    bpy.utils.register_class(BIM_OT_load_project)
    try:
        assert addon.operators.bonsai_available()
        res = bpy.ops.indoor.export_ifc(filepath=str(tmp_path / "n.ifc"), open_in_bonsai=True)
        assert res == {"FINISHED"}
    finally:
        bpy.utils.unregister_class(BIM_OT_load_project)
    assert opened == [str(tmp_path / "n.ifc")]


def _fake_reconstruct(addon, monkeypatch, office):
    """Record the Reconstruct operator's engine calls; the model is the preset's truth."""
    seen = []

    def fake(cloud, method, *, params=None, rng=0, progress=None, should_stop=None):
        seen.append((method, params, rng))
        return office.truth

    monkeypatch.setattr(addon.operators.reconstruction, "reconstruct", fake)
    return seen


def test_parameter_defaults_are_the_engines(addon):
    """Every parameter the add-on shows starts at the engine's default of its key (the generic
    method's smallest wall is 0.5 m², not the Manhattan grammar's 1.5 m²)."""
    pm = bu.engine_module("params")
    defaults = {r.key: r.value for r in pm.params_table(pm.Params())}
    shown = addon.props.ENGINE_PARAMS
    assert {key for _, key, _, _ in shown} == {
        "manhattan.min_wall_area", "generic.cells.min_wall_area", "manhattan.max_wall_thickness",
        "generic.search.max_wall_thickness", "preprocess.clean.voxel_size"}
    for prop, key, _, _ in shown:
        for where, rna in (("scene", addon.props.INDOOR_PG_settings.bl_rna),
                           ("operator", bpy.ops.indoor.reconstruct.get_rna_type())):
            assert rna.properties[prop].default == pytest.approx(defaults[key], rel=1e-6), (where, prop)
            assert key in rna.properties[prop].description
    settings = bu.fresh_scene().indoor
    assert settings.min_wall_area_generic == pytest.approx(pm.Params().generic.cells.min_wall_area)
    assert settings.min_wall_area_manhattan == pytest.approx(pm.Params().manhattan.min_wall_area)


def test_reconstruct_passes_key_parameters(addon, office, monkeypatch):
    scene = bu.fresh_scene()
    obj = addon.bridge.point_cloud_to_object(office.cloud, name="office")
    _select(obj)
    pm = bu.engine_module("params")
    defaults = pm.Params()
    seen = _fake_reconstruct(addon, monkeypatch, office)
    assert bpy.ops.indoor.reconstruct(method="manhattan", seed=3) == {"FINISHED"}
    assert seen[-1] == ("manhattan", None, 3)  # defaults: the engine chooses from the data
    # "Set parameters" with the shown values untouched: exactly the engine's defaults
    assert bpy.ops.indoor.reconstruct(method="auto", use_custom_params=True) == {"FINISHED"}
    assert seen[-1][1] == defaults
    assert bpy.ops.indoor.reconstruct(method="manhattan", use_custom_params=True, min_wall_area_manhattan=2.5,
                                      max_wall_thickness_manhattan=0.35) == {"FINISHED"}
    method, params, _ = seen[-1]
    assert method == "manhattan" and isinstance(params, pm.Params)
    assert params.manhattan.min_wall_area == 2.5 and params.manhattan.max_wall_thickness == 0.35
    assert params.manhattan.bin_size is None  # data-dependent fields still chosen from the scan
    assert params.generic == defaults.generic and params.preprocess == defaults.preprocess
    res = bpy.ops.indoor.reconstruct(method="generic", use_custom_params=True, working_voxel=0.04,
                                     min_wall_area_generic=0.7)
    assert res == {"FINISHED"}
    method, params, _ = seen[-1]
    assert method == "generic" and params.preprocess.clean.voxel_size == 0.04
    assert params.generic.cells.min_wall_area == 0.7 and params.manhattan == defaults.manhattan
    assert len(_objects("Spaces", scene)) == len(office.truth.spaces)


def test_reconstruct_takes_the_panel_settings(addon, office, monkeypatch):
    """Settings of the panel (scene.indoor) are the run's unless the caller sets them."""
    scene = bu.fresh_scene()
    _select(addon.bridge.point_cloud_to_object(office.cloud, name="office"))
    seen = _fake_reconstruct(addon, monkeypatch, office)
    s = scene.indoor
    s.method, s.reconstruct_seed, s.use_custom_params, s.min_wall_area_generic = "generic", 7, True, 0.9
    assert bpy.ops.indoor.reconstruct() == {"FINISHED"}
    method, params, seed = seen[-1]
    assert (method, seed) == ("generic", 7) and params.generic.cells.min_wall_area == 0.9
    assert bpy.ops.indoor.reconstruct(seed=2, use_custom_params=False) == {"FINISHED"}
    assert seen[-1] == ("generic", None, 2)


def test_load_and_save_parameters(addon, office, monkeypatch, tmp_path):
    scene = bu.fresh_scene()
    _select(addon.bridge.point_cloud_to_object(office.cloud, name="office"))
    pm = bu.engine_module("params")
    seen = _fake_reconstruct(addon, monkeypatch, office)
    path = tmp_path / "mine.toml"
    path.write_text("[manhattan]\nmin_wall_area = 2.0\n\n[generic.cells]\nmin_wall_area = 0.8\n")
    assert bpy.ops.indoor.load_parameters(filepath=str(path)) == {"FINISHED"}
    loaded = pm.load_params(str(path))
    s = scene.indoor
    assert s.params_file == str(path) and s.params_toml
    assert s.min_wall_area_manhattan == pytest.approx(2.0) and s.min_wall_area_generic == pytest.approx(0.8)
    assert bpy.ops.indoor.reconstruct(method="manhattan") == {"FINISHED"}
    assert seen[-1][1] == loaded  # the loaded parameters are the run's
    assert bpy.ops.indoor.reconstruct(method="generic", use_custom_params=True,
                                      min_wall_area_generic=1.25) == {"FINISHED"}
    params = seen[-1][1]
    assert params.generic.cells.min_wall_area == 1.25 and params.manhattan.min_wall_area == 2.0
    # Save writes what Reconstruct would use: the loaded file and, when set, the panel's values
    out = tmp_path / "saved.toml"
    assert bpy.ops.indoor.save_parameters(filepath=str(out)) == {"FINISHED"}
    assert pm.load_params(str(out)) == loaded
    s.use_custom_params, s.max_wall_thickness_generic = True, 0.25
    assert bpy.ops.indoor.save_parameters(filepath=str(out)) == {"FINISHED"}
    assert pm.load_params(str(out)).generic.search.max_wall_thickness == 0.25
    assert pm.load_params(str(out)).manhattan.min_wall_area == 2.0


@pytest.mark.parametrize("case", ["unknown_key", "not_toml", "missing"])
def test_bad_parameter_file_reports_and_changes_nothing(addon, tmp_path, case):
    scene = bu.fresh_scene()
    path = tmp_path / f"{case}.toml"
    if case == "unknown_key":
        path.write_text("[manhattan]\nno_such_key = 1.0\n")
    elif case == "not_toml":
        path.write_text("[manhattan\nmin_wall_area = \n")
    s = scene.indoor
    before = (s.params_toml, s.params_file, s.min_wall_area_manhattan)
    state = bu.scene_state()
    with pytest.raises(RuntimeError) as e:
        bpy.ops.indoor.load_parameters(filepath=str(path))
    msg = str(e.value)
    assert f"{case}.toml" in msg and "input error" in msg and len(msg.strip().splitlines()) == 1
    assert "no_such_key" in msg or case != "unknown_key"
    assert (s.params_toml, s.params_file, s.min_wall_area_manhattan) == before
    assert bu.scene_state() == state


def test_save_parameters_to_a_bad_place_reports(addon, tmp_path):
    bu.fresh_scene()
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(RuntimeError, match="output error"):
        bpy.ops.indoor.save_parameters(filepath=str(blocker / "p.toml"))
    assert blocker.read_text() == "x"
