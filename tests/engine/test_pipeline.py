"""engine.pipeline: one preprocessing for both methods and the auto choice; far stray
clusters removed before anything else."""
import numpy as np
import pytest

import engine.pipeline as pipeline
from engine.pointcloud import PointCloud
from engine.reconstruct import reconstruct
from engine.segmentation.cleaning import building_points
from engine.synthetic import preset
from engine.synthetic.scan import LABEL_OUTSIDE


@pytest.fixture(scope="module")
def office():
    return preset("office_mw", seed=1, noise="tls", target_points=100_000)


def _with_strays(cloud, seed=0):
    """A 3,000-point cluster 800 m away and 200 points scattered over 2 km."""
    rng = np.random.default_rng(seed)
    far = np.r_[rng.normal([800.0, 300.0, 1.0], [3.0, 3.0, 1.0], (3000, 3)),
                rng.uniform(-1000.0, 1000.0, (200, 3))]
    far = far[np.min(np.abs(far[:, :2]), axis=1) > 100.0]  # none near the building
    return PointCloud(xyz=np.r_[cloud.xyz, far]), len(far)


def test_far_clusters_are_removed_and_the_building_kept(office):
    cloud, n_far = _with_strays(office.cloud)
    keep, groups = building_points(cloud.xyz, 0.5, 0.05)
    n = len(office.cloud)
    inside = office.cloud.fields["label"] != LABEL_OUTSIDE  # outside: seen through windows (may go too)
    assert keep[:n][inside].all()  # every point of the building
    assert not keep[n:].any() and groups >= 2  # and none of the strays
    model = reconstruct(cloud, "manhattan", rng=0)
    assert len(model.spaces) == len(office.truth.spaces)
    outside_dropped = int((~keep[:n]).sum())
    assert model.provenance.trace["cleaning"]["stray_points_removed"] == n_far + outside_dropped


@pytest.mark.parametrize("name, noise", [("two_storey_office", "tls"), ("two_storey_office", "mobile"),
                                         ("syn_house", "mobile")])
def test_a_building_is_one_cluster(name, noise):
    """Storeys over a slab and rooms behind walls stay connected at 0.5 m voxels."""
    sc = preset(name, seed=0, noise=noise, target_points=100_000)
    keep, _ = building_points(sc.cloud.xyz, 0.5, 0.05)
    assert keep[sc.cloud.fields["label"] != LABEL_OUTSIDE].all()  # what is seen outside through windows may go


def test_auto_preprocesses_once(office, monkeypatch):
    calls = []
    real = pipeline.extract_planes

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(pipeline, "extract_planes", counting)
    model = reconstruct(office.cloud, "auto", rng=0)
    assert model.provenance.method == "manhattan" and len(calls) == 1


def test_auto_and_manhattan_give_the_same_manhattan_model():
    """auto chooses on the grammar's own normals with a copy of the Generator: the model is
    --method manhattan's. Before, auto's normals, storeys and random stream were its own
    (this scan: vertices 0.86 mm apart, the alignment 9e-5 apart); 1 µm is the margin for
    two runs of the same computation."""
    sc = preset("office_mw", seed=1, noise="mobile", target_points=100_000)
    a = reconstruct(sc.cloud, "auto", rng=0)
    b = reconstruct(sc.cloud, "manhattan", rng=0)
    assert a.provenance.method == "manhattan"
    assert len(a.spaces) == len(b.spaces) == len(sc.truth.spaces)
    va, vb = (np.concatenate([s.geometry.vertices for s in m.spaces]) for m in (a, b))
    assert va.shape == vb.shape and np.abs(va - vb).max() <= 1e-6
    assert np.abs(a.transform - b.transform).max() <= 1e-9
    assert len(a.walls) == len(b.walls) and len(a.doors) + len(a.windows) == len(b.doors) + len(b.windows)


def test_auto_and_generic_give_the_same_generic_model():
    """Same seed, same preprocessing, same search: the same spaces (areas within 1e-6 m²)."""
    sc = preset("hexagon_hall", seed=1, noise="tls", target_points=100_000)
    a = reconstruct(sc.cloud, "auto", rng=0)
    b = reconstruct(sc.cloud, "generic", rng=0)
    assert a.provenance.method == "generic"
    area = [sorted(s.geometry.plan_area_perimeter()[0] for s in m.spaces) for m in (a, b)]
    assert len(area[0]) == len(area[1]) == len(sc.truth.spaces)
    assert np.allclose(area[0], area[1], atol=1e-6)


def test_prepared_carries_working_values_to_every_point(office):
    prep = pipeline.preprocess(office.cloud, rng=0, planes=False)
    full = prep.to_full(np.arange(len(prep.working)))
    # each point's representative lies in its voxel: within the voxel's diagonal
    d = np.linalg.norm(prep.cloud.xyz - prep.working.xyz[full], axis=1)
    assert d.max() <= prep.voxel * np.sqrt(3) + 1e-9


