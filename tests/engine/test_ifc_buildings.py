"""Real architects' plans reconstructed (issue 19): FZK-Haus (a ground floor with an open plan
under a double-height void, an attic under pitched roof slabs) and the Duplex (two flats with a
0.55 m party wall, two levels in one scan), scanned by :func:`engine.synthetic.ifc_scene`.

Scored with :func:`engine.evaluation.rooms.room_scores` (one-to-one footprint IoU, open plans
merged) on seed 2 — the rules were developed on seed 0 and benchmarked on seed 1. The issue's
targets are asserted where they are met, with the margin to the measured figure stated; the
others are xfail (strict=False) with the figure measured today."""
import numpy as np
import pytest
from shapely.geometry import LineString
from shapely.ops import unary_union

from engine.errors import ReconstructionError
from engine.evaluation import evaluate
from engine.evaluation.elements import _plan
from engine.evaluation.rooms import RoomScoreParams, merge_open_plans, room_scores, scanned_spaces
from engine.reconstruct import reconstruct
from engine.synthetic import ifc_scene

SEED = 2
POINTS = 300_000
_cache = {}


def _run(name, noise="tls"):
    key = (name, noise)
    if key not in _cache:
        sc = ifc_scene(name, seed=SEED, noise=noise, target_points=POINTS)
        m = reconstruct(sc.cloud, "auto", rng=0)
        seen = scanned_spaces(sc.truth, sc.cloud.xyz)
        _cache[key] = (sc, m, room_scores(m, sc.truth, seen=seen))
    return _cache[key]


def _walls(sc, m):
    """Side-face completeness and correctness at 10 cm over the faces of the true spaces the
    scan reaches (as the rooms are scored: the Duplex's roof space, 150 m² of walls no
    scanner enters, counted as missed before, 0.75 instead of 0.93 on seed 2)."""
    from engine.evaluation import EvaluationParams
    from engine.evaluation.patches import patches_from_model

    seen = scanned_spaces(sc.truth, sc.cloud.xyz)
    prm = EvaluationParams()
    keys = [p.key for p in patches_from_model(sc.truth, prm.surface_types, kinds=prm.groups,
                                              merge=prm.merge_coplanar)]
    ev = evaluate(m, sc.truth, prm, visible={k: k.split(":")[0] in seen for k in keys})
    i = int(np.argmin(np.abs(ev.buffers - 0.10)))
    return float(ev.curve("completeness", "wall")[i]), float(ev.curve("correctness", "wall")[i])


# ----------------------------------------------------------------------------- the scorer
def test_open_plans_merge_only_where_no_wall_separates_them():
    from shapely.geometry import box

    a, b, c = box(0, 0, 3, 3), box(3, 0, 6, 3), box(6.2, 0, 9, 3)  # a|b touch, b..c 0.2 m gap
    wall_bc = box(6.0, 0, 6.2, 3)
    assert merge_open_plans([a, b, c], [wall_bc]) == [[0, 1], [2]]
    assert merge_open_plans([a, b, c], [wall_bc, box(2.95, 0, 3.05, 3)]) == [[0], [1], [2]]
    with pytest.raises(Exception):
        RoomScoreParams(min_iou=0)


# ----------------------------------------------------------------------------- FZK-Haus
@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_fzk_haus_rooms(noise):
    sc, m, r = _run("fzk_haus", noise)
    assert r["storeys"]["model"] == 2  # the attic under the pitched roof is a storey
    # targets: recall >= 0.95 (seed 0: 1.0), mean IoU >= 0.9 (seed 0: 0.99)
    assert r["recall"] >= 0.95, r
    assert r["mean_iou"] >= 0.9, r
    assert r["small_spurious"] == 0 and r["outside_m2"] <= 0.5, r


