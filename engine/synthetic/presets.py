"""Preset synthetic buildings with their simulated scans and true models.

Each preset is a floor plan (furnished with seeded clutter), scanned with the terrestrial
(σ = 5 mm) or the mobile (σ = 2 cm) simulator, plus its true :class:`BuildingModel` and,
for some, model variants:

* ``office_mw`` — seven rooms on a long corridor (Manhattan); 15 windows, an entrance
  door at the corridor's west end, the door between Room 1 and Room 2 closed;
* ``two_storey_office`` — two storeys of offices on a corridor; 22 windows, an entrance
  door at the ground-floor corridor's west end;
* ``house_multi_height`` — four rooms with different ceiling heights; 8 windows and an
  entrance door;
* ``three_storey_house`` — three storeys (2.7, 2.6 and 2.4 m high, 0.3 m slabs) of different
  layouts over one footprint: 10 rooms, 9 doors (one to the outside), 11 windows;
* ``unscanned_room`` — a corridor with four rooms, one never scanned (its door closed);
* ``syn_house`` — non-Manhattan: a common room, three private rooms and an open space;
  9 windows (one in the slanted outer wall) and an entrance door;
* ``hexagon_hall`` — a hexagonal hall with four small side rooms;
* ``eval_demo`` — docs/method.md §4: a 6 m × 9 m × 2.5 m room plus a 1.8 m wide corridor;
  variants ``inacc`` (outer walls 5 cm outwards), ``incomp`` (the corridor missing),
  ``incorr`` (an extra 4 m × 6 m room);
* ``change_demo`` — docs/method.md §5: ``truth`` is the old model, the cloud scans the changed
  building (two new walls around a storage room, one wall removed between two offices);
  ``cloud.fields["new"]`` is 1 on the new walls; ``variants["changed"]`` is the changed
  building's truth; the removed wall has ``attributes["removed_in_scan"] = True``;
* ``change_office`` — docs/method.md §5, like ``change_demo`` on an office of eight rooms on a
  corridor: the partition between Room 5 and Room 6 removed (one office), two new walls with a
  door each splitting Room 2 and Room 7 (one office becomes two, twice); windows.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Optional, Union

import numpy as np
from shapely.geometry import Polygon
from shapely.ops import unary_union

from ..errors import InputError
from ..model import BuildingModel
from ..pointcloud import PointCloud
from ..progress import Progress
from .furnish import FurnishParams, furnish
from .plan import (
    _MITRE,
    Door,
    FloorPlan,
    PlanStorey,
    Room,
    Window,
    build_truth,
    plan_geometry,
    rooms_from_partition,
)
from .scan import ScanParams, simulate_scan

__all__ = ["SyntheticScene", "PRESETS", "NOISE_SIGMA", "DEFAULT_POINTS", "preset", "preset_plans",
           "scene_from_plans", "scan_params_for"]

NOISE_SIGMA = {"tls": 0.005, "mobile": 0.02}
"""Range noise σ of the two scanner kinds, metres."""
MOBILE_MAX_RANGE = 20.0
"""Maximum range of the mobile scanner, metres."""
DEFAULT_POINTS = 1_000_000
"""Default number of points of a preset scan."""
MAX_POINTS = 100_000_000
"""Larger point counts are refused (memory: about 100 bytes per point while simulating)."""


@dataclass(frozen=True, eq=False)
class SyntheticScene:
    """A synthetic building: its scan, its true model and the plan behind both.

    Attributes
    ----------
    name : str
        Preset name.
    seed : int
    noise_sigma : float
        Range noise σ of the scan, metres.
    cloud : PointCloud
        The simulated scan; ``fields["label"]`` int32 per point (LABEL_WALL 0,
        LABEL_FLOOR 1, LABEL_CEILING 2, LABEL_CLUTTER 3, LABEL_OUTSIDE 4, LABEL_GLASS 5,
        LABEL_DOOR 6); change_demo adds ``fields["new"]``.
    truth : BuildingModel
        The true model (for change_demo: the old building).
    plan : FloorPlan
        The furnished floor plan that was scanned.
    variants : dict of str -> BuildingModel
    scan_params : ScanParams
    timings : dict of str -> float
        Seconds spent on the plan, the truth and the scan.
    """

    name: str
    seed: int
    noise_sigma: float
    cloud: PointCloud
    truth: BuildingModel
    plan: FloorPlan
    variants: Mapping[str, BuildingModel] = field(default_factory=dict)
    scan_params: Optional[ScanParams] = None
    timings: Mapping[str, float] = field(default_factory=dict)


# ----------------------------------------------------------------------------- plans
def _rect(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _side(rooms, name: str, direction) -> int:
    """Index of the edge of room ``name`` whose outward normal points most along
    ``direction`` (a compass vector (dx, dy))."""
    room = next(r for r in rooms if r.name == name)
    pts = np.asarray(room.polygon, dtype=np.float64)
    nxt = np.roll(pts, -1, axis=0)
    ccw = float(np.sum(pts[:, 0] * nxt[:, 1] - nxt[:, 0] * pts[:, 1])) > 0
    e = nxt - pts
    n = np.column_stack([e[:, 1], -e[:, 0]]) * (1.0 if ccw else -1.0)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return int(np.argmax(n @ (np.asarray(direction, float) / np.linalg.norm(direction))))


_N, _S, _E, _W = (0, 1), (0, -1), (1, 0), (-1, 0)


def _windows(rooms, specs) -> list:
    """Windows from (room, compass direction, position, width, height, sill) tuples."""
    return [Window(name, pos, w, h, sill, _side(rooms, name, dirn)) for name, dirn, pos, w, h, sill in specs]


def _entrance(rooms, name, direction, position=0.5, width=1.0, height=2.1, open=True) -> Door:
    """An exterior door of room ``name`` in its wall facing ``direction``."""
    return Door((name,), position, width, height, open, _side(rooms, name, direction))


def _office_mw():
    t = 0.15
    cells = [("Corridor", _rect(0, 0, 18, 2), {"furnished": False})]
    for k in range(4):
        cells.append((f"Room {k + 1}", _rect(4.5 * k, 2, 4.5 * (k + 1), 7)))
    for k in range(3):
        cells.append((f"Room {k + 5}", _rect(6 * k, -5.5, 6 * (k + 1), 0)))
    rooms = rooms_from_partition(cells, t)
    pos = [0.3, 0.5, 0.7, 0.4, 0.6, 0.3, 0.8]
    doors = [Door((f"Room {k + 1}", "Corridor"), pos[k]) for k in range(7)]
    doors.append(Door(("Room 1", "Room 2"), 0.7, open=False))
    doors.append(_entrance(rooms, "Corridor", _W, 0.5, width=1.2))
    specs = [(f"Room {k + 1}", _N, 0.5, 1.5, 1.4, 0.9) for k in range(4)]
    specs += [("Room 1", _W, 0.5, 1.2, 1.4, 0.9), ("Room 4", _E, 0.5, 1.2, 1.4, 0.9)]
    specs += [(f"Room {k + 5}", _S, p, 1.2, 1.4, 0.9) for k in range(3) for p in (0.25, 0.75)]
    specs += [("Room 5", _W, 0.5, 1.2, 1.4, 0.9), ("Room 7", _E, 0.5, 1.2, 1.4, 0.9),
              ("Corridor", _E, 0.5, 1.0, 1.2, 1.0)]
    return FloorPlan("office_mw", (PlanStorey(0.0, 3.0, "Ground floor"),), tuple(rooms), tuple(doors),
                     interior_thickness=t, exterior_thickness=0.3, windows=tuple(_windows(rooms, specs)))


def _two_storey_office():
    t = 0.2
    rooms, doors = [], []
    splits = {0: ([0, 5, 10, 14], [0, 4.5, 9.5, 14]), 1: ([0, 4, 9, 14], [0, 5, 10, 14])}
    for s, (north, south) in splits.items():
        cells = [(f"Corridor {s}", _rect(0, 0, 14, 2), {"furnished": False, "storey": s})]
        names = []
        for k in range(3):
            cells.append((f"Room {s}.{k + 1}", _rect(north[k], 2, north[k + 1], 7), {"storey": s}))
            cells.append((f"Room {s}.{k + 4}", _rect(south[k], -5, south[k + 1], 0), {"storey": s}))
            names += [f"Room {s}.{k + 1}", f"Room {s}.{k + 4}"]
        rooms += rooms_from_partition(cells, t)
        doors += [Door((n, f"Corridor {s}"), 0.25 + 0.5 * (i % 2)) for i, n in enumerate(names)]
    specs = []
    for s in (0, 1):
        specs += [(f"Room {s}.{k}", _N, 0.5, 1.5, 1.4, 0.9) for k in (1, 2, 3)]
        specs += [(f"Room {s}.{k}", _S, 0.5, 1.5, 1.4, 0.9) for k in (4, 5, 6)]
        specs += [(f"Room {s}.{k}", _W, 0.5, 1.0, 1.4, 0.9) for k in (1, 4)]
        specs += [(f"Room {s}.{k}", _E, 0.5, 1.0, 1.4, 0.9) for k in (3, 6)]
    specs += [("Corridor 0", _E, 0.5, 1.0, 1.2, 1.0), ("Corridor 1", _E, 0.5, 1.0, 1.2, 1.0)]
    doors.append(_entrance(rooms, "Corridor 0", _W, 0.5, width=1.2))
    storeys = (PlanStorey(0.0, 2.8, "Ground floor"), PlanStorey(3.1, 2.8, "First floor"))
    return FloorPlan("two_storey_office", storeys, tuple(rooms), tuple(doors), interior_thickness=t,
                     exterior_thickness=0.3, slab_thickness=0.3, windows=tuple(_windows(rooms, specs)))


def _three_storey_house():
    """A house of three storeys of different heights and layouts over one 10 m x 8 m
    footprint: a hall, a living room and a kitchen; a landing, two bedrooms and a bathroom;
    a landing, a study and a room under the roof."""
    t = 0.15
    layout = {0: [("Hall", _rect(0, 0, 3, 8), {"furnished": False}), ("Living", _rect(3, 0, 10, 5)),
                  ("Kitchen", _rect(3, 5, 10, 8))],
              1: [("Landing 1", _rect(0, 0, 3, 8), {"furnished": False}), ("Bedroom 1", _rect(3, 0, 10, 4)),
                  ("Bedroom 2", _rect(3, 4, 7, 8)), ("Bath", _rect(7, 4, 10, 8))],
              2: [("Landing 2", _rect(0, 0, 3, 4), {"furnished": False}), ("Study", _rect(0, 4, 3, 8)),
                  ("Top room", _rect(3, 0, 10, 8))]}
    rooms, doors = [], []
    for s, cells in layout.items():
        rooms += rooms_from_partition([(n, poly, {**(kw[0] if kw else {}), "storey": s})
                                       for n, poly, *kw in cells], t)
    doors += [Door(("Living", "Hall"), 0.5), Door(("Kitchen", "Hall"), 0.5), Door(("Living", "Kitchen"), 0.3),
              Door(("Bedroom 1", "Landing 1"), 0.5), Door(("Bedroom 2", "Landing 1"), 0.5),
              Door(("Bath", "Bedroom 2"), 0.5), Door(("Study", "Landing 2"), 0.5),
              Door(("Top room", "Landing 2"), 0.5)]
    doors.append(_entrance(rooms, "Hall", _W, 0.5, width=1.0))
    specs = [("Living", _S, 0.5, 2.0, 1.4, 0.8), ("Living", _E, 0.5, 1.5, 1.4, 0.8),
             ("Kitchen", _N, 0.6, 1.2, 1.1, 1.1),
             ("Hall", _N, 0.5, 0.8, 1.0, 1.2), ("Bedroom 1", _S, 0.5, 1.5, 1.3, 0.9),
             ("Bedroom 1", _E, 0.5, 1.2, 1.3, 0.9), ("Bedroom 2", _N, 0.5, 1.2, 1.3, 0.9),
             ("Bath", _E, 0.5, 0.6, 0.8, 1.5), ("Study", _W, 0.5, 1.0, 1.2, 0.9),
             ("Top room", _S, 0.3, 1.2, 1.0, 0.9), ("Top room", _E, 0.5, 1.2, 1.0, 0.9)]
    storeys = (PlanStorey(0.0, 2.7, "Ground floor"), PlanStorey(3.0, 2.6, "First floor"),
               PlanStorey(5.9, 2.4, "Second floor"))
    return FloorPlan("three_storey_house", storeys, tuple(rooms), tuple(doors), interior_thickness=t,
                     exterior_thickness=0.3, slab_thickness=0.3, windows=tuple(_windows(rooms, specs)))


def _house_multi_height():
    t = 0.12
    cells = [
        ("Living room", _rect(0, 0, 5, 4), {"ceiling_height": 2.8}),
        ("Kitchen", _rect(5, 0, 9, 4), {"ceiling_height": 2.4}),
        ("Bedroom", _rect(0, 4, 5, 9), {"ceiling_height": 2.6}),
        ("Studio", _rect(5, 4, 9, 9), {"ceiling_height": 3.2}),
    ]
    rooms = rooms_from_partition(cells, t)
    doors = [Door(("Living room", "Kitchen"), 0.5), Door(("Living room", "Bedroom"), 0.7),
             Door(("Studio", "Kitchen"), 0.4), _entrance(rooms, "Living room", _S, 0.2)]
    specs = [("Living room", _S, 0.7, 1.8, 1.4, 0.8), ("Living room", _W, 0.5, 1.2, 1.4, 0.9),
             ("Kitchen", _S, 0.5, 1.2, 1.2, 1.0), ("Kitchen", _E, 0.5, 1.0, 1.2, 1.0),
             ("Bedroom", _N, 0.5, 1.5, 1.3, 0.9), ("Bedroom", _W, 0.5, 1.0, 1.3, 0.9),
             ("Studio", _N, 0.5, 2.0, 1.5, 0.8), ("Studio", _E, 0.5, 1.2, 1.5, 0.8)]
    return FloorPlan("house_multi_height", (PlanStorey(0.0, 3.2, "Ground floor"),), tuple(rooms),
                     tuple(doors), interior_thickness=t, exterior_thickness=0.3, windows=tuple(_windows(rooms, specs)))


def _unscanned_room():
    t = 0.15
    cells = [("Corridor", _rect(0, 0, 10, 2), {"furnished": False}),
             ("Room 1", _rect(0, 2, 5, 7)), ("Room 2", _rect(5, 2, 10, 7)),
             ("Room 3", _rect(0, -5, 5, 0), {"scanned": False}), ("Room 4", _rect(5, -5, 10, 0))]
    rooms = rooms_from_partition(cells, t)
    doors = [Door(("Room 1", "Corridor"), 0.5), Door(("Room 2", "Corridor"), 0.4),
             Door(("Room 3", "Corridor"), 0.5, open=False), Door(("Room 4", "Corridor"), 0.6)]
    return FloorPlan("unscanned_room", (PlanStorey(0.0, 2.8, "Ground floor"),), tuple(rooms), tuple(doors),
                     interior_thickness=t, exterior_thickness=0.3)


def _syn_house():
    t = 0.15

    def xs(y):  # the slanted wall between the west and the east part
        return 6.0 + 0.15 * y

    def yd(x):  # the slanted wall between the private rooms
        return 4.0 + (x - 6.6) / 8.4

    cells = [
        ("Common room", [(0, 0), (6, 0), (xs(4), 4), (0, 4)]),
        ("Open space", [(0, 4), (xs(4), 4), (xs(10), 10), (0, 10)], {"ceiling_height": 3.2}),
        ("Private room 1", [(6, 0), (10.5, 0), (10.5, yd(10.5)), (xs(4), 4)]),
        ("Private room 2", [(10.5, 0), (15, 0), (15, 5), (10.5, yd(10.5))]),
        ("Private room 3", [(xs(4), 4), (15, 5), (11, 10), (xs(10), 10)]),
    ]
    rooms = rooms_from_partition(cells, t)
    doors = [Door(("Common room", "Open space"), 0.6), Door(("Common room", "Private room 1"), 0.5),
             Door(("Open space", "Private room 3"), 0.5), Door(("Private room 1", "Private room 2"), 0.4),
             _entrance(rooms, "Common room", _S, 0.25)]
    specs = [("Common room", _S, 0.7, 1.8, 1.4, 0.9), ("Common room", _W, 0.5, 1.2, 1.4, 0.9),
             ("Open space", _W, 0.5, 1.5, 1.5, 0.9), ("Open space", _N, 0.5, 2.0, 1.5, 0.9),
             ("Private room 1", _S, 0.5, 1.2, 1.4, 0.9), ("Private room 2", _S, 0.5, 1.2, 1.4, 0.9),
             ("Private room 2", _E, 0.5, 1.0, 1.4, 0.9), ("Private room 3", (1.0, 0.8), 0.5, 1.5, 1.4, 0.9),
             ("Private room 3", _N, 0.5, 1.0, 1.4, 0.9)]
    return FloorPlan("syn_house", (PlanStorey(0.0, 2.7, "Ground floor"),), tuple(rooms), tuple(doors),
                     interior_thickness=t, exterior_thickness=0.3, windows=tuple(_windows(rooms, specs)))


def _hexagon_hall():
    t = 0.2
    r = 6.0
    hexagon = [(r * math.cos(k * math.pi / 3), r * math.sin(k * math.pi / 3)) for k in range(6)]
    cells = [("Hall", hexagon, {"ceiling_height": 4.0, "furnished": False})]
    doors = []
    width, depth = 4.0, 3.0
    for n, e in enumerate((0, 1, 3, 4)):
        p, q = np.asarray(hexagon[e]), np.asarray(hexagon[(e + 1) % 6])
        d = (q - p) / np.linalg.norm(q - p)
        out = np.array([d[1], -d[0]])  # outward of the CCW hexagon
        a = p + d * (r - width) / 2
        b = a + d * width
        cells.append((f"Side room {n + 1}", [tuple(b), tuple(a), tuple(a + out * depth), tuple(b + out * depth)],
                      {"ceiling_height": 2.6}))
        doors.append(Door(("Hall", f"Side room {n + 1}"), 0.5, width=1.0))
    rooms = rooms_from_partition(cells, t)
    return FloorPlan("hexagon_hall", (PlanStorey(0.0, 4.0, "Ground floor"),), tuple(rooms), tuple(doors),
                     interior_thickness=t, exterior_thickness=0.3)


_EVAL_T = 0.2
"""Interior wall thickness of eval_demo, metres."""


_EVAL_CORRIDOR = 1.8
"""Width of eval_demo's corridor, metres (with the 6 m x 9 m room, the wall areas give
ratios close to the thesis's Fig. 5.10, see :func:`_eval_demo_plan`)."""


