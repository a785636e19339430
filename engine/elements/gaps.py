"""Gaps in a wall's face rasters (docs/method.md §7.3): where a face is present and where it
is observed, the rectangles of the empty components, and where a hole's edges lie (a
reveal plane inside the thickness, else where the face points end). :mod:`.openings` reads
them for every wall run."""
from __future__ import annotations

import math
from typing import Optional

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy import ndimage

from .params import OpeningParams

__all__ = ["banded", "head_across", "hole_deficit", "leaf_needed", "box_sum", "face_present", "mask_runs",
           "observed_columns", "gap_rectangles", "hole_edge", "near_points", "on_solid"]


def box_sum(a: np.ndarray, k: int) -> np.ndarray:
    """Sum of ``a`` over a k × k window (zero outside)."""
    return ndimage.uniform_filter(a.astype(np.float64), size=k, mode="constant") * (k * k)


def face_present(count: np.ndarray, params: OpeningParams) -> np.ndarray:
    """Cells where the face is present: the kernel (smallest of 3..11 cells that expects
    ``kernel_points`` from the local density) holds at least one point and
    ``presence_share`` of the local density."""
    big = max(3, int(round(params.density_window / params.cell)) | 1)
    present = np.zeros(count.shape, bool)
    chosen = np.zeros(count.shape, bool)
    for k in (3, 5, 7, 9, 11):
        box = box_sum(count, k)
        occ = box_sum(box > 0, big)
        ref = box_sum(box, big) / np.maximum(occ, 1e-9)
        pick = ~chosen & ((ref >= params.kernel_points) | (k == 11))
        present[pick] = (box[pick] >= np.maximum(params.presence_share * ref[pick], 1.0 - 1e-9))
        chosen |= pick
    return present


def mask_runs(mask: np.ndarray, bridge: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Starts and stops of the runs of True in ``mask``, across breaks of at most ``bridge``."""
    idx = np.flatnonzero(mask)
    if not len(idx):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    cut = np.flatnonzero(np.diff(idx) > bridge + 1)
    return np.r_[idx[0], idx[cut + 1]], np.r_[idx[cut], idx[-1]] + 1


def _longest_run(mask: np.ndarray, bridge: int = 0) -> tuple[int, int]:
    """[start, stop) of the longest run of True across breaks of at most ``bridge`` False
    (0, 0 when none)."""
    a, b = mask_runs(mask, bridge)
    if not len(a):
        return 0, 0
    k = int(np.argmax(b - a))
    return int(a[k]), int(b[k])


def observed_columns(cols: list, run: int, window: int, ends: bool = False) -> list:
    """Per face, the columns where it is observed: where its points (and rays through it)
    within ``window`` columns reach 5 % of the densest face's usual count, bridging
    stretches without them of up to ``run`` columns. ``ends`` (an exterior wall): a stretch
    at the wall's end shorter than ``run`` is observed too when it holds at least three
    points per window everywhere (a corner window's head and sill, far from the scanner; on
    an interior wall a sparse face beside a door would split the door)."""
    wins = [ndimage.convolve1d(cc, np.ones(window), mode="constant") for cc in cols]
    ref = max(float(np.percentile(wv, 75)) for wv in wins)
    out = []
    for wv in wins:
        obs = np.zeros(len(wv), bool)
        for a, b in zip(*mask_runs(wv >= max(3.0, 0.05 * ref), run)):
            obs[a:b] = True
        seen = np.flatnonzero(obs)
        if ends and len(seen):
            for sl in (np.s_[:seen[0]], np.s_[seen[-1] + 1:]):
                if 0 < len(wv[sl]) <= run and (wv[sl] >= 3.0).all():
                    obs[sl] = True
        out.append(obs)
    return out


def _rectangle(mask: np.ndarray, share: float, bridge: int) -> tuple[int, int, int, int]:
    """The dominant rectangle [c0, c1) x [r0, r1) of a gap component's mask (rows and
    columns at least ``share`` empty, across short breaks of ``bridge`` cells)."""
    c0, c1, r0, r1 = 0, mask.shape[0], 0, mask.shape[1]
    for _ in range(3):
        cf = mask[:, r0:r1].mean(axis=1) if r1 > r0 else np.zeros(mask.shape[0])
        a, b = _longest_run(cf >= share, bridge)
        if b <= a:
            return 0, 0, 0, 0
        c0, c1 = a, b
        rf = mask[c0:c1].mean(axis=0)
        a, b = _longest_run(rf >= share, bridge)
        if b <= a:
            return 0, 0, 0, 0
        r0, r1 = a, b
    return c0, c1, r0, r1


def _transom(solid: np.ndarray, a, b, share: float = 0.9) -> bool:
    """Whether a transom separates rectangles ``a`` and ``b`` [c0, c1, r0, r1], one above the
    other: a row between them with points (``solid``, the raster's cells holding face points)
    over ``share`` of their common columns. Noise leaves scattered points only, and a sparse
    face too (the face's kernel fills its cells, not its points: no transom)."""
    lo, hi = min(a[3], b[3]), max(a[2], b[2])
    x0, x1 = max(a[0], b[0]), min(a[1], b[1])
    return hi > lo and x1 > x0 and bool((np.mean(solid[x0:x1, lo:hi], axis=0) >= share).any())


def _merge(rects: list, gap: int, solid: Optional[np.ndarray] = None) -> list:
    """Merge rectangles [c0, c1, r0, r1] closer than ``gap`` cells along one axis that overlap
    along the other by half the larger one's extent, unless one lies above the other with a
    transom between them (a row of ``solid``, cells with face points: :func:`_transom`). Side by
    side they merge across a mullion: a wide window's mullions are inside one window (the
    Duplex's 2.8 m glazing, one IfcWindow, was two), stacked windows are often separate."""
    rects = [list(r) for r in rects]
    i = 0
    while i < len(rects):
        for j in range(i + 1, len(rects)):
            a, b = rects[i], rects[j]
            du, dz = max(a[0], b[0]) - min(a[1], b[1]), max(a[2], b[2]) - min(a[3], b[3])
            ou = -du / max(1, a[1] - a[0], b[1] - b[0])  # overlap share of the larger one
            oz = -dz / max(1, a[3] - a[2], b[3] - b[2])
            side = du <= gap and oz >= 0.5
            stacked = dz <= gap and ou >= 0.5
            if solid is not None and stacked and not side and dz > 0 and _transom(solid, a, b):
                continue
            if side or stacked:
                rects[i] = [min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3])]
                del rects[j]
                i = -1
                break
        i += 1
    return [tuple(r) for r in rects]


