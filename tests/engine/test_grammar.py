"""Manhattan shape grammar on synthetic scenes with known truth (SPEC.md §2).

Scenes come from ``engine.synthetic`` with fixed seeds; every figure asserted is a
"Done when" number of the grammar issue: typed cuboids, room count, side-face
completeness/correctness at b = 10 cm, median wall-point distance, ceiling heights.
"""
import json

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from engine.errors import Cancelled, EmptyCloudError, ReconstructionError
from engine.grammar import (ManhattanParams, classify, face_index, grid_face_index, reconstruct_grammar,
                            reconstruct_manhattan, union_of_boxes)
from engine.grammar.ipof import local_radii
from engine.grammar.params import estimate_spacing
from engine.model import BuildingModel, ShapeType
from engine.pointcloud import PointCloud
from engine.synthetic import LABEL_WALL, preset

SIGMA = {"tls": 0.005, "mobile": 0.02}


OFFICE_POINTS = 250_000  # the office scan of test_generic and test_segmentation_presets too


@pytest.fixture(scope="module")
def office_tls(synthetic_scene, synthetic_model):
    key = ("office_mw", 1, "tls", OFFICE_POINTS)
    return synthetic_scene(*key), synthetic_model("manhattan", *key, rng=0)


@pytest.fixture(scope="module")
def office_mobile(synthetic_scene, synthetic_model):
    key = ("office_mw", 1, "mobile", OFFICE_POINTS)
    return synthetic_scene(*key), synthetic_model("manhattan", *key, rng=0)


def truth_type(truth, c):
    """Type of the truth shape holding point c (interior / wall / exterior)."""
    for s in truth.shapes:
        if s.type not in (ShapeType.INTERIOR, ShapeType.WALL) or not s.active:
            continue
        fp = s.footprint()
        lo, hi = s.bounds
        if fp is not None and lo[2] - 1e-6 <= c[2] <= hi[2] + 1e-6 and Polygon(fp).contains(Point(c[0], c[1])):
            return s.type
    return ShapeType.EXTERIOR


def type_accuracy(sc, model):
    parts = [s for s in model.shapes if s.grid is not None]
    ok = sum(truth_type(sc.truth, s.bounds.mean(axis=0)) == s.type for s in parts)
    return ok / len(parts), len(parts)


def footprint_iou(a, b):
    pa, pb = Polygon(a.footprint()), Polygon(b.footprint())
    return pa.intersection(pb).area / pa.union(pb).area


def match_rooms(model, truth):
    """Each truth room → (best model room, IoU of footprints)."""
    out = []
    for t in truth.spaces:
        best = max(model.spaces, key=lambda s: footprint_iou(s, t) if s.storey == t.storey else -1)
        out.append((t, best, footprint_iou(best, t)))
    return out


def wall_point_distances(model, cloud):
    """|distance| of the truth wall points to the nearest vertical face of an interior
    space whose extent holds their projection (inf when none does)."""
    pts = cloud.xyz[cloud.fields["label"] == LABEL_WALL]
    best = np.full(len(pts), np.inf)
    for srf in model.surfaces():
        if srf.kind != "wall":
            continue
        n = srf.normal
        a = int(np.argmax(np.abs(n)))
        lo, hi = srf.polygon.min(axis=0), srf.polygon.max(axis=0)
        other = [k for k in range(3) if k != a]
        inside = np.all((pts[:, other] >= lo[other] - 1e-3) & (pts[:, other] <= hi[other] + 1e-3), axis=1)
        d = np.abs(pts[:, a] - srf.polygon[0, a])
        best = np.where(inside, np.minimum(best, d), best)
    return best


@pytest.mark.parametrize("which", ["tls", "mobile"])
def test_office_types_rooms_and_faces(which, request):
    """Mobile: two thin cuboids beside a door in the corridor wall read IPoF(sides) 0.23-0.26 <
    τ and were typed exterior (type accuracy 0.969-0.978, seeds 1-3) until a wall face's
    index counted its points with tilted normals too (``faces_by_position``): 1.0."""
    from engine.evaluation import EvaluationParams, evaluate

    sc, model = request.getfixturevalue(f"office_{which}")
    acc, n = type_accuracy(sc, model)
    assert n >= 20
    assert acc >= 0.98, f"{which}: {acc:.3f} of {n} cuboids typed right"
    assert len(model.spaces) == len(sc.truth.spaces) == 8
    for t, m, iou in match_rooms(model, sc.truth):
        assert iou >= 0.95, (t.name, m.name, iou)
    res = evaluate(model, sc.truth, EvaluationParams(buffers=(0.1,), groups=("wall",)))
    assert res.curves["wall"]["completeness"][0] >= 0.95
    assert res.curves["wall"]["correctness"][0] >= 0.95
    d = wall_point_distances(model, sc.cloud)
    d = d[np.isfinite(d)]
    assert len(d) > 1000
    assert np.median(d) <= 1.5 * SIGMA[which], np.median(d)


def test_model_conventions_and_logs(office_tls):
    sc, model = office_tls
    parts = [s for s in model.shapes if s.grid is not None]
    for s in parts:
        assert any(line.startswith("place:") for line in s.log)
        assert any(line.startswith("classify:") for line in s.log)
        for k in ("ipof_top", "ipof_sides", "ipof_f0", "ipof_f5"):
            assert k in s.support
    for room in model.spaces:
        assert room.children and all(model[c].parent == room.id and not model[c].active for c in room.children)
        assert room.footprint() is not None
        assert room.log[0].startswith("merge:")
    walls = model.walls
    assert walls and all(w.terminal and w.attributes["thickness"] <= 0.5 for w in walls)
    # adjacency between rooms goes through a wall; rooms are not connected without doors
    adj = [r for r in model.relations_of("adjacency") if r.a in {s.id for s in model.spaces}]
    assert adj and all(model[r.via].type == ShapeType.WALL for r in adj if r.via)
    assert model.provenance.method == "manhattan"
    assert model.provenance.parameters["tau"] == ManhattanParams().tau
    assert model.provenance.seed is not None and "topology" in model.provenance.timings
    back = BuildingModel.from_json(model.to_json())
    assert back.summary() == model.summary()
    assert json.loads(model.to_json())["provenance"]["method"] == "manhattan"


