"""Free ends of walls as cuts of the Manhattan grid (issue 19: open plans).

The grid's cuts are the wall planes (docs/method.md §2): a wall that stops in the middle of a
storey — a partition ending in an open plan, a kitchen's wall open to the hall — gives no cut
across its line where it stops, so the cuboid on its line runs on past its end, is typed a
wall as a whole (its faces seen over enough of it), and splits the open plan in two (the
Duplex: the living room and kitchen apart from the foyer they open onto, along a partition
that stops 2.8 m short). :func:`free_wall_ends` finds where a wall's surface near the ceiling
stops for at least ``min_passage_width`` with the room running on along and across its line,
and cuts there; the part beyond the end is then typed on its own evidence (a ceiling over it:
a room; a beam or a lintel: :func:`.passages.wide_passages`), and :func:`heal_split_cells`
types the cuboids the cut splits elsewhere as they were. :class:`UpperBand` holds the points
near the ceiling that both read.
"""
from __future__ import annotations

import numpy as np

from ..elements.gaps import mask_runs
from ..model import ShapeType
from .params import ManhattanParams
from .place import StoreyFrame
from .rules import classify

__all__ = ["UpperBand", "free_wall_ends", "heal_split_cells"]

_BAND = (0.8, 0.95)
"""A wall's surface is read between these shares of the height up to the lowest ceiling: a
wall reaches up there, furniture (desks, cabinets, shelves) does not, and a door's lintel or
a beam over a wide opening does (it is no open stretch)."""
_MIN_COUNT = 1
"""A bin along a wall plane is surface when it holds at least this many of its points: any
(office_mw, mobile, 300k points: a wall's top seen at 0-2 points per 18 cm bin over 2 m; an
open stretch holds none)."""
_MIN_WALL = 0.2
"""A wall's stretch beside a free end is at least this long (metres): its end, not clutter."""
_FLOOR_SHARE = 0.5
"""The floor is seen along at least this share of an open stretch: it is inside the storey;
and the ceiling beside the wall's end on both sides of its plane."""
_JUNCTION_POINTS = 3
"""A wall across the line in the first metre past an end, near the ceiling, holds at least this
many points: the end is a junction."""
_CEILING_SPAN = 1.0
"""Metres past a wall's end over which the ceiling must run on, on both sides of its plane."""
_CEILING_REACH = 0.3
"""Ceiling and floor points in a band this wide beyond the wall's face on each side count
(metres)."""


class UpperBand:
    """The points of one storey facing x or y between 80 % and 95 % of its height up to the
    lowest ceiling (:data:`_BAND`), sorted by their position across each axis once, so that any
    plane's surface along it is a bisection away: a wall reaches up there, furniture does not,
    and a lintel or a beam over an opening does.

    p : (n, 3) float64, metres. along : per axis the (n,) bool mask of the points whose normal
    lies along it. frame : the storey's levels. params : grammar parameters (``shape_buffer``
    δ: a plane's points lie within it). spacing : σ (bins of max(5 cm, 2 σ))."""

    def __init__(self, p: np.ndarray, along: list, frame: StoreyFrame, params: ManhattanParams,
                 spacing: float):
        h = frame.ceilings[0] - frame.floor
        band = (p[:, 2] >= frame.floor + _BAND[0] * h) & (p[:, 2] <= frame.floor + _BAND[1] * h)
        self.d = float(params.shape_buffer)
        self.bin = max(0.05, 2.0 * float(spacing))
        self._axes = []
        for a in (0, 1):
            sel = np.flatnonzero(along[a] & band)
            sel = sel[np.argsort(p[sel, a])]  # slices of it go into histograms: any order
            self._axes.append((p[sel, a], p[sel, 1 - a]))

    def along(self, a: int, w: float) -> np.ndarray:
        """Positions along the plane at ``w`` on axis ``a`` of its points (within δ)."""
        t, u = self._axes[a]
        i0, i1 = np.searchsorted(t, [w - self.d, w + self.d])
        return u[i0:i1]

    def surface(self, a: int, w: float, edges: np.ndarray) -> np.ndarray:
        """(len(edges) - 1,) bool: the bins along the plane that hold a surface (at least
        :data:`_MIN_COUNT` points)."""
        return np.histogram(self.along(a, w), edges)[0] >= _MIN_COUNT

    def count(self, a: int, lo: float, hi: float, u_lo: float, u_hi: float) -> int:
        """Points facing axis ``a`` whose position on it lies in [lo, hi] and along their plane
        in [u_lo, u_hi]."""
        t, u = self._axes[a]
        i0, i1 = np.searchsorted(t, [lo, hi])
        return int(((u[i0:i1] >= u_lo) & (u[i0:i1] <= u_hi)).sum())

    def share(self, a: int, w: float, lo: float, hi: float) -> float:
        """Share of the bins of [lo, hi] along the plane that hold a surface."""
        n = max(int(round((hi - lo) / self.bin)), 1)
        return float(self.surface(a, w, np.linspace(lo, hi, n + 1)).mean())


