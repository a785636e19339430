"""Doors, doorless openings and windows in reconstructed wall runs (docs/method.md §7.3).

Each wall run is looked at in its own frame: ``u`` along ``axis_line`` (metres from its
start), ``v`` across (+ towards the left side, ``n`` = axis rotated +90°), ``z`` up. One
pass over a 2-D grid of the cloud gives each wall the points near it; each wall then gets
rasters in its ``(u, z)`` plane (:attr:`OpeningParams.cell`): points on each *face*; points
*inside* the thickness (jambs, heads, sills, thresholds, glazing, recessed door leaves);
points *in front* of each face (furniture); and, with scanner positions, a ray test — the
segment from a scanner to a point beyond the wall crosses the face plane in a cell *seen
through*; a point just in front of the face, projected from the scanner, *shadows* a cell.

A gap is where a face has no points while it is observed around it (density-adaptive
kernels); on interior walls seen from both sides it must be a gap on both faces. Gaps are
cut to rectangles, merged when noise split them, measured from their jambs, lintel and
sill (reveal planes, else where the face points end) and classified: reaching the floor
with wall above, a door (wider than :attr:`OpeningParams.max_door_width`, or up to the
ceiling: a doorless "opening"); wall below and above, a window. A gap is kept when the
evidence says hole, not shadow: rays through it, points beyond an exterior wall, the gap on
both faces, floor points through the thickness, reveal points at its edges; and no
furniture shadowing it (the ray test; without scanners, points in front covering it). A
door-sized gap on one face with a planar leaf a few centimetres behind it is a closed door
(``"open": False``).

Cost: the grid pass is linear in the points, a wall's rasters follow its area, and the ray
test visits per scanner the points in the angular sector of each wall face it sees.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Optional, Sequence

import numpy as np
from scipy import ndimage

from ..errors import InputError
from ..geometry.boxes import column_max, column_min, min_area_box
from ..geometry.sort import stable_argsort
from ..model import Polyhedron, Shape, ShapeType, Storey
from .gaps import (banded, box_sum, face_present, gap_rectangles, head_across, hole_deficit, hole_edge,
                   leaf_columns, leaf_needed, leaf_to_floor, near_points, observed_columns, on_solid, round_hole)
from .inputs import checked
from .junctions import abutting, clear_of, hidden_columns
from .leaves import flush_leaves
from .overlap import admit, overlap
from .params import OpeningParams
from .sills import floor_under, level_sill, low_quantile, meet, split_by_bottom
from .viewpoints import group_members

__all__ = ["OpeningParams", "detect_openings"]


# ----------------------------------------------------------------------------- wall frames
@dataclass
class _Wall:
    """A wall run's frame: start ``p0``, unit axis ``d`` and normal ``n`` (left), metres."""

    shape: Shape
    p0: np.ndarray
    d: np.ndarray
    n: np.ndarray
    length: float
    thickness: float
    floor_z: float
    ceiling_z: float
    external: bool
    sides: tuple
    faces: np.ndarray = None  # (2,) v of the left and right face, metres
    top: float = math.inf     # the wall's own top (its rooms' ceiling; ≤ ceiling_z), metres


def _storey_of(shape: Shape, storeys: Sequence[Storey]) -> tuple[float, float]:
    """Floor and ceiling z of a wall's storey (by index, else position; else its own z)."""
    st = next((st for st in storeys if st.index == shape.storey), None)
    st = st or (storeys[shape.storey] if 0 <= shape.storey < len(storeys) else None)
    return (float(st.floor_z), float(st.ceiling_z)) if st else tuple(float(z) for z in shape.bounds[:, 2])


def _frame(shape: Shape, storeys: Sequence[Storey]) -> _Wall:
    """The wall's frame from ``axis_line`` / ``thickness`` (else its footprint's box)."""
    a = shape.attributes
    axis = a.get("axis_line")
    if axis is not None:
        try:
            axis, thick = np.asarray(axis, dtype=np.float64).reshape(2, 2), float(a.get("thickness", 0.0))
        except (TypeError, ValueError):
            raise InputError(f"wall {shape.id!r}: axis_line must be [[x0, y0], [x1, y1]], "
                             "thickness a number") from None
    else:
        origin, axes, size = min_area_box(shape.geometry.vertices)
        x, y = axes[0, :2], axes[1, :2]
        mid = origin[:2] + y * size[1] / 2
        axis = np.stack([mid, mid + x * size[0]])
        thick = float(a.get("thickness", size[1]))
    if not (np.all(np.isfinite(axis)) and math.isfinite(thick) and thick > 0):
        raise InputError(f"wall {shape.id!r}: axis_line and thickness must be finite, thickness > 0")
    length = float(np.hypot(*(axis[1] - axis[0])))
    if length <= 0:
        raise InputError(f"wall {shape.id!r}: axis_line has zero length")
    d = (axis[1] - axis[0]) / length
    sides = (tuple(a.get("sides") or ()) + (None, None))[:2]
    z0, z1 = _storey_of(shape, storeys)
    try:  # the wall's own top (its rooms' ceiling) where it has one, else its storey's
        top = float(a.get("ceiling_z", z1))
    except (TypeError, ValueError):
        raise InputError(f"wall {shape.id!r}: ceiling_z must be a number") from None
    top = top if math.isfinite(top) and z0 < top <= z1 else z1
    return _Wall(shape, axis[0], d, np.array([-d[1], d[0]]), length, thick, z0, z1,
                 bool(a.get("external", False)), sides, top=top)


