"""The registration check of change detection (engine.change): a scan that does not fit the
model is reported "unregistered" and claims no change (unless forced); a scan far from the
model is registered by the coarse start; ``indoor changes`` exits 1 on an unregistered scan
and rejects bad options with typed one-line errors.

Scenes: the ``change_demo`` preset (old model; the scan of the changed building, 30k points)
and, as an unrelated scan, ``hexagon_hall`` (15k points). Measured on these (see
``RegistrationParams.min_fitness``): change_demo fitness 0.89, wall fitness 0.83; the 500 m
shifted scan after the coarse start the same; hexagon_hall on the change_demo model 0.20 and
0.10 against thresholds 0.5 and 0.4.

The global step (FPFH + RANSAC, then ICP): scans 500 m and 30° / 120° off about z on
change_demo (TLS) and office_mw (mobile), 12k points, end 0.8-0.9 mm RMS from the truth
(CPU 7-13 s each on a busy 2-core machine, so marked slow); hexagon_hall turned and moved
stays unregistered (best fitness 0.19, wall fitness 0.14).
"""
import json
import time

import numpy as np
import pytest

from engine import synthetic
from engine.change import (
    EXISTING,
    UNCLASSIFIED,
    detect_changes,
    model_points,
    register,
    registration_quality,
    write_change_outputs,
)
from engine.cli.changes import read_matrix
from engine.errors import FormatError, InputError
from engine.io import read_point_cloud, write_ply
from scenes.change import old_model, removed_faces

SHIFT = np.array([400.0, -300.0, 0.0])
"""500 m away."""


@pytest.fixture(scope="module")
def demo():
    return synthetic.preset("change_demo", seed=0, target_points=30_000)


@pytest.fixture(scope="module")
def demo_result(demo):
    return detect_changes(demo.truth, demo.cloud)


@pytest.fixture(scope="module")
def other():
    return synthetic.preset("hexagon_hall", seed=0, target_points=15_000)


def test_registration_quality_counts_points_on_the_surfaces():
    from scipy.spatial import cKDTree

    mp, mn = model_points(old_model(), 0.1)
    tree = cKDTree(mp)
    off = mp + 0.03 * mn  # 3 cm off every surface, along its normal
    fit, rmse, wall = registration_quality(tree, mp, mn, off, 0.05, 0.1, normals=mn)
    assert fit == 1.0 and wall == 1.0
    assert rmse == pytest.approx(0.03, abs=1e-9)
    fit, rmse, wall = registration_quality(tree, mp, mn, off, 0.02, 0.1, normals=mn)
    assert fit == 0.0 and wall == 0.0 and np.isnan(rmse)
    # points on the floors and ceilings only: walls have no say in the wall fitness
    flat = np.abs(mn[:, 2]) > 0.9
    fit, _, wall = registration_quality(tree, mp, mn, mp[flat], 0.05, 0.1, normals=mn[flat])
    assert fit == 1.0 and np.isnan(wall)


def test_change_demo_registered(demo, demo_result):
    res = demo_result
    reg = res.registration
    assert reg.status == "registered" and res.registered and reg.start == "initial"
    # measured 0.89 and 0.83; the thresholds are 0.5 and 0.4
    assert reg.fitness > 0.75 and reg.wall_fitness > 0.65, (reg.fitness, reg.wall_fitness)
    assert reg.rmse < 0.01 and reg.fitness_distance == 0.05
    assert np.abs(reg.transform - np.eye(4)).max() < 5e-3
    # the known removed wall's faces are still found, the new walls too
    removed = removed_faces(demo.truth)
    assert len(removed) == 2 and set(res.redundant) == removed
    assert sum(e["kind"] == "wall" for e in res.elements) >= 1
    s = res.summary()
    assert s["registration"]["status"] == "registered" and s["classified"] and not s["forced"]
    assert s["registration"]["fitness"] == pytest.approx(reg.fitness)
    assert s["unclassified"] == 0 and s["existing"] + s["new"] == s["points"]


