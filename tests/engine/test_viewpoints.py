"""Stand-in scanners for a scan without scanner positions (engine/elements/viewpoints.py):
viewpoints in the rooms' free space, lines of sight blocked by the scan's occupied voxels."""
import numpy as np
from shapely.geometry import box

from engine.elements.params import ViewpointParams
from engine.elements.viewpoints import occupancy, room_viewpoints, visible_pairs
from engine.model import Storey


def _plane(rng, x, y, z, n):
    """n points uniform in the axis-aligned rectangle spanned by the (lo, hi) ranges."""
    return np.column_stack([rng.uniform(*x, n), rng.uniform(*y, n), rng.uniform(*z, n)])


def _two_rooms(rng):
    """Two 4 m × 4 m rooms side by side (x 0–4 and 4.1–8.1), a 10 cm wall between them at
    x 4.0–4.1 with a 1 m × 2 m doorway at y 1.5–2.5; floors at z 0, 2.6 m high."""
    wall = np.vstack([_plane(rng, (4.0, 4.0), (0, 1.5), (0, 2.6), 4000),
                      _plane(rng, (4.0, 4.0), (2.5, 4), (0, 2.6), 4000),
                      _plane(rng, (4.0, 4.0), (1.5, 2.5), (2.0, 2.6), 800),
                      _plane(rng, (4.1, 4.1), (0, 1.5), (0, 2.6), 4000),
                      _plane(rng, (4.1, 4.1), (2.5, 4), (0, 2.6), 4000),
                      _plane(rng, (4.1, 4.1), (1.5, 2.5), (2.0, 2.6), 800)])
    floor = _plane(rng, (0, 8.1), (0, 4), (0, 0), 20000)
    floor[:, 2] += rng.normal(0.0, 0.005, len(floor))  # range noise
    far = _plane(rng, (8.1, 8.1), (0, 4), (0, 2.6), 6000)  # room B's far wall
    return wall, floor, far


def test_viewpoints_stand_in_each_room_in_free_space():
    rng = np.random.default_rng(0)
    wall, floor, far = _two_rooms(rng)
    p = ViewpointParams()
    xyz = np.vstack([wall, floor, far, _plane(rng, (0.9, 1.3), (0.9, 1.3), (1.5, 1.5), 400)])  # a shelf top
    st = [Storey(index=0, name="0", floor_z=0.0, ceiling_z=2.6, elevation=0.0)]
    fps = {0: {"a": box(0, 0, 4.0, 4.0), "b": box(4.1, 0, 8.1, 4.0)}}
    vp = room_viewpoints(fps, st, occupancy(xyz, p), p)
    # 3 m × 3 m inside each room after the clearance: one grid point per 4 m, at its middle
    assert len(vp) == 2
    assert np.allclose(sorted(vp[:, 0]), [2.0, 6.1], atol=0.01) and np.allclose(vp[:, 1], 2.0, atol=0.01)
    assert np.allclose(vp[:, 2], 1.5)  # a scanner's height, under 60 % of 2.6 m
    # a viewpoint in furniture is left out
    fps = {0: {"a": box(0, 0, 2.2, 2.2)}}  # its only grid point (1.1, 1.1) is on the shelf
    assert len(room_viewpoints(fps, st, occupancy(xyz, p), p)) == 0


def test_a_line_of_sight_passes_a_doorway_and_stops_at_a_wall():
    rng = np.random.default_rng(1)
    wall, floor, far = _two_rooms(rng)
    xyz = np.vstack([wall, floor, far])
    vp = np.array([[1.0, 2.0, 1.5]])  # in room A, facing the doorway
    pt, v = visible_pairs(xyz, vp, ViewpointParams())
    seen = np.zeros(len(xyz), bool)
    seen[pt] = True
    assert np.all(v == 0)
    f = xyz[len(wall) + len(floor):]  # room B's far wall, 4 m behind the partition
    fs = seen[len(wall) + len(floor):]
    # straight through the doorway (the line at x 4.0 within y 1.5–2.5, z < 2) ...
    lam = (4.05 - 1.0) / (f[:, 0] - 1.0)
    y_at, z_at = 2.0 + lam * (f[:, 1] - 2.0), 1.5 + lam * (f[:, 2] - 1.5)
    through = (np.abs(y_at - 2.0) < 0.3) & (z_at > 0.3) & (z_at < 1.7)
    blocked = (np.abs(y_at - 2.0) > 0.7) | (z_at > 2.3)
    assert through.sum() > 50 and blocked.sum() > 500
    assert fs[through].mean() > 0.95  # seen through the doorway
    assert fs[blocked].mean() < 0.02  # hidden by the partition
    # room A's own side of the partition (its face at x 4.0) is seen: its own surface
    a_face = seen[:len(wall)][wall[:, 0] < 4.05]
    assert a_face.mean() > 0.95
    # a floor seen at a glancing angle is its own surface, not an obstacle: room B's floor
    # 2-3.5 m beyond the doorway (the line 4-5 m long, 7 % of it within 10 cm of the floor)
    fl = xyz[len(wall):len(wall) + len(floor)]
    beyond = (fl[:, 0] > 6.0) & (fl[:, 0] < 7.5) & (np.abs(fl[:, 1] - 2.0) < 0.2)
    assert beyond.sum() > 50
    assert seen[len(wall):len(wall) + len(floor)][beyond].mean() > 0.9
    pt0, _ = visible_pairs(xyz, vp, ViewpointParams(plane_tolerance=0.0))  # no own surface: blocked
    assert np.isin(np.flatnonzero(beyond) + len(wall), pt0).mean() < 0.5


def test_no_viewpoints_no_pairs():
    xyz = np.random.default_rng(2).uniform(0, 1, (100, 3))
    pt, v = visible_pairs(xyz, np.zeros((0, 3)))
    assert len(pt) == len(v) == 0


def test_each_storeys_viewpoints_look_at_a_point():
    """The ground seen through an upper storey's window lies nearer the lower storey's
    viewpoints; the upper ones must be asked too (at least 2 per level)."""
    from engine.elements.viewpoints import _nearest_per_level

    low = np.array([[x, 2.0, 1.5] for x in (1.0, 3.0, 5.0, 7.0, 9.0)])
    high = np.array([[2.0, 2.0, 4.6], [8.0, 2.0, 4.6], [14.0, 2.0, 4.6]])
    vp = np.vstack([low, high])
    src = np.array([[5.0, -3.0, 0.0]])  # the ground outside, under the upper storey
    s, v, d = _nearest_per_level(src, vp, ViewpointParams(neighbours=4))
    assert (s == 0).all()
    assert sorted(v[vp[v, 2] > 3]) == [5, 6] and len(v[vp[v, 2] < 3]) == 2  # 2 per level, nearest
    assert np.allclose(d, np.linalg.norm(vp[v] - src[0], axis=1))
    # one level: the 4 nearest
    s, v, d = _nearest_per_level(src, low, ViewpointParams(neighbours=4))
    assert sorted(v) == [0, 1, 2, 3] or sorted(v) == [1, 2, 3, 4]
