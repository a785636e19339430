"""Rule 1, *place* ``I → N : H ≠ 0``: histogram peaks → grid intervals → cuboids.

Wall surfaces are peaks of the histograms of x and y of the points whose normal points
along that axis; floor and ceiling levels are peaks of the histogram of z of the points
with vertical normals. Peaks are measured in *area* (distinct σ-cells × σ²), not in raw
counts, so that the dense patch right under a terrestrial scanner is no peak. A wall's
second face seen over little of its area is kept when it faces away from a strong face
within a wall's thickness (:func:`paired_faces`).

Storeys and levels. A horizontal level is a **ceiling** when most of its cells have no
other horizontal surface above them within the storey, a **floor** when most have none
below; a level with surfaces both above and below (a desk, a shelf) is neither and makes
no cut. The storeys are the z ranges between consecutive floor → top-ceiling pairs.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..geometry.boxes import column_min
from .params import ManhattanParams

__all__ = ["Peak", "Level", "StoreyFrame", "histogram_peaks", "paired_faces", "with_partner", "detect_levels",
           "storey_chunks", "storey_frame"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Peak:
    """A surface found in a histogram: ``position`` (metres) and ``area`` (m²)."""

    position: float
    area: float


@dataclass(frozen=True)
class Level:
    """A horizontal surface level: z (metres), area (m²), share of cells with nothing
    above (``exposed_up``) and nothing below (``exposed_down``) in the storey."""

    z: float
    area: float
    exposed_up: float
    exposed_down: float


@dataclass(frozen=True)
class StoreyFrame:
    """One storey's vertical cuts: ``floor`` z, ``ceilings`` (increasing z), metres."""

    floor: float
    ceilings: tuple

    @property
    def ceiling(self) -> float:
        """The highest ceiling level, z metres."""
        return float(self.ceilings[-1])

    @property
    def cuts(self) -> np.ndarray:
        """(k + 1,) float64 — floor then every ceiling level: the z edges of the cuboids."""
        return np.array([self.floor, *self.ceilings], dtype=np.float64)


