"""Change detection (engine.change) on the hand-built scene of ``scenes.change``: wall W1
removed, two new walls (N1, N2) whose points carry ``fields["new"] = 1``."""
import json
import os

import numpy as np
import pytest

from engine.change import (EXISTING, NEW, ChangeParams, RegistrationParams, cluster_points, detect_changes,
                           transform_model, write_change_outputs)
from engine.evaluation.patches import patches_from_model
from engine.pointcloud import PointCloud
from scenes.change import changed_scan, old_model, precision_recall, removed_faces, rot_z, sample_patch


@pytest.fixture(scope="module")
def scene():
    return old_model(), changed_scan(seed=3)


def test_new_points_and_redundant_faces(scene):
    model, scan = scene
    res = detect_changes(model, scan)
    truth = scan.fields["new"] == 1
    prec, rec = precision_recall(res.point_type == NEW, truth)
    assert prec >= 0.97 and rec >= 0.97, (prec, rec)
    # the scan is already registered: ICP must not move it
    assert np.abs(res.registration.transform - np.eye(4)).max() < 5e-3
    assert res.registration.residual < 0.01
    removed = removed_faces(model)
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
    moved = transform_model(model, rot_z(5.0, (0.3, -0.2, 0.0)))
    # force: the unregistered result still classifies (without it, it claims no change)
    params = ChangeParams(registration=RegistrationParams(enabled=False), force=True)
    bad = detect_changes(moved, scan, params)
    truth = scan.fields["new"] == 1
    assert np.mean(bad.point_type == NEW) > 3 * np.mean(truth)
    assert len(bad.redundant) > 2


def test_model_against_its_own_surfaces_has_no_change():
    model = old_model()
    rng = np.random.default_rng(7)
    pts = np.vstack([sample_patch(p, 300.0, rng) for p in patches_from_model(model)])
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
