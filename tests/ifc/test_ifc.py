"""IFC writer and reader: write hand-built models, validate, re-open, tessellate, read back."""
import os

import numpy as np
import pytest

pytest.importorskip("ifcopenshell")
import ifcopenshell.geom  # noqa: E402
import ifcopenshell.util.element  # noqa: E402
import ifcopenshell.validate  # noqa: E402

from engine import (BuildingModel, Cancelled, FormatError, InputError, Polyhedron, Provenance,  # noqa: E402
                    Relation, Shape, Storey)
from engine.ifc import IfcWriteParams, read_ifc, read_mesh, read_reference, write_ifc  # noqa: E402
from engine.topology import space_graph  # noqa: E402

H = 2.6  # storey height of the hand-built models, m
T = 0.2  # wall thickness, m


def _wall(i, x0, y0, x1, y1, z0=0.0, z1=H, storey=0):
    return Shape(f"w{i}", "wall", Polyhedron.box((x0, y0, z0), (x1, y1, z1)), name=f"Wall {i}", terminal=True,
                 storey=storey, attributes={"thickness": T})


def hand_model(transform=None, offset=(0.0, 0.0, 0.0)) -> BuildingModel:
    """Two rooms and a corridor; room 2 is merged from two parts; a door between room 1 and the
    corridor; a non-prism (sloped) exterior shape; walls all round.

    Plan (metres):  y 0..4: room 1 (x 0..4), room 2 (x 4.2..9, parts x 4.2..6.5 and 6.5..9);
                    y 4.2..6: corridor (x 0..9). Walls 0.2 thick between and around.
    """
    r1 = Shape("r1", "interior", Polyhedron.box((0, 0, 0), (4, 4, H)), name="Room 1", terminal=True,
               support={"ipof_top": 0.93, "coverage": 0.81}, log=("split x", "interior: ipof 0.93"))
    p1 = Shape("r2a", "interior", Polyhedron.box((4.2, 0, 0), (6.5, 4, H)), active=False, parent="r2")
    p2 = Shape("r2b", "interior", Polyhedron.box((6.5, 0, 0), (9, 4, H)), name="", active=False, parent="r2")
    r2 = Shape("r2", "interior", Polyhedron.box((4.2, 0, 0), (9, 4, H)), name="Room 2",
               children=("r2a", "r2b"), support={"ipof_top": 0.88})
    # corridor: an L-shaped prism (non-rectangular footprint)
    cor = Shape("c", "interior", Polyhedron.prism([(0, 4.2), (9, 4.2), (9, 6), (3, 6), (3, 7), (0, 7)], 0, H),
                name="Corridor")
    walls = [
        _wall(1, 4, 0, 4.2, 4),        # room 1 | room 2
        _wall(2, 0, 4, 9, 4.2),        # rooms | corridor
        _wall(3, -T, -T, 9 + T, 0),    # south
        _wall(4, 9, 0, 9 + T, 6),      # east
        _wall(5, -T, 0, 0, 7),         # west
    ]
    door = Shape("d1", "door", Polyhedron.box((1.0, 4.0, 0.0), (1.9, 4.2, 2.0)), name="Door 1", parent="w2",
                 attributes={"width": 0.9, "height": 2.0})
    walls[1] = walls[1].with_(children=("d1",))
    floor = Shape("s0", "slab", Polyhedron.box((-T, -T, -0.3), (9 + T, 7, 0)), name="Floor slab")
    ceil = Shape("s1", "slab", Polyhedron.box((-T, -T, H), (9 + T, 7, H + 0.3)), name="Ceiling slab")
    # exterior: a sloped (non-prism) wedge north-east of the corridor
    v = np.array([[3, 6.2, 0], [9, 6.2, 0], [9, 9, 0], [3, 9, 0], [3, 6.2, H], [9, 6.2, H]], dtype=float)
    faces = [(0, 3, 2, 1), (0, 1, 5, 4), (1, 2, 5), (0, 4, 3), (2, 3, 4, 5)]
    ext = Shape("x", "exterior", Polyhedron(v, faces), name="Outside")
    shapes = (r1, p1, p2, r2, cor, *walls, door, floor, ceil, ext)
    rel = [
        Relation("adjacency", "r1", "r2", via="w1"),
        Relation("adjacency", "r1", "c", via="w2"),
        Relation("adjacency", "r2", "c", via="w2"),
        Relation("connectivity", "r1", "c", via="d1"),
        Relation("adjacency", "r2a", "r2b"),
        Relation("connectivity", "r2a", "r2b"),
    ]
    m = BuildingModel(shapes=shapes, storeys=(Storey(0, 0.0, H, "Ground floor", 0.0),), relations=rel,
                      provenance=Provenance("manhattan", {"eps": 0.05}, 7, {"total": 1.5}),
                      name="hand")
    if transform is not None:
        m = m.with_(transform=transform, offset=np.asarray(offset, dtype=float))
    return m