def test_scan_500_m_away_registered_by_the_coarse_start(demo, demo_result):
    res = detect_changes(demo.truth, demo.cloud.xyz + SHIFT)
    reg = res.registration
    assert reg.status == "registered"
    assert reg.start in ("centroid", "bounding-box centre")
    assert reg.attempts[0]["start"] == "initial" and reg.attempts[0]["fitness"] < 0.05  # measured 0.0
    # the same registration: each point lands within 1 cm of where the unshifted run puts it
    # (ICP converges to the same optimum from either start; residual 2 mm)
    pts = demo.cloud.xyz[::20]
    want = pts @ demo_result.registration.transform[:3, :3].T + demo_result.registration.transform[:3, 3]
    t = reg.transform
    got = (pts + SHIFT) @ t[:3, :3].T + t[:3, 3]
    assert np.linalg.norm(got - want, axis=1).max() < 0.01
    # the same result: fitness within 0.02, the same redundant faces, ≥ 99 % of the point types
    assert abs(reg.fitness - demo_result.registration.fitness) < 0.02
    assert set(res.redundant) == set(demo_result.redundant) == removed_faces(demo.truth)
    assert np.mean(res.point_type == demo_result.point_type) > 0.99
    assert abs(len(res.elements) - len(demo_result.elements)) <= 1


def test_unrelated_scan_unregistered_claims_no_change(demo, other, tmp_path):
    res = detect_changes(demo.truth, other.cloud)
    reg = res.registration
    assert reg.status == "unregistered" and not res.registered and not res.classified
    # measured 0.20 and 0.10 (thresholds 0.5 and 0.4)
    assert reg.fitness < 0.4 and reg.wall_fitness < 0.3, (reg.fitness, reg.wall_fitness)
    # the initial transform, both coarse starts and the global step (FPFH + RANSAC) were tried
    starts = [a["start"] for a in reg.attempts]
    assert starts[:3] == ["initial", "centroid", "bounding-box centre"], starts
    assert any(s.startswith("global") for s in starts[3:]), starts
    assert res.redundant == [] and res.elements == []
    assert np.all(res.point_type == UNCLASSIFIED) and np.all(res.cluster == -1)
    s = res.summary()
    assert s["new"] == 0 and s["existing"] == 0 and s["unclassified"] == len(other.cloud)
    assert s["registration"]["status"] == "unregistered"
    paths = write_change_outputs(res, other.cloud, tmp_path)
    cov = _json(paths["coverage_json"])
    assert cov["registration_status"] == "unregistered"
    assert not any(r["redundant"] for r in cov["surfaces"])


def _json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _cli(argv, capsys):
    from engine.cli import main

    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def files(demo, other, tmp_path_factory):
    d = tmp_path_factory.mktemp("changes_cli")
    model = d / "old.json"
    demo.truth.to_json(model)
    write_ply(d / "scan.ply", demo.cloud)
    write_ply(d / "other.ply", other.cloud)
    return d, model, d / "scan.ply", d / "other.ply"


def test_cli_registered(files, capsys):
    d, model, scan, _ = files
    out = d / "registered"
    code, text, err = _cli(["changes", str(model), str(scan), "-o", str(out)], capsys)
    assert code == 0, err
    assert "registration: fitness 0." in text and "FAILED" not in text
    s = _json(out / "summary.json")
    assert s["registration"]["status"] == "registered" and s["registration"]["fitness"] > 0.75
    assert len(s["redundant"]) == 2


