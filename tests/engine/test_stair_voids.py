"""A stair hall open to the storey above is a room of the storey below (engine.grammar.manhattan,
issue 19: stairs and voids).

The Duplex, mobile scans, level 1: each flat's stair hall is 1 m wide, its ceiling 5.7 m up
(over the upper flight, 3.1 m above level 1's top at 2.6 m); the walk passes its door and never
enters it. Its cuboids see their floor but no ceiling at 2.6 m, and another room's wall line
cuts a 12 cm strip across it. Built here as that row of cuboids: x 0.42–1.42 the hall
(exterior so far), x 1.42–2.47 the foyer beside it (interior), one z layer 0–2.6 m."""
import numpy as np
import pytest

from engine.grammar.geometry import box_of
from engine.grammar.manhattan import _open_voids
from engine.grammar.params import ManhattanParams
from engine.grammar.place import StoreyFrame
from engine.model import Shape, ShapeType

X = np.array([0.42, 1.42, 2.47])
Y = np.array([-9.73, -8.08, -7.55, -7.43, -6.78])
I, E = ShapeType.INTERIOR, ShapeType.EXTERIOR
# the hall's cuboids as the Duplex's mobile seed 4 measured them: faces -y, +x, +y, -x
HALL = {0: (E, None, 0.47, (0.87, 0.11, 0.0, 0.76)),
        1: (E, None, 0.97, (0.0, 0.56, 0.13, 0.75)),
        2: (E, 1, 1.0, (0.13, 0.43, 0.13, 0.26)),  # the strip another room's wall line cut
        3: (I, None, 0.84, (0.13, 0.7, 0.03, 0.88))}


def _row():
    shapes, types = {}, np.empty((2, 4, 1), dtype=object)
    for j in range(4):
        for i in range(2):
            t, thin, bottom, faces = HALL[j] if i == 0 else (I, None, 0.9, (0.0, 0.0, 0.0, 0.0))
            sup = {f"ipof_f{q + 2}": v for q, v in enumerate(faces)}
            sup.update(ipof_f0=bottom, ipof_f1=0.0 if i == 0 else 0.9, ipof_bottom=bottom,
                       ipof_top=0.0 if i == 0 else 0.9)
            shapes[i, j, 0] = Shape(id=f"c{i}{j}", type=t, grid=(i, j, 0), support=sup,
                                    geometry=box_of((X[i], Y[j], 0.0), (X[i + 1], Y[j + 1], 2.6)),
                                    attributes={"thin_axis": thin})
            types[i, j, 0] = t
    return shapes, types


def _grid(x0, x1, y0, y1, z, step=0.05):
    u, v = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step), indexing="ij")
    return np.column_stack([u.ravel(), v.ravel(), np.full(u.size, z)])


@pytest.mark.parametrize("floor_above", [False, True])
def test_a_stair_hall_whose_ceiling_is_a_storey_up_is_a_room(floor_above):
    """Its ceiling, a storey's height above level 1's top, is what shows the column open (the
    upper flight's treads and the shaft's walls cover little of its footprint); up to 3 m
    above the top it was not looked at, and the strip across the hall (its faces on the hall's
    walls 12 cm wide, 0.13–0.26 seen) was never a candidate. With a floor above it, it stays
    outside."""
    pts = [_grid(0.42, 1.42, -9.73, -6.78, 5.7),  # the hall's ceiling
           _grid(1.42, 2.47, -9.73, -6.78, 3.12)]  # the upper storey's floor beside it
    if floor_above:
        pts.append(_grid(0.42, 1.42, -9.73, -6.78, 3.12))
    xyz = np.vstack(pts) + np.random.default_rng(0).normal(0, 0.005, (sum(len(p) for p in pts), 3))
    normals = np.tile([0.0, 0.0, 1.0], (len(xyz), 1))
    shapes, types = _row()
    _open_voids(shapes, types, xyz, normals, StoreyFrame(floor=0.0, ceilings=(2.6,)),
                ManhattanParams(shape_buffer=0.05))
    hall = [types[0, j, 0] for j in range(3)]
    if floor_above:
        assert hall == [E, E, E]
    else:
        assert hall == [I, I, I]
        assert all(shapes[0, j, 0].attributes["ceiling_seen"] is False for j in range(3))
    assert types[0, 3, 0] == I and all(types[1, j, 0] == I for j in range(4))


def test_a_thin_strip_whose_neighbours_do_not_see_the_wall_stays_open():
    """The short side of the strip counts as seen only where both cuboids beside it see that
    wall: with the west wall unseen in the room beyond the strip, the hall leads outside."""
    pts = [_grid(0.42, 1.42, -9.73, -6.78, 5.7), _grid(1.42, 2.47, -9.73, -6.78, 3.12)]
    xyz = np.vstack(pts)
    shapes, types = _row()
    s = shapes[0, 3, 0]
    shapes[0, 3, 0] = s.with_(support={**s.support, "ipof_f5": 0.1})
    _open_voids(shapes, types, xyz, np.tile([0.0, 0.0, 1.0], (len(xyz), 1)),
                StoreyFrame(floor=0.0, ceilings=(2.6,)), ManhattanParams(shape_buffer=0.05))
    assert [types[0, j, 0] for j in range(3)] == [E, E, E]
