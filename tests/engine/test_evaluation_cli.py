"""``indoor evaluate`` and ``indoor changes`` through their own argparse (engine.cli.evaluate,
engine.cli.changes), on hand-built models and scans written to disk."""
import argparse
import json
import os

import numpy as np
import pytest

from engine.cli.changes import add_changes, read_matrix
from engine.cli.evaluate import add_evaluate
from engine.errors import FormatError, IndoorError, InputError
from engine.io import read_point_cloud, write_ply
from scenes.change import changed_scan, old_model
from scenes.evaluation import CORRIDOR, REF, ROOM, grow, room_model


def _parser():
    parser = argparse.ArgumentParser(prog="indoor")
    sub = parser.add_subparsers(dest="command", required=True)
    orig = sub.add_parser

    def add_parser(name, **kw):  # like engine.cli: every subcommand gets --quiet and --json
        p = orig(name, **kw)
        p.add_argument("--quiet", action="store_true")
        p.add_argument("--json", action="store_true")
        return p

    sub.add_parser = add_parser
    add_evaluate(sub)
    add_changes(sub)
    return parser


def _run(argv):
    args = _parser().parse_args(argv)
    return args.func(args)


def test_evaluate_cli(tmp_path, capsys):
    src = tmp_path / "inacc.json"
    ref = tmp_path / "ref.json"
    room_model({"Room 1": grow(ROOM, 0.05, "wsn"), "Corridor": grow(CORRIDOR, 0.05, "esn")}).to_json(src)
    REF.to_json(ref)
    out = tmp_path / "out"
    assert _run(["evaluate", str(src), str(ref), "-o", str(out), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    comp = np.array(payload["completeness"])  # all groups: floors and ceilings match at any b
    assert comp[0] < 0.8 and comp[-1] > 0.97
    for name in ("evaluation.json", "curves.csv", "curves.png", "reference_surfaces.ply",
                 "source_surfaces.ply", "accuracy_points.ply"):
        assert os.path.getsize(out / name) > 0
    d = json.load(open(out / "evaluation.json"))
    assert d["source"] == str(src)
    # element scores beside the surface curves: the same two rooms, no doors in either
    el = json.load(open(out / "elements.json"))
    assert el == d["elements"] == payload["elements"]
    assert (el["spaces"]["model"], el["spaces"]["truth"], el["spaces"]["matched"]) == (2, 2, 2)
    walls = np.array(d["curves"]["wall"]["completeness"])
    assert walls[0] <= 0.45 and walls[-1] >= 0.97
    # walls only, solid-wall option, custom buffers
    assert _run(["evaluate", str(src), str(ref), "-o", str(out), "--groups", "wall", "--buffers", "0.02,0.08",
                 "--quiet"]) == 0
    d = json.load(open(out / "evaluation.json"))
    assert d["buffers_m"] == [0.02, 0.08] and set(d["curves"]) == {"wall", "all"}


def test_evaluate_cli_bad_input(tmp_path):
    ref = tmp_path / "ref.json"
    REF.to_json(ref)
    with pytest.raises(InputError, match="not found"):
        _run(["evaluate", str(tmp_path / "nope.json"), str(ref), "-o", str(tmp_path / "o")])
    bad = tmp_path / "bad.json"
    bad.write_text("{\"hello\": 1}")
    with pytest.raises(FormatError):
        _run(["evaluate", str(bad), str(ref), "-o", str(tmp_path / "o")])
    with pytest.raises(InputError, match="group"):
        _run(["evaluate", str(ref), str(ref), "-o", str(tmp_path / "o"), "--groups", "roof"])
    with pytest.raises(IndoorError):
        _run(["evaluate", str(ref), str(ref), "-o", str(tmp_path / "o"), "--buffers", "0.05,0.01"])


def test_changes_cli(tmp_path, capsys):
    model = tmp_path / "old.json"
    old_model().to_json(model)
    scan = changed_scan(density=250.0, seed=1)
    path = tmp_path / "scan.ply"
    write_ply(path, scan)
    out = tmp_path / "changes"
    assert _run(["changes", str(model), str(path), "-o", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["redundant"] == ["room_A:3", "room_B:5"]
    assert s["new_walls"] == 2
    assert s["registration"]["residual_m"] < 0.01
    back = read_point_cloud(out / "classified_points.ply")
    assert len(back) == len(scan)
    t = back.fields["type"].astype(int)
    truth = scan.fields["new"] == 1
    assert np.mean(t[truth] == 1) > 0.95 and np.mean(t[~truth] == 0) > 0.99
    cov = json.load(open(out / "coverage.json"))
    assert {r["key"] for r in cov["surfaces"] if r["redundant"]} == {"room_A:3", "room_B:5"}


def test_changes_cli_bad_input(tmp_path):
    model = tmp_path / "old.json"
    old_model().to_json(model)
    with pytest.raises(InputError, match="not found"):
        _run(["changes", str(model), str(tmp_path / "missing.ply"), "-o", str(tmp_path / "o")])
    m = tmp_path / "t.txt"
    m.write_text("1 0 0\n0 1 0\n")
    with pytest.raises(FormatError, match="4x4"):
        read_matrix(m)
    np.savetxt(m, np.eye(4))
    np.testing.assert_array_equal(read_matrix(m), np.eye(4))