def _eval_demo_plan(extra_room=False, without_corridor=False, grow=0.0):
    """The demonstration of docs/method.md §4: Room 1 (6 m x 9 m x 2.5 m) and a 1.8 m x 9 m corridor along
    its long side, one door between them.

    Interior wall-face areas: room 75 m², corridor 54 m², of which 2 x 22.5 m² face each
    other. Moving the outer faces out (``grow`` = 0.05, "inacc") keeps 45/129 = 0.35 of
    the wall area in place (thesis: ≈0.38); leaving out the corridor ("incomp") keeps
    75/129 = 0.58 (thesis: ≈0.62); the extra 4 m x 6 m room ("incorr") adds 50 m², so the
    true share of the source is 129/179 = 0.72 (thesis: ≈0.72).
    """
    t = _EVAL_T
    rooms = [Room("Room 1", _rect(0, 0, 6, 9), furnished=True)]
    doors = []
    if not without_corridor:
        rooms.append(Room("Corridor", _rect(6 + t, 0, 6 + t + _EVAL_CORRIDOR, 9), furnished=False))
        doors.append(Door(("Room 1", "Corridor"), 0.5))
    if extra_room:
        rooms.append(Room("Room 2", _rect(-t - 4, 1.5, -t, 7.5)))
        doors.append(Door(("Room 1", "Room 2"), 0.5))
    if grow:
        rooms = _grow_outer(rooms, grow, t)
    return FloorPlan("eval_demo", (PlanStorey(0.0, 2.5, "Ground floor"),), tuple(rooms), tuple(doors),
                     interior_thickness=t, exterior_thickness=0.3)


