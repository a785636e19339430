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

__all__ = ["kdtree"]


def kdtree(points: np.ndarray) -> cKDTree:
    """A :class:`scipy.spatial.cKDTree` of ``points`` ((n, d) float), built for speed."""
    return cKDTree(np.asarray(points, dtype=np.float64), balanced_tree=False, compact_nodes=False)