def test_rotated_input_is_aligned_back(office_tls):
    sc, model = office_tls
    yaw = np.radians(35.0)
    rot = np.eye(4)
    rot[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    sub = sc.cloud.subset(np.random.default_rng(0).random(sc.cloud.n) < 0.6)
    m = reconstruct_manhattan(sub.transformed(rot), rng=0)
    assert len(m.spaces) == 8
    # the model's transform takes its rooms back onto the rotated scan
    t_room = max(sc.truth.spaces, key=lambda s: Polygon(s.footprint()).area)
    c_in = (rot @ np.r_[t_room.centroid, 1.0])[:3]
    centres = np.array([m.to_input_frame(s.centroid[None])[0] for s in m.spaces])
    assert np.min(np.linalg.norm(centres[:, :2] - c_in[:2], axis=1)) < 0.1


def test_house_multi_height_ceilings():
    sc = preset("house_multi_height", seed=1, noise="tls", target_points=150_000)
    model = reconstruct_manhattan(sc.cloud, rng=0)
    assert len(model.spaces) == len(sc.truth.spaces)
    heights = set()
    for t, m, iou in match_rooms(model, sc.truth):
        assert iou >= 0.95
        assert abs(m.bounds[1, 2] - t.bounds[1, 2]) <= 0.03, (t.name, m.bounds[1, 2], t.bounds[1, 2])
        assert abs(m.bounds[0, 2] - t.bounds[0, 2]) <= 0.03
        heights.add(round(float(t.bounds[1, 2]), 2))
    assert len(heights) >= 3  # the scene really has rooms of their own height


def test_two_storeys_are_stacked():
    sc = preset("two_storey_office", seed=1, noise="tls", target_points=200_000)
    model = reconstruct_manhattan(sc.cloud, rng=0)
    assert len(model.storeys) == len(sc.truth.storeys) == 2
    for m, t in zip(model.storeys, sc.truth.storeys):
        assert abs(m.floor_z - t.floor_z) <= 0.03 and abs(m.ceiling_z - t.ceiling_z) <= 0.03
    for k in (0, 1):
        truth_rooms = [s for s in sc.truth.spaces if s.storey == k]
        rooms = [s for s in model.spaces if s.storey == k]
        # every true room is found on its storey (storey 0: one wall face hidden by
        # furniture splits one room in two, see the note)
        matched = [max(footprint_iou(r, t) for r in rooms) for t in truth_rooms]
        assert sum(iou >= 0.95 for iou in matched) >= len(truth_rooms) - (1 if k == 0 else 0), matched
        assert all(s.bounds[0, 2] >= model.storeys[k].floor_z - 1e-6 for s in rooms)


# ----------------------------------------------------------------------------- pieces
def test_point_on_face_index_is_covered_share():
    rng = np.random.default_rng(0)
    sigma = 0.05
    n = int(4.0 / sigma**2)  # a 2 m x 2 m face sampled at spacing σ
    uv = rng.random((n, 2)) * 2.0
    full = grid_face_index(uv, np.array([0.0, 2.0]), np.array([0.0, 2.0]), sigma)
    assert 0.9 <= full[0, 0] <= 1.0
    half = grid_face_index(uv[uv[:, 0] < 1.0], np.array([0.0, 1.0, 2.0]), np.array([0.0, 2.0]), sigma)
    assert half[0, 0] >= 0.9 and half[1, 0] == 0.0
    # ten times denser: still at most 1 (a dense patch near a scanner is no bigger)
    dense = grid_face_index(rng.random((10 * n, 2)) * [0.5, 2.0], np.array([0.0, 2.0]), np.array([0.0, 2.0]), sigma)
    assert 0.2 <= dense[0, 0] <= 0.3
    # a neighbour's points just outside a thin face do not leak into it
    strip = grid_face_index(np.column_stack([rng.uniform(0, 1.0, n), rng.uniform(0, 2, n)]),
                            np.array([0.0, 1.0, 1.15]), np.array([0.0, 2.0]), sigma, margin=0.01)
    assert strip[1, 0] == 0.0
    # the general polygon version agrees
    pts = np.column_stack([uv, np.zeros(n)])
    sq = np.array([[0, 0, 0], [1, 0, 0], [1, 2, 0], [0, 2, 0]], float)
    v = face_index(pts, None, sq, np.array([0, 0, 1.0]), 0.02, sigma, np.radians(20))
    assert 0.55 <= v <= 1.0


def test_point_on_face_index_discs_stay_in_their_own_rectangle():
    """A disc covers its own rectangle alone, also across a rectangle narrower than its
    radius (each rectangle is dilated apart from the others: the rasters of two rectangles
    of one parity, dilated together, used to let a disc reach over a 2 cm one)."""
    sigma = 0.05
    for width in (0.02, 0.2):
        uv = np.column_stack([np.full(101, 0.99), np.linspace(0.0, 1.0, 101)])  # 1 cm from its edge
        got = grid_face_index(uv, np.array([0.0, 1.0, 1.0 + width, 2.0]), np.array([0.0, 1.0]), sigma)[:, 0]
        assert got[0] > 0.05 and got[1] == 0.0 and got[2] == 0.0, (width, got)
    # the same points on either side of a 2 cm rectangle: each side its own coverage
    two = np.vstack([uv, uv + [0.04, 0.0]])  # at 0.99 and 1.03
    got = grid_face_index(two, np.array([0.0, 1.0, 1.02, 2.0]), np.array([0.0, 1.0]), sigma)[:, 0]
    alone = grid_face_index(uv + [0.04, 0.0], np.array([0.0, 1.0, 1.02, 2.0]), np.array([0.0, 1.0]), sigma)
    assert got[1] == 0.0 and got[2] == pytest.approx(alone[2, 0], abs=1e-12) and got[2] > 0.03


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_point_on_face_index_measures_a_rectangle_thinner_than_its_raster(seed):
    """A 7 cm strip between two cuts, on a surface sampled as densely as either side of it,
    is seen as well as they are; it read 0 (no centre of a σ/3 = 5 cm raster cell lies in it
    once its margins are off: the Duplex's hallway ended at such a strip). Empty, it stays 0."""
    rng = np.random.default_rng(seed)
    sigma = 0.15
    uv = rng.random((int(4.0 / (sigma / 2) ** 2), 2)) * 2.0  # points σ/2 apart over 2 m x 2 m
    u = np.array([0.0, 1.066, 1.134, 2.0])  # inside its margins: 1.076-1.124, between cell centres
    got = grid_face_index(uv, u, np.array([0.0, 2.0]), sigma, margin=0.01)[:, 0]
    assert got[1] >= 0.9 and min(got[0], got[2]) >= 0.9, got
    empty = uv[(uv[:, 0] < u[1]) | (uv[:, 0] > u[2])]
    assert grid_face_index(empty, u, np.array([0.0, 2.0]), sigma, margin=0.01)[1, 0] == 0.0
    # a few points: the share of its length their discs reach, not all of it
    few = np.vstack([empty, [[1.1, 0.5], [1.1, 1.5]]])
    part = grid_face_index(few, u, np.array([0.0, 2.0]), sigma, margin=0.01)[1, 0]
    assert part == pytest.approx(2 * 2 * sigma / (2.0 - 2 * 0.01), abs=1e-9), part


@pytest.mark.parametrize("seed", [0, 1])
def test_point_on_face_index_follows_local_spacing(seed):
    """A ceiling seen sparsely from far away (points 2.5 σ apart, evenly) is seen with the
    adaptive radius, and barely without; isolated strays keep σ (issue 19)."""
    rng = np.random.default_rng(seed)
    sigma, far = 0.05, 0.125
    g = np.arange(0.0, 2.0, far) + far / 2
    uv = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2) + rng.normal(0, 0.01, (len(g) ** 2, 2))
    edges = np.array([0.0, 2.0])
    plain = grid_face_index(uv, edges, edges, sigma)[0, 0]
    adaptive = grid_face_index(uv, edges, edges, sigma, max_radius=3 * sigma)[0, 0]
    # discs of σ over a 2.5 σ lattice cover π/6.25 ≈ 0.5; of ≥ 2.25 σ (the class below
    # 2.5 σ·√(π/4)) nearly all
    assert plain <= 0.6 and adaptive >= 0.9, (plain, adaptive)
    # radii measured beforehand (over a larger neighbourhood) give the same index
    given = grid_face_index(uv, edges, edges, sigma, radii=local_radii(uv, sigma, 3 * sigma))[0, 0]
    assert given == pytest.approx(adaptive, abs=1e-12)
    # 12 strays over 4 m² (2 per m² is no surface): each covers σ only, adaptive or not
    strays = rng.uniform(0, 2, (12, 2))
    s_plain = grid_face_index(strays, edges, edges, sigma)[0, 0]
    s_adapt = grid_face_index(strays, edges, edges, sigma, max_radius=3 * sigma)[0, 0]
    assert s_adapt == pytest.approx(s_plain, abs=1e-12) and s_adapt < 0.03
    # and a dense face is not changed by it
    dense = rng.random((int(4.0 / sigma**2), 2)) * 2.0
    assert grid_face_index(dense, edges, edges, sigma, max_radius=3 * sigma)[0, 0] == pytest.approx(
        grid_face_index(dense, edges, edges, sigma)[0, 0], abs=0.02)


def test_classify_rule_conditions():
    t = 0.3
    wall, line = classify({"ipof_sides": 0.6, "ipof_top": 0.0}, True, False, t)
    assert wall == ShapeType.WALL and "wall" in line
    assert classify({"ipof_sides": 0.6, "ipof_top": 0.7}, True, False, t)[0] == ShapeType.INTERIOR
    assert classify({"ipof_sides": 0.6, "ipof_top": 0.0}, True, True, t)[0] == ShapeType.INTERIOR
    assert classify({"ipof_sides": 0.0, "ipof_top": 0.5}, False, False, t)[0] == ShapeType.INTERIOR
    typ, line = classify({"ipof_sides": 0.0, "ipof_top": 0.1}, False, False, t)
    assert typ == ShapeType.EXTERIOR and "0.10 < tau=0.3" in line
    # a seen top with no floor and no side under it, on the floor: a soffit or an eave
    soffit = {"ipof_top": 0.35, "ipof_bottom": 0.03, "ipof_f2": 0.0, "ipof_f3": 0.05, "ipof_f4": 0.0, "ipof_f5": 0.0}
    typ, line = classify(soffit, False, False, t, on_floor=True, min_evidence=0.1)
    assert typ == ShapeType.EXTERIOR and "soffit" in line
    assert classify(soffit, False, False, t, on_floor=False, min_evidence=0.1)[0] == ShapeType.INTERIOR  # upper layer
    assert classify(soffit, False, False, t)[0] == ShapeType.INTERIOR  # the thesis's rule (min_evidence 0)
    # one side seen (a wall running on past the glazing) under a partial top: still a soffit
    assert classify({**soffit, "ipof_f5": 0.35}, False, False, t, on_floor=True, min_evidence=0.1)[0] == \
        ShapeType.EXTERIOR
    for change in ({"ipof_bottom": 0.2}, {"ipof_f3": 0.4, "ipof_f5": 0.4}, {"ipof_f3": 0.4, "ipof_top": 0.7}):
        # floor under it, two walls, or one wall under a well seen ceiling: a room part
        assert classify({**soffit, **change}, False, False, t, on_floor=True, min_evidence=0.1)[0] == \
            ShapeType.INTERIOR
    # a ceiling seen only sparsely (a strip over a cabinet, seen from far away): interior over
    # a seen floor, or some floor and two sides seen; not alone, nor above the floor
    strip = {"ipof_top": 0.21, "ipof_top_sparse": 0.45, "ipof_bottom": 0.35, "ipof_sides": 0.24,
             "ipof_f2": 0.0, "ipof_f3": 0.0, "ipof_f4": 0.0, "ipof_f5": 0.0}
    typ, line = classify(strip, False, False, t, on_floor=True, min_evidence=0.1)
    assert typ == ShapeType.INTERIOR and "sparsely" in line
    hidden = {**strip, "ipof_bottom": 0.17}  # a cabinet hides most of the floor
    assert classify(hidden, False, False, t, on_floor=True, min_evidence=0.1)[0] == ShapeType.EXTERIOR
    assert classify({**hidden, "ipof_f3": 0.19, "ipof_f5": 0.29}, False, False, t, on_floor=True,
                    min_evidence=0.1)[0] == ShapeType.INTERIOR
    for change in ({"ipof_top_sparse": 0.29}, {"ipof_bottom": 0.05, "ipof_f3": 0.4, "ipof_f5": 0.4}):
        assert classify({**strip, **change}, False, False, t, on_floor=True, min_evidence=0.1)[0] == \
            ShapeType.EXTERIOR
    assert classify(strip, False, False, t, on_floor=False, min_evidence=0.1)[0] == ShapeType.EXTERIOR


def test_union_of_boxes():
    L = union_of_boxes(np.array([[[0, 0, 0], [2, 1, 3]], [[0, 1, 0], [1, 2, 3]]], float))
    fp = L.footprint()
    assert fp is not None and Polygon(fp).area == pytest.approx(3.0)
    assert L.volume() == pytest.approx(9.0)
    stacked = union_of_boxes(np.array([[[0, 0, 0], [2, 1, 2]], [[0, 0, 2], [1, 1, 3]]], float))
    assert stacked.footprint() is None
    assert stacked.volume() == pytest.approx(5.0)


