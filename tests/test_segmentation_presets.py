"""Planes and cells on the synthetic presets against their true models (engine.synthetic)."""
import functools

import numpy as np
import pytest

from engine.segmentation import PreprocessParams, ceiling_levels, is_structural_wall, preprocess
from seg_scenes import match_planes, room_coverage, truth_walls

synthetic = pytest.importorskip("engine.synthetic")

POINTS = 250_000
NON_MANHATTAN = ("syn_house", "hexagon_hall")


@functools.lru_cache(maxsize=None)
def _run(name, noise):
    scene = synthetic.preset(name, seed=1, noise=noise, target_points=POINTS)
    params = PreprocessParams(align_manhattan=name not in NON_MANHATTAN)
    return scene, preprocess(scene.cloud, params, rng=0)


@pytest.mark.parametrize("name,noise,max_dist", [
    ("syn_house", "tls", 0.02), ("hexagon_hall", "tls", 0.02),
    ("syn_house", "mobile", 0.04), ("hexagon_hall", "mobile", 0.04),
])
def test_planes_match_visible_true_walls(name, noise, max_dist):
    scene, res = _run(name, noise)
    st = res.storeys[0]
    levels = ceiling_levels(res.planes, st)
    walls = [p for p in res.planes if is_structural_wall(p, st, levels=levels)]
    truth = truth_walls(scene.truth, res.transform, res.working)
    flags, unmatched = match_planes(walls, truth, 2.0, max_dist)
    assert len(flags) >= 8  # enough visible walls for the test to mean something
    assert all(flags), f"{flags.count(False)} of {len(flags)} visible walls unmatched"
    assert len(unmatched) <= 0.1 * len(walls)


@pytest.mark.parametrize("name", ["office_mw", "syn_house", "hexagon_hall"])
def test_cells_cover_every_true_room(name):
    scene, res = _run(name, "tls")
    cov = room_coverage(res.cells, scene.truth, res.transform, 0)
    assert len(cov) == len(scene.truth.spaces)
    for room, share, dist in cov:
        assert share >= 0.98, (room, share)
        assert dist <= 0.05, (room, dist)
    # few cells: the hexagon example of the thesis has 89
    assert len(res.cells.cells) <= 60


def test_office_storey_and_faces():
    scene, res = _run("office_mw", "tls")
    (st,) = res.storeys
    t = scene.truth.storeys[0]
    assert abs(st.floor_z - t.floor_z) < 0.03 and abs(st.ceiling_z - t.ceiling_z) < 0.03
    # most shared faces carry the wall plane they lie on
    faces = [f for f in res.cells.faces if f.kind == "vertical"]
    with_wall = [f for f in faces if f.wall_plane is not None]
    assert len(with_wall) >= 0.8 * len(faces)
    assert all(0.0 <= f.coverage <= 1.0 for f in faces)


def test_rooms_of_several_ceiling_heights_get_matching_cell_levels():
    scene, res = _run("house_multi_height", "tls")
    (st,) = res.storeys
    assert abs(st.ceiling_z - 3.2) < 0.03  # the storey reaches the highest ceiling
    levels = ceiling_levels(res.planes, st)
    truth = sorted({round(s.bounds[1][2], 2) for s in scene.truth.spaces})
    assert len(levels) == len(truth)
    assert np.allclose(levels, truth, atol=0.03)
    # every room is covered by the cells of each layer below its ceiling
    cov = room_coverage(res.cells, scene.truth, res.transform, 0)
    assert all(share >= 0.98 and dist <= 0.05 for _, share, dist in cov)
