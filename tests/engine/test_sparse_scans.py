"""Sparse and single-position scans (issue 19): whole floors at 100k points per storey, TLS
and mobile, and one terrestrial position per storey in its biggest room (the other rooms
seen only through doors), on the IFC-built scenes and the procedural presets.

Scored with :func:`engine.evaluation.rooms.room_scores` (open plans merged, only the true
rooms the scan reaches: :func:`~engine.evaluation.rooms.scanned_spaces`). Targets: room
recall >= 0.95 and no space under 1.5 m² or under 1.8 m high that the truth lacks
(``small_spurious == 0``). Seed 2 — the rules were developed on seeds 1 and 3. Targets are
asserted where met (the measured figures on seed 2 are in ``MEASURED``); the others are
xfail (strict=False) with the figure measured today."""
import numpy as np
import pytest

from engine.errors import InputError
from engine.evaluation.rooms import room_scores, scanned_spaces
from engine.reconstruct import reconstruct
from engine.synthetic import ScanParams, preset, preset_plans

SEED = 2
PER_FLOOR = 100_000
IFC = ("fzk_haus", "duplex")
_cache = {}


def _floors(name):
    if name in IFC:
        from engine.synthetic import ifc_scene_path, ifc_truth
        t = ifc_truth(ifc_scene_path(name))
        return len({s.storey for s in t.spaces if 0 <= s.storey < len(t.storeys)})
    return len(preset_plans(name)["truth"].storeys)


def _run(name, kind):
    key = (name, kind)
    if key not in _cache:
        dens, noise = kind.split("-")
        pps = 1 if dens == "single" else None
        n = PER_FLOOR * _floors(name)
        if name in IFC:
            from engine.synthetic import ifc_scene
            sc = ifc_scene(name, seed=SEED, noise=noise, target_points=n, positions_per_storey=pps)
        else:
            sc = preset(name, seed=SEED, noise=noise, target_points=n, positions_per_storey=pps)
        m = reconstruct(sc.cloud, "auto", rng=0)
        _cache[key] = (sc, m, room_scores(m, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz)))
    return _cache[key]


# ----------------------------------------------------------------------------- the simulator option
def test_one_position_per_storey_in_the_biggest_room():
    from engine.synthetic import build_truth, scanner_positions

    plan = preset_plans("two_storey_office")["truth"].validated()
    pos = scanner_positions(plan, ScanParams(positions_per_storey=1))
    assert pos.shape == (2, 3)  # one per storey
    for s in range(2):
        rooms = [r for r in plan.rooms if r.storey == s and r.scanned]
        big = max(rooms, key=lambda r: r.shape.area)
        p = [q for q in pos if abs(q[2] - plan.floor_z(big) - 1.5) < 1e-6]
        assert len(p) == 1 and big.shape.contains(__import__("shapely").geometry.Point(p[0][:2]))
    assert len(scanner_positions(plan, ScanParams())) > 2
    assert build_truth(plan) is not None
    with pytest.raises(InputError):
        ScanParams(positions_per_storey=0)
    with pytest.raises(InputError):
        ScanParams(mode="mobile", positions_per_storey=1)


# ----------------------------------------------------------------------------- the targets
# (scene, kind): (recall, small or low spaces the truth lacks) measured on seed 2, and the
# reason when a target is not met (xfail).
MEASURED = {
    ("office_mw", "sparse-tls"): (1.0, 0), ("office_mw", "sparse-mobile"): (1.0, 0),
    ("office_mw", "single-tls"): (1.0, 0),  # IoU 1.0 (0.73-0.81 on seeds 1, 3 before the far-ceiling rule)
    ("two_storey_office", "sparse-tls"): (1.0, 0), ("two_storey_office", "sparse-mobile"): (1.0, 0),
    ("two_storey_office", "single-tls"): (1.0, 0),  # IoU 0.999 (0.83 before)
    ("syn_house", "sparse-tls"): (1.0, 0), ("syn_house", "sparse-mobile"): (1.0, 0),
    ("syn_house", "single-tls"): (1.0, 0),
    ("fzk_haus", "sparse-tls"): (1.0, 0), ("fzk_haus", "sparse-mobile"): (1.0, 0),
    ("fzk_haus", "single-tls"): (1.0, 0),  # 0.5 before the void-wall and far-ceiling rules; IoU 0.89
    ("duplex", "sparse-tls"): (1.0, 0),  # a wardrobe was a 1.1-1.3 m² space before the no-floor rule
    ("duplex", "sparse-mobile"): (1.0, 0),
    ("duplex", "single-tls"): (0.667, 0),  # 0.0 before the storey-footprint rule (one 5.7 m high storey)
}
XFAIL = {
    ("duplex", "single-tls"): "level 2: the hallway seen through the bedroom door is not modelled (recall 0.667; "
                              "seeds 1, 2, 3); open plan of level 1 IoU 0.72",
}
CASES = [(n, k) for n in ("office_mw", "two_storey_office", "syn_house", "fzk_haus", "duplex")
         for k in ("sparse-tls", "sparse-mobile", "single-tls")]