def test_spacing_estimate():
    rng = np.random.default_rng(2)
    xy = rng.random((40_000, 2)) * [10.0, 10.0]  # 400 points / m²: σ = 5 cm
    s = estimate_spacing(np.column_stack([xy, np.zeros(len(xy))]), rng=0)
    assert 0.04 <= s <= 0.065


def test_bad_input_and_cancel(office_tls):
    sc, _ = office_tls
    with pytest.raises(EmptyCloudError):
        reconstruct_manhattan(PointCloud(np.zeros((3, 3))))
    flat = PointCloud(np.column_stack([np.random.default_rng(0).random((5000, 2)) * 5, np.zeros(5000)]))
    with pytest.raises(ReconstructionError):
        reconstruct_grammar(flat)
    with pytest.raises(Cancelled):
        reconstruct_manhattan(sc.cloud.subset(slice(0, 20000)), should_stop=lambda: True)


def test_progress_and_same_seed_same_model(office_tls):
    sc, _ = office_tls
    sub = sc.cloud.subset(np.random.default_rng(1).random(sc.cloud.n) < 0.4)
    seen = []
    a = reconstruct_manhattan(sub, rng=7, progress=lambda f, msg: seen.append((f, msg)))
    b = reconstruct_manhattan(sub, rng=7)
    assert seen and seen[-1][0] == pytest.approx(1.0)
    assert all(f2 >= f1 for (f1, _), (f2, _) in zip(seen, seen[1:]))

    def strip(m):
        d = m.to_dict()
        d["provenance"]["timings"] = {}
        return json.dumps(d, sort_keys=True)

    assert strip(a) == strip(b)
    assert len(a.spaces) == 8


def test_parameters_from_data_and_thesis_table():
    rng = np.random.default_rng(3)
    xy = rng.random((40_000, 2)) * 10.0
    xyz = np.column_stack([xy, rng.normal(0, 0.01, len(xy))])  # σ_noise = 1 cm
    from engine.grammar import params_from_data

    p = params_from_data(xyz)
    assert p.complete and 0.007 <= p.noise <= 0.013
    assert p.shape_buffer >= 3 * p.noise and p.shape_buffer <= p.max_wall_thickness / 4
    assert 0.02 <= p.bin_size <= p.max_wall_thickness / 2
    kept = params_from_data(xyz, ManhattanParams(bin_size=0.04))
    assert kept.bin_size == 0.04  # a chosen value is kept
    t = ManhattanParams.spec_table("synthetic")
    assert (t.bin_size, t.max_wall_thickness, t.shape_buffer) == (0.05, 0.5, 0.05)
    with pytest.raises(ValueError):
        ManhattanParams.spec_table("nope")


def _row_of_cuboids(widths, thin_len, bottom, faces, types):
    """Three cuboids along y — room, a 0.24 m band, room — ``thin_len`` long in x (the band
    between the rooms), as ``place_storey`` leaves them before its passage pass."""
    from engine.grammar.geometry import box_of
    from engine.model import Shape

    ys = np.cumsum([0.0] + list(widths))
    shapes, grid = {}, np.empty((1, 3, 1), dtype=object)
    for j, t in enumerate(types):
        sup = {"ipof_bottom": bottom if j == 1 else 0.9, **({f"ipof_f{q}": v for q, v in faces.items()} if j == 1 else {})}
        shapes[(0, j, 0)] = Shape(id=f"c{j}", type=t, geometry=box_of((0, ys[j], 0), (thin_len, ys[j + 1], 2.5)),
                                  grid=(0, j, 0), support=sup, attributes={"thin_axis": 1 if j == 1 else None})
        grid[0, j, 0] = t
    return shapes, grid


@pytest.mark.parametrize("length, bottom, face, expect", [
    (3.4, 0.99, 0.08, ShapeType.INTERIOR),   # FZK-Haus: 3.4 m under a 0.24 m beam, floor seen -> one open plan
    (3.4, 0.05, 0.08, ShapeType.EXTERIOR),   # no floor under it: a wall hidden behind furniture
    (3.4, 0.99, 0.45, ShapeType.EXTERIOR),   # a face of it seen: a wall with a low opening
])
def test_wide_passage_joins_rooms(length, bottom, face, expect):
    from engine.grammar.passages import wide_passages as _wide_passages

    I, E = ShapeType.INTERIOR, ShapeType.EXTERIOR
    shapes, types = _row_of_cuboids((4.0, 0.24, 1.5), length, bottom, {2: face, 4: 0.08}, (I, E, I))
    _wide_passages(shapes, types, ManhattanParams())
    assert shapes[(0, 1, 0)].type == expect and types[0, 1, 0] == expect
    if expect == I:  # it joins the narrower side; the open boundary faces the 4 m room (face -y)
        assert "passage" in shapes[(0, 1, 0)].log[-1] and shapes[(0, 1, 0)].attributes["open_face"] == 2
    shapes, types = _row_of_cuboids((4.0, 0.24, 1.5), length, bottom, {2: face, 4: 0.08}, (I, E, E))
    _wide_passages(shapes, types, ManhattanParams())  # outside on one side: never a passage
    assert shapes[(0, 1, 0)].type == E


def _band_between(flank, length=1.96, bottom=0.2, flank_len=1.0, top=0.0):
    """:func:`_row_of_cuboids` (a 0.13 m band between two rooms, ``length`` long) with a column
    of cuboids of the types ``flank`` (along y) on either side of it along x."""
    from engine.grammar.geometry import box_of

    I, E = ShapeType.INTERIOR, ShapeType.EXTERIOR
    mid, g = _row_of_cuboids((4.0, 0.13, 1.5), length, bottom, {2: 0.0, 4: 0.0}, (I, E, I))
    mid[(0, 1, 0)] = mid[(0, 1, 0)].with_(support={**mid[(0, 1, 0)].support, "ipof_top": top})
    shapes, grid = {}, np.empty((3, 3, 1), dtype=object)
    for i, (x0, x1) in enumerate(((-flank_len, 0.0), (0.0, length), (length, length + flank_len))):
        for j in range(3):
            b = mid[(0, j, 0)].geometry.bounds
            t = g[0, j, 0] if i == 1 else flank[j]
            shapes[(i, j, 0)] = mid[(0, j, 0)].__class__(**{
                **mid[(0, j, 0)].__dict__, "id": f"c{i}{j}", "grid": (i, j, 0), "type": t,
                "geometry": box_of((x0, b[0][1], 0), (x1, b[1][1], 2.5))})
            grid[i, j, 0] = t
    return shapes, grid


@pytest.mark.parametrize("flank, bottom, top, expect", [
    ("WWW", 0.2, 0.0, ShapeType.INTERIOR),   # the Duplex's 1.96 m hallway: side walls run on across the band
    ("WWE", 0.2, 0.0, ShapeType.INTERIOR),   # ... one of them a piece no scan saw (beside a stair's void)
    ("WWW", 0.0, 0.11, ShapeType.INTERIOR),  # its floor unseen, a little of its ceiling seen (TLS seed 5)
    ("IWI", 0.2, 0.0, ShapeType.EXTERIOR),   # a doorway: its jambs are pieces of the wall it pierces
    ("WWW", 0.05, 0.05, ShapeType.EXTERIOR),  # neither floor nor ceiling seen: a wall's body (faces unseen)
])
def test_a_band_across_a_corridor_between_its_side_walls_joins_its_parts(flank, bottom, top, expect):
    """A thin band whose ceiling a far scan missed, between two parts of a hallway 1.96 m wide
    (under ``min_passage_width``): when the walls at its ends run on across it — the hallway's
    side walls — it is part of the hallway, not a doorway (whose ends are the pierced wall's
    pieces, with the rooms beside them). The Duplex at 200k points (TLS): both hallways of its
    upper level were cut in two and the bedrooms' doors led into the split-off ends."""
    from engine.grammar.passages import wide_passages as _wide_passages

    kinds = {"W": ShapeType.WALL, "E": ShapeType.EXTERIOR, "I": ShapeType.INTERIOR}
    shapes, types = _band_between([kinds[c] for c in flank], bottom=bottom, top=top)
    _wide_passages(shapes, types, ManhattanParams())
    assert shapes[(1, 1, 0)].type == expect and types[1, 1, 0] == expect


def _two_columns(lengths, bottom=0.99):
    """Two columns of :func:`_row_of_cuboids` side by side along x (cut at a stair's side)."""
    from engine.grammar.geometry import box_of

    I, E = ShapeType.INTERIOR, ShapeType.EXTERIOR
    shapes, grid = {}, np.empty((2, 3, 1), dtype=object)
    x0 = 0.0
    for i, ln in enumerate(lengths):
        sub, g = _row_of_cuboids((4.0, 0.12, 1.5), ln, bottom, {2: 0.0, 4: 0.0}, (I, E, I))
        for (_, j, k), sh in sub.items():
            b = sh.geometry.bounds
            shapes[(i, j, k)] = sh.__class__(**{**sh.__dict__, "id": f"c{i}{j}", "grid": (i, j, k),
                                                "geometry": box_of((x0, b[0][1], 0), (x0 + ln, b[1][1], 2.5))})
            grid[i, j, k] = g[0, j, k]
        x0 += ln
    return shapes, grid