def free_wall_ends(p: np.ndarray, along: list, ceiling: np.ndarray, cuts: list, frame: StoreyFrame,
                   params: ManhattanParams, upper: UpperBand) -> list[np.ndarray]:
    """Cuts at the free ends of the walls of one storey, per axis.

    Parameters
    ----------
    p : (n, 3) float64 — the storey's points, metres, z up. along : per axis x, y, z, the
        (n,) bool mask of the points whose normal lies along it.
    ceiling : (m, 2) float64 — x, y of the points on the storey's lowest ceiling.
    cuts : [X, Y] — the grid's cuts so far (wall planes and extent bounds), increasing.
    frame : the storey's floor and ceiling levels. params : grammar parameters.
    upper : the storey's :class:`UpperBand`.

    Returns
    -------
    [x, y] : the new cuts along x and along y, (m, 3) float64 arrays (unsorted, possibly empty)
    of the cut's position and the lowest and highest face plane of its wall (on the other
    axis: the grid columns of the wall's line, :func:`heal_split_cells`). A wall is the planes
    of ``cuts[a]`` chained at most ``max_wall_thickness`` apart; its faces' upper band
    (:class:`UpperBand`) is binned along it, and a bin with a point on any face is surface (a
    face in a shelf's or a scanner's shadow is no end). A run of bins without surface at
    least ``min_passage_width`` long, with floor points along at least half of it within
    ``max_wall_thickness`` of its mid-plane, ends the wall on each side where a surface of at
    least 20 cm (half of its bins surface) borders it and the storey runs on past the end on
    both sides of the wall: ceiling and floor points in at least half of the ``level_cell``
    bins of the first metre past the end, in 30 cm bands beyond its outer faces (no beam or
    lintel over the line, no stair void or unscanned room on one side, not outside an
    exterior wall's glazing), with no wall across the line there (points facing the other axis
    near the ceiling within 30 cm beside the wall's faces, clear of its own end face: a
    junction whose corner spoilt the wall's normals, a corridor crossing the line). That end
    (the wall's last point) is a cut across the other axis unless a cut lies within
    ``max_wall_thickness`` / 2 of it already.
    """
    out = [[], []]
    width = params.min_passage_width
    if width <= 0 or len(p) == 0:
        return [np.zeros((0, 3)), np.zeros((0, 3))]
    d, t_max = params.shape_buffer, params.max_wall_thickness
    floor = along[2] & (np.abs(p[:, 2] - frame.floor) <= d)
    b = upper.bin
    need = int(np.ceil(width / b))
    for a in (0, 1):
        o = 1 - a
        other = np.asarray(cuts[o], dtype=np.float64)
        if len(other) < 2:
            continue
        edges = np.arange(other[0], other[-1] + b, b)
        nb = len(edges) - 1
        if nb < need:
            continue
        fsel = np.flatnonzero(floor)
        fsel = fsel[np.argsort(p[fsel, a])]  # into histograms: any order of ties
        ft = p[fsel, a]
        floor_xy = p[fsel, :2]
        planes = np.asarray(cuts[a], dtype=np.float64)
        u_of = [upper.along(a, w) for w in planes]
        # a wall's faces: the planes chained at most a wall thickness apart; open where none has
        # surface (one face hidden behind a shelf or in a scanner's shadow is no end)
        chain = np.r_[0, np.cumsum(np.diff(planes) > t_max)]
        for g in range(int(chain[-1]) + 1 if len(planes) else 0):
            group = np.flatnonzero(chain == g)
            u = np.concatenate([u_of[q] for q in group])
            if not len(u):
                continue
            occ = np.histogram(u, edges)[0] >= _MIN_COUNT
            w = float(planes[group].mean())
            faces = (float(planes[group].min()) - d, float(planes[group].max()) + d)
            starts, stops = mask_runs(~occ)
            fl = None
            for r0, r1 in zip(starts.tolist(), stops.tolist()):
                if r1 - r0 < need:
                    continue
                if fl is None:
                    fl = np.histogram(p[fsel[slice(*np.searchsorted(ft, [w - t_max, w + t_max]))], o],
                                      edges)[0] > 0
                if fl[r0:r1].mean() < _FLOOR_SHARE:
                    continue
                for end, side in ((r0, -1), (r1, +1)):
                    if end == 0 or end == nb:
                        continue  # the gap runs to the storey's end: no wall beyond it there
                    k = int(np.ceil(_MIN_WALL / b))
                    wall = occ[max(end - k, 0):end] if side < 0 else occ[end:end + k]
                    if len(wall) < k or wall.mean() < 0.5:
                        continue
                    if side < 0:
                        pos = float(u[u < edges[r0]].max())
                        span = (pos, min(pos + _CEILING_SPAN, float(edges[r1])))
                    else:
                        pos = float(u[u >= edges[r1]].min())
                        span = (max(pos - _CEILING_SPAN, float(edges[r0])), pos)
                    if min(_two_sided_share(ceiling, a, faces, span, params.level_cell),
                           _two_sided_share(floor_xy, a, faces, span, params.level_cell)) < _FLOOR_SHARE:
                        continue
                    # a wall across the line there, beside the wall's faces and clear of its own
                    # end face: a junction (the corner spoilt the wall's normals near it) or a
                    # corridor crossing the line, not a free end
                    lo_o, hi_o = (pos + 2 * d, span[1]) if side < 0 else (span[0], pos - 2 * d)
                    across = upper.count(o, lo_o, hi_o, faces[0] - _CEILING_REACH, faces[0]) + \
                        upper.count(o, lo_o, hi_o, faces[1], faces[1] + _CEILING_REACH)
                    if across >= _JUNCTION_POINTS:
                        continue
                    near = np.r_[other, [e[0] for e in out[o]]]
                    if np.abs(near - pos).min() > t_max / 2:
                        out[o].append((pos, float(planes[group].min()), float(planes[group].max())))
    return [np.array(e, dtype=np.float64).reshape(-1, 3) for e in out]


