"""The point-on-face index (docs/method.md §2, thesis Eq. 3.1): IPoF = n σ² / A_face.

n is the number of points within the shape buffer δ of a face and inside its extent, σ
the point spacing and A_face the face area. Scans are much denser near the scanner than
far from it, so counting raw points would call a small patch near the scanner "covered".
We therefore count points after thinning them to one per σ × σ cell of the face plane:
n σ² is then the area the points cover and IPoF the covered share of the face (≈ 1 for a
fully seen face, whatever the density). Only points whose normal is within θ of the
face's normal count (as in the point clustering, docs/method.md §1), so that the edge of a
ceiling does not make the side of a wall look seen.

Two entry points: :func:`grid_face_index` evaluates every face lying on one axis-aligned
plane of a grid at once (the Manhattan grammar), :func:`face_index` evaluates one planar
polygon of any orientation (reusable by the generic pipeline).
"""
from __future__ import annotations

import numpy as np

from ..threads import thread_cap

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


def local_radii(uv: np.ndarray, spacing: float, max_radius: float, k: int = 4) -> np.ndarray:
    """Each point's sampling radius on its plane: the local spacing, never below σ.

    The local spacing is √(π / k) times the distance to the k-th nearest neighbour in the
    plane (1 / √density for a uniform sampling). A point whose local spacing exceeds
    ``max_radius`` is isolated (a stray, not a sparsely seen surface) and keeps σ.
    """
    from scipy.spatial import cKDTree

    r = np.full(len(uv), float(spacing))
    if len(uv) <= k or max_radius <= spacing:
        return r
    d, _ = cKDTree(uv).query(uv, k=k + 1, workers=thread_cap())
    s = d[:, -1] * np.sqrt(np.pi / k)
    grow = (s > spacing) & (s <= max_radius)
    r[grow] = s[grow]
    return r


