"""The point-on-face index (SPEC.md §2, rule 2): IPoF = n σ² / A_face.

n is the number of points within the shape buffer δ of a face and inside its extent, σ
the point spacing and A_face the face area. Scans are much denser near the scanner than
far from it, so counting raw points would call a small patch near the scanner "covered".
We therefore count points after thinning them to one per σ × σ cell of the face plane:
n σ² is then the area the points cover and IPoF the covered share of the face (≈ 1 for a
fully seen face, whatever the density). Only points whose normal is within θ of the
face's normal count (SPEC.md §1 clustering), so that the edge of a ceiling does not make
the side of a wall look seen.

Two entry points: :func:`grid_face_index` evaluates every face lying on one axis-aligned
plane of a grid at once (the Manhattan grammar), :func:`face_index` evaluates one planar
polygon of any orientation (reusable by the generic pipeline).
"""
from __future__ import annotations

import numpy as np

__all__ = ["grid_face_index", "face_index", "plane_cells"]


def plane_cells(uv: np.ndarray, spacing: float) -> np.ndarray:
    """Unique σ-cells hit by points projected on a plane.

    ``uv`` : (n, 2) float64, metres, in-plane coordinates. Returns (m, 2) float64 — the
    centres of the distinct cells (one per σ × σ cell holding at least one point).
    """
    if len(uv) == 0:
        return np.zeros((0, 2))
    cells = np.unique(np.floor(uv / spacing).astype(np.int64), axis=0)
    return (cells + 0.5) * spacing


def grid_face_index(uv: np.ndarray, u_edges: np.ndarray, v_edges: np.ndarray, spacing: float):
    """Point-on-face index of every rectangle of a grid on one plane.

    Parameters
    ----------
    uv : (n, 2) float64
        In-plane coordinates (metres) of the points already selected as lying within δ
        of the plane with a normal along the plane's normal.
    u_edges : (a + 1,) float64, increasing — the grid's cuts along u, metres.
    v_edges : (b + 1,) float64, increasing — the grid's cuts along v, metres.
    spacing : σ, metres.

    Returns
    -------
    ipof : (a, b) float64 — n σ² / A of each rectangle (0 for an empty grid).
    """
    a, b = len(u_edges) - 1, len(v_edges) - 1
    out = np.zeros((max(a, 0), max(b, 0)))
    if a <= 0 or b <= 0 or len(uv) == 0:
        return out
    c = plane_cells(uv, spacing)
    iu = np.searchsorted(u_edges, c[:, 0], side="right") - 1
    iv = np.searchsorted(v_edges, c[:, 1], side="right") - 1
    ok = (iu >= 0) & (iu < a) & (iv >= 0) & (iv < b)
    np.add.at(out, (iu[ok], iv[ok]), 1.0)
    area = np.outer(np.diff(u_edges), np.diff(v_edges))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(area > 0, out * spacing**2 / area, 0.0)


def face_index(points: np.ndarray, normals, polygon: np.ndarray, normal: np.ndarray,
               buffer: float, spacing: float, max_angle: float) -> float:
    """Point-on-face index of one planar polygon.

    Parameters
    ----------
    points : (n, 3) float64 — metres.
    normals : (n, 3) float or None — unit normals (None: every point counts).
    polygon : (k, 3) float64 — the face's vertices, metres, planar.
    normal : (3,) float64 — the face's unit normal.
    buffer : δ, metres. spacing : σ, metres. max_angle : θ, radians.

    Returns the index (0.0 for a degenerate face).
    """
    from shapely import contains_xy
    from shapely.geometry import Polygon

    normal = np.asarray(normal, dtype=np.float64)
    poly = np.asarray(polygon, dtype=np.float64).reshape(-1, 3)
    # an orthonormal in-plane basis
    helper = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    d = (np.asarray(points) - poly[0]) @ normal
    sel = np.abs(d) <= buffer
    if normals is not None:
        sel &= np.abs(np.asarray(normals, dtype=np.float64) @ normal) >= np.cos(max_angle)
    p2 = Polygon(np.column_stack([poly @ u, poly @ v]))
    if p2.area <= 0:
        return 0.0
    pts = np.asarray(points)[sel]
    c = plane_cells(np.column_stack([pts @ u, pts @ v]), spacing)
    if len(c) == 0:
        return 0.0
    inside = contains_xy(p2, c[:, 0], c[:, 1])
    return float(inside.sum() * spacing**2 / p2.area)
