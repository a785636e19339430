"""The building elements of the IFC writer, as an architect's tool reads them: walls on their
axes with material layers, types and joins, slabs, doors and windows in their openings, a
doorless opening, one exterior element per storey, second-level space boundaries with the
fillings inside their wall's boundary; validated with EXPRESS rules and read back."""
import re

import numpy as np
import pytest

pytest.importorskip("ifcopenshell")
import ifcopenshell  # noqa: E402
import ifcopenshell.util.element as ue  # noqa: E402
import ifcopenshell.util.placement as up  # noqa: E402
import ifcopenshell.validate  # noqa: E402
from shapely.geometry import Polygon  # noqa: E402

from engine import BuildingModel, Polyhedron, Provenance, Relation, Shape, Storey, synthetic  # noqa: E402
from engine.ifc import build_ifc, read_ifc, write_ifc  # noqa: E402
from engine.ifc.writer_geometry import slab_type  # noqa: E402

H = 2.6  # storey height, m
TI, TE = 0.2, 0.3  # interior / exterior wall thickness, m


def _wall(wid, x0, y0, x1, y1, axis, sides, external, joins=()):
    t = TE if external else TI
    fp = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return Shape(wid, "wall", Polyhedron.prism(fp, 0.0, H), name=wid, terminal=True, storey=0,
                 attributes={"thickness": t, "height": H, "external": external, "thickness_measured": True,
                             "axis_line": [list(axis[0]), list(axis[1])], "sides": list(sides),
                             "joins": [dict(wall=w, at=a, other_at=o) for w, a, o in joins]})


def _opening(oid, kind, wall, x0, y0, x1, y1, sill, height, width, spaces, **extra):
    stype = "window" if kind == "window" else "door"
    fp = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return Shape(oid, stype, Polyhedron.prism(fp, sill, sill + height), name=oid, terminal=True, parent=wall,
                 storey=0, attributes={"width": width, "height": height, "sill": sill, "kind": kind,
                                       "spaces": list(spaces), "confidence": 0.9, **extra},
                 support={"points_beyond": 120.0, "floor_points": 40.0})


