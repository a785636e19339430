"""Building elements of whole reconstructions scored against the truth (issue targets):
doors and windows by centre within 0.3 m, widths within 10 cm, exterior walls all round, a
floor and a ceiling/roof slab per storey, one space per room, walls within 1.5 × the true runs,
the door graph equal to the truth's. Scenes and seeds not used while tuning the detectors."""
import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.validate
import numpy as np
import pytest

from engine.evaluation.elements import evaluate_elements
from engine.ifc import write_ifc
from engine.model import ShapeType
from engine.reconstruct import reconstruct
from engine.synthetic import preset

CASES = [("office_mw", "tls", 3), ("two_storey_office", "tls", 4), ("syn_house", "tls", 3),
         ("house_multi_height", "mobile", 4), ("syn_house", "mobile", 3), ("three_storey_house", "tls", 3)]


@pytest.fixture(scope="module")
def results():
    return {}


def _run(results, name, noise, seed, points=300_000):
    """A preset or an IFC-built scene (fzk_haus, duplex) scanned, reconstructed and scored."""
    key = (name, noise, seed, points)
    if key not in results:
        if name in ("fzk_haus", "duplex"):
            from engine.synthetic.ifcscene import ifc_scene

            sc = ifc_scene(name, seed=seed, noise=noise, target_points=points)
        else:
            sc = preset(name, seed=seed, noise=noise, target_points=points)
        m = reconstruct(sc.cloud, "auto", rng=0)
        results[key] = (sc, m, evaluate_elements(m, sc.truth))
    return results[key]


@pytest.mark.slow
@pytest.mark.parametrize("name, noise, seed", CASES)
def test_elements_meet_the_targets(results, name, noise, seed):
    sc, m, r = _run(results, name, noise, seed)
    for kind, least in (("doors", 0.95), ("windows", 0.9)):
        d = r[kind]
        assert d["true"] > 0
        assert d["precision"] >= least and d["recall"] >= least, (kind, d)
        assert d["width_error_max"] <= 0.10, (kind, d)
    assert r["exterior"]["external_share"] >= 0.99  # every exterior boundary has an exterior wall
    s = r["slabs"]
    assert s["floor_found"] == s["ceiling_found"] == s["storeys"] == len(sc.truth.storeys)
    assert r["spaces"]["model"] == r["spaces"]["truth"] == r["spaces"]["matched"]
    assert r["walls"]["model"] <= 1.5 * r["walls"]["truth_runs"]
    assert r["connectivity"]["equal"], r["connectivity"]


@pytest.mark.slow
def test_the_ifc_of_a_reconstruction_is_a_building_model(results, tmp_path):
    sc, m, _ = _run(results, "office_mw", "tls", 3)
    path = str(tmp_path / "office.ifc")
    write_ifc(m, path)
    f = ifcopenshell.open(path)
    assert len(f.by_type("IfcSpace")) == len(sc.truth.spaces)  # one per room
    assert len(f.by_type("IfcDoor")) == len(m.doors) and len(f.by_type("IfcWindow")) == len(m.windows)
    assert len(f.by_type("IfcExternalSpatialElement")) == len(m.storeys)
    assert len(f.by_type("IfcVirtualElement")) == 0  # walls everywhere between the rooms
    ext = [w for w in f.by_type("IfcWall")
           if ifcopenshell.util.element.get_psets(w).get("Pset_WallCommon", {}).get("IsExternal")]
    assert len(ext) == sum(bool(w.attributes["external"]) for w in m.walls) > 0
    for e in f.by_type("IfcDoor") + f.by_type("IfcWindow"):  # filling an opening in its wall
        op = e.FillsVoids[0].RelatingOpeningElement
        assert op.VoidsElements[0].RelatingBuildingElement.is_a("IfcWall")
    assert f.by_type("IfcRelConnectsPathElements")
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(f, logger, express_rules=True)
    assert [s for s in logger.statements if s.get("level") == "error"] == []


