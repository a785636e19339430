"""Stand-in scanners for a scan that does not say where it was taken (docs/method.md §7.3).

The opening test tells a hole from a shadow by the rays through a wall's face: a point seen
beyond the wall through a gap proves the gap open, furniture in front of the face shadows it.
A file without scanner positions (a merged export, a cloud cropped and saved again) has no
rays. The rooms of the model say where a scanner could have stood: viewpoints on a grid over
each room's footprint, at a scanner's height, in free space. A point is "seen" from each of its
nearest viewpoints whose straight line to it crosses no occupied voxel of the scan (other than
the point's own surface): what a scanner standing there would have measured. The opening test
then runs on those (point, viewpoint) pairs as on a real scanner's rays.

Cost: voxel keys once (n log n), then per point its ``neighbours`` nearest viewpoints, each
line marched in steps of half a voxel through a hash of the occupied voxels (sorted keys).
"""
from __future__ import annotations

import math
from typing import Mapping, Optional, Sequence

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.sort import stable_argsort
from ..model import Storey
from .params import ViewpointParams

__all__ = ["ViewpointParams", "group_members", "occupancy", "room_viewpoints", "visible_pairs"]

_BITS = 21  # bits per axis of a voxel key (±1 M voxels)
_OFF = 1 << (_BITS - 1)


def _keys(ijk: np.ndarray) -> np.ndarray:
    """int64 keys of (m, 3) voxel indices."""
    a = ijk.astype(np.int64) + _OFF
    return (a[..., 0] << (2 * _BITS)) | (a[..., 1] << _BITS) | a[..., 2]


