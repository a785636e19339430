"""The true model of every synthetic preset: write IFC4, validate, check the spatial tree,
tessellate, read back (footprints, topology) — the plan/truth only, no scan simulated."""
import pytest

pytest.importorskip("ifcopenshell")
import ifcopenshell.geom  # noqa: E402
import ifcopenshell.util.element  # noqa: E402
import ifcopenshell.validate  # noqa: E402
from shapely.geometry import Polygon  # noqa: E402

from engine import synthetic  # noqa: E402
from engine.ifc import read_ifc, write_ifc  # noqa: E402


@pytest.mark.parametrize("name", synthetic.PRESETS)
def test_preset_truth_writes_valid_ifc_that_round_trips(name, tmp_path):
    truth = synthetic.build_truth(synthetic.preset_plans(name)["truth"])
    path = str(tmp_path / f"{name}.ifc")
    write_ifc(truth, path)
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(path, logger)
    assert [s["message"] for s in logger.statements if s.get("level") == "error"] == []

    f = ifcopenshell.open(path)
    ue = ifcopenshell.util.element
    storey_index = {s.id(): ue.get_psets(s)["Indoor_Storey"]["Index"] for s in f.by_type("IfcBuildingStorey")}
    assert sorted(storey_index.values()) == [s.index for s in truth.storeys]
    n_products = 0
    for cls in ("IfcSpace", "IfcExternalSpatialElement", "IfcWall", "IfcSlab", "IfcDoor", "IfcWindow"):
        for e in f.by_type(cls):
            shape = truth[ue.get_psets(e)["Indoor_Shape"]["ShapeId"]]
            is_space = cls in ("IfcSpace", "IfcExternalSpatialElement")
            holder = ue.get_aggregate(e) if is_space else ue.get_container(e)
            if shape.parent is not None and cls == "IfcSpace" and holder.is_a("IfcSpace"):
                holder = ue.get_aggregate(holder)
            assert storey_index[holder.id()] == shape.storey, (cls, shape.id)
            n_products += 1
    assert n_products == sum(1 for s in truth.shapes if s.type.value != "none")
    assert len(f.by_type("IfcOpeningElement")) == len(truth.doors) + len(truth.windows)

    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    it = ifcopenshell.geom.iterator(settings, f, 1, include=f.by_type("IfcProduct"))
    assert it.initialize()
    n_geom = 1
    while it.next():
        n_geom += 1
    assert n_geom >= n_products

    back = read_ifc(path)
    assert back.summary() == truth.summary()
    assert sorted((r.kind, r.a, r.b, r.via) for r in back.relations) == \
        sorted((r.kind, r.a, r.b, r.via) for r in truth.relations)
    for s in truth.shapes:
        fp = s.footprint()
        if s.is_space and fp is not None:
            got = back[s.id].footprint()
            assert got is not None, s.id
            a, b = Polygon(fp), Polygon(got)
            assert a.intersection(b).area / a.union(b).area >= 0.99, s.id
        assert back[s.id].storey == s.storey
