"""Preprocessing: cleaning, normals, Manhattan alignment, storeys, point clusters."""
import os

import numpy as np
import pytest

from engine.errors import EmptyCloudError, ReconstructionError
from engine.io import read_point_cloud
from engine.pointcloud import PointCloud
from engine.segmentation import (CLASS_HORIZONTAL, CLASS_WALL, align_manhattan, classify_points, clean,
                                 detect_storeys, estimate_normals, voxel_downsample)
from engine.synthetic import preset
from scenes import DATA
from scenes.segmentation import rotation, two_room_office, two_storey


def _working(cloud):
    w, _, _ = clean(cloud)
    return estimate_normals(w)


def _yaw_error_deg(rot_applied, transform_back):
    """Angle (degrees) of the residual rotation aligned <- original, modulo 90° about z."""
    m = np.linalg.inv(transform_back) @ rot_applied
    r = m[:3, :3]
    yaw = np.degrees(np.arctan2(r[1, 0], r[0, 0]))
    yaw = (yaw + 45) % 90 - 45
    tilt = np.degrees(np.arccos(np.clip(r[2, 2], -1, 1)))
    return abs(yaw), tilt


def test_voxel_downsample_keeps_attributes_and_maps_back():
    rng = np.random.default_rng(0)
    xyz = rng.random((5000, 3))
    cloud = PointCloud(xyz=xyz, fields={"label": np.arange(5000, dtype=np.int32)})
    w, kept, voxel_of = voxel_downsample(cloud, 0.1)
    assert len(w) <= 1000 and len(w) > 800  # 10 x 10 x 10 voxels, nearly all occupied
    assert np.array_equal(w.fields["label"], kept)
    # every input point maps to the representative of its own voxel
    q = np.floor((xyz - xyz.min(axis=0)) / 0.1).astype(int)
    assert np.array_equal(q, q[kept][voxel_of])


@pytest.mark.parametrize("yaw_deg,tx,ty", [(27.3, 1.0, -0.7), (-61.0, 0.0, 2.0), (8.0, -1.5, 0.5)])
def test_alignment_recovers_random_yaw_and_tilt(yaw_deg, tx, ty):
    cloud, _ = two_room_office(seed=3)
    rot = rotation(np.radians(yaw_deg), np.radians(tx), np.radians(ty))
    w = _working(cloud.transformed(rot))
    aligned, back = align_manhattan(w, rng=1)
    yaw_err, tilt_err = _yaw_error_deg(rot, back)
    assert yaw_err < 0.2
    assert tilt_err < 0.2
    # the transform maps aligned points back to the input frame
    assert np.allclose(aligned.xyz @ back[:3, :3].T + back[:3, 3], w.xyz, atol=1e-9)


def test_alignment_of_synthetic_office_within_half_degree():
    scene = preset("office_mw", seed=1, target_points=200_000)
    rng = np.random.default_rng(7)
    yaw = rng.uniform(-np.pi, np.pi)
    rot = rotation(yaw, rng.uniform(-0.02, 0.02), rng.uniform(-0.02, 0.02))
    w = _working(scene.cloud.transformed(rot))
    _, back = align_manhattan(w, rng=2)
    yaw_err, tilt_err = _yaw_error_deg(rot, back)
    assert yaw_err < 0.5
    assert tilt_err < 0.5
    # the transform alone (the pipeline rotates the full cloud itself): the same transform
    none, back2 = align_manhattan(w, rng=2, apply=False)
    assert none is None and np.array_equal(back2, back)


def test_room_scan_alignment_levels_floor_and_axis_aligns_walls():
    cloud = read_point_cloud(os.path.join(DATA, "room_scan1.pcd"))
    w = _working(cloud)
    aligned, back, res = align_manhattan(w, rng=0, return_result=True)
    # the scan is tilted by about 1 degree (its floor by 1.0°, its ceiling by 0.64°; floor
    # and ceiling planes differ by 0.45° in the data, and the walls also vote): after
    # alignment both are level within 0.6° (measured 0.31° and 0.51°)
    hor = classify_points(aligned) == CLASS_HORIZONTAL
    for sel in (hor & (aligned.xyz[:, 2] < -1.0), hor & (aligned.xyz[:, 2] > 1.4)):
        p = aligned.xyz[sel]
        a = np.c_[p[:, :2], np.ones(len(p))]
        sol, *_ = np.linalg.lstsq(a, p[:, 2], rcond=None)
        assert np.degrees(np.arctan(np.hypot(*sol[:2]))) < 0.6
    assert 0.8 < np.degrees(res.tilt) < 1.3
    # walls: the weighted mean deviation of wall normals from the nearest axis is ~0
    n = aligned.normals[classify_points(aligned) == CLASS_WALL].astype(float)
    phi = np.arctan2(n[:, 1], n[:, 0])
    dev = np.angle(np.exp(4j * phi)) / 4
    near = np.abs(dev) < np.radians(5)  # clutter normals excluded
    assert near.mean() > 0.6
    assert abs(np.degrees(np.mean(dev[near]))) < 0.1


