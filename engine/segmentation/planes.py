"""Multi-scale RANSAC planes with orientation and support constraints (docs/method.md §3.1).

Method
------
*Local extraction.* The wall points (and, separately, the floor/ceiling points) of each
storey are cut into square tiles of ``tile_size`` in x, y (the "voxels of about room size").
In each tile a seeded RANSAC finds planes one after the other:

- wall hypotheses come from two points (the plane through them *containing the vertical*),
  floor/ceiling hypotheses from one point (the horizontal plane through it) — the
  orientation constraint is built into the hypothesis, so no sample is wasted;
- a point supports a hypothesis when it is within the inlier band and its normal agrees
  with the plane's within ``normal_agreement`` (this keeps the two walls of a corner apart);
- the best hypothesis is refitted by least squares on its inliers (a 2D line fit of x, y for
  walls, the mean z for horizontal planes) with the storey's inlier band —
  ``noise_factor`` × the robust σ (1.4826·MAD) of the floor's heights, between
  ``distance_threshold`` and ``max_distance_threshold``, so mobile scans with σ = 2 cm keep
  their points while TLS scans keep a tight band (a band adapted per plane instead grew
  on walls bent by a few degrees and fitted one tilted plane across the bend) — and the fit
  is repeated;
- it is kept when it has ``min_points`` inliers spanning ``min_extent`` and filling at least
  ``min_fill`` of their bounding rectangle (scattered clutter that lines up by chance does
  not); its inliers leave the tile's pool.

*Global refinement.* Two planes of the same kind merge when the angle between them is below
``merge_angle`` and the median distance of each one's supporting points to the other is
below ``merge_distance`` (the thesis uses the minimum distance; the median is the robust
choice; for noisy data twice the planes' adaptive band, capped at ``max_distance_threshold``,
replaces ``merge_distance`` when larger). Merged planes are refitted on the union of their
supports; rounds repeat until nothing merges. Finally every unassigned point of the same
class within a plane's band (and agreeing normal) joins the nearest plane, and the planes
are refitted.

Departures from the thesis: wall planes are fitted *exactly vertical* and floor/ceiling planes
*exactly horizontal* in the aligned frame (the orientation constraint θ is applied to the
points' normals instead) — after Manhattan/vertical alignment this is more accurate than a
free 3D fit on noisy, occluded walls.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..errors import InputError, ReconstructionError
from ..geometry.kdtree import kdtree
from ..geometry.sort import stable_argsort
from ..model import Storey
from ..pointcloud import PointCloud
from ..progress import Progress
from .classify import CLASS_HORIZONTAL, CLASS_WALL, classify_points
from .params import ClassifyParams, PlaneParams

__all__ = ["Plane", "extract_planes"]

log = logging.getLogger(__name__)

_MAD_TO_SIGMA = 1.4826
"""σ of a normal distribution = 1.4826 × its median absolute deviation."""
_MIN_PAIR_SEPARATION = 0.05
"""Two-point wall hypotheses need points at least this far apart in x, y (metres), else
their direction is noise."""
_MERGE_BAND_FACTOR = 1.5
"""A merged plane keeps the union's points within this many bands of the refitted plane."""
_WIDE_FACTOR = 3.0
"""The per-plane noise estimate looks at residuals within this many current bands."""
_MAX_UNBEND = 3
"""At most this many times a bent wall plane is cut to its larger half."""
_MERGE_SAMPLE = 3000
"""At most this many supporting points enter a merge test's median (speed)."""