def _grow_outer(rooms, d, t):
    """Move every room face that faces the outside ``d`` metres outwards."""
    polys = [r.shape for r in rooms]
    out = []
    for i, r in enumerate(rooms):
        others = [p.buffer(t, **_MITRE) for j, p in enumerate(polys) if j != i]
        grown = polys[i].buffer(d, **_MITRE)
        if others:
            grown = grown.difference(unary_union(others))
        grown = grown.simplify(1e-6)
        out.append(Room(r.name, tuple(grown.exterior.coords), r.storey, r.ceiling_height, r.scanned, r.furnished))
    return out


def _change_demo_plans():
    t = 0.15
    x1 = 0.075 + 0.5 * 3.85  # centre of old Room 1 (clear span 0.075 .. 3.925)
    x2 = 4.075 + 0.5 * 3.85
    old_cells = [("Corridor", _rect(0, 0, 16, 2), {"furnished": False})]
    old_cells += [(f"Room {k + 1}", _rect(4 * k, 2, 4 * (k + 1), 7)) for k in range(4)]
    old = FloorPlan("change_demo", (PlanStorey(0.0, 2.8, "Ground floor"),),
                    tuple(rooms_from_partition(old_cells, t)),
                    tuple(Door((f"Room {k + 1}", "Corridor"), 0.5) for k in range(4)),
                    interior_thickness=t, exterior_thickness=0.3)
    new_cells = [("Corridor", _rect(0, 0, 16, 2), {"furnished": False}),
                 ("Room 1", _rect(0, 2, 8, 7)),
                 ("Room 3", _rect(8, 2, 12, 7)),
                 ("Room 4", [(12, 2), (16, 2), (16, 4.5), (14, 4.5), (14, 7), (12, 7)]),
                 ("Storage", _rect(14, 4.5, 16, 7), {"furnished": False})]
    span = (0.075, 7.925)
    new = FloorPlan("change_demo_changed", old.storeys, tuple(rooms_from_partition(new_cells, t)),
                    (Door(("Room 1", "Corridor"), (x1 - span[0]) / (span[1] - span[0])),
                     Door(("Room 1", "Corridor"), (x2 - span[0]) / (span[1] - span[0])),
                     Door(("Room 3", "Corridor"), 0.5), Door(("Room 4", "Corridor"), 0.5),
                     Door(("Room 4", "Storage"), 0.5)),
                    interior_thickness=t, exterior_thickness=0.3)
    return old, new


