"""Units, up axis and degenerate clouds (engine.segmentation.frame).

Scenes are synthetic presets of 60k points (fixed seeds), rescaled or rotated here by
exact factors and permutations, so the truth is known exactly: the unit, the file axis
that points up and the floor (``label`` 1) and ceiling (``label`` 2) points.
"""
import functools
import os
import time

import numpy as np
import pytest

from engine.errors import InputError, ReconstructionError
from engine.io import read_point_cloud
from engine.pointcloud import PointCloud
from engine.segmentation import (UNITS, UP_AXES, check_degenerate, detect_storeys, detect_units, detect_up,
                                 normalize_frame, up_rotation)
from engine.segmentation.checks import FrameParams, frame_sample
from engine.segmentation.frame import _building
from engine.synthetic import preset
from scenes import DATA

POINTS = 60_000
LABEL_FLOOR, LABEL_CEILING, LABEL_OUTSIDE = 1, 2, 4

# (preset, seed, noise): every preset the brief names, both scanner kinds, two seeds
SCENES = [
    ("office_mw", 0, "tls"),
    ("syn_house", 1, "mobile"),
    ("hexagon_hall", 0, "tls"),
    ("house_multi_height", 1, "mobile"),
    ("two_storey_office", 0, "mobile"),
    ("two_storey_office", 1, "tls"),
]


@functools.lru_cache(maxsize=None)
def _preset(name, seed, noise, clutter=True, surroundings=True):
    return preset(name, seed=seed, noise=noise, target_points=POINTS, clutter=clutter,
                  surroundings=surroundings)


def _scene(name, seed, noise, clutter=True, surroundings=True):
    """The scan; with ``surroundings`` (the simulator's default) it holds points outside
    (``label`` 4: ground, trees, a neighbour's facade) seen through windows and open doors."""
    return _preset(name, seed, noise, clutter, surroundings).cloud


def _no_scanners(cloud):
    return cloud.with_(scanner_positions=None, scan_index=None)


def _with_up(cloud, up):
    """The cloud as a file whose axis ``up`` points up: p_file = Rᵀ p (R = up_rotation)."""
    r = up_rotation(up)
    sp = None if cloud.scanner_positions is None else cloud.scanner_positions @ r
    return cloud.with_(xyz=cloud.xyz @ r, scanner_positions=sp)


def _in_units(cloud, unit):
    f = UNITS[unit]
    sp = None if cloud.scanner_positions is None else cloud.scanner_positions / f
    return cloud.with_(xyz=cloud.xyz / f, scanner_positions=sp)


def _floor_tilt_deg(cloud):
    """Angle (degrees) between z and the least-squares normal of the lowest floor's points
    (the floor label covers every storey)."""
    p = cloud.xyz[cloud.fields["label"] == LABEL_FLOOR]
    p = p[p[:, 2] < np.percentile(p[:, 2], 1) + 0.5]
    c = p - p.mean(axis=0)
    _, vec = np.linalg.eigh(c.T @ c)
    return float(np.degrees(np.arccos(abs(vec[2, 0]))))


def test_up_rotations_are_proper_and_bring_the_axis_to_z():
    for up in UP_AXES:
        r = up_rotation(up)
        e = np.zeros(3)
        e["xyz".index(up[-1])] = -1.0 if up.startswith("-") else 1.0
        assert np.allclose(r @ r.T, np.eye(3)) and np.isclose(np.linalg.det(r), 1.0)
        assert np.allclose(r @ e, [0, 0, 1])
    with pytest.raises(InputError):
        up_rotation("w")


@pytest.mark.parametrize("name,seed,noise", SCENES)
@pytest.mark.parametrize("scanners", [True, False])
def test_ordinary_metre_z_up_scan_is_left_alone(name, seed, noise, scanners):
    cloud = _scene(name, seed, noise)
    cloud = cloud if scanners else _no_scanners(cloud)
    out, rec = normalize_frame(cloud)
    assert out is cloud  # nothing rotated, nothing rescaled
    assert rec["units"] == "m" and rec["scale"] == 1.0 and rec["up"] == "z"
    assert rec["rotation"] == np.eye(3).tolist()
    assert rec["units_confidence"] >= 0.5 and rec["up_confidence"] >= 0.5