@pytest.mark.parametrize("beam, lengths, expect_open", [
    (True, (1.0, 1.05), True),     # a row of two cuboids 2.05 m long under a beam: split at the beam
    (False, (1.0, 1.05), False),   # nothing near the ceiling (Duplex TLS foyer): one room, no boundary
    (False, (0.9,), None),         # a door's width: stays exterior
])
def test_wide_passage_row_and_beam(beam, lengths, expect_open):
    from engine.grammar.ends import UpperBand
    from engine.grammar.passages import wide_passages as _wide_passages
    from engine.grammar.place import StoreyFrame

    shapes, types = _two_columns(lengths)
    rng = np.random.default_rng(0)
    pts = [np.column_stack([rng.uniform(0, 2.05, 2000), rng.uniform(0, 9, 2000), np.full(2000, 0.0)])]
    normal_y = []
    if beam:  # a 0.25 m downstand: its two faces at y = 4.0 and 4.12, from 2.25 to 2.5 m
        for y in (4.0, 4.12):
            pts.append(np.column_stack([rng.uniform(0, 2.05, 600), np.full(600, y), rng.uniform(2.25, 2.5, 600)]))
            normal_y.append(len(pts) - 1)
    p = np.vstack(pts)
    kind = np.concatenate([np.full(len(q), 1 if k in normal_y else 2) for k, q in enumerate(pts)])
    params = ManhattanParams(shape_buffer=0.03, spacing=0.03, noise=0.005, bin_size=0.02)
    upper = UpperBand(p, [kind == 0, kind == 1, kind == 2], StoreyFrame(0.0, (2.5,)), params, 0.03)
    _wide_passages(shapes, types, params, upper)
    for i in range(len(lengths)):
        s = shapes[(i, 1, 0)]
        if expect_open is None:
            assert s.type == ShapeType.EXTERIOR
            continue
        assert s.type == ShapeType.INTERIOR and types[i, 1, 0] == ShapeType.INTERIOR
        assert ("open_face" in s.attributes) == expect_open, s.log[-1]


@pytest.mark.parametrize("width, bottom, ends, room, expect", [
    (0.6, 0.18, 0.27, ShapeType.INTERIOR, ShapeType.INTERIOR),  # Duplex TLS: strip beside a stair void
    (0.6, 0.18, 0.0, ShapeType.INTERIOR, ShapeType.EXTERIOR),   # an end open to the outside
    (0.6, 0.05, 0.27, ShapeType.INTERIOR, ShapeType.EXTERIOR),  # no floor seen under it
    (1.5, 0.18, 0.27, ShapeType.INTERIOR, ShapeType.EXTERIOR),  # wider than a pocket: a light well, a yard
    (0.6, 0.18, 0.27, ShapeType.EXTERIOR, ShapeType.EXTERIOR),  # open to no room: a shaft
])
def test_a_narrow_pocket_closed_by_walls_and_open_to_a_room_is_part_of_it(width, bottom, ends, room, expect):
    """A strip on the floor whose ceiling no scan line crossed (wall | strip | room along y, its
    two ends on the grid's edge with faces seen ``ends``) is the room's when walls and rooms
    close it and it opens to a room; else it stays exterior."""
    from engine.grammar.geometry import box_of
    from engine.grammar.passages import enclosed_pockets
    from engine.model import Shape

    ys = np.cumsum([0.0, 0.12, width, 4.0])
    kinds = (ShapeType.WALL, ShapeType.EXTERIOR, room)
    shapes, types = {}, np.empty((1, 3, 1), dtype=object)
    for j, t in enumerate(kinds):
        sup = {"ipof_bottom": bottom, "ipof_top": 0.02, "ipof_f2": 0.0, "ipof_f4": 0.0, "ipof_f3": ends,
               "ipof_f5": ends} if j == 1 else {"ipof_bottom": 0.9, "ipof_top": 0.9}
        shapes[(0, j, 0)] = Shape(id=f"c{j}", type=t, geometry=box_of((0, ys[j], 0), (2.0, ys[j + 1], 2.6)),
                                  grid=(0, j, 0), support=sup,
                                  attributes={"thin_axis": 1 if j == 0 else None})
        types[0, j, 0] = t
    enclosed_pockets(shapes, types, ManhattanParams())
    assert shapes[(0, 1, 0)].type == expect and types[0, 1, 0] == expect
    if expect == ShapeType.INTERIOR:
        strip = shapes[(0, 1, 0)]
        assert strip.attributes["ceiling_seen"] is False and "closed by walls" in strip.log[-1]


@pytest.mark.parametrize("beyond, free_face, expect", [
    (ShapeType.EXTERIOR, 0.0, ShapeType.INTERIOR),  # the Duplex bedroom's slice before the party wall
    (ShapeType.INTERIOR, 0.0, ShapeType.WALL),  # rooms both sides: seen from either, a wall
    (ShapeType.EXTERIOR, 0.2, ShapeType.WALL)])  # something at the room's face: a wall's second face
def test_a_slice_before_a_wall_seen_from_the_room_is_the_rooms(beyond, free_face, expect):
    """party wall core | 10 cm slice | room along x: the slice's face on the wall is seen
    (0.93), the one on the room not; the grid cut it off the room at a wall line elsewhere
    (engine.grammar.passages.room_slices). It is the room's, unless a room lies beyond the
    wall too or its face on the room holds a surface."""
    from engine.grammar.geometry import box_of
    from engine.grammar.passages import room_slices
    from engine.model import Shape

    xs = np.cumsum([0.0, 0.55, 0.1, 3.7])
    kinds = (beyond, ShapeType.WALL, ShapeType.INTERIOR)
    shapes, types = {}, np.empty((3, 1, 1), dtype=object)
    for i, t in enumerate(kinds):
        sup = {"ipof_bottom": 0.0, "ipof_top": 0.0, "ipof_f5": 0.93, "ipof_f3": free_face} if i == 1 else \
            {"ipof_bottom": 0.9, "ipof_top": 0.9}
        shapes[(i, 0, 0)] = Shape(id=f"c{i}", type=t, geometry=box_of((xs[i], 0, 0), (xs[i + 1], 5.0, 2.6)),
                                  grid=(i, 0, 0), support=sup,
                                  attributes={"thin_axis": 0 if i == 1 else None})
        types[i, 0, 0] = t
    room_slices(shapes, types, ManhattanParams())
    assert shapes[(1, 0, 0)].type == expect and types[1, 0, 0] == expect


@pytest.mark.parametrize("gap, expect", [(0.06, ShapeType.INTERIOR), (0.12, ShapeType.EXTERIOR)])
def test_a_pocket_behind_a_sliver_joins_the_room_with_it(gap, expect):
    """wall | pocket | gap | room along y: a 6 cm sliver (two cuts of one surface, thinner than
    2 shape_buffer) between the pocket and the room joins with the pocket; a gap as thick as a
    wall (a doorway) keeps the pocket out of the room beyond it."""
    from engine.grammar.geometry import box_of
    from engine.grammar.passages import enclosed_pockets
    from engine.model import Shape

    ys = np.cumsum([0.0, 0.12, 0.54, gap, 4.0])
    kinds = (ShapeType.WALL, ShapeType.EXTERIOR, ShapeType.EXTERIOR, ShapeType.INTERIOR)
    shapes, types = {}, np.empty((1, 4, 1), dtype=object)
    for j, t in enumerate(kinds):
        sup = {"ipof_bottom": 0.19 if j == 1 else (0.0 if j == 2 else 0.9),
               "ipof_top": 0.0 if j in (1, 2) else 0.9,
               "ipof_f3": 0.3 if j == 1 else 0.0, "ipof_f5": 0.3 if j == 1 else 0.0}
        shapes[(0, j, 0)] = Shape(id=f"c{j}", type=t, geometry=box_of((0, ys[j], 0), (2.0, ys[j + 1], 2.6)),
                                  grid=(0, j, 0), support=sup,
                                  attributes={"thin_axis": 1 if j in (0, 2) else None})
        types[0, j, 0] = t
    enclosed_pockets(shapes, types, ManhattanParams(shape_buffer=0.05))
    assert types[0, 1, 0] == expect and types[0, 2, 0] == expect


def _half_seen_room(window: bool):
    """three_storey_house mobile (seeds 3, 4, 7): a bedroom (0..7 x 0..4 m) cut at x 4..4.15 by
    the plane of a partition of the rooms north of it; the walk stayed in its west half, so its
    east half's ceiling (0.06) and floor (0.16) were seen only at a glance and it was typed
    exterior, yet its far walls (y = 0 and x = 7) were seen across it. ``window``: the face at
    x = 4.15 is seen (a wall with a window in it between the two halves)."""
    from engine.grammar.geometry import box_of
    from engine.model import Shape

    X, Y = np.array([0.0, 4.0, 4.15, 7.0]), np.array([0.0, 4.0, 4.15, 8.0])
    I, E, W = ShapeType.INTERIOR, ShapeType.EXTERIOR, ShapeType.WALL
    kinds = {(0, 0): I, (1, 0): I, (2, 0): E, (0, 1): W, (1, 1): W, (2, 1): E, (0, 2): I, (1, 2): W,
             (2, 2): I}
    faces = {(2, 0): dict(ipof_bottom=0.16, ipof_top=0.06, ipof_f2=0.48, ipof_f3=0.38, ipof_f4=0.19,
                          ipof_f5=0.5 if window else 0.0),
             (1, 0): dict(ipof_bottom=0.7, ipof_top=0.3, ipof_f3=0.5 if window else 0.0),
             (2, 1): dict(ipof_f2=0.19, ipof_f4=0.27)}
    shapes, types = {}, np.empty((3, 3, 1), dtype=object)
    for (i, j), t in kinds.items():
        sup = {f"ipof_f{q}": 0.0 for q in range(2, 6)}
        sup.update({"ipof_bottom": 0.9, "ipof_top": 0.9} if t == I else {"ipof_bottom": 0.0, "ipof_top": 0.0})
        sup.update(faces.get((i, j), {}))
        thin = 2 if (i, j) == (1, 1) else 0 if i == 1 else 1 if j == 1 else None
        shapes[i, j, 0] = Shape(id=f"c{i}{j}", type=t, grid=(i, j, 0), support=sup,
                                geometry=box_of((X[i], Y[j], 0), (X[i + 1], Y[j + 1], 2.6)),
                                attributes={"thin_axis": thin})
        types[i, j, 0] = t
    # the far walls' points: y = 0 and x = 7 over the east half, 5 cm apart
    g = np.arange(0.025, 2.6, 0.05)
    u1, z1 = np.meshgrid(np.arange(4.175, 7.0, 0.05), g, indexing="ij")
    u2, z2 = np.meshgrid(np.arange(0.025, 4.0, 0.05), g, indexing="ij")
    south = np.column_stack([u1.ravel(), np.zeros(u1.size), z1.ravel()])
    east = np.column_stack([np.full(u2.size, 7.0), u2.ravel(), z2.ravel()])
    xyz = np.vstack([south, east])
    normals = np.vstack([np.tile([0.0, 1.0, 0.0], (len(south), 1)),
                         np.tile([-1.0, 0.0, 0.0], (len(east), 1))])
    return shapes, types, xyz, normals, X, Y