def element_model() -> BuildingModel:
    """Two rooms A (x 0..4) and B (x 4.2..8), y 0..4, 2.6 m high, on one storey.

    Walls: ``w1`` between the rooms (0.2 m; a door ``d1`` and a doorless opening ``d3``),
    exterior walls 0.3 m per room side (``wSA``, ``wSB`` south, ``wNA``, ``wNB`` north, ``wW``
    west, ``wE`` east); an exterior door ``d2`` in ``wSB``, windows ``win1`` (``wW``) and
    ``win2`` (``wNB``), both 1.2 × 1.2 m; a floor and a roof slab. The outside is two shapes:
    ``exterior_s0`` (a U round the south, west and east) and ``x_north``.
    """
    a = Shape("A", "interior", Polyhedron.box((0, 0, 0), (4, 4, H)), name="Room A", terminal=True)
    b = Shape("B", "interior", Polyhedron.box((4.2, 0, 0), (8, 4, H)), name="Room B", terminal=True)
    ext = Shape("exterior_s0", "exterior",
                Polyhedron.prism([(-3, -3), (11.3, -3), (11.3, 4.3), (8.3, 4.3), (8.3, -0.3), (-0.3, -0.3),
                                  (-0.3, 4.3), (-3, 4.3)], 0.0, H), name="Outside")
    north = Shape("x_north", "exterior", Polyhedron.box((-3, 4.3, 0), (11.3, 7, H)), name="Outside north")
    walls = [
        _wall("w1", 4.0, 0.0, 4.2, 4.0, [(4.1, 0.0), (4.1, 4.0)], ["A", "B"], False,
              [("wSA", "ATSTART", "ATEND"), ("wNA", "ATEND", "ATSTART")]),
        _wall("wSA", -0.3, -0.3, 4.1, 0.0, [(-0.3, -0.15), (4.1, -0.15)], ["A", "exterior_s0"], True,
              [("wSB", "ATEND", "ATSTART"), ("wW", "ATSTART", "ATEND")]),
        _wall("wSB", 4.1, -0.3, 8.3, 0.0, [(4.1, -0.15), (8.3, -0.15)], ["B", "exterior_s0"], True,
              [("wSA", "ATSTART", "ATEND")]),  # the pair wSA-wSB again: written once
        _wall("wNA", -0.3, 4.0, 4.1, 4.3, [(4.1, 4.15), (-0.3, 4.15)], ["A", "exterior_s0"], True),
        _wall("wNB", 4.1, 4.0, 8.3, 4.3, [(8.3, 4.15), (4.1, 4.15)], ["B", "x_north"], True),
        _wall("wW", -0.3, 0.0, 0.0, 4.0, [(-0.15, 4.0), (-0.15, 0.0)], ["A", "exterior_s0"], True),
        _wall("wE", 8.0, 0.0, 8.3, 4.0, [(8.15, 0.0), (8.15, 4.0)], ["B", "exterior_s0"], True,
              [("wSB", "ATSTART", "ATEND"), ("nowhere", "ATSTART", "ATEND")]),  # an unknown wall: skipped
    ]
    openings = [
        _opening("d1", "door", "w1", 4.0, 1.0, 4.2, 1.9, 0.0, 2.0, 0.9, ["A", "B"], open=True),
        _opening("d2", "door", "wSB", 6.0, -0.3, 7.0, 0.0, 0.0, 2.1, 1.0, ["B", "exterior_s0"], open=False),
        _opening("d3", "opening", "w1", 4.0, 2.8, 4.2, 3.6, 0.0, 2.1, 0.8, ["A", "B"]),
        _opening("win1", "window", "wW", -0.3, 1.5, 0.0, 2.7, 0.9, 1.2, 1.2, ["A", "exterior_s0"]),
        _opening("win2", "window", "wNB", 5.5, 4.0, 6.7, 4.3, 0.9, 1.2, 1.2, ["B", "x_north"]),
    ]
    children = {}
    for o in openings:
        children.setdefault(o.parent, []).append(o.id)
    walls = [w.with_(children=tuple(children.get(w.id, ()))) for w in walls]
    plan = [(-0.3, -0.3), (8.3, -0.3), (8.3, 4.3), (-0.3, 4.3)]
    floor = Shape("floor", "slab", Polyhedron.prism(plan, -0.3, 0.0), name="Floor", storey=0,
                  attributes={"kind": "floor", "thickness": 0.3})
    roof = Shape("roof", "slab", Polyhedron.prism(plan, H, H + 0.25), name="Roof", storey=0,
                 attributes={"kind": "roof", "thickness": 0.25})
    rel = [
        Relation("adjacency", "A", "B", via="w1"),
        Relation("adjacency", "A", "exterior_s0", via="wSA"),
        Relation("adjacency", "B", "exterior_s0", via="wSB"),
        Relation("adjacency", "A", "x_north", via="wNA"),
        Relation("adjacency", "A", "exterior_s0", via="wW"),
        Relation("adjacency", "exterior_s0", "B", via="wE"),
        Relation("adjacency", "B", "x_north"),  # no via: through wNB, whose sides name both
        Relation("adjacency", "A", "exterior_s0"),  # no via: already through wSA, nothing more
        Relation("connectivity", "A", "exterior_s0"),  # no via and no door: not written
        Relation("connectivity", "A", "B", via="d1"),
        Relation("connectivity", "A", "B", via="d3"),
        Relation("connectivity", "B", "exterior_s0", via="d2"),
    ]
    return BuildingModel(shapes=(a, b, ext, north, *walls, *openings, floor, roof),
                         storeys=(Storey(0, 0.0, H, "Ground floor", 0.0),), relations=tuple(rel),
                         provenance=Provenance("test", {}, 5), name="elements")


def _errors(path, express_rules):
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(path, logger, express_rules=express_rules)
    return [s for s in logger.statements if s.get("level") == "error"]


def _sid(e):
    return ue.get_psets(e).get("Indoor_Shape", {}).get("ShapeId")


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    m = element_model()
    path = str(tmp_path_factory.mktemp("elements") / "elements.ifc")
    write_ifc(m, path)
    return m, path, ifcopenshell.open(path)


@pytest.mark.slow
def test_validates_with_express_rules_in_ifc4_and_ifc4x3(written, tmp_path):
    _, path, _ = written
    assert _errors(path, express_rules=True) == []
    p4x3 = str(tmp_path / "elements_4x3.ifc")
    write_ifc(element_model(), p4x3, schema="IFC4X3")
    assert ifcopenshell.open(p4x3).schema == "IFC4X3"
    assert _errors(p4x3, express_rules=True) == []