def gap_rectangles(mask: np.ndarray, p: OpeningParams, solid: Optional[np.ndarray] = None) -> list:
    """Rectangles [c0, c1, r0, r1] (cells) of the empty components of ``mask``; two close
    ones with a transom of ``solid`` (cells with face points) between them stay two.

    A component may hold several openings joined by thin empty channels (a sparse band
    under the ceiling links two windows and a door between them on a mobile scan): its
    dominant rectangle is taken, its columns cleared (with a margin wider than the merge
    gap, so that the ragged edge of one gap does not come back as another and widen it), and
    what is left is looked at again, after every first rectangle (which the caller prefers
    when two overlap).
    """
    bridge = max(1, int(round(p.merge_gap / p.cell)))
    rects = []
    todo = [(mask, 0, 0)]
    while todo:
        m, dc, dr = todo.pop(0)
        lab, _ = ndimage.label(m)
        for i, sl in enumerate(ndimage.find_objects(lab), start=1):
            if sl is None:
                continue
            sub = lab[sl] == i
            if sub.sum() < 4:
                continue
            c0, c1, r0, r1 = _rectangle(sub, p.rect_share, bridge)
            if c1 - c0 < 2 or r1 - r0 < 2:
                continue
            x0, y0 = dc + sl[0].start, dr + sl[1].start
            rects.append((c0 + x0, c1 + x0, r0 + y0, r1 + y0))
            rest = sub.copy()
            rest[max(0, c0 - bridge - 1):c1 + bridge + 1] = False
            if rest.sum() >= 4:
                todo.append((rest, x0, y0))
    return _merge(rects, bridge, solid)


