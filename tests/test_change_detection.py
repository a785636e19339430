"""Change detection (engine.change) on a hand-built scene with known changes.

Old model: rooms A | B side by side (wall W1 between them), a corridor C behind wall W2,
outer walls, floor and ceiling slabs. The changed building: W1 removed (A and B are one
room), two new walls (N1 in the merged room, N2 across the corridor). The scan samples the
changed building's visible surfaces with 5 mm noise; points on the new walls carry
``fields["new"] = 1``.
"""
import json
import os

import numpy as np
import pytest

from engine.change import (EXISTING, NEW, ChangeParams, RegistrationParams, cluster_points, detect_changes,
                           transform_model, write_change_outputs)
from engine.evaluation.patches import patches_from_model, points_inside, project_to
from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey
from engine.pointcloud import PointCloud

H = 2.5
T = 0.2
ROOMS_OLD = {"A": (0, 0, 4, 6), "B": (4.2, 0, 8, 6), "C": (0, 6.2, 8, 8)}
ROOMS_NEW = {"AB": (0, 0, 8, 6), "C": (0, 6.2, 8, 8)}
NEW_WALLS = {"N1": (0, 3.0, 3.0, 3.1), "N2": (5.0, 6.2, 5.1, 8.0)}


def _box(x0, y0, x1, y1, z0=0.0, z1=H):
    return Polyhedron.box((x0, y0, z0), (x1, y1, z1))


def old_model() -> BuildingModel:
    shapes = [Shape(id=f"room_{k}", type=ShapeType.INTERIOR, geometry=_box(*r), name=f"Room {k}")
              for k, r in ROOMS_OLD.items()]
    walls = {"W1": (4, 0, 4.2, 6), "W2": (0, 6, 8, 6.2), "Wwest": (-T, -T, 0, 8 + T),
             "Weast": (8, -T, 8 + T, 8 + T), "Wsouth": (0, -T, 8, 0), "Wnorth": (0, 8, 8, 8 + T)}
    for k, w in walls.items():
        shapes.append(Shape(id=k, type=ShapeType.WALL, geometry=_box(*w), name=k,
                            attributes={"thickness": T, "removed_in_scan": k == "W1"}))
    shapes.append(Shape(id="floor", type=ShapeType.SLAB, geometry=_box(-T, -T, 8 + T, 8 + T, -T, 0)))
    shapes.append(Shape(id="ceiling", type=ShapeType.SLAB, geometry=_box(-T, -T, 8 + T, 8 + T, H, H + T)))
    return BuildingModel(shapes=tuple(shapes), storeys=(Storey(0, 0.0, H),))


def _sample(patch, density, rng):
    minx, miny, maxx, maxy = patch.geom.bounds
    n = rng.poisson(density * (maxx - minx) * (maxy - miny))
    xy = np.column_stack([rng.uniform(minx, maxx, n), rng.uniform(miny, maxy, n)])
    xy = xy[points_inside(patch, xy)]
    return patch.to3d(xy)


def _in_boxes(xyz, boxes, margin=0.0):
    m = np.zeros(len(xyz), dtype=bool)
    for x0, y0, x1, y1 in boxes:
        m |= (xyz[:, 0] > x0 - margin) & (xyz[:, 0] < x1 + margin) & (xyz[:, 1] > y0 - margin) & \
             (xyz[:, 1] < y1 + margin)
    return m


def changed_scan(density=800.0, sigma=0.005, seed=0) -> PointCloud:
    """Scan of the changed building: room faces minus what the new walls hide, plus the new
    walls' exposed faces; Gaussian noise of ``sigma`` metres."""
    rng = np.random.default_rng(seed)
    changed = BuildingModel(shapes=tuple(
        Shape(id=k, type=ShapeType.INTERIOR, geometry=_box(*r)) for k, r in ROOMS_NEW.items()))
    pts, new = [], []
    for p in patches_from_model(changed):
        q = _sample(p, density, rng)
        q = q[~_in_boxes(q, NEW_WALLS.values())]
        pts.append(q)
        new.append(np.zeros(len(q), dtype=np.int32))
    wall_model = BuildingModel(shapes=tuple(
        Shape(id=k, type=ShapeType.WALL, geometry=_box(*r)) for k, r in NEW_WALLS.items()))
    inside_rooms = list(ROOMS_NEW.values())
    for p in patches_from_model(wall_model, (ShapeType.WALL,), kinds=("wall",)):
        q = _sample(p, density, rng)
        # keep the exposed parts (faces against an existing wall are hidden)
        inner = np.zeros(len(q), dtype=bool)
        for x0, y0, x1, y1 in inside_rooms:
            inner |= (q[:, 0] > x0 + 1e-3) & (q[:, 0] < x1 - 1e-3) & (q[:, 1] > y0 + 1e-3) & (q[:, 1] < y1 - 1e-3)
        q = q[inner]
        pts.append(q)
        new.append(np.ones(len(q), dtype=np.int32))
    xyz = np.vstack(pts)
    xyz = xyz + rng.normal(0.0, sigma, xyz.shape)
    return PointCloud(xyz, fields={"new": np.concatenate(new)})


