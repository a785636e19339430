"""Polygons and polyhedra: shoelace areas, Newell normals, triangulation, volume, plan outline.

A polygon is a (k, 2) or (k, 3) float64 array of vertices in order (not closed: the last
vertex is not repeated); a polyhedron is ``(vertices (n, 3) float64, faces)`` with faces as
sequences of vertex indices, counter-clockwise seen from outside. Lengths in metres.
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np
from shapely.geometry import Polygon
from shapely.ops import unary_union

__all__ = ["signed_area", "polygon_area", "area_3d", "newell_normal", "triangulate_polygon",
           "triangulate_faces", "polyhedron_volume", "prism_footprint", "plan_area_perimeter", "polygon_parts"]


def signed_area(xy: np.ndarray) -> float:
    """Shoelace area of a 2-D polygon ``xy`` (k, 2), m²: positive when counter-clockwise."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    x, y = xy[:, 0], xy[:, 1]
    return float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)) / 2


def polygon_area(xy: np.ndarray) -> float:
    """Unsigned shoelace area of a 2-D polygon ``xy`` (k, 2), m²."""
    return abs(signed_area(xy))


def area_3d(v: np.ndarray) -> float:
    """Area (m²) of a planar polygon ``v`` (k, 3) in space: half the norm of Σ vᵢ × vᵢ₊₁."""
    v = np.asarray(v, dtype=np.float64).reshape(-1, 3)
    return float(np.linalg.norm(np.cross(v, np.roll(v, -1, axis=0)).sum(axis=0)) / 2)


def newell_normal(v: np.ndarray) -> np.ndarray:
    """(3,) float64 unit normal of a polygon ``v`` (k, 3) by Newell's method (counter-
    clockwise vertices give the normal they are seen around); zero when degenerate."""
    v = np.asarray(v, dtype=np.float64).reshape(-1, 3)
    w = np.roll(v, -1, axis=0)
    n = np.array([
        np.sum((v[:, 1] - w[:, 1]) * (v[:, 2] + w[:, 2])),
        np.sum((v[:, 2] - w[:, 2]) * (v[:, 0] + w[:, 0])),
        np.sum((v[:, 0] - w[:, 0]) * (v[:, 1] + w[:, 1])),
    ])
    norm = np.linalg.norm(n)
    return n / norm if norm > 0 else n


def triangulate_polygon(vertices: np.ndarray, face: Sequence[int]) -> list[tuple[int, int, int]]:
    """Triangles (vertex index triples, as in ``face``) of the planar polygon ``face`` of
    ``vertices`` (n, 3): ear clipping in the plane's dominant projection, keeping the face's
    orientation; a fan over what is left when no ear is found (degenerate faces)."""
    idx = list(face)
    if len(idx) == 3:
        return [tuple(idx)]
    v = vertices[idx]
    w = np.roll(v, -1, axis=0)
    n = np.cross(v, w).sum(axis=0)
    # project to the plane's dominant axes
    drop = int(np.argmax(np.abs(n)))
    keep = [a for a in range(3) if a != drop]
    p = v[:, keep]
    sign = 1.0 if n[drop] >= 0 else -1.0
    rem = list(range(len(idx)))
    out = []
    guard = 0
    while len(rem) > 3 and guard < 10000:
        guard += 1
        m = len(rem)
        for j in range(m):
            a, b, c = rem[(j - 1) % m], rem[j], rem[(j + 1) % m]
            cross = (p[b, 0] - p[a, 0]) * (p[c, 1] - p[a, 1]) - (p[b, 1] - p[a, 1]) * (p[c, 0] - p[a, 0])
            if cross * sign <= 1e-15:
                continue
            inside = False
            for o in rem:
                if o in (a, b, c):
                    continue
                if _in_triangle(p[o], p[a], p[b], p[c], sign):
                    inside = True
                    break
            if not inside:
                out.append((idx[a], idx[b], idx[c]))
                rem.pop(j)
                break
        else:  # degenerate: fall back to a fan
            break
    for j in range(1, len(rem) - 1):
        out.append((idx[rem[0]], idx[rem[j]], idx[rem[j + 1]]))
    return out


def _in_triangle(q, a, b, c, sign) -> bool:
    def s(p1, p2, p3):
        return ((p2[0] - p1[0]) * (p3[1] - p1[1]) - (p2[1] - p1[1]) * (p3[0] - p1[0])) * sign

    return s(a, b, q) >= 0 and s(b, c, q) >= 0 and s(c, a, q) >= 0


def triangulate_faces(vertices: np.ndarray, faces: Sequence[Sequence[int]]) -> np.ndarray:
    """(m, 3) int64 triangles of every face of a polyhedron (:func:`triangulate_polygon`)."""
    tris = []
    for f in faces:
        tris.extend(triangulate_polygon(vertices, f))
    return np.asarray(tris, dtype=np.int64).reshape(-1, 3)


def polyhedron_volume(vertices: np.ndarray, faces: Sequence[Sequence[int]]) -> float:
    """Enclosed volume in m³ (divergence theorem; faces must be closed and outward)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    fan = [(f[0], f[j], f[j + 1]) for f in faces for j in range(1, len(f) - 1)]  # one triangle a row
    if not fan:
        return 0.0
    a, b, c = (vertices[list(col)] for col in zip(*fan))
    return abs(float(np.einsum("ij,ij->", a, np.cross(b, c)))) / 6.0


def prism_footprint(vertices: np.ndarray, faces: Sequence[Sequence[int]]) -> Optional[np.ndarray]:
    """(k, 2) float64 counter-clockwise footprint of a vertical prism, else None.

    A prism has one horizontal bottom face, one horizontal top face with as many vertices,
    and vertical sides (the bottom face's outline, seen from above, is returned).
    """
    normals = [newell_normal(vertices[list(f)]) for f in faces]
    bottoms = [i for i, n in enumerate(normals) if n[2] < -0.999]
    tops = [i for i, n in enumerate(normals) if n[2] > 0.999]
    if len(bottoms) != 1 or len(tops) != 1:
        return None
    for i, n in enumerate(normals):
        if i not in (bottoms[0], tops[0]) and abs(n[2]) > 1e-6:
            return None
    b = vertices[list(faces[bottoms[0]])][::-1, :2]
    t = vertices[list(faces[tops[0]])][:, :2]
    if len(b) != len(t):
        return None
    return b


def plan_area_perimeter(vertices: np.ndarray, faces: Sequence[Sequence[int]]) -> tuple[float, float]:
    """Area (m²) and perimeter (m) of the horizontal projection (the plan outline).

    A prism's footprint directly; any other solid (a room made of several parts, a sloped
    ceiling) through the union of its projected triangles. 0, 0 for an empty one.
    """
    fp = prism_footprint(vertices, faces)
    if fp is not None:
        poly = Polygon(fp)
    else:
        tris = [Polygon(vertices[i, :2]) for i in triangulate_faces(vertices, faces)]
        poly = unary_union([p for p in tris if p.area > 0])
    if poly.is_empty:
        return 0.0, 0.0
    return float(poly.area), float(poly.length)


def polygon_parts(geom) -> list:
    """The non-empty shapely Polygons of a geometry (a Polygon, a MultiPolygon or a
    collection, nested collections flattened; lines and points left out)."""
    if geom is None or geom.is_empty:
        return []
    if isinstance(geom, Polygon):
        return [geom]
    return [p for part in getattr(geom, "geoms", ()) for p in polygon_parts(part)]