def _change_office_plans():
    t, h = 0.15, 0.075

    def frac(x, a, b):  # door centre x on the clear stretch a..b of a cell's side
        return (x - (a + h)) / ((b - h) - (a + h))

    north = [(4.5 * k, 4.5 * (k + 1)) for k in range(4)]
    south = [(6.0 * k, 6.0 * (k + 1)) for k in range(3)]
    old_cells = [("Corridor", _rect(0, 0, 18, 2), {"furnished": False})]
    old_cells += [(f"Room {k + 1}", _rect(a, 2, b, 7)) for k, (a, b) in enumerate(north)]
    old_cells += [(f"Room {k + 5}", _rect(a, -5.5, b, 0)) for k, (a, b) in enumerate(south)]
    old_rooms = rooms_from_partition(old_cells, t)
    nx = [a + 2.25 for a, _ in north]
    sx = [3.0, 9.0, 16.5]
    # north rooms first (their south side runs east), south rooms after the corridor (its south
    # side runs east): the positions are fractions of the room's clear span, from the west
    old_doors = [Door((f"Room {k + 1}", "Corridor"), frac(x, *north[k])) for k, x in enumerate(nx)]
    old_doors += [Door(("Corridor", f"Room {k + 5}"), frac(x, *south[k])) for k, x in enumerate(sx)]
    old_doors.append(_entrance(old_rooms, "Corridor", _W, 0.5, width=1.2))
    wins = [(f"Room {k + 1}", _N, 0.5, 1.5, 1.4, 0.9) for k in range(4)]
    old_wins = wins + [("Room 5", _S, 0.5, 1.2, 1.4, 0.9), ("Room 6", _S, 0.5, 1.2, 1.4, 0.9),
                       ("Room 7", _S, 0.25, 1.2, 1.4, 0.9)]
    old = FloorPlan("change_office", (PlanStorey(0.0, 3.0, "Ground floor"),), tuple(old_rooms), tuple(old_doors),
                    interior_thickness=t, exterior_thickness=0.3, windows=tuple(_windows(old_rooms, old_wins)))
    new_cells = [("Corridor", _rect(0, 0, 18, 2), {"furnished": False}),
                 ("Room 1", _rect(0, 2, 4.5, 7)), ("Room 2", _rect(4.5, 2, 9, 4.5)),
                 ("Room 2b", _rect(4.5, 4.5, 9, 7)), ("Room 3", _rect(9, 2, 13.5, 7)), ("Room 4", _rect(13.5, 2, 18, 7)),
                 ("Room 5", _rect(0, -5.5, 12, 0)), ("Room 7", _rect(12, -5.5, 15, 0)),
                 ("Room 8", _rect(15, -5.5, 18, 0))]
    new_rooms = rooms_from_partition(new_cells, t)
    new_doors = [Door((n, "Corridor"), frac(x, *north[k])) for k, (n, x) in
                 enumerate(zip(("Room 1", "Room 2", "Room 3", "Room 4"), nx))]
    new_doors += [Door(("Corridor", "Room 5"), frac(sx[0], 0, 12)), Door(("Corridor", "Room 5"), frac(sx[1], 0, 12)),
                  Door(("Corridor", "Room 8"), frac(sx[2], 15, 18)),
                  Door(("Room 2", "Room 2b"), 0.5), Door(("Room 7", "Room 8"), 0.5),
                  _entrance(new_rooms, "Corridor", _W, 0.5, width=1.2)]
    new_wins = [("Room 1", _N, 0.5, 1.5, 1.4, 0.9), ("Room 2b", _N, 0.5, 1.5, 1.4, 0.9),
                ("Room 3", _N, 0.5, 1.5, 1.4, 0.9), ("Room 4", _N, 0.5, 1.5, 1.4, 0.9),
                ("Room 5", _S, frac(3.0, 0, 12), 1.2, 1.4, 0.9), ("Room 5", _S, frac(9.0, 0, 12), 1.2, 1.4, 0.9),
                ("Room 7", _S, frac(12 + h + 0.25 * (6 - 2 * h), 12, 15), 1.2, 1.4, 0.9)]
    new = FloorPlan("change_office_changed", old.storeys, tuple(new_rooms), tuple(new_doors),
                    interior_thickness=t, exterior_thickness=0.3, windows=tuple(_windows(new_rooms, new_wins)))
    return old, new