def _lines(rev, oth, n: int, span: float):
    """Lines of ``n`` points along an edge among the reveal points ``rev``: each run of ``n``
    consecutive values once sorted, its median, its extent in ``rev`` and whether it spreads
    over ``span`` of the other coordinate ``oth``."""
    o = np.argsort(rev)
    wu, wo = sliding_window_view(rev[o], n), sliding_window_view(oth[o], n)
    return np.median(wu, axis=1), wu[:, -1] - wu[:, 0], np.ptp(wo, axis=1) >= span


def _outermost_line(rev, oth, ctr: float, take_max: bool, span: float, ends_face) -> float:
    """The jamb in front of a reveal plane at ``ctr``: a frame or lining set into the hole
    shows a denser plane than the wall's own reveal before it (FZK-Haus: the windows' frames
    7.5 cm inside the hole, the reveal seen by one scan line, windows 15 cm narrow). The
    outermost line of at least four points (a tenth of the reveal's) within 1 cm, across
    ``span`` of the band, 3.5 cm or more out from the plane (a mobile scan's noise about a
    jamb stays within that) and ending the face; else ``ctr``."""
    n = max(4, int(math.ceil(0.1 * len(rev))))
    if len(rev) < n:
        return ctr
    cand, extent, spread = _lines(rev, oth, n, span)
    out = (cand <= ctr - 0.035) if take_max else (cand >= ctr + 0.035)
    ok = np.flatnonzero((extent <= 0.01) & spread & out)
    for j in (ok if take_max else ok[::-1]):  # from the outermost
        into, back = ends_face(float(cand[j]), 0.04)
        if into <= 0.25 * back + 1:
            return float(cand[j])
    return ctr