def test_entity_counts(written):
    _, path, f = written
    assert _errors(path, express_rules=False) == []  # the schema; EXPRESS rules in the slow test above
    count = {c: len(f.by_type(c)) for c in (
        "IfcWall", "IfcSlab", "IfcDoor", "IfcWindow", "IfcOpeningElement", "IfcRelVoidsElement",
        "IfcRelFillsElement", "IfcExternalSpatialElement", "IfcVirtualElement", "IfcWallType", "IfcSlabType",
        "IfcDoorType", "IfcWindowType", "IfcRelDefinesByType", "IfcMaterial", "IfcMaterialLayerSet",
        "IfcMaterialLayerSetUsage", "IfcRelAssociatesMaterial", "IfcRelConnectsPathElements")}
    assert count == {
        "IfcWall": 7, "IfcSlab": 2, "IfcDoor": 2, "IfcWindow": 2, "IfcOpeningElement": 5, "IfcRelVoidsElement": 5,
        "IfcRelFillsElement": 4, "IfcExternalSpatialElement": 1, "IfcVirtualElement": 0,
        "IfcWallType": 2, "IfcSlabType": 2, "IfcDoorType": 2, "IfcWindowType": 1, "IfcRelDefinesByType": 7,
        "IfcMaterial": 4, "IfcMaterialLayerSet": 4, "IfcMaterialLayerSetUsage": 4, "IfcRelAssociatesMaterial": 8,
        "IfcRelConnectsPathElements": 5}


def test_walls_axis_placement_layers_types_and_psets(written):
    m, _, f = written
    walls = {_sid(w): w for w in f.by_type("IfcWall")}
    for wid, w in walls.items():
        s = m[wid]
        axis = np.array(s.attributes["axis_line"], dtype=float)
        length = float(np.linalg.norm(axis[1] - axis[0]))
        d = (axis[1] - axis[0]) / length
        mat = up.get_local_placement(w.ObjectPlacement)  # world = model frame here
        assert np.allclose(mat[:3, 0], [d[0], d[1], 0], atol=1e-12)  # local x along the axis
        assert np.allclose(mat[:2, 3], axis[0], atol=1e-12) and mat[2, 3] == pytest.approx(0.0)
        (rep,) = [r for r in w.Representation.Representations if r.RepresentationIdentifier == "Axis"]
        pts = np.array([p.Coordinates for p in rep.Items[0].Points])
        assert np.allclose(pts, [[0, 0], [length, 0]], atol=1e-12)
        assert w.PredefinedType == "SOLIDWALL"
        common = ue.get_psets(w)["Pset_WallCommon"]
        assert common["IsExternal"] is s.attributes["external"] and "LoadBearing" not in common
        usage = ue.get_material(w)
        t = s.attributes["thickness"]
        assert usage.is_a("IfcMaterialLayerSetUsage") and usage.LayerSetDirection == "AXIS2"
        assert usage.DirectionSense == "POSITIVE" and usage.OffsetFromReferenceLine == pytest.approx(-t / 2)
        (layer,) = usage.ForLayerSet.MaterialLayers
        assert layer.LayerThickness == pytest.approx(t)
        name = "Exterior wall" if s.attributes["external"] else "Wall"
        assert layer.Material.Name == name
        wtype = ue.get_type(w)
        assert wtype.is_a("IfcWallType") and wtype.Name == f"{name} {round(t * 1000)} mm"
        assert ue.get_material(wtype) == usage.ForLayerSet  # the type holds the layer set
        qto = ue.get_psets(w, qtos_only=True)["Qto_WallBaseQuantities"]
        assert qto["Length"] == pytest.approx(length) and qto["Width"] == pytest.approx(t)
    # w1 holds a 0.9 x 2.0 door and a 0.8 x 2.1 opening: net side area 4 x 2.6 - 1.8 - 1.68
    qto = ue.get_psets(walls["w1"], qtos_only=True)["Qto_WallBaseQuantities"]
    assert qto["NetSideArea"] == pytest.approx(4 * H - 1.8 - 1.68)