def _bucket(xyz: np.ndarray, walls: list[_Wall], reach: float, cell: float) -> list[np.ndarray]:
    """Indices of the points near each wall (within ``reach`` of a face, its storey ± reach):
    one sort of the points by 2-D grid cell, then per wall the cells its widened footprint
    covers."""
    xy = xyz[:, :2]
    lo = column_min(xy)
    ij = np.floor((xy - lo) / cell).astype(np.int64)
    nx, ny = column_max(ij) + 1
    key = ij[:, 0] * ny + ij[:, 1]
    order = stable_argsort(key)
    skey, h, out = key[order], cell * 0.7072, []
    for w in walls:
        half = w.thickness / 2 + reach
        ends = np.array([w.p0 - w.d * reach, w.p0 + w.d * (w.length + reach)])
        corners = np.vstack([ends + w.n * half, ends - w.n * half])
        i0, j0 = np.maximum(np.floor((corners.min(axis=0) - lo) / cell).astype(int), 0)
        i1, j1 = np.minimum(np.floor((corners.max(axis=0) - lo) / cell).astype(int), [nx - 1, ny - 1])
        if i1 < i0 or j1 < j0:
            out.append(np.zeros(0, np.int64))
            continue
        gi, gj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="ij")
        gi, gj = gi.ravel(), gj.ravel()
        c = lo + (np.column_stack([gi, gj]) + 0.5) * cell - w.p0
        uc, vc = c @ w.d, c @ w.n
        keep = (np.abs(vc) <= half + h) & (uc >= -reach - h) & (uc <= w.length + reach + h)
        keys = gi[keep] * ny + gj[keep]
        s, e = np.searchsorted(skey, keys, "left"), np.searchsorted(skey, keys, "right")
        cnt = e - s  # the cells' runs of sorted points, concatenated
        idx = order[np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt) + np.repeat(s, cnt)]
        p = xyz[idx]
        rel = p[:, :2] - w.p0
        u, v = rel @ w.d, rel @ w.n
        ok = ((u >= 0) & (u < w.length) & (np.abs(v) <= half)
              & (p[:, 2] >= w.floor_z - reach) & (p[:, 2] <= w.ceiling_z + reach))
        out.append(np.sort(idx[ok]))
    return out


# ----------------------------------------------------------------------------- faces
def _face_fit(r: np.ndarray, u: np.ndarray, z: np.ndarray, length: float,
              window: float) -> tuple[float, float, int]:
    """Offset and robust spread (metres) of the face in residuals ``r`` (within ``window``
    of the nominal face) of points at ``u`` along the wall, height ``z``; the offset is 0 and
    the count 0 when the peak covers less than a third of the wall (25 cm squares): a door
    leaf, the jambs of an outer face never seen, a cupboard side are not the face."""
    keep = np.abs(r) < window
    r, u, z = r[keep], u[keep], z[keep]
    if len(r) < 30:
        return 0.0, float("nan"), 0
    bins = np.arange(-window, window + 1e-9, 0.005)
    hist, _ = np.histogram(r, bins)
    hist = ndimage.convolve1d(hist, [1, 2, 3, 2, 1], mode="constant")
    peak = float((bins[:-1] + 0.0025)[int(np.argmax(hist))])
    near = np.abs(r - peak) < 0.06
    peak = float(np.median(r[near]))
    mad = float(np.median(np.abs(r[near] - peak))) * 1.4826
    on = np.abs(r - peak) < max(0.015, 2.0 * mad)
    nb, zb = max(1, int(math.ceil(length / 0.25))), np.floor((z - z.min()) / 0.25).astype(np.int64)
    sq = np.clip((u[on] / 0.25).astype(np.int64), 0, nb - 1) * (zb.max() + 1) + zb[on]
    if np.count_nonzero(np.bincount(sq) >= 3) < nb * (zb.max() + 1) / 3:
        return 0.0, float("nan"), 0
    return peak, mad, int(near.sum())


# ----------------------------------------------------------------------------- per-wall evidence
@dataclass
class _Data:
    """The rasters of one wall: ``(2, nu, nz)`` per side (0 = left, 1 = right), ``(nu, nz)``
    otherwise; counts of points per cell."""

    face: np.ndarray
    inside: np.ndarray
    floor: np.ndarray          # (nu,) floor points inside the thickness
    bottom: np.ndarray         # (nu,) per column, the lowest points inside the thickness
                               # up to 0.4 m (their 20th percentile z), NaN without any
    low_face: np.ndarray       # (nu,) vertical points on a face plane just above the floor
                               # (a sill's face under a window; a doorway has none)
    front: np.ndarray          # points in front of each face, projected perpendicularly
    leaf: np.ndarray           # points leaf_depth behind each face
    through: np.ndarray        # ray test: cells seen through from each side
    shadow: np.ndarray         # ray test: cells hidden by points in front
    behind: np.ndarray         # ray test: cells hidden by another wall (the scanner stands behind it)
    fu: np.ndarray             # u, z of the face and inside points, metres
    fz: np.ndarray
    fcls: np.ndarray           # 0 / 1: on the left / right face, 2: inside the thickness
    fdev: np.ndarray           # depth behind the face (face points; < 0 in front), metres
    scans: list                # per side: face points per scanner
    rays: bool = False
    stand_in: bool = False     # the rays come from stand-in scanners (lines of sight), not a scan
    hidden: np.ndarray = None  # (nu,) columns where another wall stands against a face
    cross: object = None       # (u, z) where rays through the wall crossed a face (metres): a list
                               # of arrays during the ray test, one (k, 2) array after it