def hole_edge(coord, other, inside, lo, hi, olo, ohi, take_max, inward: float = 0.0,
              proud: Optional[np.ndarray] = None, depth: Optional[np.ndarray] = None,
              passed: Optional[np.ndarray] = None, behind: Optional[float] = None) -> Optional[float]:
    """Where the wall ends in ``coord`` within [lo, hi] (``other`` within [olo, ohi]): the
    median of the ``inside`` points of a reveal (a dense plane across the thickness, 1 cm
    histogram peak; looked for ``inward`` metres — the faces' noise tolerance — further into
    the hole too: a jamb on the candidate's cell edge falls either side of it; or, with fewer
    than six points, one scan line along the edge: four within 1 cm across a third of the
    band), else where the face points end (a few strays beyond) plus the gap expected there.
    ``depth`` (the ``inside`` points' depth behind the nearer face): a plane whose points all
    stand well behind the face is a frame or lining set into the hole, and the wall ends where
    its face does, further out. ``passed``: where rays through the wall cross the face (in
    ``coord``, within the band), the hole's own points. ``behind``: where a wall standing
    against the face ends on the hole's side; the face's sampling is measured from there on."""
    band = (other >= olo) & (other <= ohi)
    m = (coord >= lo) & (coord <= hi) & band
    ext = 0.01 * math.ceil(inward / 0.01 - 1e-9)  # whole 1 cm bins: the histogram keeps its grid
    r_lo, r_hi = (lo, hi + ext) if take_max else (lo - ext, hi)
    in_rev = (coord >= r_lo) & (coord <= r_hi) & band & inside
    rev = coord[in_rev]
    face = coord[band & ~inside]

    def ends_face(ctr: float, near: float) -> tuple[int, int]:
        # face points beyond ``near`` into the hole and behind: a jamb ends the face
        d = (face - ctr) if take_max else (ctr - face)  # > 0: into the hole
        return int(((d > near) & (d < 0.30)).sum()), int(((d < -near) & (d > -0.30)).sum())

    if 4 <= len(rev) < 6:
        # a terrestrial scanner's vertical line on a jamb (a horizontal one on a sill): too
        # few points for the histogram, but in one line along the edge, not strays — nor a
        # line inside the wall's body with the face running on past it (a partition's end)
        cand, extent, spread = _lines(rev, other[in_rev], 4, 0.3 * (ohi - olo))
        j = int(np.argmin(extent))
        ctr = float(cand[j])
        into, back = ends_face(ctr, 0.04)  # past a casing or lining
        if extent[j] <= 0.01 and spread[j] and lo <= ctr <= hi and into <= 0.25 * back + 1:
            return ctr
    if len(rev) >= 6:
        hist, edges = np.histogram(rev, np.arange(r_lo, r_hi + 0.01, 0.01))
        # the bar is the mean over [lo, hi]'s bins: searching further in must not lower it
        nb = max(1, len(np.arange(lo, hi + 0.01, 0.01)) - 1)
        if len(hist) >= 3:
            win = ndimage.convolve1d(hist, np.ones(7), mode="constant")
            k = int(np.argmax(win))
            if win[k] >= max(6.0, 0.5 * len(rev), 3.0 * win.sum() / nb):  # a plane, not spilled noise
                ctr = float(np.median(rev[np.abs(rev - edges[k] - 0.005) <= 0.035]))
                # ... and a jamb ends the face: the face runs on past spilled noise, 10-30 cm
                # into the hole (clear of casings and an open leaf at the jamb) as densely as
                # half of it does behind (a mobile scan's σ 2 cm puts a few face points into
                # the thickness: six in one window read as a jamb 24 cm beyond the true one,
                # house_multi_height mobile 4)
                into, back = ends_face(ctr, 0.10)
                if not (into >= 10 and into > 0.5 * back):
                    ctr = _outermost_line(rev, other[in_rev], ctr, take_max, 0.3 * (ohi - olo), ends_face)
                    if (pier := _pier(coord[band & ~inside], other[band & ~inside], ctr, take_max,
                                      max(0.035, 1.5 * inward), 0.3 * (ohi - olo))) is not None:
                        return pier
                    if depth is None or not _set_back(rev, depth[in_rev], ctr, take_max, inward):
                        return ctr
                    # the jamb seen starts deep in the thickness: a frame set into the hole, the
                    # wall's own reveal seen on the face's plane only (FZK-Haus: a terrestrial
                    # scan's 100k points, the reveal's first 2 cm; windows 7 cm narrow). The
                    # wall ends where the face does, and the face's last points (that strip's)
                    # stand at the edge: no gap added
                    ends = _face_end(coord, face, m & ~inside, lo, hi, take_max, proud, behind)
                    end = None if ends is None else ends[0]
                    return ctr if end is None or (end > ctr if take_max else end < ctr) else end
    ends = _face_end(coord, face, m & ~inside, lo, hi, take_max, proud, behind)
    if ends is None:
        return None
    last, end = ends
    if depth is None and passed is None:
        return end
    # the gap expected after the face's last point stops at what stands in the hole: the
    # second point (one may stray) inside the thickness past the face's last one, too deep
    # for a face's spilled noise (a reveal, a frame, glazing), or where a ray passed the face
    # (two_storey_office TLS at 100k points: the faces' last columns 0-2 cm from the jambs,
    # the gap added 8-10 cm, windows 10-16 cm narrow)
    hole = [] if depth is None else [coord[m & inside & (depth >= inward + 0.03)]]
    if passed is not None:
        hole.append(passed[(passed >= lo) & (passed <= hi)])
    cs = np.concatenate(hole)
    cs = cs[(cs > last) if take_max else (cs < last)]
    cs = np.sort(cs) if take_max else -np.sort(-cs)  # from the wall's side
    if len(cs) < 2:
        return end
    return min(end, cs[1]) if take_max else max(end, cs[1])


def head_across(fu, fz, et: Optional[float], mid: tuple, c: float) -> bool:
    """Whether the head measured at ``et`` over a hole shows points (face and reveal, ``fu``,
    ``fz``) within two cells of it over ``mid``, the hole's width away from its jambs."""
    if et is None:
        return False
    return bool(((np.abs(fz - et) <= 2 * c) & (fu > mid[0]) & (fu < mid[1])).any())


