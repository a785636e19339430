"""The plan view (issue 19): :func:`engine.evaluation.planview.plan_view` writes a PNG of the
model over the truth, one panel per storey; :func:`plan_differences` lists where the plan
leaves the truth. A tiny two-storey model, no scan simulation."""
import struct
import sys

import numpy as np
import pytest

from engine.errors import InputError, MissingDependencyError
from engine.evaluation.planview import plan_differences, plan_view
from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey
from engine.pointcloud import PointCloud

pytest.importorskip("matplotlib")


def _box(id_, type_, x0, y0, x1, y1, z0, z1, storey=0, name=""):
    return Shape(id_, type_, Polyhedron.box((x0, y0, z0), (x1, y1, z1)), storey=storey, name=name or id_)


def _house(partition_x=4.0, two_storeys=True):
    """8 m × 5 m inside 0.2 m walls; on the ground floor a partition at ``partition_x`` with
    a door, a room each side; upstairs (3 m) one room."""
    sh = []
    floors = [(0, 0.0, 2.6)] + ([(1, 3.0, 5.6)] if two_storeys else [])
    for k, z0, z1 in floors:
        sh += [_box(f"wS{k}", ShapeType.WALL, -0.2, -0.2, 8.2, 0.0, z0, z1, k),
               _box(f"wN{k}", ShapeType.WALL, -0.2, 5.0, 8.2, 5.2, z0, z1, k),
               _box(f"wW{k}", ShapeType.WALL, -0.2, 0.0, 0.0, 5.0, z0, z1, k),
               _box(f"wE{k}", ShapeType.WALL, 8.0, 0.0, 8.2, 5.0, z0, z1, k)]
    px = partition_x
    sh += [_box("wP", ShapeType.WALL, px, 0.0, px + 0.1, 5.0, 0.0, 2.6),
           _box("door", ShapeType.DOOR, px, 2.0, px + 0.1, 2.9, 0.0, 2.0),
           _box("win", ShapeType.WINDOW, 2.0, -0.2, 3.0, 0.0, 0.9, 2.1),
           _box("A", ShapeType.INTERIOR, 0.0, 0.0, px, 5.0, 0.0, 2.6, name="Living"),
           _box("B", ShapeType.INTERIOR, px + 0.1, 0.0, 8.0, 5.0, 0.0, 2.6, name="Kitchen")]
    storeys = [Storey(0, 0.0, 2.6, "Ground", 0.0)]
    if two_storeys:
        sh.append(_box("C", ShapeType.INTERIOR, 0.0, 0.0, 8.0, 5.0, 3.0, 5.6, storey=1, name="Attic"))
        storeys.append(Storey(1, 3.0, 5.6, "Upper", 3.0))
    return BuildingModel(shapes=tuple(sh), storeys=tuple(storeys), name="tiny")


def _png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


def _cloud(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([rng.uniform(0, 8, n), rng.uniform(0, 5, n), rng.uniform(0, 5.6, n)])
    return PointCloud(xyz)


def test_plan_view_writes_a_png_of_the_expected_size(tmp_path):
    truth = _house()
    model = _house(partition_x=4.5)
    path = tmp_path / "plan.png"
    r = plan_view(model, truth, cloud=_cloud(), path=path, dpi=50, panel_size=(6.0, 6.0))
    # extent: the walls, -0.2..8.2 × -0.2..5.2, plus 1 m each side: 10.4 m × 7.4 m; the
    # scale fits 10.4 m in 6 in (0.577 in/m): maps 6 in × 4.27 in, panels 6.9 in wide (+0.9),
    # legend 1.9 in; height 4.27 + 1.0 in
    w, h = _png_size(path)
    assert (w, h) == (r["width"], r["height"])
    assert w == round((2 * 6.9 + 1.9) * 50) and h == round((7.4 * 6 / 10.4 + 1.0) * 50)
    assert [p["name"] for p in r["panels"]] == ["Ground", "Upper"]
    ground, upper = r["panels"]
    assert (ground["spaces"], ground["walls"], ground["true_rooms"]) == (2, 5, 2)
    assert (upper["spaces"], upper["walls"], upper["true_rooms"]) == (1, 4, 1)
    # the labels: name, area and the best IoU with one true room (Living: 4.5×5 vs 4×5 -> 0.89)
    assert ground["labels"][0] == "Living 22.5 m² IoU 0.89"
    assert 0 < ground["points"] <= 2000 * 0.2 / 5.6 * 2  # the ±0.1 m slice at mid-height (1.3 m)


def test_plan_view_one_storey_and_bad_storey(tmp_path):
    truth = _house()
    r = plan_view(truth, path=tmp_path / "one.png", storey=1, dpi=40)
    assert [p["storey"] for p in r["panels"]] == [1]
    assert _png_size(tmp_path / "one.png") == (r["width"], r["height"])
    for bad in (2, -1, True, "0", []):
        with pytest.raises(InputError):
            plan_view(truth, path=tmp_path / "bad.png", storey=bad)
    assert not (tmp_path / "bad.png").exists()


def test_plan_view_without_matplotlib_is_a_typed_error(tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    with pytest.raises(MissingDependencyError) as e:
        plan_view(_house(), path=tmp_path / "x.png")
    assert e.value.kind == "dependency" and e.value.package == "matplotlib"
    assert not (tmp_path / "x.png").exists()


def test_plan_differences_find_the_moved_partition():
    truth, model = _house(), _house(partition_x=4.5)
    d = plan_differences(model, truth)
    kinds = {(x["kind"], x["storey"]): x for x in d}
    extra, missing = kinds[("extra wall", 0)], kinds[("missing wall", 0)]
    # the partition moved 0.5 m east: 0.1 m × 5 m of wall each way, less the 0.1 m at each end
    # within the slack of the outer walls: 0.1 × 4.8 m, within 1e-6
    assert extra["area"] == pytest.approx(0.48, abs=1e-6) and extra["bbox"] == (4.5, 0.1, 4.6, 4.9)
    assert missing["area"] == pytest.approx(0.48, abs=1e-6) and missing["bbox"] == (4.0, 0.1, 4.1, 4.9)
    assert extra["names"] == ["wP"]
    # Living grew over the true partition into Kitchen: its 0.1 m on the true wall is within
    # the slack of the rooms, and the 0.1 m gap of the model is closed by it too
    assert not [x for x in d if x["kind"] in ("room uncovered", "space off rooms")]
    assert not [x for x in d if x["storey"] == 1]  # the upper floor is the same
    # the attic left out of the model: 8 m × 5 m of room uncovered upstairs
    d = plan_differences(model.replace_shapes(remove=["C"]), truth, storeys=[1])
    assert [(x["kind"], x["names"], x["area"]) for x in d] == [("room uncovered", ["Attic"], 40.0)]
    assert plan_differences(truth, truth) == []
