"""Status per element, new walls, changes.ifc and the as-built model (engine.change, issue 17)
on the ``change_demo`` and ``change_office`` presets (TLS and mobile), fixed seeds.

Thresholds: new points precision/recall ≥ 0.97 (TLS and mobile, measured 0.984–0.999 over
seeds), the removed wall
"not installed" (coverage ≤ 0.05, measured ≤ 0.02; absent ≥ 0.5, measured ≥ 0.8) and no other
wall flagged; each new wall in changes.ifc within 5 cm and 2° of the truth (measured ≤ 1 cm,
≤ 0.1°).
"""
import json
import os

import numpy as np
import pytest

from engine import synthetic
from engine.change import (NEW, NO_DATA, NOT_INSTALLED, ChangeParams, as_built_model, detect_changes,
                           write_change_outputs)
from engine.change.newwalls import WallFitParams, _pairs, _ransac_lines, _wall_from_pair
from engine.geometry.boxes import min_area_box
from scenes.change import precision_recall

FLAGGED = ("not installed", "incomplete")


def _scene(name, noise, n, seed=0):
    s = synthetic.preset(name, seed=seed, noise=noise, target_points=n)
    return s, detect_changes(s.truth, s.cloud)


@pytest.fixture(scope="module")
def demo_tls():
    return _scene("change_demo", "tls", 200_000)


@pytest.fixture(scope="module")
def office_tls():
    return _scene("change_office", "tls", 300_000)


@pytest.fixture(scope="module")
def office_mobile():
    return _scene("change_office", "mobile", 300_000)


@pytest.fixture(scope="module")
def demo_mobile():
    return _scene("change_demo", "mobile", 200_000, seed=1)


def _frame(vertices):
    """(direction unit 2D, centre 2D, thickness) of a wall box."""
    origin, axes, size = min_area_box(np.asarray(vertices))
    d = axes[0, :2]
    if d[np.argmax(np.abs(d))] < 0:
        d = -d
    return d, np.asarray(vertices)[:, :2].mean(axis=0), float(size[1])


def _check_walls_against_truth(fitted_vertices, truth_walls, *, ends=0.16):
    """Each true new wall has a fitted one within 2° and 5 cm (axis offset at the true wall's centre,
    thickness); its ends within ``ends`` — a wall thickness plus 1 cm: which wall owns a junction's
    square is a convention (the truth's partition gives it to the new wall at a T, the fit stops at
    the old wall's face; at an L the longer wall keeps the corner) — measured 0 or 15 cm."""
    assert len(fitted_vertices) == len(truth_walls)
    for tw in truth_walls:
        td, tc, tt = _frame(tw.geometry.vertices)
        tu = np.sort((np.asarray(tw.geometry.vertices)[:, :2] - tc) @ td)[[0, -1]]
        best = None
        for fv in fitted_vertices:
            d, c, t = _frame(fv)
            ang = np.degrees(np.arccos(min(1.0, abs(d @ td))))
            if ang >= 10:
                continue
            # the fitted axis line's offset from the true centre, across the true wall
            off = abs((tc - c) @ np.array([-d[1], d[0]]))
            u = np.sort((np.asarray(fv)[:, :2] - tc) @ td)[[0, -1]]
            if best is None or off < best[1]:
                best = (ang, off, t, u)
        assert best is not None, tw.id
        ang, off, t, u = best
        assert ang <= 2.0, (tw.id, ang)
        assert off <= 0.05, (tw.id, off)
        assert abs(t - tt) <= 0.05, (tw.id, t, tt)
        assert np.abs(u - tu).max() <= ends, (tw.id, u, tu)


def _statuses(scene, res):
    removed = {w.id for w in scene.truth.walls if w.attributes.get("removed_in_scan")}
    assert len(removed) == 1
    walls = [e for e in res.element_status if e["type"] == "wall"]
    assert len(walls) == len(scene.truth.walls)
    flagged = {e["id"] for e in walls if e["status"] in FLAGGED}
    assert flagged == removed
    (rid,) = removed
    rec = res.element(rid)
    assert rec["status"] == NOT_INSTALLED and rec["coverage"] <= 0.05 and rec["absent"] >= 0.5
    assert rec["ifc_class"] == "IfcWall" and len(rec["global_id"]) == 22
    assert len(rec["faces"]) == 2 and all(len(f["polygon"]) >= 1 for f in rec["faces"])
    # the room faces of the removed wall are the redundant ones, and name it
    assert res.redundant and {res.surface_elements[k] for k in res.redundant} == removed
    for k in res.redundant:
        row = next(r for r in res.coverage_table(scene.truth) if r["key"] == k)
        assert row["element_global_id"] == rec["global_id"]
        ring = np.asarray(row["polygon"][0])
        pt = next(p for p in res.coverage_patches if p.key == k)
        assert np.abs(ring @ pt.normal - pt.rho).max() < 1e-6
    return rid