def round_hole(fu, fz, fin, el: float, er: float, eb: float, et: float, tol: float, proud, dev,
               p) -> Optional[tuple]:
    """A window measured (``el``, ``er``, ``eb``, ``et``) over its whole height and width that
    is round or oval (FZK-Haus's Rundfenster read 0.8 m for 1.0): its extent across its
    middle, else None. Each edge is measured in bands a fifth of the other side wide (at
    least 10 cm): about the middle, and 0.3 of the side either way from it. Round: the
    middle band's edges 3 cm or more further out than both others', across and up, on all
    four sides (the same band and estimator: a scan's noise and spacing widen all three
    alike, and a mobile scanner's rings thin one height only, not the head and sill too)."""
    srch, out = p.edge_search, 0.03
    hz, hu = max(0.05, (et - eb) / 10), max(0.05, (er - el) / 10)
    zm, um = (eb + et) / 2, (el + er) / 2

    def edges(coord, other, lo, hi, at, h):
        return (hole_edge(coord, other, fin, lo - srch, lo + srch, at - h, at + h, True, tol, proud, dev),
                hole_edge(coord, other, fin, hi - srch, hi + srch, at - h, at + h, False, tol, proud, dev))

    def widest(coord, other, lo, hi, mid, h, span):
        a, b = edges(coord, other, lo, hi, mid, h)
        for f in (-0.3, 0.3):
            fa, fb = edges(coord, other, lo, hi, mid + f * span, h)
            if a is None or b is None or fa is None or fb is None or a > fa - out or b < fb + out:
                return None
        return a, b

    across = widest(fu, fz, el, er, zm, hz, et - eb)
    up = across and widest(fz, fu, eb, et, um, hu, er - el)
    return None if not up else (across[0], across[1], up[0], up[1])


def _pier(face: np.ndarray, oth: np.ndarray, ctr: float, take_max: bool, near: float,
          span: float) -> Optional[float]:
    """The end of a pier's face on the hole's side of a jamb plane at ``ctr``: six face points
    or more (``face`` along the edge, ``oth`` across) ``near`` or further from the plane
    towards the hole, over ``span`` of the band, and within 15 cm of it, with next to no
    face behind the plane (a quarter as many points within 30 cm): the face resumes before
    the plane, which is the far jamb of the pier, the next hole's (the Duplex's terrace doors
    10 cm beside the glazing: the door measured to the glazing's jamb, 13 cm wide); else
    None. A jamb's spilled noise stays within ``near``; a door frame's face flush with the
    plaster stands in the hole with the wall's face behind its jamb (FZK-Haus). With no face
    at all behind the plane, four points past it (1 cm or more) make a pier too."""
    d = (face - ctr) if take_max else (ctr - face)  # > 0: towards the hole
    behind = (d < -near) & (d > -0.30)  # a wall's face behind a jamb; the next hole behind a pier's
    on = (d > near) & (d <= 0.15)
    if on.sum() < 6 or np.ptp(oth[on]) < span or behind.sum() > 0.25 * on.sum():
        # a sparse scan's pier: four points or more past the plane, some within ``near`` of
        # it, and no face at all behind it (a jamb's spill has the wall's face behind it).
        # The Duplex's terrace doors on a mobile scan at 100k points: the pier's face in 5
        # points 1-8 cm from the glazing's jamb, the door 13 cm wide
        on = (d > 0.01) & (d <= 0.15)
        if behind.any() or on.sum() < 4 or np.ptp(oth[on]) < span:
            return None
    return float(face[on].max() if take_max else face[on].min())


def _set_back(rev: np.ndarray, depth: np.ndarray, ctr: float, take_max: bool, tol: float) -> bool:
    """The jamb plane at ``ctr`` among the reveal points ``rev`` (``depth``: behind the nearer
    face) is a frame set into the hole: its points stand well behind the face (a tenth or
    fewer within 3 cm of the faces' noise tolerance ``tol``: the wall's own reveal runs up to
    the face, and a mobile scan's spilled face points fall near it), and the hole goes on
    outward of it (three points or more 2 cm or further out, as deep: the frame's front)."""
    on = np.abs(rev - ctr) <= 0.035
    out = ((rev < ctr - 0.02) if take_max else (rev > ctr + 0.02)) & (depth >= tol + 0.03)
    return bool(on.any() and np.mean(depth[on] < tol + 0.03) <= 0.1 and out.sum() >= 3)


