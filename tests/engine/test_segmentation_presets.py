"""The shared preprocessing and the generic method's cells on the synthetic presets against
their true models (engine.pipeline, engine.grammar.generic.storey_cells)."""
import functools

import numpy as np
import pytest

from engine.grammar.generic import storey_cells
from engine.grammar.params import CellParams, CoverageParams
from engine.pipeline import preprocess
from engine.synthetic import preset
from scenes.segmentation import match_planes, room_coverage, truth_walls

POINTS = 250_000


@functools.lru_cache(maxsize=None)
def _run(name, noise):
    scene = preset(name, seed=1, noise=noise, target_points=POINTS)
    return scene, preprocess(scene.cloud, rng=0)


@pytest.mark.parametrize("name,noise,max_dist", [
    ("syn_house", "tls", 0.02), ("hexagon_hall", "tls", 0.02),
    ("syn_house", "mobile", 0.04), ("hexagon_hall", "mobile", 0.04),
])
def test_planes_match_visible_true_walls(name, noise, max_dist):
    scene, prep = _run(name, noise)
    # the wall planes that cut cells (CellParams.min_wall_area)
    walls = [p for p in prep.planes if p.kind == "wall" and p.area >= CellParams().min_wall_area]
    truth = truth_walls(scene.truth, np.eye(4), prep.working)
    flags, unmatched = match_planes(walls, truth, 2.0, max_dist)
    assert len(flags) >= 8  # enough visible walls for the test to mean something
    # every visible true wall has a plane (furniture faces add planes of their own: their
    # cells are no room, and the search leaves them out)
    assert all(flags), f"{flags.count(False)} of {len(flags)} visible walls unmatched"


@pytest.mark.parametrize("name", ["office_mw", "syn_house", "hexagon_hall"])
def test_cells_cover_every_true_room(name):
    scene, prep = _run(name, "tls")
    (sc,) = storey_cells(prep)
    cov = room_coverage(sc.cells.polygons, scene.truth, np.eye(4), 0)
    assert len(cov) == len(scene.truth.spaces)
    # each room is a union of cells: covered (measured ≥ 0.9994) with nothing outside
    # (measured ≤ 0.0001 of its area), so the rjMCMC can select it exactly
    for room, share, excess in cov:
        assert share >= 0.98, (room, share)
        assert excess <= 0.02, (room, excess)


def test_office_storey_within_3cm():
    scene, prep = _run("office_mw", "tls")
    (st,) = prep.storeys
    t = scene.truth.storeys[0]
    assert abs(st.floor_z - t.floor_z) < 0.03 and abs(st.ceiling_z - t.ceiling_z) < 0.03
    assert prep.storeys_found


def test_rooms_of_several_ceiling_heights_get_their_ceiling_planes():
    scene, prep = _run("house_multi_height", "tls")
    (st,) = prep.storeys
    assert abs(st.ceiling_z - 3.2) < 0.03  # the storey reaches the highest ceiling
    mid = (st.floor_z + st.ceiling_z) / 2
    big = CoverageParams().min_ceiling_area
    levels = sorted({round(float(p.offset / p.normal[2]), 2) for p in prep.planes
                     if p.kind == "horizontal" and p.area >= big and p.offset / p.normal[2] > mid})
    truth = sorted({round(s.bounds[1][2], 2) for s in scene.truth.spaces})
    # every true ceiling height has a plane within 3 cm (several pieces may share a level)
    assert all(min(abs(lv - t) for lv in levels) <= 0.03 for t in truth), (levels, truth)
    cov = room_coverage(storey_cells(prep)[0].cells.polygons, scene.truth, np.eye(4), 0)
    assert all(share >= 0.98 and excess <= 0.02 for _, share, excess in cov)