@pytest.mark.parametrize("name,seed,noise", [s for s in SCENES if s[0] != "hexagon_hall"])  # no window
def test_frame_sample_leaves_the_outside_out(name, seed, noise):
    # the points outside are few (0.5-1.6 %) but sparse: before, they held 27-84 % of the
    # sample's area weight and widened its voxel (measured: 9 354 sample points instead of
    # 33 159 for house_multi_height); the building's own sample is as fine as without them
    cloud = _scene(name, seed, noise)
    params = FrameParams()
    s = frame_sample(cloud, params, 0)
    b = _building(cloud, s, params, 0)
    index = {p.tobytes(): i for i, p in enumerate(cloud.xyz)}
    lab = cloud.fields["label"]

    def outside(x):  # (share of the points, share of the area weight) outside
        o = lab[[index[p.tobytes()] for p in x.xyz]] == LABEL_OUTSIDE
        return o.mean(), (x.radius[o] ** 2).sum() / (x.radius ** 2).sum(), (~o).sum()

    pts0, area0, in0 = outside(s)
    pts1, area1, in1 = outside(b)
    assert area0 > 0.25 and pts0 > 0.005  # measured 0.27-0.84 and 0.008-0.078
    # measured 0-0.018 (0.176 for house_multi_height: ground seen through its open doors,
    # joined to the floor at the threshold) and 0-0.01
    assert area1 < 0.25 and area1 < 0.5 * area0 and pts1 < 0.02
    assert in1 >= 0.99 * in0  # nothing of the building lost (measured: 1.0-2.9 times as many)
    plain = _scene(name, seed, noise, surroundings=False)
    s_plain = frame_sample(plain, params, 0)
    assert _building(plain, s_plain, params, 0) is s_plain  # one component: the sample as it was
    assert len(b.xyz) >= 0.75 * len(s_plain.xyz)  # measured 0.98-1.01


@pytest.mark.parametrize("name,seed,noise", SCENES)
def test_storey_heights_ignore_the_outside(name, seed, noise):
    # before, two_storey_office/tls read 5.81 m (the ground outside pulled its lowest floor
    # layer up and off) and house_multi_height/mobile no storey at all
    plan = _preset(name, seed, noise).plan
    truth = {plan.ceiling_z(r) - plan.storeys[r.storey].floor_z for r in plan.rooms}
    for unit in ("m", "mm"):
        g = detect_units(_in_units(_no_scanners(_scene(name, seed, noise)), unit))
        found = np.array(g.storey_heights) * UNITS[unit]
        assert len(found) and all(min(abs(h - t) for t in truth) < 0.03 for h in found), (truth, g.evidence)
        assert min(abs(found - max(truth))) < 0.03, (truth, g.evidence)  # measured < 0.01 m


@pytest.mark.parametrize("name,seed,noise", SCENES[:4])
def test_empty_z_up_scan_without_scanner_positions_is_accepted(name, seed, noise):
    # no furniture and no scanner: the sign has no cue, the file's z is kept
    cloud = _no_scanners(_scene(name, seed, noise, clutter=False))
    out, rec = normalize_frame(cloud)
    assert out is cloud and rec["up"] == "z" and rec["units"] == "m"


@pytest.mark.parametrize("name,seed,noise", SCENES)
@pytest.mark.parametrize("unit", ["mm", "cm", "in", "ft"])
def test_scan_in_other_units_is_rescaled(name, seed, noise, unit):
    cloud = _scene(name, seed, noise)
    g = detect_units(_in_units(cloud, unit))
    assert g.unit == unit and g.confidence >= 0.5, g.evidence
    out, rec = normalize_frame(_in_units(cloud, unit))
    assert rec["units"] == unit and abs(rec["scale"] / UNITS[unit] - 1) < 0.01
    assert any("rescaled" in w for w in out.warnings)
    # back in metres: the same points (float rounding of a division and a product only)
    assert np.allclose(out.xyz, cloud.xyz, rtol=0, atol=1e-9 * np.abs(cloud.xyz).max())
    assert np.allclose(out.scanner_positions, cloud.scanner_positions, rtol=0, atol=1e-9 * 100)


@pytest.mark.parametrize("name,seed,noise", [s for s in SCENES if s[0] != "office_mw"])
@pytest.mark.parametrize("unit", ["mm", "cm", "in", "ft"])
def test_units_without_scanner_positions(name, seed, noise, unit):
    # feet need a second storey or ceiling height here: all these presets have one
    g = detect_units(_in_units(_no_scanners(_scene(name, seed, noise)), unit))
    assert g.unit == unit and g.confidence >= 0.5, g.evidence


