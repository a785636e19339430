"""The Blender add-on, inside Blender: registration, Import scan, the bridge, bad files."""
import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

import blender_util as bu  # noqa: E402  (tests/addon/ is on the path: pytest's prepend import mode)

pytestmark = pytest.mark.blender


@pytest.fixture
def scene(addon):
    return bu.fresh_scene()


def _synthetic_cloud_arrays(n, rng):
    xyz = np.column_stack([rng.uniform(-4, 6, n), rng.uniform(-3, 3, n), rng.uniform(0, 2.8, n)])
    colors = rng.integers(0, 256, (n, 3)).astype(np.uint8)
    intensity = rng.uniform(0, 1000, n).astype(np.float32)
    normals = rng.normal(size=(n, 3))
    normals = (normals / np.linalg.norm(normals, axis=1, keepdims=True)).astype(np.float32)
    label = rng.integers(0, 4, n).astype(np.int32)
    distance = rng.uniform(0, 0.5, n).astype(np.float32)
    return xyz, colors, intensity, normals, label, distance


def _attr(mesh, name, prop, width):
    a = mesh.attributes[name]
    dtype = np.int32 if prop == "value" and a.data_type == "INT" else np.float32
    out = np.empty(len(a.data) * width, dtype=dtype)
    a.data.foreach_get(prop, out)
    return out.reshape(-1, width) if width > 1 else out