def _new_points(scene, res, low):
    truth = scene.cloud.fields["new"] == 1
    structural = scene.cloud.fields["label"] != synthetic.LABEL_CLUTTER
    prec, rec = precision_recall((res.point_type == NEW)[structural], truth[structural])
    assert prec >= low and rec >= low, (prec, rec)


def _truth_new(scene):
    return [w for w in scene.variants["changed"].walls if w.attributes.get("new_in_scan")]


@pytest.mark.slow
def test_change_office_tls(office_tls, tmp_path):
    scene, res = office_tls
    _new_points(scene, res, 0.97)
    rid = _statuses(scene, res)
    _check_walls_against_truth([w["shape"].geometry.vertices for w in res.new_walls], _truth_new(scene))
    # each new wall has its door (issue 13's opening detection), 0.9 m wide
    assert len(res.new_openings) == 2
    assert all(abs(d.attributes["width"] - 0.9) < 0.05 for d in res.new_openings)
    # the outputs: changes.ifc with the new walls, read back, and the removed wall by its GlobalId
    paths = write_change_outputs(res, scene.cloud, tmp_path, model=scene.truth, update=True)
    import ifcopenshell
    import ifcopenshell.util.element as ue
    from engine.ifc.reader import read_ifc
    f = ifcopenshell.open(paths["changes_ifc"])
    status = {e.GlobalId: ue.get_psets(e)["Indoor_Change"]["Status"] for e in f.by_type("IfcWall")}
    assert sorted(status.values()) == ["new", "new", "not installed"]
    assert status[res.element(rid)["global_id"]] == "not installed"
    back = read_ifc(paths["changes_ifc"])
    new_back = [w for w in back.walls if w.id.startswith("new_wall")]
    _check_walls_against_truth([w.geometry.vertices for w in new_back], _truth_new(scene))
    el = json.load(open(paths["elements_json"]))
    assert {e["global_id"] for e in el["elements"] if e["status"] == "not installed" and e["type"] == "wall"} \
        == {res.element(rid)["global_id"]}
    assert len(el["new_walls"]) == 2 and all(w["global_id"] in status for w in el["new_walls"])
    assert el["redundant_surfaces"] and all(r["element_id"] == rid for r in el["redundant_surfaces"])
    # as built: Rooms 5 and 6 are one office, Rooms 2 and 7 split in two; walls 1 removed, 2 added
    built = read_ifc(paths["as_built_ifc"])
    assert len(built.walls) == len(scene.truth.walls) + 1
    assert len(built.spaces) == len(scene.truth.spaces) - 1 + 2
    names = sorted(s.name for s in built.spaces)
    assert "Room 5 + Room 6" in names and "Room 2 (2)" in names and "Room 7 (2)" in names
    # changes.bcf: one topic per change (the removed wall, the two new ones), each naming its element
    from engine.change.bcf import read_bcf
    topics = read_bcf(paths["changes_bcf"])
    assert len(topics) == 3
    assert {t["guid"] for t in topics} == set(status)
    assert sorted(t["status"] for t in topics) == ["new", "new", "not installed"]


@pytest.mark.slow
def test_change_demo_tls(demo_tls):
    scene, res = demo_tls
    _new_points(scene, res, 0.97)
    _statuses(scene, res)
    # the two new walls meet at an L: the corner goes to one of them (15 cm = a wall thickness)
    _check_walls_against_truth([w["shape"].geometry.vertices for w in res.new_walls], _truth_new(scene))
    built = as_built_model(scene.truth, res)
    names = sorted(s.name for s in built.spaces)
    assert "Room 1 + Room 2" in names and "Room 4 (2)" in names
    areas = {s.name: s.geometry.plan_area_perimeter()[0] for s in built.spaces}
    assert abs(areas["Room 1 + Room 2"] - 7.85 * 4.85) < 0.1  # the two offices and the wall between