# ----------------------------------------------------------------------------- IFC-built scenes
@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_fzk_haus_has_no_false_door_and_its_walls(results, noise):
    """Measured on seed 3: doors P 1.00 / R 1.00 (R 0.80 before the flush-leaf rule, while the
    simulator kept the front door's leaf, 1.2 cm behind the inner face; the door is open in
    the scans now, as the truth has it), windows F1 1.00 (TLS and mobile; mobile was 0.90 while a
    gap component joining two windows and a door kept only the door), 13 walls for 13 true
    runs. Before the open-plan rule the passage under the beam was a 3.6 m 'door'. Margin:
    one window of eleven (F1 0.95)."""
    sc, m, r = _run(results, "fzk_haus", noise, 3)
    assert r["doors"]["precision"] >= 0.95 and r["doors"]["recall"] >= 0.95, r["doors"]
    assert r["windows"]["f1"] >= 0.95, r["windows"]
    assert r["walls"]["truth_runs"] / 1.5 <= r["walls"]["model"] <= 1.5 * r["walls"]["truth_runs"], r["walls"]


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_duplex_party_wall_is_one_wall_without_openings(results, noise):
    """Measured on seed 3: doors P 1.00 / R 1.00 (TLS), 1.00 / 0.93 (mobile: 0.86 while the
    front door, half shadowed by a partition but seen through and with its jamb and head,
    was taken for an occlusion); before the thick walls 0.43 / 0.71 and 0.69 / 0.79, with
    4-5 m 'openings' along the party wall into the other flat; before the egress rule (level
    2's 750 x 2200 mm windows were doors) 0.76 / 0.93 (TLS). Margin: one door of 14. The party
    wall between the flats is an interior wall (both sides rooms) and holds no opening."""
    sc, m, r = _run(results, "duplex", noise, 3)
    assert r["doors"]["precision"] >= 13 / 14 - 1e-9 and r["doors"]["recall"] >= 12 / 14 - 1e-9, r["doors"]
    if noise == "tls":
        # windows, seed 3: 23 of 24 found, one false (0.96 / 0.96; a 0.59 m pane in a level-2
        # partition); 22 of 24 before the two roof windows were found as holes in the roof
        # (test_duplex_roof_windows_are_holes_in_its_roof), 15 of 24 before the stacked panes
        # were kept apart (their transoms measured by both), low panes (sill 8 cm, sill seen in
        # a few columns) taken for windows and exterior sides known by name. Margin: two
        # windows.
        assert r["windows"]["recall"] >= 19 / 24 and r["windows"]["precision"] >= 0.9, r["windows"]
    from engine.evaluation.elements import _in_truth_frame, _plan

    from shapely.geometry import Point

    mt = _in_truth_frame(m, sc.truth)
    # the party wall of level 2 (level 1's party walls are stair and closet walls)
    party = [w for w in sc.truth.walls if "Party" in (w.name or "") and _plan(w, sc.truth).area > 5.0]
    assert len(party) == 1
    core, (z0, z1) = _plan(party[0], sc.truth).buffer(-0.1), party[0].bounds[:, 2]
    for o in mt.doors + mt.windows:
        c = o.centroid
        assert not (z0 < c[2] < z1 and core.contains(Point(c[0], c[1]))), (o.id, o.attributes.get("kind"), c)
    from shapely.ops import unary_union

    on = [w for w in mt.walls if z0 < w.centroid[2] < z1 and _plan(w, mt).intersection(core).area > 0]

    def share(walls):
        return unary_union([_plan(w, mt) for w in walls]).intersection(core).area / core.area

    # modelled along its length as interior walls (seed 3: 0.92 TLS, the stair core breaks
    # it; 1.00 mobile, where a 0.9 m exterior stub at the stair core overlaps it: 0.05)
    assert share([w for w in on if not w.attributes["external"]]) >= 0.8
    assert share([w for w in on if w.attributes["external"]]) <= 0.15


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_duplex_roof_windows_are_holes_in_its_roof(results, noise, tmp_path):
    """The upper flat's two skylights stand in its flat roof: from the rooms under them, holes
    1.03 m x 1.08 m through the ceiling with their reveals and frame above (none found before:
    no detector looked up). Seed 3: each found within 0.1 m of its centre (measured 2 cm),
    its width within 10 cm of the truth's 1.17 m (the frame's outer size on the roof; the hole
    measures 1.08-1.10 m), no other roof window; in the IFC an IfcWindow SKYLIGHT filling an
    opening that voids the IfcSlab ROOF over it, and the file validates."""
    sc, m, r = _run(results, "duplex", noise, 3)
    from engine.evaluation.elements import _in_truth_frame

    mt = _in_truth_frame(m, sc.truth)
    found = [w for w in mt.windows if w.attributes.get("skylight")]
    true = [w for w in sc.truth.windows if w.centroid[2] > 6.2]
    assert len(true) == 2 and len(found) == 2, [w.centroid.round(2).tolist() for w in found]
    for t in true:
        d = [float(np.linalg.norm(f.centroid - t.centroid)) for f in found]
        f = found[int(np.argmin(d))]
        assert min(d) <= 0.1 and abs(f.attributes["width"] - t.attributes["width"]) <= 0.1, (min(d), f.attributes)
        assert m[f.parent].type == ShapeType.SLAB and m[f.parent].attributes["kind"] == "roof"
    if noise == "tls":
        path = str(tmp_path / "duplex.ifc")
        write_ifc(m, path)
        f = ifcopenshell.open(path)
        sky = [w for w in f.by_type("IfcWindow") if w.PredefinedType == "SKYLIGHT"]
        assert len(sky) == 2
        for w in sky:
            host = w.FillsVoids[0].RelatingOpeningElement.VoidsElements[0].RelatingBuildingElement
            assert host.is_a("IfcSlab") and host.PredefinedType == "ROOF"
        logger = ifcopenshell.validate.json_logger()
        ifcopenshell.validate.validate(f, logger, express_rules=True)
        assert [s for s in logger.statements if s.get("level") == "error"] == []


@pytest.mark.slow
def test_three_storeys_in_one_scan_are_three_storeys(results):
    """three_storey_house (storeys 2.7, 2.6 and 2.4 m high over 0.3 m slabs, a different layout
    on each), seed 3: three storeys at the true floor heights (within 5 cm; measured within
    1 cm), every room on its storey, a floor and a ceiling slab per storey (the targets
    above check the counts)."""
    sc, m, r = _run(results, "three_storey_house", "tls", 3)
    from engine.evaluation.elements import _in_truth_frame, _storey_of, _truth_storey

    mt = _in_truth_frame(m, sc.truth)
    assert [round(s.floor_z, 1) for s in sc.truth.storeys] == [0.0, 3.0, 5.9]
    assert len(mt.storeys) == 3
    for s, t in zip(mt.storeys, sc.truth.storeys):
        assert abs(s.floor_z - t.floor_z) <= 0.05 and abs(s.ceiling_z - t.ceiling_z) <= 0.05, (s, t)
    rooms = {m_id: t_id for m_id, t_id in r["spaces"]["pairs"]}
    assert len(rooms) == len(sc.truth.spaces) == 10
    for m_id, t_id in rooms.items():
        assert _storey_of(mt[m_id], sc.truth) == _truth_storey(sc.truth[t_id], sc.truth)
    assert [p["floor"] and p["ceiling"] for p in r["slabs"]["per_storey"]] == [True] * 3


@pytest.mark.slow
def test_a_partition_seen_little_from_one_side_keeps_its_wall_and_door(results):
    """three_storey_house mobile, seed 5: the top storey's landing/study partition (16 cm, a
    door in it) is seen over 0.85 m² from the study (furniture in front of it), under the
    1.5 m² a wall surface needs, and the rooms met at its landing face: no wall, no door, the
    door graph one edge short. Its second face, behind the first and seen from the other
    side, makes the cut now: the wall, its door and the graph are there."""
    sc, m, r = _run(results, "three_storey_house", "mobile", 5)
    assert r["doors"]["true"] == r["doors"]["matched"] == r["doors"]["found"] == 9, r["doors"]
    assert r["connectivity"]["equal"], r["connectivity"]
    assert r["walls"]["model"] == r["walls"]["truth_runs"] == 19
    from engine.evaluation.elements import _in_truth_frame

    mt = _in_truth_frame(m, sc.truth)
    # the true partition: y 3.92-4.08 m, x 0.08-2.92 m, on the top storey (floor 5.9 m)
    walls = [w for w in mt.walls if w.bounds[0, 2] > 5.0 and w.bounds[0, 0] < 1.0 and w.bounds[1, 0] > 2.0
             and abs(0.5 * (w.bounds[0, 1] + w.bounds[1, 1]) - 4.0) <= 0.1]
    assert len(walls) == 1, [w.bounds.round(2).tolist() for w in walls]
    thickness = walls[0].bounds[1, 1] - walls[0].bounds[0, 1]
    assert abs(thickness - 0.16) <= 0.05, thickness  # measured 0.15


