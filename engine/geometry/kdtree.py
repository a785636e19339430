"""One k-d tree builder for point clouds.

SciPy's default (a balanced tree with compact nodes) spends most of a 1M-point build on the
median splits and the node shrinking; on scans (dense near the scanner, sparse far away) an
unbalanced sliding-midpoint tree builds 2-3x faster and answers ball and kNN queries as fast
or faster (1M-point office scan: build 0.35 -> 0.13 s, 20k ball counts 0.74 -> 0.44 s). The
results are the same (exact queries); only the order of equidistant neighbours may differ.
Build one per cloud and share it between the stages that query the same points
(:func:`engine.geometry.spacing.estimate_spacing`, :func:`engine.grammar.params.estimate_noise`,
the normals' fallback) instead of one each.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .boxes import column_max, column_min
from .sort import stable_argsort

__all__ = ["kdtree", "spatial_order"]


def kdtree(points: np.ndarray) -> cKDTree:
    """A :class:`scipy.spatial.cKDTree` of ``points`` ((n, d) float), built for speed."""
    return cKDTree(np.asarray(points, dtype=np.float64), balanced_tree=False, compact_nodes=False)


def _spread_bits(v: np.ndarray) -> np.ndarray:
    """The low 21 bits of each value spread to every third bit (for a 3D Morton key)."""
    v = v.astype(np.int64) & 0x1FFFFF
    v = (v | (v << 32)) & 0x1F00000000FFFF
    v = (v | (v << 16)) & 0x1F0000FF0000FF
    v = (v | (v << 8)) & 0x100F00F00F00F00F
    v = (v | (v << 4)) & 0x10C30C30C30C30C3
    v = (v | (v << 2)) & 0x1249249249249249
    return v


def spatial_order(points: np.ndarray, cell: float) -> np.ndarray:
    """(n,) int64 permutation putting ``points`` ((n, 3), metres) in Morton (z-) order of cells
    of edge ``cell`` (enlarged so the extent fits 2^21 cells per axis).

    Neighbourhood queries answered in this order walk the tree's nodes and the points' memory
    in step: open3d's normals of a 1M-point mobile scan (points in the trajectory's order)
    take 1.8 s instead of 3.1 s, with the same result.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0:
        return np.zeros(0, np.int64)
    lo = column_min(p)
    cell = max(float(cell), float((column_max(p) - lo).max()) / (2**21 - 1), 1e-9)
    q = np.floor((p - lo) / cell).astype(np.int64)
    key = _spread_bits(q[:, 0]) | (_spread_bits(q[:, 1]) << 1) | (_spread_bits(q[:, 2]) << 2)
    return stable_argsort(key)
