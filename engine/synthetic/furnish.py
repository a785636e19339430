"""Clutter for synthetic rooms: shelves and cabinets against walls (not in front of doors
or windows), tables in the room.

Clutter occludes walls and floors in the simulated scans, as furniture does in real ones.
Placement is random but reproducible: same plan, same parameters, same seed, same boxes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from shapely.ops import unary_union

from .plan import Clutter, FloorPlan, door_footprint, window_footprint

__all__ = ["FurnishParams", "furnish"]


@dataclass(frozen=True)
class FurnishParams:
    """How much furniture goes in a room and of what size (metres)."""

    shelves: tuple = (1, 2)
    """Inclusive (min, max) number of shelves against the walls of a room."""
    cabinets: tuple = (0, 1)
    """Inclusive (min, max) number of low cabinets against the walls."""
    tables: tuple = (1, 1)
    """Inclusive (min, max) number of tables inside the room."""
    shelf_depth: float = 0.4
    """Depth of a shelf, metres."""
    shelf_width: tuple = (1.0, 2.0)
    """Range of shelf widths along the wall, metres."""
    shelf_height: tuple = (1.8, 2.2)
    """Range of shelf heights, metres."""
    cabinet_depth: float = 0.5
    """Depth of a cabinet, metres."""
    cabinet_width: tuple = (0.8, 1.2)
    """Range of cabinet widths, metres."""
    cabinet_height: tuple = (0.8, 1.1)
    """Range of cabinet heights, metres."""
    table_size: tuple = (0.8, 1.6)
    """Table top, metres (depth, length)."""
    table_height: float = 0.75
    """Height of the table top above the floor, metres."""
    wall_gap: float = 0.02
    """Gap between a wall and the back of a shelf or cabinet, metres."""
    table_wall_clearance: float = 0.7
    """Minimum distance of a table from the walls, metres."""
    door_clearance: float = 1.0
    """No furniture within this distance of a door opening, metres."""
    window_clearance: float = 0.3
    """No shelf or cabinet within this distance of a window opening, metres."""
    spacing: float = 0.3
    """Minimum distance between two pieces of furniture, metres."""
    min_room_area: float = 6.0
    """Rooms smaller than this (m²) stay empty."""
    attempts: int = 40
    """Random placements tried per piece before giving up."""


def _inside(room_poly, fp, others, doors, params) -> bool:
    if not room_poly.buffer(-0.005).contains(fp):
        return False
    if doors is not None and fp.intersects(doors):
        return False
    return all(fp.distance(o) >= params.spacing for o in others)


def furnish(plan: FloorPlan, rng=None, params: FurnishParams = FurnishParams()) -> FloorPlan:
    """A copy of ``plan`` with clutter placed in every furnished room.

    Parameters
    ----------
    plan : FloorPlan
    rng : numpy Generator, int or None
        Seed of the placement.
    params : FurnishParams

    Returns
    -------
    FloorPlan
        ``plan`` with ``clutter`` extended (existing clutter is kept).
    """
    rng = np.random.default_rng(rng)
    items = list(plan.clutter)
    door_zones = {}
    for d in plan.doors:
        fp = door_footprint(plan, d)[0].buffer(params.door_clearance)
        for name in d.rooms:
            door_zones.setdefault(name, []).append(fp)
    window_zones = {}
    for w in plan.windows:
        window_zones.setdefault(w.room, []).append(window_footprint(plan, w)[0].buffer(params.window_clearance))
    for room in plan.rooms:
        poly = room.shape
        if not room.furnished or poly.area < params.min_room_area:
            continue
        doors = unary_union(door_zones[room.name]) if room.name in door_zones else None
        zones = door_zones.get(room.name, []) + window_zones.get(room.name, [])
        wall_zones = unary_union(zones) if zones else None
        placed = [c.footprint() for c in items if c.room == room.name]
        coords = np.asarray(poly.exterior.coords)
        edges = [(coords[k], coords[k + 1]) for k in range(len(coords) - 1)]
        lengths = np.array([np.hypot(*(q - p)) for p, q in edges])

        def against_wall(kind, depth, widths, heights):
            for _ in range(params.attempts):
                w = float(rng.uniform(*widths))
                h = float(rng.uniform(*heights))
                ok = lengths >= w + 0.2
                if not ok.any():
                    return
                e = int(rng.choice(np.flatnonzero(ok), p=lengths[ok] / lengths[ok].sum()))
                p, q = edges[e]
                d = (q - p) / lengths[e]
                n = np.array([d[1], -d[0]])  # outward of a CCW polygon
                u = float(rng.uniform(w / 2 + 0.1, lengths[e] - w / 2 - 0.1))
                c = p + d * u - n * (depth / 2 + params.wall_gap)
                cand = Clutter(kind, (float(c[0]), float(c[1])), (w, depth, h), math.atan2(d[1], d[0]), room.name)
                fp = cand.footprint()
                if _inside(poly, fp, placed, wall_zones, params):
                    items.append(cand)
                    placed.append(fp)
                    return

        for _ in range(int(rng.integers(params.shelves[0], params.shelves[1] + 1))):
            against_wall("shelf", params.shelf_depth, params.shelf_width, params.shelf_height)
        for _ in range(int(rng.integers(params.cabinets[0], params.cabinets[1] + 1))):
            against_wall("cabinet", params.cabinet_depth, params.cabinet_width, params.cabinet_height)
        inner = poly.buffer(-params.table_wall_clearance)
        for _ in range(int(rng.integers(params.tables[0], params.tables[1] + 1))):
            if inner.is_empty:
                break
            minx, miny, maxx, maxy = inner.bounds
            for _ in range(params.attempts):
                c = rng.uniform([minx, miny], [maxx, maxy])
                e = int(np.argmax(lengths))
                d = (edges[e][1] - edges[e][0]) / lengths[e]
                angle = math.atan2(d[1], d[0]) + (math.pi / 2 if rng.random() < 0.5 else 0.0)
                sy, sx = params.table_size
                cand = Clutter("table", (float(c[0]), float(c[1])), (sx, sy, params.table_height), angle, room.name)
                fp = cand.footprint()
                if inner.contains(fp.centroid) and _inside(poly, fp, placed, doors, params):
                    items.append(cand)
                    placed.append(fp)
                    break
    return plan.with_(clutter=tuple(items))