@pytest.mark.slow
def test_a_cabinet_against_a_partition_leaves_the_room_whole_and_no_false_door(results):
    """two_storey_office mobile, seed 4: a 2 m cabinet 0.4 m deep stands against the 0.2 m
    partition between two ground-floor rooms (x 9.9-10.1 m). Its front was the room's end:
    the cuboids behind it, each thinner than a wall, had a low ceiling index on the sparse
    ceiling and came out exterior — a 0.7 m "wall" at x 9.4-10.1 with a 2.8 m "door" in it,
    the room 0.5 m short. The ceiling over them is seen at the room's density beside them:
    they are the room's (:func:`engine.grammar.passages.furniture_strips`)."""
    from engine.evaluation.elements import _in_truth_frame

    sc, m, r = _run(results, "two_storey_office", "mobile", 4)
    assert r["doors"]["true"] == r["doors"]["found"] == r["doors"]["matched"] == 13, r["doors"]
    mt = _in_truth_frame(m, sc.truth)
    ground = [w for w in mt.walls if w.bounds[1, 2] < 3.0 and 2.0 < 0.5 * (w.bounds[0, 1] + w.bounds[1, 1]) < 7.0
              and w.bounds[0, 0] < 10.1 and w.bounds[1, 0] > 9.4 and w.bounds[1, 1] - w.bounds[0, 1] > 3.0]
    assert len(ground) == 1, [w.bounds.round(2).tolist() for w in ground]
    lo, hi = ground[0].bounds[:, 0]
    assert abs(lo - 9.9) <= 0.05 and abs(hi - 10.1) <= 0.05, (lo, hi)  # the partition, 0.2 m thick
    assert not [o for o in mt.doors + mt.windows if o.parent == ground[0].id]
    room = next(s for s in mt.spaces if s.bounds[1, 2] < 3.0 and s.bounds[0, 0] > 4.9 and s.bounds[0, 1] > 2.0)
    assert abs(room.bounds[1, 0] - 9.9) <= 0.05, room.bounds.round(2).tolist()  # 9.4 before



@pytest.mark.slow
def test_a_strip_behind_a_shelf_cut_by_another_rooms_partition_stays_its_rooms():
    """two_storey_office TLS, seed 5, 100k points: a shelf and a cabinet (fronts at x 10.02 and
    10.12) stand against the partition at x 9.4-9.6 between two ground-floor rooms; the faces of
    the partition across the corridor (x 9.9, 10.1) cut the grid here too, so the strip 9.6-10.1
    behind the furniture is two parts, its ceiling 0.52 and 0.84 seen, the furniture's front
    on the cut at 10.1 (IPoF 0.35) and the partition on the other side: a 0.5 m "space", made a
    wall (0.7 m thick, with a 4.7 m floor-to-ceiling "opening" in it). The strip's ceiling is
    seen over 0.65 of its area: it joins its room (:func:`engine.grammar.rules._strip_join`)."""
    from engine.evaluation.elements import _in_truth_frame

    sc = preset("two_storey_office", seed=5, noise="tls", target_points=100_000)
    m = reconstruct(sc.cloud, "auto", rng=5)
    r = evaluate_elements(m, sc.truth)
    assert r["doors"]["true"] == r["doors"]["found"] == r["doors"]["matched"] == 13, r["doors"]
    mt = _in_truth_frame(m, sc.truth)
    south = [w for w in mt.walls if w.bounds[1, 2] < 3.0 and w.bounds[1, 1] < 0.0 and w.bounds[0, 1] > -5.0
             and w.bounds[0, 0] < 10.1 and w.bounds[1, 0] > 9.4 and w.bounds[1, 1] - w.bounds[0, 1] > 3.0]
    assert len(south) == 1, [w.bounds.round(2).tolist() for w in south]
    lo, hi = south[0].bounds[:, 0]
    assert abs(lo - 9.4) <= 0.05 and abs(hi - 9.6) <= 0.05, (lo, hi)  # the partition, 0.2 m thick
    assert not south[0].attributes["external"]
    assert not [o for o in mt.doors + mt.windows if o.parent == south[0].id]



@pytest.mark.slow
@pytest.mark.parametrize("seed, positions", [(5, True), (4, False)])
def test_a_sparse_mobile_scans_closed_door_is_a_door_as_wide_as_its_leaf(seed, positions):
    """office_mw mobile, 100k points: the closed door between rooms 1 and 2 (its leaf 4.5 cm
    behind one face, flush with the other within the noise) is a gap on one face with the leaf
    behind it. Seed 5 with positions: a band between the scanner's lines crossing it at its own
    height was read first as a window on both faces (1.1 m wide, confidence 0.40) and kept the
    hole from the door (0.70): door missed, false window. Seed 4 without positions: the stand-in
    scanners' lines passing between the sparse leaf's points read as an open door, which a
    one-face gap cannot be: missed (seeds 3-7, 5 of 5 runs without positions). Its width was
    then the gap's on the sparse face (0.74 m for 0.90): a closed door is as wide as its leaf."""
    sc = preset("office_mw", seed=seed, noise="mobile", target_points=100_000)
    cloud = sc.cloud if positions else sc.cloud.with_(scan_index=None, scanner_positions=None)
    m = reconstruct(cloud, "auto", rng=seed)
    r = evaluate_elements(m, sc.truth)
    closed = [d for d in sc.truth.doors if not d.attributes["open"]]
    assert len(closed) == 1
    pairs = dict((t, f) for f, t in r["doors"]["pairs"])
    assert closed[0].id in pairs, r["doors"]
    found = next(d for d in m.doors if d.id == pairs[closed[0].id])
    assert found.attributes["open"] is False
    assert abs(found.attributes["width"] - closed[0].attributes["width"]) <= 0.10, found.attributes["width"]
    assert r["doors"]["recall"] == 1.0 and r["windows"]["precision"] >= 0.9, (r["doors"], r["windows"])