@dataclass(frozen=True, eq=False)
class Plane:
    """A planar surface found in the working cloud.

    Attributes
    ----------
    id : int
        Index in the list :func:`extract_planes` returns.
    kind : str
        "wall" (vertical) or "horizontal" (floor or ceiling).
    normal : (3,) float64
        Unit normal: horizontal for walls (``normal[2] == 0``), (0, 0, 1) for horizontal planes.
    offset : float
        ρ in ``normal · p = ρ``, metres.
    support : (m,) int64
        Indices of the supporting points in the working cloud.
    storey : int
        Index of the storey it was found in (-1 when storeys were not given).
    rms : float
        Root-mean-square point-to-plane distance of the support, metres.
    band : float
        The inlier band used for this plane, metres.
    segment : (2, 2) float64
        Walls: the x, y end points of the support's extent along the wall line (metres);
        horizontal planes: the min and max x, y corners of the support.
    z_range : (2,) float64
        Min and max z of the support, metres.
    area : float
        Area covered by the support on the plane (occupied 10 cm grid cells), m².
    """

    id: int
    kind: str
    normal: np.ndarray
    offset: float
    support: np.ndarray
    storey: int = -1
    rms: float = 0.0
    band: float = 0.0
    segment: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    z_range: np.ndarray = field(default_factory=lambda: np.zeros(2))
    area: float = 0.0

    def distance(self, points: np.ndarray) -> np.ndarray:
        """(n,) float64 signed distance of (n, 3) points to the plane, metres."""
        return np.asarray(points, dtype=np.float64) @ self.normal - self.offset

    @property
    def direction(self) -> np.ndarray:
        """(2,) float64 — the wall line's direction in x, y (walls only)."""
        return np.array([-self.normal[1], self.normal[0]])

    @property
    def length(self) -> float:
        """Length of a wall's segment, metres."""
        return float(np.linalg.norm(self.segment[1] - self.segment[0]))

    def to_dict(self) -> dict:
        return {"id": self.id, "kind": self.kind, "normal": [float(v) for v in self.normal],
                "offset": float(self.offset), "points": int(len(self.support)), "storey": int(self.storey),
                "rms": float(self.rms), "segment": self.segment.tolist(),
                "z_range": [float(v) for v in self.z_range], "area": float(self.area)}


_AREA_CELL = 0.1
"""Grid cell (metres) used to measure a plane's covered area."""


def _fit(kind: str, pts: np.ndarray):
    """Least-squares plane of the given kind: (normal (3,), offset)."""
    if kind == "horizontal":
        return np.array([0.0, 0.0, 1.0]), float(pts[:, 2].mean())
    xy = pts[:, :2]
    c = xy.mean(axis=0)
    d = xy - c
    w, v = np.linalg.eigh(d.T @ d)
    n2 = v[:, 0]  # smallest eigenvalue: the normal of the line
    # a canonical sign: the largest component positive
    if n2[np.argmax(np.abs(n2))] < 0:
        n2 = -n2
    normal = np.array([n2[0], n2[1], 0.0])
    return normal, float(normal[:2] @ c)


def _finish(pid: int, kind: str, normal, offset, support, xyz, storey, band) -> Plane:
    pts = xyz[support]
    res = pts @ normal - offset
    if kind == "wall":
        u = np.array([-normal[1], normal[0]])
        t = pts[:, :2] @ u
        base = normal[:2] * offset
        seg = np.array([base + t.min() * u, base + t.max() * u])
        coords = np.c_[t, pts[:, 2]]
    else:
        seg = np.array([pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)])
        coords = pts[:, :2]
    q = np.floor(coords / _AREA_CELL).astype(np.int64)
    if len(q):
        q -= q.min(axis=0)
        area = len(np.unique(q[:, 0] * (q[:, 1].max() + 1) + q[:, 1])) * _AREA_CELL ** 2
    else:
        area = 0.0
    return Plane(id=pid, kind=kind, normal=normal, offset=float(offset), support=np.asarray(support, np.int64),
                 storey=int(storey), rms=float(np.sqrt(np.mean(res ** 2))) if len(res) else 0.0, band=float(band),
                 segment=seg, z_range=np.array([pts[:, 2].min(), pts[:, 2].max()]), area=float(area))


def _agree(normal, nrm, cos_agree):
    return np.abs(nrm @ normal) >= cos_agree


def _refine(kind, normal, offset, pts, nrm, params: PlaneParams, band=None):
    """Least-squares refinement; returns (normal, offset, inlier mask, band).

    ``band`` is the storey's inlier band (from the floor's noise, see
    :func:`_noise_band`); when None it is adapted to this plane's own residuals."""
    cos_agree = np.cos(params.normal_agreement)
    fixed = band is not None
    band = params.distance_threshold if band is None else band
    ok = _agree(normal, nrm, cos_agree)
    inl = ok & (np.abs(pts @ normal - offset) <= band)
    for _ in range(3):
        if inl.sum() < 3:
            break
        normal, offset = _fit(kind, pts[inl])
        ok = _agree(normal, nrm, cos_agree)
        r = pts @ normal - offset
        if not fixed:
            wide = ok & (np.abs(r) <= _WIDE_FACTOR * band)
            sigma = _MAD_TO_SIGMA * np.median(np.abs(r[wide])) if wide.any() else 0.0
            band = float(np.clip(params.noise_factor * sigma, params.distance_threshold,
                                 params.max_distance_threshold))
        inl = ok & (np.abs(r) <= band)
    return normal, offset, inl, band