@pytest.mark.slow
def test_fzk_haus_attic_and_void():
    sc, m, r = _run("fzk_haus")
    attic, ground = r["per_storey"][1], r["per_storey"][0]
    assert attic["matched"] == 1 and attic["ious"][0] >= 0.95  # the "Galerie" under two roof slabs (0.99)
    # its body follows the two roof planes: volume 217.5 m³ in the IFC (218.3 on seed 3; a box
    # up to the ridge held 360 m³), 5 % margin
    true_attic = next(s for s in sc.truth.spaces if s.name == "Galerie")
    up = [s for s in m.spaces if s.storey == 1]
    assert len(up) == 1 and up[0].attributes.get("sloped_top") is True
    assert abs(up[0].geometry.volume() - true_attic.geometry.volume()) <= 0.05 * true_attic.geometry.volume()
    assert up[0].geometry.footprint() is None  # no prism: the IFC writes a Brep
    # the open plan (living room, hall with the stair, kitchen) under the double-height void
    k = next(i for i, g in enumerate(ground["true_groups"]) if "Flur" in g)
    assert ground["ious"][k] >= 0.9  # 0.98 on seed 0 (0.69 before the void rule)
    # the hall and the living room, open to each other under a beam: two spaces split at the beam,
    # connected without a wall or a door (an IfcVirtualElement in the IFC)
    names = {s.id: s.name for s in m.spaces}
    open_links = {frozenset((r.a, r.b)) for r in m.relations
                  if r.kind == "connectivity" and r.via is None and r.a in names and r.b in names}
    assert len(open_links) == 1, open_links
    low = [s for s in m.spaces if s.attributes.get("confidence") is not None]
    assert low and all(0.5 <= s.attributes["confidence"] < 1.0 for s in low)  # ceiling partly unseen


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_fzk_haus_side_faces(noise):
    # seed 2 measures completeness 0.99 / 0.99 and correctness 0.99 / 0.99 (TLS / mobile);
    # correctness was 0.75 while the attic was a box up to the ridge and 0.94 while the hall and
    # the living room, open under a beam, were two rooms with a gap (margin 0.04 to the target)
    sc, m, _ = _run("fzk_haus", noise)
    c, k = _walls(sc, m)
    assert c >= 0.95 and k >= 0.95, (c, k)


# ----------------------------------------------------------------------------- Duplex
@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_duplex_rooms(noise):
    sc, m, r = _run("duplex", noise)
    assert r["storeys"]["model"] == 2  # both levels of the one scan
    assert r["recall"] >= 0.95, r  # 14/14 on seeds 0, 1, 2
    assert r["small_spurious"] <= 1, r  # slivers between doubled wall lines: 6-11 before, 0-1 now


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_duplex_no_extra_spaces(noise):
    # seed 2 TLS: a bedroom's wardrobe (1.1 m², its front cut at a wall line elsewhere) was a space
    # of its own; no floor is seen under it, so it is furniture, not a room: 14 of 14, no extra.
    # Seed 2 mobile: 16 spaces for 14 rooms while level 2 (flat ceilings under a higher hallway
    # ceiling) was taken for an attic (docs/method.md §2 "Sloped tops"); 14 of 14 since
    # (precision 1.0, mean IoU 0.97)
    sc, m, r = _run("duplex", noise)
    assert r["small_spurious"] == 0 and r["precision"] >= 0.95, r


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_duplex_open_plan_is_one_space(noise):
    # each flat's living room and kitchen open onto the foyer past a partition that stops 2.8 m
    # short; the grid had no cut where it stops, so its cuboid ran on as a wall and the foyer
    # was a space of its own (17 and 16 spaces for 14 rooms, TLS / mobile, seeds 2-5); with a cut
    # at the wall's free end (engine.grammar.ends) one space holds all three: 0.99-1.00 of the
    # foyer's and the kitchen's area on seed 2 (0.00 of the foyer's before), 14 spaces
    sc, m, r = _run("duplex", noise)
    for living in (s for s in sc.truth.spaces if s.name == "Living Room"):
        lp = _plan(living, sc.truth)
        space = _plan(max(m.spaces, key=lambda s: _plan(s, m).intersection(lp).area), m)
        for t in sc.truth.spaces:
            tp = _plan(t, sc.truth)
            if t.name in ("Kitchen", "Foyer") and tp.distance(lp) < 0.5:
                assert space.intersection(tp).area >= 0.9 * tp.area, (t.name, t.id)
    assert len(m.spaces) <= r["true"] + 1, (len(m.spaces), r["true"])  # 14 of 14 measured


@pytest.mark.slow
def test_duplex_iou_and_envelope():
    sc, m, r = _run("duplex")
    # targets: mean IoU >= 0.9 (seeds 0, 1: 0.95, 0.94), nothing outside the envelope (0 m²)
    assert r["mean_iou"] >= 0.9 and r["outside_m2"] <= 0.5, r
    assert min(min(p["ious"]) for p in r["per_storey"] if p["ious"]) >= 0.8, r  # seed 0: 0.88