def test_wall_joins_each_pair_once_with_their_ends(written):
    _, _, f = written
    joins = {(_sid(r.RelatingElement), _sid(r.RelatedElement)): (r.RelatingConnectionType, r.RelatedConnectionType)
             for r in f.by_type("IfcRelConnectsPathElements")}
    assert joins == {("w1", "wSA"): ("ATSTART", "ATEND"), ("w1", "wNA"): ("ATEND", "ATSTART"),
                     ("wSA", "wSB"): ("ATEND", "ATSTART"), ("wSA", "wW"): ("ATSTART", "ATEND"),
                     ("wE", "wSB"): ("ATSTART", "ATEND")}


def test_slabs_kind_psets_and_layers():
    m = element_model()
    f = build_ifc(m)
    slabs = {_sid(s): s for s in f.by_type("IfcSlab")}
    assert {k: s.PredefinedType for k, s in slabs.items()} == {"floor": "FLOOR", "roof": "ROOF"}
    for k, ext, t in (("floor", False, 0.3), ("roof", True, 0.25)):
        s = slabs[k]
        assert ue.get_psets(s)["Pset_SlabCommon"]["IsExternal"] is ext
        usage = ue.get_material(s)
        assert usage.LayerSetDirection == "AXIS3" and usage.OffsetFromReferenceLine == 0.0
        assert usage.ForLayerSet.MaterialLayers[0].LayerThickness == pytest.approx(t)
        assert ue.get_type(s).is_a("IfcSlabType") and ue.get_type(s).PredefinedType == s.PredefinedType
    st = (Storey(0, 0.0, 2.6), Storey(1, 2.9, 5.5))
    assert [slab_type(k, z0, z1, st, 0.05) for k, z0, z1 in (
        ("floor", -0.3, 0.0), ("base", -0.3, 0.0), ("roof", 5.5, 5.8), ("ceiling", 2.6, 2.9),
        ("ceiling", 5.5, 5.8), ("", -0.3, 0.0), ("", 2.6, 2.9), ("", 5.5, 5.8))] == \
        ["FLOOR", "BASESLAB", "ROOF", "FLOOR", "ROOF", "BASESLAB", "FLOOR", "ROOF"]


def test_doors_windows_types_and_openings(written):
    m, _, f = written
    fills = {_sid(e): e for e in f.by_type("IfcDoor") + f.by_type("IfcWindow")}
    assert set(fills) == {"d1", "d2", "win1", "win2"}
    for sid, e in fills.items():
        s = m[sid]
        assert (e.OverallWidth, e.OverallHeight) == (pytest.approx(s.attributes["width"]),
                                                     pytest.approx(s.attributes["height"]))
        assert e.PredefinedType == ("WINDOW" if s.type.value == "window" else "DOOR")
        (fill,) = e.FillsVoids
        (void,) = fill.RelatingOpeningElement.VoidsElements
        assert _sid(void.RelatingBuildingElement) == s.parent
        # the filling and its opening turn with the wall: local x along the wall axis
        wall_x = up.get_local_placement(void.RelatingBuildingElement.ObjectPlacement)[:3, 0]
        assert np.allclose(up.get_local_placement(e.ObjectPlacement)[:3, 0], wall_x, atol=1e-12)
        name = "Window" if e.is_a("IfcWindow") else "Door"
        assert ue.get_psets(e)[f"Pset_{name}Common"]["IsExternal"] is (sid != "d1")
        assert ue.get_psets(e)["Indoor_Support"]["points_beyond"] == pytest.approx(120.0)
    types = {e: ue.get_type(fills[e]) for e in fills}
    assert types["d1"].Name == "Door 900 x 2000 mm" and types["d2"].Name == "Door 1000 x 2100 mm"
    assert types["win1"] == types["win2"] and types["win1"].Name == "Window 1200 x 1200 mm"
    assert types["win1"].PartitioningType == "NOTDEFINED" and types["d1"].OperationType == "NOTDEFINED"
    # the doorless opening: a hole in w1 with no filling and no IfcDoor
    (hole,) = [o for o in f.by_type("IfcOpeningElement") if _sid(o) == "d3"]
    assert not hole.HasFillings and _sid(hole.VoidsElements[0].RelatingBuildingElement) == "w1"
    q = ue.get_psets(hole, qtos_only=True)["Qto_OpeningElementBaseQuantities"]
    assert (q["Width"], q["Height"], q["Depth"]) == (pytest.approx(0.8), pytest.approx(2.1), pytest.approx(TI))