_PLANS: dict[str, Callable[[], FloorPlan]] = {
    "office_mw": _office_mw,
    "two_storey_office": _two_storey_office,
    "house_multi_height": _house_multi_height,
    "three_storey_house": _three_storey_house,
    "unscanned_room": _unscanned_room,
    "syn_house": _syn_house,
    "hexagon_hall": _hexagon_hall,
    "eval_demo": _eval_demo_plan,
    "change_demo": lambda: _change_demo_plans()[0],
    "change_office": lambda: _change_office_plans()[0],
}

PRESETS = tuple(_PLANS)
"""Names of the presets :func:`preset` knows."""


def preset_plans(name: str) -> dict[str, FloorPlan]:
    """The unfurnished floor plans of a preset: ``"truth"``, ``"scanned"`` and variants."""
    if name not in _PLANS:
        raise InputError(f"unknown synthetic preset {name!r}; choose one of {', '.join(PRESETS)}")
    if name == "eval_demo":
        return {"truth": _eval_demo_plan(), "inacc": _eval_demo_plan(grow=0.05),
                "incomp": _eval_demo_plan(without_corridor=True), "incorr": _eval_demo_plan(extra_room=True)}
    if name in ("change_demo", "change_office"):
        old, new = _change_demo_plans() if name == "change_demo" else _change_office_plans()
        return {"truth": old, "changed": new}
    return {"truth": _PLANS[name]()}