def _two_sided_share(pts: np.ndarray, a: int, faces: tuple, span: tuple, cell: float) -> float:
    """The smaller, over the two sides of a wall whose faces lie at ``faces`` (low, high) on axis
    ``a``, of the share of the ``cell`` bins of ``span`` (along the other axis) with points of
    ``pts`` ((m, 2) x, y) in a 30 cm band beyond the face on that side."""
    o = 1 - a
    n = max(int(round((span[1] - span[0]) / cell)), 1)
    bins = np.linspace(span[0], span[1], n + 1)
    c = pts[:, a]
    return min(float((np.histogram(pts[side, o], bins)[0] > 0).mean())
               for side in ((c <= faces[0]) & (c >= faces[0] - _CEILING_REACH),
                            (c >= faces[1]) & (c <= faces[1] + _CEILING_REACH)))


def heal_split_cells(shapes: dict, types: np.ndarray, ends: list, X: np.ndarray, Y: np.ndarray,
                     params: ManhattanParams) -> None:
    """Cuboids split by a free wall end's cut away from that wall's line typed as one, in place.

    A cut at a wall's end runs across the whole storey; elsewhere it splits a room's cuboid in
    two, each typed on half the evidence (a sofa hiding the floor of the smaller half made a
    living room's corner an "eave"). Off the wall's line (grid columns whose centre lies
    outside the wall's faces), the cuboids joined across such cuts are typed as one by
    :func:`.rules.classify` when their types differ, from their combined point-on-face figures
    (length-weighted top, bottom and side faces along the cut's axis, the end faces of the
    first and last), top-down so that "top touches an interior shape" is known. The wall's
    line keeps its own types: that is what the cut is for.

    ``shapes`` / ``types`` : :func:`.manhattan.place_storey`'s classified cuboids, keyed and
    indexed (i, j, k). ``ends`` : :func:`free_wall_ends`'s result. X, Y : the grid's cuts.
    """
    cuts = [X, Y]
    nz = types.shape[2]
    lo_face, hi_face = {0: 5, 1: 2}, {0: 3, 1: 4}  # faces at the low / high end along an axis
    for o in (0, 1):
        if not len(ends[o]):
            continue
        a = 1 - o
        centres = (cuts[a][:-1] + cuts[a][1:]) / 2
        lengths = np.diff(cuts[o])
        transparent = {}  # cut index along o -> columns along a where it is not its wall's line
        for pos, lo, hi in ends[o]:
            jc = int(np.argmin(np.abs(cuts[o] - pos)))
            off = (centres < lo) | (centres > hi)
            transparent[jc] = transparent.get(jc, off) & off
        for i in range(len(centres)):
            j = 0
            while j < len(lengths):
                j1 = j
                while j1 + 1 < len(lengths) and j1 + 1 in transparent and transparent[j1 + 1][i]:
                    j1 += 1
                if j1 > j:
                    _heal_run(shapes, types, [(i, q) if o == 1 else (q, i) for q in range(j, j1 + 1)],
                              lengths[j:j1 + 1], o, lo_face[o], hi_face[o], nz, params)
                j = j1 + 1