@pytest.mark.slow
def test_a_strip_behind_a_shelf_whose_first_part_is_a_room_part_joins_its_room(results):
    """two_storey_office mobile, seed 3, 300k points, without scanner positions: upstairs a
    shelf (front at x 9.48) stands against the partition at 9.87-10.1; a wall line of the
    storey cuts the room at x 9.1, so the strip behind the shelf is a thin interior part
    (9.1-9.5, its ceiling 0.43 seen) and an exterior one (9.5-9.87, 0.29): the run across them
    started only at an exterior part, the exterior part stayed outside, and the partition was
    a 0.6 m wall with a 1.3 m "door". A run may start with a thin interior part when it
    holds an exterior one."""
    from engine.evaluation.elements import _in_truth_frame

    sc, _, _ = _run(results, "two_storey_office", "mobile", 3)
    m = reconstruct(sc.cloud.with_(scan_index=None, scanner_positions=None), "auto", rng=3)
    r = evaluate_elements(m, sc.truth)
    assert r["doors"]["true"] == r["doors"]["found"] == r["doors"]["matched"] == 13, r["doors"]
    mt = _in_truth_frame(m, sc.truth)
    upper = [w for w in mt.walls if w.bounds[0, 2] > 2.5 and w.bounds[1, 1] < 0.0 and w.bounds[0, 1] > -5.0
             and w.bounds[0, 0] < 10.1 and w.bounds[1, 0] > 9.4 and w.bounds[1, 1] - w.bounds[0, 1] > 3.0]
    assert len(upper) == 1, [w.bounds.round(2).tolist() for w in upper]
    assert upper[0].bounds[1, 0] - upper[0].bounds[0, 0] <= 0.3, upper[0].bounds.round(2).tolist()


@pytest.mark.slow
def test_half_shadowed_terrace_doors_with_their_reveals_are_found(results):
    """The Duplex, mobile, seed 6: each flat's terrace door (0.81 m, beside a 4.8 m glazed
    wall) is 41-57 % in the shadow of furniture, seen through over 12-17 % and has its jambs
    and head inside the wall's thickness. The shadow cost its whole share of the confidence
    and both doors were dropped (12 of 14 found); it now weighs only as far as the reveals
    leave the hole unconfirmed: 14 of 14, none extra. One terrace door measures 0.94 m (its
    jamb beside the glazing is in the shadow): widths within 15 cm, not the 10 cm target."""
    _all_doors_and_both_terrace_doors(results, 6, 0.15)  # measured 0.13 m


def _all_doors_and_both_terrace_doors(results, seed, width_error):
    """The Duplex, mobile, ``seed``: 14 of 14 doors, none extra, widths within
    ``width_error``, both level-1 terrace doors matched."""
    sc, m, r = _run(results, "duplex", "mobile", seed)
    from engine.evaluation.elements import _openings

    d = r["doors"]
    assert d["true"] == d["found"] == d["matched"] == 14, d
    assert d["width_error_max"] <= width_error, d
    matched = {t for _, t in d["pairs"]}
    terrace = [s.id for s in _openings(sc.truth, False)
               if min(abs(s.scope.center[1] + 0.21), abs(s.scope.center[1] + 17.59)) < 0.05 and s.scope.center[2] < 3]
    assert len(terrace) == 2 and set(terrace) <= matched


@pytest.mark.slow
def test_a_partition_seen_from_the_room_behind_it_casts_no_shadow_on_a_door(results):
    """The Duplex, mobile, seed 7: a terrace door's jamb meets the partition between the
    living room and the foyer. Rays from the foyer's scan positions to that partition's far
    face, carried on to the wall, fell on the door: 41 % of it read as shadowed (over the
    40 % that makes a shadow), though 29 % of it was seen through from the living room, and
    the door was dropped (13 of 14). A scanner behind another wall sees nothing of the face
    there, and such rays no longer shadow a door: 14 of 14, none extra."""
    _all_doors_and_both_terrace_doors(results, 7, 0.10)  # measured 0.01 m


@pytest.mark.slow
def test_a_hallway_strip_between_a_far_scans_lines_is_the_hallways(results):
    """The Duplex, TLS, seed 3: the west hallway's ceiling beside the stair void is seen from
    its far end as lines 0.6 m apart; the 0.6 m strip between the last two (half of it over
    the void) had no ceiling point and was exterior, so the bedroom's door stood in a 0.7 m
    "wall" and led outside (Bedroom 2 - exterior instead of Bedroom 2 - Hallway). The strip,
    closed by walls and open to the hallway, is the hallway's now."""
    sc, m, r = _run(results, "duplex", "tls", 3)
    names = {s.id: s.name + ("W" if s.bounds[0, 0] < 3.0 else "E") for s in sc.truth.spaces}
    c = r["connectivity"]
    edges = [{names.get(a, a), names.get(b, b)} for a, b in c["missing"] + c["extra"]]
    assert {"Bedroom 2W", "HallwayW"} not in edges and {"Bedroom 2W", "exterior_s2"} not in edges, edges
    # the east hallway's end by its stair: closed on its west by a wall stretch no scan saw, with
    # a closet behind it that no scanner entered; it counted as a gap leading outside, and the
    # bedroom's door into the hallway led outside (engine.grammar.passages.enclosed_pockets)
    assert {"Bedroom 2E", "HallwayE"} not in edges and {"Bedroom 2E", "exterior_s2"} not in edges, edges
    assert r["spaces"]["mean_iou"] >= 0.955, r["spaces"]["mean_iou"]  # measured 0.967 (0.950, 0.958 before)


@pytest.mark.slow
def test_a_hallway_cut_by_another_rooms_wall_line_stays_whole(results):
    """The Duplex, TLS, 100k points, seed 4: the lines of two walls elsewhere on level 2 (a
    utility room's and a bathroom's faces, 6 cm apart) cut the west hallway 0.6 m before its
    end. The 6 cm strip between them held the hallway's floor and ceiling points as densely as
    the hallway beside it, but no raster cell of the face index fits in it: it read unseen and
    was outside, so the 0.54 m end beyond it became a wall's inside — a 0.7 m wall with the
    bedroom's door in it (measured 1.25 m for 0.86) and a 1.95 m "door" across the hallway.
    The strip is measured along its centre line now: the hallway reaches its end."""
    from engine.evaluation.elements import _in_truth_frame

    sc, m, r = _run(results, "duplex", "tls", 4, points=100_000)
    mt = _in_truth_frame(m, sc.truth)
    end = np.array([1.4, -11.3, 4.4])  # the hallway's end, level 2
    hall = [s for s in mt.spaces if np.all(s.bounds[0] <= end) and np.all(end <= s.bounds[1])]
    assert len(hall) == 1 and hall[0].bounds[1, 1] > -9.0, [s.bounds.round(2).tolist() for s in hall]
    across = [d for d in mt.doors if abs(d.scope.center[1] + 11.01) < 0.3 and d.scope.center[0] < 3.0]
    assert not across, [d.scope.center.round(2).tolist() for d in across]
    truth = {t.id: t for t in sc.truth.doors}
    door = next(t for t in truth.values() if abs(t.scope.center[0] - 1.85) < 0.05 and abs(t.scope.center[1] + 11.61) < 0.05)
    assert door.id in {t for _, t in r["doors"]["pairs"]}, r["doors"]