def test_one_exterior_element_per_storey_holds_every_exterior_shape(written):
    _, _, f = written
    (ext,) = f.by_type("IfcExternalSpatialElement")
    ps = ue.get_psets(ext)["Indoor_Shape"]
    assert ps["ShapeId"] == "exterior_s0" and ps["MergedShapeIds"] == '["exterior_s0","x_north"]'
    body = [r for r in ext.Representation.Representations if r.RepresentationIdentifier == "Body"][0]
    assert len(body.Items) == 2
    (fp,) = [r for r in ext.Representation.Representations if r.RepresentationIdentifier == "FootPrint"]
    areas = sorted(Polygon([p.Coordinates for p in c.Points]).area for c in fp.Items[0].Elements)
    assert areas == [pytest.approx(8.6 * 4.6), pytest.approx(14.3 * 10)]  # the hole and the outer ring
    outside = {b.RelatingSpace for b in f.by_type("IfcRelSpaceBoundary")
               if b.InternalOrExternalBoundary == "EXTERNAL"}
    spaces = {_sid(b.RelatingSpace) for b in f.by_type("IfcRelSpaceBoundary")}
    assert ext in outside and spaces == {"A", "B", "exterior_s0"}


def _area(b):
    plane = b.ConnectionGeometry.SurfaceOnRelatingElement
    outer = Polygon([p.Coordinates for p in plane.OuterBoundary.Points])
    return outer.area - sum(Polygon([p.Coordinates for p in r.Points]).area for r in plane.InnerBoundaries)


def test_second_level_boundaries_with_fillings_inside_their_walls(written):
    _, _, f = written
    bounds = f.by_type("IfcRelSpaceBoundary2ndLevel")
    assert len(bounds) == len(f.by_type("IfcRelSpaceBoundary"))
    pairs = {}
    for b in bounds:
        if b.CorrespondingBoundary is not None:
            assert b.CorrespondingBoundary.CorrespondingBoundary == b
            key = (frozenset((_sid(b.RelatingSpace), _sid(b.CorrespondingBoundary.RelatingSpace))),
                   _sid(b.RelatedBuildingElement))
            pairs.setdefault(key, []).append(b)
    assert set(pairs) == {(frozenset(p), e) for p, e in (
        (("A", "B"), "w1"), (("A", "exterior_s0"), "wSA"), (("B", "exterior_s0"), "wSB"),
        (("A", "exterior_s0"), "wNA"), (("A", "exterior_s0"), "wW"), (("B", "exterior_s0"), "wE"),
        (("B", "exterior_s0"), "wNB"), (("A", "B"), "d1"), (("A", "B"), "d3"), (("B", "exterior_s0"), "d2"),
        (("A", "exterior_s0"), "win1"), (("B", "exterior_s0"), "win2"))}
    assert all(len(v) == 2 for v in pairs.values())
    for (_, elem), (b1, b2) in pairs.items():
        for b in (b1, b2):
            el = b.RelatedBuildingElement
            assert b.PhysicalOrVirtualBoundary == ("VIRTUAL" if el.is_a("IfcOpeningElement") else "PHYSICAL")
            assert b.InternalOrExternalBoundary == ("EXTERNAL" if "exterior_s0" in
                                                    {_sid(b1.RelatingSpace), _sid(b2.RelatingSpace)} else "INTERNAL")
            if el.is_a("IfcWall"):
                assert b.ParentBoundary is None
            else:  # door, window, doorless opening: inside the wall's boundary of the same space
                parent = b.ParentBoundary
                assert parent.RelatedBuildingElement.is_a("IfcWall") and parent.RelatingSpace == b.RelatingSpace
                assert _sid(parent.RelatedBuildingElement) == {"d1": "w1", "d3": "w1", "d2": "wSB",
                                                                "win1": "wW", "win2": "wNB"}[elem]
                assert b in parent.InnerBoundaries
    by = {(_sid(b.RelatingSpace), _sid(b.RelatedBuildingElement)): b for b in bounds
          if b.CorrespondingBoundary is not None}
    # faces: the door 0.9 x 2.0, the opening 0.8 x 2.1, the window 1.2 x 1.2; the walls without them
    assert _area(by[("A", "d1")]) == pytest.approx(1.8) and _area(by[("B", "d3")]) == pytest.approx(1.68)
    assert _area(by[("A", "win1")]) == pytest.approx(1.44)
    assert _area(by[("A", "w1")]) == pytest.approx(4 * H - 1.8 - 1.68)  # two notches at the floor
    wa = by[("A", "wW")].ConnectionGeometry.SurfaceOnRelatingElement
    assert len(wa.InnerBoundaries) == 1 and _area(by[("A", "wW")]) == pytest.approx(4 * H - 1.44)
    assert _area(by[("exterior_s0", "wW")]) == pytest.approx(4 * H - 1.44)
    assert _area(by[("exterior_s0", "wNB")]) == pytest.approx(4.2 * H - 1.44)  # the exterior face: 4.2 m
    # no virtual boundary to the exterior; one-sided boundaries of the slabs on each room
    assert not [b for b in bounds if b.PhysicalOrVirtualBoundary == "VIRTUAL"
                and not b.RelatedBuildingElement.is_a("IfcOpeningElement")]
    one_sided = {(_sid(b.RelatingSpace), _sid(b.RelatedBuildingElement)) for b in bounds
                 if b.CorrespondingBoundary is None}
    assert {("A", "floor"), ("A", "roof"), ("B", "floor"), ("B", "roof")} <= one_sided