@pytest.mark.slow
def test_change_office_mobile(office_mobile):
    scene, res = office_mobile
    # mobile (σ = 2 cm): measured precision 0.992, recall 0.984 (seed 0); the issue asks 0.97
    _new_points(scene, res, 0.97)
    _statuses(scene, res)
    _check_walls_against_truth([w["shape"].geometry.vertices for w in res.new_walls], _truth_new(scene))


@pytest.mark.slow
@pytest.mark.parametrize("name,noise,n,seed", [("change_office", "mobile", 300_000, 2),
                                               ("change_demo", "mobile", 200_000, 3),
                                               ("change_office", "tls", 300_000, 1),
                                               ("change_demo", "tls", 200_000, 2)])
def test_new_points_other_seeds(name, noise, n, seed):
    # other furniture and scanner paths: new points from the nearest surface (a fitted new wall's
    # faces or the model's) near the corners; measured 0.990/0.993, 0.991/0.995, 0.991/0.994,
    # 0.997/0.998; two new walls, no third one in a doorway (change_demo TLS seed 2 had one)
    scene, res = _scene(name, noise, n, seed=seed)
    _new_points(scene, res, 0.97)
    assert len(res.new_walls) == 2


@pytest.mark.slow
def test_change_demo_mobile(demo_mobile):
    scene, res = demo_mobile
    _new_points(scene, res, 0.97)  # measured 0.987 / 0.990
    _statuses(scene, res)
    _check_walls_against_truth([w["shape"].geometry.vertices for w in res.new_walls], _truth_new(scene))


@pytest.mark.slow
def test_status_without_scan_positions_and_unseen_wall(office_tls):
    scene, _ = office_tls
    cloud = scene.cloud
    # a room never scanned: no points in Room 3 (north row, 9..13.5 m) -> its outer wall has no data
    xy = cloud.xyz[:, :2]
    keep = ~((xy[:, 0] > 9.0) & (xy[:, 0] < 13.5) & (xy[:, 1] > 2.0))
    cut = cloud.subset(np.flatnonzero(keep)).with_(scanner_positions=None, scan_index=None)
    res = detect_changes(scene.truth, cut, ChangeParams(fit_walls=False))
    removed = [w.id for w in scene.truth.walls if w.attributes.get("removed_in_scan")]
    rec = res.element(removed[0])
    assert rec["evidence"] == "points" and rec["status"] == NOT_INSTALLED and rec["absent"] >= 0.5
    # the outer wall of Room 3: in the north band, within Room 3's x range
    outer = [w for w in scene.truth.walls if w.bounds[0, 1] > 6.9 and w.bounds[0, 0] >= 8.9 and w.bounds[1, 0] <= 13.6]
    assert outer
    for w in outer:
        assert res.element(w.id)["status"] == NO_DATA, res.element(w.id)
    flagged = {e["id"] for e in res.element_status if e["type"] == "wall" and e["status"] in FLAGGED}
    assert flagged == set(removed)


def test_wall_pair_from_two_faces():
    # two faces of a 12 cm wall along x (1 cm noise) and a short jamb: one wall, axis y = 1.0
    rng = np.random.default_rng(4)
    u = rng.uniform(0.0, 3.0, 3000)
    a = np.column_stack([u, 0.94 + rng.normal(0, 0.003, len(u))])
    b = np.column_stack([u[:2000], 1.06 + rng.normal(0, 0.003, 2000)])
    jamb = np.column_stack([np.full(100, 1.5) + rng.normal(0, 0.003, 100), rng.uniform(0.94, 1.06, 100)])
    xy = np.vstack([a, b, jamb])
    p = WallFitParams()
    lines = _ransac_lines(xy, 0.01, p, np.random.default_rng(0))
    pairs = [(x, y) for x, y in _pairs(lines, p, 0.01) if y is not None]
    assert len(pairs) == 1
    w = _wall_from_pair(*pairs[0])
    assert abs(w["thickness"] - 0.12) < 0.005
    assert np.abs(w["axis"][:, 1] - 1.0).max() < 0.005
    assert abs(min(w["axis"][:, 0]) - 0.0) < 0.05 and abs(max(w["axis"][:, 0]) - 3.0) < 0.05