def _analyse(w: _Wall, idx: np.ndarray, xyz, normals, scan_count, tol: float,
             p: OpeningParams) -> _Data:
    """The wall's rasters; ``scan_count`` (point indices → points per scanner) or None."""
    c = p.cell
    nu = max(1, int(math.ceil(w.length / c)))
    nz = max(1, int(math.ceil((w.ceiling_z - w.floor_z) / c)))
    pts = xyz[idx]
    rel = pts[:, :2] - w.p0
    u, v, z = rel @ w.d, rel @ w.n, pts[:, 2]
    iu = np.clip((u / c).astype(np.int64), 0, nu - 1)
    iz = np.floor((z - w.floor_z) / c).astype(np.int64)
    inz = (iz >= 0) & (iz < nz)
    flat = iu * nz + np.clip(iz, 0, nz - 1)
    core = (z > w.floor_z + p.edge_band) & (z < w.ceiling_z - p.edge_band)
    vl, vr = w.faces
    t = min(tol, 0.45 * (vl - vr))
    vertical = np.ones(len(idx), bool)
    if normals is not None:
        vertical = np.abs(normals[idx, :2] @ w.n) >= 0.5
    on = [(np.abs(v - vl) < t) & vertical & core & inz, (np.abs(v - vr) < t) & vertical & core & inz]
    # the face whose edges measure a hole reaches further into the room: a door's casing
    # stands proud of the plaster (the gaps are found on the plaster's plane alone)
    tp = max(t, p.face_proud)
    edge = [on[0] | ((v >= vl + t) & (v < vl + tp) & vertical & core & inz),
            on[1] | ((v <= vr - t) & (v > vr - tp) & vertical & core & inz)]
    inside = (v < vl - t) & (v > vr + t)
    front = [(v > vl + t) & (v <= vl + p.reach), (v < vr - t) & (v >= vr - p.reach)]
    low = np.abs(z - w.floor_z) < p.edge_band
    mid = (z > w.floor_z + max(p.edge_band, 0.1)) & (z < w.ceiling_z - max(p.edge_band, 0.1)) & inz
    d0, d1 = p.leaf_depth
    d0 = max(d0, t)  # nearer than the face tolerance is the face
    leaf = [(vl - v >= d0) & (vl - v <= d1) & (v > vr + t), (v - vr >= d0) & (v - vr <= d1) & (v < vl - t)]

    def raster(mask):
        return np.bincount(flat[mask], minlength=nu * nz).reshape(nu, nz).astype(np.float64)

    scans = [np.zeros(0, np.int64) if scan_count is None else scan_count(idx[on[s]]) for s in (0, 1)]
    # the reveals up to the ceiling: a head's soffit may stand less than edge_band under it
    either = edge[0] | edge[1] | (inside & (z > w.floor_z + p.edge_band) & inz)
    return _Data(face=np.stack([raster(on[0]), raster(on[1])]),
                 inside=raster(inside & core & inz),
                 floor=np.bincount(iu[inside & low], minlength=nu).astype(np.float64),
                 bottom=low_quantile(iu, z - w.floor_z, inside & (z > w.floor_z - p.edge_band)
                                      & (z < w.floor_z + 0.4), nu),
                 low_face=np.bincount(iu[((np.abs(v - vl) < t) | (np.abs(v - vr) < t)) & vertical
                                         & (z > w.floor_z + 0.03) & (z <= w.floor_z + p.edge_band)],
                                      minlength=nu).astype(np.float64),
                 front=np.stack([raster(front[0] & mid), raster(front[1] & mid)]),
                 leaf=np.stack([raster(leaf[0] & core & inz), raster(leaf[1] & core & inz)]),
                 through=np.zeros((2, nu, nz)), shadow=np.zeros((2, nu, nz)),
                 behind=np.zeros((2, nu, nz)), cross=[],
                 fu=u[either], fz=z[either], scans=scans,
                 fcls=np.where(edge[0], 0, np.where(edge[1], 1, 2))[either].astype(np.int8),
                 fdev=np.where(edge[0], vl - v,  # inside the thickness: behind the nearer face
                               np.where(edge[1], v - vr, np.minimum(vl - v, v - vr)))[either])


def _wall_of_points(walls: list[_Wall], idx: list, xyz: np.ndarray, tol: float) -> np.ndarray:
    """(n,) int: the index of a wall whose thickness (between its faces, ``tol`` out, along its
    run, within its storey) holds each point, -1 for none."""
    out = np.full(len(xyz), -1, np.int64)
    for k, (w, ii) in enumerate(zip(walls, idx)):
        rel = xyz[ii, :2] - w.p0
        v, z = rel @ w.n, xyz[ii, 2]
        out[ii[(v <= w.faces[0] + tol) & (v >= w.faces[1] - tol) & (z >= w.floor_z) & (z <= w.ceiling_z)]] = k
    return out


def _behind_wall(walls: list[_Wall], wall_of: np.ndarray, S: np.ndarray, cell_xy: np.ndarray,
                 tol: float) -> np.ndarray:
    """(m,) bool: the ray from scanner ``S`` through an occluder inside wall ``wall_of`` (-1:
    none) reaches its face cell (``cell_xy``) only through that wall: scanner and cell lie on
    its two sides, each clear of its thickness."""
    out = np.zeros(len(wall_of), bool)
    for k in np.unique(wall_of[wall_of >= 0]):
        sel = wall_of == k
        w2 = walls[int(k)]
        mid, half = (w2.faces[0] + w2.faces[1]) / 2, (w2.faces[0] - w2.faces[1]) / 2 + tol
        ds = float((S[:2] - w2.p0) @ w2.n) - mid
        dc = (cell_xy[sel] - w2.p0) @ w2.n - mid
        out[sel] = (abs(ds) > half) & (np.abs(dc) > half) & (np.sign(dc) != np.sign(ds))
    return out