def grid_face_index(uv: np.ndarray, u_edges: np.ndarray, v_edges: np.ndarray, spacing: float,
                    margin: float = 0.0, resolution: float | None = None, max_radius: float = 0.0,
                    radii: np.ndarray | None = None, thin: float = 0.0, thin_margin: float = 0.0):
    """Point-on-face index of every rectangle of a grid on one plane.

    The covered area n σ² is measured as the union of discs of radius σ around the
    points (rasterised at ``resolution`` and dilated), clipped to each rectangle: overlaps
    count once, so a dense patch cannot score above 1, and randomly sampled surfaces at
    spacing σ are fully covered.

    Parameters
    ----------
    uv : (n, 2) float64
        In-plane coordinates (metres) of the points already selected as lying within δ
        of the plane with a normal along the plane's normal.
    u_edges : (a + 1,) float64, increasing — the grid's cuts along u, metres.
    v_edges : (b + 1,) float64, increasing — the grid's cuts along v, metres.
    spacing : σ, metres.
    margin : points closer than this to a rectangle's edge do not count, and the area is
        shrunk alike (at most a quarter of each side), metres. With margin = 2 σ_noise,
        the noisy edge of a neighbouring surface (a ceiling meeting a wall) does not make
        the top of a thin wall look seen.
    resolution : raster cell, metres (default σ / 3, at least 1 cm).
    max_radius : > σ: each disc's radius is its point's local spacing up to this
        (:func:`local_radii`), so that a surface seen sparsely from far away (a ceiling seen
        at a grazing angle, or through a door) counts as seen where its points lie evenly;
        0: every disc has radius σ.
    radii : (n,) float64 or None — each point's radius, metres, already known (e.g.
        :func:`local_radii` over a larger neighbourhood than the grid's); overrides
        ``max_radius``.
    thin, thin_margin : a rectangle at most ``thin`` wide along an axis has the margin
        ``thin_margin`` across it, up to a third of its width (metres; 0: off). A ceiling's
        points near a wall, pushed along their shallow rays by the range noise, fall into the
        wall's footprint at the ceiling's height, from both sides, further than the margin
        (the range noise is about twice the surface noise measured across a surface): over a
        thin cuboid (a wall, a doorway) they covered the core (Duplex, 1M mobile points: a
        doorway's top 0.48, a bedroom and its hallway one room).

    Returns
    -------
    ipof : (a, b) float64 — covered area / area of each rectangle, 0–1 (0 for an empty grid).
    """
    from scipy.ndimage import binary_dilation

    a, b = len(u_edges) - 1, len(v_edges) - 1
    out = np.zeros((max(a, 0), max(b, 0)))
    if a <= 0 or b <= 0 or len(uv) == 0:
        return out
    h = float(resolution) if resolution else max(spacing / 3.0, 0.01)
    u0, v0 = u_edges[0], v_edges[0]
    nu = max(int(np.ceil((u_edges[-1] - u0) / h)), 1)
    nv = max(int(np.ceil((v_edges[-1] - v0) / h)), 1)
    # raster cell centres → rectangle index, or -1 inside the margin / outside the grid
    du, dv = np.diff(u_edges), np.diff(v_edges)
    mu, mv = np.minimum(margin, du / 4), np.minimum(margin, dv / 4)
    if thin > 0:
        mu = np.where(du <= thin, np.minimum(du / 3, np.maximum(thin_margin, mu)), mu)
        mv = np.where(dv <= thin, np.minimum(dv / 3, np.maximum(thin_margin, mv)), mv)

    def cell_owner(edges, n, origin, m):  # (the owner or -1, the rectangle the centre lies in)
        c = origin + (np.arange(n) + 0.5) * h
        i = np.clip(np.searchsorted(edges, c, side="right") - 1, 0, len(edges) - 2)
        ok = (c >= edges[i] + m[i]) & (c <= edges[i + 1] - m[i]) & (c >= edges[0]) & (c <= edges[-1])
        return np.where(ok, i, -1), i

    (ou, ru), (ov, rv) = cell_owner(u_edges, nu, u0, mu), cell_owner(v_edges, nv, v0, mv)
    iu = np.floor((uv[:, 0] - u0) / h).astype(np.int64)
    iv = np.floor((uv[:, 1] - v0) / h).astype(np.int64)
    ok = (iu >= 0) & (iu < nu) & (iv >= 0) & (iv < nv)
    iu, iv, pts = iu[ok], iv[ok], uv[ok]
    if radii is not None:
        radii = np.asarray(radii, dtype=np.float64)[ok]

    def owner(t, edges, m):
        i = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(edges) - 2)
        return np.where((t >= edges[i] + m[i]) & (t <= edges[i + 1] - m[i]), i, -1)

    # a point counts only for the rectangle that holds it (its own coordinates, not its
    # raster cell's; and not inside the margin)
    pu, pv = owner(pts[:, 0], u_edges, mu), owner(pts[:, 1], v_edges, mv)
    keep = (pu >= 0) & (pv >= 0)
    iu, iv, pu, pv = iu[keep], iv[keep], pu[keep], pv[keep]
    # radius classes: σ, and (adaptive) σ·1.5^j up to max_radius, each point in the largest
    # class not above its local spacing
    top = float(radii[keep].max(initial=spacing)) if radii is not None else max_radius
    levels = [float(spacing)]
    while top > spacing and levels[-1] * 1.5 <= top + 1e-12:
        levels.append(levels[-1] * 1.5)
    if len(levels) > 1:
        r = radii[keep] if radii is not None else local_radii(pts[keep], spacing, max_radius)
        cls = np.clip(np.searchsorted(np.asarray(levels), r * (1 + 1e-9), side="right") - 1, 0, None)
    else:
        cls = np.zeros(len(iu), dtype=np.int64)
    # discs must not spill into a neighbouring rectangle: every rectangle is dilated on its
    # own, in one pass over a raster with 2 k empty rows and columns between rectangles (each
    # raster row and column moves 2 k per rectangle boundary before it; a point to its own
    # rectangle's side, even when its raster cell lies just across the edge)
    gap = 2 * int(np.ceil(levels[-1] / h))
    shape = (nu + gap * a, nv + gap * b)
    cover = np.zeros(shape, dtype=bool)
    piu, piv = iu + gap * pu, iv + gap * pv
    for c in np.unique(cls):
        k = int(np.ceil(levels[c] / h))
        yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
        grid = np.zeros(shape, dtype=bool)
        grid[piu[cls == c], piv[cls == c]] = True
        cover |= binary_dilation(grid, structure=(xx**2 + yy**2) * h * h <= levels[c] ** 2)
    vu, vv = np.flatnonzero(ou >= 0), np.flatnonzero(ov >= 0)
    face = ou[vu][:, None] * b + ov[vv][None, :]
    mine = cover[np.ix_(vu + gap * ru[vu], vv + gap * rv[vv])]
    covered = np.bincount(face[mine], minlength=a * b).reshape(a, b)
    total = np.bincount(face.ravel(), minlength=a * b).reshape(a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(total > 0, covered / np.maximum(total, 1), 0.0)
    _thin_rectangles(out, total, pu, pv, pts[keep], np.asarray(levels)[cls], u_edges, v_edges, mu, mv)
    return out


def _thin_rectangles(out, total, pu, pv, pts, r, u_edges, v_edges, mu, mv) -> None:
    """The index of the rectangles that hold no raster cell (thinner than a cell once their
    margins are off: a sliver between two cuts a few centimetres apart), in place: the share
    of its centre line, along its long side, that its own points' discs cover. On the raster
    it read 0 whatever lay on it (the Duplex's hallway, 100k terrestrial points: a 6 cm strip
    between two rooms' wall lines, floor and ceiling points as dense as in the room beside it,
    was an unseen cuboid, and the hallway ended at it). ``pu``, ``pv``, ``pts``, ``r``: the
    points that count (their rectangle, in-plane coordinates, disc radius)."""
    thin = np.argwhere(total == 0)
    if not len(thin) or not len(pts):
        return
    key = pu * out.shape[1] + pv
    order = np.argsort(key, kind="stable")
    key = key[order]
    for i, j in thin:
        lo = np.array([u_edges[i] + mu[i], v_edges[j] + mv[j]])
        hi = np.array([u_edges[i + 1] - mu[i], v_edges[j + 1] - mv[j]])
        if np.any(hi <= lo):
            continue
        k0, k1 = np.searchsorted(key, [i * out.shape[1] + j, i * out.shape[1] + j + 1])
        if k1 == k0:
            continue
        own, rad = pts[order[k0:k1]], r[order[k0:k1]]
        along = int(np.argmax(hi - lo))  # the long side; the centre line runs along it
        mid = 0.5 * (lo[1 - along] + hi[1 - along])
        half = np.sqrt(np.maximum(rad ** 2 - (own[:, 1 - along] - mid) ** 2, 0.0))
        s = np.clip(own[:, along] - half, lo[along], hi[along])
        e = np.clip(own[:, along] + half, lo[along], hi[along])
        o = np.argsort(s)
        s, e = s[o], np.maximum.accumulate(e[o])  # union of the intervals, left to right
        start = np.r_[s[0], np.maximum(s[1:], e[:-1])]
        out[i, j] = float(np.sum(np.maximum(e - start, 0.0)) / (hi[along] - lo[along]))


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
    uv = np.column_stack([pts @ u, pts @ v])
    if len(uv) == 0:
        return 0.0
    inside = contains_xy(p2, uv[:, 0], uv[:, 1])
    c = plane_cells(uv[inside], spacing)
    return float(len(c) * spacing**2 / p2.area)