def scan_params_for(noise: Union[str, float], target_points: Optional[int]) -> ScanParams:
    """Scanner settings for a noise name ("tls", "mobile") or a σ in metres (terrestrial)."""
    if isinstance(noise, str):
        key = noise.strip().lower()
        if key in NOISE_SIGMA:
            if key == "mobile":
                return ScanParams(mode="mobile", sigma=NOISE_SIGMA[key], max_range=MOBILE_MAX_RANGE,
                                  target_points=target_points)
            return ScanParams(mode="tls", sigma=NOISE_SIGMA[key], target_points=target_points)
        try:
            noise = float(key)
        except ValueError:
            raise InputError(f"noise must be 'tls', 'mobile' or a σ in metres, not {noise!r}") from None
    sigma = float(noise)
    if not math.isfinite(sigma) or sigma < 0 or sigma > 0.5:
        raise InputError(f"noise σ must be between 0 and 0.5 m, not {sigma!r}")
    return ScanParams(mode="tls", sigma=sigma, target_points=target_points)


def _changed_walls(model_a: BuildingModel, model_b: BuildingModel, share: float = 0.5) -> list[str]:
    """Ids of walls of ``model_a`` whose footprint is mostly not covered by ``model_b``'s walls."""
    cover = unary_union([Polygon(w.footprint()) for w in model_b.walls])
    out = []
    for w in model_a.walls:
        fp = Polygon(w.footprint())
        if fp.intersection(cover).area < share * fp.area:
            out.append(w.id)
    return out