def _heal_run(shapes, types, cells, lengths, o, f_lo, f_hi, nz, params) -> None:
    w = lengths / lengths.sum()
    side_faces = (3, 5) if o == 1 else (2, 4)
    for k in range(nz - 1, -1, -1):
        keys = [(i, j, k) for i, j in cells]
        if len({types[q] for q in keys}) == 1:
            continue
        sup = [shapes[q].support for q in keys]

        def avg(name, default=0.0):
            return float(sum(wi * s.get(name, default) for wi, s in zip(w, sup)))
        f = {0: avg("ipof_f0"), 1: avg("ipof_f1"), f_lo: sup[0].get(f"ipof_f{f_lo}", 0.0),
             f_hi: sup[-1].get(f"ipof_f{f_hi}", 0.0)}
        for q in side_faces:
            f[q] = avg(f"ipof_f{q}")
        b0, b1 = shapes[keys[0]].geometry.bounds, shapes[keys[-1]].geometry.bounds
        size = np.asarray(b1[1], dtype=float)[:2] - np.asarray(b0[0], dtype=float)[:2]
        tx, ty = bool(size[0] <= params.max_wall_thickness), bool(size[1] <= params.max_wall_thickness)
        sx, sy = (f[3] + f[5]) / 2, (f[2] + f[4]) / 2
        sides = max(sx, sy) if tx == ty else (sx if tx else sy)
        support = {f"ipof_f{q}": f[q] for q in range(6)}
        support.update(ipof_top=f[1], ipof_bottom=f[0], ipof_sides=float(sides))
        if k == 0:
            support["ipof_top_sparse"] = float(sum(wi * s.get("ipof_top_sparse", s.get("ipof_top", 0.0))
                                                   for wi, s in zip(w, sup)))
        above = k + 1 < nz and any(types[i, j, k + 1] == ShapeType.INTERIOR for i, j, _ in keys)
        typ, line = classify(support, tx or ty, above, params.tau, on_floor=k == 0,
                             min_evidence=params.min_room_evidence)
        for q in keys:
            if types[q] != typ:
                types[q] = typ
                shapes[q] = shapes[q].logged(
                    f"{line} (typed with the cuboids it was cut from at a free wall end)",
                    type=typ, terminal=typ != ShapeType.INTERIOR)