def test_cli_unregistered_exit_1_and_force(files, capsys):
    d, model, _, other = files
    out = d / "unregistered"
    code, text, err = _cli(["changes", str(model), str(other), "-o", str(out)], capsys)
    assert code == 1
    assert "registration FAILED: fitness 0." in text and "< 0.50" in text
    assert "--initial" in err and "--force" in err and "Traceback" not in err
    s = _json(out / "summary.json")  # the outputs are written, with the status
    reg = s["registration"]
    assert reg["status"] == "unregistered" and reg["fitness"] < 0.4 and reg["rmse_m"] is not None
    assert s["redundant"] == [] and s["new"] == 0 and s["new_elements"] == 0
    back = read_point_cloud(out / "classified_points.ply")
    assert np.all(back.fields["type"] == UNCLASSIFIED)
    # --force: changes reported, the status still unregistered, exit 0
    out = d / "forced"
    code, text, err = _cli(["changes", str(model), str(other), "-o", str(out), "--force"], capsys)
    assert code == 0, err
    assert "registration FAILED" in text and "--force" in text
    s = _json(out / "summary.json")
    assert s["registration"]["status"] == "unregistered" and s["forced"]
    assert len(s["redundant"]) > 0 and s["new"] > 0
    back = read_point_cloud(out / "classified_points.ply")
    assert UNCLASSIFIED not in set(np.unique(back.fields["type"])) and np.any(back.fields["type"] == EXISTING)


def test_cli_bad_input_is_a_typed_one_line_error(files, tmp_path, capsys):
    from engine.cli import build_parser

    scan = files[2]
    small = tmp_path / "small.json"
    old_model().to_json(small)
    cases = [
        ([str(tmp_path / "nope.json"), str(scan)], InputError, "not found"),
        ([str(small), str(small)], InputError, "extension"),  # a model given as the scan
        ([str(small), str(scan), "--distance", "nan"], InputError, "--distance"),
        ([str(small), str(scan), "--distance", "inf"], InputError, "--distance"),
        ([str(small), str(scan), "--alpha", "-1"], InputError, "--alpha"),
        ([str(small), str(scan), "--redundant-threshold", "2"], InputError, "--redundant-threshold"),
    ]
    scaled = tmp_path / "scaled.txt"
    np.savetxt(scaled, np.diag([2.0, 2.0, 2.0, 1.0]))
    cases.append(([str(small), str(scan), "--initial", str(scaled)], FormatError, "rigid"))
    for argv, kind, word in cases:
        full = ["changes", *argv, "-o", str(tmp_path / "o")]
        args = build_parser().parse_args(full)
        with pytest.raises(kind, match=word):
            args.func(args)
        code, _, err = _cli(full, capsys)
        assert code not in (0, None), argv
        lines = err.strip().splitlines()
        assert len(lines) == 1 and "error" in lines[0] and "Traceback" not in err, (argv, err)


