"""Ceiling points told by their height where their normals fail (docs/method.md §2, §3.2).

A sparse scan sees a ceiling as scan lines far apart: a mobile scanner's rings around each
position, a terrestrial scan far from its position. A point's neighbourhood then holds one
line, and its PCA normal tilts anywhere about that line (hexagon_hall mobile at 100k points:
median |n_z| 0.3 near the scanner, 0.03 a metre or two away), so the ceiling there is not
seen as horizontal, and a room seen only sparsely is lost. A point on a ceiling level is a
ceiling point whatever its normal, unless it is a wall's top: there is wall below it.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..threads import thread_cap
from .params import ManhattanParams
from .place import StoreyFrame

__all__ = ["ceiling_mask", "over_walls"]

WALL_BELOW = (0.15, 0.6)
"""A wall's top has points of the wall between these depths under it (metres): a wall reaches
the ceiling (``ManhattanParams.wall_top_band``), and a surface this far down is no ceiling."""


def over_walls(xyz: np.ndarray, cand: np.ndarray, level: float, upright: np.ndarray,
               reach: float) -> np.ndarray:
    """Which of the candidate points stand over a wall: (n,) bool, True only where ``cand``.

    xyz : (n, 3) float64 metres. cand : (n,) bool, the points on the ceiling ``level`` (z,
    metres) to test. upright : (n,) bool, the points that may be a wall's (not horizontal).
    reach : metres; a candidate with an ``upright`` point within it in plan, between the
    depths :data:`WALL_BELOW` under the level, is a wall's top.
    """
    out = np.zeros(len(xyz), bool)
    below = upright & (xyz[:, 2] >= level - WALL_BELOW[1]) & (xyz[:, 2] <= level - WALL_BELOW[0])
    idx = np.flatnonzero(cand)
    if not len(idx) or not below.any():
        return out
    d, _ = cKDTree(xyz[below, :2]).query(xyz[idx, :2], distance_upper_bound=reach, workers=thread_cap())
    out[idx[np.isfinite(d)]] = True
    return out


def ceiling_mask(p: np.ndarray, hor: np.ndarray, level: float, frame: StoreyFrame,
                 params: ManhattanParams) -> np.ndarray:
    """Which points lie on the ceiling at ``level`` (z, metres): (n,) bool.

    ``p`` : (n, 3) float64 storey points, metres; ``hor`` : (n,) bool, normal along z.
    A horizontal point is on it when it lies within the shape buffer δ of the level, or
    when it is the top surface of its ``level_cell`` cell in the storey (nothing above
    it within δ) and at most ``wall_top_band`` below the level. The second part follows
    a ceiling that reads lower far from a terrestrial scanner (a range-dependent error of
    the scans, not a step), and stops at a real step (a soffit or a lower ceiling more
    than the band down). Departure from rule 1 (docs/method.md §2). With
    ``params.ceiling_by_level`` any point within δ of the level is on it too, unless it stands
    over a wall (:func:`over_walls`; the module doc).
    """
    d = params.shape_buffer
    m = hor & (np.abs(p[:, 2] - level) <= d)
    if params.ceiling_by_level:  # and any point on the level but a wall's top
        at = ~m & (np.abs(p[:, 2] - level) <= d)
        m |= at & ~over_walls(p, at, level, ~hor, 2 * d)
    cand = hor & (p[:, 2] <= frame.ceiling + d)
    if not cand.any():
        return m
    k = np.floor(p[cand, :2] / params.level_cell).astype(np.int64)
    k -= k.min(axis=0)
    key = k[:, 0] * (int(k[:, 1].max()) + 1) + k[:, 1]
    z = p[cand, 2]
    order = np.argsort(key)  # the highest point of each cell (reduceat: ufunc.at is slow)
    first = np.ones(len(key), dtype=bool)
    first[1:] = key[order][1:] != key[order][:-1]
    top = np.maximum.reduceat(z[order], np.flatnonzero(first))
    zt = np.empty_like(z)
    zt[order] = top[np.cumsum(first) - 1]
    ok = (z >= zt - d) & (zt >= level - params.wall_top_band) & (zt <= level + d)
    m[np.flatnonzero(cand)[ok]] = True
    return m