def _ray_test(walls: list[_Wall], data: list[_Data], xyz, scan_index, scanners, tol: float,
              p: OpeningParams, wall_of: Optional[np.ndarray] = None, stand_in: bool = False) -> None:
    """Fill ``through`` / ``shadow`` of each wall face from the scanners that see it.

    A point in front of a face shadows the cell its ray would reach; when the ray reaches
    that cell only through another wall (``wall_of``: the wall holding each point) the
    scanner stands behind that wall and does not see the face there at all: such cells go
    to ``behind``, not ``shadow`` (see :func:`_judge`)."""
    k_n = len(scanners)
    per_scan = np.bincount(scan_index[(scan_index >= 0) & (scan_index < k_n)], minlength=k_n)
    need: dict[int, list] = {}
    floor_n = np.maximum(5, np.minimum(p.min_scan_points, 0.005 * per_scan))
    for wi, dd in enumerate(data):
        for s in (0, 1):
            if len(dd.scans[s]) == 0:
                continue
            # a scanner with a few points on the face may see it mostly through its holes (a
            # glazed wall): its rays through the face count when they are many (below)
            for k in np.flatnonzero(dd.scans[s] >= (floor_n if stand_in else 1)):
                need.setdefault(int(k), []).append((wi, s))
    if not need:
        return
    order = stable_argsort(scan_index)
    starts = np.searchsorted(scan_index[order], np.arange(k_n + 1))
    c = p.cell
    solid = ([[near_points(dd.face[0]), near_points(dd.face[1]), near_points(dd.inside)] for dd in data]
             if stand_in else None)
    for k, pairs in need.items():
        sel_k = order[starts[k]:starts[k + 1]]
        pts = xyz[sel_k]
        wall_k = np.full(len(sel_k), -1, np.int64) if wall_of is None else wall_of[sel_k]
        S = np.asarray(scanners[k], np.float64)
        az = np.arctan2(pts[:, 1] - S[1], pts[:, 0] - S[0])
        o = np.argsort(az)
        az_s = az[o]
        for wi, s in pairs:
            w, dd = walls[wi], data[wi]
            sg = 1.0 if s == 0 else -1.0
            vf, vo = w.faces[s], w.faces[1 - s]
            rs = S[:2] - w.p0
            a_s, u_s = sg * (rs @ w.n), rs @ w.d
            a_n, a_f = sg * vf, sg * vo
            if a_s <= a_n + tol:
                continue  # the scanner stands in the wall (a door) or behind the face
            e0 = w.p0 + w.n * vf - S[:2]
            e1 = e0 + w.d * w.length
            t0, t1 = sorted((math.atan2(e0[1], e0[0]), math.atan2(e1[1], e1[0])))
            if t1 - t0 <= math.pi:
                ranges = [(t0, t1)]
            else:
                ranges = [(t1, math.pi), (-math.pi, t0)]
            sel = np.concatenate([o[np.searchsorted(az_s, a):np.searchsorted(az_s, b, "right")]
                                  for a, b in ranges])
            if len(sel) == 0:
                continue
            q = pts[sel]
            rq = q[:, :2] - w.p0
            a_q, u_q = sg * (rq @ w.n), rq @ w.d
            thr = a_q < a_f - tol
            if stand_in and thr.any():
                # a line of sight, not a ray: it passes the faces and the thickness only where
                # they have no points (a sparse face leaves gaps between voxels; a door's leaf)
                i_t = np.flatnonzero(thr)
                hit = np.zeros(len(i_t), bool)
                planes = ((a_n, solid[wi][s]), (a_f, solid[wi][1 - s]), ((a_n + a_f) / 2, solid[wi][2]))
                for a_x, sol in planes:
                    lam_x = (a_s - a_x) / (a_s - a_q[i_t])  # where the line crosses that plane
                    hit |= on_solid(sol, u_s + lam_x * (u_q[i_t] - u_s), S[2] + lam_x * (q[i_t, 2] - S[2]),
                                    w, c)
                thr[i_t[hit]] = False
            occ = (a_q > a_n + tol) & (a_q < min(a_s - 0.05, a_n + p.reach))  # furniture near the face
            m = thr | occ
            if not m.any():
                continue
            lam = (a_s - a_n) / (a_s - a_q[m])
            uc = u_s + lam * (u_q[m] - u_s)
            zc = S[2] + lam * (q[m, 2] - S[2])
            ok = (uc >= 0) & (uc < w.length) & (zc >= w.floor_z) & (zc < w.ceiling_z)
            nu, nz = dd.through.shape[1:]
            flat = (np.clip((uc[ok] / c).astype(np.int64), 0, nu - 1) * nz
                    + np.clip(((zc[ok] - w.floor_z) / c).astype(np.int64), 0, nz - 1))
            is_thr = thr[m][ok]
            glance = dd.scans[s][k] < floor_n[k]  # it sees the face through its holes, if at all:
            if glance and is_thr.sum() < p.min_scan_points:  # as many rays through as a face's points
                continue
            dd.through[s] += np.bincount(flat[is_thr], minlength=nu * nz).reshape(nu, nz)
            dd.cross += [] if stand_in else [np.c_[uc[ok][is_thr], zc[ok][is_thr]]]
            if glance:
                continue  # its rays through count, not its few points' shadows
            shade, wk = ~is_thr, wall_k[sel][m][ok]
            other = shade & (wk >= 0) & (wk != wi)
            if other.any():
                cell_xy = w.p0 + np.outer(uc[ok][other], w.d) + w.n * vf
                hid = np.flatnonzero(other)[_behind_wall(walls, wk[other], S, cell_xy, tol)]
                shade[hid] = False
                dd.behind[s] += np.bincount(flat[hid], minlength=nu * nz).reshape(nu, nz)
            dd.shadow[s] += np.bincount(flat[shade], minlength=nu * nz).reshape(nu, nz)
            dd.rays = True


# ----------------------------------------------------------------------------- gaps
def _gap_rects(dd: _Data, p: OpeningParams, external: bool = False, hidden=None) -> tuple[list, list]:
    """Candidate rectangles (full-raster cells) with their mode ("both": a hole through every
    observed face; 0 / 1: a gap on that face only), and the per-side observed columns; no
    gap in the columns another wall covers on either face (``hidden``, (2, nu) bool)."""
    c = p.cell
    nz = dd.face.shape[2]
    r_lo = int(math.ceil(p.edge_band / c))
    r_hi = max(r_lo + 1, nz - r_lo)
    run = int(round(p.unobserved_run / c))
    cols = [dd.face[s][:, r_lo:r_hi].sum(axis=1) + dd.through[s][:, r_lo:r_hi].sum(axis=1) for s in (0, 1)]
    obs = observed_columns(cols, run, int(round(p.density_window / c)) | 1, ends=external)
    empty = [~face_present(dd.face[s][:, r_lo:r_hi], p) for s in (0, 1)]
    solid = (dd.face[0][:, r_lo:r_hi] > 0) | (dd.face[1][:, r_lo:r_hi] > 0)  # a transom's points
    o0, o1 = obs
    free = np.ones(len(o0), bool) if hidden is None else ~(hidden[0] | hidden[1])
    both = (empty[0] | ~o0[:, None]) & (empty[1] | ~o1[:, None]) & (o0 | o1)[:, None] & free[:, None]
    out = [((a, b, r0 + r_lo, r1 + r_lo), "both") for a, b, r0, r1 in gap_rectangles(both, p, solid)]
    for s in (0, 1):
        if obs[1 - s].any():  # a face-only gap where the other face is there: a closed door?
            single = empty[s] & obs[s][:, None] & ~empty[1 - s] & free[:, None]
            out += [((a, b, r0 + r_lo, r1 + r_lo), s) for a, b, r0, r1 in gap_rectangles(single, p, solid)]
    return out, obs


def _inner_faces(obs, c0: int, c1: int, outer: list) -> list:
    """The faces (0 left, 1 right) observed over most of columns c0..c1, outer faces left out."""
    return [s for s in (0, 1) if s not in outer and obs[s][c0:c1].mean() > 0.5]