def _removed_faces(model):
    """Keys of the room faces coplanar with a side of the removed wall (derived from geometry)."""
    rooms = patches_from_model(model)
    walls = [p for p in patches_from_model(model, (ShapeType.WALL,)) if model[p.shape_id].attributes.get(
        "removed_in_scan")]
    out = set()
    for r in rooms:
        for w in walls:
            if r.normal @ w.normal < -0.99 and abs(r.rho + w.rho) < 1e-6:
                if project_to(w.geom, w, r).intersection(r.geom).area > 0.5 * r.area:
                    out.add(r.key)
    return out


def _rot_z(deg, shift):
    a = np.radians(deg)
    m = np.eye(4)
    m[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    m[:3, 3] = shift
    return m


@pytest.fixture(scope="module")
def scene():
    return old_model(), changed_scan(seed=3)


def _precision_recall(pred, truth):
    tp = np.sum(pred & truth)
    return tp / max(pred.sum(), 1), tp / max(truth.sum(), 1)


def test_new_points_and_redundant_faces(scene):
    model, scan = scene
    res = detect_changes(model, scan)
    truth = scan.fields["new"] == 1
    prec, rec = _precision_recall(res.point_type == NEW, truth)
    assert prec >= 0.97 and rec >= 0.97, (prec, rec)
    # the scan is already registered: ICP must not move it
    assert np.abs(res.registration.transform - np.eye(4)).max() < 5e-3
    assert res.registration.residual < 0.01
    removed = _removed_faces(model)
    assert len(removed) == 2
    assert set(res.redundant) == removed
    cov = dict(zip(res.coverage_keys, res.coverage))
    others = [c for k, c in cov.items() if k not in removed]
    assert min(others) > 0.6
    assert max(cov[k] for k in removed) < 0.05
    # two candidate new elements, both wall-like, holding (nearly) all new points
    walls = [e for e in res.elements if e["kind"] == "wall"]
    assert len(walls) == 2
    assert sum(e["points"] for e in walls) >= 0.95 * truth.sum()


def test_without_icp_a_shifted_model_reads_as_change(scene):
    # (ICP recovering 5° yaw + 0.3 m shift is tested on the change_demo preset)
    model, scan = scene
    moved = transform_model(model, _rot_z(5.0, (0.3, -0.2, 0.0)))
    # force: the unregistered result still classifies (without it, it claims no change)
    params = ChangeParams(registration=RegistrationParams(enabled=False), force=True)
    bad = detect_changes(moved, scan, params)
    truth = scan.fields["new"] == 1
    assert np.mean(bad.point_type == NEW) > 3 * np.mean(truth)
    assert len(bad.redundant) > 2


def test_model_against_its_own_surfaces_has_no_change():
    model = old_model()
    rng = np.random.default_rng(7)
    pts = np.vstack([_sample(p, 300.0, rng) for p in patches_from_model(model)])
    pts += rng.normal(0, 0.003, pts.shape)
    res = detect_changes(model, PointCloud(pts))
    assert np.mean(res.point_type == EXISTING) > 0.99
    assert res.redundant == []
    assert res.coverage.min() > 0.9


def test_cluster_points_separates_blobs():
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 1, (500, 3))
    b = rng.uniform(0, 1, (300, 3)) + [3, 0, 0]
    lab = cluster_points(np.vstack([a, b]), 0.2)
    assert len(np.unique(lab)) == 2
    assert np.all(lab[:500] == 0) and np.all(lab[500:] == 1)


def test_outputs_written(scene, tmp_path):
    model, scan = scene
    sub = scan.subset(np.arange(0, len(scan), 4))
    res = detect_changes(model, sub)
    paths = write_change_outputs(res, sub, tmp_path)
    for p in paths.values():
        assert os.path.getsize(p) > 0
    cov = json.load(open(paths["coverage_json"]))
    assert len(cov["surfaces"]) == len(res.coverage_keys)
    assert sorted(r["key"] for r in cov["surfaces"] if r["redundant"]) == sorted(res.redundant)
    summary = json.load(open(paths["summary_json"]))
    assert summary["new"] == int(np.sum(res.point_type == NEW))
    with open(paths["points_ply"], "rb") as f:
        head = f.read(600).split(b"end_header")[0].decode()
    assert f"element vertex {len(sub)}" in head
    for name in ("type", "distance", "cluster", "surface"):
        assert f" {name}\n" in head
