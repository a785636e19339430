"""The Manhattan grammar on the two real PCL room scans (tests/data/room_scan*.pcd).

Two single-position TLS scans of one furnished room (112 k points each; the second from
another position, rotated about 35°). The floor is measured at z ≈ −1.27 m and the
ceiling at ≈ +1.65 m in the scanner frame (medians of the levelled horizontal points:
the lowest floor points reach −1.35 m only at grazing range), so the clear height is
≈ 2.92 m. A desk plane near z = −0.15 m holds more points than the floor.

Both scans see the whole room, 10.7 m × 4.55 m: scan 2 sees both end walls (x −4.57 and
+6.11 after alignment); in scan 1 the ceiling runs on without a step or lintel from
x −2.6 to 7.75 m and the long walls reach x ≈ 8.1 m under it, where the far end wall is
seen only in patches. The ceiling reads up to 9 cm low 5–8 m from either scanner (the
floor 3–5 cm low): a range-dependent error of the scans, not a lower ceiling.
"""
import os

import numpy as np
import pytest

from engine.grammar import ManhattanParams, reconstruct_manhattan
from engine.io import read_point_cloud
from engine.model import ShapeType
from scenes import DATA


_MODELS = {}


def _reconstruct(name):
    """The scan and its model, reconstructed once per test session (≈ 5 s each)."""
    if name not in _MODELS:
        cloud = read_point_cloud(os.path.join(DATA, name))
        _MODELS[name] = (cloud, reconstruct_manhattan(cloud, ManhattanParams.real_tls(), rng=0))
    return _MODELS[name]


@pytest.fixture(scope="module", params=["room_scan1.pcd", "room_scan2.pcd"])
def scan(request):
    cloud, model = _reconstruct(request.param)
    return request.param, cloud, model


def _room_at_scanner(model):
    origin = np.linalg.inv(model.transform) @ np.array([0.0, 0.0, 0.0, 1.0])  # scanner at the origin
    for s in model.spaces:
        lo, hi = s.bounds
        if np.all(origin[:2] >= lo[:2]) and np.all(origin[:2] <= hi[:2]):
            return s
    return None


def test_scanned_room_is_one_interior_space(scan):
    name, cloud, model = scan
    room = _room_at_scanner(model)
    assert room is not None, [s.bounds for s in model.spaces]
    lo, hi = room.bounds
    # floor and ceiling: the desk plane (z ≈ −0.15 m) is neither a floor nor a storey
    assert len(model.storeys) == 1
    assert -1.32 <= lo[2] <= -1.22 and 1.60 <= hi[2] <= 1.70, (lo[2], hi[2])
    assert hi[2] - lo[2] == pytest.approx(2.92, abs=0.05)
    zc = sorted({round(float(z), 3) for s in model.shapes if s.grid is not None for z in s.bounds[:, 2]})
    assert len(zc) == 2  # one band of cuboids: no cut at the desk
    # the room's short side: 4.55 m wall to wall in both scans (y from −1.5 to 3.1 m in scan 1)
    size = hi[:2] - lo[:2]
    assert min(size) == pytest.approx(4.55, abs=0.1), size
    assert room.type == ShapeType.INTERIOR and len(model.of_type("interior", active=None)) >= 1


def test_room_faces_lie_on_the_wall_points(scan):
    name, cloud, model = scan
    room = _room_at_scanner(model)
    pts = model.to_input_frame(cloud.xyz) if False else (cloud.xyz - model.transform[:3, 3]) @ model.transform[:3, :3]
    checked = 0
    for srf in model.surfaces():
        if srf.shape_id != room.id or srf.kind != "wall":
            continue
        a = int(np.argmax(np.abs(srf.normal)))
        lo, hi = srf.polygon.min(axis=0), srf.polygon.max(axis=0)
        o = 1 - a
        near = (np.abs(pts[:, a] - lo[a]) <= 0.3) & (pts[:, o] >= lo[o]) & (pts[:, o] <= hi[o]) \
            & (pts[:, 2] >= lo[2]) & (pts[:, 2] <= hi[2])
        if near.sum() < 500:  # a face with no wall behind it (the opening side)
            continue
        # the wall points are the densest layer near the face
        d = pts[near, a] - lo[a]
        h, e = np.histogram(d, bins=np.arange(-0.3, 0.31, 0.02))
        wall_layer = (e[np.argmax(h)] + e[np.argmax(h) + 1]) / 2
        assert abs(wall_layer) <= 0.10, (name, srf.face, wall_layer, lo, hi, h.tolist())
        checked += 1
    assert checked >= 3


def test_beyond_the_opening_is_reported(scan):
    name, cloud, model = scan
    room = _room_at_scanner(model)
    # every placed cuboid outside the room is typed (exterior here: only partly seen)
    others = [s for s in model.shapes if s.grid is not None and s.parent != room.id]
    assert all(s.type in (ShapeType.EXTERIOR, ShapeType.WALL, ShapeType.INTERIOR) for s in others)
    assert all(any(line.startswith("classify:") for line in s.log) for s in others)


@pytest.fixture(scope="module")
def both_rooms():
    out = {}
    for name in ("room_scan1.pcd", "room_scan2.pcd"):
        out[name] = _room_at_scanner(_reconstruct(name)[1])
    return out


def test_both_scans_give_the_same_room(both_rooms):
    # The scans are unregistered (scan 2 is turned about 40° and taken ~2 m further along
    # the room), so the rooms are compared by size. Both see the same 10.7 m × 4.55 m room:
    # scan 2 sees both end walls (x −4.57 and +6.11); in scan 1 the far end wall (x ≈ 8.1)
    # is seen only in patches behind furniture and the far ceiling reads ~9 cm low.
    sizes = {}
    for name, room in both_rooms.items():
        assert room is not None and room.type == ShapeType.INTERIOR, name
        lo, hi = room.bounds
        sizes[name] = np.array([*sorted(hi[:2] - lo[:2]), hi[2] - lo[2]])
    s1, s2 = sizes["room_scan1.pcd"], sizes["room_scan2.pcd"]
    assert np.all(np.abs(s1 - s2) <= 0.25), (s1, s2)
    assert s1[1] == pytest.approx(10.7, abs=0.25) and s1[0] == pytest.approx(4.55, abs=0.1), s1