def group_members(starts: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Positions (into an array sorted by group, group ``g`` at ``starts[g]:starts[g + 1]``)
    of every member of each of ``groups``, group after group."""
    lens = starts[groups + 1] - starts[groups]
    return np.repeat(starts[groups] - np.cumsum(lens) + lens, lens) + np.arange(int(lens.sum()))


def room_viewpoints(footprints: Mapping[int, Mapping[str, object]], storeys: Sequence[Storey],
                    occupied, p: ViewpointParams = ViewpointParams()) -> np.ndarray:
    """(k, 3) viewpoints: per storey and room footprint (shapely), a grid of ``p.spacing`` over
    the footprint shrunk by ``p.clearance`` (its representative point when the grid misses it),
    at ``p.height`` over the floor (at most 60 % of the storey's height); a point whose voxel or
    a neighbour is occupied (furniture) is left out. ``occupied``: a callable (m, 3) → (m,) bool."""
    from shapely.geometry import Point
    from shapely.prepared import prep

    by_index = {s.index: s for s in storeys}
    out = []
    for k, fps in footprints.items():
        st = by_index.get(k)
        if st is None:
            continue
        z = st.floor_z + min(p.height, 0.6 * (st.ceiling_z - st.floor_z))
        for g in fps.values():
            inner = g.buffer(-p.clearance)
            if inner.is_empty:
                inner = g
            x0, y0, x1, y1 = inner.bounds
            xs = np.arange(x0 + (((x1 - x0) % p.spacing) / 2), x1, p.spacing)
            ys = np.arange(y0 + (((y1 - y0) % p.spacing) / 2), y1, p.spacing)
            pg = prep(inner)
            pts = [(x, y) for x in xs for y in ys if pg.contains(Point(x, y))]
            if not pts:
                q = inner.representative_point()
                pts = [(q.x, q.y)]
            out.extend((x, y, z) for x, y in pts)
    if not out:
        return np.zeros((0, 3))
    vp = np.asarray(out, np.float64)
    v = p.voxel
    free = np.ones(len(vp), bool)
    for d in np.array(np.meshgrid([-v, 0, v], [-v, 0, v], [-v, 0, v])).T.reshape(-1, 3):
        free &= ~occupied(vp + d)
    return vp[free]


class _Occupancy:
    """Occupied voxels of a cloud (sorted int64 keys)."""

    def __init__(self, xyz: np.ndarray, voxel: float):
        self.v = voxel
        self.keys = np.unique(_keys(np.floor(xyz / voxel)))

    def __call__(self, q: np.ndarray) -> np.ndarray:
        k = _keys(np.floor(q / self.v))
        i = np.searchsorted(self.keys, k)
        i = np.minimum(i, len(self.keys) - 1)
        return self.keys[i] == k


def occupancy(xyz: np.ndarray, p: ViewpointParams = ViewpointParams()) -> _Occupancy:
    """The occupied voxels of ``xyz`` (``p.voxel``): a callable (m, 3) → (m,) bool."""
    return _Occupancy(np.asarray(xyz, np.float64)[np.isfinite(xyz).all(axis=1)], p.voxel)


def _voxel_planes(xyz: np.ndarray, src: np.ndarray, inv: np.ndarray, cnt: np.ndarray,
                  max_flatness: float) -> np.ndarray:
    """(m, 3) unit normal of each source voxel's points (PCA about their mean ``src``), zero
    where fewer than 3 points or no plane (least spread over ``max_flatness`` of the next)."""
    m = len(src)
    d = xyz - src[inv]
    cov = np.stack([np.stack([np.bincount(inv, d[:, i] * d[:, j], m) for j in range(3)], axis=-1)
                    for i in range(3)], axis=-2) / cnt[:, None, None]
    w, vec = np.linalg.eigh(cov)
    flat = (cnt >= 3) & (w[:, 0] <= max_flatness * w[:, 1])
    return np.where(flat[:, None], vec[:, :, 0], 0.0)


def _nearest_per_level(src: np.ndarray, viewpoints: np.ndarray, p: ViewpointParams):
    """(source, viewpoint, distance) candidates: each source's nearest viewpoints within
    ``p.max_range`` on each level (viewpoint height): ``p.neighbours`` in all, at least 2 per
    level — the ground seen through an upper storey's window is nearer the lower storey's
    viewpoints, which see it through their own windows."""
    z = np.round(viewpoints[:, 2], 2)
    levels = np.unique(z)
    per = p.neighbours if len(levels) == 1 else max(2, p.neighbours // len(levels))
    out_s, out_v, out_d = [], [], []
    m = len(src)
    for lv in levels:
        ids = np.flatnonzero(z == lv)
        kq = min(per, len(ids))
        d, i = cKDTree(viewpoints[ids]).query(src, k=kq, distance_upper_bound=p.max_range)
        d, i = d.reshape(m, kq), i.reshape(m, kq)
        ok = np.isfinite(d)
        out_s.append(np.repeat(np.arange(m), kq)[ok.ravel()])
        out_v.append(ids[i[ok]])
        out_d.append(d[ok])
    return np.concatenate(out_s), np.concatenate(out_v), np.concatenate(out_d)


def visible_pairs(xyz: np.ndarray, viewpoints: np.ndarray,
                  p: ViewpointParams = ViewpointParams(), occupancy: Optional[_Occupancy] = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(point index, viewpoint index) int64 arrays: each point with each of its nearest
    viewpoints (:func:`_nearest_per_level`) whose line to it crosses no
    occupied voxel farther than ``2 voxel`` from the point, ``p.plane_tolerance`` from its
    plane (its own surface) and ``voxel`` from the viewpoint. Points are taken per voxel of
    ``p.source_voxel``: their mean position and plane (PCA)."""
    n = len(xyz)
    if n == 0 or len(viewpoints) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    occ = occupancy if occupancy is not None else _Occupancy(xyz, p.voxel)
    sk = _keys(np.floor(xyz / p.source_voxel))
    uniq, inv = np.unique(sk, return_inverse=True)
    m = len(uniq)
    cnt = np.bincount(inv, minlength=m).astype(np.float64)
    src = np.column_stack([np.bincount(inv, xyz[:, j], m) for j in range(3)]) / cnt[:, None]
    # each source voxel's plane: its own surface does not block its lines (a floor seen at a
    # glancing angle); too few points or no plane: the first 2 voxels do not
    nrm = _voxel_planes(xyz, src, inv, cnt, p.max_flatness)
    s_idx, v_idx, dist = _nearest_per_level(src, viewpoints, p)
    clear = np.zeros(len(s_idx), bool)
    step = p.voxel / 2
    order = np.argsort(dist, kind="stable")
    skip = 2 * p.voxel
    for a in range(0, len(order), p.chunk):
        sel = order[a:a + p.chunk]
        P = src[s_idx[sel]]
        V = viewpoints[v_idx[sel]]
        d = V - P
        L = np.linalg.norm(d, axis=1)
        u = d / np.maximum(L, 1e-9)[:, None]
        ns = int(math.ceil(L.max() / step)) + 1
        blocked = np.zeros(len(sel), bool)
        for j in range(int(skip / step) + 1, ns):  # nearer than ``skip`` nothing blocks
            t = j * step
            if t <= skip:
                continue
            live = np.flatnonzero((t < L - p.voxel) & ~blocked)
            if len(live) == 0:
                continue
            q = P[live] + u[live] * t
            hit = np.flatnonzero(occ(q))
            nl = nrm[s_idx[sel][live[hit]]]  # the point's own plane does not block
            own = (np.abs(np.einsum("ij,ij->i", q[hit] - P[live[hit]], nl)) < p.plane_tolerance) \
                & np.any(nl != 0.0, axis=1)
            blocked[live[hit[~own]]] = True
        clear[sel] = ~blocked
    s_ok, v_ok = s_idx[clear], v_idx[clear]
    # expand source voxels to their points
    o = stable_argsort(inv)
    starts = np.searchsorted(inv[o], np.arange(m + 1))
    pt = o[group_members(starts, s_ok)]
    return pt.astype(np.int64), np.repeat(v_ok, starts[s_ok + 1] - starts[s_ok]).astype(np.int64)