def test_storeys_of_two_storey_scene_within_3cm():
    cloud, truth = two_storey(seed=2)
    storeys = detect_storeys(_working(cloud))
    assert len(storeys) == 2
    for s, (f, c) in zip(storeys, truth):
        assert abs(s.floor_z - f) < 0.03 and abs(s.ceiling_z - c) < 0.03


def test_storeys_of_synthetic_two_storey_office_within_3cm():
    scene = preset("two_storey_office", seed=0, target_points=300_000)
    storeys = detect_storeys(_working(scene.cloud))
    truth = sorted(scene.truth.storeys, key=lambda s: s.floor_z)
    assert len(storeys) == len(truth) == 2
    for s, t in zip(storeys, truth):
        assert abs(s.floor_z - t.floor_z) < 0.03 and abs(s.ceiling_z - t.ceiling_z) < 0.03



def test_a_floor_the_scanners_stood_on_is_a_floor():
    """FZK-Haus mobile, 100k points, seed 6: the attic's floor lies 0.2 m over the ground
    floor's ceiling; with that ceiling's points kept out of the thin window under it, what is
    left there (the slab's edges, the stair) weighed as much as the knee walls above it:
    contrast -0.03 (0.39 on seed 5), no floor, one storey up to the ridge (rooms 2 of 5). The
    walk's 46 positions 1.5 m over it say a floor is there."""
    pytest.importorskip("ifcopenshell")
    from engine.synthetic.ifcscene import ifc_scene

    from engine.pipeline import preprocess

    sc = ifc_scene("fzk_haus", seed=6, noise="mobile", target_points=100_000)
    prep = preprocess(sc.cloud, planes=False, full_normals=True)  # as a convert does
    assert [round(s.floor_z, 1) for s in prep.storeys] == [0.0, 2.7], prep.storeys

def test_room_scan_storey_is_not_the_desk():
    cloud = read_point_cloud(os.path.join(DATA, "room_scan1.pcd"))
    aligned, _ = align_manhattan(_working(cloud), rng=0)
    storeys = detect_storeys(aligned)
    assert len(storeys) == 1
    # floor at the scanner's foot about -1.27 m (the scan is tilted, its lowest corner is
    # -1.35), ceiling about +1.65 m; the desk layer (about -0.55 m) must not be the floor
    assert abs(storeys[0].floor_z + 1.27) < 0.03
    assert abs(storeys[0].ceiling_z - 1.65) < 0.03


def test_classify_points_by_normal():
    cloud, _ = two_room_office(seed=1)
    w = _working(cloud)
    lab = classify_points(w)
    truth = w.fields["label"]
    assert np.mean(lab[truth == 0] == CLASS_WALL) > 0.9
    assert np.mean(lab[np.isin(truth, [1, 2])] == CLASS_HORIZONTAL) > 0.9


def test_single_plane_has_no_vertical_structure():
    rng = np.random.default_rng(0)
    xyz = np.c_[rng.random((20000, 2)) * 5, rng.normal(0, 0.003, 20000)]
    with pytest.raises(ReconstructionError, match="no vertical structure"):
        align_manhattan(_working(PointCloud(xyz=xyz)))


def test_too_few_points_is_a_clear_error():
    rng = np.random.default_rng(0)
    with pytest.raises(EmptyCloudError, match="usable points"):  # CleanParams.min_points: 100
        clean(PointCloud(xyz=rng.random((80, 3)), source="tiny.ply"))


def test_no_ceiling_is_a_clear_error():
    cloud, _ = two_storey(seed=0)
    lab = cloud.fields["label"]
    keep = ~((lab == 2) | (cloud.xyz[:, 2] > 2.8))  # one storey, ceiling removed
    with pytest.raises(ReconstructionError, match="no storey found"):
        detect_storeys(_working(cloud.subset(keep)))


def test_room_scan_wall_planes_are_axis_aligned():
    """The big wall planes of the real scan after alignment: residual ±0.36° (the two long
    walls of room_scan1 are themselves 0.72° from parallel)."""
    from engine.pipeline import align, preprocess

    cloud = read_point_cloud(os.path.join(DATA, "room_scan1.pcd"))
    res = align(preprocess(cloud, rng=0), rng=0)
    rot = res.transform[:3, :3]  # aligned -> input
    big = [p for p in res.planes if p.kind == "wall" and p.area >= 4.0]
    assert len(big) >= 2
    for p in big:
        n = rot.T @ np.asarray(p.normal, float)  # the plane's normal in the aligned frame
        dev = np.degrees(np.angle(np.exp(4j * np.arctan2(n[1], n[0]))) / 4)
        assert abs(dev) < 0.5
    assert len(res.storeys) == 1 and abs(res.storeys[0].floor_z + 1.27) < 0.03