@pytest.mark.slow
def test_duplex_glazing_keeps_rooms_inside_mobile():
    # a walking scanner looks through the living rooms' glazed fronts onto the terraces: a window
    # head's soffit read as ceiling used to carry a room 0.6 m past the wall (0.39 m² on seed 2,
    # 1.0-1.2 m² on seeds 3 and 4); a ceiling with no floor and no wall under it is no room
    sc, m, r = _run("duplex", "mobile")
    assert r["outside_m2"] <= 0.1 and r["recall"] >= 0.95, r  # 0.0 and 1.0 on seed 2


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["tls", "mobile"])
def test_duplex_party_wall_is_modelled(noise):
    """The 0.55 m party wall between the flats: on its storey, model walls cover both of its
    faces over most of its length, and no room lies on it. (Before, the model's rooms and walls
    of every storey were compared with it: the level-1 living rooms, which reach across the
    line of the level-2 party wall, were counted as lying on it.) Seed 2: both faces of each
    of its four pieces covered wholly, no room on them, TLS and mobile."""
    sc, m, _ = _run("duplex", noise)
    party = [w for w in sc.truth.walls if "Party" in (w.name or "")]
    assert party

    def at(x, z):
        return x.bounds[0, 2] <= z <= x.bounds[1, 2]

    for w in party:
        z = float(w.bounds[:, 2].mean())  # the model's walls and rooms at its mid-height
        walls = unary_union([_plan(x, m).buffer(0.1) for x in m.walls if at(x, z)])
        rooms = [_plan(x, m) for x in m.spaces if at(x, z)]
        p = _plan(w, sc.truth)
        x0, y0, x1, y1 = p.bounds
        along_y = (y1 - y0) > (x1 - x0)
        faces = ([LineString([(x0 + 0.05, y0), (x0 + 0.05, y1)]), LineString([(x1 - 0.05, y0), (x1 - 0.05, y1)])]
                 if along_y else
                 [LineString([(x0, y0 + 0.05), (x1, y0 + 0.05)]), LineString([(x0, y1 - 0.05), (x1, y1 - 0.05)])])
        for f in faces:
            covered = f.intersection(walls).length
            assert covered >= 0.8 * f.length, (w.name, covered, f.length)
        on_it = sum(p.intersection(r).area for r in rooms)
        assert on_it <= 0.1 * p.area, (w.name, on_it, p.area)
        if z > 3.0:  # upstairs the bedrooms reach its faces: modelled 0.55 m thick (seed 2, TLS and
            # mobile; 0.74 m before, each bedroom lost a 10 cm slice to a wall line 10 cm off the
            # wall's face, engine.grammar.passages.room_slices). Downstairs: 0.65 and 0.74 m for
            # 0.49 and 0.55, not asserted
            best = max((x for x in m.walls if at(x, z)), key=lambda x: _plan(x, m).intersection(p).area)
            assert abs(best.attributes["thickness"] - min(x1 - x0, y1 - y0)) <= 0.03, (w.name, best.id)


@pytest.mark.slow
@pytest.mark.xfail(reason="side faces of the scanned spaces: seed 2 measures completeness 0.93, correctness "
                          "0.96 (TLS; mobile 0.93 / 0.96); missed: the upper bedrooms' wardrobe alcoves (2 m "
                          "cabinets, 0.6 m of wall seen above them, 22 m2: the weak peak at their back is no "
                          "second face, another cut stands within a wall's thickness beyond it), faces of the "
                          "stairwells (one space through both levels in the truth)", strict=False)
def test_duplex_side_faces():
    sc, m, _ = _run("duplex")
    c, k = _walls(sc, m)
    assert c >= 0.95 and k >= 0.95, (c, k)


# ----------------------------------------------------------------------------- evidence rule
def test_an_all_rejected_model_is_an_error_naming_the_stage(monkeypatch):
    """When the evidence rule rejects every space, reconstruct says so (no silent empty model)."""
    import engine.grammar.manhattan as manhattan
    from engine.synthetic import preset

    real = manhattan.reject_implausible_spaces

    def reject_all(model, min_width, min_area, min_height, tau=None, **kw):
        return real(model, 1e6, min_area, min_height, tau, **kw)  # everything is "too narrow"

    monkeypatch.setattr(manhattan, "reject_implausible_spaces", reject_all)
    sc = preset("office_mw", seed=1, noise="tls", target_points=60_000)
    with pytest.raises(ReconstructionError, match="evidence rule rejected all"):
        reconstruct(sc.cloud, "manhattan", rng=0)
