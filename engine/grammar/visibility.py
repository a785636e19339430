"""Cuboids seen through from inside (docs/method.md §2, classify; issue 19: "not seen" is not
"not there"). A helper of :func:`engine.grammar.manhattan.place_storey`.

A room seen only at a glance from a scanner's walk past its door has a ceiling covered far
below τ (three_storey_house, mobile: the east half of a bedroom, 0.11 of its ceiling seen), so
its cuboids are typed exterior and the building's outline ran through the middle of the room.
Yet the room's far walls were seen: the rays from the scanner to those wall points crossed the
cuboid, through free air inside the building. :func:`seen_through` finds the exterior cuboids
on the floor whose far walls were so seen — from a scanner standing in an interior cuboid of
the storey, along rays that cross only interior cuboids and no seen face (a wall with a door
or a window in it) before they enter the cuboid, over at least τ of one of its walls; such a
cuboid may be a room's part wider than a pocket (:func:`.passages.enclosed_pockets`, which
still requires it closed all round by walls and rooms and open to a room). Rays from a scanner
outside the building, or through a window or a door, prove nothing: a courtyard or a terrace
seen through glazing stays outside.

Without scanner positions, stand-in scanners stand in the interior cuboids
(:func:`engine.elements.viewpoints.room_viewpoints`) and a point is seen from those whose
line to it crosses no occupied voxel of the scan (:func:`engine.elements.viewpoints.visible_pairs`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..model import ShapeType, Storey
from .ipof import grid_face_index
from .params import ManhattanParams
from .passages import _SIDES
from .place import StoreyFrame

__all__ = ["Views", "seen_through"]

_OPPOSITE = {2: 4, 3: 5, 4: 2, 5: 3}


@dataclass(frozen=True)
class Views:
    """Where the scan was taken from, in the grammar's frame: ``positions`` (k, 3) float64
    scanner origins, metres, and ``scan_index`` (n,) int each point's scanner (-1 unknown; None
    with a single scanner); ``positions`` None: unknown (stand-in scanners)."""

    positions: Optional[np.ndarray] = None
    scan_index: Optional[np.ndarray] = None

    def rays(self, idx: np.ndarray, pts: np.ndarray, storey: int, frame: StoreyFrame, cells: list,
             occupied_xyz: np.ndarray):
        """(row into ``idx``, origin (m, 3)) of every ray to the points ``idx`` (at ``pts``):
        the real scanners', or stand-ins' in ``cells`` (interior footprints (x0, y0, x1, y1)) whose
        line of sight crosses no occupied voxel of ``occupied_xyz``."""
        if self.positions is not None:
            sp = np.asarray(self.positions, dtype=np.float64).reshape(-1, 3)
            if self.scan_index is None:
                if len(sp) != 1:
                    return np.zeros(0, np.int64), np.zeros((0, 3))
                return np.arange(len(idx)), np.repeat(sp, len(idx), axis=0)
            si = np.full(len(idx), -1, np.int64)
            known = idx < len(self.scan_index)  # points added to the storey (roof undersides): none
            si[known] = np.asarray(self.scan_index)[idx[known]]
            ok = np.flatnonzero((si >= 0) & (si < len(sp)))
            return ok, sp[si[ok]]
        from shapely.geometry import box

        from ..elements.params import ViewpointParams
        from ..elements.viewpoints import occupancy, room_viewpoints, visible_pairs

        vp = ViewpointParams()
        occ = occupancy(occupied_xyz, vp)
        st = Storey(storey, float(frame.floor), float(frame.ceiling))
        views = room_viewpoints({storey: {q: box(*c) for q, c in enumerate(cells)}}, [st], occ, vp)
        if len(views) == 0:
            return np.zeros(0, np.int64), np.zeros((0, 3))
        pt, v = visible_pairs(pts, views, vp, occ)
        return pt, views[v]


def _cells_along(o: np.ndarray, e: np.ndarray, X: np.ndarray, Y: np.ndarray):
    """The grid cells each plan segment o → e (m, 2) crosses, in order: (m, c) int arrays
    i, j of the cell of each stretch between successive cuts (-1 past the end of the
    segment or outside the grid)."""
    d = e - o
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = (X[None, :] - o[:, :1]) / d[:, :1]
        ty = (Y[None, :] - o[:, 1:]) / d[:, 1:]
    t = np.concatenate([tx, ty], axis=1)
    t = np.where(np.isfinite(t) & (t > 0) & (t < 1), t, np.inf)
    t = np.sort(np.concatenate([np.zeros((len(o), 1)), t, np.ones((len(o), 1))], axis=1), axis=1)
    a, b = t[:, :-1], t[:, 1:]
    live = np.isfinite(b) & (b > a)
    mid = np.where(live, (a + np.where(np.isfinite(b), b, a)) / 2, 0.0)
    q = o[:, None, :] + mid[..., None] * d[:, None, :]
    i = np.searchsorted(X, q[..., 0], side="right") - 1
    j = np.searchsorted(Y, q[..., 1], side="right") - 1
    inside = live & (i >= 0) & (i < len(X) - 1) & (j >= 0) & (j < len(Y) - 1)
    return np.where(inside, i, -1), np.where(inside, j, -1), live


def _clear_rays(o: np.ndarray, e: np.ndarray, target: tuple, room: np.ndarray, seen: np.ndarray,
                X: np.ndarray, Y: np.ndarray):
    """(m,) bool: the plan ray o → e (ending inside cuboid ``target`` (i, j)) starts in an
    interior cuboid, crosses only interior cuboids (``room`` (nx, ny) bool) up to ``target``
    and no face seen (``seen`` (4, nx, ny) bool, side faces 2 … 5) between two of them or into
    ``target``; and (m,) int the side face of ``target`` through which it enters (2 … 5)."""
    I, J, live = _cells_along(o, e, X, Y)
    Ic, Jc = np.maximum(I, 0), np.maximum(J, 0)
    at = live & (I == target[0]) & (J == target[1])
    # every stretch up to the target lies in an interior cuboid, and from it on in the target
    before = np.cumsum(at, axis=1) == 0
    ok = ~np.any(live & before & ((I < 0) | ~room[Ic, Jc]), axis=1)
    ok &= ~np.any(live & ~before & ~at, axis=1) & at.any(axis=1) & ~at[:, 0]
    # no seen face crossed between two successive stretches, no corner crossed
    step = live[:, 1:] & ((I[:, 1:] != I[:, :-1]) | (J[:, 1:] != J[:, :-1]))
    di, dj = I[:, 1:] - I[:, :-1], J[:, 1:] - J[:, :-1]
    entry = np.full(len(o), -1)
    into = step & at[:, 1:]
    for f, a, b in _SIDES:
        ok &= ~np.any(step & (di == a) & (dj == b) & seen[f - 2][Ic[:, :-1], Jc[:, :-1]], axis=1)
        entry[np.any(into & (di == a) & (dj == b), axis=1)] = _OPPOSITE[f]
    return ok & ~np.any(step & (np.abs(di) + np.abs(dj) != 1), axis=1), entry


def seen_through(shapes: dict, types: np.ndarray, xyz: np.ndarray, normals: np.ndarray, X: np.ndarray,
                 Y: np.ndarray, frame: StoreyFrame, storey: int, params: ManhattanParams, spacing: float,
                 margin: float, views: Optional[Views]) -> dict:
    """Exterior cuboids on the floor whose far walls were seen through them from inside:
    {(i, j): the side faces (2 … 5) through which the rays entered}, where at least τ of one
    side face was so seen.

    Candidates (floor layer, exterior, nothing interior above, wider than a wall both ways, some
    floor or ceiling seen: IPoF(bottom) or IPoF(top) > ``min_room_evidence``): each side face
    seen at all (IPoF > ``min_room_evidence``) is measured again (:func:`.ipof.grid_face_index`)
    over only its points whose ray (:meth:`Views.rays`) is clear (:func:`_clear_rays`: from an
    interior cuboid through interior cuboids and unseen faces into the candidate). ``xyz``,
    ``normals`` : the storey's points and unit normals (the grammar's frame); ``views`` None: no
    test (empty)."""
    if views is None:
        return {}
    nx, ny, nz = types.shape
    tau, d, t_max = params.tau, float(params.shape_buffer), params.max_wall_thickness
    low = params.min_room_evidence
    wide = np.minimum(np.diff(X)[:, None], np.diff(Y)[None, :]) > t_max
    room = np.array([[types[i, j, 0] == ShapeType.INTERIOR for j in range(ny)] for i in range(nx)], bool)
    cand = []
    for i, j in zip(*np.nonzero(wide & ~room)):
        s = shapes[(i, j, 0)]
        if types[i, j, 0] != ShapeType.EXTERIOR or \
                any(types[i, j, k] == ShapeType.INTERIOR for k in range(1, nz)):
            continue
        if max(s.support.get("ipof_bottom", 0.0), s.support.get("ipof_top", 0.0)) > low and \
                any(s.support.get(f"ipof_f{f}", 0.0) > low for f, _, _ in _SIDES):
            cand.append((int(i), int(j)))
    if not cand or not (room & wide).any():
        return {}
    seen = np.zeros((4, nx, ny), bool)  # per side face (2 … 5) of the floor layer: seen at τ or more
    for (i, j, k), s in shapes.items():
        if k == 0:
            seen[:, i, j] = [s.support.get(f"ipof_f{f}", 0.0) >= tau for f in range(2, 6)]
    z0, z1 = frame.floor, frame.cuts[1]  # the floor layer
    in_storey = (xyz[:, 2] >= z0 - d) & (xyz[:, 2] <= frame.ceiling + d)
    lower = np.flatnonzero(in_storey & (xyz[:, 2] >= z0) & (xyz[:, 2] <= z1))
    cos_t = np.cos(params.normal_angle)
    faces = []  # (cuboid, face, axis, plane, its points)
    for (i, j) in cand:
        lo, hi = np.array([X[i], Y[j]]), np.array([X[i + 1], Y[j + 1]])
        for f, di, dj in _SIDES:
            if shapes[(i, j, 0)].support.get(f"ipof_f{f}", 0.0) <= low:
                continue
            a, q = (0 if di else 1), lower
            w = hi[a] if (di + dj) > 0 else lo[a]
            on = q[(np.abs(xyz[q, a] - w) <= d) & (np.abs(normals[q, a]) >= cos_t)
                   & (xyz[q, 1 - a] >= lo[1 - a]) & (xyz[q, 1 - a] <= hi[1 - a])]
            if len(on):
                faces.append(((i, j), f, a, w, lo, hi, on))
    if not faces:
        return {}
    every = np.unique(np.concatenate([fc[-1] for fc in faces]))
    cells = [(X[i], Y[j], X[i + 1], Y[j + 1]) for i, j in zip(*np.nonzero(room & wide))]
    row, origin = views.rays(every, xyz[every], storey, frame, cells, xyz[in_storey])
    keep = (origin[:, 2] >= z0) & (origin[:, 2] <= frame.ceiling)
    pt, origin = every[row[keep]], origin[keep]
    best, out = {}, {}
    for (c, f, a, w, lo, hi, on) in faces:
        m = np.isin(pt, on)
        if not m.any():
            continue
        end = xyz[pt[m], :2].copy()
        end[:, a] = w - (1 if f in (3, 4) else -1) * 1e-6  # onto the face, just inside the cuboid
        clear, entry = _clear_rays(origin[m, :2], end, c, room, seen, X, Y)
        pts = np.unique(pt[m][clear])
        if len(pts) == 0:
            continue
        o = 1 - a
        share = float(grid_face_index(xyz[pts][:, (o, 2)], np.array([lo[o], hi[o]]), np.array([z0, z1]),
                                      spacing, margin)[0, 0])
        if share >= tau and share > best.get(c, 0.0):
            best[c], out[c] = share, tuple(sorted(set(entry[clear].tolist())))
    return out
