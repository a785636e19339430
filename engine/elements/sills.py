"""What lies under a hole in a wall, column by column (docs/method.md §7.3): the floor through
a doorway, a sill's top under a window. :mod:`.openings` reads it to tell a tall window from a
door and to cut a door standing beside a window in one hole."""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .params import OpeningParams

__all__ = ["floor_under", "level_sill", "low_quantile", "meet", "split_by_bottom"]


def low_quantile(col: np.ndarray, h: np.ndarray, mask: np.ndarray, n: int, q: float = 0.2) -> np.ndarray:
    """Per column (0..n-1), the ``q`` quantile of ``h`` over the masked points; NaN where
    a column has none (one sort, linear after it)."""
    out = np.full(n, np.nan)
    c, v = col[mask], h[mask]
    if not len(c):
        return out
    order = np.lexsort((v, c))
    c, v = c[order], v[order]
    starts = np.flatnonzero(np.r_[True, c[1:] != c[:-1]])
    counts = np.diff(np.r_[starts, len(c)])
    out[c[starts]] = v[starts + np.floor(q * (counts - 1)).astype(np.int64)]
    return out


def split_by_bottom(dd, rect, p: OpeningParams, bounds: Optional[list] = None) -> list:
    """A gap (``rect``: columns c0..c1, rows r0..r1 of a wall's rasters ``dd``) whose bottom
    is the floor over one stretch and a sill over the next (a door beside a window, one hole
    between their frames) → the two rectangles, the door's reaching down to the floor rows;
    else the gap as it is. Columns (the gap's and
    ``edge_search`` beyond, where its edges are measured) are told by what lies under the
    hole inside the thickness (``bottom``, floor points); each stretch must span a door's or
    a window's width of such columns, one stretch each. The parts come in order along the
    wall. ``bounds`` (a list): on a cut, (end of the first stretch's last column, start of
    the second's first column) in metres along the wall is appended: the columns between
    them show neither (a pier between the door and the window, unseen under them)."""
    c0, c1, r0, r1 = rect
    c = p.cell
    if r0 * c > 2.5 * p.floor_tolerance or r1 * c < p.min_door_height:  # no door's height down to near the floor
        return [rect]
    ext = int(round(p.edge_search / c))
    a, b = max(0, c0 - ext), min(len(dd.bottom), c1 + ext)
    bottom, floor = dd.bottom[a:b], dd.floor[a:b]
    low = (floor > 0) | (np.isfinite(bottom) & (bottom < p.min_sill))
    high = np.isfinite(bottom) & (bottom >= p.min_sill) & (floor == 0)
    level = high.copy()
    if high.any():  # a sill's top is one level: a column's bottom off it is a jamb's or a mullion's
        # lowest points, no stray under the sill (the Duplex's terrace door beside its glazing,
        # terrestrial without positions: the door's jamb column at 0.31 m past its two floor
        # columns was a wrong side of the cut, one too many, the sill at 0.113 m ± 4 mm)
        level &= np.abs(bottom - float(np.median(bottom[high]))) <= p.sill_level
    known = np.flatnonzero(low | level)
    if (len(known) < 4 or not low.any() or level.sum() < p.min_sill_columns
            or 2 * level.sum() < high.sum()):
        # (a sill's top in fewer columns, or most columns above the floor at no one level: a
        # jamb's and a ramp's lowest points; office_mw terrestrial seed 14 at 100k points: a
        # door's left jamb, two columns at 0.11-0.13 m, cut a 0.3 m "window" off it)
        return [rect]
    seq = level[known]  # labels in column order: one change from floor to sill (or back)
    # the best single cut (fewest columns on the wrong side of it): a stray column (a point
    # under a sill, the floor seen through a window's frame) does not undo the split, while
    # more than a tenth of them wrong says there is no one cut (Duplex TLS without positions:
    # its terrace door and the low window beside it were one 5.7 m window on some machines)
    h = np.cumsum(seq)
    j = np.arange(1, len(seq))
    low_first = h[j - 1] + (len(seq) - j - (h[-1] - h[j - 1]))  # highs before the cut, lows after
    wrong = np.minimum(low_first, len(seq) - low_first)
    i = int(np.argmin(wrong))
    if wrong[i] > int(0.1 * len(seq)):
        return [rect]
    sill_first = bool(low_first[i] > len(seq) - low_first[i])
    # the cut, between the last of one and the first of the other, a column above the floor
    # (a mullion's, a jamb's) standing between them on the window's side
    e0, e1 = int(known[i]), int(known[i + 1])
    inner = e0 + 1 + np.flatnonzero(high[e0 + 1:e1])
    if len(inner):
        e0, e1 = (int(inner.max()), e1) if sill_first else (e0, int(inner.min()))
    k = a + (e0 + e1 + 1) // 2
    lows, highs = a + np.flatnonzero(low), a + np.flatnonzero(high)
    # each stretch spans a door's (a window's) width of its columns, or, seen in two columns
    # or more, its side of the cut does (a terrestrial scan at 100k points sees the floor
    # through a doorway in the few columns its scan lines cross: the Duplex's terrace door,
    # floor in 2 of its 16 columns, was one 5.7 m opening with the window beside it)
    # (a side reaching out to where the hole's edge is looked for: the gap's rectangle stops
    # short of the jambs)
    door_side, window_side = ((k, c1 + ext), (c0 - ext, k)) if sill_first else ((c0 - ext, k), (k, c1 + ext))

    def spans(cols, side, least):
        return ((cols.max() - cols.min() + 1) * c >= least
                or (len(cols) >= 2 and (side[1] - side[0]) * c >= least))

    if not (c0 < k < c1 and spans(lows, door_side, p.min_door_width)
            and spans(highs, window_side, p.min_window_width)):
        return [rect]
    r_floor = int(math.ceil(p.edge_band / c))
    left, right = (c0, k, r0, r1), (k, c1, r0, r1)  # in order along the wall
    if bounds is not None:
        bounds.append(((a + e0 + 1) * c, (a + e1) * c))
    if sill_first:  # the door is on the right
        return [left, (k, c1, min(r0, r_floor), r1)]
    return [(c0, k, min(r0, r_floor), r1), right]