def _measure(w: _Wall, dd: _Data, rect, side, outer: list, obs, tol: float, leafy: bool,
             p: OpeningParams) -> Optional[tuple]:
    """Edges (u0, u1, bottom z, top z; metres) and kind of a candidate rectangle of cells, from
    the jambs, head and sill inside the thickness, else from where the face points end (a
    closed door's leaf is no reveal; a one-face gap is measured on that face); None when
    it is no door, opening or window."""
    c, srch = p.cell, p.edge_search
    c0, c1, r0, r1 = rect
    z0, z1 = w.floor_z, w.ceiling_z
    ul, ur, zb, zt = c0 * c, c1 * c, z0 + r0 * c, z0 + r1 * c
    floor_reach, ceil_reach = zb - z0 <= p.floor_tolerance, z1 - zt <= p.ceiling_tolerance
    cls = dd.fcls
    keep = (cls == side) if side is not None else (cls == 2) | np.isin(cls, _inner_faces(obs, c0, c1, outer))
    keep &= (dd.fdev < tol / 2) | (cls == 2)  # the face's core and casings: few strays from a leaf behind it
    if leafy:
        keep &= cls != 2
    fu, fz, fin = dd.fu[keep], dd.fz[keep], cls[keep] == 2
    dev = dd.fdev[keep]
    proud = dev < -min(tol, 0.45 * (w.faces[0] - w.faces[1]))  # a casing's
    zlo, zhi = (z0 + p.edge_band if floor_reach else zb) + 0.05, zt - 0.05
    cr = dd.cross  # where rays passed the faces
    pu = cr[(cr[:, 1] >= zlo) & (cr[:, 1] <= zhi), 0]
    bl, br = abutting(dd.hidden, c0, c1, c, 0.5 + srch)
    el = hole_edge(fu, fz, fin, ul - srch, ul + c, zlo, zhi, True, tol, proud, dev, pu, bl)
    er = hole_edge(fu, fz, fin, ur - c, ur + srch, zlo, zhi, False, tol, proud, dev, pu, br)
    if floor_reach and side is None:  # a doorway's gap run out to the wall's end: a stub past
        # its jamb unseen against the wall met there, the jamb inside the gap (the Duplex's
        # 0.86 m hallway doors 10 cm from a junction: 10 cm too wide, their reveal seen)
        if el is None and ul - c <= 0.0:
            el = hole_edge(fu, fz, fin, ul - c, ul + srch, zlo, zhi, True, tol, proud, dev, pu, bl)
        if er is None and ur + c >= w.length:
            er = hole_edge(fu, fz, fin, ur - srch, ur + c, zlo, zhi, False, tol, proud, dev, pu, br)
    el = max(ul - c if el is None else max(el, ul - srch), 0.0)  # not past the run's ends
    er = min(ur + c if er is None else min(er, ur + srch), w.length)
    if dd.hidden is not None:  # ... nor into a wall standing against a face
        el, er = clear_of(dd.hidden, el, er, c0, c1, c)
    if er <= el:
        return None
    across = (el + 0.05, er - 0.05)
    pz = cr[(cr[:, 0] >= across[0]) & (cr[:, 0] <= across[1]), 1]
    et = z1 if ceil_reach else hole_edge(fz, fu, fin, zt - c, zt + srch, *across, False, tol, proud, dev, pz)
    head_seen = et is not None
    et = zt + c if et is None else et
    eb = z0 if floor_reach else hole_edge(fz, fu, fin, zb - srch, zb + c, *across, True, tol, proud, dev, pz)
    if (eb is None and side is None and not leafy and zb - z0 <= p.unseen_bottom
            and floor_under(dd, el, er, p)):
        floor_reach, eb = True, z0  # a door's lower part unseen, the floor seen through its thickness
    eb = zb - c if eb is None else eb
    rnd = not (floor_reach or ceil_reach) and round_hole(fu, fz, fin, el, er, eb, et, tol, proud, dev, p)
    if rnd:
        el, er, eb, et = max(rnd[0], 0.0), min(rnd[1], w.length), rnd[2], rnd[3]
    width = er - el
    if floor_reach and side is None and not leafy:
        # the material under the hole: the floor through a doorway, a sill's top under a window
        ia, ib = max(0, int(el / c)), max(0, int(math.ceil(er / c)))
        cols = dd.bottom[ia:ib]
        seen = cols[np.isfinite(cols)]
        # a hole too low for a door needs less: a few columns (a sill seen grazing) tell a low window
        low_hole = et - z0 < p.min_door_height
        if len(seen) >= (p.min_sill_columns if low_hole else max(2, 0.5 * len(cols))):
            if float(np.median(seen)) >= p.min_sill:
                floor_reach, eb = False, z0 + float(np.median(seen))
        elif (sill := level_sill(dd.bottom[ia + 1:ib - 1], dd.floor[ia + 1:ib - 1], p)) is not None:
            # a sparse scan's sill, seen between the jambs (a jamb's column holds the jamb's
            # lowest points, at any height: the Duplex's 0.86 m doors read a "sill" at 0.28 m)
            floor_reach, eb = False, z0 + sill
        elif ib - ia > 2 and float((dd.low_face[ia + 1:ib - 1] > 0).mean()) >= 0.6:
            # the sill's top unseen, its face seen right above the floor all along the hole
            top = hole_edge(fz, fu, fin, z0, zb + c, el + 0.05, er - 0.05, True)
            floor_reach, eb = False, max(z0 + p.min_sill, zb - c if top is None else top)
    mid = (max(across[0], el + 0.15), min(across[1], er - 0.15))  # the hole 15 cm clear of its jambs
    if floor_reach and not ceil_reach and side is None and not leafy and et - z0 < p.min_door_height \
            and not head_across(fu, fz, et if head_seen else None, mid, c):
        # too low for a door, with no point over the gap up to the search's end but the jambs'
        # own: a sparse face's kernel closed it from those, and the head is the first face
        # above them, away from the jambs (the Duplex's terrace doors on mobile scans at 100k
        # points: the gap's top at 1.0 m, where the jamb and the pier beside it showed points)
        lo = (et if head_seen else zt) + c
        top = hole_edge(fz, fu, fin, lo, z1, *mid, False, tol, proud, dev, pz) if mid[1] > mid[0] else None
        et = et if top is None else top
    if floor_reach:
        if not p.min_door_width <= width <= p.max_opening_width:
            return None
        if et - z0 < p.min_door_height:
            return None  # too low to walk through, however wide (a strip under furniture)
        if ceil_reach or width > p.max_door_width or min(w.top, z1) - et <= p.ceiling_tolerance:
            return el, er, z0, et, "opening"
        return el, er, z0, et, "door"
    if ceil_reach:
        # the raster leaves out the band under the ceiling (``edge_band``), so a window whose
        # head stands a few centimetres under it (glazing up to the ceiling) reaches the
        # raster's top: its head's soffit, a plane inside the thickness, tells it from a hole
        # up to the ceiling (whose ceiling runs on over the thickness, at the ceiling)
        et = hole_edge(fz[fin], fu[fin], fin[fin], zt - c, zt + srch, el + 0.05, er - 0.05, False)
        if et is None or z1 - et < p.min_head:
            return None
    if not p.min_window_width <= width <= p.max_opening_width or et - eb < p.min_window_height:
        return None
    return el, er, eb, et, "window"


