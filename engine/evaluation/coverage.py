"""Points on surfaces: which points lie on which planar patch, and how much of it they cover.

Shared by the visibility annotation of references (point-on-face index) and by the change
detection (point classification, surface coverage by 2D alpha shapes, docs/method.md §5).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from ..errors import Cancelled
from ..geometry import alpha
from ..geometry.sort import stable_argsort
from .patches import PlanarPatch, points_inside

__all__ = ["PatchSupport", "patch_support", "alpha_area", "thin_grid", "PointBuckets"]

BUCKET_CELL = 1.0
"""Grid size of the buckets that limit each surface's candidate points to its box, metres."""
CORNER_COS = float(np.cos(np.radians(45.0)))
"""Two surfaces whose normals differ by more than 45° make a corner (or an edge)."""


def thin_grid(xy: np.ndarray, cell: float) -> np.ndarray:
    """Keep one point per ``cell``-sized square of a grid starting at the points' minimum
    corner (the last point of each, in cell order): (n, 2) float64 → (m, 2) float64, m ≤ n."""
    return alpha.thin_grid(np.asarray(xy, dtype=np.float64).reshape(-1, 2), cell, anchor="min", keep="last")


def alpha_area(xy: np.ndarray, r_alpha: float, *, thin: Optional[float] = None) -> float:
    """Area (m²) of the 2D alpha shape of points: the Delaunay triangles whose circumradius
    is below ``r_alpha`` (metres).

    ``xy`` : (n, 2) float64, metres. ``thin`` : the points are first thinned to one per
    cell of a raster of this size (:func:`thin_grid`, default ``r_alpha / 4``), which bounds
    the work while the kept triangles stay far below ``r_alpha``.
    Fewer than 3 points, or collinear points, give 0.
    """
    return alpha.alpha_area(thin_grid(xy, r_alpha / 4 if thin is None else thin), r_alpha)


@dataclass(frozen=True, eq=False)
class PatchSupport:
    """Which points lie on which patch.

    Attributes
    ----------
    on_model : (n,) bool
        The point is within ``max_distance`` of some patch whose outline contains its
        projection (and whose normal agrees, when normals are used).
    distance : (n,) float64
        |distance| to the closest patch whose outline contains the projection (and whose
        normal agrees), metres; ``inf`` when none is within ``search_distance``.
    patch : (n,) int32
        Index of that patch (-1 when none).
    members : list of (k_j,) int64
        For each patch, the indices of the points within ``max_distance`` of it (inside
        its outline, normal agreeing) — a point may support several patches.
    """

    on_model: np.ndarray
    distance: np.ndarray
    patch: np.ndarray
    members: list