def preset(name: str, *, seed: int = 0, noise: Union[str, float] = "tls",
           target_points: Optional[int] = None, scale: float = 1.0, clutter: bool = True,
           furnish_params: FurnishParams = FurnishParams(), surroundings: bool = True,
           positions_per_storey: Optional[int] = None, progress=None, should_stop=None) -> SyntheticScene:
    """Build a preset synthetic scene (plan, true model, variants, simulated scan).

    Parameters
    ----------
    name : str
        One of :data:`PRESETS`.
    seed : int
        Seeds the clutter placement, the scan's azimuth offsets and its noise.
    noise : "tls", "mobile" or float
        Terrestrial scans with σ = 5 mm, a mobile walk with σ = 2 cm, or terrestrial scans
        with the given σ in metres.
    target_points : int, optional
        About how many points the scan has (default ``DEFAULT_POINTS * scale``).
    scale : float
        Multiplies the default point count when ``target_points`` is not given.
    clutter : bool
        Furnish the rooms (shelves, cabinets, tables) or leave them empty.
    furnish_params : FurnishParams
    surroundings : bool
        Ground, trees and a neighbour's facade outside the building, seen through windows
        and open exterior doors (:attr:`ScanParams.surroundings`).
    positions_per_storey : int, optional
        Terrestrial only: at most this many scanner positions per storey, in its biggest
        rooms (:attr:`ScanParams.positions_per_storey`; 1: single-position scans).
    progress, should_stop : callbacks (see :class:`engine.progress.Progress`)

    Returns
    -------
    SyntheticScene

    Raises
    ------
    InputError
        Unknown preset name or bad noise value.
    """
    plans = preset_plans(name)
    return scene_from_plans(plans, name=name, seed=seed, noise=noise, target_points=target_points,
                            scale=scale, clutter=clutter, furnish_params=furnish_params,
                            surroundings=surroundings, scanned="changed" if name in ("change_demo", "change_office") else "truth",
                            positions_per_storey=positions_per_storey, progress=progress, should_stop=should_stop)