def _face_end(coord, face, m, lo, hi, take_max, proud, behind: Optional[float] = None) -> Optional[tuple]:
    """Where the face points ``m`` (within [lo, hi]) end walking into the hole: the last one,
    and it plus the gap expected after it; ``face``: the band's face coordinates (the
    sampling's gap there), ``proud``: a casing's points; ``behind``: the face's sampling is
    measured on the hole's side of it (a wall abutting the face); None without points."""
    # walking from the face into the hole, the face ends at the first gap much wider than
    # the spacing of the points before it, with only strays (a tenth) beyond
    if not m.any():
        return None
    x = np.sort(coord[m] - lo if take_max else hi - coord[m])
    n = len(x)
    i = np.arange(n)
    sp = (x - x[np.maximum(i - 10, 0)]) / np.maximum(np.minimum(i, 10), 1)
    gap = np.append(np.diff(x), np.inf)
    end = np.flatnonzero((gap > np.maximum(4 * sp, 0.03)) & (i >= min(2, n - 1)) & (i >= 0.9 * n - 1))
    k = int(end[0]) if len(end) else n - 1
    # the last point falls short of the edge by the gap expected at a random place of the
    # sampling pattern, Σg² / 2Σg over the face's points up to 0.5 m behind it: half the
    # spacing of scan lines along the edge (a terrestrial scanner's columns beside a jamb,
    # 10-30 cm apart at 100k points: the mean gap between points, which the columns' own
    # points make small, read windows 5 cm too wide on average, up to 17), next to nothing
    # where lines run across the edge up to it
    # (the face of the next room behind a partition that abuts this face is not: the gap
    # across the partition's body is no gap of the sampling. FZK-Haus's front door at the end
    # of a 1.5 m hall, a terrestrial scan at 100k points: the door read 0.85-0.88 m for 1.01
    # — when the face between them shows its sampling: two scan lines or more)
    xa = face - lo if take_max else hi - face
    xa = np.sort(xa[(xa <= x[k] + 1e-9) & (xa >= x[k] - 0.5)])
    if behind is not None:
        own = xa[xa >= ((behind - lo) if take_max else (hi - behind))]
        if int((np.diff(own) > 0.01).sum()) >= 1:
            xa = own
    g = np.diff(xa)
    after = float((g * g).sum() / (2.0 * g.sum())) if len(g) >= 2 and g.sum() > 0 else float(sp[k])
    if proud is not None:
        xp = coord[m & proud] - lo if take_max else hi - coord[m & proud]
        if (xp >= x[k] - 0.01).any():
            after = float(sp[k])
    e = min(float(x[k] + after), hi - lo)
    return (lo + float(x[k]), lo + e) if take_max else (hi - float(x[k]), hi - e)


def near_points(a: np.ndarray, k: int = 3) -> np.ndarray:
    """Cells with a point within a k × k neighbourhood (boolean)."""
    return box_sum(a, k) > 0 if a.size else np.zeros(a.shape, bool)


def banded(face: np.ndarray, a: int, b: int, lo: int, hi: int, rb: int, p) -> bool:
    """``face``: (2, nu, nz) counts of a wall's two faces. The rows ``lo:hi`` are sampled
    thinly along the face beside columns ``a:b`` too (within ``band_flank`` either side: under
    ``band_share`` of the flanks' density over the wall's height): a band between a scanner's
    lines (a mobile scanner's rings leave one at its own height), not a hole."""
    f = int(round(p.band_flank / p.cell))
    nu, nz = face.shape[1:]
    cols = np.r_[max(0, a - f):a, b:min(nu, b + f)]
    if len(cols) == 0 or hi <= lo:
        return False
    face = face[:, cols].sum(axis=0)  # both faces
    rows = face[:, lo:hi].mean()
    return bool(rows < p.band_share * face[:, rb:max(rb + 1, nz - rb)].mean())


def hole_deficit(face: np.ndarray, a: int, b: int, lo: int, hi: int, p) -> float:
    """Face points missing over columns ``a:b``, rows ``lo:hi`` of a face (``face``: (nu, nz)
    counts): what the face holds per cell in the same rows within ``band_flank`` beside the
    hole, times the hole's columns, less what the hole holds.

    - Row by row, so that a mobile scanner's lines (bands of rows the face is sampled in, bands
      it is not) expect points only where a line crosses the hole.
    - By the sparser of the two flanks (one at least half as wide as ``band_flank``; 0 without
      one): a scanner passing close to one flank samples it far more densely than the hole."""
    f = int(round(p.band_flank / p.cell))
    nu = face.shape[0]
    if hi <= lo or b <= a:
        return 0.0
    flanks = [face[c0:c1, lo:hi] for c0, c1 in ((max(0, a - f), a), (b, min(nu, b + f)))
              if 2 * (c1 - c0) >= f]
    if not flanks:
        return 0.0
    expected = min(float(fl.mean(axis=0).sum()) for fl in flanks) * (b - a)
    return expected - float(face[a:b, lo:hi].sum())