@pytest.mark.parametrize("scanner, window, expect", [
    ((2.0, 2.0, 1.5), False, ShapeType.INTERIOR),  # seen across the room from its west half
    (None, False, ShapeType.INTERIOR),             # no positions: a stand-in in the west half
    ((2.0, 2.0, 1.5), True, ShapeType.EXTERIOR),   # seen only through a window: proves nothing
    ((9.0, 2.0, 1.5), False, ShapeType.EXTERIOR),  # from a scanner outside the building
    ((2.0, 6.0, 1.5), False, ShapeType.EXTERIOR),  # from the room north of it, through its wall
])
def test_a_room_whose_far_walls_were_seen_through_it_from_inside_is_interior(scanner, window, expect):
    """"Not seen" is not "not there": an exterior cuboid wider than a pocket whose far walls were
    seen from an interior cuboid, along rays through interior cuboids and unseen faces only, is
    part of the room they were seen from (:func:`engine.grammar.visibility.seen_through`); the
    partition between it and the room north of it stays as it was."""
    from engine.grammar.passages import enclosed_pockets
    from engine.grammar.place import StoreyFrame
    from engine.grammar.visibility import Views, seen_through

    shapes, types, xyz, normals, X, Y = _half_seen_room(window)
    params = ManhattanParams(max_wall_thickness=0.3, shape_buffer=0.05, spacing=0.05, noise=0.01,
                             bin_size=0.02)
    views = Views() if scanner is None else Views(np.array([scanner]), np.zeros(len(xyz), np.int32))
    seen = seen_through(shapes, types, xyz, normals, X, Y, StoreyFrame(0.0, (2.6,)), 0, params, 0.05,
                        0.02, views)
    assert ((2, 0) in seen) == (expect == ShapeType.INTERIOR)
    assert seen_through(shapes, types, xyz, normals, X, Y, StoreyFrame(0.0, (2.6,)), 0, params, 0.05,
                        0.02, None) == {}  # no test without views
    enclosed_pockets(shapes, types, params, seen)
    assert types[2, 0, 0] == expect and shapes[2, 0, 0].type == expect
    assert types[2, 1, 0] == ShapeType.EXTERIOR  # the partition's gap: not joined to either room
    if expect == ShapeType.INTERIOR:
        assert shapes[2, 0, 0].attributes["ceiling_seen"] is False and "face 5" in shapes[2, 0, 0].log[-1]
    # without the visibility test the wide cuboid is no pocket
    shapes, types, *_ = _half_seen_room(window)
    enclosed_pockets(shapes, types, params)
    assert types[2, 0, 0] == ShapeType.EXTERIOR


@pytest.mark.parametrize("seed", [0, 1])
def test_attic_needs_the_flat_ceilings_to_be_few(seed):
    """A storey is an attic (its sloped points copied onto its top as ceiling) only when they
    outnumber the flat points at all its ceiling levels in its upper half, not at its top
    level alone: Duplex level 2 (mobile, seed 6) has flat 5.7 m ceilings under a small 6.63 m
    one, and the tilted normals of its wall tops (9,201 points against 2,008 at 6.63 m, 45,964
    at both levels) made it an "attic" whose copied points over the wall lines merged three
    rooms."""
    from engine.grammar.manhattan import _with_sloped_ceiling
    from engine.grammar.place import StoreyFrame

    rng = np.random.default_rng(seed)
    params = ManhattanParams(shape_buffer=0.05)

    def plane(n, z, nz):
        xyz = np.column_stack([rng.uniform(0, 8, n), rng.uniform(0, 8, n), np.full(n, z) + rng.normal(0, 0.005, n)])
        nrm = np.column_stack([np.sqrt(1 - nz**2) * np.ones(n), np.zeros(n), np.full(n, nz)])
        return xyz, nrm

    floor = plane(20000, 0.0, 1.0)
    low, high = plane(20000, 2.6, 1.0), plane(1000, 3.5, 1.0)
    tilted = plane(4000, 2.4, 0.5)  # wall tops' normals, sloped
    frame = StoreyFrame(0.0, (2.6, 3.5))
    xyz, nrm = (np.vstack(a) for a in zip(floor, low, high, tilted))
    out, _, under = _with_sloped_ceiling(xyz, nrm, frame, params)
    assert under is None and out is xyz  # flat ceilings: no attic (4,000 sloped vs 21,000 flat)
    # an attic: the same sloped points under a small flat top and no flat ceiling below it
    xyz, nrm = (np.vstack(a) for a in zip(floor, high, tilted))
    out, _, under = _with_sloped_ceiling(xyz, nrm, StoreyFrame(0.0, (3.5,)), params)
    assert under is not None and len(out) == len(xyz) + len(under) and len(under) == 4000


def _face(y, x0, x1, z0, z1, step, rng):
    gx, gz = np.meshgrid(np.arange(x0, x1, step), np.arange(z0, z1, step), indexing="ij")
    t = y + rng.normal(0.0, 0.003, gx.size)
    return t, np.column_stack([gx.ravel(), gz.ravel()])


def test_a_walls_second_face_seen_little_still_makes_a_cut():
    """paired_faces: a surface under min_wall_area is kept when it is the far face of a wall
    (behind a strong face, within the wall thickness, seen from the other side); clutter in
    front of a wall (seen from the wall's own side) and surfaces of mixed orientation are not."""
    from engine.grammar.place import paired_faces
    from engine.grammar.place import histogram_peaks

    rng = np.random.default_rng(0)
    params = ManhattanParams(bin_size=0.03, shape_buffer=0.03, spacing=0.02, noise=0.005)
    parts = [  # (y, x range, z range, side the scanner saw it from: the normals' sign)
        (0.0, (0.0, 3.0), (0.0, 2.4), -1),   # the partition's face toward y < 0, 7.2 m²
        (0.15, (1.0, 2.0), (1.2, 2.0), +1),  # its far face, 0.8 m² seen (furniture hides the rest)
        (-0.3, (0.2, 1.2), (0.0, 0.8), -1),  # a cabinet's front before the near face: 0.8 m²
        (2.0, (0.0, 3.0), (0.0, 2.4), +1),   # another wall, 7.2 m²
        (1.8, (1.0, 2.0), (1.0, 1.8), +1),   # 0.2 m behind it, seen from the same side: 0.8 m²
    ]
    ts, uvs, signs = [], [], []
    for y, (x0, x1), (z0, z1), side in parts:
        t, uv = _face(y, x0, x1, z0, z1, 0.02, rng)
        ts.append(t), uvs.append(uv), signs.append(np.full(len(t), float(side)))
    t, uv, sign = np.concatenate(ts), np.vstack(uvs), np.concatenate(signs)
    strong = histogram_peaks(t, uv, params, 0.02, params.min_wall_area)
    assert [round(p.position, 1) for p in strong] == [0.0, 2.0]
    partners = {}
    kept = [round(p.position, 2) for p in paired_faces(strong, t, uv, sign, params, 0.02, partners=partners)]
    assert kept == [0.0, 0.15, 2.0]
    assert [(round(w, 2), round(s, 2)) for w, s in partners.items()] == [(0.15, 0.0)]
    # normals of no clear orientation (unoriented): nothing is paired
    mixed = np.where(rng.random(len(t)) < 0.5, 1.0, -1.0)
    assert [round(p.position, 1) for p in paired_faces(strong, t, uv, mixed, params, 0.02)] == [0.0, 2.0]
    # off when min_paired_wall_area is not below min_wall_area
    off = params.with_(min_paired_wall_area=params.min_wall_area)
    assert len(paired_faces(strong, t, uv, sign, off, 0.02)) == 2
    # a strong cut within a wall's thickness beyond the weak face (0.45 m): the interval is
    # thin already, one more cut would only make strips
    t2, uv2 = _face(0.45, 0.0, 3.0, 0.0, 2.4, 0.02, rng)
    t3, uv3, sign3 = np.r_[t, t2], np.vstack([uv, uv2]), np.r_[sign, np.full(len(t2), 1.0)]
    strong3 = histogram_peaks(t3, uv3, params, 0.02, params.min_wall_area)
    assert [round(p.position, 2) for p in strong3] == [0.0, 0.45, 2.0]
    assert [round(p.position, 2) for p in paired_faces(strong3, t3, uv3, sign3, params, 0.02)] == [0.0, 0.45, 2.0]