def _judge(w: _Wall, dd: _Data, rect, mode, obs, tol: float, p: OpeningParams) -> Optional[dict]:
    """Measure a candidate, classify it and weigh its evidence; None when it is no opening.

    Confidence: up to 0.5 for rays seen through it, 0.25 for a gap on both faces of an
    interior wall, 0.2 for an unshadowed hole in an exterior wall, 0.15 each for floor points
    through the thickness and for reveals, 0.2 (no scanners, exterior wall) for points
    beyond it, 0.15 (a window in an exterior wall) for the face points the hole lacks on an
    observed face (``hole_points``), 0.45 for a closed door's leaf; less the shadowed share
    times the share of its edges without reveals (or, without scanners, the covered share)."""
    c = p.cell
    nu, nz = dd.face.shape[1:]
    rb = int(math.ceil(p.edge_band / c))
    c0, c1, r0, r1 = rect
    outer = [s for s in (0, 1) if w.sides[s] is None] if w.external else []
    if w.external and not outer:
        outer = [int(np.argmin([obs[0][c0:c1].mean(), obs[1][c0:c1].mean()]))]
    side = mode if mode != "both" else None
    leaf_sides = [side] if side is not None else [s for s in (0, 1) if s not in outer]
    leafy = any(float(near_points(dd.leaf[s][c0:c1, max(rb, r0):r1]).mean())
                >= leaf_needed(dd.face[s], c0, c1, max(rb, r0), r1, p) for s in leaf_sides)
    m = _measure(w, dd, rect, side, outer, obs, tol, leafy, p)
    if m and m[4] == "window" and leafy and \
            leaf_to_floor(dd, c0, c1, rb, hs := int(round((m[2] - w.floor_z) / c)), leaf_sides, p):
        a, b = leaf_columns(dd, c0, c1, rb, hs, leaf_sides, p)  # the leaf's width, to the floor
        m = _measure(w, dd, (a, b, rb, r1), side, outer, obs, tol, leafy, p) or m
    elif m and m[4] == "door" and side is not None and leafy:  # a closed door: as wide as its leaf
        a, b = leaf_columns(dd, c0, c1, rb, int(round((m[3] - w.floor_z) / c)), leaf_sides, p)
        if (a, b) != (c0, c1):
            m = _measure(w, dd, (a, b, rb, r1), side, outer, obs, tol, leafy, p) or m
    if m is None or (side is not None and m[4] != "door"):
        return None
    el, er, eb, et, kind = m
    z0 = w.floor_z
    # cells of the measured rectangle, one cell in from its edges
    a = int(np.clip(round(el / c) + 1, 0, nu - 1))
    b = int(np.clip(round(er / c) - 1, a + 1, nu))
    lo = max(rb, int(round((eb - z0) / c)) + 1)
    hi = int(np.clip(round((et - z0) / c) - 1, lo + 1, nz))
    cells = (slice(a, b), slice(lo, hi))
    seen = near_points(dd.through[0][cells] + dd.through[1][cells])
    band = dd.stand_in and banded(dd.face, a, b, lo, hi, rb, p)
    if band:
        seen = np.zeros_like(seen)  # a stand-in's line through a thinly sampled band proves nothing
    elif dd.stand_in and kind == "door":  # ... nor one between a leaf's points
        seen &= ~near_points(dd.leaf[0][cells] + dd.leaf[1][cells])
    f_through = float(seen.mean())
    reached = seen | near_points(dd.inside[cells])  # a leaf, glazing or reveal was hit there
    shade = dd.shadow[0][cells] + dd.shadow[1][cells]
    if kind == "opening":
        # a scanner behind another wall does not see the face: no shadow on a door or window
        # there (the Duplex's glazed terrace door whose jamb meets the partition between the
        # living room and the foyer read 41 % shadowed by that partition's far face, seen
        # from the foyer); a wide floor-to-ceiling "opening" gets no such pass (below): the
        # walls' shadows still tell it from the gap a model leaves beside a stair's void
        shade = shade + dd.behind[0][cells] + dd.behind[1][cells]
    f_occ = float((near_points(shade) & ~reached).mean())
    f_front = max([float(near_points(dd.front[s][cells]).mean()) for s in _inner_faces(obs, a, b, outer)],
                  default=0.0)
    n_beyond = 0 if band else (int(sum(dd.front[s][cells].sum() for s in outer))
                               + int(dd.through[:, a:b, lo:hi].sum()))  # nor points beyond it
    both = (not w.external) and obs[0][a:b].mean() > 0.8 and obs[1][a:b].mean() > 0.8
    f_floor = float((box_sum(dd.floor[a:b, None], 3)[:, 0] > 0).mean()) if kind != "window" else 0.0
    # reveals: jambs, head and sill inside the thickness, well above the noise spilling from
    # the faces (the wall's inside points per face point, times the face points there)
    spill = float(dd.inside.sum()) / max(float(dd.face.sum()), 1.0)
    ie, je = int(round(el / c)), int(round(er / c))
    strips = [np.s_[max(0, ie - 2):ie + 2, lo:hi], np.s_[max(0, je - 2):je + 2, lo:hi]]
    for zz, there in ((et, w.ceiling_z - et > 1e-6), (eb, kind == "window")):
        if there:
            r = int(round((zz - z0) / c))
            strips.append(np.s_[a:b, max(0, r - 2):r + 2])
    f_reveal = float(np.mean([dd.inside[st].sum() >= max(2.0, 3.0 * spill * dd.face[:, st[0], st[1]].sum())
                              for st in strips]))
    cover = [(float(near_points(dd.leaf[s][cells]).mean()), leaf_needed(dd.face[s], a, b, lo, hi, p))
             for s in leaf_sides]  # the leaf's cover of the hole on a face, and what it needs there
    f_leaf = max([f for f, _ in cover], default=0.0)
    occluded = f_occ >= p.max_occluded if dd.rays else f_front >= p.max_front_cover
    if dd.stand_in:  # a stand-in's projection may exaggerate a shadow: the cover in front says so too
        occluded = occluded and f_front >= p.max_front_cover
    # a half-shadowed door or window is no occlusion when rays pass through it and its jambs
    # and head stand inside the thickness: a shadow has neither (the shadowed share still
    # lowers the confidence); a wide "opening" may be a door joined to the shadow beside it,
    # one a door wide is a door whose lintel the scan missed (docs/method.md §7.3)
    occluded &= not ((kind != "opening" or er - el <= p.max_door_width) and f_through >= p.min_seen_through
                     and f_reveal >= p.reveal_share)
    # (a stand-in's lines pass between a sparse leaf's points: they prove no open door)
    closed = kind == "door" and any(f >= need for f, need in cover) and (f_through < p.min_seen_through
                                                                        or dd.stand_in)
    if side is not None and not closed:
        return None
    if (w.external and f_through < p.min_seen_through and not _inner_faces(obs, a, b, outer)
            and any(obs[s][a:b].mean() > 0.5 for s in outer)):
        return None  # an exterior wall seen from outside only there: the scan is not where the model says
    # a stand-in scanner's line through a gap in an interior wall proves less than a ray: the
    # room beyond has its own scanners, and a strip the scan sampled thinly (a mobile
    # scanner's lines) is a gap too; outside an exterior wall only openings let rays reach
    w_through = 0.5
    if dd.stand_in and not w.external:  # ... and only with a threshold or reveals to show for it;
        # reveals only where both faces show the gap: with one face hidden all along (cabinets
        # against a partition on both sides), the "reveals" may be the cabinets' sides inside
        # a wall the model drew too thick (two_storey_office mobile 3 at 300k: a 2 m "door")
        backed = f_reveal / p.reveal_share if min(obs[0][a:b].mean(), obs[1][a:b].mean()) > 0.5 else 0.0
        w_through = 0.25 * min(1.0, f_floor / p.cue_share + backed)
    conf = w_through * min(1.0, f_through / (2 * p.min_seen_through)) * dd.rays
    conf += 0.25 * both + 0.2 * (w.external and not occluded and side is None)
    conf += 0.15 * min(1.0, f_floor / p.cue_share) + 0.15 * min(1.0, f_reveal / p.reveal_share)
    missing = 0.0
    if kind == "window" and w.external:  # the face's own density beside the hole, row by row,
        # says how sure its emptiness is (nothing beyond may return a point: the sky, a street)
        missing = max([hole_deficit(dd.face[s], a, b, lo, hi, p) for s in _inner_faces(obs, a, b, outer)],
                      default=0.0)
    conf += 0.15 * min(1.0, max(0.0, missing / p.hole_points))
    conf += 0.2 * min(1.0, n_beyond / 20.0) * (not dd.rays or dd.stand_in) * w.external + 0.45 * closed
    # a shadow over a hole whose jambs and head stand inside the thickness hides part of a real
    # opening: it weighs only as far as the reveals leave the hole unconfirmed
    shade_cost = f_occ * (1.0 - f_reveal) if dd.rays else f_front
    if dd.stand_in:
        shade_cost = min(shade_cost, f_front)
    conf = float(np.clip(conf - shade_cost, 0.0, 1.0))
    # a window framed by its reveals, unshadowed, with nothing inside its hole: the sky
    framed = (kind == "window" and w.external and not occluded and f_reveal >= p.framed_share
              and float((dd.inside[cells] > 0).mean()) < 0.5)
    shadow = occluded and not (f_through >= 2 * p.min_seen_through or closed)
    if shadow or (conf < p.min_confidence and not framed):
        return None
    return {"u0": el, "u1": er, "width": er - el, "height": et - eb, "sill": eb - z0, "kind": kind,
            "open": not closed, "confidence": conf,
            "support": {"seen_through": f_through, "occluded": f_occ if dd.rays else f_front,
                        "points_beyond": n_beyond, "floor_points": float(dd.floor[a:b].sum()),
                        "threshold_share": f_floor, "reveal_share": f_reveal,
                        "both_faces": float(both), "leaf_share": f_leaf, "missing_points": missing}}


