"""PCA of k-nearest-neighbour neighbourhoods: point normals and the local shape statistics.

One kernel (a k-d tree query, the batched scatter matrices, ``eigh``) serves the normal
fallback of the preprocessing, the frame checks' sample statistics, the registration's
check normals and the change detection's normals of ambiguous points.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..threads import thread_cap
from .kdtree import kdtree, spatial_order

__all__ = ["knn_pca", "knn_normals", "eigenvalues_3x3", "smallest_eigenpairs", "one_sided_normals",
           "sheet_normals", "wall_sheet_normals", "hybrid_covariances", "SHEET_TILT"]


def knn_pca(xyz: np.ndarray, k: int, query: Optional[np.ndarray] = None, *,
            workers: Optional[int] = None, tree=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """PCA of the ``k`` nearest neighbours (the point itself included) of query points.

    Parameters
    ----------
    xyz : (n, 3) float64 — the points the neighbours come from (centre georeferenced
        coordinates first: the scatter matrices keep their digits).
    k : neighbours per query point, clipped to n.
    query : (m,) int indices into ``xyz`` of the query points; None: every point.
    workers : threads of the k-d tree query (None: :func:`engine.threads.thread_cap`).
    tree : a k-d tree of ``xyz`` to share (:func:`engine.geometry.kdtree.kdtree`), or None.

    Returns
    -------
    distances : (m, k) float64 — to the neighbours, nearest first (same unit as ``xyz``).
    eigenvalues : (m, 3) float64 — of each neighbourhood's scatter matrix, ascending.
    eigenvectors : (m, 3, 3) float64 — unit columns matching ``eigenvalues``; column 0 is
        the normal (sign arbitrary).
    """
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    q = xyz if query is None else xyz[np.asarray(query)]
    k = int(min(k, len(xyz)))
    tree = kdtree(xyz) if tree is None else tree
    d, nb = tree.query(q, k=k, workers=thread_cap() if workers is None else workers)
    d = np.asarray(d, dtype=np.float64).reshape(len(q), k)
    nb = np.asarray(nb).reshape(len(q), k)
    p = xyz[nb]
    p = p - p.mean(axis=1, keepdims=True)
    w, v = np.linalg.eigh(np.matmul(p.transpose(0, 2, 1), p))  # batched matmul: 4x einsum's speed
    return d, w, v


def knn_normals(xyz: np.ndarray, k: int, query: Optional[np.ndarray] = None, *,
                workers: Optional[int] = None, tree=None) -> np.ndarray:
    """(m, 3) float64 unit PCA normals (sign arbitrary) of the query points over their ``k``
    nearest neighbours in ``xyz`` (see :func:`knn_pca`)."""
    return knn_pca(xyz, k, query, workers=workers, tree=tree)[2][:, :, 0]


def _eigen_parts(cov: np.ndarray):
    """Entries (one row each) and ascending eigenvalues of symmetric 3×3 matrices (trigonometric
    closed form), and where a matrix is a multiple of the identity."""
    a = np.ascontiguousarray(np.asarray(cov, dtype=np.float64).reshape(-1, 9).T)  # one row per entry
    a00, a11, a22, a01, a02, a12 = a[0], a[4], a[8], a[1], a[2], a[5]
    q = (a00 + a11 + a22) / 3.0
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    p = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * (a01 * a01 + a02 * a02 + a12 * a12)) / 6.0)
    iso = p <= 1e-12 * np.maximum(np.abs(q), 1e-300)
    ps = np.where(iso, 1.0, p)
    det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02) + a02 * (a01 * a12 - b11 * a02))
    phi = np.arccos(np.clip(det / (2.0 * ps ** 3), -1.0, 1.0)) / 3.0
    big = q + 2.0 * p * np.cos(phi)
    small = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    w = np.column_stack([small, 3.0 * q - big - small, big])
    w[iso] = q[iso, None]
    return (a00, a11, a22, a01, a02, a12), w, iso


def eigenvalues_3x3(cov: np.ndarray) -> np.ndarray:
    """(m, 3) ascending eigenvalues of (m, 3, 3) symmetric matrices, in closed form."""
    return _eigen_parts(cov)[1]


def smallest_eigenpairs(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and the eigenvector of the smallest one of symmetric 3×3
    matrices, in closed form (vectorised; a batched ``eigh`` costs 5× more on 1M matrices).

    ``cov`` : (m, 3, 3) float64 symmetric. Returns ``(w, n)``: (m, 3) eigenvalues ascending,
    (m, 3) unit eigenvectors of ``w[:, 0]`` (sign arbitrary; (0, 0, 1) where the matrix is
    a multiple of the identity, every direction then being one).
    """
    (a00, a11, a22, a01, a02, a12), w, iso = _eigen_parts(cov)
    small = w[:, 0]
    # the eigenvector of the smallest eigenvalue: the largest cross product of two rows of a − λ I
    m00, m11, m22 = a00 - small, a11 - small, a22 - small
    r0 = (m00, a01, a02)
    r1 = (a01, m11, a12)
    r2 = (a02, a12, m22)

    def cross(u, v):
        return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])

    n = cross(r0, r1)
    best = n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
    for c in (cross(r0, r2), cross(r1, r2)):
        cn = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
        better = cn > best
        n = tuple(np.where(better, ci, ni) for ci, ni in zip(c, n))
        best = np.where(better, cn, best)
    good = ~iso & (best > 0)
    scale = np.where(good, 1.0 / np.sqrt(np.where(good, best, 1.0)), 0.0)
    n = np.column_stack([n[0] * scale, n[1] * scale, np.where(good, n[2] * scale, 1.0)])
    return w, n