def test_single_storey_in_feet_without_scanners_stays_metres_with_low_confidence():
    # 9.84 units of height: 3 m in feet, or a 9.8 m hall in metres; nothing else tells
    cloud = _in_units(_no_scanners(_scene("office_mw", 0, "tls")), "ft")
    g = detect_units(cloud)
    assert g.unit == "m" and g.confidence < 0.5 and "feet" in g.evidence
    out, rec = normalize_frame(cloud)  # processed in metres, with a warning the user sees
    assert rec["units"] == "m" and any("low confidence" in w for w in out.warnings)


@pytest.mark.parametrize("name,seed,noise", SCENES)
@pytest.mark.parametrize("up", ["y", "-y", "x", "-x", "-z"])
def test_rotated_scan_is_turned_back_to_z_up(name, seed, noise, up):
    cloud = _scene(name, seed, noise)
    g = detect_up(_with_up(cloud, up))
    assert g.up == up and g.confidence >= 0.5, g.evidence
    out, rec = normalize_frame(_with_up(cloud, up))
    assert rec["up"] == up and rec["units"] == "m"
    assert _floor_tilt_deg(out) < 1.0  # exact permutations: measured < 0.05°
    lab = out.fields["label"]
    assert np.median(out.xyz[lab == LABEL_FLOOR, 2]) < np.median(out.xyz[lab == LABEL_CEILING, 2])
    assert np.allclose(out.xyz, cloud.xyz, atol=1e-9)


@pytest.mark.parametrize("name,seed,noise", SCENES)
@pytest.mark.parametrize("up", ["-y", "x", "-z"])
def test_rotated_furnished_scan_without_scanners_is_turned_back(name, seed, noise, up):
    # the sign from gravity alone: furniture tops lie in the lower half of a storey
    cloud = _no_scanners(_scene(name, seed, noise))
    out, rec = normalize_frame(_with_up(cloud, up))
    assert rec["up"] == up, rec["evidence"]["up"]
    assert _floor_tilt_deg(out) < 1.0
    assert np.allclose(out.xyz, cloud.xyz, atol=1e-9)


@pytest.mark.parametrize("up", ["y", "-x"])
def test_rotated_empty_scan_without_scanners_cannot_be_oriented(up):
    cloud = _no_scanners(_scene("syn_house", 1, "mobile", clutter=False))
    with pytest.raises(ReconstructionError, match="cannot be oriented.*--up"):
        normalize_frame(_with_up(cloud, up))
    out, rec = normalize_frame(_with_up(cloud, up), up=up)  # told: fine
    assert rec["up"] == up and rec["up_confidence"] == 1.0 and _floor_tilt_deg(out) < 1.0


def test_given_units_and_up_skip_detection_and_transform_everything():
    cloud = _scene("office_mw", 0, "tls")
    cloud = cloud.with_(normals=np.tile(np.array([0, 0, 1.0], np.float32), (len(cloud), 1)),
                        offset=np.array([100.0, 200.0, 5.0]))
    f = _in_units(_with_up(cloud, "-y"), "cm")
    f = f.with_(normals=f.normals @ up_rotation("-y"), offset=cloud.offset @ up_rotation("-y") / 0.01)
    out, rec = normalize_frame(f, units="cm", up="-y")
    assert rec["evidence"] == {"units": "given", "up": "given"}
    assert rec["units"] == "cm" and rec["scale"] == 0.01 and rec["up"] == "-y"
    assert np.allclose(out.xyz, cloud.xyz, atol=1e-9)
    assert np.allclose(out.normals, [0, 0, 1], atol=1e-6)
    assert np.allclose(out.scanner_positions, cloud.scanner_positions, atol=1e-9)
    assert np.allclose(out.offset, cloud.offset, atol=1e-9)  # xyz + offset: original coordinates
    with pytest.raises(InputError):
        normalize_frame(f, units="furlong")
    with pytest.raises(InputError):
        normalize_frame(f, up="up")


def test_low_crop_is_not_rescaled():
    # a 0.5 m slice above the floor: no ceiling, no storey height; metres stay metres
    cloud = _scene("office_mw", 0, "tls")
    crop = _no_scanners(cloud.subset(cloud.xyz[:, 2] < 0.5))
    out, rec = normalize_frame(crop)
    assert rec["units"] == "m" and rec["up"] == "z" and out is crop