# ----------------------------------------------------------------------------- entry point
def _fit_faces(frames: list[_Wall], idx: list, xyz: np.ndarray, p: OpeningParams) -> float:
    """Set each wall's face offsets from its points; return the range noise σ (metres)."""
    spread = []
    for w, ii in zip(frames, idx):
        rel = xyz[ii, :2] - w.p0
        u, v, z = rel @ w.d, rel @ w.n, xyz[ii, 2]
        core = (z > w.floor_z + 0.2) & (z < w.ceiling_z - 0.2)
        offs = []
        for sg in (1.0, -1.0):
            r = sg * v[core] - w.thickness / 2
            peak, mad, cnt = _face_fit(r, u[core], z[core], w.length, p.face_search)
            offs.append(peak if cnt >= 30 else 0.0)
            if cnt >= 200 and math.isfinite(mad):
                spread.append(mad)
        w.faces = np.array([w.thickness / 2 + offs[0], -(w.thickness / 2 + offs[1])])
    return float(np.median(spread)) if spread else 0.01


def _shape(w: _Wall, o: dict, oid: str, name: str, exterior: str) -> Shape:
    half = w.thickness / 2
    a, b = w.p0 + w.d * o["u0"], w.p0 + w.d * o["u1"]
    fp = [a - w.n * half, b - w.n * half, b + w.n * half, a + w.n * half]
    z0 = w.floor_z + o["sill"]
    kind = o["kind"]
    attrs = {"width": o["width"], "height": o["height"], "sill": o["sill"], "kind": kind,
             "spaces": [w.sides[0] or exterior, w.sides[1] or exterior],
             "confidence": o["confidence"]}
    if kind != "window":
        attrs["open"] = o["open"]
    sup = o["support"]
    what = "closed door" if not o["open"] else kind
    return Shape(oid, ShapeType.WINDOW if kind == "window" else ShapeType.DOOR,
                 Polyhedron.prism(fp, z0, z0 + o["height"]), storey=w.shape.storey, name=name,
                 terminal=True, parent=w.shape.id, support=sup, attributes=attrs,
                 log=(f"openings: {what} {o['width']:.2f} m x {o['height']:.2f} m, sill {o['sill']:.2f} m; "
                      f"seen through {sup['seen_through']:.0%}, occluded {sup['occluded']:.0%}, "
                      f"confidence {o['confidence']:.2f}",))