@pytest.mark.slow
def test_a_dense_scan_keeps_the_attic_storey(results):
    """FZK-Haus, TLS, 1M points, seed 10: the attic's ridge strip holds 1.5 m² in σ-cells at this
    density (σ 4 cm), under the 2 m² a level needs, and the grammar dropped the storey that the
    preprocessing had found: no Galerie, half the exterior walls, no roof slab (exterior share
    0.50, ceilings 1 of 2, walls 9 of 13). The preprocessing's storey frames it now: the
    figures of 300k points (exterior walls all round, a floor and a roof over both storeys,
    13 wall runs, the Galerie matched)."""
    sc, m, r = _run(results, "fzk_haus", "tls", 10, points=1_000_000)
    assert len(m.storeys) == 2
    assert r["exterior"]["external_share"] >= 0.99
    s = r["slabs"]
    assert s["floor_found"] == s["ceiling_found"] == s["storeys"] == 2
    assert r["walls"]["model"] == r["walls"]["truth_runs"] == 13
    names = {t.id: t.name for t in sc.truth.spaces}
    assert "Galerie" in {names[t] for _, t in r["spaces"]["pairs"]}


@pytest.mark.slow
def test_a_dense_scan_keeps_the_rooms_out_of_the_outer_walls_at_their_windows(results):
    """syn_house, TLS, 1M points, seed 3 (the generic method): a window's glazing gives a plane
    15 cm inside the outer wall, and the strip between it and the wall's inner face, its
    "ceiling" the window's head, joined the room as walled in — through the room's own seen
    wall. The rooms reached 15 cm into two outer walls (mean IoU 0.991) and the walls' faces,
    placed there, showed none of their windows (7 of 9). Now 9 of 9, mean IoU 0.9996."""
    sc, m, r = _run(results, "syn_house", "tls", 3, points=1_000_000)
    d = r["windows"]
    assert d["matched"] == d["true"] == d["found"] == 9, d  # 7 of 9 before
    assert r["spaces"]["mean_iou"] >= 0.995, r["spaces"]  # 0.9996 (0.9912 before)


@pytest.mark.slow
def test_a_doorway_whose_top_only_the_ceilings_noise_covers_is_a_door(results):
    """The Duplex, mobile, 1M points, seed 10: the ceiling's points next to the 12 cm wall
    between a bedroom and its hallway, pushed into the wall's footprint by the range noise,
    covered the doorway's top (IPoF 0.48 from 9 points): the doorway was a room part, the
    bedroom and the hallway one space (IoU 0.64) and the door lost. Measured again with wider
    margins across the wall, its top is unseen: the door (0.86 m, centre x 1.92 m, y -6.19 m)
    is found and the two rooms are two spaces."""
    sc, m, r = _run(results, "duplex", "mobile", 10, points=1_000_000)
    from engine.evaluation.elements import _openings

    door = next(d for d in _openings(sc.truth, False)
                if abs(d.scope.center[0] - 1.92) < 0.05 and abs(d.scope.center[1] + 6.19) < 0.05)
    assert door.id in {t for _, t in r["doors"]["pairs"]}, r["doors"]
    names = {t.id: t.name for t in sc.truth.spaces}
    flat = [names[t] for _, t in r["spaces"]["pairs"] if sc.truth[t].bounds[0, 0] < 3.0 and sc.truth[t].storey == 2]
    assert sorted(flat).count("Hallway") == 1 and sorted(flat).count("Bedroom 2") == 1, flat
    merged = [mm for mm, t in r["spaces"]["pairs"] if names[t] in ("Hallway", "Bedroom 2") and sc.truth[t].bounds[0, 0] < 3.0]
    assert len(set(merged)) == 2, merged


def _without_positions(results, name, noise, seed):
    """The scene of :func:`_run` reconstructed from its points alone (no scanner positions, no
    scan of each point: a merged export), scored."""
    sc, _, _ = _run(results, name, noise, seed)
    key = (name, noise, seed, "no positions")
    if key not in results:
        cloud = sc.cloud.with_(scan_index=None, scanner_positions=None)
        m = reconstruct(cloud, "auto", rng=0)
        results[key] = (sc, m, evaluate_elements(m, sc.truth))
    return results[key]


@pytest.mark.slow
def test_a_scan_without_scanner_positions_finds_its_doors_from_stand_in_scanners(results):
    """The Duplex, TLS, seed 3, without its scanner positions: without rays, furniture in
    front of a gap could only be judged by its perpendicular cover, and no gap was seen
    through: 8 of 14 doors (11 found), 11 of 24 windows (13 found). Stand-in scanners in the
    rooms, with lines of sight through the scan's voxels: 14 of 14 doors (none extra), 21 of
    24 windows (2 extra; the level-2 windows 750 x 2200 are windows, not doors)."""
    sc, m, r = _without_positions(results, "duplex", "tls", 3)
    d, w = r["doors"], r["windows"]
    assert d["matched"] >= 13 and d["found"] <= d["matched"] + 2, d  # measured 14 of 14 found
    assert w["matched"] >= 18 and w["found"] <= w["matched"] + 4, w  # measured 21 of 23 found


@pytest.mark.slow
def test_a_mobile_scanners_band_at_its_own_height_is_no_window_without_positions(results):
    """office_mw, mobile, seed 4, without scanner positions: the mobile scanner's rings leave a
    band 0.3-0.4 m tall without points at its own height (1.5 m) on far walls; stand-in
    scanners at that height saw through it and made 4 windows 0.33-0.43 m tall (19 found of
    15). A gap whose rows the face also holds thinly beside it is a band, not a hole: 15 of 15,
    none extra, and all 9 doors (a closed door's leaf is not seen through)."""
    sc, m, r = _without_positions(results, "office_mw", "mobile", 4)
    d, w = r["doors"], r["windows"]
    assert w["matched"] == w["true"] == 15 and w["found"] <= 16, w  # measured 15 found
    assert d["matched"] == d["true"] == 9 and d["found"] <= 10, d  # measured 9 found


