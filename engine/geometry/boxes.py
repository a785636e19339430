"""Oriented boxes: the minimum-area box of a point set about the z axis."""
from __future__ import annotations

import numpy as np

__all__ = ["min_area_box", "box_sides", "column_min", "column_max"]


def column_min(a: np.ndarray) -> np.ndarray:
    """``a.min(axis=0)`` of an (n, d) array, a column at a time: numpy reduces an (n, 3)
    C-ordered array along its rows 3-4x slower than it reduces its strided columns."""
    a = np.asarray(a)
    return np.array([a[:, i].min() for i in range(a.shape[1])], dtype=a.dtype)


def column_max(a: np.ndarray) -> np.ndarray:
    """``a.max(axis=0)`` of an (n, d) array, a column at a time (see :func:`column_min`)."""
    a = np.asarray(a)
    return np.array([a[:, i].max() for i in range(a.shape[1])], dtype=a.dtype)


def min_area_box(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The minimum-area oriented box of ``vertices`` about the z axis (rotating calipers).

    Parameters
    ----------
    vertices : (n, 3) float64 — metres.

    Returns
    -------
    origin : (3,) float64 — the box corner, metres.
    axes : (3, 3) float64 — rows X, Y, Z: X along the longer horizontal side, Z = up.
    size : (3,) float64 — extent along each axis, metres.
    No vertices give a zero box at the origin.
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if len(v) == 0:
        return np.zeros(3), np.eye(3), np.zeros(3)
    zmin, zmax = v[:, 2].min(), v[:, 2].max()
    xy = v[:, :2]
    best = None
    try:
        from scipy.spatial import ConvexHull  # here: scipy.spatial costs 0.4 s to import

        hull = xy[ConvexHull(xy).vertices] if len(xy) >= 3 else xy
    except Exception:  # collinear or too few points
        hull = xy
    edges = np.diff(np.vstack([hull, hull[:1]]), axis=0)
    angles = np.unique(np.round(np.mod(np.arctan2(edges[:, 1], edges[:, 0]), np.pi / 2), 9))
    if len(angles) == 0:
        angles = np.array([0.0])
    for a in angles:
        c, s = np.cos(a), np.sin(a)
        ax = np.array([[c, s], [-s, c]])
        p = hull @ ax.T
        lo, hi = p.min(axis=0), p.max(axis=0)
        area = float(np.prod(hi - lo))
        if best is None or area < best[0] - 1e-12:
            best = (area, ax, lo, hi)
    _, ax, lo, hi = best
    size2 = hi - lo
    if size2[0] < size2[1] - 1e-9:  # X along the longer side
        ax = np.array([ax[1], -ax[0]])
        p = hull @ ax.T
        lo, hi = p.min(axis=0), p.max(axis=0)
        size2 = hi - lo
    origin2 = ax.T @ lo
    axes = np.array([[ax[0, 0], ax[0, 1], 0.0], [ax[1, 0], ax[1, 1], 0.0], [0.0, 0.0, 1.0]])
    return np.array([origin2[0], origin2[1], zmin]), axes, np.array([size2[0], size2[1], zmax - zmin])


def box_sides(geom) -> tuple[float, float]:
    """(shorter, longer) side of a shapely geometry's minimum-area bounding rectangle (shapely's
    ``minimum_rotated_rectangle``; :func:`min_area_box` is the same box of an (n, 3) vertex
    array), metres; (0, length) for a degenerate one, (0, 0) for an empty one."""
    if geom is None or geom.is_empty:
        return 0.0, 0.0
    box = geom.minimum_rotated_rectangle
    c = np.asarray(getattr(box, "exterior", box).coords)  # a line or a point when degenerate
    if len(c) < 3:
        return 0.0, float(np.linalg.norm(c[-1] - c[0]))
    a, b = float(np.linalg.norm(c[1] - c[0])), float(np.linalg.norm(c[2] - c[1]))
    return min(a, b), max(a, b)