class PointBuckets:
    """Points sorted into a coarse 3D grid, to fetch those inside a box quickly.

    ``xyz`` : (n, 3) float64 metres; ``cell`` : grid size, metres.
    """

    def __init__(self, xyz: np.ndarray, cell: float = 1.0):
        self.xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        self.cell = float(cell)
        if len(self.xyz) == 0:
            self.lo = np.zeros(3)
            self.dims = np.ones(3, dtype=np.int64)
            self.order = np.zeros(0, dtype=np.int64)
            self.starts = np.zeros(2, dtype=np.int64)
            return
        self.lo = self.xyz.min(axis=0)
        ijk = np.floor((self.xyz - self.lo) / self.cell).astype(np.int64)
        self.dims = ijk.max(axis=0) + 1
        code = (ijk[:, 0] * self.dims[1] + ijk[:, 1]) * self.dims[2] + ijk[:, 2]
        self.order = stable_argsort(code)
        self.starts = np.searchsorted(code[self.order], np.arange(int(np.prod(self.dims)) + 1))

    def in_box(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Indices (k,) int64 of the points in the cells meeting the box [lo, hi] (a superset
        of the points inside it)."""
        a = np.clip(np.floor((np.asarray(lo) - self.lo) / self.cell).astype(np.int64), 0, self.dims - 1)
        b = np.clip(np.floor((np.asarray(hi) - self.lo) / self.cell).astype(np.int64), 0, self.dims - 1)
        if np.any(np.asarray(hi) < self.lo) or len(self.order) == 0:
            return np.zeros(0, dtype=np.int64)
        i, j = np.meshgrid(np.arange(a[0], b[0] + 1), np.arange(a[1], b[1] + 1), indexing="ij")
        base = ((i * self.dims[1] + j) * self.dims[2]).ravel()
        first = self.starts[base + a[2]]
        last = self.starts[base + b[2] + 1]
        parts = [self.order[f:l] for f, l in zip(first, last) if l > f]
        return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)


def patch_support(patches: Sequence[PlanarPatch], xyz: np.ndarray, max_distance: float, *,
                  normals: Optional[np.ndarray] = None, max_normal_angle: Optional[float] = None,
                  search_distance: Optional[float] = None, should_stop=None) -> PatchSupport:
    """Assign points to the planar patches they lie on (vectorised per patch).

    Parameters
    ----------
    patches : list of PlanarPatch
    xyz : (n, 3) float64
        Points in the patches' frame, metres.
    max_distance : float
        r: a point lies on a patch when |nᵀp − ρ| ≤ r and its projection is inside.
    normals : (n, 3) float, optional
        Point normals; with ``max_normal_angle`` (radians) a point only lies on a patch
        whose normal is within that angle (either direction). A point within r of two
        non-parallel surfaces (an edge or corner of the model, where estimated normals
        are blurred) is on the model whatever its normal; ``members`` and ``distance``
        still only use surfaces the normal agrees with.
    search_distance : float, optional
        Distances are reported up to this (default ``max_distance``), metres.
    should_stop : callable, optional
        Polled once per patch; see :class:`engine.progress.Progress`.
    """
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    n = len(xyz)
    search = max(float(search_distance or 0.0), float(max_distance))
    best = np.full(n, np.inf)
    best_patch = np.full(n, -1, dtype=np.int32)
    near_any = np.zeros(n, dtype=bool)      # within r of some surface, inside its outline
    agree = np.zeros(n, dtype=bool)         # ... and the normal agrees with one of them
    first_n = np.zeros((n, 3))              # normal of the first such surface
    corner = np.zeros(n, dtype=bool)        # near two non-parallel surfaces
    members = []
    use_normals = normals is not None and max_normal_angle is not None
    if use_normals:
        nrm = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        cos_n = float(np.cos(max_normal_angle))
    buckets = PointBuckets(xyz, BUCKET_CELL)
    for j, pt in enumerate(patches):
        if should_stop is not None and should_stop():
            raise Cancelled("cancelled by the user")
        outline = np.vstack(pt.outline3d())
        cand = buckets.in_box(outline.min(axis=0) - search, outline.max(axis=0) + search)
        dc = np.abs(xyz[cand] @ pt.normal - pt.rho)
        keep = dc <= search
        idx, dj = cand[keep], dc[keep]
        if len(idx):
            inside = points_inside(pt, pt.to2d(xyz[idx]))
            idx, dj = idx[inside], dj[inside]
        near = idx[dj <= max_distance]
        if use_normals:
            ok = np.abs(nrm[idx] @ pt.normal) >= cos_n
            if len(near):
                seen = near_any[near]
                corner[near[seen]] |= np.abs(first_n[near[seen]] @ pt.normal) < CORNER_COS
                first_n[near[~seen]] = pt.normal
                near_any[near] = True
                agree[near[ok[dj <= max_distance]]] = True
            idx, dj, near = idx[ok], dj[ok], near[ok[dj <= max_distance]]
        members.append(near)
        closer = dj < best[idx]
        best[idx[closer]] = dj[closer]
        best_patch[idx[closer]] = j
    if use_normals:
        on = agree | corner
        return PatchSupport(on, best, best_patch, members)
    on = best <= max_distance
    return PatchSupport(on, best, best_patch, members)