@pytest.mark.slow
def test_a_sparse_scan_keeps_its_low_sills_windows_and_its_doors_doors(results):
    """The Duplex, TLS, seed 3, thinned to 100k points (about a real scan's density): its
    glazing down to 10 cm sills showed the sill's top in 3 of 16 and 15 of 96 columns, under
    the half a door-tall gap needed, and read as doors: 16 doors found for 14 (13 matched),
    11 windows of 22. A sill seen at one level in a few columns, with the floor seen in none,
    makes it a window: 13 doors (none extra), 15 windows."""
    sc, m, r = _run(results, "duplex", "tls", 3, points=100_000)
    d, w = r["doors"], r["windows"]
    assert d["matched"] >= 12 and d["found"] <= d["matched"] + 1, d  # measured 13 of 13 found
    assert w["matched"] >= 14 and w["found"] <= w["matched"] + 1, w  # measured 15 of 15 found


@pytest.mark.slow
def test_a_sparse_scan_without_positions_keeps_the_floor_over_a_slab(results):
    """two_storey_office, mobile, seed 3, thinned to 100k points and without scanner positions:
    the first floor's floor is 16 points per m² in scan lines, and a 0.42 m neighbourhood of its
    points is mostly the ceiling under the slab: their normals tilted anywhere (29 of 241
    within 25° of vertical), the floor of a 19 m² room read as unseen (IPoF 0.09) and the room
    as the inside of furniture (13 spaces for 14 rooms). Over each point's own sheet (split at
    the neighbours' gap in height): 14 spaces for 14 rooms and the door graph equal."""
    key = ("two_storey_office", "mobile", 3, "100k, no positions")
    if key not in results:
        sc, _, _ = _run(results, "two_storey_office", "mobile", 3, points=100_000)
        m = reconstruct(sc.cloud.with_(scan_index=None, scanner_positions=None), "auto", rng=0)
        results[key] = (sc, m, evaluate_elements(m, sc.truth))
    sc, m, r = results[key]
    s = r["spaces"]
    assert s["model"] == s["truth"] == s["matched"] == 14, {k: s[k] for k in ("model", "truth", "matched")}
    assert r["connectivity"]["equal"], r["connectivity"]


@pytest.mark.slow
def test_a_sparse_side_room_keeps_its_wall_behind_a_shelf(results):
    """hexagon_hall, mobile, seed 4, 100k points (the generic method): the mobile path barely
    enters the side rooms, and a side room's wall behind a shelf is 17 points a m² above it —
    no plane on 10 cm cells, so the room stopped at the shelf's front and its "wall" there
    had gaps: 8 doors found for 4 (3 matched), 3 windows where there are none. The fill
    measured at the support's own spacing: 3 doors, all right, no window; the door into the
    NE side room, whose hall-side face is seen but not its room side, is still missed."""
    sc, m, r = _run(results, "hexagon_hall", "mobile", 4, points=100_000)
    d, w = r["doors"], r["windows"]
    assert d["found"] == d["matched"] >= 3, d  # measured 3 of 3 (4 true)
    assert w["found"] == 0, w
    assert r["spaces"]["model"] == r["spaces"]["truth"] == 5, r["spaces"]


@pytest.mark.slow
def test_the_unseen_end_of_a_partition_does_not_join_its_rooms(results):
    """syn_house, mobile, seed 4, 100k points (the generic method): the last 30 cm of the
    partition between the two private rooms before its T-junction, both faces unseen and the
    ceiling's noisy edges over it, was a covered cell between the rooms with no seen wall
    towards either, and joined them into one space (with the sparse walls' planes kept, which
    cut that cell off the rest of the wall). A cell no thicker than a wall, open towards a
    room over less than 2 m, is a gap in a wall line: 5 rooms of 5, every door and window and
    no other."""
    sc, m, r = _run(results, "syn_house", "mobile", 4, points=100_000)
    d, w, s = r["doors"], r["windows"], r["spaces"]
    assert s["model"] == s["truth"] == s["matched"] == 5, {k: s[k] for k in ("model", "truth", "matched")}
    assert d["found"] == d["matched"] == d["true"] == 5, d
    assert w["found"] == w["matched"] == w["true"] == 9, w
    assert r["connectivity"]["equal"], r["connectivity"]


@pytest.mark.slow
def test_a_partition_seen_little_from_one_side_keeps_its_door_without_positions(results):
    """three_storey_house, mobile, seed 5, 300k points, without scanner positions: the top
    storey's partition between the landing and the study makes a cut from the landing's side
    but is seen over less than the 1.5 m² a cut needs from the study's; without oriented normals its second
    face was not looked for, the rooms met at one face and the partition's door was lost
    (8 doors of 9). Its two faces open away from each other: 9 of 9 and the door graph."""
    sc, m, r = _without_positions(results, "three_storey_house", "mobile", 5)
    d = r["doors"]
    assert d["found"] == d["matched"] == d["true"] == 9, d
    assert r["connectivity"]["equal"], r["connectivity"]


@pytest.mark.slow
def test_a_site_wall_seen_through_the_windows_stays_outside_the_attic(results):
    """FZK-Haus, mobile, 1M points, seed 4, without scanner positions: the top of a site wall
    10 m beyond the roof's eaves, at the ridge's height, was read as the attic's ceiling
    running on beyond its seen extent (far scan lines), and the attic took the 10 m between
    them: 238 m² for 110, IoU 0.45, the roof slab over it (ceilings 1 of 2 storeys). The
    ceiling's points are followed only while their steps grow gradually: the attic stops at
    the eaves."""
    key = ("fzk_haus", "mobile", 4, "1M, no positions")
    if key not in results:
        from engine.synthetic.ifcscene import ifc_scene

        sc = ifc_scene("fzk_haus", seed=4, noise="mobile", target_points=1_000_000)
        m = reconstruct(sc.cloud.with_(scan_index=None, scanner_positions=None), "auto", rng=0)
        results[key] = (sc, m, evaluate_elements(m, sc.truth))
    sc, m, r = results[key]
    attic = [s for s in m.spaces if s.storey == 1]
    assert len(attic) == 1
    lo, hi = attic[0].bounds
    assert lo[1] >= -0.1 and hi[1] <= 10.1, (lo, hi)  # the house spans y 0 to 10 m
    s = r["slabs"]
    assert s["floor_found"] == s["ceiling_found"] == s["storeys"] == 2, s