def test_far_strays_at_ground_level_do_not_make_the_cloud_look_flat(office):
    """1 % of points spread over 2 km × 2 km but only ±50 m in z: the degenerate-cloud checks
    judge the building, not the strays (they called such a scan flat)."""
    from engine.segmentation.checks import check_degenerate

    rng = np.random.default_rng(3)
    strays = rng.uniform(-1000.0, 1000.0, (len(office.cloud) // 100, 3)) * [1.0, 1.0, 0.05]
    check_degenerate(PointCloud(xyz=np.r_[office.cloud.xyz, strays], source="strays"))


def test_a_scan_past_max_points_is_thinned_first_and_reconstructs_alike(office):
    from dataclasses import replace

    from engine.params import Params
    from engine.segmentation.params import CleanParams

    cloud = office.cloud.with_(xyz=office.cloud.xyz.copy())
    assert pipeline.cap_points(cloud, CleanParams())[1] == {}  # under the bound: untouched
    cap = 40_000
    thin, info = pipeline.cap_points(cloud, CleanParams(max_points=cap))
    assert info["points"] == len(cloud) and abs(info["kept"] - cap) < 0.02 * cap  # binomial: sd ~ 0.4 %
    again, _ = pipeline.cap_points(cloud, CleanParams(max_points=cap))
    assert np.array_equal(thin.xyz, again.xyz)  # seeded: the same points every run
    # a random sample keeps the density pattern: the share of each true label is the scan's
    lab_all = np.bincount(cloud.fields["label"], minlength=8) / len(cloud)
    lab_thin = np.bincount(thin.fields["label"], minlength=8) / len(thin)
    assert np.max(np.abs(lab_all - lab_thin)) < 0.01
    base = Params()
    params = replace(base, preprocess=replace(base.preprocess, clean=replace(base.preprocess.clean, max_points=cap)))
    model = reconstruct(cloud, "manhattan", params=params, rng=0)
    assert model.provenance.trace["cleaning"]["thinned"] == info
    assert "thin" in model.provenance.timings
    rooms = [s for s in model.spaces if not s.parent]
    assert len(rooms) == len(office.truth.spaces)  # the 40k-point sample still gives every room


def test_scanner_positions_outside_the_building_are_dropped(office):
    """A file's scanner positions that lie outside its points (PCD's default viewpoint at the
    origin of a georeferenced cloud, poses in another frame) are not where it was scanned."""
    cloud = office.cloud
    sp = cloud.scanner_positions
    assert sp is not None and len(sp) > 2 and cloud.scan_index is not None
    moved = sp.copy()
    moved[0] += [500.0, 0.0, 0.0]  # one pose in another frame: it and its points' scan go
    out, dropped = pipeline.plausible_scanners(cloud.with_(scanner_positions=moved), 1.0)
    assert dropped == 1
    assert np.isnan(out.scanner_positions[0]).all() and np.isfinite(out.scanner_positions[1:]).all()
    assert (out.scan_index[cloud.scan_index == 0] == -1).all()
    assert (out.scan_index[cloud.scan_index != 0] == cloud.scan_index[cloud.scan_index != 0]).all()
    # all of them elsewhere: the cloud has none, and the openings use stand-ins in the rooms
    away = cloud.with_(scanner_positions=sp + [0.0, 0.0, 50.0])
    out, dropped = pipeline.plausible_scanners(away, 1.0)
    assert dropped == len(sp) and out.scanner_positions is None and out.scan_index is None
    model = reconstruct(away, "auto", rng=0)
    assert model.provenance.trace["cleaning"]["scanner_positions_dropped"] == len(sp)
    doors = [d for d in model.doors if d.attributes.get("detected")]
    assert len(doors) >= len(office.truth.doors) - 1, len(doors)  # stand-ins find them
    # positions inside the building's box are kept (a scanner 1 m over the top still is)
    inside = cloud.with_(scanner_positions=sp + [0.0, 0.0, 0.5])
    assert pipeline.plausible_scanners(inside, 1.0)[1] == 0


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_normals_shared_within_the_working_voxels_are_as_good_as_per_point(noise):
    """A dense scan (office_mw, 1M points): the Manhattan grammar's normals estimated once per
    working-cloud voxel (6-7 cm, a quarter of the points), over that point's neighbourhood in
    the full cloud, and shared by the voxel's points, are as often axis-aligned as one normal
    per point (TLS 0.924 against 0.920 within 10°, mobile 0.579 against 0.580 — a mobile
    scan's range noise spoils both alike), and the partition between Rooms 2 and 3 faces
    its normal as often (0.998, 0.810 both ways) — at a third to a half of the time."""
    from engine.geometry.spacing import estimate_spacing
    from engine.segmentation.cleaning import clean

    sc = preset("office_mw", seed=3, noise=noise, target_points=1_000_000)
    p = sc.cloud.xyz
    _, _, voxel = clean(sc.cloud)
    assert voxel >= 0.05  # the working cloud's voxel grew: about 4 points share one
    spacing = estimate_spacing(p)
    per_point = pipeline.full_cloud_normals(sc.cloud, spacing=spacing).normals
    shared = pipeline.full_cloud_normals(sc.cloud, spacing=spacing, voxel=voxel).normals
    aligned = [np.mean(np.abs(n).max(axis=1) >= np.cos(np.deg2rad(10))) for n in (per_point, shared)]
    assert aligned[1] >= aligned[0] - 0.01, aligned  # margin: 1 % of the points
    wall = ((p[:, 0] > 8.85) & (p[:, 0] < 9.13) & (p[:, 1] > 2.3) & (p[:, 1] < 6.8)
            & (p[:, 2] > 0.3) & (p[:, 2] < 2.6))
    facing = [np.mean(np.abs(n[wall, 0]) >= np.cos(np.deg2rad(20))) for n in (per_point, shared)]
    assert facing[1] >= facing[0] - 0.02, facing  # margin: 2 % of the partition's points
