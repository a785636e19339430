"""Geometry of the IFC writer: cleaned rings, door sizes, wall axes, door openings and the
common faces that become space boundaries (metres, the model's frame)."""
from __future__ import annotations

from typing import Optional

import numpy as np
from shapely.geometry import Polygon

from ..geometry.planes import plane_frame
from ..model import BuildingModel, Polyhedron, Shape, ShapeType, Storey

__all__ = ["default_storeys", "clean_ring", "door_size", "wall_axis", "opening_geometry", "face_table",
           "common_face"]

_SAME_POINT = 1e-9
"""Distance (m) under which two consecutive ring vertices are one."""


def default_storeys(model: BuildingModel) -> list:
    """One storey spanning every shape, for a model without storeys."""
    shapes = [s for s in model.shapes if s.type != ShapeType.NONE and len(s.geometry.vertices)]
    if not shapes:
        return [Storey(0, 0.0, 0.0, "Storey 0")]
    b = np.array([s.bounds for s in shapes])
    return [Storey(0, float(b[:, 0, 2].min()), float(b[:, 1, 2].max()), "Storey 0")]


def clean_ring(ring: np.ndarray, tol: float = _SAME_POINT) -> Optional[np.ndarray]:
    """Drop repeated consecutive vertices of a closed ring; None when fewer than 3 remain."""
    r = np.asarray(ring, dtype=np.float64)
    keep = np.linalg.norm(r - np.roll(r, 1, axis=0), axis=1) > tol
    r = r[keep]
    return r if len(r) >= 3 else None


def door_size(d: Shape) -> tuple[float, float]:
    """Width and height of a door, metres (its attributes, else its scope and bounds)."""
    b = d.geometry.bounds
    w = float(d.attributes.get("width", np.sort(d.scope.size[:2])[1]))
    h = float(d.attributes.get("height", b[1, 2] - b[0, 2]))
    return w, h


def wall_axis(s: Shape, g: Polyhedron) -> Optional[np.ndarray]:
    """(2, 2) float64 — the wall's centre line (metres) along its longer horizontal side."""
    sc = s.scope
    if sc.size[0] <= 0:
        return None
    x, y = sc.axes[0, :2], sc.axes[1, :2]
    o = sc.origin[:2] + y * sc.size[1] / 2
    return np.array([o, o + x * sc.size[0]])


def opening_geometry(door: Shape, g: Polyhedron, wall_g: Polyhedron, margin: float) -> Polyhedron:
    """The door's box enlarged by ``margin`` beyond each side of the wall (metres)."""
    sc = door.scope
    ax = sc.axes
    # the horizontal scope axis closest to the wall's thin direction
    wsc = Shape("_w", ShapeType.WALL, wall_g).scope
    thin = wsc.axes[int(np.argmin(wsc.size[:2]))]
    k = int(np.argmax([abs(ax[0] @ thin), abs(ax[1] @ thin)]))
    lo = np.zeros(3)
    size = np.array(sc.size, dtype=np.float64)
    # reach through the whole wall thickness plus the margin
    wall_thick = float(np.min(wsc.size[:2]))
    centre_k = (sc.center - wsc.center) @ ax[k]
    half = max(size[k] / 2, wall_thick / 2 + abs(centre_k)) + margin
    lo[k] = size[k] / 2 - half
    size[k] = 2 * half
    corners2 = []
    base = sc.origin + ax.T @ lo
    for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
        corners2.append(base[:2] + ax[0, :2] * size[0] * a + ax[1, :2] * size[1] * b)
    zmin, zmax = g.bounds[:, 2]
    return Polyhedron.prism(np.array(corners2), zmin, zmax)


def face_table(g: Polyhedron) -> list:
    """[(unit outward normal (3,), vertices (k, 3))] of every face of ``g``."""
    return [(g.face_normal(i), g.face_vertices(i)) for i in range(len(g.faces))]


def common_face(space_g: Polyhedron, elem_g: Polyhedron, gap: float, min_cos: float, min_area: float,
                tables: Optional[dict] = None):
    """The largest common region of an outward space face and an anti-parallel element face.

    Faces bound each other when ``-n_space · n_element >= min_cos`` and their planes are at
    most ``gap`` apart (metres); regions smaller than ``min_area`` (m²) are ignored.
    ``tables`` caches :func:`face_table` by ``id`` of the polyhedron.

    Returns ``(polygon (k, 2) float64 in the plane frame, origin (3,), normal (3,), u (3,))``
    — the normal is the space face's outward normal — or None when the shapes do not touch.
    """
    sb, eb = space_g.bounds, elem_g.bounds
    if np.any(sb[0] > eb[1] + gap) or np.any(eb[0] > sb[1] + gap):
        return None
    best = None
    tables = {} if tables is None else tables
    for g in (space_g, elem_g):
        if id(g) not in tables:
            tables[id(g)] = face_table(g)
    for n, vs in tables[id(space_g)]:
        if not np.any(n):
            continue
        d = float(n @ vs[0])
        u, w = plane_frame(n, flat_cos=1.0)  # u horizontal on every wall and sloped face
        w = w / np.linalg.norm(w)  # unit to the last digit: the boundary polygons are written as they are
        ps = None
        for m, ve in tables[id(elem_g)]:
            if -(n @ m) < min_cos:
                continue
            if abs(float(n @ ve[0]) - d) > gap:
                continue
            if ps is None:
                ps = Polygon(np.column_stack([(vs - vs[0]) @ u, (vs - vs[0]) @ w])).buffer(0)
            pe = Polygon(np.column_stack([(ve - vs[0]) @ u, (ve - vs[0]) @ w])).buffer(0)
            inter = ps.intersection(pe)
            if inter.is_empty:
                continue
            parts = getattr(inter, "geoms", [inter])
            for part in parts:
                if part.geom_type != "Polygon" or part.area < min_area:
                    continue
                if best is None or part.area > best[0]:
                    ring = np.asarray(part.exterior.coords)[:-1]
                    best = (part.area, ring, vs[0].copy(), n, u)
    if best is None:
        return None
    return best[1], best[2], best[3], best[4]