def test_read_matrix_rigid(tmp_path):
    m = tmp_path / "t.txt"
    a = np.radians(30.0)
    rigid = np.eye(4)
    rigid[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    rigid[:3, 3] = (1.0, 2.0, 3.0)
    np.savetxt(m, rigid)
    np.testing.assert_allclose(read_matrix(m), rigid, atol=1e-12)
    for bad in (np.zeros((4, 4)), np.diag([1.0, 1.0, -1.0, 1.0])):
        np.savetxt(m, bad)
        with pytest.raises(FormatError):
            read_matrix(m)
    bottom = rigid.copy()
    bottom[3] = (0.0, 0.0, 1.0, 1.0)
    np.savetxt(m, bottom)
    with pytest.raises(FormatError, match="last row"):
        read_matrix(m)


def _turned(xyz, degrees):
    """Scan points turned by ``degrees`` about z (about the origin), then moved by SHIFT."""
    a = np.radians(degrees)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    return xyz @ rot.T + SHIFT


def _rms_error(reg, true_xyz, moved_xyz):
    """RMS distance, metres, between the registered scan points and their true positions."""
    t = reg.transform
    return float(np.sqrt(np.mean(np.sum((moved_xyz @ t[:3, :3].T + t[:3, 3] - true_xyz) ** 2, axis=1))))


@pytest.mark.slow
@pytest.mark.parametrize("name, noise, degrees", [("change_demo", "tls", 30.0), ("office_mw", "mobile", 30.0),
                                                  ("change_demo", "tls", 120.0), ("office_mw", "mobile", 120.0)])
def test_global_registration_from_500_m_and_turned(name, noise, degrees):
    """From 500 m and 30° (120°) off about z, the registered scan lies within 1 cm (RMS) of the
    truth. Measured RMS 0.7-1.3 mm (TLS σ 5 mm, mobile σ 2 cm), the margin is ≥ 7×.

    At 30° ICP from the centroid start finds the pose too (the global step runs as well and
    agrees). office_mw at 120°: the coarse starts end in a wrong pose (fitness 0.50, wall
    fitness 0.10, below the check), the global step registers it. change_demo at 120°: ICP from the centroid ends
    in the half-turned pose, which passes the check (fitness 0.73, wall fitness 0.55); the
    global pose scores 0.90 / 0.83 and is kept (the tie break of the quality check)."""
    sc = synthetic.preset(name, seed=0, noise=noise, target_points=12_000)
    moved = _turned(sc.cloud.xyz, degrees)
    t0 = time.perf_counter()
    reg = register(sc.truth, moved)
    seconds = time.perf_counter() - t0
    err = _rms_error(reg, sc.cloud.xyz, moved)
    print(f"{name} {noise} {degrees:.0f} deg: {reg.status} from {reg.start}, fitness {reg.fitness:.3f}, "
          f"wall fitness {reg.wall_fitness:.3f}, residual {reg.residual * 1000:.1f} mm, "
          f"RMS error {err * 1000:.1f} mm, {seconds:.1f} s")
    assert reg.status == "registered" and not reg.ambiguous
    assert err < 0.01, err
    assert reg.fitness > 0.8 and reg.wall_fitness > 0.7  # measured ≥ 0.89 and ≥ 0.83
    starts = [a["start"] for a in reg.attempts]
    assert any(s.startswith("global") for s in starts), starts
    if (name, degrees) == ("office_mw", 120.0):
        # the coarse starts end in wrong poses the check rejects; the global step registers the scan
        assert reg.start.startswith("global")
        assert all(a["wall_fitness"] < 0.4 for a in reg.attempts if not a["start"].startswith("global"))
    if (name, degrees) == ("change_demo", 120.0):
        # the centroid start passed the check in the wrong (half-turned) pose; the global pose beat it
        wrong = next(a for a in reg.attempts if a["start"] == "centroid")
        assert wrong["fitness"] >= 0.5 and wrong["wall_fitness"] >= 0.4, wrong
        assert reg.start.startswith("global") and reg.wall_fitness > wrong["wall_fitness"] + 0.15
    d = reg.to_dict()
    assert d["status"] == "registered" and d["ambiguous"] is False and d["residual_m"] < 0.02


@pytest.mark.slow
def test_global_registration_deterministic(demo):
    """The same input gives the same transform (seeded draws; ICP's sums may differ in the last bits)."""
    moved = _turned(demo.cloud.xyz[::3], 120.0)
    a, b = register(demo.truth, moved), register(demo.truth, moved)
    assert a.start == b.start and np.abs(a.transform - b.transform).max() < 1e-6


@pytest.mark.slow
def test_unrelated_scan_turned_and_far_unregistered(demo, other):
    """hexagon_hall's scan, 500 m and 30° off, against change_demo's model: no pose passes."""
    moved = _turned(other.cloud.xyz, 30.0)
    t0 = time.perf_counter()
    reg = register(demo.truth, moved)
    print(f"unrelated: {reg.status}, fitness {reg.fitness:.3f}, wall fitness {reg.wall_fitness:.3f}, "
          f"{time.perf_counter() - t0:.1f} s, {len(reg.attempts)} attempts")
    assert reg.status == "unregistered"
    # measured ≤ 0.21 and ≤ 0.15 over all attempts (thresholds 0.5 and 0.4)
    assert max(a["fitness"] for a in reg.attempts) < 0.4
    assert max(a["wall_fitness"] for a in reg.attempts) < 0.3
    assert sum(a["start"].startswith("global") for a in reg.attempts) >= 2  # both voxel sizes tried