def level_sill(bottom: np.ndarray, floor: np.ndarray, p: OpeningParams):
    """The sill's height (metres over the floor) of a floor-reaching gap whose columns
    (``bottom``: the lowest points inside the thickness, NaN where none; ``floor``: floor
    points inside it) show a sill and barely the floor, however few of them the scan saw;
    None when they do not.

    A sparse scan sees a 10 cm sill's top in a few columns of a tall window only (Duplex at
    100k points: 3 of 16, 15 of 96), too few for the half that the plain rule asks of a gap a
    door's height tall; a doorway shows the floor through its thickness wherever it shows
    anything. So: ``level_sill_columns`` columns or more whose bottoms stand at one level
    (within ``sill_level``) ``min_sill`` or more above the floor — the top of a sill, not a
    box standing in a doorway — and the floor (a floor point, or a bottom under ``min_sill``)
    in at most a tenth of the columns showing either, as :func:`split_by_bottom` allows a
    stray: one floor point, pushed into the thickness by the range noise, made the Duplex's
    4.8 m glazing on its 10 cm sill a doorless opening (terrestrial, σ 1.2 cm; its sill seen
    in 14 of 96 columns)."""
    fin = np.isfinite(bottom)
    low = (floor > 0) | (fin & (bottom < p.min_sill))
    high = fin & ~low
    if not high.any():
        return None
    seen = bottom[high]
    level = float(np.median(seen))
    if int(np.count_nonzero(np.abs(seen - level) <= p.sill_level)) < p.level_sill_columns:
        return None
    if int(np.count_nonzero(low)) > int(0.1 * int(np.count_nonzero(low | high))):
        return None
    return level


def floor_under(dd, el: float, er: float, p: OpeningParams) -> bool:
    """Whether the floor shows inside the wall's thickness between u ``el`` and ``er``
    (metres) in more columns than a sill's top does: no wall stands under that stretch of the
    hole. A window's sill is wall down to the floor; a floor point inside its thickness would
    be a face point that the range noise pushed in, rarer than the sill's top beside it."""
    c = p.cell
    ia, ib = max(0, int(el / c)), max(0, int(math.ceil(er / c)))
    cols = dd.bottom[ia:ib]
    sill = int(np.count_nonzero(np.isfinite(cols) & (cols >= p.min_sill) & (dd.floor[ia:ib] == 0)))
    return int(np.count_nonzero(dd.floor[ia:ib] > 0)) > sill


def meet(first: dict, second: dict, lo: float, hi: float, cut: float) -> None:
    """Set the facing edges (``u1`` of ``first``, ``u0`` of ``second``, metres; and their
    widths) of the two parts of a hole that :func:`split_by_bottom` cut at ``cut``, in order
    along the wall. [``lo``, ``hi``] is the stretch between them whose columns show neither a
    sill nor the floor: an edge measured in it is a jamb of its own there (the Duplex's
    terrace doors stand 10 cm beside their glazing, the pier between them unseen under the
    hole: the door, cut halfway across that stretch, was 6.5 cm narrow); one measured past it
    ran on into the other part, and stops at the cut. Where the two still overlap, the door's
    edge stands and the window's stops at it (the window's edge search starts at the cut, its
    jamb may lie before it); two of a kind meet at the cut."""
    for o, key in ((first, "u1"), (second, "u0")):
        if not lo - 1e-9 <= o[key] <= hi + 1e-9:
            o[key] = min(o[key], cut) if key == "u1" else max(o[key], cut)
    if first["u1"] > second["u0"]:
        win = [o["kind"] == "window" for o in (first, second)]
        if win == [True, False]:
            first["u1"] = second["u0"]
        elif win == [False, True]:
            second["u0"] = first["u1"]
        else:
            first["u1"], second["u0"] = min(first["u1"], cut), max(second["u0"], cut)
    for o in (first, second):
        o["width"] = o["u1"] - o["u0"]