def _evaluated_point_count(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    geometry = obj.evaluated_get(dg).evaluated_geometry()
    pointcloud = geometry.pointcloud
    return None if pointcloud is None else len(pointcloud.points)


# --------------------------------------------------------------------------- registration
def _registered_state(addon):
    draw = bpy.types.TOPBAR_MT_file_import.draw
    return {
        "operator": hasattr(bpy.types, "INDOOR_OT_import_scan"),
        "op_callable": "import_scan" in dir(bpy.ops.indoor),
        "panel": hasattr(bpy.types, "INDOOR_PT_import_scan"),
        "settings": addon.props.INDOOR_PG_settings.is_registered,
        "scene_prop": hasattr(bpy.types.Scene, "indoor"),
        "menu": addon.operators.menu_import in getattr(draw, "_draw_funcs", []),
        "export_menu": addon.operators.menu_export in getattr(bpy.types.TOPBAR_MT_file_export.draw,
                                                              "_draw_funcs", []),
        "export_op": hasattr(bpy.types, "INDOOR_OT_export_ifc"),
    }


def _handlers():
    return {name: len(getattr(bpy.app.handlers, name)) for name in dir(bpy.app.handlers)
            if not name.startswith("_") and isinstance(getattr(bpy.app.handlers, name), list)}


def test_register_unregister_twice_leaves_nothing(addon):
    addon.unregister()
    try:
        before_handlers = _handlers()
        assert not any(_registered_state(addon).values())
        addon.register()
        addon.register()  # a second register is safe
        assert all(_registered_state(addon).values())
        draw = bpy.types.TOPBAR_MT_file_import.draw
        assert draw._draw_funcs.count(addon.operators.menu_import) == 1
        assert bpy.context.scene.indoor.display_ratio == 1.0
        addon.unregister()
        addon.unregister()  # a second unregister is a no-op
        assert not any(_registered_state(addon).values())
        assert _handlers() == before_handlers
    finally:
        addon.register()


def test_panel_lives_in_the_indoor_sidebar_tab(addon):
    pt = bpy.types.INDOOR_PT_import_scan
    assert (pt.bl_space_type, pt.bl_region_type, pt.bl_category, pt.bl_label) == \
        ("VIEW_3D", "UI", "Indoor", "Import scan")


# --------------------------------------------------------------------------- Import scan
def test_import_scan_builds_point_mesh_with_attributes(scene, tmp_path, rng):
    n = 5000
    xyz, colors, intensity, normals, label, distance = _synthetic_cloud_arrays(n, rng)
    path = str(tmp_path / "room.ply")
    bu.write_binary_ply(path, xyz, colors=colors, intensity=intensity, normals=normals,
                        extra={"label": label, "distance": distance})
    cloud = bu.engine_module("io").read_point_cloud(path)  # what the operator gets
    assert sorted(cloud.fields) == ["distance", "label"]

    result = bpy.ops.indoor.import_scan(filepath=path, display_ratio=1.0, point_radius=0.015)
    assert result == {"FINISHED"}

    coll = scene.collection.children.get("Scan")
    assert coll is not None and len(coll.objects) == 1
    obj = coll.objects[0]
    assert obj.name == "room" and bpy.context.view_layer.objects.active == obj
    mesh = obj.data
    assert len(mesh.vertices) == n and len(mesh.edges) == 0 and len(mesh.polygons) == 0
    co = np.empty(n * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    np.testing.assert_array_equal(co.reshape(-1, 3), cloud.xyz.astype(np.float32))
    np.testing.assert_allclose(co.reshape(-1, 3), xyz, atol=1e-5)  # the file's own values

    attrs = {a.name: (a.data_type, a.domain) for a in mesh.attributes if not a.name.startswith(".")}
    assert attrs["color"] == ("BYTE_COLOR", "POINT")
    assert attrs["intensity"] == ("FLOAT", "POINT")
    assert attrs["normal"] == ("FLOAT_VECTOR", "POINT")
    assert attrs["label"] == ("INT", "POINT")
    assert attrs["distance"] == ("FLOAT", "POINT")
    rgb = np.rint(_attr(mesh, "color", "color_srgb", 4)[:, :3] * 255)
    np.testing.assert_array_equal(rgb, colors)
    np.testing.assert_array_equal(_attr(mesh, "intensity", "value", 1), intensity)
    np.testing.assert_allclose(_attr(mesh, "normal", "vector", 3), normals, atol=1e-7)
    np.testing.assert_array_equal(_attr(mesh, "label", "value", 1), label)
    np.testing.assert_array_equal(_attr(mesh, "distance", "value", 1), distance)
    assert mesh.color_attributes.active_color.name == "color"

    # drawn as points: the Geometry Nodes modifier turns every vertex into a point
    mod = obj.modifiers["Indoor Points"]
    assert mod.type == "NODES"
    kinds = {node.bl_idname for node in mod.node_group.nodes}
    assert "GeometryNodeMeshToPoints" in kinds
    assert _evaluated_point_count(obj) == n
    # ... with a material whose shader reads the colour attribute
    mat = mesh.materials[0]
    attr_nodes = [nd for nd in mat.node_tree.nodes if nd.bl_idname == "ShaderNodeAttribute"]
    assert [nd.attribute_name for nd in attr_nodes] == ["color"]
    assert attr_nodes[0].outputs["Color"].is_linked
    assert tuple(obj["indoor_offset"]) == (0.0, 0.0, 0.0)
    assert obj["indoor_points"] == n


def test_import_keeps_large_offset_recoverable(scene, tmp_path, rng):
    n = 2000
    origin = np.array([512_345.25, 5_402_120.75, 240.0])  # UTM-like coordinates
    local = rng.uniform(0, 8, (n, 3))
    path = str(tmp_path / "geo.ply")
    bu.write_binary_ply(path, origin + local)
    assert bpy.ops.indoor.import_scan(filepath=path) == {"FINISHED"}
    obj = scene.collection.children["Scan"].objects["geo"]
    xyz, offset = bu.addon_module().bridge.object_points(obj)
    assert np.abs(offset).max() > 1e4  # the reader removed the offset ...
    assert np.abs(xyz).max() < 1e4  # ... so float32 vertices keep millimetres
    err = np.abs(xyz + offset - (origin + local)).max()
    assert err < 1e-3


def test_display_ratio_subsamples_drawing_not_data(scene, tmp_path, rng):
    n = 20000
    path = str(tmp_path / "dense.ply")
    bu.write_binary_ply(path, rng.uniform(0, 5, (n, 3)))
    assert bpy.ops.indoor.import_scan(filepath=path, display_ratio=0.25, seed=3) == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    assert len(obj.data.vertices) == n
    drawn = _evaluated_point_count(obj)
    assert abs(drawn - 0.25 * n) < 5 * np.sqrt(n * 0.25 * 0.75)  # binomial, 5 sigma
    bridge = bu.addon_module().bridge
    bridge.set_display(obj, display_ratio=1.0)
    assert _evaluated_point_count(obj) == n
    bridge.set_display(obj, display_ratio=0.0)
    assert _evaluated_point_count(obj) in (0, None)
    assert len(obj.data.vertices) == n


def test_section_hides_points_above_height_only_when_on(scene, addon):
    eng = bu.engine_module()
    z = np.repeat(np.arange(10) * 0.3, 100)  # 100 points at each of 0.0, 0.3, ..., 2.7 m
    xyz = np.column_stack([np.tile(np.arange(100) * 0.01, 10), np.zeros(1000), z])
    obj = addon.bridge.point_cloud_to_object(eng.PointCloud(xyz=xyz), name="sec")
    assert _evaluated_point_count(obj) == 1000
    addon.bridge.set_display(obj, section_z=1.0)  # height set, section still off
    assert _evaluated_point_count(obj) == 1000
    addon.bridge.set_display(obj, section=True)
    assert _evaluated_point_count(obj) == 400  # z = 0.0, 0.3, 0.6, 0.9
    addon.bridge.set_display(obj, display_ratio=0.5, section_z=2.0)
    drawn = _evaluated_point_count(obj)
    assert abs(drawn - 350) < 5 * np.sqrt(700 * 0.25)
    assert len(obj.data.vertices) == 1000


def test_second_import_reuses_scan_collection_and_node_group(scene, tmp_path, rng):
    for name in ("a", "b"):
        bu.write_binary_ply(str(tmp_path / f"{name}.ply"), rng.uniform(0, 5, (100, 3)))
        assert bpy.ops.indoor.import_scan(filepath=str(tmp_path / f"{name}.ply")) == {"FINISHED"}
    assert sorted(o.name for o in scene.collection.children["Scan"].objects) == ["a", "b"]
    assert [c.name for c in bpy.data.collections].count("Scan") == 1
    assert [g.name for g in bpy.data.node_groups] == ["Indoor Points"]


# --------------------------------------------------------------------------- bad files
def _truncated_ply(path):
    with open(path, "wb") as f:
        f.write(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
                b"property float x\nproperty float y\nproperty float z\nend_header\n")
        f.write(np.zeros(30, np.float32).tobytes())  # 10 of the 1000 points


@pytest.mark.parametrize("case", ["missing", "wrong_extension", "truncated"])
def test_bad_file_reports_error_and_leaves_scene_unchanged(scene, tmp_path, case):
    if case == "missing":
        path = str(tmp_path / "nowhere.ply")
    elif case == "wrong_extension":
        path = str(tmp_path / "notes.docx")
        with open(path, "w") as f:
            f.write("1 2 3\n4 5 6\n")
    else:
        path = str(tmp_path / "cut.ply")
        _truncated_ply(path)
    before = bu.scene_state()
    # an ERROR report of an operator called from Python surfaces as RuntimeError
    with pytest.raises(RuntimeError) as info:
        bpy.ops.indoor.import_scan(filepath=path)
    message = str(info.value)
    assert os.path.basename(path) in message
    assert "Traceback" not in message
    assert bu.scene_state() == before


def test_several_files_at_once_and_one_bad_file_imports_none(scene, tmp_path, rng):
    for name in ("s1", "s2"):
        bu.write_binary_ply(str(tmp_path / f"{name}.ply"), rng.uniform(0, 5, (300, 3)))
    _truncated_ply(str(tmp_path / "s3.ply"))
    before = bu.scene_state()
    with pytest.raises(RuntimeError, match="s3.ply"):
        bpy.ops.indoor.import_scan(directory=str(tmp_path), files=[{"name": "s1.ply"}, {"name": "s3.ply"}])
    assert bu.scene_state() == before
    assert bpy.ops.indoor.import_scan(directory=str(tmp_path),
                                      files=[{"name": "s1.ply"}, {"name": "s2.ply"}]) == {"FINISHED"}
    objs = scene.collection.children["Scan"].objects
    assert sorted(o.name for o in objs) == ["s1", "s2"]
    assert all(len(o.data.vertices) == 300 for o in objs)


def test_bridge_failure_midway_removes_what_it_made(scene, addon, monkeypatch, rng):
    eng = bu.engine_module()
    cloud = eng.PointCloud(xyz=rng.uniform(0, 1, (50, 3)), fields={"label": np.arange(50)})
    before = bu.scene_state()

    def boom(mesh, name, values):
        raise eng.InputError("field cannot be written", "mem.ply")

    monkeypatch.setattr(addon.bridge.points, "_write_field", boom)
    with pytest.raises(eng.InputError):
        addon.bridge.point_cloud_to_object(cloud, name="mem")
    assert bu.scene_state() == before


def test_bridge_maps_field_dtypes(scene, addon, rng):
    eng = bu.engine_module()
    n = 300
    fields = {
        "f64": rng.normal(size=n),
        "i64": rng.integers(-5, 5, n),
        "flag": rng.random(n) > 0.5,
        "vec": rng.normal(size=(n, 3)),
        "pair": rng.integers(0, 9, (n, 2)).astype(np.int16),
        "position": rng.normal(size=n),  # a reserved Blender name
    }
    cloud = eng.PointCloud(xyz=rng.uniform(0, 1, (n, 3)), scan_index=np.zeros(n, np.int32), fields=fields)
    obj = addon.bridge.point_cloud_to_object(cloud, name="fields")
    mesh = obj.data
    types = {a.name: a.data_type for a in mesh.attributes if not a.name.startswith(".")}
    assert types["f64"] == "FLOAT" and types["i64"] == "INT" and types["flag"] == "INT"
    assert types["vec"] == "FLOAT_VECTOR" and types["pair_0"] == "INT" and types["pair_1"] == "INT"
    assert types["field_position"] == "FLOAT" and types["scan_index"] == "INT"
    np.testing.assert_allclose(_attr(mesh, "f64", "value", 1), fields["f64"], rtol=1e-6)
    np.testing.assert_array_equal(_attr(mesh, "i64", "value", 1), fields["i64"])
    np.testing.assert_array_equal(_attr(mesh, "flag", "value", 1), fields["flag"].astype(np.int32))
    np.testing.assert_allclose(_attr(mesh, "vec", "vector", 3), fields["vec"], rtol=1e-6)
    np.testing.assert_array_equal(_attr(mesh, "pair_1", "value", 1), fields["pair"][:, 1])
    np.testing.assert_allclose(_attr(mesh, "field_position", "value", 1), fields["position"], rtol=1e-6)
    # vertex positions untouched by the "position" field
    co = np.empty(n * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    np.testing.assert_allclose(co.reshape(-1, 3), cloud.xyz, atol=1e-7)


def test_height_colors_follow_z(scene, addon):
    eng = bu.engine_module()
    z = np.linspace(0.0, 3.0, 301)
    cloud = eng.PointCloud(xyz=np.column_stack([np.zeros_like(z), np.zeros_like(z), z]))
    obj = addon.bridge.point_cloud_to_object(cloud, name="h")
    name = addon.bridge.add_height_colors(obj, z_range=(0.0, 3.0))
    rgba = _attr(obj.data, name, "color_srgb", 4)
    ramp = addon.bridge.HEIGHT_RAMP
    np.testing.assert_allclose(rgba[0, :3], ramp[0][1], atol=1 / 255)
    np.testing.assert_allclose(rgba[-1, :3], ramp[-1][1], atol=1 / 255)
    assert obj.data.color_attributes.active_color.name == name


# --------------------------------------------------------------------------- Reconstruct
@pytest.fixture(scope="module")
def office_scan():
    synthetic = bu.engine_module("synthetic")
    return synthetic.preset("office_mw", seed=1, target_points=60_000)


def test_object_to_cloud_round_trips_the_import(scene, addon, rng):
    eng = bu.engine_module()
    n = 500
    xyz, colors, intensity, normals, _, _ = _synthetic_cloud_arrays(n, rng)
    cloud = eng.PointCloud(xyz=xyz, colors=colors, intensity=intensity, normals=normals, offset=[100.0, 0, 5])
    back = addon.bridge.object_to_cloud(addon.bridge.point_cloud_to_object(cloud, name="rt"))
    np.testing.assert_allclose(back.xyz, xyz, atol=1e-5)
    np.testing.assert_array_equal(back.colors, colors)
    np.testing.assert_array_equal(back.intensity, intensity)
    np.testing.assert_allclose(back.normals, normals, atol=1e-7)
    np.testing.assert_array_equal(back.offset, cloud.offset)


def test_reconstruct_builds_collections_from_the_model(scene, addon, office_scan, tmp_path):
    obj = addon.bridge.point_cloud_to_object(office_scan.cloud, name="office")
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.indoor.reconstruct(method="manhattan", seed=0) == {"FINISHED"}
    model = addon.bridge.stored_model()
    # the same engine call on the same data gives the model the operator stored
    engine_reconstruct = bu.engine_module("reconstruct").reconstruct
    expect = engine_reconstruct(addon.bridge.object_to_cloud(obj), "manhattan", rng=0)
    assert [s.id for s in model.shapes] == [s.id for s in expect.shapes]
    top = scene.collection.children["Indoor Model"]
    colls = {c.name: c for c in top.children}
    active = [s for s in model.shapes if s.active]
    n_rooms = sum(s.type.value == "interior" for s in active)
    n_walls = sum(s.type.value == "wall" for s in active)
    assert n_rooms >= 2 and n_walls >= 4
    assert len(colls["Spaces"].objects) == n_rooms and len(colls["Walls"].objects) == n_walls
    assert len(colls["Cells"].objects) == sum(not s.active for s in model.shapes)
    assert colls["Cells"].hide_viewport and colls["Cells"].hide_render
    # geometry: each object's world vertices are the shape's vertices mapped by the model transform
    shapes = {s.id: s for s in model.shapes}
    wall = colls["Walls"].objects[0]
    geom = shapes[wall["indoor_shape_id"]].geometry
    co = np.empty(len(wall.data.vertices) * 3, np.float32)
    wall.data.vertices.foreach_get("co", co)
    m = np.asarray(wall.matrix_world)
    world = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    expect_world = geom.vertices @ model.transform[:3, :3].T + model.transform[:3, 3]
    np.testing.assert_allclose(world, expect_world, atol=1e-4)
    assert len(wall.data.polygons) == len(geom.faces)
    # Export IFC writes the stored model; the file re-opens with one IfcSpace per interior space
    ifc_path = str(tmp_path / "office.ifc")
    assert bpy.ops.indoor.export_ifc(filepath=ifc_path) == {"FINISHED"}
    import ifcopenshell

    f = ifcopenshell.open(ifc_path)
    assert len(f.by_type("IfcWall")) == n_walls
    assert len([s for s in f.by_type("IfcSpace")]) >= n_rooms
    # a second run replaces the model instead of adding to it
    n_objects = len(bpy.data.objects)
    assert bpy.ops.indoor.reconstruct(method="manhattan", seed=0) == {"FINISHED"}
    assert len(bpy.data.objects) == n_objects
    assert sorted(o.name for o in colls["Spaces"].objects) == sorted(
        s.name or s.id for s in model.shapes if s.active and s.type.value == "interior")


def test_reconstruct_failure_reports_and_leaves_scene_unchanged(scene, addon, rng):
    eng = bu.engine_module()
    flat = np.column_stack([rng.uniform(0, 5, 3000), rng.uniform(0, 5, 3000), np.zeros(3000)])
    obj = addon.bridge.point_cloud_to_object(eng.PointCloud(xyz=flat), name="floor_only")
    bpy.context.view_layer.objects.active = obj
    before = bu.scene_state()
    with pytest.raises(RuntimeError, match="floor_only"):
        bpy.ops.indoor.reconstruct(method="manhattan")
    assert bu.scene_state() == before
    assert "Indoor Model.json" not in bpy.data.texts
    assert not bpy.ops.indoor.export_ifc.poll()  # nothing to export


def test_import_of_a_bad_count_and_a_bug_are_one_line_reports(scene, tmp_path, monkeypatch):
    """A PLY with a negative count, and any exception that is not the engine's own (a bug),
    are one-line reports naming the file and the kind of error — never a traceback — and the
    scene stays as it was."""
    bad = tmp_path / "neg.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex -5\nproperty float x\n"
                    b"property float y\nproperty float z\nend_header\n" + b"\0" * 60)
    before = bu.scene_state()
    with pytest.raises(RuntimeError) as e:
        bpy.ops.indoor.import_scan(filepath=str(bad))
    msg = str(e.value)
    assert "neg.ply: input error" in msg and "negative" in msg and "Traceback" not in msg
    assert len(msg.strip().splitlines()) == 1
    assert bu.scene_state() == before
    def boom(*a, **k):
        raise ZeroDivisionError("float division by zero")

    # the engine's reader, as the Import operator calls it, raises a bug
    monkeypatch.setattr(bu.addon_module().operators.scan, "read_point_cloud", boom)
    with pytest.raises(RuntimeError) as e:
        bpy.ops.indoor.import_scan(filepath=str(bad))
    msg = str(e.value)
    assert "internal error: ZeroDivisionError" in msg and "Traceback" not in msg
    assert bu.scene_state() == before


def test_import_with_the_engines_frame_record_applies_it_without_checks(scene, tmp_path, rng):
    """scripts/batch.py passes the engine's frame record of the file it converted: the import
    applies that scale and rotation (the same points as detecting them) and skips the checks;
    a malformed record is a report and leaves the scene as it was."""
    u = rng.uniform(0, 1, (400, 2))  # a room's six faces, 5 x 3 x 4 m in millimetres, y up
    face = np.arange(400) % 6
    size = np.array([5000.0, 3000.0, 4000.0])
    xyz = np.zeros((400, 3))
    for k in range(6):
        a, (b, c) = k // 2, [d for d in range(3) if d != k // 2]
        m = face == k
        xyz[m, a] = size[a] * (k % 2)
        xyz[m, b], xyz[m, c] = u[m, 0] * size[b], u[m, 1] * size[c]
    path = str(tmp_path / "mm.ply")
    bu.write_binary_ply(path, xyz)
    assert bpy.ops.indoor.import_scan(filepath=path, units="mm", up_axis="y") == {"FINISHED"}
    first = bpy.context.view_layer.objects.active
    record = first["indoor_frame"]
    assert bpy.ops.indoor.import_scan(filepath=path, frame_record=record) == {"FINISHED"}
    second = bpy.context.view_layer.objects.active
    assert second != first and second["indoor_frame"] == record
    a, b = (np.empty(400 * 3, np.float32) for _ in range(2))
    first.data.vertices.foreach_get("co", a)
    second.data.vertices.foreach_get("co", b)
    np.testing.assert_array_equal(a, b)
    assert np.ptp(b.reshape(-1, 3)[:, 2]) < 5.1 and np.ptp(b.reshape(-1, 3)[:, 1]) < 5.1  # metres, z up
    before = bu.scene_state()
    with pytest.raises(RuntimeError) as info:
        bpy.ops.indoor.import_scan(filepath=path, frame_record="{not json")
    assert "mm.ply" in str(info.value) and "Traceback" not in str(info.value)
    assert bu.scene_state() == before