@pytest.mark.slow
@pytest.mark.parametrize("seed", [5, 7])
def test_the_attic_reaches_the_knee_walls_its_roof_comes_down_onto(results, seed):
    """FZK-Haus, mobile, 100k points, with scanner positions: a strip of the roof 1.3-1.75 m
    in from the eaves is never seen (nor the floor under it), so the attic's seen ceiling
    stops 1.75 m short of the knee wall, 0.51 m beyond its last point (more than a wall's
    thickness), and the knee walls (0.6 m high) reach no ceiling: the attic was 6.75 m wide
    for 9.4, its exterior walls covered 0.35-0.70 of the outline (seeds 3-5, 7). A wall
    whose top meets the roof planes closes the attic: the walls cover it all round."""
    key = ("fzk_haus", "mobile", seed, 100_000)
    if key not in results:
        from engine.synthetic.ifcscene import ifc_scene

        sc = ifc_scene("fzk_haus", seed=seed, noise="mobile", target_points=100_000)
        m = reconstruct(sc.cloud, "auto", rng=seed)
        results[key] = (sc, m, evaluate_elements(m, sc.truth))
    sc, m, r = results[key]
    attic = [s for s in m.spaces if s.storey == 1]
    assert len(attic) == 1
    lo, hi = attic[0].bounds
    assert lo[1] <= 0.3 + 0.15 and hi[1] >= 9.7 - 0.15, (lo, hi)  # the knee walls' faces at 0.3, 9.7
    per = r["exterior"]["per_storey"]
    assert min(p["external_share"] for p in per if p["boundary_m"] > 0) >= 0.95, per  # measured 1.00


@pytest.mark.slow
def test_a_strip_along_a_cabinet_touching_another_room_at_a_corner_joins_its_room(results):
    """syn_house, mobile, 1M points, seed 3 (the generic method): a covered strip along a
    cabinet's front in the common room touched the private room beside it over 3 cm at a
    corner; as a cell between two spaces it joined neither, the room stopped at the cabinet
    and the cabinet's front became a wall with a "window" over it (10 found for 9). Faces
    shorter than ``link_length`` in all are no adjacency: the strip joins its room, 9 of 9
    windows, mean room IoU 0.99. The search's seed 3 (as the benchmark rows): with seed 0 the
    chain happened to take the strip in before too (seeds 1-3 did not)."""
    key = ("syn_house", "mobile", 3, "1M, search seed 3")
    if key not in results:
        sc = preset("syn_house", seed=3, noise="mobile", target_points=1_000_000)
        m = reconstruct(sc.cloud, "auto", rng=3)
        results[key] = (sc, m, evaluate_elements(m, sc.truth))
    sc, m, r = results[key]
    w, s = r["windows"], r["spaces"]
    assert w["found"] == w["matched"] == w["true"] == 9, w
    assert s["model"] == s["truth"] == s["matched"] == 5 and s["mean_iou"] >= 0.985, s  # measured 0.99


@pytest.mark.slow
def test_a_partition_without_positions_is_two_faces_not_a_blur(results):
    """office_mw, mobile, seed 3, 300k points, without scanner positions: σ 9 cm, so the
    normals' 0.22 m neighbourhood of a 14 cm partition's point spans both its faces, and 10 %
    of its points faced it; the grammar found no face, the partition was lost and its two rooms
    were one (7 spaces for 8 rooms). Split across the gap between the faces, each point's own
    face gives its normal (45 % face it): 8 of 8 and the door graph equal."""
    sc, m, r = _without_positions(results, "office_mw", "mobile", 3)
    s = r["spaces"]
    assert s["model"] == s["truth"] == s["matched"] == 8, {k: s[k] for k in ("model", "truth", "matched")}
    assert s["mean_iou"] >= 0.98, s  # measured 0.9995
    assert r["connectivity"]["equal"], r["connectivity"]


def _width_errors(sc, m, r, windows: bool) -> np.ndarray:
    from engine.evaluation.elements import _opening_width, _openings

    kind = "windows" if windows else "doors"
    f = {s.id: s for s in _openings(m, windows)}
    t = {s.id: s for s in _openings(sc.truth, windows)}
    return np.array([_opening_width(f[a]) - _opening_width(t[b]) for a, b in r[kind]["pairs"]])


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 4])
def test_fzk_windows_are_measured_to_the_wall_not_their_frames(results, seed):
    """FZK-Haus, terrestrial, 100k points: its nine windows' frames stand 10.5 cm behind the
    inner face, 7 cm into the hole, and its two round windows are 1.0 m across. Frames read
    as jambs and round windows measured over the inner rectangle's height put 3 of 11
    windows more than 10 cm narrow on both seeds (mean error 7 cm). Now at most one (a frame
    whose front no point shows), mean under 4.5 cm."""
    sc, m, r = _run(results, "fzk_haus", "tls", seed, 100_000)
    w = r["windows"]
    assert w["true"] == w["found"] == w["matched"] == 11, w
    e = np.abs(_width_errors(sc, m, r, True))
    assert (e > 0.10).sum() <= 1 and e.mean() <= 0.045, np.sort(e).round(3)  # before: 3, 0.072 / 0.078


@pytest.mark.slow
def test_a_door_whose_lintel_the_scan_missed_is_found(results):
    """The Duplex, terrestrial, 100k points, seed 5: a terrace door (0.81 m, 20 cm under the
    ceiling, beside the 4.8 m glazing) shows no face point above its head, so it reached the
    ceiling: an "opening", and an opening gets no pass for the furniture's shadow over half
    of it, however well its jambs are seen (both were) and rays pass (26 %). One a door wide
    does now: 14 of 14 doors (13 before)."""
    sc, m, r = _run(results, "duplex", "tls", 5, 100_000)
    from engine.evaluation.elements import _openings

    d = r["doors"]
    assert d["true"] == d["matched"] == 14, d
    terrace = [s.id for s in _openings(sc.truth, False) if s.scope.center[2] < 3
               and min(abs(s.scope.center[1] + 0.21), abs(s.scope.center[1] + 17.59)) < 0.05]
    assert len(terrace) == 2 and set(terrace) <= {t for _, t in d["pairs"]}