def test_reads_back_and_is_reproducible(written, tmp_path):
    m, path, _ = written
    r = read_ifc(path)
    assert {s.id for s in r.walls} == {s.id for s in m.walls}
    assert {s.id for s in r.doors} == {"d1", "d2", "d3"}  # d3: an IfcOpeningElement without a filling
    assert r["d3"].attributes["kind"] == "opening" and r["d3"].parent == "w1"
    assert {s.id for s in r.slabs} == {"floor", "roof"}
    assert [s.id for s in r.shapes if s.type.value == "exterior"] == ["exterior_s0"]
    for s in r.walls:
        assert s.attributes["thickness"] == pytest.approx(m[s.id].attributes["thickness"])
        assert np.allclose(s.bounds, m[s.id].bounds, atol=1e-6)
    want = {("adjacency", frozenset(("A", "B")), "w1"), ("connectivity", frozenset(("A", "B")), "d1"),
            ("connectivity", frozenset(("A", "B")), "d3"),
            ("connectivity", frozenset(("B", "exterior_s0")), "d2")}
    want |= {("adjacency", frozenset((a, "exterior_s0")), w) for a, w in (
        ("A", "wSA"), ("B", "wSB"), ("A", "wNA"), ("A", "wW"), ("B", "wE"), ("B", "wNB"))}
    got = {(x.kind, frozenset((x.a, x.b)), x.via) for x in r.relations}
    assert want <= got
    assert not [g for g in got - want if g[2] in {s.id for s in m.walls} | {"d1", "d2", "d3", "win1", "win2"}]
    # the same model twice: the same file (apart from the header time stamp)
    a = build_ifc(m).to_string()
    b = build_ifc(m).to_string()
    mask = re.compile(r"FILE_NAME\('[^']*','[^']*'")
    assert mask.sub("", a) == mask.sub("", b)


@pytest.mark.slow
def test_synthetic_office_truth_validates_with_express_rules(tmp_path):
    truth = synthetic.build_truth(synthetic.preset_plans("office_mw")["truth"])
    path = str(tmp_path / "office_mw.ifc")
    write_ifc(truth, path)
    assert _errors(path, express_rules=True) == []
    f = ifcopenshell.open(path)
    assert len(f.by_type("IfcWindow")) == len(truth.windows)
    assert len(f.by_type("IfcOpeningElement")) == len(truth.doors) + len(truth.windows)
    assert len(f.by_type("IfcExternalSpatialElement")) == len(truth.storeys)
    fillings = [b for b in f.by_type("IfcRelSpaceBoundary")
                if b.RelatedBuildingElement.is_a("IfcDoor") or b.RelatedBuildingElement.is_a("IfcWindow")]
    assert fillings and all(b.ParentBoundary is not None and b.CorrespondingBoundary is not None for b in fillings)