@pytest.mark.slow
@pytest.mark.parametrize("name,kind", CASES)
def test_sparse_and_single_position_rooms(name, kind, request):
    if (name, kind) in XFAIL:
        request.applymarker(pytest.mark.xfail(reason=XFAIL[(name, kind)], strict=False))
    sc, m, r = _run(name, kind)
    assert (name, kind) in MEASURED
    assert r["storeys"]["model"] >= 1
    # recall target 0.95 (seed 2 figure in MEASURED: margin = measured - 0.95)
    assert r["recall"] >= 0.95, r
    assert r["small_spurious"] == 0, r
    assert np.isfinite(r["mean_iou"]) and r["mean_iou"] >= 0.8, r


@pytest.mark.slow
def test_single_position_storeys_are_separated():
    """One position per storey sees one room of each level, in different places: each level's
    floor and ceiling are a storey (their area is measured against that storey's own
    footprint, not the building's). Before: one storey 5.7 m high, no room matched."""
    sc, m, r = _run("duplex", "single-tls")
    assert r["storeys"]["model"] == 2, r["storeys"]
    heights = [float(s.bounds[1, 2] - s.bounds[0, 2]) for s in m.spaces]
    assert heights and max(heights) < 3.0, heights  # 2.58 m rooms, not 5.7 m


@pytest.mark.slow
@pytest.mark.parametrize("name", ["office_mw", "fzk_haus"])
def test_single_position_reaches_the_far_walls(name):
    """The far ends of a long room seen from one position (sparse ceiling scan lines) and
    the walls of a double-height void (no ceiling to reach) bound the room: seed 2 IoU
    office corridor 1.0 (0.73-0.81 before on seeds 1, 3), FZK-Haus open plan 0.79 (0)."""
    sc, m, r = _run(name, "single-tls")
    ground = r["per_storey"][0]
    assert ground["matched"] == ground["true"] >= 1, ground
    assert min(ground["ious"]) >= (0.95 if name == "office_mw" else 0.7), ground


# ----------------------------------------------------------------------------- thin partitions
@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3])
def test_mobile_partitions_keep_rooms_apart(seed):
    """office_mw, mobile, 300k points: the normals' neighbourhood (30 points within 22 cm)
    spans both faces of the 16 cm partition between Rooms 2 and 3, so only 20 % of its points
    faced it and the grammar merged the rooms (7 spaces for 8 rooms on seeds 2 and 3). The
    normals over the neighbours seen from the same side (docs/method.md §1 "Normals"): 71 %
    face it, 8 of 8 rooms, mean IoU 0.987 / 0.998 on seeds 3 / 2."""
    from engine.pipeline import full_cloud_normals
    from engine.geometry.spacing import estimate_spacing

    sc = preset("office_mw", seed=seed, noise="mobile", target_points=300_000)
    p = sc.cloud.xyz
    wall = ((p[:, 0] > 8.85) & (p[:, 0] < 9.13) & (p[:, 1] > 2.3) & (p[:, 1] < 6.8)
            & (p[:, 2] > 0.3) & (p[:, 2] < 2.6))
    n = full_cloud_normals(sc.cloud, spacing=estimate_spacing(p)).normals
    facing = np.mean(np.abs(n[wall, 0]) >= np.cos(np.deg2rad(20)))
    assert facing >= 0.5  # 0.2 before; 0.71 / 0.83 (seeds 3 / 2)
    m = reconstruct(sc.cloud, "auto", rng=0)
    r = room_scores(m, sc.truth)
    assert r["matched"] == r["true"] == 8 and r["model"] == 8, r
    assert r["mean_iou"] >= 0.95, r
    # and no room loses the strip over a cabinet against the partition (its ceiling seen only
    # sparsely from the mobile path: IoU 0.90 on seed 3 before the sparse ceiling index;
    # 0.998-0.999 every room, seeds 2, 3)
    assert min(r["per_storey"][0]["ious"]) >= 0.95, r["per_storey"][0]["ious"]