def test_without_scanner_positions_a_walls_second_face_is_told_by_its_open_side():
    """paired_faces without oriented normals (no scanner positions; three_storey_house mobile
    at 300k points lost a door with the partition it was in): a weak surface is the far face
    of a wall when, where both are seen, each has the other within reach behind it and
    nothing before it. A cabinet's front 0.3 m before a partition seen from both sides is not:
    behind the partition's near face lies its far face too."""
    from engine.grammar.place import histogram_peaks, paired_faces

    rng = np.random.default_rng(1)
    params = ManhattanParams(bin_size=0.03, shape_buffer=0.03, spacing=0.02, noise=0.005)

    def faces(parts):
        ts, uvs = zip(*(_face(y, x0, x1, z0, z1, 0.02, rng) for y, (x0, x1), (z0, z1) in parts))
        t, uv = np.concatenate(ts), np.vstack(uvs)
        strong = histogram_peaks(t, uv, params, 0.02, params.min_wall_area)
        return ([round(p.position, 2) for p in strong],
                [round(p.position, 2) for p in paired_faces(strong, t, uv, None, params, 0.02)])

    # a partition's face (7.2 m²), its far face seen over 0.8 m², another wall 2 m away
    strong, kept = faces([(0.0, (0.0, 3.0), (0.0, 2.4)), (0.15, (1.0, 2.0), (1.2, 2.0)),
                          (2.0, (0.0, 3.0), (0.0, 2.4))])
    assert strong == [0.0, 2.0] and kept == [0.0, 0.15, 2.0]
    # a partition seen from both sides (two strong faces) and a cabinet's front before it
    strong, kept = faces([(0.0, (0.0, 3.0), (0.0, 2.4)), (0.15, (0.0, 3.0), (0.0, 2.4)),
                          (-0.3, (0.5, 2.0), (0.0, 0.9))])
    assert strong == [0.0, 0.15] and kept == strong
    # a partition whose far face is seen only at one end (where a surface 0.45 m before the
    # near face is not): the near face has its other face already and takes no second one
    # (the Duplex mobile at 300k points: a cut 0.46 m from a bathroom's partition split a
    # doorway off its wall, and the door was lost)
    strong, kept = faces([(0.0, (0.0, 3.0), (0.0, 2.4)), (-0.1, (0.0, 1.0), (0.0, 2.4)),
                          (0.45, (1.2, 2.6), (0.4, 1.4))])
    assert strong == [-0.1, 0.0] and kept == strong


def test_a_storey_without_a_ceiling_level_keeps_the_preprocessings_top():
    """FZK-Haus's attic at 1M points: its ridge's flat strip, seen at a grazing angle, holds
    1.5 m² in σ-cells (2.7 m² at 300k), under ``min_level_area`` (2 m²): the storey had one
    level, no frame, and was dropped with its rooms, walls and slabs. The preprocessing's
    storey (its top followed up the roof) gives the frame: the floor level found, its top."""
    from engine.grammar.place import Level, given_frame, storey_frame

    params = ManhattanParams()
    floor = Level(2.702, 64.7, 1.0, 1.0)
    assert storey_frame([floor], params) is None
    fr = given_frame([floor], (2.700, 6.031), params)
    assert fr.floor == pytest.approx(2.702) and fr.ceilings == (pytest.approx(6.031),)
    # no exposed level near the given floor: the given floor; a storey lower than a storey: none
    fr = given_frame([Level(4.0, 3.0, 1.0, 0.2)], (2.700, 6.031), params)
    assert fr.floor == pytest.approx(2.700)
    assert given_frame([floor], (2.700, 2.700 + 0.9 * params.min_storey_height), params) is None


def test_the_ground_seen_through_a_door_is_not_the_storeys_floor():
    """FZK-Haus at 1M points (TLS): the ground outside the front door, 5 cm under the floor and
    seen through the door, made a 3 m² level with nothing below it under the 90 m² floor. As
    the lowest such level it was the storey's floor: every room's floor lay 5 cm above it, none
    was seen, and the evidence rule removed all five rooms. The floor is the lowest level with
    nothing below it and a quarter of the largest one's area; a sunken part as large stays the
    floor."""
    from engine.grammar.place import Level, storey_frame

    params = ManhattanParams()
    ceiling = Level(2.502, 90.9, 1.0, 0.0)
    fr = storey_frame([Level(-0.052, 3.0, 0.0, 1.0), Level(0.002, 93.9, 0.0, 0.95), ceiling], params)
    assert fr.floor == pytest.approx(0.002) and fr.ceilings == (pytest.approx(2.502),)
    fr = storey_frame([Level(-0.3, 30.0, 0.0, 1.0), Level(0.002, 63.9, 0.0, 0.95), ceiling], params)
    assert fr.floor == pytest.approx(-0.3)


@pytest.mark.parametrize("ceiling_over_it, expect", [
    (False, ShapeType.EXTERIOR),  # only the ceiling's noise near the wall's faces: part of the doorway
    (True, ShapeType.INTERIOR),   # the ceiling runs on over it: not under a lintel
])
def test_doorway_cut_in_two_by_a_cross_wall_plane(ceiling_over_it, expect):
    """two_storey_office mobile 3: a door in the corridor wall (y 1.9..2.1) cut at x = 10.1 by
    the plane of a wall of the storey's other side; the 22 cm piece, thin both ways, had its top
    covered by ceiling points pushed into the wall's footprint (0.70) and joined the corridor and
    the room; the other piece was the doorway (exterior), then the wall runs on."""
    from engine.grammar.geometry import box_of
    from engine.grammar.passages import doorway_tops
    from engine.model import Shape

    X, Y = np.array([9.51, 9.88, 10.1, 10.52, 13.9]), np.array([0.1, 1.9, 2.1, 6.9])
    I, E, W = ShapeType.INTERIOR, ShapeType.EXTERIOR, ShapeType.WALL
    line = [(W, 2, 0.9), (I, 2, 0.23), (E, 2, 0.25), (W, 1, 0.9)]  # type, thin axis, faces toward y
    shapes, types = {}, np.empty((4, 3, 1), dtype=object)
    for i in range(4):
        for j in range(3):
            t, thin, face = line[i] if j == 1 else (I, None, 0.0)
            sup = {f"ipof_f{q}": 0.0 for q in range(6)}
            sup.update(ipof_f2=face, ipof_f4=face, ipof_f0=1.0, ipof_f1=0.7 if j == 1 else 1.0)
            shapes[i, j, 0] = Shape(id=f"c{i}{j}", type=t, grid=(i, j, 0), support=sup,
                                    geometry=box_of((X[i], Y[j], 0), (X[i + 1], Y[j + 1], 2.8)),
                                    attributes={"thin_axis": thin})
            types[i, j, 0] = t
    step = 0.03
    u, v = np.meshgrid(np.arange(9.51, 13.9, step), np.arange(0.1, 6.9, step), indexing="ij")
    uv = np.column_stack([u.ravel(), v.ravel()])
    if not ceiling_over_it:  # over the wall line only what the noise pushed 4 cm past its faces
        uv = uv[(uv[:, 1] < 1.94) | (uv[:, 1] > 2.06)]
    params = ManhattanParams(max_wall_thickness=0.5, shape_buffer=0.05, spacing=step, noise=0.02, bin_size=0.02)
    doorway_tops(shapes, types, uv, X, Y, params, step, 2 * 0.02)
    assert types[1, 1, 0] == expect and shapes[1, 1, 0].type == expect
    assert types[2, 1, 0] == E and types[0, 1, 0] == W  # the rest of the line as it was


@pytest.mark.parametrize("closet_floor, expect", [(0.0, ShapeType.INTERIOR), (0.5, ShapeType.EXTERIOR)])
def test_a_pocket_beside_an_unseen_closet_is_closed_by_the_wall_between(closet_floor, expect):
    """The Duplex, TLS, seed 3, level 2: the hallway's end by the stair (a 0.54 m strip, its
    ceiling between a far scan's lines) is closed on one side by a wall whose 13 cm stretch
    there no scan saw (both faces unseen), with a closet no scanner entered behind it; the
    stretch counted as a gap leading outside, the strip stayed exterior and the bedroom's door
    into the hallway led outside. A gap between two wall parts toward a cuboid whose floor was
    never seen closes the pocket; toward one whose floor was seen (looked into) it does not."""
    from engine.grammar.geometry import box_of
    from engine.grammar.passages import enclosed_pockets
    from engine.model import Shape

    X, Y = np.array([0.0, 1.52, 1.65, 3.61]), np.array([0.0, 0.11, 0.65, 4.65])
    I, E, W = ShapeType.INTERIOR, ShapeType.EXTERIOR, ShapeType.WALL
    kinds = {(0, 0): W, (1, 0): W, (2, 0): W, (0, 1): E, (1, 1): E, (2, 1): E, (0, 2): I, (1, 2): W, (2, 2): I}
    faces = {(2, 1): dict(ipof_f2=0.56, ipof_f3=0.30, ipof_f4=0.0, ipof_f5=0.01, ipof_bottom=0.22, ipof_top=0.09),
             (1, 1): dict(ipof_bottom=0.0, ipof_top=0.0),
             (0, 1): dict(ipof_bottom=closet_floor, ipof_top=0.1, ipof_f2=0.5, ipof_f4=0.9, ipof_f5=0.0)}
    shapes, types = {}, np.empty((3, 3, 1), dtype=object)
    for (i, j), t in kinds.items():
        sup = {f"ipof_f{q}": 0.0 for q in range(2, 6)}
        sup.update(faces.get((i, j), {"ipof_bottom": 0.9, "ipof_top": 0.9}))
        thin = 0 if i == 1 else (1 if j == 0 else None)
        shapes[i, j, 0] = Shape(id=f"c{i}{j}", type=t, grid=(i, j, 0), support=sup,
                                geometry=box_of((X[i], Y[j], 0), (X[i + 1], Y[j + 1], 2.6)),
                                attributes={"thin_axis": thin})
        types[i, j, 0] = t
    enclosed_pockets(shapes, types, ManhattanParams(max_wall_thickness=0.3, shape_buffer=0.05))
    assert types[2, 1, 0] == expect and shapes[2, 1, 0].type == expect


@pytest.mark.parametrize("beyond, beside, expect", [
    (None, 0.5, ShapeType.INTERIOR),   # the outer wall seen beside the pocket runs on past it
    (None, 0.0, ShapeType.EXTERIOR),   # unseen beside it too: the edge may be where the scan stopped
    (ShapeType.EXTERIOR, 0.5, ShapeType.EXTERIOR)])  # the grid reaches on: outside beyond
