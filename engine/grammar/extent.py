"""Where a storey's grid ends (docs/method.md §2, place): the ceiling's seen extent, its far scan
lines followed beyond it, and the weakly seen wall that closes it; a cell-membership test of
the horizontal levels. Helpers of :func:`engine.grammar.manhattan.place_storey`."""
from __future__ import annotations

import numpy as np

__all__ = ["FAR_POINTS", "cell_lookup", "closing_wall", "scan_lines", "seen_extent"]

FAR_POINTS = 200
"""The largest gap between the outermost this many ceiling points along an axis is the
step between its scan lines at its far end (how much farther beyond its last point than
a wall's thickness a weak wall may close it)."""


def seen_extent(xy: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Seen extent of the main ceiling along x and y, metres: (lo (2,), hi (2,)) of its cells
    and (lo (2,), hi (2,)) of its points.

    ``xy`` : (n, 2) float64 horizontal coordinates of the ceiling's points, metres. The
    points are binned into ``cell`` × ``cell`` cells (``level_cell``); the largest
    8-connected group of occupied cells is the ceiling (stray patches seen through
    windows are not, so no percentile is needed), and the outer edges of its outermost
    cells along each axis give the extent. Cells, not points: a terrestrial scan
    is far denser near the scanner, so a point percentile would cut off the sparsely seen
    far end of a ceiling. The outermost points of those cells say how far the ceiling was
    seen (the cells' edges overstate it by up to a cell).
    """
    from scipy import ndimage

    c = np.floor(xy / cell).astype(np.int64)
    c0 = c.min(axis=0)
    c -= c0
    grid = np.zeros(tuple(c.max(axis=0) + 1), dtype=bool)
    grid[c[:, 0], c[:, 1]] = True
    lab, n = ndimage.label(grid, structure=np.ones((3, 3), dtype=bool))
    inside = np.ones(len(xy), dtype=bool)
    if n > 1:
        sizes = np.bincount(lab.ravel())[1:]
        grid = lab == (int(np.argmax(sizes)) + 1)
        inside = grid[c[:, 0], c[:, 1]]
    idx = np.argwhere(grid) + c0
    seen = xy[inside]
    return idx.min(axis=0) * cell, (idx.max(axis=0) + 1) * cell, seen.min(axis=0), seen.max(axis=0)


def scan_lines(r: np.ndarray, gap: float) -> float:
    """How far a ceiling's points run on beyond its seen extent: ``r`` (ascending) their
    distances beyond its edge, followed while each step is at most ``gap`` or three times
    the largest step before it (scan lines part gradually with range); the first larger jump
    leaves the ceiling (FZK-Haus mobile at 1M points without positions: the top of a
    site wall 10 m beyond the roof's eaves, at the ridge's height, took the attic there)."""
    if len(r) == 0:
        return 0.0
    g = np.diff(np.r_[0.0, r])
    allowed = np.maximum(gap, 3.0 * np.maximum.accumulate(np.r_[0.0, g[:-1]]))
    bad = np.nonzero(g > allowed)[0]
    if len(bad) == 0:
        return float(r[-1])
    return float(r[bad[0] - 1]) if bad[0] > 0 else 0.0


def closing_wall(edge: float, side: int, weak, reach: float) -> float:
    """Where the grid ends beyond the last wall: the outermost sparsely seen wall surface
    (``weak``: positions, metres, of surfaces holding at least ``min_bound_wall_area`` and
    reaching a ceiling) within ``reach`` of the ceiling's seen ``edge`` (a far end wall seen
    only in patches, behind furniture), else the edge itself. ``side`` −1: low end, +1: high end.
    """
    near = [w for w in (weak or ()) if abs(w - edge) <= reach]
    if not near:
        return float(edge)
    return float(max(near) if side > 0 else min(near))


def cell_lookup(xy: np.ndarray, cell: float):
    """A membership test for the level_cell cells holding ``xy`` (n, 2) metres:
    returns f(k) → bool for (m, 2) int cell indices."""
    if len(xy) == 0:
        return lambda k: np.zeros(len(k), dtype=bool)
    c = np.floor(xy / cell).astype(np.int64)
    lo = c.min(axis=0) - 1
    shape = c.max(axis=0) - lo + 2
    grid = np.zeros(tuple(shape), dtype=bool)
    grid[c[:, 0] - lo[0], c[:, 1] - lo[1]] = True

    def f(k):
        i = k - lo
        ok = (i[:, 0] >= 0) & (i[:, 0] < shape[0]) & (i[:, 1] >= 0) & (i[:, 1] < shape[1])
        out = np.zeros(len(k), dtype=bool)
        out[ok] = grid[i[ok, 0], i[ok, 1]]
        return out

    return f
