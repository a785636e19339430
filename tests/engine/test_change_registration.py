"""The registration check of change detection (engine.change): a scan that does not fit the
model is reported "unregistered" and claims no change (unless forced); a scan far from the
model is registered by the coarse start; ``indoor changes`` exits 1 on an unregistered scan
and rejects bad options with typed one-line errors.

Scenes: the ``change_demo`` preset (old model; the scan of the changed building, 30k points)
and, as an unrelated scan, ``hexagon_hall`` (15k points). Measured on these (see
``RegistrationParams.min_fitness``): change_demo fitness 0.89, wall fitness 0.83; the 500 m
shifted scan after the coarse start the same; hexagon_hall on the change_demo model 0.20 and
0.10 against thresholds 0.5 and 0.4.
"""
import json

import numpy as np
import pytest

from engine import synthetic
from engine.change import (
    EXISTING,
    NEW,
    UNCLASSIFIED,
    detect_changes,
    model_points,
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
    assert len(reg.attempts) == 3  # the initial transform and both coarse starts were tried
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
    assert set(np.unique(back.fields["type"])) <= {EXISTING, NEW}


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