def test_a_pocket_at_the_grids_edge_is_closed_by_the_outer_wall(beyond, beside, expect):
    """The Duplex, TLS, seed 3, level 2: the east hallway's end (a 0.54 m strip, its ceiling
    between a far scan's lines) runs to the outer wall, which the stair hides there (0.04 of
    it seen, 0.45-0.50 beside it): the grid's edge counted as open to the outside, the strip
    stayed exterior and the hallway ended 0.6 m short of the bedroom's wall, a "wall" with a
    1.95 m "door" in it. Past the grid's edge lies the outermost wall plane: seen beside the
    pocket along the edge, it closes it."""
    from engine.grammar.geometry import box_of
    from engine.grammar.passages import enclosed_pockets
    from engine.model import Shape

    X = np.array([0.0, 1.96] + ([] if beyond is None else [3.0]))
    Y = np.array([0.0, 0.11, 0.65, 4.65])
    I, E, W = ShapeType.INTERIOR, ShapeType.EXTERIOR, ShapeType.WALL
    nx = len(X) - 1
    shapes, types = {}, np.empty((nx, 3, 1), dtype=object)
    for i in range(nx):
        for j in range(3):
            t = (W, E, I)[j] if i == 0 else beyond
            sup = {f"ipof_f{q}": 0.0 for q in range(2, 6)}
            sup.update(ipof_bottom=0.9, ipof_top=0.9)
            if (i, j) == (0, 1):  # the pocket: the wall behind it seen, the outer wall barely
                sup.update(ipof_f2=0.56, ipof_f3=0.04, ipof_f5=0.5, ipof_bottom=0.21, ipof_top=0.07)
            elif (i, j) == (0, 2):  # the room beyond the pocket, along the grid's edge
                sup.update(ipof_f3=beside)
            elif i == 1:
                sup.update(ipof_bottom=0.0, ipof_top=0.0)
            shapes[i, j, 0] = Shape(id=f"c{i}{j}", type=t, grid=(i, j, 0), support=sup,
                                    geometry=box_of((X[i], Y[j], 0), (X[i + 1], Y[j + 1], 2.6)),
                                    attributes={"thin_axis": 1 if j == 0 else None})
            types[i, j, 0] = t
    enclosed_pockets(shapes, types, ManhattanParams(max_wall_thickness=0.5, shape_buffer=0.125))
    assert types[0, 1, 0] == expect and shapes[0, 1, 0].type == expect


def _strip_scene(kinds, widths, ceiling_share, seed=0):
    """Cuboids along y — ``kinds`` of ``widths`` metres, 4 m long in x — with ceiling points
    of the lowest level: 30 per m² over the room (the first kind), ``ceiling_share`` of that
    over the others (σ 2 cm spill across their edges)."""
    from engine.grammar.geometry import box_of
    from engine.model import Shape

    rng = np.random.default_rng(seed)
    ys = np.cumsum([0.0] + list(widths))
    shapes, types, uv = {}, np.empty((1, len(kinds), 1), dtype=object), []
    for j, t in enumerate(kinds):
        sup = {"ipof_bottom": 0.9 if j == 0 else 0.05, "ipof_top": 0.9 if j == 0 else 0.1,
               **{f"ipof_f{q}": (0.1 if j < len(kinds) - 1 else 0.5) for q in (2, 3, 4, 5)}}
        shapes[(0, j, 0)] = Shape(id=f"c{j}", type=t, geometry=box_of((0, ys[j], 0), (4.0, ys[j + 1], 2.8)),
                                  grid=(0, j, 0), support=sup, attributes={"thin_axis": None if j == 0 else 1})
        types[0, j, 0] = t
        dens = 30.0 * (1.0 if j == 0 else (0.0 if t == ShapeType.WALL else ceiling_share))
        n = rng.poisson(dens * 4.0 * widths[j])
        uv.append(np.column_stack([rng.uniform(0, 4.0, n), rng.uniform(ys[j], ys[j + 1], n) + rng.normal(0, 0.02, n)]))
    return shapes, types, np.vstack(uv), np.array([0.0, 4.0]), ys


@pytest.mark.parametrize("case, expect", [
    ("cabinet", True),       # room | 0.08 | 0.12 | 0.3 m strips | wall: the ceiling over them seen
    ("thin room part", True),  # the 0.3 m strip by the wall a room of its own (its ceiling index)
    ("wall body", False),    # no ceiling point over the strips: a wall's body
    ("sparse", False),       # the ceiling seen at a fifth of the room's density: not enough
    ("too wide", False),     # the strips 1.2 m across: wider than a pocket
    ("room beyond", False),  # a room, not a wall, at the run's end: a gap between two rooms
    ("doorway band", False),  # from a thin interior part of a wall line (a doorway), not a room
])
def test_a_strip_behind_furniture_between_a_room_and_a_wall_is_the_rooms(case, expect):
    """A tall cabinet against a wall cuts the room at its front: the thin cuboids between it
    and the wall had a low ceiling index on a sparse scan and came out exterior (two_storey_
    office mobile: the room ended at the cabinet, a 0.7 m "wall" with a false door beside it).
    Their ceiling, seen at the room's density beside them, makes them the room's."""
    from engine.grammar.passages import furniture_strips

    I, E, W = ShapeType.INTERIOR, ShapeType.EXTERIOR, ShapeType.WALL
    widths = [4.0, 0.08, 0.12, 0.3, 0.2]
    kinds = [I, E, E, E, W]
    share = {"cabinet": 0.8, "wall body": 0.0, "sparse": 0.2}.get(case, 0.8)
    if case == "too wide":
        widths = [4.0, 0.4, 0.4, 0.4, 0.2]
    if case == "room beyond":
        kinds = [I, E, E, E, I]
    if case == "doorway band":
        widths = [0.2, 0.08, 0.12, 0.3, 0.2]
    if case == "thin room part":
        kinds = [I, E, E, I, W]
    shapes, types, uv, X, Y = _strip_scene(kinds, widths, share)
    furniture_strips(shapes, types, uv, X, Y, ManhattanParams(), 0.04)
    got = [types[0, j, 0] for j in (1, 2, 3)]
    assert got == ([I] * 3 if expect else kinds[1:4]), got
    if expect:  # their faces across the run are furniture: one space with the room
        assert [shapes[(0, j, 0)].attributes["joined_faces"] for j in (1, 2, 3)] == [(2, 4), (2, 4), (2,)]
        assert "behind furniture" in shapes[(0, 3, 0)].log[-1]


def test_a_ceilings_far_scan_lines_are_followed_until_a_jump():
    """Beyond a ceiling's seen extent its points are followed while the steps between them
    grow gradually (scan lines part with range: 0.23 m then 0.56 m on office_mw seen from one
    position); a jump of more than three times the largest step before it (and more than a
    wall's thickness) leaves the ceiling — the top of a site wall 10 m beyond the eaves."""
    from engine.grammar.extent import scan_lines as _scan_lines

    lines = np.r_[np.linspace(0.0, 0.05, 20), np.linspace(0.23, 0.27, 20), np.linspace(0.79, 0.89, 20)]
    assert _scan_lines(lines, 0.5) == pytest.approx(0.89)
    assert _scan_lines(np.r_[lines, 10.8, 10.9], 0.5) == pytest.approx(0.89)
    assert _scan_lines(np.array([10.8, 10.85]), 0.5) == 0.0  # nothing near the edge
    assert _scan_lines(np.array([0.1, 0.2, 0.3]), 0.5) == pytest.approx(0.3)
    assert _scan_lines(np.array([]), 0.5) == 0.0


@pytest.mark.parametrize("spacing, reaches", [(0.16, True), (0.03, False)])
def test_a_walls_top_reaches_a_ceiling_seen_as_far_as_its_normals_are_spoiled(spacing, reaches):
    """A wall's top (points 5-15 cm under the ceiling along 2 m) counts only under a seen
    ceiling. Next to the wall the ceiling's normals are spoiled over their neighbourhood
    (2.5 σ), so its seen cells begin that far out: 60 cm here, beyond the one 25 cm cell
    around the wall's that counted before. At σ = 16 cm (a sparse scan: two_storey_office at
    100k points without positions lost a partition so) that is the ceiling over the wall; on
    a dense scan (σ 3 cm) a ceiling seen only from 60 cm away is not."""
    from engine.grammar.extent import cell_lookup as _cell_lookup
    from engine.grammar.manhattan import _reaches_ceiling
    from engine.grammar.place import StoreyFrame

    rng = np.random.default_rng(0)
    top = np.c_[rng.normal(0.0, 0.005, 200), rng.uniform(0.0, 2.0, 200), rng.uniform(2.35, 2.45, 200)]
    ceiling = np.c_[rng.uniform(0.6, 3.0, 800), rng.uniform(0.0, 2.0, 800), np.full(800, 2.5)]
    params = ManhattanParams(noise=0.0, bin_size=0.05, shape_buffer=0.05)
    cells = [_cell_lookup(ceiling[:, :2], params.level_cell)]
    frame = StoreyFrame(0.0, (2.5,))
    assert _reaches_ceiling(top, 0, 0.0, frame, params, spacing, None)  # at the ceiling's height
    assert _reaches_ceiling(top, 0, 0.0, frame, params, spacing, cells) == reaches


def test_a_surface_reaches_the_ceiling_by_its_own_points_not_a_neighbouring_wall_s():
    """A cabinet's front 8 cm before the plane of a partition elsewhere along the line (the
    partition's top seen along 4 m, the cabinet 2.2 m high): within 1.5 bins of the cabinet's
    plane lie the partition's top points, and the cabinet "reached the ceiling"
    (two_storey_office mobile at 100k points, seed 11: a cut through the corridor split it in
    two rooms). The partition's points count for the partition's peak only, half-way
    between the two at most."""
    from engine.grammar.manhattan import _reaches_ceiling
    from engine.grammar.place import StoreyFrame

    rng = np.random.default_rng(0)
    wall = np.c_[rng.normal(5.1, 0.015, 400), rng.uniform(2.0, 6.0, 400), rng.uniform(2.6, 2.75, 400)]
    cabinet = np.c_[rng.normal(5.02, 0.015, 300), rng.uniform(-3.0, -1.0, 300), rng.uniform(0.2, 2.2, 300)]
    pts = np.vstack([wall, cabinet])
    pts = pts[np.argsort(pts[:, 0])]
    params = ManhattanParams(noise=0.015, bin_size=0.05, shape_buffer=0.05)
    frame = StoreyFrame(0.0, (2.8,))
    for pos, reaches in ((5.1, True), (5.02, False)):
        mid = (5.1 + 5.02) / 2
        between = (mid, np.inf) if pos == 5.1 else (-np.inf, mid)
        assert _reaches_ceiling(pts, 0, pos, frame, params, 0.05, None, pts[:, 0], between) == reaches
    assert _reaches_ceiling(pts, 0, 5.02, frame, params, 0.05, None, pts[:, 0])  # the slab alone


