"""PCA of k-nearest-neighbour neighbourhoods: point normals and the local shape statistics.

One kernel (a k-d tree query, the batched scatter matrices, ``eigh``) serves the normal
fallback of the preprocessing, the frame checks' sample statistics, the registration's
check normals and the change detection's normals of ambiguous points.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..threads import thread_cap
from .kdtree import kdtree

__all__ = ["knn_pca", "knn_normals"]


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