def test_floor_only_millimetre_scan_needs_the_units():
    # no ceiling and no scanner: 18 000 units across is no building in metres, and nothing
    # tells millimetres from centimetres: refuse quickly instead of running for minutes
    cloud = _scene("office_mw", 0, "tls")
    crop = _in_units(_no_scanners(cloud.subset(cloud.xyz[:, 2] < 1.0)), "mm")
    t = time.perf_counter()
    with pytest.raises(ReconstructionError, match="units cannot be told.*--units"):
        normalize_frame(crop.with_(source="crop.ply"))
    assert time.perf_counter() - t < 10.0
    # ... but the scanner's height above the floor tells it (1.5 m in millimetres)
    g = detect_units(_in_units(cloud.subset(cloud.xyz[:, 2] < 1.0), "mm"))
    assert g.unit == "mm" and g.confidence >= 0.5


def test_real_room_scans_are_metres_z_up():
    for f in ("room_scan1.pcd", "room_scan2.pcd"):
        cloud = read_point_cloud(os.path.join(DATA, f))
        _, rec = normalize_frame(cloud)
        assert rec["units"] == "m" and rec["up"] == "z", rec["evidence"]


@pytest.mark.parametrize("unit", ["mm", "ft"])
def test_real_room_scan_in_other_units(unit):
    # a real, 1° tilted scan with a noisy floor: levelled and measured layer by layer
    cloud = read_point_cloud(os.path.join(DATA, "room_scan1.pcd"))
    _, rec = normalize_frame(_in_units(cloud, unit))
    assert rec["units"] == unit and rec["up"] == "z", rec["evidence"]


# ----------------------------------------------------------------------------- degenerate
N_BIG = 1_000_000


def _degenerate(kind, rng):
    n = N_BIG
    if kind == "identical":
        return np.tile([1.0, 2.0, 3.0], (n, 1))
    if kind == "few distinct":
        return np.repeat(rng.random((5, 3)) * 10, n // 5, axis=0)
    if kind == "line":
        return np.outer(rng.random(n) * 20, [0.6, 0.8, 0.0]) + rng.normal(0, 0.01, (n, 3))
    if kind == "plane":
        return np.c_[rng.random((n, 2)) * 20, np.zeros(n)]
    if kind == "tilted noisy plane":
        tilt = np.array([[1, 0, 0], [0, 0.8, 0.6], [0, -0.6, 0.8]])
        return np.c_[rng.random((n, 2)) * 20, rng.normal(0, 0.02, n)] @ tilt
    if kind == "noise in a box":
        return rng.random((n, 3)) * [15, 10, 3]
    raise ValueError(kind)


@pytest.mark.parametrize("kind,message", [
    ("identical", "identical"), ("few distinct", "distinct"), ("line", "line"), ("plane", "flat"),
    ("tilted noisy plane", "flat"), ("noise in a box", "no structure")])
def test_degenerate_cloud_fails_fast_naming_the_file(kind, message):
    cloud = PointCloud(xyz=_degenerate(kind, np.random.default_rng(3)), source=f"{kind}.ply")
    for call in (check_degenerate, normalize_frame):
        t = time.perf_counter()
        with pytest.raises(ReconstructionError, match=message) as info:
            call(cloud)
        # the brief asks < 10 s at 1M points; measured under 1 s on a shared 2-core machine
        assert time.perf_counter() - t < 10.0
        assert info.value.path == f"{kind}.ply"


def test_thin_slab_is_flat_once_the_units_are_known():
    # two parallel planes 2 m wide, 10 cm apart (well above their sampling: neighbourhoods
    # of 3 cm): flat in metres; in unknown units a thin but well-sampled object, not refused
    rng = np.random.default_rng(4)
    n = 50_000
    xyz = np.c_[rng.random((n, 2)) * 2, np.where(rng.random(n) < 0.5, 0.0, 0.1)]
    with pytest.raises(ReconstructionError, match="flat"):
        check_degenerate(PointCloud(xyz=xyz), scale=1.0)
    check_degenerate(PointCloud(xyz=xyz * 1000))
    with pytest.raises(ReconstructionError, match="flat"):
        check_degenerate(PointCloud(xyz=xyz * 1000), scale=0.001)


def test_flat_cloud_has_no_storey_instead_of_an_index_error():
    rng = np.random.default_rng(5)
    n = 5000
    cloud = PointCloud(xyz=np.c_[rng.random((n, 2)) * 10, np.zeros(n)],
                       normals=np.tile([0, 0, 1.0], (n, 1)), source="flat.ply")
    with pytest.raises(ReconstructionError, match="no storey"):
        detect_storeys(cloud)
    # two histogram bins (1 cm of relief) as well
    cloud = cloud.with_(xyz=np.c_[cloud.xyz[:, :2], rng.random(n) * 0.04])
    with pytest.raises(ReconstructionError, match="no storey"):
        detect_storeys(cloud)