def test_a_second_face_is_a_wall_when_the_face_it_pairs_with_reaches_the_ceiling():
    """with_partner: a paired second face too little seen under the ceiling is a wall when
    its partner reaches the ceiling and no other second face of that partner stands nearer
    it (a cabinet against the wall's far side has its front further off)."""
    from engine.grammar.place import with_partner

    up = {4.6: True, 4.39: False, 9.6: False, 9.4: False}
    assert with_partner(4.39, {4.39: 4.6}, up)
    assert not with_partner(4.6, {4.39: 4.6}, up)  # not a second face
    assert not with_partner(9.4, {9.4: 9.6}, up)  # its partner is no wall either
    # the true face at 4.39 and a cabinet's front at 4.1 behind the same partner
    both = {4.39: 4.6, 4.1: 4.6}
    assert with_partner(4.39, both, up) and not with_partner(4.1, both, up)
    # second faces of the same partner on its two sides do not shadow each other
    assert with_partner(4.8, {4.39: 4.6, 4.8: 4.6}, up) and with_partner(4.39, {4.39: 4.6, 4.8: 4.6}, up)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [10, 13])
def test_a_partition_s_far_face_seen_obliquely_keeps_its_rooms_apart(seed):
    """two_storey_office mobile at 100k points (50k a floor), layouts no rule was developed
    on: the far face of a ground-floor partition was paired with its near face but had too
    few points under the ceiling, so it made no cut and its two rooms merged (13 rooms of 14).
    14 of 14 since a second face is a wall when its partner reaches the ceiling."""
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct

    sc = preset("two_storey_office", seed=seed, noise="mobile", target_points=100_000)
    model = reconstruct(sc.cloud, "auto", rng=seed)
    r = room_scores(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    assert r["true"] == r["model"] == r["matched"] == 14, r
    assert r["mean_iou"] >= 0.95, r  # 0.984 on both (0.94 before)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [13, 15])
def test_a_room_reaches_its_wall_behind_furniture_on_another_wall_s_plane(seed):
    """two_storey_office TLS at 100k points, held-out seeds 13 and 15: the partitions north
    and south of the corridor are staggered by 0.5 m, so the south one's plane crosses the
    north room 0.5 m before its own wall, where furniture stands against that wall. The
    furniture's front lies on that plane and covers its face, so the strip between the plane
    and the wall was not taken for a strip behind furniture (its face toward the room had to
    be unseen), and the room ended 0.5 m short. The strip's own ceiling, seen at the room's
    density, now decides alone: every room IoU >= 0.97 (0.94 and 0.90 before)."""
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct

    sc = preset("two_storey_office", seed=seed, noise="tls", target_points=100_000)
    model = reconstruct(sc.cloud, "auto", rng=seed)
    r = room_scores(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    assert r["true"] == r["model"] == r["matched"] == 14, r
    ious = [v for st in r["per_storey"] for v in st["ious"]]
    assert min(ious) >= 0.97, ious


@pytest.mark.slow
def test_a_cabinet_before_a_partition_s_plane_makes_no_cut():
    """two_storey_office mobile at 100k points, seed 11 (a layout no rule was developed on):
    a cabinet 7 cm before the plane of a partition reached the ceiling by the partition's
    points and cut the corridor in two (15 rooms for 14). 14 of 14 since a surface reaches
    the ceiling by its own points."""
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct

    sc = preset("two_storey_office", seed=11, noise="mobile", target_points=100_000)
    model = reconstruct(sc.cloud, "auto", rng=11)
    r = room_scores(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    assert r["true"] == r["model"] == r["matched"] == 14, r


def test_ceiling_points_by_their_level_but_not_a_wall_s_top():
    """A ceiling at 2.6 m seen as scan lines 0.4 m apart, most of its points with a tilted
    normal (a sparse scan: a neighbourhood holds one line), and a wall at x = 0 reaching it.
    On the level, the ceiling's points count whatever their normal (``ceiling_by_level``);
    the wall's top does not (its wall stands under it); with the switch off only the points
    with a vertical normal do."""
    from dataclasses import replace as dreplace

    from engine.grammar.levels import ceiling_mask
    from engine.grammar.params import ManhattanParams
    from engine.grammar.place import StoreyFrame

    rng = np.random.default_rng(4)
    xs = np.arange(0.3, 5.0, 0.05)
    ceiling = np.array([(x, y, 2.6 + rng.normal(0, 0.01)) for y in np.arange(0.2, 4.0, 0.4) for x in xs])
    wall = np.c_[rng.normal(0.0, 0.01, 3000), rng.uniform(0, 4, 3000), rng.uniform(0, 2.62, 3000)]
    p = np.vstack([ceiling, wall])
    hor = np.zeros(len(p), bool)
    hor[:len(ceiling):4] = True  # a quarter of the ceiling's normals vertical, the others tilted
    frame = StoreyFrame(floor=0.0, ceilings=(2.6,))
    params = ManhattanParams(shape_buffer=0.05)
    m = ceiling_mask(p, hor, 2.6, frame, params)
    assert m[:len(ceiling)].all()
    top = np.flatnonzero(np.abs(wall[:, 2] - 2.6) <= params.shape_buffer) + len(ceiling)
    assert len(top) > 20 and not m[top].any()  # the wall's top
    off = ceiling_mask(p, hor, 2.6, frame, dreplace(params, ceiling_by_level=False))
    assert off[:len(ceiling)].sum() == hor[:len(ceiling)].sum()


@pytest.mark.slow
@pytest.mark.parametrize("scene, noise, seed, positions", [("three_storey_house", "mobile", 16, True),
                                                            ("three_storey_house", "mobile", 13, True),
                                                            ("two_storey_office", "tls", 4, False)])
def test_a_room_s_far_part_seen_in_sparse_scan_lines_is_the_room_s(scene, noise, seed, positions):
    """Mobile scans at 100k points over three storeys (33k a floor): the walk enters a long
    room at one end only, and its far part's ceiling is seen in scan lines far apart; most of
    their points get a tilted normal (38 of 136 vertical in three_storey_house seed 16), so the
    part's top index was 0.07 and the room ended at another wall's plane, 2.9 m short, with its
    outer wall and two windows missed (held-out seeds 16 and 13: exterior-wall share 0.94,
    room IoU 0.955 and 0.958). The ceiling's points now count by their height
    (``ceiling_by_level``): IoU 0.999. Thin strips between a room and its wall that the
    classification then makes rooms of join the room as those behind furniture did: without
    that, two_storey_office TLS without positions, seed 4, had a false door and a room 0.5 m
    short once its strips' ceiling counted by height."""
    from engine.evaluation import evaluate_elements
    from engine.evaluation.rooms import scanned_spaces
    from engine.reconstruct import reconstruct

    sc = preset(scene, seed=seed, noise=noise, target_points=100_000)
    cloud = sc.cloud if positions else sc.cloud.with_(scanner_positions=None, scan_index=None)
    model = reconstruct(cloud, "auto", rng=seed)
    e = evaluate_elements(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    s = e["spaces"]
    assert s["model_rooms"] == s["truth"] == s["matched"], s
    assert s["mean_iou"] >= 0.99, s
    assert e["exterior"]["external_share"] >= 0.98, e["exterior"]
    assert e["doors"]["precision"] == 1.0, e["doors"]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [14, 17])
def test_a_partition_seen_in_sparse_scan_lines_keeps_its_rooms_apart(seed):
    """two_storey_office mobile at 100k points (50k a floor), held-out seeds 14 and 17: a
    partition's one seen face, between two rooms, is scan lines far apart, and most of its
    points get a tilted normal; counted by their normal alone its face read IPoF 0.29 < τ, so
    the two rooms were one space (13 rooms of 14, mean IoU over the truth's rooms 0.89 and
    0.88). A wall face's
    index now counts the points along no axis too (``faces_by_position``): 14 of 14, the
    graph right."""
    from engine.evaluation import evaluate_elements
    from engine.evaluation.rooms import scanned_spaces
    from engine.reconstruct import reconstruct

    sc = preset("two_storey_office", seed=seed, noise="mobile", target_points=100_000)
    model = reconstruct(sc.cloud, "auto", rng=seed)
    e = evaluate_elements(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    s = e["spaces"]
    assert s["model_rooms"] == s["truth"] == s["matched"] == 14, s
    assert s["mean_iou"] >= 0.97, s  # 0.981 and 0.991
    assert e["connectivity"]["equal"], e["connectivity"]


@pytest.mark.slow
def test_a_cabinet_s_tilted_edges_make_no_wall_of_the_strip_behind_it():
    """office_mw mobile at 300k points, seed 3: a cabinet 0.4 m deep against a partition. The
    tilted normals of its edges lean every way; counted for the faces of the strip behind it,
    they lifted its sides' index over τ and the strip became a wall, the room 0.4 m short
    (IoU 0.90). Only tilted points leaning along the face's axis count (``faces_by_position``):
    every room IoU >= 0.98."""
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct

    sc = preset("office_mw", seed=3, noise="mobile", target_points=300_000)
    model = reconstruct(sc.cloud, "auto", rng=3)
    r = room_scores(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
    assert r["true"] == r["model"] == r["matched"], r
    ious = [v for st in r["per_storey"] for v in st["ious"]]
    assert min(ious) >= 0.98, ious
