"""Exterior wall thickness where the scan sees through the wall (docs/method.md §7.3).

From inside, an exterior wall shows only its inner face; its outer face is seen only through
its openings, as their reveals: the jambs, the sill and the head of a window or an open door
run from the inner face to the outer face. The depth of the reveal points behind the inner
face is the wall's thickness there. Glazing stops most rays: where a pane fills the opening,
the reveal seen in full ends at the pane, and only its sparse part seen through the pane
reaches the outer face; without that part the thickness is not measured (a reveal that ends
at the pane is the frame's depth, not the wall's).

Points are bucketed once in a plan grid (``cell``); each opening reads only the cells its
reveal region touches, so the cost is n (one sort) plus the points near openings.
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from ..geometry.boxes import column_min
from ..geometry.sort import stable_argsort
from ..model import Shape, ShapeType

__all__ = ["PointGrid", "reveal_depth"]


class PointGrid:
    """Points sorted by plan cell for box queries (metres)."""

    def __init__(self, xyz: np.ndarray, cell: float = 0.5):
        self.xyz = np.asarray(xyz, dtype=np.float64)
        self.cell = float(cell)
        if len(self.xyz) == 0:
            self.keys = np.zeros(0, np.int64)
            self.order = np.zeros(0, np.int64)
            self.lo = np.zeros(2, np.int64)
            self.ny = 1
            return
        ij = np.floor(self.xyz[:, :2] / self.cell).astype(np.int64)
        self.lo = column_min(ij)
        ij -= self.lo
        self.ny = int(ij[:, 1].max()) + 1
        keys = ij[:, 0] * self.ny + ij[:, 1]
        self.order = stable_argsort(keys)
        self.keys = keys[self.order]

    def in_box(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Indices of the points inside the plan box ``lo``–``hi`` (2,) and its z range when
        ``lo``/``hi`` are (3,)."""
        if len(self.keys) == 0:
            return np.zeros(0, np.int64)
        i0, j0 = np.floor(np.asarray(lo[:2]) / self.cell).astype(np.int64) - self.lo
        i1, j1 = np.floor(np.asarray(hi[:2]) / self.cell).astype(np.int64) - self.lo
        j0, j1 = max(j0, 0), min(j1, self.ny - 1)
        out = []
        for i in range(max(i0, 0), i1 + 1):
            a = np.searchsorted(self.keys, i * self.ny + j0)
            b = np.searchsorted(self.keys, i * self.ny + j1, side="right")
            if b > a:
                out.append(self.order[a:b])
        if not out:
            return np.zeros(0, np.int64)
        idx = np.concatenate(out)
        p = self.xyz[idx]
        m = np.all((p[:, :2] >= lo[:2]) & (p[:, :2] <= hi[:2]), axis=1)
        if len(lo) > 2:
            m &= (p[:, 2] >= lo[2]) & (p[:, 2] <= hi[2])
        return idx[m]


def reveal_depth(wall: Shape, openings: Sequence[Shape], grid: PointGrid, inner_side: int,
                 max_thickness: float, band: float = 0.04, min_points: int = 30) -> Optional[float]:
    """Thickness of an exterior wall from the reveals of its openings, metres (None when they
    show too few points).

    Parameters
    ----------
    wall : wall run (``axis_line``, ``thickness``).
    openings : its doors and windows (``width``, ``sill``, ``height`` and their boxes).
    grid : the scan's points in the model frame.
    inner_side : +1 when the room is on the left of the axis (+n side), -1 on the right.
    max_thickness : reveal points deeper than this behind the inner face are not the wall's.
    band : reveal points lie within this of a jamb, the sill or the head, metres.
    """
    a, b = (np.asarray(p, float) for p in wall.attributes["axis_line"])
    d = (b - a) / max(float(np.linalg.norm(b - a)), 1e-12)
    n = np.array([-d[1], d[0]]) * inner_side  # towards the room
    t = float(wall.attributes["thickness"])
    inner = a + n * t / 2  # a point on the inner face
    depths, panes = [], []
    for o in openings:
        c = o.centroid
        u = float(d @ (c[:2] - a))
        w = float(o.attributes.get("width", np.sort(o.scope.size[:2])[1]))
        z0, z1 = o.bounds[:, 2]
        u0, u1 = u - w / 2, u + w / 2
        # the reveal region behind the inner face, in plan
        corners = [a + d * uu - n * vv for uu in (u0 - band, u1 + band) for vv in (-band, max_thickness)]
        corners = np.array(corners)
        idx = grid.in_box(np.r_[corners.min(axis=0), z0 - band], np.r_[corners.max(axis=0), z1 + band])
        if len(idx) == 0:
            continue
        p = grid.xyz[idx]
        pu = (p[:, :2] - a) @ d
        pv = (inner - p[:, :2]) @ n  # depth behind the inner face
        jamb = (np.abs(pu - u0) <= band) | (np.abs(pu - u1) <= band)
        inside = (pu > u0 + band) & (pu < u1 - band)
        # a door's floor runs on outside: its sill is no reveal
        sill = (np.abs(p[:, 2] - z0) <= band) if o.type == ShapeType.WINDOW else np.zeros(len(p), bool)
        sill_head = inside & (sill | (np.abs(p[:, 2] - z1) <= band))
        jamb &= (p[:, 2] > z0 + band) & (p[:, 2] < z1 - band)
        m = (jamb | sill_head) & (pv > band) & (pv <= max_thickness)
        depths.append(pv[m])
        body = inside & (p[:, 2] > z0 + band) & (p[:, 2] < z1 - band) & (pv > band) & (pv <= max_thickness)
        panes.append(pv[body])
    if not depths:
        return None
    dv = np.concatenate(depths)
    if len(dv) < min_points:
        return None
    end = _reveal_end(dv, band, max_thickness)
    pane = _pane_depth(np.concatenate(panes), band, max_thickness)
    if pane is None or end > pane + 2 * band:
        return end
    # the reveal seen in full stops at a pane: its part seen through the pane, if any
    tail = dv[dv > pane + band]
    if len(tail) < max(min_points // 3, 5):
        return None
    return float(np.percentile(tail, 95))


def _pane_depth(depth: np.ndarray, start: float, stop: float, step: float = 0.01,
                share: float = 0.5) -> Optional[float]:
    """Depth of a pane across the openings (the densest 2 cm of the points inside them,
    holding at least ``share`` of those points), or None."""
    if len(depth) < 20:
        return None
    edges = np.arange(start, stop + step, step)
    h, _ = np.histogram(depth, bins=edges)
    two = h[:-1] + h[1:]
    i = int(np.argmax(two))
    if two[i] < share * len(depth):
        return None
    return float(edges[i + 1])


def _reveal_end(depth: np.ndarray, start: float, stop: float, step: float = 0.01) -> float:
    """Where the reveal ends: the far edge of the run of 1 cm depth bins, from the inner face
    on, that hold at least a quarter of the typical bin's points (a gap of one bin is
    bridged). Points beyond it (through the opening) are sparse and far."""
    edges = np.arange(start, stop + step, step)
    h, _ = np.histogram(depth, bins=edges)
    full = h[h > 0]
    if len(full) == 0:
        return float(np.max(depth))
    low = 0.25 * float(np.median(full))
    end, gap = 0, 0
    for i, c in enumerate(h):
        if c >= low:
            end, gap = i + 1, 0
        else:
            gap += 1
            if gap > 1:
                break
    return float(edges[end]) if end else float(np.max(depth))
