"""Cleaning and normals: non-finite rows, voxel downsampling, statistical outliers, PCA normals.

docs/method.md §1 "Clean". The working cloud is a voxel-downsampled copy (one *representative* input
point per voxel, so every attribute and truth field survives and the scan noise is not
averaged away); the original cloud is kept by the caller for evaluation.
"""
from __future__ import annotations

import logging
from typing import Optional

import numpy as np

from ..errors import EmptyCloudError
from ..geometry.kdtree import kdtree, spatial_order
from ..geometry.normals import (SHEET_TILT, eigenvalues_3x3, hybrid_covariances, knn_normals,
                                one_sided_normals, sheet_normals, smallest_eigenpairs, wall_sheet_normals)
from ..lazy_open3d import open3d
from ..pointcloud import PointCloud
from ..progress import Progress
from .params import CleanParams, NormalParams
from ..threads import thread_cap
from ..geometry.boxes import column_max, column_min
from ..geometry.sort import stable_argsort

__all__ = ["drop_nonfinite", "building_points", "voxel_downsample", "remove_statistical_outliers",
           "estimate_normals", "clean", "clean_voxels"]

log = logging.getLogger(__name__)

_MAX_VOXEL_ROUNDS = 4
"""At most this many enlargements of the voxel to reach ``max_working_points``."""
_VOXEL_GROWTH_MARGIN = 1.05
"""Enlarge the voxel a little more than the surface estimate so one round usually does."""


def _name(cloud: PointCloud) -> str:
    return cloud.source or "point cloud"


def drop_nonfinite(cloud: PointCloud) -> PointCloud:
    """The cloud without rows whose coordinates are NaN or infinite.

    ``dropped_nonfinite`` counts the rows removed (added to what the reader dropped).
    """
    ok = np.isfinite(cloud.xyz).all(axis=1)
    if ok.all():
        return cloud
    out = cloud.subset(ok)
    return out.with_(dropped_nonfinite=cloud.dropped_nonfinite + int((~ok).sum()))


def voxel_downsample(cloud: PointCloud, voxel_size: float) -> tuple[PointCloud, np.ndarray, np.ndarray]:
    """Keep one input point per occupied voxel.

    Parameters
    ----------
    cloud : PointCloud
    voxel_size : float
        Voxel edge, metres; ``<= 0`` returns the cloud unchanged.

    Returns
    -------
    working : PointCloud
        The representatives (the first point of each voxel in input order), all attributes kept.
    kept : (m,) int64
        Index of each representative in ``cloud``.
    voxel_of : (n,) int64
        For every input point, the index of its representative in ``working`` — use it to
        carry per-point results (labels, plane ids) back to the full cloud.
    """
    n = len(cloud)
    if voxel_size <= 0 or n == 0:
        idx = np.arange(n, dtype=np.int64)
        return cloud, idx, idx
    kept, voxel_of = _voxel_keys(cloud.xyz, voxel_size, True)
    return cloud.subset(kept), kept, voxel_of


def _voxel_key(xyz: np.ndarray, voxel_size: float) -> np.ndarray:
    """(n,) int64 key of each point's voxel of edge ``voxel_size`` (grid from the minimum)."""
    q = np.floor((xyz - column_min(xyz)) / voxel_size).astype(np.int64)
    dims = column_max(q) + 1
    return (q[:, 0] * dims[1] + q[:, 1]) * dims[2] + q[:, 2]


def _voxel_count(xyz: np.ndarray, voxel_size: float) -> int:
    """How many voxels of edge ``voxel_size`` the points occupy (what :func:`_voxel_keys` would
    keep, without the stable argsort and the representatives)."""
    if len(xyz) == 0:
        return 0
    key = _voxel_key(xyz, voxel_size)
    key.sort()
    return 1 + int(np.count_nonzero(key[1:] != key[:-1]))