def rot_z(deg, t=(0, 0, 0)):
    a = np.deg2rad(deg)
    m = np.eye(4)
    m[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    m[:3, 3] = t
    return m


def validate(path):
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(path, logger)
    return [s for s in logger.statements if str(s.get("level", "")).lower() in ("error", "40")]


def _errors(path, express_rules=False):
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(path, logger, express_rules=express_rules)
    return [s for s in logger.statements if s.get("level") == "error"]


def _footprint_iou(a, b):
    from shapely.geometry import Polygon

    pa, pb = Polygon(a), Polygon(b)
    return pa.intersection(pb).area / pa.union(pb).area


LOSSLESS = IfcWriteParams(parts=True)
"""Parts of merged spaces included: the file reads back as the model."""


def _rels(model):
    return sorted((r.kind, r.a, r.b, r.via) for r in model.relations)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The hand model rotated by 30° with a georeferencing-size offset, written once with the
    parts of merged spaces (the lossless file the round-trip tests read back)."""
    m = hand_model(rot_z(30, (5, -3, 0.5)), offset=(2.5e6, 5.6e6, 120.0))
    path = str(tmp_path_factory.mktemp("ifc") / "hand.ifc")
    assert write_ifc(m, path, params=LOSSLESS) == path
    return m, path


def test_written_file_validates_with_express_rules(written):
    _, path = written
    assert _errors(path, express_rules=True) == []


def test_spatial_tree_containment_and_elements(written):
    m, path = written
    f = ifcopenshell.open(path)
    assert f.schema == "IFC4"
    ue = ifcopenshell.util.element
    (project,) = f.by_type("IfcProject")
    units = {u.UnitType: (u.Prefix, u.Name) for u in project.UnitsInContext.Units}
    assert units["LENGTHUNIT"] == (None, "METRE") and units["AREAUNIT"] == (None, "SQUARE_METRE")
    ctx = {(c.ContextIdentifier, c.TargetView) for c in f.by_type("IfcGeometricRepresentationSubContext")}
    assert {("Body", "MODEL_VIEW"), ("Axis", "GRAPH_VIEW"), ("FootPrint", "SKETCH_VIEW")} <= ctx
    (site,) = f.by_type("IfcSite")
    (building,) = f.by_type("IfcBuilding")
    (storey,) = f.by_type("IfcBuildingStorey")
    assert ue.get_aggregate(site) == project and ue.get_aggregate(building) == site
    assert ue.get_aggregate(storey) == building and storey.Elevation == pytest.approx(0.0)
    loc = site.ObjectPlacement.RelativePlacement.Location.Coordinates
    assert np.allclose(loc, [2.5e6 + 5, 5.6e6 - 3, 120.5])
    spaces = {ue.get_psets(s)["Indoor_Shape"]["ShapeId"]: s for s in f.by_type("IfcSpace")}
    assert set(spaces) == {"r1", "r2", "r2a", "r2b", "c"}
    for sid in ("r1", "r2", "c"):
        assert ue.get_aggregate(spaces[sid]) == storey and spaces[sid].CompositionType == "ELEMENT"
    for sid in ("r2a", "r2b"):  # the merged space aggregates its parts
        assert ue.get_aggregate(spaces[sid]) == spaces["r2"] and spaces[sid].CompositionType == "PARTIAL"
    (ext,) = f.by_type("IfcExternalSpatialElement")
    assert ue.get_aggregate(ext) == storey
    walls = f.by_type("IfcWall")
    assert len(walls) == 5 and all(ue.get_container(w) == storey for w in walls)
    assert {w.Representation.Representations[0].RepresentationType for w in walls} == {"SweptSolid"}
    assert ext.Representation.Representations[0].RepresentationType == "Brep"
    slabs = {s.Name: s.PredefinedType for s in f.by_type("IfcSlab")}
    assert slabs == {"Floor slab": "BASESLAB", "Ceiling slab": "ROOF"}
    (door,) = f.by_type("IfcDoor")
    assert ue.get_container(door) == storey
    assert (door.OverallWidth, door.OverallHeight) == (pytest.approx(0.9), pytest.approx(2.0))
    (opening,) = f.by_type("IfcOpeningElement")
    assert door.FillsVoids[0].RelatingOpeningElement == opening
    assert opening.VoidsElements[0].RelatingBuildingElement.Name == "Wall 2"
    # provenance, support and quantities
    prov = ue.get_psets(project)["Indoor_Provenance"]
    assert prov["Method"] == "manhattan" and prov["Seed"] == 7 and '"eps":0.05' in prov["Parameters"]
    r1 = ue.get_psets(spaces["r1"])
    assert r1["Indoor_Support"]["ipof_top"] == pytest.approx(0.93)
    assert r1["Indoor_Support"]["coverage"] == pytest.approx(0.81)
    q = ue.get_psets(spaces["c"], qtos_only=True)["Qto_SpaceBaseQuantities"]
    assert q["NetFloorArea"] == pytest.approx(9 * 1.8 + 3 * 1.0)
    assert q["Height"] == pytest.approx(H) and q["GrossVolume"] == pytest.approx((9 * 1.8 + 3) * H)
    qw = ue.get_psets(walls[1], qtos_only=True)["Qto_WallBaseQuantities"]
    assert qw["Width"] == pytest.approx(T)
    # styles: one colour per type
    assert len(f.by_type("IfcSurfaceStyle")) == 5


def test_space_boundaries_pair_up_and_doors_connect_spaces(written):
    m, path = written
    f = ifcopenshell.open(path)
    ue = ifcopenshell.util.element

    def sid(e):
        return ue.get_psets(e).get("Indoor_Shape", {}).get("ShapeId")

    pairs = set()
    for b in f.by_type("IfcRelSpaceBoundary"):
        assert b.RelatingSpace is not None and b.RelatedBuildingElement is not None
        assert b.PhysicalOrVirtualBoundary in ("PHYSICAL", "VIRTUAL")
        if b.CorrespondingBoundary is not None:
            assert b.CorrespondingBoundary.CorrespondingBoundary == b
            pairs.add((tuple(sorted((sid(b.RelatingSpace), sid(b.CorrespondingBoundary.RelatingSpace)))),
                       b.RelatedBuildingElement.is_a(), sid(b.RelatedBuildingElement)))
    assert pairs == {(("r1", "r2"), "IfcWall", "w1"), (("c", "r1"), "IfcWall", "w2"),
                     (("c", "r2"), "IfcWall", "w2"), (("c", "r1"), "IfcDoor", "d1"),
                     (("r2a", "r2b"), "IfcVirtualElement", "open:r2a|r2b")}
    # the door's boundaries have a connection surface the size of the door (0.9 x 2.0 m)
    from shapely.geometry import Polygon

    import ifcopenshell.util.placement as up

    door = m["d1"].geometry
    for b in f.by_type("IfcRelSpaceBoundary"):
        if b.RelatedBuildingElement.is_a("IfcDoor"):
            plane = b.ConnectionGeometry.SurfaceOnRelatingElement
            pts = np.array([p.Coordinates for p in plane.OuterBoundary.Points])
            assert Polygon(pts).area == pytest.approx(1.8)
            # placed relative to the space: in world coordinates it lies on a face of the door
            world = up.get_local_placement(b.RelatingSpace.ObjectPlacement) @ \
                up.get_axis2placement(plane.BasisSurface.Position)
            q = np.column_stack([pts[:, :2], np.zeros(len(pts)), np.ones(len(pts))]) @ world.T
            homog = np.vstack([(q[:, :3] - m.offset).T, np.ones(len(q))])
            local = np.linalg.solve(m.transform, homog).T[:, :3]  # back to the model frame
            lo, hi = door.bounds
            assert np.all(local >= lo - 1e-6) and np.all(local <= hi + 1e-6)
            assert np.ptp(local[:, 1]) < 1e-6 and local[0, 1] in (pytest.approx(4.0), pytest.approx(4.2))
    # one-sided boundaries: room 1 touches the south and west walls and both slabs
    one_sided = {(sid(b.RelatingSpace), sid(b.RelatedBuildingElement))
                 for b in f.by_type("IfcRelSpaceBoundary") if b.CorrespondingBoundary is None}
    assert {("r1", "w3"), ("r1", "w5"), ("r1", "s0"), ("r1", "s1")} <= one_sided
    assert ("r1", "w4") not in one_sided


def test_tessellates_in_original_frame(written):
    m, path = written
    f = ifcopenshell.open(path)
    s = ifcopenshell.geom.settings()
    s.set("use-world-coords", True)
    products = f.by_type("IfcWall") + f.by_type("IfcSlab") + f.by_type("IfcSpace") + f.by_type("IfcDoor") + \
        f.by_type("IfcExternalSpatialElement")
    got = {}
    it = ifcopenshell.geom.iterator(s, f, 1, include=products)
    assert it.initialize()
    while True:
        sh = it.get()
        got[sh.id] = np.asarray(sh.geometry.verts).reshape(-1, 3)
        if not it.next():
            break
    assert len(got) == len(products)
    ue = ifcopenshell.util.element
    for e in products:
        shape = m[ue.get_psets(e)["Indoor_Shape"]["ShapeId"]]
        want = m.to_input_frame(shape.geometry.vertices, include_offset=True)
        v = got[e.id()]
        assert np.allclose(v.min(axis=0), want.min(axis=0), atol=1e-6)
        assert np.allclose(v.max(axis=0), want.max(axis=0), atol=1e-6)


def test_round_trip_footprints_relations_and_attributes(written):
    m, path = written
    r = read_ifc(path)
    assert r.summary() == m.summary()
    assert np.allclose(r.transform, m.transform) and np.allclose(r.offset, m.offset)
    assert [(s.floor_z, s.ceiling_z, s.name) for s in r.storeys] == [(0.0, H, "Ground floor")]
    for s in m.shapes:
        got = r[s.id]
        assert got.type == s.type and got.storey == s.storey and got.active == s.active
        assert got.parent == s.parent and set(got.children) == set(s.children)
        assert np.allclose(got.bounds, s.bounds, atol=1e-6)
        assert got.geometry.volume() == pytest.approx(s.geometry.volume(), rel=1e-6) or s.type.value == "wall"
        fp = s.footprint()
        if s.is_space and fp is not None:
            assert _footprint_iou(got.footprint(), fp) >= 0.99
    assert r["r1"].support == pytest.approx(m["r1"].support)
    assert r["r1"].log == m["r1"].log
    assert r["d1"].attributes["width"] == pytest.approx(0.9)
    assert r["w2"].attributes["thickness"] == pytest.approx(T)
    assert _rels(r) == _rels(m)
    # the wall with the door is a mesh with a hole: its volume lost the door's 0.9 x 0.2 x 2.0
    assert r["w2"].geometry.volume() == pytest.approx(9 * T * H - 0.9 * T * 2.0, rel=1e-6)
    assert r.provenance.method == "manhattan" and r.provenance.seed == 7
    assert r.provenance.parameters == {"eps": 0.05}
    assert space_graph(r, "connectivity").has_edge("r1", "c")


def test_identity_frame_ifc4x3_and_non_rigid_transform(tmp_path):
    m = hand_model()
    p4x3 = str(tmp_path / "hand4x3.ifc")
    write_ifc(m, p4x3, schema="IFC4X3", params=LOSSLESS)
    assert ifcopenshell.open(p4x3).schema.upper().startswith("IFC4X3")
    assert _errors(p4x3) == []
    r = read_ifc(p4x3)
    assert _rels(r) == _rels(m)
    assert _footprint_iou(r["c"].footprint(), m["c"].footprint()) >= 0.99
    # a scaled (non-rigid) transform is baked into the vertices and undone on reading
    s = np.diag([1.5, 1.5, 1.0, 1.0])
    ms = m.with_(transform=s)
    ps = str(tmp_path / "scaled.ifc")
    write_ifc(ms, ps, params=LOSSLESS)
    assert _errors(ps) == []
    rs = read_ifc(ps)
    assert np.allclose(rs["r1"].bounds, m["r1"].bounds, atol=1e-6)
    f = ifcopenshell.open(ps)
    s_ = ifcopenshell.geom.settings()
    s_.set("use-world-coords", True)
    wall = [w for w in f.by_type("IfcWall") if w.Name == "Wall 3"][0]
    v = np.asarray(ifcopenshell.geom.create_shape(s_, wall).geometry.verts).reshape(-1, 3)
    assert v[:, 0].max() == pytest.approx(1.5 * (9 + T))


def test_write_is_atomic_and_rejects_bad_requests(tmp_path):
    m = hand_model()
    path = tmp_path / "out.ifc"
    path.write_text("old")
    with pytest.raises(InputError, match="IFC2X3"):
        write_ifc(m, path, schema="IFC2X3")
    with pytest.raises(InputError, match="no shapes"):
        write_ifc(BuildingModel(), path)
    assert path.read_text() == "old"
    write_ifc(m, path)
    assert path.read_text().startswith("ISO-10303-21")
    assert [p.name for p in tmp_path.iterdir()] == ["out.ifc"]  # no temporary file left


def test_reader_unit_scale_and_storey_elevation_in_millimetres(tmp_path):
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.geometry
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial
    import ifcopenshell.api.unit

    api = ifcopenshell.api
    f = api.project.create_file("IFC4")
    project = api.root.create_entity(f, ifc_class="IfcProject", name="mm")
    api.unit.assign_unit(f)  # millimetres
    model = api.context.add_context(f, context_type="Model")
    body = api.context.add_context(f, context_type="Model", context_identifier="Body",
                                   target_view="MODEL_VIEW", parent=model)
    site = api.root.create_entity(f, ifc_class="IfcSite")
    building = api.root.create_entity(f, ifc_class="IfcBuilding")
    api.aggregate.assign_object(f, products=[site], relating_object=project)
    api.aggregate.assign_object(f, products=[building], relating_object=site)
    storeys = []
    for name, z in (("upper", 3000.0), ("ground", 0.0)):
        st = api.root.create_entity(f, ifc_class="IfcBuildingStorey", name=name)
        st.Elevation = z
        api.aggregate.assign_object(f, products=[st], relating_object=building)
        m = np.eye(4)
        m[2, 3] = z / 1000
        api.geometry.edit_object_placement(f, product=st, matrix=m)
        storeys.append(st)
    wall = api.root.create_entity(f, ifc_class="IfcWall", name="W")
    api.spatial.assign_container(f, products=[wall], relating_structure=storeys[0])
    m = np.eye(4)
    m[:3, 3] = (1.0, 2.0, 3.0)
    api.geometry.edit_object_placement(f, product=wall, matrix=m)
    rep = api.geometry.add_wall_representation(f, context=body, length=5.0, height=2.5, thickness=0.25)
    api.geometry.assign_representation(f, product=wall, representation=rep)
    path = str(tmp_path / "mm.ifc")
    f.write(path)
    r = read_ifc(path)
    got = [(s.name, s.floor_z, s.elevation) for s in r.storeys]
    assert got == [("ground", 0.0, 0.0), ("upper", 3.0, 3.0)]
    (w,) = r.walls
    assert w.storey == 1
    assert np.allclose(w.bounds, [[1.0, 2.0, 3.0], [6.0, 2.25, 5.5]], atol=1e-6)
    assert w.footprint() is not None  # the tessellated prism is recognised


def test_bad_input_gives_clear_errors(tmp_path):
    missing = tmp_path / "missing.ifc"
    with pytest.raises(InputError, match="missing.ifc: file not found"):
        read_ifc(missing)
    txt = tmp_path / "notes.ifc"
    txt.write_text("hello, not an IFC\n")
    with pytest.raises(FormatError, match="notes.ifc: not an IFC file"):
        read_ifc(txt)
    header = ("ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('','',(''),(''),'','','');\n"
              "FILE_SCHEMA(('{}'));\nENDSEC;\nDATA;\n{}ENDSEC;\nEND-ISO-10303-21;\n")
    ifc5 = tmp_path / "future.ifc"
    ifc5.write_text(header.format("IFC5", ""))
    with pytest.raises(FormatError, match="future.ifc: unsupported IFC schema 'IFC5'"):
        read_ifc(ifc5)
    nostorey = tmp_path / "nostorey.ifc"
    nostorey.write_text(header.format("IFC4", "#1=IFCPROJECT('0YvctVUKr0kugbFTf53O9L',$,'p',$,$,$,$,$,$);\n"))
    with pytest.raises(InputError, match="nostorey.ifc: the IFC file has no storeys"):
        read_ifc(nostorey)
    broken = tmp_path / "broken.ifc"
    broken.write_text(header.format("IFC4", "#1=IFCPROJECT('0YvctVUKr0kugbFTf53O9L',$,'p';;garbage\n"))
    with pytest.raises(InputError, match="broken.ifc"):
        read_ifc(broken)
    other = tmp_path / "model.txt"
    other.write_text("x")
    with pytest.raises(InputError, match="model.txt: unknown reference format"):
        read_reference(other)


def test_read_mesh_obj_and_ply(tmp_path):
    import trimesh

    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(4, 0.2, 2.5)), node_name="wall_a", geom_name="wall_a")
    room = trimesh.creation.box(extents=(4, 3, 2.5))
    room.apply_translation((0, 1.6, 0))
    scene.add_geometry(room, node_name="room_1", geom_name="room_1")
    obj = tmp_path / "ref.obj"
    scene.export(str(obj))
    m = read_reference(obj)
    kinds = sorted(s.type.value for s in m.shapes)
    assert kinds == ["interior", "wall"]
    surf = m.surfaces(types=("interior",))
    assert sum(s.area for s in surf if s.kind == "floor") == pytest.approx(12.0)
    assert sum(s.area for s in surf if s.kind == "wall") == pytest.approx(2 * (4 + 3) * 2.5)
    ply = tmp_path / "ref.ply"
    room.export(str(ply))
    (s,) = read_mesh(ply).shapes
    assert s.geometry.volume() == pytest.approx(30.0)
    cloud = tmp_path / "cloud.ply"
    trimesh.PointCloud(np.random.default_rng(0).random((50, 3))).export(str(cloud))
    with pytest.raises(FormatError, match="cloud.ply: the file holds no triangles"):
        read_mesh(cloud)


def test_real_fzk_haus(data_dir):
    m = read_ifc(os.path.join(data_dir, "AC20-FZK-Haus.ifc"))
    assert [s.name for s in m.storeys] == ["Erdgeschoss", "Dachgeschoss"]
    assert [s.floor_z for s in m.storeys] == pytest.approx([0.0, 2.7])
    assert len(m.spaces) == 7 and len(m.walls) == 13 and len(m.doors) == 5
    assert sorted(s.storey for s in m.spaces) == [0, 0, 0, 0, 0, 0, 1]
    assert sorted(w.storey for w in m.walls) == [0] * 9 + [1] * 4
    assert all(d.storey == 0 and d.parent in {w.id for w in m.walls} for d in m.doors)
    # the three inner doors join the hall to three rooms (the two outer doors bound one space);
    # the open kitchen/living boundaries are virtual (connectivity without a door)
    conn = m.relations_of("connectivity")
    doors = {d.id for d in m.doors}
    names = {s.id: s.name for s in m.spaces}
    by_door = sorted(tuple(sorted((names[r.a], names[r.b]))) for r in conn if r.via in doors)
    assert by_door == [("Bad", "Flur"), ("Buero", "Flur"), ("Flur", "Schlafzimmer")]
    assert all(r.via in doors or r.via is None for r in conn)
    assert nx_connected(space_graph(m, "connectivity", include_exterior=True), min_nodes=5)
    # wall surfaces are there for the evaluation, in metres
    walls = m.surfaces(types=("wall",))
    assert 200 < sum(s.area for s in walls) < 600
    b = np.array([s.bounds for s in m.shapes])
    assert b[:, 0].min(axis=0)[2] > -1.0 and b[:, 1].max(axis=0)[2] < 10.0


def nx_connected(g, min_nodes):
    import networkx as nx

    largest = max(nx.connected_components(g), key=len)
    return len(largest) >= min_nodes


def test_real_duplex_ifc2x3(data_dir):
    m = read_ifc(os.path.join(data_dir, "Duplex_A_20110907_architecture.ifc"))
    assert [s.name for s in m.storeys] == ["T/FDN", "Level 1", "Level 2", "Roof"]
    assert [s.floor_z for s in m.storeys] == pytest.approx([-1.25, 0.0, 3.1, 6.0])
    assert len(m.spaces) == 21 and len(m.walls) == 57 and len(m.doors) == 14
    assert sorted({s.storey for s in m.spaces}) == [1, 2, 3]
    assert sum(1 for s in m.spaces if s.storey in (1, 2)) == 20
    conn = m.relations_of("connectivity")
    assert len(conn) >= 10 and all(r.via in {d.id for d in m.doors} for r in conn)
    # the two flats are mirror images: floor area of level 1 and level 2 spaces are similar
    area = [sum(s.area for s in m.surfaces() if s.kind == "floor" and s.storey == k) for k in (1, 2)]
    assert area[0] > 50 and area[1] > 50


def test_model_without_storeys_and_odd_shapes(tmp_path):
    m = hand_model()
    extra = (
        Shape("n", "none", Polyhedron.box((20, 0, 0), (21, 1, 1))),                   # ignored
        Shape("wx", "wall", Polyhedron.box((30, 0, 0), (31, 0.2, 3)), storey=-1),     # in no storey
        Shape("wi", "wall", Polyhedron.box((0, 0, 0), (1, 0.2, 1)), active=False),    # merged-away part
        Shape("flat", "slab", Polyhedron(np.zeros((3, 3)), [(0, 1, 2)])),             # no volume
    )
    m = m.with_(shapes=m.shapes + extra, storeys=())
    path = str(tmp_path / "nostoreys.ifc")
    write_ifc(m, path)
    assert _errors(path) == []
    f = ifcopenshell.open(path)
    ue = ifcopenshell.util.element
    (storey,) = f.by_type("IfcBuildingStorey")
    assert storey.Elevation == pytest.approx(-0.3)  # spans the floor slab to the ceiling slab
    names = {w.Name: ue.get_container(w).is_a() for w in f.by_type("IfcWall")}
    assert names["wx"] == "IfcBuilding" and "wi" not in names and len(names) == 6
    assert len(f.by_type("IfcSlab")) == 2
    r = read_ifc(path)
    assert len(r.storeys) == 1 and r["wx"].storey == -1 and r["w1"].storey == 0
    assert "n" not in r and "wi" not in r and "flat" not in r


def test_offset_as_map_conversion(tmp_path):
    m = hand_model(rot_z(-15, (1, 2, 0)), offset=(4.5e5, 5.4e6, 35.0))
    path = str(tmp_path / "geo.ifc")
    write_ifc(m, path, params=IfcWriteParams(georeference="map_conversion", crs_name="EPSG:25832", parts=True))
    assert _errors(path) == []
    f = ifcopenshell.open(path)
    (mc,) = f.by_type("IfcMapConversion")
    assert (mc.Eastings, mc.Northings, mc.OrthogonalHeight) == (4.5e5, 5.4e6, 35.0)
    assert mc.TargetCRS.Name == "EPSG:25832"
    (site,) = f.by_type("IfcSite")
    assert np.allclose(site.ObjectPlacement.RelativePlacement.Location.Coordinates, [1, 2, 0])
    r = read_ifc(path)
    assert np.allclose(r.offset, m.offset) and np.allclose(r.transform, m.transform)
    assert np.allclose(r["r1"].bounds, m["r1"].bounds, atol=1e-6)
    assert _rels(r) == _rels(m)
    with pytest.raises(InputError, match="georeference"):
        write_ifc(m, str(tmp_path / "x.ifc"), params=IfcWriteParams(georeference="somewhere"))


def test_progress_and_cancel(tmp_path):
    m = hand_model()
    path = tmp_path / "p.ifc"
    seen = []
    write_ifc(m, path, progress=lambda f, msg: seen.append(f))
    assert seen == sorted(seen) and seen[-1] == pytest.approx(1.0)
    seen.clear()
    read_ifc(path, progress=lambda f, msg: seen.append(f))
    assert seen == sorted(seen) and seen[-1] == pytest.approx(1.0)
    calls = []

    def stop_after_a_while():
        calls.append(1)
        return len(calls) > 3

    out = tmp_path / "cancelled.ifc"
    with pytest.raises(Cancelled):
        write_ifc(m, out, should_stop=stop_after_a_while)
    assert not out.exists()
    with pytest.raises(Cancelled):
        read_ifc(path, should_stop=lambda: True)


def test_by_default_one_ifcspace_per_room(tmp_path):
    """Area schedules list IfcSpace: the merged room r2 is one space, its parts r2a and r2b are
    not written (they are with ``parts=True``), and the file still validates."""
    m = hand_model()
    path = str(tmp_path / "rooms.ifc")
    write_ifc(m, path)
    assert _errors(path, express_rules=True) == []
    f = ifcopenshell.open(path)
    rooms = {s.Name for s in f.by_type("IfcSpace")}
    assert rooms == {m[s.id].name or s.id for s in m.spaces} and len(rooms) == len(m.spaces)
    assert not [s for s in f.by_type("IfcSpace") if s.CompositionType == "PARTIAL"]
    lossless = str(tmp_path / "parts.ifc")
    write_ifc(m, lossless, params=LOSSLESS)
    assert len(ifcopenshell.open(lossless).by_type("IfcSpace")) > len(rooms)


_PRELOAD = """
import sys, threading
sys.path.insert(0, {root!r})
if {missing}:
    sys.modules["ifcopenshell"] = None  # not installed
from engine.ifc import common
common.preload_writer_modules()
common.preload_writer_modules()  # once per process
threads = [t for t in threading.enumerate() if t.name == "ifc-preload"]
assert len(common._preloading) == 1 and len(threads) <= 1
common._preloading[0].join(60)
loaded = [m for m in common.WRITER_MODULES if sys.modules.get(m) is not None]
print(len(loaded), len(common.WRITER_MODULES))
if {missing}:
    from engine.errors import MissingDependencyError
    from engine.ifc import write_ifc
    try:
        write_ifc(None, "x.ifc")
    except MissingDependencyError as e:
        print("missing:", e)
"""


@pytest.mark.parametrize("missing", [False, True])
def test_writer_modules_preload_in_the_background_once(tmp_path, missing):
    """A convert that writes an IFC starts importing ifcopenshell while it reconstructs; a
    missing ifcopenshell is still reported by the writer, not by the background thread."""
    import subprocess
    import sys

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    proc = subprocess.run([sys.executable, "-c", _PRELOAD.format(root=root, missing=missing)],
                          cwd=str(tmp_path), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.split("\n")
    n, total = map(int, lines[0].split())
    if missing:
        assert n == 0 and "missing:" in proc.stdout and "ifcopenshell" in lines[1]
        assert "Traceback" not in proc.stderr
    else:
        assert n == total == 7