def detect_openings(walls: Sequence[Shape], storeys: Sequence[Storey], xyz: np.ndarray,
                    normals: Optional[np.ndarray] = None, scan_index: Optional[np.ndarray] = None,
                    scanner_positions: Optional[np.ndarray] = None, params: OpeningParams = OpeningParams(),
                    exterior_ids: Mapping[int, str] = {}, view_pairs: Optional[tuple] = None) -> list[Shape]:
    """Openings (DOOR / WINDOW shapes per the shared conventions: parent wall, width, height, sill, kind,
    spaces from the wall's "sides" (None side -> exterior_ids[storey]), confidence, support) in the walls.

    Parameters
    ----------
    walls : sequence of Shape
        Wall runs (ShapeType.WALL; ``attributes`` "axis_line", "thickness", "external",
        "sides"; a wall without "axis_line" is framed by its footprint's box). Other shapes
        are ignored.
    storeys : sequence of Storey
        Floor and ceiling heights (metres) of the walls' storeys.
    xyz : (n, 3) float64
        Points in the walls' (model) frame, metres; non-finite rows are ignored.
    normals : (n, 3) float64, optional
        Unit normals; when given, only points on near-vertical patches facing across the
        wall count as face points.
    scan_index : (n,) int, optional
        Scanner of each point (index into ``scanner_positions``, -1 unknown).
    scanner_positions : (k, 3) float64, optional
        Scanner origins, metres; with ``scan_index`` they enable the ray test.
    params : OpeningParams
    exterior_ids : mapping of storey index -> exterior shape id
        The space of a wall side without a space (default ``"exterior_s<k>"``).
    view_pairs : (point index, scanner index) int arrays, optional
        Instead of ``scan_index``: every scanner that sees each point (stand-in scanners,
        :func:`engine.elements.viewpoints.visible_pairs`); needs ``scanner_positions``.

    Returns
    -------
    list of Shape
        DOOR shapes (kind "door" or "opening", ``"open"`` False for closed doors) and
        WINDOW shapes, ids ``"<kind>_<wall id>_<j>"``, ordered by wall then along it.

    Raises
    ------
    InputError
        Malformed arrays or a wall without a usable axis or thickness.
    """
    xyz, normals, scan_index, scanners, view_pairs = checked(xyz, normals, scan_index, scanner_positions,
                                                              view_pairs)
    frames = [_frame(w, storeys) for w in walls if w.type == ShapeType.WALL]
    for w in frames:  # a side facing the storey's exterior (named, or no space) is an outer side
        ext = exterior_ids.get(w.shape.storey, f"exterior_s{w.shape.storey}")
        w.sides = tuple(None if sd == ext else sd for sd in w.sides)
    if not frames or len(xyz) == 0:
        return []
    p = params
    idx = _bucket(xyz, frames, p.reach, p.grid)
    sigma = _fit_faces(frames, idx, xyz, p)
    tol = float(np.clip(p.face_sigmas * sigma, *p.face_tolerance))
    n_scans = 0 if scanners is None else len(scanners)
    scan_count = None
    if n_scans and view_pairs is not None:  # stand-in scanners: a point may be seen from several
        pp, vv = (np.asarray(a, np.int64) for a in view_pairs)
        o = np.argsort(pp, kind="stable")
        pp, vv = pp[o], vv[o]
        starts = np.searchsorted(pp, np.arange(len(xyz) + 1))

        def scan_count(ii):
            return np.bincount(vv[group_members(starts, ii)], minlength=n_scans)
    elif n_scans:
        pp = None

        def scan_count(ii):
            k = scan_index[ii]
            return np.bincount(k[(k >= 0) & (k < n_scans)], minlength=n_scans)
    data = [_analyse(w, ii, xyz, normals, scan_count, tol, p) for w, ii in zip(frames, idx)]
    if scan_count is not None:
        wall_of = _wall_of_points(frames, idx, xyz, tol)
        if pp is None:
            _ray_test(frames, data, xyz, scan_index, scanners, tol, p, wall_of)
        else:
            _ray_test(frames, data, xyz[pp], vv, scanners, tol, p, wall_of[pp], stand_in=True)
            for dd in data:
                dd.stand_in = dd.rays
    for dd in data:
        dd.cross = np.concatenate(dd.cross) if dd.cross else np.zeros((0, 2))
    out: list[Shape] = []
    count = {"door": 0, "window": 0}
    hidden = hidden_columns(frames, p.cell, p.junction_depth)
    for w, dd, hid in zip(frames, data, hidden):
        rects, obs = _gap_rects(dd, p, w.external, hid)
        dd.hidden = hid[0] | hid[1]
        found: list[dict] = []
        for rect, mode in sorted(rects, key=lambda r: r[1] != "both"):
            bounds: list = []
            parts = split_by_bottom(dd, rect, p, bounds) if mode == "both" else [rect]
            judged = [_judge(w, dd, part, mode, obs, tol, p) for part in parts]
            if len(parts) == 2 and all(judged):  # no face between them: they meet
                meet(*judged, *bounds[0], parts[0][1] * p.cell)
            for o in judged:
                found = admit(found, o, p.abut, p.abut_share)
        for o in flush_leaves(dd.fu, dd.fz, dd.fcls, dd.fdev, w.sides, w.length, w.floor_z, w.ceiling_z, tol, p):
            if not any(overlap(o, f, p.abut, p.abut_share) for f in found):
                found.append(o)
        ext = exterior_ids.get(w.shape.storey, f"exterior_s{w.shape.storey}")
        for j, o in enumerate(sorted(found, key=lambda f: f["u0"])):
            tag = "window" if o["kind"] == "window" else "door"
            count[tag] += 1
            out.append(_shape(w, o, f"{tag}_{w.shape.id}_{j}", f"{tag.capitalize()} {count[tag]}", ext))
    return out