def _voxel_keys(xyz: np.ndarray, voxel_size: float, inverse: bool):
    """(kept (m,) int64 sorted, voxel_of (n,) int64 or None) — see :func:`voxel_downsample`."""
    key = _voxel_key(xyz, voxel_size)
    order = stable_argsort(key)  # stable: the first point of a voxel comes first
    ks = key[order]
    first = np.ones(len(ks), bool)
    first[1:] = ks[1:] != ks[:-1]
    kept = order[first]
    if not inverse:
        return np.sort(kept), None
    group = np.cumsum(first) - 1  # voxel number of each sorted point
    rank_of_group = np.empty(len(kept), np.int64)
    korder = np.argsort(kept)  # representatives in input order (distinct indices)
    rank_of_group[korder] = np.arange(len(kept))
    voxel_of = np.empty(len(xyz), np.int64)
    voxel_of[order] = rank_of_group[group]
    return kept[korder].astype(np.int64), voxel_of


_NEIGHBOUR_OFFSETS = np.array([(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                               if (dx, dy, dz) > (0, 0, 0)], dtype=np.int64)
"""Half of the 26-neighbourhood (each voxel pair once)."""


def building_points(xyz: np.ndarray, voxel: float, min_share: float) -> tuple[np.ndarray, int]:
    """Which points belong to the building: the groups of 26-connected occupied voxels of
    edge ``voxel`` holding at least ``min_share`` of the points of the largest group (far
    stray clusters — a car park seen through a window, a reflection 1 km away — are not).

    Cost: a sort of the occupied voxels' keys and one search per neighbour offset, O(n log n);
    nothing is allocated over the bounding box.

    Returns
    -------
    keep : (n,) bool
    groups_removed : int
    """
    xyz = np.asarray(xyz, dtype=np.float64)
    n = len(xyz)
    if n == 0 or voxel <= 0 or min_share <= 0:
        return np.ones(n, bool), 0
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    q = np.floor((xyz - column_min(xyz)) / voxel).astype(np.int64) + 1  # a free layer on every side
    dims = column_max(q) + 2
    key = (q[:, 0] * dims[1] + q[:, 1]) * dims[2] + q[:, 2]
    occupied, voxel_of, counts = np.unique(key, return_inverse=True, return_counts=True)
    rows, cols = [], []
    for dx, dy, dz in _NEIGHBOUR_OFFSETS:
        nk = occupied + (dx * dims[1] + dy) * dims[2] + dz
        j = np.minimum(np.searchsorted(occupied, nk), len(occupied) - 1)
        hit = occupied[j] == nk
        rows.append(np.nonzero(hit)[0])
        cols.append(j[hit])
    r, c = np.concatenate(rows), np.concatenate(cols)
    m = len(occupied)
    graph = coo_matrix((np.ones(len(r), np.int8), (r, c)), shape=(m, m))
    k, group = connected_components(graph, directed=False)
    size = np.bincount(group, weights=counts, minlength=k)
    good = size >= min_share * size.max()
    return good[group[voxel_of]], int(k - good.sum())


def remove_statistical_outliers(cloud: PointCloud, neighbors: int, std_ratio: float) -> tuple[PointCloud, np.ndarray]:
    """Drop points whose mean distance to their ``neighbors`` nearest neighbours exceeds the
    mean over the cloud by ``std_ratio`` standard deviations.

    Returns the filtered cloud and the (n,) bool mask of kept points.
    """
    n = len(cloud)
    if n <= neighbors + 1:
        return cloud, np.ones(n, bool)
    d, _ = kdtree(cloud.xyz).query(cloud.xyz, k=neighbors + 1, workers=thread_cap())
    md = d[:, 1:].mean(axis=1)
    keep = md <= md.mean() + std_ratio * md.std()
    return (cloud if keep.all() else cloud.subset(keep)), keep


def clean(cloud: PointCloud, params: CleanParams = CleanParams(), *, progress=None,
          should_stop=None) -> tuple[PointCloud, np.ndarray, float]:
    """Non-finite rows dropped, voxel downsampling, statistical outlier removal (see
    :func:`clean_voxels`, which also gives every point's voxel)."""
    work, kept, voxel, _ = clean_voxels(cloud, params, progress=progress, should_stop=should_stop)
    return work, kept, voxel


def clean_voxels(cloud: PointCloud, params: CleanParams = CleanParams(), *, progress=None,
                 should_stop=None) -> tuple[PointCloud, np.ndarray, float, Optional[tuple]]:
    """Non-finite rows dropped, voxel downsampling, statistical outlier removal.

    Returns
    -------
    working : PointCloud
        The cleaned working cloud.
    source_index : (m,) int64
        Index of each working point in the *finite* input (``drop_nonfinite(cloud)``).
    voxel : float
        The voxel edge actually used, metres (``params.voxel_size`` or larger, see
        ``CleanParams.max_working_points``; 0 when downsampling is off).
    voxels : (representatives (k,) int64 sorted, voxel_of (n,) int64) of the finite input
        on that grid before the outlier removal (:func:`estimate_normals`'s ``voxels``), or
        None when downsampling is off.

    Raises
    ------
    EmptyCloudError
        Fewer than ``params.min_points`` usable points remain.
    """
    p = Progress.wrap(progress, should_stop)
    p(0.0, "cleaning")
    finite = drop_nonfinite(cloud)
    if len(finite) < params.min_points:
        raise EmptyCloudError(
            f"only {len(finite)} usable points (at least {params.min_points} are needed to find "
            "walls, floors and ceilings)", cloud.source or None)
    voxel = params.voxel_size
    if voxel > 0:
        count = _voxel_count(finite.xyz, voxel)
        for _ in range(_MAX_VOXEL_ROUNDS):
            if count <= params.max_working_points:
                break
            voxel *= np.sqrt(count / params.max_working_points) * _VOXEL_GROWTH_MARGIN
            count = _voxel_count(finite.xyz, voxel)
        voxels = _voxel_keys(finite.xyz, voxel, True)
        kept = voxels[0]
        work = finite.subset(kept)
    else:
        work, kept, voxels = finite, np.arange(len(finite), dtype=np.int64), None
    p(0.5, "outlier removal")
    if params.remove_outliers:
        work, keep = remove_statistical_outliers(work, params.outlier_neighbors, params.outlier_std_ratio)
        kept = kept[keep]
    if len(work) < params.min_points:
        raise EmptyCloudError(
            f"only {len(work)} points left after downsampling to {params.voxel_size} m voxels "
            f"(at least {params.min_points} are needed)", cloud.source or None)
    p(1.0, f"{len(work)} working points")
    log.info("cleaned %s: %d -> %d working points (voxel %.3f m)", _name(cloud), len(cloud), len(work), voxel)
    return work, kept, float(max(voxel, 0.0)), voxels


def _o3d():
    return open3d("Normal estimation")


def estimate_normals(cloud: PointCloud, params: NormalParams = NormalParams(), *, progress=None,
                     should_stop=None, tree=None, share: float = 0.0, voxels=None) -> PointCloud:
    """PCA normals over a hybrid radius / k-nearest neighbourhood (open3d), one-sided where
    scanner positions are known.

    Parameters
    ----------
    cloud : PointCloud
        (n, 3) float64 metres. Downsample first for large clouds (see :func:`clean`).
    params : NormalParams
    tree : a k-d tree of ``cloud.xyz`` (:func:`engine.geometry.kdtree.kdtree`) for the
        fallback below, or None (one is built when a point needs it).
    share : float
        0: a normal per point. Otherwise the edge of voxels (metres) whose points share one
        normal: that of the voxel's first point, over its neighbourhood among *all* points
        (:func:`engine.geometry.normals.hybrid_covariances`). A dense scan's neighbours of
        points a few centimetres apart are nearly the same points: one estimate per voxel of
        the working cloud costs what the working cloud costs, whatever the scan's density.
    voxels : that grid's (representatives, voxel_of) of ``cloud.xyz`` when already known
        (:func:`clean_voxels`), or None.

    Returns
    -------
    PointCloud
        A copy with ``normals`` (n, 3) float32 unit vectors. When scanner positions are known
        (``scanner_positions`` (k, 3) with ``scan_index``, or a single position) and
        ``params.orient_to_scanner``, each normal faces its scanner
        (``n · (s − p) ≥ 0``); otherwise the sign is open3d's (arbitrary but consistent
        enough: nothing in this package depends on it). Points with fewer than 3 neighbours
        within the radius (sparse areas far from the scanner) get the PCA normal of their
        ``fallback_knn`` nearest points. With scanner positions, a point whose neighbourhood
        is far from planar and wide (``one_sided_planarity``, ``one_sided_reach``) gets the
        normal of its neighbours seen from its side
        (:func:`engine.geometry.normals.one_sided_normals`): on sparse scans the two faces of
        a partition fall into one neighbourhood.

    Raises
    ------
    EmptyCloudError
        Fewer than 3 points.
    """
    if len(cloud) < 3:
        raise EmptyCloudError("normals need at least 3 points", cloud.source or None)
    p = Progress.wrap(progress, should_stop)
    p(0.0, "normals")
    s = _scanner_of_points(cloud)
    one_sided = s is not None and params.one_sided_planarity > 0
    # no positions: sheets told apart by the gap between them, in height or side by side
    sheets = s is None and params.one_sided_planarity > 0 and max(params.sheet_gap, params.wall_sheet_gap) > 0
    q = voxel_of = None  # the points estimated (None: every point) and each point's voxel
    if share > 0:
        q, voxel_of = _voxel_keys(cloud.xyz, share, True) if voxels is None else voxels
        if len(q) > _SHARE_WORTH * len(cloud):  # hardly two points a voxel: one each
            q = voxel_of = None
    if q is None:
        nrm, cov = _open3d_normals(cloud.xyz, params, one_sided or sheets)
    else:
        tree = kdtree(cloud.xyz) if tree is None else tree
        cov, cnt = hybrid_covariances(cloud.xyz, q, params.max_nn, params.radius, tree=tree)
        nrm = smallest_eigenpairs(cov)[1]
        nrm[cnt < 3] = (0.0, 0.0, 1.0)  # open3d's mark of too few neighbours (below)
        if not (one_sided or sheets):
            cov = None
    qx = np.arange(len(cloud)) if q is None else q  # the estimated points' indices in the cloud
    wide = beside = np.zeros(0, np.int64)
    if cov is not None:
        # the neighbourhood's radius is about √(2 · trace): only wide ones can reach a second sheet
        trace = cov[:, 0, 0] + cov[:, 1, 1] + cov[:, 2, 2]
        wide = np.flatnonzero(2.0 * trace >= params.one_sided_reach ** 2)
        w = eigenvalues_3x3(cov[wide])
        wide = wide[w[:, 0] > params.one_sided_planarity * w[:, 1]]  # and far from planar
        if sheets:
            beside = wide  # side by side: the two faces of a partition (below)
            # two horizontal sheets spread the neighbourhood in height by at least what a sixth
            # of it at ``sheet_gap`` from the rest does: a noisy floor's is not split
            wide = wide[cov[wide, 2, 2] >= (5 / 36) * params.sheet_gap ** 2]
        del cov
    # open3d leaves exactly (0, 0, 1) when a neighbourhood has fewer than 3 points
    bad = (~np.isfinite(nrm).all(axis=1) | (np.linalg.norm(nrm, axis=1) < 0.5)
           | ((nrm[:, 0] == 0.0) & (nrm[:, 1] == 0.0)))
    if bad.any():  # too few neighbours within the radius (sparse, far from the scanner)
        nrm[bad] = knn_normals(cloud.xyz, params.fallback_knn, qx[bad], tree=tree)
    redo = wide[~bad[wide]]
    to_scanner = s - cloud.xyz if s is not None else None  # read by both steps below
    if sheets:
        # no scanner says which side a point was seen from: a floor and the ceiling under its
        # slab are told apart by the gap in height between them. Only tilted normals: a wall's
        # stays near horizontal however noisy, a floor's already within the split's tilt
        nz = np.abs(nrm[redo, 2])
        redo = redo[(nz >= 0.1) & (nz < np.cos(SHEET_TILT))]

    def own_sheet(estimate, idx, gap, what):  # again over each point's own sheet; the points done
        nonlocal tree
        tree = kdtree(cloud.xyz) if tree is None else tree
        n1 = estimate(cloud.xyz, qx[idx], params.max_nn, params.radius, gap,
                      planarity=params.one_sided_planarity, tree=tree)
        got = np.isfinite(n1).all(axis=1)
        nrm[idx[got]] = n1[got]
        log.debug("normals: %d of %d points re-estimated over their own %s", int(got.sum()), len(nrm), what)
        return idx[got]

    if sheets:
        if len(redo) and params.sheet_gap > 0:
            beside = np.setdiff1d(beside, own_sheet(sheet_normals, redo, params.sheet_gap, "sheet"))
        beside = beside[~bad[beside]]
        if params.wall_sheet_gap > 0 and len(beside):
            # nor which face of a partition: the faces are told apart by the gap between them
            own_sheet(wall_sheet_normals, beside, params.wall_sheet_gap, "face")
    elif len(redo):
        # neighbourhoods far from planar and wide enough to reach a second sheet (the other
        # face of a partition, a table's underside): again over the points seen from this side
        with np.errstate(invalid="ignore", divide="ignore"):  # a point at its scanner: NaN, left out
            view = to_scanner / np.linalg.norm(to_scanner, axis=1, keepdims=True)
        tree = kdtree(cloud.xyz) if tree is None else tree
        n1 = one_sided_normals(cloud.xyz, view, qx[redo], params.max_nn, params.radius, tree=tree)
        got = np.isfinite(n1).all(axis=1)
        nrm[redo[got]] = n1[got]
        log.debug("normals: %d of %d points re-estimated from their side", int(got.sum()), len(nrm))
    if voxel_of is not None:
        nrm = nrm[voxel_of]  # every point takes its voxel's (each faces its own scanner below)
    if params.orient_to_scanner and s is not None:
        ok = np.isfinite(s).all(axis=1)
        flip = ok & (np.einsum("ij,ij->i", nrm, to_scanner) < 0)
        nrm[flip] *= -1.0
    p(1.0, "normals done")
    return cloud.with_(normals=nrm.astype(np.float32))


_SHARE_WORTH = 0.8
"""Normals are shared within voxels only when that leaves at most this share of the points to
estimate."""


def _open3d_normals(xyz: np.ndarray, params: NormalParams, covariances: bool):
    """(n, 3) float64 normals of every point (open3d's hybrid PCA; exactly (0, 0, 1) where
    fewer than 3 neighbours) and, when ``covariances``, their (n, 3, 3) covariances (else None)."""
    o3d = _o3d()
    order = spatial_order(xyz, params.radius)  # queries in space order: same normals, less time
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz[order]))
    hybrid = o3d.geometry.KDTreeSearchParamHybrid(radius=params.radius, max_nn=params.max_nn)
    if covariances:
        pc.estimate_covariances(hybrid)  # kept: the normals below reuse them (open3d's own normals)
    pc.estimate_normals(hybrid)
    nrm = np.empty((len(xyz), 3))
    nrm[order] = np.asarray(pc.normals, dtype=np.float64)
    cov = None
    if covariances:
        cov = np.empty((len(xyz), 3, 3))
        cov[order] = np.asarray(pc.covariances)
    return nrm, cov


def _scanner_of_points(cloud: PointCloud):
    """(n, 3) float64 scanner position of each point, or None when unknown (NaN rows allowed)."""
    sp = cloud.scanner_positions
    if sp is None or len(sp) == 0 or not np.isfinite(sp).any():
        return None
    if cloud.scan_index is not None and len(sp) > 1:
        si = np.clip(cloud.scan_index, 0, len(sp) - 1)
        return sp[si]
    if len(sp) == 1:
        return np.broadcast_to(sp[0], cloud.xyz.shape)
    return None
