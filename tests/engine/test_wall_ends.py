"""Free ends of walls cut the Manhattan grid (engine.grammar.ends, issue 19: open plans).

A storey 10 m x 8 m, 2.6 m high, sampled at 5 cm with 5 mm noise (seed 0): floor and
ceiling everywhere unless a case removes them, a partition in the plane x = 5 along y."""
import numpy as np
import pytest

from engine.grammar.ends import UpperBand, free_wall_ends
from engine.grammar.params import ManhattanParams
from engine.grammar.place import StoreyFrame

FRAME = StoreyFrame(floor=0.0, ceilings=(2.6,))
STEP = 0.05


def _grid(u0, u1, v0, v1):
    u, v = np.meshgrid(np.arange(u0, u1, STEP), np.arange(v0, v1, STEP), indexing="ij")
    return u.ravel(), v.ravel()


def _storey(wall_spans, floor_holes=(), ceiling_holes=(), seed=0, sparse_top=None, cross_y=(), end_faces=()):
    """Points and normal masks: floor z=0, ceiling z=2.6 over 0..10 x 0..8 minus the holes
    ((x0, x1, y0, y1) boxes), the partition's two faces x = 4.95 and 5.05 over ``wall_spans``
    ((y0, y1) along y, full height)."""
    rng = np.random.default_rng(seed)
    parts, kinds = [], []
    for z, holes in ((0.0, floor_holes), (2.6, ceiling_holes)):
        x, y = _grid(0, 10, 0, 8)
        keep = np.ones(len(x), bool)
        for x0, x1, y0, y1 in holes:
            keep &= ~((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1))
        parts.append(np.column_stack([x[keep], y[keep], np.full(keep.sum(), z)]))
        kinds.append(np.full(keep.sum(), 2))
    for y0, y1 in wall_spans:
        for xf in (4.95, 5.05):
            y, z = _grid(y0, y1, 0.0, 2.6)
            parts.append(np.column_stack([np.full(len(y), xf), y, z]))
            kinds.append(np.zeros(len(y), int))
    for yf in end_faces:  # the partition's end face, 10 cm wide, facing y
        x, z = _grid(4.95, 5.05, 0.0, 2.6)
        parts.append(np.column_stack([x, np.full(len(x), yf), z]))
        kinds.append(np.ones(len(x), int))
    for yf in cross_y:  # a wall facing y across the whole storey (a corridor's side)
        x, z = _grid(0.0, 10.0, 0.0, 2.6)
        parts.append(np.column_stack([x, np.full(len(x), yf), z]))
        kinds.append(np.ones(len(x), int))
    p = np.vstack(parts)
    p += rng.normal(0, 0.005, p.shape)
    kind = np.concatenate(kinds)
    if sparse_top is not None:  # a wall seen sparsely along (y0, y1): one point in 60 kept
        y0, y1 = sparse_top
        drop = (kind == 0) & (p[:, 1] > y0) & (p[:, 1] < y1) & (rng.random(len(p)) > 1 / 60)
        p, kind = p[~drop], kind[~drop]
    along = [kind == 0, kind == 1, kind == 2]
    ceiling = p[(kind == 2) & (p[:, 2] > 1.3)][:, :2]
    return p, along, ceiling


def _ends(wall_spans, cuts_y=(0.0, 8.0), **kw):
    p, along, ceiling = _storey(wall_spans, **kw)
    cuts = [np.array([0.0, 4.95, 5.05, 10.0]), np.array(cuts_y)]
    params = ManhattanParams(shape_buffer=0.05, spacing=STEP, noise=0.005, bin_size=0.02)
    return free_wall_ends(p, along, ceiling, cuts, FRAME, params, UpperBand(p, along, FRAME, params, STEP))


def test_a_partition_stopping_in_an_open_plan_cuts_at_its_end():
    # its own end face (seen on mobile scans) is no wall across the line
    x, y = (e[:, 0] for e in _ends([(0.0, 4.0)], end_faces=(4.0,)))
    assert len(x) == 0
    assert len(y) == 1 and abs(y[0] - 4.0) <= 0.05, y  # one cut where the partition ends


def test_an_opening_between_two_wall_pieces_cuts_at_both_ends():
    y = _ends([(0.0, 3.0), (6.0, 8.0)])[1][:, 0]
    assert sorted(np.round(y, 1).tolist()) == [3.0, 6.0]


