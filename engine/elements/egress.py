"""Exterior doors that lead nowhere walkable are windows (docs/method.md §7.3).

A gap in an exterior wall that reaches the floor is a door by its shape. Seen through, the
scan also says what lies beyond it: a door leads onto ground, a terrace or a balcony at about
its floor's level, just outside. A floor-to-ceiling window of an upper storey (the Duplex's
750 × 2200 mm windows on level 2, sill 10 cm, with nothing under the hole to see) has nothing
there; the ground seen through it lies a storey lower, or (a narrow one seen at a glance,
a scan without its surroundings) is not seen at all, while its storey's floor lies a storey
above the building's lowest. Such an opening is a window with its sill at the gap's bottom.
On the lowest storey without points beyond, and behind a closed leaf, nothing changes.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..model import Shape, ShapeType
from .params import OpeningParams
from .thickness import PointGrid

__all__ = ["elevated_doors"]


def _outer_normal(wall: Shape):
    """(a, d, n, half): the wall's axis start and unit direction, the unit normal pointing to
    its exterior side and half its thickness; None when the wall has no exterior side."""
    ax = wall.attributes.get("axis_line")
    sides = wall.attributes.get("sides") or [None, None]
    if ax is None:
        return None
    left_out = str(sides[0]).startswith("exterior_s")
    right_out = str(sides[1]).startswith("exterior_s")
    if left_out == right_out:
        return None
    a, b = np.asarray(ax[0], float), np.asarray(ax[1], float)
    d = (b - a) / max(float(np.linalg.norm(b - a)), 1e-12)
    n = np.array([-d[1], d[0]]) * (1.0 if left_out else -1.0)  # left of the axis is +n
    return a, d, n, float(wall.attributes["thickness"]) / 2


def _beyond(grid: PointGrid, a, d, n, half, u0, u1, depth, z0, z1, start: float = 0.05) -> int:
    """Points beyond the outer face: along the wall in [u0, u1], ``start`` to ``depth`` out,
    z in [z0, z1]."""
    corners = np.array([a + d * u + n * (half + v) for u in (u0, u1) for v in (start, depth)])
    idx = grid.in_box(np.r_[corners.min(axis=0), z0], np.r_[corners.max(axis=0), z1])
    if len(idx) == 0:
        return 0
    q = grid.xyz[idx, :2] - a
    u, v = q @ d, q @ n - half
    return int(np.count_nonzero((u >= u0) & (u <= u1) & (v >= start) & (v <= depth)))


def elevated_doors(openings: list[Shape], walls: list[Shape], grid: PointGrid,
                   params: OpeningParams = OpeningParams(),
                   lowest_floor: Optional[float] = None) -> list[Shape]:
    """``openings`` with the open exterior doors (and doorless openings) that lead nowhere
    walkable turned into windows; names renumbered per kind when one changed.

    Nowhere walkable: no points at the door's floor level just beyond it while the scan saw
    through it, and either the ground seen far below through it or (``lowest_floor``, the
    building's lowest storey floor, metres) its storey's floor ``elevated_drop`` or more
    above the lowest one (a narrow window seen through at a glance shows little ground, and a
    scan of the building's inside often none)."""
    by_id = {w.id: w for w in walls}
    out, changed = [], False
    for o in openings:
        w = by_id.get(o.parent)
        seen = float((o.support or {}).get("seen_through", 0.0))
        frame = _outer_normal(w) if w is not None and w.attributes.get("external") else None
        if o.type != ShapeType.DOOR or not o.attributes.get("open", True) or frame is None:
            out.append(o)
            continue
        floor = float(o.bounds[0, 2]) - float(o.attributes.get("sill", 0.0))
        upper = lowest_floor is not None and floor - lowest_floor >= params.elevated_drop
        # an upper storey's open door shows its balcony's floor just beyond whether or not
        # much else is seen through it; on the lowest storey only what is seen through counts
        if seen < params.min_seen_through and not upper:
            out.append(o)
            continue
        a, d, n, half = frame
        u = float(d @ (o.centroid[:2] - a))
        width = float(o.attributes.get("width", 0.0))
        u0, u1 = u - width / 2, u + width / 2
        lo, hi = params.egress_band
        # from a step's depth out: the first pass's walls have the default thickness, and a
        # thicker wall's sill under a low window lies at about the floor's level
        walk = _beyond(grid, a, d, n, half, u0, u1, params.egress_depth, floor + lo, floor + hi,
                       params.egress_gap)
        below = _beyond(grid, a, d, n, half, u0 - 2.0, u1 + 2.0, 20.0, -np.inf, floor - params.elevated_drop)
        if walk > 3 or (below < params.min_elevated_points and not upper):
            out.append(o)
            continue
        attrs = {k: v for k, v in o.attributes.items() if k != "open"}
        attrs["kind"] = "window"
        why = (f"{below} points of the ground {params.elevated_drop:.1f} m or more below"
               if below >= params.min_elevated_points else
               f"its floor {floor - lowest_floor:.1f} m above the lowest storey's")
        out.append(o.logged(f"egress: nothing walkable within {params.egress_depth:.1f} m beyond it "
                            f"({walk} points at its floor's level), {why}: a window down to the floor",
                            type=ShapeType.WINDOW, id=o.id.replace("door_", "window_", 1), attributes=attrs))
        changed = True
    if not changed:
        return out
    count = {ShapeType.DOOR: 0, ShapeType.WINDOW: 0}
    named = []
    for o in out:
        count[o.type] = count.get(o.type, 0) + 1
        named.append(o.with_(name=f"{o.type.value.capitalize()} {count[o.type]}"))
    return named