def _noise_band(xyz, labels, storey: Storey, params: PlaneParams):
    """Inlier band of a storey: ``noise_factor`` × the robust σ (1.4826 · MAD) of the floor
    points' heights around ``storey.floor_z`` (a floor is flat, so its spread is the scan
    noise), clipped to [``distance_threshold``, ``max_distance_threshold``]. None when the
    floor has too few points."""
    sel = (labels == CLASS_HORIZONTAL) & (np.abs(xyz[:, 2] - storey.floor_z) <= params.max_distance_threshold * 2)
    if sel.sum() < params.min_points:
        return None
    r = xyz[sel, 2] - np.median(xyz[sel, 2])
    sigma = _MAD_TO_SIGMA * np.median(np.abs(r))
    return float(np.clip(params.noise_factor * sigma, params.distance_threshold, params.max_distance_threshold))


def _bent_half(normal, P, inl, params: PlaneParams):
    """When the two halves of the extent (along the wall) of a wall plane's inliers give
    directions more than ``max_bend`` apart, the mask of the inliers of the larger half;
    else None."""
    idx = np.nonzero(inl)[0]
    if len(idx) < 2 * params.min_points:
        return None
    u = np.array([-normal[1], normal[0]])
    t = P[idx, :2] @ u
    if t.max() - t.min() < 2 * params.min_extent:
        return None
    cut = 0.5 * (t.min() + t.max())  # halves of the extent: a chord's two clusters separate
    a, b = idx[t <= cut], idx[t > cut]
    if min(len(a), len(b)) < max(params.min_points // 2, 3):
        return None
    na, _ = _fit("wall", P[a])
    nb, _ = _fit("wall", P[b])
    if abs(float(na @ nb)) >= np.cos(params.max_bend):
        return None
    mask = np.zeros(len(P), bool)
    mask[a if len(a) >= len(b) else b] = True
    return mask


def _plane_coords(kind, normal, pts) -> np.ndarray:
    """2D coordinates of points on a plane: (along, z) on a wall, (x, y) on a floor."""
    if kind == "wall":
        u = np.array([-normal[1], normal[0]])
        return np.c_[pts[:, :2] @ u, pts[:, 2]]
    return pts[:, :2]


def _fill_at(coords, cell: float) -> float:
    q = np.floor(coords / cell).astype(np.int64)
    q -= q.min(axis=0)
    dims = q.max(axis=0) + 1
    return len(np.unique(q[:, 0] * dims[1] + q[:, 1])) / float(dims[0] * dims[1])


def _filled(kind, normal, pts, min_fill: float, spacing=None) -> bool:
    """Whether the support fills ``min_fill`` of its bounding rectangle on the plane: near 1
    for a wall, tiny for points of scattered objects that happen to line up.

    Measured on the ``_AREA_CELL`` grid, or where the scan is sampled more sparsely than
    that around the support (a wall seen from far, or only through a door, on a sparse
    scan: 20 points a square metre can never fill 15 % of 10 cm cells) on a grid of twice
    the median distance from a support point to its nearest other point of the tile
    (``spacing(pts)``), about one point a cell on a surface sampled evenly. Clutter that
    lines up is a few objects, each sampled as densely as the scan, and the sparse noise
    tail of a wall lies beside the wall's dense points: their spacing stays small and their
    fill low."""
    coords = _plane_coords(kind, normal, pts)
    if _fill_at(coords, _AREA_CELL) >= min_fill:
        return True
    if spacing is None or len(coords) < 3:
        return False
    cell = 2.0 * spacing(pts)
    return cell > _AREA_CELL and _fill_at(coords, cell) >= min_fill


def _ransac_tile(kind, pts, nrm, params: PlaneParams, rng, band=None):
    """Planes of one tile: list of (normal, offset, local inlier indices, band)."""
    out = []
    pool = np.arange(len(pts))
    cos_agree = np.cos(params.normal_agreement)
    rejected = 0
    tree = []

    def spacing(sup):  # median distance to the nearest other point of the tile
        if not tree:
            tree.append(kdtree(pts))
        return float(np.median(tree[0].query(sup, k=2)[0][:, 1]))

    while len(pool) >= params.min_points and len(out) < params.max_planes_per_tile:
        P, N = pts[pool], nrm[pool]
        h = params.iterations
        if kind == "wall":
            i = rng.integers(len(P), size=h)
            j = rng.integers(len(P), size=h)
            d = P[j, :2] - P[i, :2]
            ln = np.linalg.norm(d, axis=1)
            good = ln >= _MIN_PAIR_SEPARATION
            if not good.any():
                break
            d, i, ln = d[good], i[good], ln[good]
            hn = np.c_[-d[:, 1] / ln, d[:, 0] / ln, np.zeros(len(d))]
            ho = np.einsum("ij,ij->i", hn, P[i])
        else:
            i = rng.integers(len(P), size=h)
            hn = np.tile([0.0, 0.0, 1.0], (h, 1))
            ho = P[i, 2]
        # score every hypothesis on a random sample of the pool (the count is an estimate;
        # the refinement below uses all points)
        if len(P) > params.score_sample:
            sidx = rng.choice(len(P), params.score_sample, replace=False)
            SP, SN = P[sidx], N[sidx]
        else:
            SP, SN = P, N
        hn32 = hn.astype(np.float32)
        dist = np.abs(hn32 @ SP.T.astype(np.float32) - ho.astype(np.float32)[:, None])
        agree = np.abs(hn32 @ SN.T.astype(np.float32)) >= cos_agree
        cnt = np.sum((dist <= params.distance_threshold) & agree, axis=1)
        best = int(np.argmax(cnt))
        if cnt[best] * len(P) / len(SP) < params.min_points:
            break
        normal, offset, inl, pband = _refine(kind, hn[best], float(ho[best]), P, N, params, band)
        if kind == "wall":  # a chord across two walls meeting at a small angle: keep one
            for _ in range(_MAX_UNBEND):
                half = _bent_half(normal, P, inl, params)
                if half is None:
                    break
                n2, o2 = _fit(kind, P[half])
                normal, offset, inl, pband = _refine(kind, n2, o2, P, N, params, band)
        if inl.sum() < params.min_points:
            break
        sup = P[inl]
        if kind == "wall":
            u = np.array([-normal[1], normal[0]])
            t = sup[:, :2] @ u
            ext = t.max() - t.min()
        else:
            ext = float(np.max(sup[:, :2].max(axis=0) - sup[:, :2].min(axis=0)))
        if ext < params.min_extent or not _filled(kind, normal, sup, params.min_fill, spacing):
            # drop the hypothesis' inliers from the pool anyway so the search moves on
            # (they may still join a plane in the final assignment)
            pool = pool[~inl]
            rejected += 1
            if rejected >= params.max_rejections:
                break
            continue
        rejected = 0
        out.append((normal, offset, pool[inl], pband))
        pool = pool[~inl]
    return out


def _merge_round(planes_raw, xyz, nrm, params: PlaneParams, rng):
    """One global-refinement round; returns (new list, merged anything?)."""
    m = len(planes_raw)
    if m < 2:
        return planes_raw, False
    normals = np.array([p[0] for p in planes_raw])
    offsets = np.array([p[1] for p in planes_raw])
    cos_merge = np.cos(params.merge_angle)
    dots = normals @ normals.T
    parent = list(range(m))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    samples = []
    for p in planes_raw:
        sup = p[2]
        samples.append(xyz[sup if len(sup) <= _MERGE_SAMPLE else rng.choice(sup, _MERGE_SAMPLE, replace=False)])
    cand = []
    ii, jj = np.nonzero(np.triu(np.abs(dots) >= cos_merge, 1))
    for a, b in zip(ii, jj):
        sign = 1.0 if dots[a, b] >= 0 else -1.0
        # cheap pre-test on the offsets for parallel planes through the same region
        if abs(offsets[a] - sign * offsets[b]) > params.merge_distance + params.max_distance_threshold * 4:
            continue
        if planes_raw[a][4] != planes_raw[b][4]:
            continue
        dab = np.median(np.abs(samples[a] @ normals[b] - offsets[b]))
        dba = np.median(np.abs(samples[b] @ normals[a] - offsets[a]))
        band = max(planes_raw[a][5], planes_raw[b][5])
        d = max(dab, dba)
        if d < max(params.merge_distance, min(2.0 * band, params.max_distance_threshold)):
            cand.append((d, a, b))
    if not cand:
        return planes_raw, False
    # greedy, closest pairs first; a merge is kept only when the refitted plane still holds
    # ``merge_keep`` of the union within its band (two walls meeting at a small angle —
    # or a local plane bridging them — do not become one bent plane)
    cur = {k: planes_raw[k] for k in range(m)}
    merged = False
    for d, a, b in sorted(cand):
        ra, rb = find(a), find(b)
        if ra == rb:
            continue
        pa, pb = cur[ra], cur[rb]
        sup = np.union1d(pa[2], pb[2])
        kind = pa[3]
        normal, offset = _fit(kind, xyz[sup])
        band = max(pa[5], pb[5])
        keep = np.abs(xyz[sup] @ normal - offset) <= band * _MERGE_BAND_FACTOR
        if keep.mean() < params.merge_keep:
            continue
        sup = sup[keep]
        normal, offset = _fit(kind, xyz[sup])
        parent[rb] = ra
        cur[ra] = (normal, offset, sup, kind, pa[4], band)
        del cur[rb]
        merged = True
    return list(cur.values()), merged


def extract_planes(cloud: PointCloud, params: PlaneParams = PlaneParams(), *,
                   labels: Optional[np.ndarray] = None, storeys: Optional[Sequence[Storey]] = None,
                   storey_margin: float = 0.3, rng=0, progress=None, should_stop=None,
                   kinds: Sequence[str] = ("wall", "horizontal")) -> list[Plane]:
    """Wall and floor/ceiling planes of an aligned cloud with normals (see module doc).

    Parameters
    ----------
    cloud : PointCloud
        Aligned (z up) working cloud, metres, with ``normals`` (n, 3) float32.
    params : PlaneParams
    labels : (n,) int8, optional
        Point clusters from :func:`classify_points` (computed when None).
    storeys : sequence of Storey, optional
        Extract each storey separately (points within ``storey_margin`` of
        [floor_z, ceiling_z], never past half-way to the next storey); planes carry the
        storey index. None: the whole cloud is one
        storey (index -1).
    rng : numpy Generator, int or None
    progress, should_stop : callables (see :class:`engine.progress.Progress`)
    kinds : the kinds of plane to find: "wall", "horizontal" or both.

    Returns
    -------
    list of Plane
        Walls first, then horizontal planes; ids are list indices.

    Raises
    ------
    InputError
        No normals.
    ReconstructionError
        No wall plane at all (no vertical structure).
    """
    rng = np.random.default_rng(rng)
    p = Progress.wrap(progress, should_stop)
    name = cloud.source or "point cloud"
    if cloud.normals is None:
        raise InputError("extract_planes needs normals; run estimate_normals first", cloud.source or None)
    if labels is None:
        labels = classify_points(cloud, ClassifyParams(params.angle_tolerance))
    xyz = cloud.xyz
    nrm = cloud.normals.astype(np.float64)
    ranges = [(-1, -np.inf, np.inf)] if not storeys else _storey_ranges(storeys, storey_margin)
    raw = []  # (normal, offset, support, kind, storey, band)
    jobs = []
    bands = {}
    for si, z0, z1 in ranges:
        bands[si] = None if not storeys else _noise_band(xyz, labels, next(s for s in storeys if s.index == si),
                                                        params)
        zin = (xyz[:, 2] >= z0) & (xyz[:, 2] <= z1)
        for kind, cls in (("wall", CLASS_WALL), ("horizontal", CLASS_HORIZONTAL)):
            if kind not in kinds:
                continue
            idx = np.nonzero(zin & (labels == cls))[0]
            if len(idx) == 0:
                continue
            q = np.floor((xyz[idx, :2] - xyz[idx, :2].min(axis=0)) / params.tile_size).astype(np.int64)
            key = q[:, 0] * (q[:, 1].max() + 1) + q[:, 1]
            order = stable_argsort(key)
            bounds = np.flatnonzero(np.diff(key[order])) + 1
            for part in np.split(order, bounds):
                jobs.append((si, kind, idx[part]))
    for k, (si, kind, idx) in enumerate(jobs):
        p(0.8 * k / max(len(jobs), 1), f"RANSAC tile {k + 1}/{len(jobs)}")
        for normal, offset, loc, band in _ransac_tile(kind, xyz[idx], nrm[idx], params, rng, bands[si]):
            raw.append((normal, offset, idx[loc], kind, si, band))
    log.info("%s: %d local planes in %d tiles", name, len(raw), len(jobs))
    for r in range(params.max_merge_rounds):
        p.check()
        raw, merged = _merge_round(raw, xyz, nrm, params, rng)
        if not merged:
            break
    p(0.9, "assigning points to planes")
    raw = _assign_rest(raw, xyz, nrm, labels, ranges, params)
    raw.sort(key=lambda t: (t[3] != "wall", t[4], -len(t[2])))
    planes = [_finish(i, kind, normal, offset, sup, xyz, si, band)
              for i, (normal, offset, sup, kind, si, band) in enumerate(raw)]
    planes = [pl for pl in planes if len(pl.support) >= params.min_points]
    planes = [Plane(**{**pl.__dict__, "id": i}) for i, pl in enumerate(planes)]
    if not any(pl.kind == "wall" for pl in planes):
        raise ReconstructionError("no wall plane found (no vertical structure)", cloud.source or None)
    p(1.0, f"{len(planes)} planes")
    log.info("%s: %d planes after refinement (%d walls)", name, len(planes),
             sum(pl.kind == "wall" for pl in planes))
    return planes


def _storey_ranges(storeys: Sequence[Storey], margin: float):
    """(index, z0, z1) of each storey: ``margin`` beyond its floor and ceiling, but never past
    half-way to the neighbouring storey (the slab between two storeys is split)."""
    st = sorted(storeys, key=lambda s: s.floor_z)
    out = []
    for k, s in enumerate(st):
        z0, z1 = s.floor_z - margin, s.ceiling_z + margin
        if k > 0:
            z0 = max(z0, 0.5 * (st[k - 1].ceiling_z + s.floor_z))
        if k + 1 < len(st):
            z1 = min(z1, 0.5 * (s.ceiling_z + st[k + 1].floor_z))
        out.append((s.index, z0, z1))
    return out


def _assign_rest(raw, xyz, nrm, labels, ranges, params: PlaneParams):
    """Give every unassigned point of the right class to the nearest plane whose band and
    normal it fits (same storey), then refit each plane once."""
    if not raw:
        return raw
    n = len(xyz)
    owner = np.full(n, -1, np.int64)
    for k, t in enumerate(raw):
        owner[t[2]] = k
    cos_agree = np.cos(params.normal_agreement)
    best_d = np.full(n, np.inf)
    best_k = owner.copy()
    free = owner < 0
    for k, (normal, offset, sup, kind, si, band) in enumerate(raw):
        cls = CLASS_WALL if kind == "wall" else CLASS_HORIZONTAL
        z0, z1 = next((a, b) for (s, a, b) in ranges if s == si)
        cand = np.nonzero(free & (labels == cls) & (xyz[:, 2] >= z0) & (xyz[:, 2] <= z1))[0]
        if len(cand) == 0:
            continue
        d = np.abs(xyz[cand] @ normal - offset)
        ok = (d <= band) & (np.abs(nrm[cand] @ normal) >= cos_agree) & (d < best_d[cand])
        if kind == "wall":  # only points continuing the wall, not far collinear clutter
            u = np.array([-normal[1], normal[0]])
            t_sup = xyz[sup, :2] @ u
            t = xyz[cand, :2] @ u
            ok &= (t >= t_sup.min() - params.tile_overlap) & (t <= t_sup.max() + params.tile_overlap)
        best_d[cand[ok]] = d[ok]
        best_k[cand[ok]] = k
    out = []
    for k, (normal, offset, sup, kind, si, band) in enumerate(raw):
        extra = np.nonzero(free & (best_k == k))[0]
        if len(extra):
            sup = np.union1d(sup, extra)
            normal, offset = _fit(kind, xyz[sup])
        out.append((normal, offset, sup, kind, si, band))
    return out
