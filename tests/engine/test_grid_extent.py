"""Where a storey's Manhattan grid ends (engine.grammar.extent, issue 19: glazing).

A room 6 m x 4.88 m, 2.6 m high (floor, ceiling and the four walls' inner faces sampled at
5 cm, 5 mm noise, seed 0). Its south wall (inner face y = 0.12, 0.42 m thick) holds a glazed
opening 4 m wide from a 0.1 m sill to a 2.52 m head: through it the head and the sill, 0.42
m deep, are seen as horizontal surfaces beyond the inner face."""
import numpy as np
import pytest

from engine.grammar.extent import seen_extent
from engine.grammar.manhattan import place_storey
from engine.grammar.params import ManhattanParams
from engine.grammar.place import StoreyFrame
from engine.model import ShapeType

STEP, H, Y0, DEPTH = 0.05, 2.6, 0.12, 0.42


def _sheet(axis, at, u, v):
    """Points of the plane ``axis`` = ``at`` over the ranges ``u``, ``v`` of the other two
    axes (in x, y, z order), and their normals."""
    a, b = np.meshgrid(np.arange(*u, STEP), np.arange(*v, STEP), indexing="ij")
    other = [k for k in range(3) if k != axis]
    xyz = np.empty((a.size, 3))
    xyz[:, axis], xyz[:, other[0]], xyz[:, other[1]] = at, a.ravel(), b.ravel()
    n = np.zeros_like(xyz)
    n[:, axis] = 1.0
    return xyz, n


def _room(depth):
    parts = [_sheet(2, 0.0, (0, 6), (Y0, 5)), _sheet(2, H, (0, 6), (Y0, 5)),
             _sheet(0, 0.0, (Y0, 5), (0, H)), _sheet(0, 6.0, (Y0, 5), (0, H)), _sheet(1, 5.0, (0, 6), (0, H)),
             _sheet(1, Y0, (0, 1), (0, H)), _sheet(1, Y0, (5, 6), (0, H)),  # the wall beside the opening
             _sheet(1, Y0, (1, 5), (0, 0.1)), _sheet(1, Y0, (1, 5), (2.52, H)),  # under the sill, over the head
             _sheet(2, 2.52, (1, 5), (Y0 - depth, Y0)), _sheet(2, 0.1, (1, 5), (Y0 - depth, Y0))]  # head, sill
    xyz = np.vstack([p[0] for p in parts])
    n = np.vstack([p[1] for p in parts])
    return xyz + np.random.default_rng(0).normal(0, 0.005, xyz.shape), n


def test_seen_extent_gives_the_cells_and_how_far_the_points_reach():
    xy = np.array([[0.03, 0.1], [0.3, 0.3], [0.6, 0.45], [0.9, 0.6], [0.12, 0.4], [0.2, 0.7],
                   [5.0, 5.0]])  # the last one: a stray patch
    lo, hi, plo, phi = seen_extent(xy, 0.25)
    assert np.allclose(lo, [0.0, 0.0]) and np.allclose(hi, [1.0, 0.75])
    assert np.allclose(plo, [0.03, 0.1]) and np.allclose(phi, [0.9, 0.7])


@pytest.mark.parametrize("depth", [DEPTH, 0.3])
def test_the_head_of_a_glazed_opening_is_no_room_beyond_the_wall(depth):
    """The Duplex, mobile, level 1: the living room's 4.8 m glazed wall (0.42 m thick), the
    head and sill of its opening seen beyond the inner face, reached to y −17.80; the
    ceiling's cells (0.25 m) took it to −18.0, more than a wall's thickness (0.5 m) beyond
    the inner face (−17.38), so a 0.62 m strip beyond the glazing was part of the room, its
    exterior wall 0.6 m out and the window not found. How far the ceiling was seen is how
    far its points reach: the head is within a wall's thickness, the grid ends at the wall."""
    xyz, n = _room(depth)
    params = ManhattanParams(shape_buffer=0.05, spacing=STEP, noise=0.005, bin_size=0.02)
    shapes = place_storey(xyz, n, StoreyFrame(floor=0.0, ceilings=(H,)), 0, params, STEP)
    lows = sorted({round(float(s.bounds[0][1]), 2) for s in shapes})
    assert lows[0] >= Y0 - 0.05, lows  # no cuboid beyond the glazing's inner face
    rooms = [s for s in shapes if s.type == ShapeType.INTERIOR]
    assert rooms and min(float(s.bounds[0][1]) for s in rooms) >= Y0 - 0.05
    assert max(float(s.bounds[1][1]) for s in rooms) >= 4.9