@pytest.mark.parametrize("case", ["door", "no floor", "stair void", "unscanned beyond", "cut there",
                                  "sparse wall", "wall across"])
def test_no_cut_without_an_open_plan_past_the_end(case):
    kw = {}
    spans = [(0.0, 4.0)]
    if case == "door":  # a 1 m gap is a door, not an open plan (min_passage_width 2 m)
        spans = [(0.0, 3.5), (4.5, 8.0)]
    elif case == "no floor":  # the stretch past the end is no room (outside, a void)
        kw["floor_holes"] = [(0, 10, 4.2, 8)]
    elif case == "stair void":  # no ceiling on one side past the end: a stair's opening
        kw["ceiling_holes"] = [(5.05, 7, 4.0, 6.0)]
    elif case == "unscanned beyond":  # floor seen, ceiling nowhere near the line past the end
        kw["ceiling_holes"] = [(4.0, 6.0, 4.0, 8.0)]
    elif case == "cut there":  # a cross wall's cut already within half a wall thickness
        kw["cuts_y"] = (0.0, 4.1, 8.0)
    elif case == "sparse wall":  # a wall seen at a point per 1.5 dm² over 4 m: still a wall
        spans, kw["sparse_top"] = [(0.0, 8.0)], (4.0, 8.0)
    elif case == "wall across":  # a corridor's side 30 cm past the end, its cut not listed: the
        # partition's last 30 cm had no normals along x by the corner (two_storey_office TLS 7)
        kw["cross_y"] = (4.3,)
    _, y = _ends(spans, **kw)
    assert len(y) == 0, (case, y)


def test_cuboids_split_by_a_cut_away_from_its_wall_are_typed_as_one():
    """A room's cuboid split by a free end's cut: the smaller half, its floor hidden by a sofa,
    alone would be an eave (exterior); typed with the other half it stays interior. The wall's
    own line keeps its types."""
    from engine.grammar.ends import heal_split_cells
    from engine.grammar.geometry import box_of
    from engine.model import Shape, ShapeType

    X, Y = np.array([0.0, 4.95, 5.05, 10.0]), np.array([0.0, 1.5, 6.0])
    I, E, W = ShapeType.INTERIOR, ShapeType.EXTERIOR, ShapeType.WALL
    sup = {(0, 0): dict(ipof_f0=0.05, ipof_f1=0.42, ipof_f5=0.8),
           (0, 1): dict(ipof_f0=0.9, ipof_f1=0.9, ipof_f5=0.8),
           (1, 0): dict(ipof_f3=0.9, ipof_f5=0.9), (1, 1): dict(ipof_f1=0.8, ipof_f0=0.9),
           (2, 0): dict(ipof_f0=0.9, ipof_f1=0.9), (2, 1): dict(ipof_f0=0.9, ipof_f1=0.9)}
    kinds = {(0, 0): E, (0, 1): I, (1, 0): W, (1, 1): I, (2, 0): I, (2, 1): I}
    shapes, types = {}, np.empty((3, 2, 1), dtype=object)
    for (i, j), t in kinds.items():
        full = {f"ipof_f{q}": 0.0 for q in range(6)}
        full.update(sup[i, j])
        full.update(ipof_top=full["ipof_f1"], ipof_bottom=full["ipof_f0"])
        box = box_of((X[i], Y[j], 0), (X[i + 1], Y[j + 1], 2.6))
        shapes[i, j, 0] = Shape(id=f"c{i}{j}", type=t, geometry=box, grid=(i, j, 0), support=full,
                                attributes={"thin_axis": 0 if i == 1 else None})
        types[i, j, 0] = t
    ends = [np.zeros((0, 3)), np.array([[1.5, 4.95, 5.05]])]  # the wall in x 4.95..5.05 ends at y 1.5
    params = ManhattanParams(shape_buffer=0.05, spacing=STEP, noise=0.005, bin_size=0.02)
    heal_split_cells(shapes, types, ends, X, Y, params)
    assert types[0, 0, 0] == I and types[0, 1, 0] == I and shapes[0, 0, 0].type == I  # healed
    assert types[1, 0, 0] == W and types[1, 1, 0] == I  # the wall's line keeps its own types
    assert "free wall end" in shapes[0, 0, 0].log[-1]