def test_confidence_is_a_property_of_detected_openings_and_partly_seen_rooms(tmp_path):
    """Indoor_Shape.Confidence (0-1) where a shape has a confidence; none where it has not."""
    from engine.model import ShapeType

    room = Shape("r", ShapeType.INTERIOR, Polyhedron.box((0, 0, 0), (4, 4, 2.8)), name="Room", terminal=True,
                 attributes={"confidence": 0.75, "ceiling_seen": 0.5})
    other = Shape("o", ShapeType.INTERIOR, Polyhedron.box((4.2, 0, 0), (8, 4, 2.8)), name="Other", terminal=True)
    m = BuildingModel(shapes=(room, other), storeys=(Storey(0, 0.0, 2.8, "Ground"),))
    path = str(tmp_path / "c.ifc")
    write_ifc(m, path)
    f = ifcopenshell.open(path)
    conf = {e.Name: ue.get_psets(e).get("Indoor_Shape", {}).get("Confidence")
            for e in f.by_type("IfcSpace")}
    assert conf["Room"] == pytest.approx(0.75) and conf["Other"] is None


@pytest.mark.parametrize("schema", ["IFC4", "IFC4X3"])
def test_property_and_quantity_types_are_the_templates(tmp_path, schema):
    """The sets are written without ifcopenshell.api (engine.ifc.properties): every standard
    property takes its buildingSMART template's measure type and every base quantity its
    template's kind, as the api would give them; our own sets type by value."""
    import ifcopenshell.util.pset as upset

    path = write_ifc(element_model(), tmp_path / "m.ifc", schema=schema)
    f = ifcopenshell.open(path)
    templates = upset.get_template(f.schema_identifier)
    checked = set()
    for d in f.by_type("IfcPropertySet") + f.by_type("IfcElementQuantity"):
        assert len(d.DefinesOccurrence) == 1 and len(d.DefinesOccurrence[0].RelatedObjects) == 1
        t = templates.get_by_name(d.Name)
        if d.Name.startswith("Indoor_"):
            for p in d.HasProperties:
                v = p.NominalValue
                assert v.is_a() in ("IfcLabel", "IfcText", "IfcBoolean", "IfcInteger", "IfcReal"), p.Name
            continue
        assert t is not None, d.Name
        kinds = {pt.Name: pt for pt in t.HasPropertyTemplates}
        for p in (d.HasProperties if d.is_a("IfcPropertySet") else d.Quantities):
            pt = kinds[p.Name]
            if d.is_a("IfcPropertySet"):
                assert p.NominalValue.is_a() == pt.PrimaryMeasureType, (d.Name, p.Name)
            else:
                assert p.is_a() == "IfcQuantity" + pt.TemplateType[2:].capitalize(), (d.Name, p.Name)
                assert d.MethodOfMeasurement == "BaseQuantities"
            checked.add((d.Name, p.Name))
    names = {n for n, _ in checked}
    assert {"Pset_WallCommon", "Pset_DoorCommon", "Pset_WindowCommon", "Pset_SlabCommon",
            "Qto_WallBaseQuantities", "Qto_DoorBaseQuantities", "Qto_WindowBaseQuantities",
            "Qto_SlabBaseQuantities", "Qto_SpaceBaseQuantities"} <= names


def test_other_standard_properties_are_typed_from_the_templates_and_updates_replace_values():
    from engine.ifc.properties import measure_type, property_values, set_property

    f = ifcopenshell.file(schema="IFC4")
    assert measure_type("IFC4", "Pset_WallCommon", "ThermalTransmittance", 0.3) == \
        "IfcThermalTransmittanceMeasure"
    assert measure_type("IFC4", "Pset_WallCommon", "FireRating", "F90") == "IfcLabel"
    assert measure_type("IFC4", "Pset_WallCommon", "NotInTheTemplate", 2) == "IfcInteger"
    assert [measure_type("IFC4", "Indoor_Shape", "X", v) for v in ("a", 1.0, True, 3)] == [
        "IfcLabel", "IfcReal", "IfcBoolean", "IfcInteger"]
    with pytest.raises(TypeError, match="Indoor_Shape.X"):
        measure_type("IFC4", "Indoor_Shape", "X", object())
    ps = f.createIfcPropertySet(ifcopenshell.guid.new(), None, "Indoor_Shape", None,
                                property_values(f, "Indoor_Shape", {"Kinds": "a", "Gone": None, "N": 2}))
    assert [p.Name for p in ps.HasProperties] == ["Kinds", "N"]
    set_property(f, ps, "Kinds", "a,b")
    set_property(f, ps, "New", 1.5)
    got = {p.Name: p.NominalValue.wrappedValue for p in ps.HasProperties}
    assert got == {"Kinds": "a,b", "N": 2, "New": 1.5}
