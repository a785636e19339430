"""Solids under sloped ceilings: a vertical prism cut by roof planes (issue 19, attic rooms).

A room under a pitched roof is the set ``{(x, y, z): (x, y) ∈ F, z0 ≤ z ≤ h(x, y)}`` over its
footprint F, with ``h = min(z1, f_1, …, f_k)`` the lower envelope of its flat top z1 and the
roof planes ``f_i(x, y)`` over it. :func:`sloped_prism` builds that boundary: the bottom,
one top face per region of F where one plane (or the flat top) is lowest, and one vertical
side per footprint edge whose upper edge follows h (broken where it crosses a region).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from shapely.geometry import Polygon

from ..model import Polyhedron
from .polygon import polygon_parts

__all__ = ["RoofPlane", "sloped_prism"]

_EPS = 1e-7


@dataclass(frozen=True)
class RoofPlane:
    """The plane ``nᵀp = d`` (unit normal ``n`` with n_z ≠ 0), as a height ``z = f(x, y)``."""

    normal: tuple
    d: float

    def z(self, x, y):
        nx, ny, nz = self.normal
        return (self.d - nx * np.asarray(x, dtype=np.float64) - ny * np.asarray(y, dtype=np.float64)) / nz

    def coefficients(self) -> tuple[float, float, float]:
        """(a, b, c) with ``f(x, y) = a x + b y + c``."""
        nx, ny, nz = self.normal
        return -nx / nz, -ny / nz, self.d / nz


def _below(box: Polygon, a: float, b: float, c: float) -> Polygon:
    """``box ∩ {a x + b y + c ≤ 0}`` (Sutherland–Hodgman on the convex box)."""
    pts = np.asarray(box.exterior.coords)[:-1]
    val = a * pts[:, 0] + b * pts[:, 1] + c
    out = []
    for i in range(len(pts)):
        p, q, vp, vq = pts[i], pts[(i + 1) % len(pts)], val[i], val[(i + 1) % len(pts)]
        if vp <= 0:
            out.append(p)
        if (vp < 0 < vq) or (vq < 0 < vp):
            out.append(p + (q - p) * (vp / (vp - vq)))
    return Polygon(out) if len(out) >= 3 else Polygon()


def sloped_prism(footprint, z0: float, z1: float, planes: Sequence[RoofPlane], *,
                 min_height: float = 0.05) -> Optional[Polyhedron]:
    """The prism over ``footprint`` ((k, 2) metres, one simple ring) from ``z0`` up to
    ``min(z1, planes)`` (module doc); None when no plane dips below ``z1`` over the footprint,
    when the footprint has holes, or when h comes within ``min_height`` of the floor
    somewhere (a roof reaching the floor: the caller keeps its box)."""
    F = Polygon(np.asarray(footprint, dtype=np.float64)).buffer(0)
    if F.geom_type != "Polygon" or F.interiors or F.area <= 0:
        return None
    ring = np.asarray(F.exterior.coords)[:-1]
    if Polygon(ring).exterior.is_ccw is False:
        ring = ring[::-1]

    def h(x, y):
        z = np.full(np.shape(x), float(z1))
        for p in planes:
            z = np.minimum(z, p.z(x, y))
        return z

    minx, miny, maxx, maxy = F.bounds
    box = Polygon([(minx - 1, miny - 1), (maxx + 1, miny - 1), (maxx + 1, maxy + 1), (minx - 1, maxy + 1)])
    coef = [p.coefficients() for p in planes]
    tops = []  # (polygon part, height function index: -1 flat, i plane)
    for i in range(-1, len(planes)):
        region = F
        ai, bi, ci = (0.0, 0.0, float(z1)) if i < 0 else coef[i]
        others = [(0.0, 0.0, float(z1))] * (i >= 0) + [coef[j] for j in range(len(planes)) if j != i]
        for aj, bj, cj in others:  # f_i <= f_j, with ties to the lower index
            region = region.intersection(_below(box, ai - aj, bi - bj, ci - cj))
            if region.is_empty:
                break
        for part in (q for q in polygon_parts(region) if q.area > 1e-6):
            if part.interiors:
                return None
            tops.append((part, i))
    if len(tops) <= 1 and (not tops or tops[0][1] < 0):
        return None
    verts: dict = {}

    def vid(x, y, z) -> int:
        key = (round(x / _EPS), round(y / _EPS), round(z / _EPS))
        if key not in verts:
            verts[key] = (len(verts), (float(x), float(y), float(z)))
        return verts[key][0]

    faces = []
    bottom = [vid(x, y, z0) for x, y in ring[::-1]]
    faces.append(tuple(bottom))
    breaks = []
    for part, i in tops:
        r = np.asarray(part.exterior.coords)[:-1]
        if not part.exterior.is_ccw:
            r = r[::-1]
        z = np.full(len(r), float(z1)) if i < 0 else planes[i].z(r[:, 0], r[:, 1])
        if float(z.min()) < z0 + min_height:
            return None
        faces.append(tuple(vid(x, y, zz) for (x, y), zz in zip(r, z)))
        breaks.append(r)
    breaks = np.vstack(breaks)
    for k in range(len(ring)):
        p, q = ring[k], ring[(k + 1) % len(ring)]
        e = q - p
        L2 = float(e @ e)
        t = (breaks - p) @ e / L2
        off = np.abs((breaks[:, 0] - p[0]) * e[1] - (breaks[:, 1] - p[1]) * e[0]) / np.sqrt(L2)
        on = (t > 1e-9) & (t < 1 - 1e-9) & (off < 1e-6)
        ts = np.unique(np.round(t[on], 9))
        pts = np.vstack([p, p + ts[:, None] * e, q]) if len(ts) else np.vstack([p, q])
        zt = h(pts[:, 0], pts[:, 1])
        side = [vid(*p, z0), vid(*q, z0)] + [vid(x, y, z) for (x, y), z in zip(pts[::-1], zt[::-1])]
        faces.append(tuple(side))
    v = np.array([c for _, c in sorted(verts.values())])
    return Polyhedron(v, faces)
