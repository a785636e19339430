"""BuildingModel: geometry, topology graphs, immutability, JSON round trip."""
import json

import numpy as np
import pytest

from engine import BuildingModel, FormatError, Polyhedron, Relation, Shape, ShapeType, Storey
from engine.model import Scope
from engine.topology import space_graph


def two_rooms():
    r1 = Shape("r1", "interior", Polyhedron.box((0, 0, 0), (4, 3, 2.5)), name="Room 1")
    r2 = Shape("r2", "interior", Polyhedron.box((4.2, 0, 0), (8, 3, 2.5)), name="Room 2")
    w = Shape("w1", "wall", Polyhedron.box((4, 0, 0), (4.2, 3, 2.5)), terminal=True)
    d = Shape("d1", "door", Polyhedron.box((4, 1, 0), (4.2, 1.9, 2.0)), parent="w1")
    w = w.with_(children=("d1",))
    rel = [Relation("adjacency", "r2", "r1", via="w1"), Relation("connectivity", "r1", "r2", via="d1")]
    return BuildingModel(shapes=(r1, r2, w, d), storeys=(Storey(0, 0.0, 2.5),), relations=rel, name="t")


def test_prism_geometry():
    p = Polyhedron.prism([(0, 0), (0, 3), (4, 3), (4, 0)], 0.0, 2.5)  # clockwise input
    assert p.volume() == pytest.approx(30.0)
    assert np.allclose(p.face_normal(0), [0, 0, -1]) and np.allclose(p.face_normal(1), [0, 0, 1])
    fp = p.footprint()
    assert fp is not None and len(fp) == 4
    x, y = fp[:, 0], fp[:, 1]
    assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) == pytest.approx(12.0)  # CCW
    v, t = p.triangles()
    assert t.shape == (12, 3)


def test_nonconvex_prism_triangulates_to_its_area():
    L = Polyhedron.prism([(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (0, 3)], 0, 1)
    assert L.volume() == pytest.approx(6.0)
    v, t = L.triangles()
    top = [tri for tri in t if np.allclose(v[tri][:, 2], 1)]
    area = sum(np.linalg.norm(np.cross(v[b] - v[a], v[c] - v[a])) / 2 for a, b, c in top)
    assert area == pytest.approx(6.0)


def test_scope_of_rotated_box():
    a = np.deg2rad(30)
    r = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    fp = np.array([(0, 0), (5, 0), (5, 2), (0, 2)]) @ r.T
    s = Scope.of_points(Polyhedron.prism(fp, 0, 3).vertices)
    assert np.allclose(sorted(s.size), [2, 3, 5])
    assert s.width == pytest.approx(2.0)
    assert np.allclose(s.center[:2], (np.array([2.5, 1.0]) @ r.T))


def test_surfaces_are_labelled_by_normal():
    m = two_rooms()
    surf = m.surfaces()
    assert {s.shape_id for s in surf} == {"r1", "r2"}
    kinds = [s.kind for s in surf if s.shape_id == "r1"]
    assert kinds.count("floor") == 1 and kinds.count("ceiling") == 1 and kinds.count("wall") == 4
    assert sum(s.area for s in surf if s.shape_id == "r1" and s.kind == "wall") == pytest.approx(2 * 2.5 * 7)


def test_graphs_and_shortest_path():
    import networkx as nx

    m = two_rooms()
    g = space_graph(m, "connectivity")
    assert set(g.nodes) == {"r1", "r2"} and g.edges["r1", "r2"]["via"] == "d1"
    assert nx.shortest_path(g, "r1", "r2") == ["r1", "r2"]
    assert space_graph(m, "adjacency").edges["r1", "r2"]["via"] == "w1"


def test_merged_space_levels():
    a = Shape("a", "interior", Polyhedron.box((0, 0, 0), (2, 2, 2)), active=False, parent="ab")
    b = Shape("b", "interior", Polyhedron.box((2, 0, 0), (4, 2, 2)), active=False, parent="ab")
    c = Shape("c", "interior", Polyhedron.box((5, 0, 0), (7, 2, 2)))
    ab = Shape("ab", "interior", Polyhedron.box((0, 0, 0), (4, 2, 2)), children=("a", "b"))
    m = BuildingModel(shapes=(a, b, c, ab), relations=[
        Relation("connectivity", "a", "b"), Relation("connectivity", "b", "c", via="door")])
    assert set(space_graph(m, "connectivity", "space").nodes) == {"ab", "c"}
    assert set(space_graph(m, "connectivity", "space").edges) == {("ab", "c")} or \
        set(space_graph(m, "connectivity", "space").edges) == {("c", "ab")}
    sub = space_graph(m, "connectivity", "subspace")
    assert set(sub.nodes) == {"a", "b", "c"} and sub.has_edge("a", "b") and sub.has_edge("b", "c")
    assert [s.id for s in m.leaves("ab")] == ["a", "b"] and m.top_level("a").id == "ab"


def test_model_is_immutable_and_edits_return_new_models():
    m = two_rooms()
    with pytest.raises(Exception):
        m.shapes[0].geometry.vertices[0, 0] = 99.0
    with pytest.raises(Exception):
        m.name = "x"
    m2 = m.replace_shapes(m["r1"].logged("reclassify: exterior", type=ShapeType.EXTERIOR))
    assert m["r1"].type is ShapeType.INTERIOR and m2["r1"].type is ShapeType.EXTERIOR
    assert m2["r1"].log[-1] == "reclassify: exterior"
    with pytest.raises(ValueError):
        BuildingModel(shapes=(m["r1"], m["r1"]))


def test_json_round_trip(tmp_path):
    m = two_rooms()
    path = tmp_path / "m.json"
    m.to_json(path)
    back = BuildingModel.from_json(path)
    assert back.to_dict() == m.to_dict()
    assert back["d1"].parent == "w1" and back["w1"].terminal
    assert json.loads(path.read_text())["schema_version"] == 1


@pytest.mark.parametrize("text, msg", [
    ("not json", "not readable as JSON"),
    ('{"a": 1}', "not a building-model"),
    ('{"schema": "indoor-building-model", "schema_version": 99}', "unsupported schema version"),
    ('{"schema": "indoor-building-model", "schema_version": 1, "shapes": [{"id": "x"}]}', "malformed"),
])
def test_bad_model_json(tmp_path, text, msg):
    p = tmp_path / "bad.json"
    p.write_text(text)
    with pytest.raises(FormatError, match=msg) as e:
        BuildingModel.from_json(p)
    assert str(p) in str(e.value)


def test_input_frame_transform():
    t = np.eye(4)
    t[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    t[:3, 3] = [10, 0, 0]
    m = BuildingModel(transform=t, offset=(1000, 2000, 0))
    assert np.allclose(m.to_input_frame([[1, 0, 0]]), [[10, 1, 0]])
    assert np.allclose(m.to_input_frame([[1, 0, 0]], include_offset=True), [[1010, 2001, 0]])
