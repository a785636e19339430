"""Point spacing of a surface sample."""
from __future__ import annotations

import numpy as np
from ..threads import thread_cap
from .kdtree import kdtree, spatial_order

__all__ = ["estimate_spacing"]


def estimate_spacing(xyz: np.ndarray, sample: int = 20000, radius: float = 0.1, percentile: float = 10.0,
                     rng=0, tree=None) -> float:
    """Surface point spacing σ = 1/sqrt(ρ), ρ a low percentile of the local surface density.

    Parameters
    ----------
    xyz : (n, 3) float64 — metres.
    sample : number of query points (random, ``rng``).
    radius : neighbourhood radius, metres; ρ = (neighbours) / (π r²).
    percentile : which percentile of ρ (0–100). A terrestrial scan is much denser near
        the scanner than on the far walls; taking the sparsest tenth (10) makes σ the
        spacing of the far surfaces, so that they can still reach τ (IPoF counts one
        point per σ × σ cell, so a denser patch cannot score above 1).
    tree : a k-d tree of ``xyz`` (:func:`engine.geometry.kdtree.kdtree`) to share, or None.

    Returns σ in metres (0.0 for fewer than two points). This is density-based rather
    than nearest-neighbour based: for random sampling the nearest-neighbour distance is
    about half of 1/sqrt(ρ), which would make a fully seen face score ~0.25, not 1.
    """
    rng = np.random.default_rng(rng)
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if len(xyz) < 2:
        return 0.0
    tree = kdtree(xyz) if tree is None else tree
    q = xyz if len(xyz) <= sample else xyz[rng.choice(len(xyz), sample, replace=False)]
    q = q[spatial_order(q, radius)]  # queries in space order: faster, same counts
    r = radius
    for _ in range(4):  # widen the ball until it holds enough neighbours to count on
        counts = tree.query_ball_point(q, r=r, return_length=True, workers=thread_cap()).astype(np.float64)
        if np.percentile(counts, percentile) >= 8:
            break
        r *= 2
    rho = np.percentile(np.maximum(counts - 1, 1), percentile) / (np.pi * r**2)
    return float(1.0 / np.sqrt(rho))