def _neighbour_chunks(xyz: np.ndarray, query: np.ndarray, k: int, radius: float, tree, workers,
                      chunk: int = 100_000):
    """Per chunk of the query points: (start, their indices, (m, k) neighbour indices (0 where
    none), (m, k) bool which are neighbours) — at most ``k`` within ``radius``."""
    tree = kdtree(xyz) if tree is None else tree
    k = int(min(k, len(xyz)))
    workers = thread_cap() if workers is None else workers
    for s in range(0, len(query), chunk):
        qi = query[s:s + chunk]
        d, nb = tree.query(xyz[qi], k=k, distance_upper_bound=radius, workers=workers)
        d, nb = np.asarray(d).reshape(len(qi), k), np.asarray(nb).reshape(len(qi), k)
        ok = np.isfinite(d)
        nb = np.where(ok, nb, 0)
        del d  # not held while the caller works on the chunk
        yield s, qi, nb, ok


def _masked_cov(cols: list, nb: np.ndarray, qi: np.ndarray, keep: np.ndarray):
    """(m, 3, 3) covariance (about their mean, divided by their count) and (m,) count of the
    neighbours ``nb`` (m, k) of query points ``qi`` that ``keep`` (m, k) selects, their
    scatter centred on the query point (digits); ``cols``: the points' contiguous x, y, z."""
    cnt = keep.sum(axis=1)
    inv = 1.0 / np.maximum(cnt, 1)
    rel = [np.where(keep, cols[c][nb] - cols[c][qi, None], 0.0) for c in range(3)]
    mu = [r.sum(axis=1) * inv for r in rel]
    cov = np.empty((len(qi), 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = cov[:, b, a] = np.einsum("ij,ij->i", rel[a], rel[b]) * inv - mu[a] * mu[b]
    return cov, cnt


def _masked_pca(cols: list, nb: np.ndarray, qi: np.ndarray, keep: np.ndarray):
    """Eigenvalues (ascending), the smallest one's unit eigenvector and the count of the
    selected neighbours (see :func:`_masked_cov`)."""
    cov, cnt = _masked_cov(cols, nb, qi, keep)
    w, n = smallest_eigenpairs(cov)
    return w, n, cnt


def hybrid_covariances(xyz: np.ndarray, query: np.ndarray, k: int, radius: float, *, tree=None,
                       workers: Optional[int] = None) -> tuple[np.ndarray, np.ndarray]:
    """Covariances of the query points' hybrid neighbourhoods: at most ``k`` nearest points of
    ``xyz`` within ``radius`` (the point itself included), as open3d's ``estimate_covariances``
    forms them, but at chosen query points only.

    Returns ``(cov, count)``: (m, 3, 3) float64 covariances about the neighbours' mean (divided
    by their count), (m,) int neighbours found."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    query = np.asarray(query, dtype=np.int64)
    cov = np.zeros((len(query), 3, 3))
    cnt = np.zeros(len(query), np.int64)
    if len(query) == 0 or len(xyz) == 0:
        return cov, cnt
    cols = [np.ascontiguousarray(xyz[:, c]) for c in range(3)]
    order = spatial_order(xyz[query], radius)  # queries in space order: a quarter less time
    for s, qi, nb, ok in _neighbour_chunks(xyz, query[order], k, radius, tree, workers):
        at = order[s:s + len(qi)]
        cov[at], cnt[at] = _masked_cov(cols, nb, qi, ok)
    return cov, cnt


def one_sided_normals(xyz: np.ndarray, view: np.ndarray, query: np.ndarray, k: int, radius: float, *,
                      min_points: int = 5, tree=None, workers: Optional[int] = None) -> np.ndarray:
    """PCA normals of the query points over the neighbours seen from the same side.

    A surface is scanned from the side it faces: the two faces of a thin wall (or a table
    top and its underside) are seen from opposite sides, so a neighbour whose direction to
    its scanner points away from the query point's (``view_q · view_p ≤ 0``) lies on another
    sheet. On sparse scans a neighbourhood of the normals' radius reaches across a 10–20 cm
    partition, and its PCA normal then lies anywhere between the wall's and the scan lines'
    (office_mw mobile, 300k points: 20 % of a partition's points faced it; 71 % with this).

    Parameters
    ----------
    xyz : (n, 3) float64 — every point, metres.
    view : (n, 3) float64 — unit vector from each point to its scanner (NaN rows: unknown;
        such neighbours are left out, such query points get NaN).
    query : (m,) int — the points to estimate.
    k, radius : at most ``k`` nearest neighbours within ``radius`` metres (the normals'
        hybrid neighbourhood).
    min_points : fewer neighbours on the query's side than this give NaN (keep the other
        estimate).
    tree : a k-d tree of ``xyz`` to share, or None.

    Returns (m, 3) float64 unit normals (sign arbitrary) or NaN rows.
    """
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    query = np.asarray(query, dtype=np.int64)
    out = np.full((len(query), 3), np.nan)
    if len(query) == 0 or len(xyz) < min_points:
        return out
    # one contiguous array per coordinate: the (m, k) gathers and products below then run on
    # contiguous memory (2x the speed of strided (m, k, 3) slices, the same sums)
    cols = [np.ascontiguousarray(xyz[:, c]) for c in range(3)]
    vcols = [np.ascontiguousarray(view[:, c], dtype=np.float64) for c in range(3)]
    for s, qi, nb, ok in _neighbour_chunks(xyz, query, k, radius, tree, workers):
        dot = vcols[0][nb] * vcols[0][qi, None]
        dot += vcols[1][nb] * vcols[1][qi, None]
        dot += vcols[2][nb] * vcols[2][qi, None]
        ok &= dot > 0.0  # NaN compares False
        del dot
        _, n, cnt = _masked_pca(cols, nb, qi, ok)  # neighbours on the other side weigh 0
        n[cnt < min_points] = np.nan
        out[s:s + len(qi)] = n
    return out


def _split_inputs(xyz, query):
    """``xyz`` (n, 3) float64, ``query`` int64, NaN normals for the query points, and the
    points' contiguous x, y, z: what the split rules below start from."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    query = np.asarray(query, dtype=np.int64)
    return xyz, query, np.full((len(query), 3), np.nan), [np.ascontiguousarray(xyz[:, c]) for c in range(3)]


def _largest_gap(d: np.ndarray, cnt: np.ndarray, min_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Per row of (m, k) offsets of a point's neighbours along one direction (inf past its
    ``cnt`` neighbours): the largest gap between consecutive sorted offsets with at least
    ``min_points`` on either side (-inf: none) and the cut in its middle."""
    ds = np.sort(d, axis=1)
    with np.errstate(invalid="ignore"):  # inf - inf past the last neighbour: NaN, not a gap
        g = np.diff(ds, axis=1)  # the gap after sorted neighbour j
    j = np.arange(g.shape[1])[None, :]
    valid = (j + 1 >= min_points) & (cnt[:, None] - j - 1 >= min_points) & np.isfinite(g)
    g = np.where(valid, g, -np.inf)
    jb = np.argmax(g, axis=1)
    at = np.arange(len(d))
    return g[at, jb], 0.5 * (ds[at, jb] + ds[at, jb + 1])


SHEET_TILT = math.radians(25.0)
"""A sheet split is kept where the point's own sheet is horizontal within this (radians)."""


def sheet_normals(xyz: np.ndarray, query: np.ndarray, k: int, radius: float, gap: float, *,
                  min_points: int = 5, max_tilt: float = SHEET_TILT, planarity: float = 0.1,
                  min_spread: float = 0.05, tree=None, workers: Optional[int] = None) -> np.ndarray:
    """PCA normals of the query points over the neighbours of their own horizontal sheet,
    where the neighbourhood holds two sheets one above the other — the scan's stand-in for
    :func:`one_sided_normals` when no scanner positions are known (z up).

    A floor and the ceiling under its slab are two horizontal sheets 10-30 cm apart. On a
    sparse scan (a mobile scan thinned to 100k points: 16 floor points per m², the
    neighbourhood's radius 0.42 m) a floor point's nearest neighbours are mostly the ceiling
    below, and those of a scanner's lines are nearly collinear: the PCA normal of the mixture
    tilts anywhere (two_storey_office: the upper floor's median |n_z| 0.55; 29 of 241 points
    within 25° of vertical). Split at the neighbours' largest gap in height (at least
    ``gap`` metres, ``min_points`` on either side), the point's own side is a sheet again
    (224 of 241). The split is kept only where that side is a horizontal plane (normal within
    ``max_tilt`` of z, smallest eigenvalue at most ``planarity`` of the middle one) spread in
    two directions (middle eigenvalue at least ``min_spread`` of the largest): a wall's
    points cut between two of a scanner's lines leave a line, which is no sheet.

    Parameters
    ----------
    xyz : (n, 3) float64 — every point, metres, z up.
    query : (m,) int — the points to estimate.
    k, radius : at most ``k`` nearest neighbours within ``radius`` metres.
    gap : the least gap in height between the two sheets, metres.

    Returns (m, 3) float64 unit normals (sign arbitrary) or NaN rows (keep the other estimate).
    """
    xyz, query, out, cols = _split_inputs(xyz, query)
    if len(query) == 0 or len(xyz) < 2 * min_points:
        return out
    for s, qi, nb, ok in _neighbour_chunks(xyz, query, k, radius, tree, workers):
        dz = np.where(ok, cols[2][nb] - cols[2][qi, None], np.inf)
        best, cut = _largest_gap(dz, ok.sum(axis=1), min_points)
        split = best >= gap
        # the point's own side of the cut (its own dz is 0)
        keep = ok & np.where((cut > 0)[:, None], dz <= cut[:, None], dz > cut[:, None])
        w, n, n_keep = _masked_pca(cols, nb, qi, keep)
        good = (split & (n_keep >= min_points) & (np.abs(n[:, 2]) >= math.cos(max_tilt))
                & (w[:, 0] <= planarity * w[:, 1]) & (w[:, 1] >= min_spread * w[:, 2]))
        n[~good] = np.nan
        out[s:s + len(qi)] = n
    return out


def wall_sheet_normals(xyz: np.ndarray, query: np.ndarray, k: int, radius: float, gap: float, *,
                       directions: int = 12, min_points: int = 5, max_tilt: float = SHEET_TILT,
                       planarity: float = 0.1, min_spread: float = 0.05, tree=None,
                       workers: Optional[int] = None) -> np.ndarray:
    """PCA normals of the query points over the neighbours of their own vertical sheet, where
    the neighbourhood holds two sheets side by side: the two faces of a partition, without
    scanner positions (z up; :func:`sheet_normals` splits in height, :func:`one_sided_normals`
    by the side each point was seen from).

    On a sparse scan the normals' neighbourhood spans both faces of a 10-15 cm partition and
    its PCA normal lies anywhere (office_mw mobile at 300k points without positions, σ 9 cm:
    10 % of a partition's points faced it; 37 % with this, 68 % with positions and
    :func:`one_sided_normals`). The neighbours are projected on ``directions`` horizontal
    directions; along the one with the largest gap between consecutive neighbours (at least
    ``gap`` metres, ``min_points`` on either side) the point's own side is kept. The split
    stands where that side is a plane facing the split's direction (within ``max_tilt``),
    planar (smallest eigenvalue at most ``planarity`` of the middle one) and spread in two
    directions (``min_spread``, as in :func:`sheet_normals`). One noisy wall has no such gap;
    a wall and a floor, or two walls at a corner, fill every projection without one.

    Returns (m, 3) float64 unit normals (sign arbitrary) or NaN rows (keep the other estimate).
    """
    xyz, query, out, cols = _split_inputs(xyz, query)
    if len(query) == 0 or len(xyz) < 2 * min_points:
        return out
    angles = np.arange(directions) * (math.pi / directions)
    for s, qi, nb, ok in _neighbour_chunks(xyz, query, k, radius, tree, workers):
        m = len(qi)
        cnt = ok.sum(axis=1)
        dx = np.where(ok, cols[0][nb] - cols[0][qi, None], 0.0)
        dy = np.where(ok, cols[1][nb] - cols[1][qi, None], 0.0)
        best = np.full(m, -np.inf)
        cut = np.zeros(m)
        axis = np.zeros((m, 2))
        for a in angles:
            c, sn = math.cos(a), math.sin(a)
            gb, cb = _largest_gap(np.where(ok, dx * c + dy * sn, np.inf), cnt, min_points)
            better = gb > best
            best = np.where(better, gb, best)
            cut = np.where(better, cb, cut)
            axis[better] = (c, sn)
        t = dx * axis[:, 0:1] + dy * axis[:, 1:2]
        keep = ok & np.where((cut > 0)[:, None], t <= cut[:, None], t > cut[:, None])  # own side: t = 0
        w, n, n_keep = _masked_pca(cols, nb, qi, keep)
        facing = np.abs(n[:, 0] * axis[:, 0] + n[:, 1] * axis[:, 1])
        good = ((best >= gap) & (n_keep >= min_points) & (facing >= math.cos(max_tilt))
                & (w[:, 0] <= planarity * w[:, 1]) & (w[:, 1] >= min_spread * w[:, 2]))
        n[~good] = np.nan
        out[s:s + m] = n
    return out