def scene_from_plans(plans: Mapping[str, FloorPlan], *, name: Optional[str] = None, seed: int = 0,
                     noise: Union[str, float] = "tls", target_points: Optional[int] = None,
                     scale: float = 1.0, clutter: bool = True,
                     furnish_params: FurnishParams = FurnishParams(), scanned: str = "truth",
                     surroundings: bool = True, positions_per_storey: Optional[int] = None, progress=None,
                     should_stop=None) -> SyntheticScene:
    """A synthetic scene from floor plans: ``plans["truth"]`` is the true building, the
    other entries are variants; ``plans[scanned]`` is the building that is scanned.

    When the scanned plan is not the truth (change detection), the cloud gets
    ``fields["new"]`` (1 on walls of the scanned building that the truth lacks), the
    truth's walls that the scanned building lacks (and their doors) get
    ``attributes["removed_in_scan"] = True`` and the scanned variant's new walls
    ``attributes["new_in_scan"] = True``. Plans that already hold clutter are not
    furnished again. Other parameters as in :func:`preset`.
    """
    prog = Progress.wrap(progress, should_stop)
    if "truth" not in plans or scanned not in plans:
        raise InputError(f"plans must hold 'truth' and the scanned plan {scanned!r}")
    name = name or plans["truth"].name
    target = int(target_points) if target_points is not None else int(round(DEFAULT_POINTS * scale))
    if not 0 < target <= MAX_POINTS:
        raise InputError(f"target_points must be between 1 and {MAX_POINTS:,}, not {target:,}")
    params = replace(scan_params_for(noise, target), surroundings=bool(surroundings),
                     positions_per_storey=None if positions_per_storey is None else int(positions_per_storey))
    ss = np.random.SeedSequence(int(seed))
    rng_furnish, rng_scan = (np.random.default_rng(s) for s in ss.spawn(2))
    timings = {}
    t0 = time.perf_counter()
    plan = plans[scanned].validated()
    if clutter and not plan.clutter:
        plan = furnish(plan, rng_furnish, furnish_params)
    elif not clutter:
        plan = plan.with_(clutter=())
    geom = plan_geometry(plan)
    prog(0.05, "true model")
    truth = build_truth(plan, geom) if scanned == "truth" else build_truth(plans["truth"].validated())
    variants = {k: build_truth(p.validated()) for k, p in plans.items() if k not in ("truth", scanned)}
    timings["truth_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = simulate_scan(plan, params, geometry=geom, rng=rng_scan, progress=prog.sub(0.1, 1.0))
    timings["scan_s"] = time.perf_counter() - t0
    cloud = result.cloud
    if scanned != "truth":
        changed = build_truth(plan, geom)
        new_ids = _changed_walls(changed, truth)
        removed = _changed_walls(truth, changed)
        new_idx = [int(i.split("_")[1]) for i in new_ids]
        cloud = cloud.with_(fields={**cloud.fields,
                                    "new": np.isin(result.wall_index, new_idx).astype(np.int32)})
        upd = []
        for wid in removed:
            w = truth[wid]
            upd.append(w.with_(attributes={**w.attributes, "removed_in_scan": True}))
            for c in w.children:
                d = truth[c]
                upd.append(d.with_(attributes={**d.attributes, "removed_in_scan": True}))
        truth = truth.replace_shapes(*upd)
        variants[scanned] = changed.replace_shapes(
            *[changed[w].with_(attributes={**changed[w].attributes, "new_in_scan": True}) for w in new_ids])
    cloud = cloud.with_(source=f"synthetic:{name}:seed={seed}")
    prog(1.0, "done")
    return SyntheticScene(name=name, seed=int(seed), noise_sigma=params.sigma, cloud=cloud, truth=truth,
                          plan=plan, variants=variants, scan_params=params, timings=timings)