def _area_profile(t: np.ndarray, uv: np.ndarray, edges: np.ndarray, spacing: float) -> np.ndarray:
    """Area (m²) of distinct σ-cells per histogram bin. t (n,), uv (n, 2) metres."""
    nb = len(edges) - 1
    if len(t) == 0 or nb <= 0:
        return np.zeros(max(nb, 0))
    b = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, nb - 1)
    key = np.unique(_cell_keys(uv, spacing, b))
    span = _key_span(uv, spacing)
    return np.bincount(key // span, minlength=nb).astype(np.float64) * spacing**2


def _key_span(uv: np.ndarray, cell: float) -> int:
    c = np.floor(uv / cell).astype(np.int64)
    return int((c[:, 0].max() - c[:, 0].min() + 1) * (c[:, 1].max() - c[:, 1].min() + 1))


def _cell_keys(uv: np.ndarray, cell: float, group: np.ndarray) -> np.ndarray:
    """One int64 per (group, cell) pair: ``group * span + cell index`` (1D keys make
    ``np.unique`` fast). ``uv`` (n, 2) metres, ``group`` (n,) int ≥ 0."""
    c = np.floor(uv / cell).astype(np.int64)
    c -= column_min(c)
    w = int(c[:, 1].max()) + 1
    return group.astype(np.int64) * _key_span(uv, cell) + c[:, 0] * w + c[:, 1]


def histogram_peaks(t: np.ndarray, uv: np.ndarray, params: ManhattanParams, spacing: float,
                    min_area: float, lo: float | None = None, hi: float | None = None) -> list[Peak]:
    """Peaks of an area histogram along one axis.

    Parameters
    ----------
    t : (n,) float64 — coordinate along the axis, metres.
    uv : (n, 2) float64 — the two other coordinates, metres (for the cell areas).
    min_area : smallest surface a peak must hold, m².
    lo, hi : optional range of t.

    Returns the peaks, increasing, each refined to the mean t of the points within a
    bin and a half of it and merged with any neighbour closer than ``min_interval``.
    """
    if len(t) == 0:
        return []
    bs = params.bin_size
    lo = float(t.min()) if lo is None else lo
    hi = float(t.max()) if hi is None else hi
    edges = np.arange(lo - bs, hi + 2 * bs, bs)
    prof = _area_profile(t, uv, edges, spacing)
    win = np.convolve(prof, np.ones(3), mode="same")  # one surface spreads over 1-3 bins
    cand = np.flatnonzero(win >= min_area)
    peaks: list[Peak] = []
    order = cand[np.argsort(-win[cand], kind="stable")]
    taken = np.zeros(len(win), dtype=bool)
    sep = max(int(np.ceil(params.min_interval / bs)), 1)
    for c in order:  # non-maximum suppression, strongest first
        if taken[max(c - sep, 0):c + sep + 1].any():
            continue
        taken[c] = True
        centre = (edges[c] + edges[c + 1]) / 2
        for _ in range(3):  # refine on the points near the peak
            near = np.abs(t - centre) <= 1.5 * bs
            if not near.any():
                break
            centre = float(np.mean(t[near]))
        peaks.append(Peak(centre, float(win[c])))
    peaks.sort(key=lambda p: p.position)
    merged: list[Peak] = []
    for p in peaks:
        if merged and p.position - merged[-1].position < params.min_interval:
            q = merged[-1]
            w = q.area + p.area
            merged[-1] = Peak((q.position * q.area + p.position * p.area) / w, max(q.area, p.area))
        else:
            merged.append(p)
    return merged


_SPAN_CELL = 0.1
"""Cells (metres) along a wall in which :func:`paired_faces` compares the extents of two faces."""


def _face_side_and_span(t: np.ndarray, sign: Optional[np.ndarray], along: np.ndarray, position: float,
                        bs: float) -> tuple[int, set]:
    """The side (+1 / −1 along the axis) a surface at ``position`` is seen from — the sign
    most of its points' oriented normals agree on (``sign`` (n,), the normals' component along
    the axis; None: not known, 1), 0 when fewer than 10 points or no clear majority (80 %) —
    and the cells of ``_SPAN_CELL`` along the wall (``along`` (n,), metres) its points
    occupy."""
    near = np.abs(t - position) <= 1.5 * bs
    if int(near.sum()) < 10:
        return 0, set()
    m = 1.0 if sign is None else float(np.mean(np.sign(sign[near])))
    span = set(np.unique(np.floor(along[near] / _SPAN_CELL).astype(np.int64)).tolist())
    return (int(np.sign(m)) if abs(m) >= 0.6 else 0), span


def _back_to_back(t: np.ndarray, along: np.ndarray, z: np.ndarray, a: float, b: float, bs: float,
                  reach: float) -> bool:
    """Without oriented normals: whether the surfaces at ``a`` and ``b`` (positions along the
    axis) are open away from each other — where both have points (columns of ``_SPAN_CELL``
    along the wall and in height), most points of each have surfaces facing the axis within
    ``reach`` on the other's side only (the other face, 10-50 cm behind) and none on their
    own (the room before them). A partition's two faces are; a surface with a cabinet's front
    before it is not (it has surfaces on both sides there)."""
    key = np.floor(along / _SPAN_CELL).astype(np.int64) * 100_003 + np.floor(z / _SPAN_CELL).astype(np.int64)
    band = 1.5 * bs
    on = [np.abs(t - c) <= band for c in (a, b)]
    common = np.intersect1d(key[on[0]], key[on[1]])
    for c, o, m in ((a, b, on[0]), (b, a, on[1])):
        k = key[m]
        k = k[np.isin(k, common)]
        if len(k) < 10:
            return False
        d = (t - c) * np.sign(o - c)  # > 0 towards the other face
        towards = np.isin(k, key[(d > band) & (d <= reach)])
        away = np.isin(k, key[(d < -band) & (d >= -reach)])
        if np.mean(towards & ~away) < 0.8:
            return False
    return True


def paired_faces(strong: list, t: np.ndarray, uv: np.ndarray, sign: Optional[np.ndarray],
                 params: ManhattanParams, spacing: float, weak: list | None = None,
                 partners: Optional[dict] = None) -> list:
    """``strong`` (histogram peaks of one axis) with the second faces of their walls.

    A partition's second face is often seen over little of its area (furniture in front of
    it, a room the scanner only looked into): below ``min_wall_area`` it makes no cut, the
    rooms on both sides meet at the first face and the partition and its door are lost
    (issue 16). A weaker surface (at least ``min_paired_wall_area``) is kept when it is the
    other side of a strong one:

    * it lies behind it, at most ``max_wall_thickness`` away;
    * the two are seen from opposite sides, each facing away from the other (the wall's
      body lies between them): clutter before a wall is seen from the wall's own side;
    * it runs along the wall at least twice ``max_wall_thickness`` (a door's or window's
      jamb, as deep as its wall, faces the same axis), and at least half of its length lies
      where the strong face has points too (the two faces of one wall span the same stretch);
    * no strong peak lies between the two, nor within ``max_wall_thickness`` beyond the weak
      one: there the wall already has a second cut, and one more would only split a thin
      interval into thinner strips, whose ceiling and floor are too narrow to be seen (on
      sparse scans they then turn exterior inside a room).

    ``t`` (n,) the points' coordinate along the axis, ``uv`` (n, 2) the other horizontal one
    and z, ``sign`` (n,) their oriented normals' component along the axis (normals facing the
    scanner), or None without scanner positions (:func:`_back_to_back` then tells the sides);
    ``weak``: the peaks of the same points at ``min_paired_wall_area`` when the
    caller has them already. ``partners``: when given, filled with each added face's position
    -> the position of the strong face it is the other side of."""
    if not strong or params.min_paired_wall_area >= params.min_wall_area:
        return strong
    bs = params.bin_size
    reach = params.max_wall_thickness + 2.0 * bs
    have = np.array([pk.position for pk in strong])
    along = uv[:, 0]
    stats = {}
    added = []
    if weak is None:
        weak = histogram_peaks(t, uv, params, spacing, params.min_paired_wall_area)
    for w in weak:
        gaps = w.position - have
        if np.abs(gaps).min() < params.min_interval:
            continue  # a strong peak already
        fw, span = _face_side_and_span(t, sign, along, w.position, bs)
        if fw == 0 or len(span) * _SPAN_CELL < 2 * params.max_wall_thickness:
            continue
        for pk, gap in zip(strong, gaps):
            if not params.min_interval <= abs(gap) <= params.max_wall_thickness:
                continue
            if pk.position not in stats:
                stats[pk.position] = _face_side_and_span(t, sign, along, pk.position, bs)
            fp, strong_span = stats[pk.position]
            # no strong cut between the two, none within a wall's thickness beyond the weak one
            # (a cut there would only split a thin interval into thinner strips)
            rel = (have - pk.position) * np.sign(gap)  # along the way from the strong face to the weak
            if np.any((rel > 1e-9) & (rel < abs(gap) - 1e-9)) or \
                    np.any((rel > abs(gap) + 1e-9) & (rel <= abs(gap) + params.max_wall_thickness)):
                continue
            # each seen from its own side, facing away from the other, along the same stretch
            if sign is None:  # and the strong face has no other face already (within a wall's
                # thickness on its far side: its other face seen sparsely looks open)
                partnered = np.any((rel <= -params.min_interval) & (rel >= -params.max_wall_thickness))
                apart = not partnered and _back_to_back(t, along, uv[:, 1], pk.position, w.position, bs, reach)
            else:
                apart = fp * gap < 0 and fw * gap > 0
            if apart and len(span & strong_span) >= 0.5 * len(span):
                added.append(w)
                if partners is not None:
                    partners[w.position] = pk.position
                log.debug("second face at %.3f (%.2f m²) behind the wall face at %.3f", w.position, w.area,
                          pk.position)
                break
    return sorted(strong + added, key=lambda pk: pk.position)


def with_partner(x: float, partners: dict, up: dict) -> bool:
    """A wall's second face seen too little near the ceiling (a sparse scan sees a partition's
    far side obliquely) is a wall when the face it is the other side of reaches the ceiling
    and no other second face of that one stands nearer it: a cabinet against that side has its
    front further off."""
    pk = partners.get(x)
    return pk is not None and up.get(pk, False) and not any(
        q == pk and 0 < (y - pk) / (x - pk) < 1 for y, q in partners.items())


def detect_levels(xyz_h: np.ndarray, params: ManhattanParams, spacing: float) -> list[Level]:
    """Horizontal levels of the points with vertical normals, with their exposure.

    ``xyz_h`` : (n, 3) float64 — points on horizontal surfaces, metres.
    """
    peaks = histogram_peaks(xyz_h[:, 2], xyz_h[:, :2], params, spacing, params.min_level_area)
    if not peaks:
        return []
    buf = max(params.shape_buffer, 1.5 * params.bin_size)
    cell = params.level_cell
    c = np.floor(xyz_h[:, :2] / cell).astype(np.int64)
    c -= c.min(axis=0)
    keys = c[:, 0] * (int(c[:, 1].max()) + 1) + c[:, 1]
    cells_of = [np.unique(keys[np.abs(xyz_h[:, 2] - p.position) <= buf]) for p in peaks]
    levels = []
    for i, p in enumerate(peaks):
        mine = cells_of[i]
        above = np.concatenate(cells_of[i + 1:]) if i + 1 < len(peaks) else np.zeros(0, np.int64)
        below = np.concatenate(cells_of[:i]) if i > 0 else np.zeros(0, np.int64)
        n = max(len(mine), 1)
        levels.append(Level(p.position, p.area, float(np.sum(~np.isin(mine, above))) / n,
                            float(np.sum(~np.isin(mine, below))) / n))
    return levels


def storey_chunks(z: np.ndarray, uv: np.ndarray, params: ManhattanParams, spacing: float) -> list[tuple]:
    """Split the z range at slabs: runs of bins that hold almost no surface.

    ``z`` : (n,) float64 and ``uv`` : (n, 2) float64 — all points, metres. Inside a slab
    nothing is scanned, so a run of z bins at least ``min_slab_thickness`` long whose
    area is below ``slab_gap_share`` of the median bin area separates two storeys.
    Returns ``[(z_lo, z_hi), ...]`` increasing (one chunk when there is no slab).
    """
    if len(z) == 0:
        return []
    bs = params.bin_size
    lo, hi = float(z.min()), float(z.max())
    edges = np.arange(lo, hi + bs, bs)
    if len(edges) < 3:
        return [(lo, hi)]
    prof = _area_profile(z, uv, edges, spacing)
    nz = prof[prof > 0]
    gap = prof < params.slab_gap_share * (np.median(nz) if len(nz) else 0.0)
    need = max(int(np.ceil(params.min_slab_thickness / bs)), 1)
    chunks, start, i = [], 0, 0
    while i < len(gap):
        if gap[i]:
            j = i
            while j < len(gap) and gap[j]:
                j += 1
            if j - i >= need and i > start and j < len(gap):
                chunks.append((float(edges[start]), float(edges[i])))
                start = j
            i = j
        else:
            i += 1
    chunks.append((float(edges[start]), hi))
    return [c for c in chunks if c[1] - c[0] >= params.min_storey_height]


def storey_frame(levels: list[Level], params: ManhattanParams):
    """The storey of one chunk: its floor and ceiling levels, or None.

    The floor is the lowest level with ``exposed_down ≥ level_exposed`` (nothing below
    it) and at least ``floor_share`` of the largest such level's area (the ground outside a
    door, seen through it 5 cm under FZK-Haus's floor, made a 3 m² level under the 90 m²
    floor at 1M points: the rooms' floors then lay above the storey's and none was seen,
    every room went), the ceilings are the levels at least ``min_storey_height`` above the
    floor with ``exposed_up ≥ level_exposed`` (nothing above them). Levels that are neither
    (desks, shelves, beds) make no cut. Without a clear floor or ceiling the lowest / highest
    level is taken.
    """
    if len(levels) < 2:
        return None
    thr = params.level_exposed
    floors = [lv for lv in levels if lv.exposed_down >= thr] or [levels[0]]
    big = max(lv.area for lv in floors)
    floor = next(lv for lv in floors if lv.area >= params.floor_share * big)
    above = [lv for lv in levels if lv.z - floor.z >= params.min_storey_height]
    if not above:
        return None
    ceilings = [lv for lv in above if lv.exposed_up >= thr] or [above[-1]]
    return StoreyFrame(float(floor.z), tuple(float(c.z) for c in ceilings))


def given_frame(levels: list, storey: tuple, params: ManhattanParams) -> StoreyFrame | None:
    """The frame of a storey found by the preprocessing whose own levels give none: the top of
    an attic under a pitched roof (the preprocessing follows its points up to the ridge) is no
    horizontal level when its flat strip, seen at a grazing angle, holds under
    ``min_level_area`` in σ-cells (FZK-Haus's attic at 1M points: σ 4 cm, the ridge 1.5 m²;
    at 300k, σ 7 cm, 2.7 m²), and the storey was dropped. Its floor is the exposed level
    nearest the given floor (within half a storey), else the given floor; its ceiling the
    given top. ``storey`` : (floor_z, ceiling_z) metres. None when lower than a storey."""
    f, c = storey
    if c - f < params.min_storey_height:
        return None
    near = [lv.z for lv in levels if abs(lv.z - f) <= params.min_storey_height / 2
            and lv.exposed_down >= params.level_exposed]
    floor = min(near, key=lambda z: abs(z - f)) if near else f
    if c - floor < params.min_storey_height:
        return None
    log.info("storey at z = %.2f: no ceiling level of its own; the preprocessing's top %.2f m", floor, c)
    return StoreyFrame(float(floor), (float(c),))