@pytest.mark.slow
def test_changes_cli_update(tmp_path, capsys):
    import argparse

    from engine.cli.changes import add_changes
    from engine.io import write_ply
    scene = synthetic.preset("change_demo", seed=2, target_points=120_000)
    model, scan = tmp_path / "old.json", tmp_path / "scan.ply"
    scene.truth.to_json(model)
    write_ply(scan, scene.cloud)
    parser = argparse.ArgumentParser(prog="indoor")
    sub = parser.add_subparsers(dest="command", required=True)
    add_changes(sub)
    out = tmp_path / "out"
    args = parser.parse_args(["changes", str(model), str(scan), "-o", str(out), "--update"])
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "not installed: IfcWall" in text and "new walls fitted: 2" in text
    for name in ("elements.json", "changes.ifc", "as_built.ifc", "summary.json", "classified_points.ply"):
        assert os.path.getsize(out / name) > 0
    s = json.load(open(out / "summary.json"))
    assert s["element_status"]["not installed"] >= 1 and len(s["new_walls_fitted"]) == 2


def _with_fake_door(model, door_id="door_0", shift=1.5):
    """The model with a copy of ``door_id`` moved ``shift`` metres along x in its (solid) wall."""
    from engine.model import Polyhedron, Scope
    d = model[door_id]
    g = Polyhedron(d.geometry.vertices + np.array([shift, 0.0, 0.0]), d.geometry.faces)
    fake = d.with_(id="door_fake", name="Fake door", geometry=g, scope=Scope.of_points(g.vertices))
    wall = model[d.parent]
    return model.replace_shapes(wall.with_(children=tuple(wall.children) + ("door_fake",)), fake)


@pytest.mark.slow
@pytest.mark.parametrize("which", ["office_tls", "office_mobile"])
def test_a_door_the_wall_closes_is_not_installed(which, request, tmp_path):
    # the model has a door (wall_3, x 3.3-4.2) where the scanned wall is solid; with and without
    # scan positions. Measured coverage of its two faces 0.97/0.87 (TLS), 0.91/0.70 (mobile);
    # the real, open doors 0.00-0.08
    scene, _ = request.getfixturevalue(which)
    model = _with_fake_door(scene.truth)
    for cloud in (scene.cloud, scene.cloud.with_(scanner_positions=None, scan_index=None)):
        res = detect_changes(model, cloud, ChangeParams(fit_walls=False))
        rec = res.element("door_fake")
        assert rec["status"] == NOT_INSTALLED and rec["walled_up"], rec["status"]
        assert res.element("wall_3")["status"] == "installed"
        others = [e for e in res.element_status if e["type"] == "door" and e["id"] != "door_fake"
                  and not scene.truth[e["id"]].attributes.get("removed_in_scan")]
        assert others and all(e["status"] == "installed" and not e["walled_up"] for e in others)
    # changes.ifc lists it as not installed, as_built.ifc drops it (its wall stays), one BCF topic
    import ifcopenshell
    import ifcopenshell.util.element as ue
    from engine.change.bcf import read_bcf
    paths = write_change_outputs(res, cloud, tmp_path, model=model, update=True)
    changes = ifcopenshell.open(paths["changes_ifc"])  # held: its entities live as long as the file
    doors = {e.Name: ue.get_psets(e)["Indoor_Change"]["Status"] for e in changes.by_type("IfcDoor")}
    assert doors["Fake door"] == NOT_INSTALLED
    built = ifcopenshell.open(paths["as_built_ifc"])
    assert "Fake door" not in {e.Name for e in built.by_type("IfcDoor")}
    assert "Wall 4" in {e.Name for e in built.by_type("IfcWall")}
    assert sum("Fake door" in t["title"] for t in read_bcf(paths["changes_bcf"])) == 1


@pytest.mark.slow
def test_a_closed_door_leaf_is_not_a_closed_wall():
    # office_mw's door_7 is closed: in a mobile scan (r ≈ 0.1 m) its leaf covers both faces of the
    # door (measured 0.72 / 0.79) but stands back from the wall's faces: the door stays installed
    scene = synthetic.preset("office_mw", seed=0, noise="mobile", target_points=300_000)
    closed = [d.id for d in scene.truth.shapes if d.type.value == "door" and d.attributes.get("open") is False]
    assert closed
    res = detect_changes(scene.truth, scene.cloud, ChangeParams(fit_walls=False))
    for did in closed:
        rec = res.element(did)
        assert min(f["coverage"] for f in rec["faces"]) >= 0.5  # the case this guards
        assert rec["status"] == "installed" and not rec["walled_up"]