@pytest.mark.slow
def test_a_glazed_wall_seen_through_keeps_its_door_and_window(results):
    """The Duplex, terrestrial, 100k points, seed 4: the garden side of the ground floor is
    4.8 m of glazing and a 0.81 m door, 10 cm apart. The scanner in front of it measured 16
    points on the wall's face (it sees through it), under the 30 that made it take part in
    the ray test, so no ray passed through the hole (two others saw the face at a slant,
    shadowed by furniture): neither the window nor the door was found. Its rays through the
    face count now: one 5.7 m opening; the floor under the door in 2 of its 16 columns then
    splits it: door and window (13 and 19 matched before, 14 and 20 measured)."""
    sc, m, r = _run(results, "duplex", "tls", 4, 100_000)
    from engine.evaluation.elements import _openings

    for kind, win in (("doors", False), ("windows", True)):
        got = {t for _, t in r[kind]["pairs"]}
        garden = [s.id for s in _openings(sc.truth, win) if s.scope.center[2] < 3
                  and abs(s.scope.center[1] + 17.59) < 0.05 and s.scope.center[0] < 7]
        assert len(garden) == 1 and garden[0] in got, (kind, r[kind])
    assert r["doors"]["matched"] >= 13 and r["doors"]["found"] <= r["doors"]["matched"] + 1, r["doors"]


def _matched(sc, r, kind, x, y):
    """Whether the true ``kind`` ("doors" / "windows") centred at plan (x, y) is matched."""
    truth = sc.truth.doors if kind == "doors" else sc.truth.windows
    t = [t for t in truth if abs(t.scope.center[0] - x) < 0.05 and abs(t.scope.center[1] - y) < 0.05]
    assert len(t) == 1, (x, y)
    return t[0].id in {b for _, b in r[kind]["pairs"]}


def _door_width_error(sc, m, r, x, y) -> float:
    """|found − true| width (m) of the door matched to the true door centred at plan (x, y)."""
    from engine.evaluation.elements import _in_truth_frame, _opening_width

    t = [t for t in sc.truth.doors if abs(t.scope.center[0] - x) < 0.05 and abs(t.scope.center[1] - y) < 0.05]
    assert len(t) == 1, (x, y)
    found = {d.id: d for d in _in_truth_frame(m, sc.truth).doors}
    pair = [a for a, b in r["doors"]["pairs"] if b == t[0].id]
    assert pair, r["doors"]
    return abs(_opening_width(found[pair[0]]) - _opening_width(t[0]))


@pytest.mark.slow
def test_a_door_whose_lower_part_the_scan_missed_is_a_door(results):
    """The Duplex, mobile, 100k points, seed 3: two bedroom doors (0.76 m) show nothing in
    their lower 0.4 m (the trajectory's lines missed it; the sparse face's presence kernel
    filled the rows from the jambs), so the gap started 0.3-0.4 m up and they read as windows
    from there — with the floor seen inside their thickness under that unmeasured bottom. A
    window's sill is wall down to the floor: the floor inside the thickness, in more columns
    than a sill's top, makes the hole reach the floor."""
    sc, m, r = _run(results, "duplex", "mobile", 3, points=100_000)
    for x, y in ((6.29, -9.67), (5.91, -7.78)):
        assert _matched(sc, r, "doors", x, y), (x, y, r["doors"])


@pytest.mark.slow
def test_a_french_window_s_sill_seen_in_two_columns_is_a_sill(results):
    """The Duplex, terrestrial, 100k points, seed 18: its 0.75 m French windows stand on a
    10 cm sill, seen at one level in two columns between the jambs and the floor in none. It
    took three columns, so they read as doors (16 of the 37 false doors over 420 rows). A
    jamb's column, which holds the jamb's lowest points at any height, is left out: with it,
    the 0.86 m door of a hallway read a "sill" at 0.28 m from its two jambs (mobile, seed 11)."""
    from engine.evaluation.elements import _in_truth_frame

    sc, m, r = _run(results, "duplex", "tls", 18, points=100_000)
    assert _matched(sc, r, "windows", 8.59, -5.57), r["windows"]
    near = [d.scope.center.round(2).tolist() for d in _in_truth_frame(m, sc.truth).doors
            if np.hypot(d.scope.center[0] - 8.59, d.scope.center[1] + 5.57) < 0.5]
    assert not near, near
    sc, m, r = _run(results, "duplex", "mobile", 11, points=100_000)
    assert _matched(sc, r, "doors", 1.92, -6.19), r["doors"]


@pytest.mark.slow
@pytest.mark.parametrize("noise, seed", [("mobile", 7), ("tls", 9)])
def test_a_terrace_door_beside_its_glazing_is_measured_to_its_own_jamb(results, noise, seed):
    """The Duplex's terrace door (0.813 m) stands 10 cm beside its 4.8 m glazing; the pier
    between them is seen in a few points, its jamb on the door's side not at all. Mobile, 100k
    points, seed 7: the pier's face in five points, fewer than a pier was asked for, and the
    door was measured to the glazing's jamb, 0.94 m. Terrestrial, seed 9: the door was cut
    from the glazing and both stopped halfway across the pier's columns, 0.748 m. Both within
    5 cm now."""
    sc, m, r = _run(results, "duplex", noise, seed, points=100_000)
    assert _door_width_error(sc, m, r, 5.76, -17.59) <= 0.05


@pytest.mark.slow
def test_a_doorway_whose_upper_part_a_sparse_face_s_kernel_closed_is_a_door(results):
    """The Duplex, mobile, 100k points, seed 5: the terrace door's gap on the faces' rasters
    stopped 1.0 m up. Its sparse face's presence kernel (55 cm) filled the rows above from the
    jamb's and the pier's few points, and the head searched for just above the gap found
    those points at 1.29 m: too low for a door, the door was lost. Points at the jambs are no
    head: the head is looked for further up, away from the jambs, and found at 2.43 m."""
    sc, m, r = _run(results, "duplex", "mobile", 5, points=100_000)
    assert _matched(sc, r, "doors", 5.76, -17.59), r["doors"]


@pytest.mark.slow
def test_a_door_10_cm_from_its_wall_run_s_end_is_measured_to_its_jamb(results):
    """The Duplex, terrestrial, 100k points, seed 11: an upstairs hallway door (0.864 m) stands
    10 cm from where its partition meets another wall. That stub's face was not seen, so the
    gap ran out to the wall run's end, and the jamb was looked for beyond it only: the door
    read 0.996 m, to the run's end. Its reveal, 20 points inside the thickness, lies inside
    the gap: looked for there when the gap reaches the run's end, the door is within 5 cm."""
    sc, m, r = _run(results, "duplex", "tls", 11, points=100_000)
    assert _door_width_error(sc, m, r, 1.85, -11.61) <= 0.05