def leaf_needed(face: np.ndarray, a: int, b: int, lo: int, hi: int, p) -> float:
    """The share of cells a closed leaf's points must reach (near them) over columns
    ``a:b``, rows ``lo:hi`` of a face (``face``: (nu, nz) counts): ``leaf_share`` of what
    the face itself reaches beside the hole (the better of its two ``leaf_flank`` flanks,
    same rows), at least ``leaf_floor``. A sparse scan (a mobile scanner's lines 15-30 cm
    apart at 100k points) leaves a flat face's cells only partly near a point, a leaf's
    as much, so a fixed share of the cells tells a closed door on dense scans only."""
    f = int(round(p.leaf_flank / p.cell))
    nu = face.shape[0]
    flanks = ((max(0, a - f), a), (b, min(nu, b + f)))
    ref = [float(near_points(face[c0:c1, lo:hi]).mean()) for c0, c1 in flanks if c1 > c0 and hi > lo]
    return p.leaf_share * min(1.0, max([p.leaf_floor] + ref))


def on_solid(solid: np.ndarray, u: np.ndarray, z: np.ndarray, w, c: float) -> np.ndarray:
    """(m,) bool: the face cells at ``u``, ``z`` (metres) within the wall (``length``,
    ``floor_z``, ``ceiling_z``) hold points near."""
    nu, nz = solid.shape
    inw = (u >= 0) & (u < w.length) & (z >= w.floor_z) & (z < w.ceiling_z)
    iu = np.clip((u / c).astype(np.int64), 0, nu - 1)
    iz = np.clip(((z - w.floor_z) / c).astype(np.int64), 0, nz - 1)
    return inw & solid[iu, iz]


def leaf_to_floor(dd, c0: int, c1: int, lo: int, hi: int, sides, p) -> bool:
    """A "window" over columns ``c0:c1`` whose bottom row is ``hi`` (``lo``: the raster's
    first row above the floor band) is a closed door's leaf seen down to the floor: on a leaf
    side (``sides``) the leaf covers the rows under it as a leaf must
    (:func:`leaf_needed`), more than the face does there. A sparse scan's few leaf points
    within the face tolerance, under kernels as wide as its spacing, made the face look
    present over the leaf's lower part (office_mw's closed door at 100k points: a 1.5 m
    "window" on a 0.6 m sill); a window's sill is wall under it, a face and no leaf."""
    if hi - lo < 2 or c1 - c0 < 2:
        return False
    for s in sides:
        leaf = float(near_points(dd.leaf[s][c0:c1, lo:hi]).mean())
        if leaf >= leaf_needed(dd.face[s], c0, c1, lo, hi, p) and \
                leaf > float(near_points(dd.face[s][c0:c1, lo:hi]).mean()):
            return True
    return False


def leaf_columns(dd, c0: int, c1: int, lo: int, hi: int, sides, p) -> tuple[int, int]:
    """Columns ``c0:c1`` widened to the closed leaf's under them: on a leaf side (``sides``),
    the neighbouring columns whose rows ``lo:hi`` a leaf covers as it must (:func:`leaf_needed`),
    up to ``max_door_width`` in all. A sparse scan's face kernels can leave only part of a
    leaf's width open above its lower part (office_mw's closed door at 100k points without
    scanner positions: a 0.25 m hole over a 0.9 m leaf, measured 0.59 m — under a door's
    least width — and left a "window")."""
    most = int(round(p.max_door_width / p.cell))
    best = (c0, c1)
    for s in sides:
        share = near_points(dd.leaf[s][:, lo:hi]).mean(axis=1) if hi > lo else np.zeros(0)
        need = leaf_needed(dd.face[s], c0, c1, lo, hi, p)
        a, b = c0, c1
        while a > 0 and b - a < most and share[a - 1] >= need:
            a -= 1
        while b < len(share) and b - a < most and share[b] >= need:
            b += 1
        a, b = min(c0, a + 1), max(c1, b - 1)  # less the cell the 3 × 3 nearness adds each side
        if b - a > best[1] - best[0]:
            best = (a, b)
    return best

