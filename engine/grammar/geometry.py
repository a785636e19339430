"""Geometry shared by the rules: unions of boxes and shared faces between shapes.

* :func:`union_of_boxes` — the boundary {V, F} of a union of axis-aligned boxes (the
  merge rule's result); a vertical prism when the union is one, so that
  ``Polyhedron.footprint()`` works.
* :func:`shared_faces` — which faces of which shapes touch (coplanar, opposite normals,
  overlapping): the geometric test behind the adjacency rule, for any planar polyhedra.
"""
from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from ..model import Polyhedron

__all__ = ["union_of_boxes", "shared_faces", "SharedFace", "box_of"]

_EPS = 1e-6


def box_of(lo, hi) -> Polyhedron:
    """Axis-aligned box between corners ``lo`` and ``hi`` (metres); faces bottom, top,
    −y, +x, +y, −x (the order of :meth:`Polyhedron.prism`)."""
    return Polyhedron.box(tuple(float(v) for v in lo), tuple(float(v) for v in hi))


def _axis_uv(axis: int) -> tuple[int, int]:
    # (axis, u, v) cyclic, so that u × v = +axis
    return (axis + 1) % 3, (axis + 2) % 3


def union_of_boxes(boxes: np.ndarray, tol: float = 1e-6) -> Polyhedron:
    """Boundary of a union of axis-aligned boxes.

    Parameters
    ----------
    boxes : (m, 2, 3) float64
        ``boxes[i] = (lo, hi)`` corners, metres. Boxes are expected to meet face to face
        (a grid); overlaps are fine.

    Returns
    -------
    Polyhedron
        A prism (``Polyhedron.prism``) when the union is a vertical prism over a polygon
        without holes; otherwise one planar face per maximal boundary rectangle strip.
    """
    from shapely.geometry import box as sbox
    from shapely.ops import unary_union

    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    if len(b) == 0:
        raise ValueError("union of no boxes")
    zlo, zhi = b[:, 0, 2], b[:, 1, 2]
    if np.ptp(zlo) <= tol and np.ptp(zhi) <= tol:
        fp = unary_union([sbox(x0, y0, x1, y1) for (x0, y0, _), (x1, y1, _) in b]).simplify(tol)
        if fp.geom_type == "Polygon" and len(fp.interiors) == 0:
            xy = np.asarray(fp.exterior.coords)[:-1]
            return Polyhedron.prism(xy, float(zlo.min()), float(zhi.max()))
    # general case: occupancy on the grid of all box coordinates
    cuts = [np.unique(np.round(b[:, :, a].ravel() / tol) * tol) for a in range(3)]
    shape = tuple(len(c) - 1 for c in cuts)
    occ = np.zeros(shape, dtype=bool)
    for lo, hi in b:
        sl = tuple(slice(int(np.searchsorted(cuts[a], lo[a] - tol / 2)),
                         int(np.searchsorted(cuts[a], hi[a] - tol / 2))) for a in range(3))
        occ[sl] = True
    verts: dict = {}
    faces = []

    def vid(p):
        key = tuple(np.round(np.asarray(p) / tol).astype(np.int64))
        if key not in verts:
            verts[key] = (len(verts), np.asarray(p, dtype=np.float64))
        return verts[key][0]

    for a in range(3):
        u, v = _axis_uv(a)
        pad = np.pad(occ, [(1, 1) if k == a else (0, 0) for k in range(3)])
        diff = np.diff(pad.astype(np.int8), axis=a)  # (shape[a]+1, ...) along a
        for plane in range(diff.shape[a]):
            sl = np.take(diff, plane, axis=a)  # 2D over the two other axes, in axis order
            for sign in (-1, 1):
                # +1 step (empty→full) is a face with outward normal −a
                mask = sl == (1 if sign < 0 else -1)
                if not mask.any():
                    continue
                other = [k for k in range(3) if k != a]
                # mask axes are (other[0], other[1]); rows over u-axis for strip building
                m_uv = mask if other[0] == u else mask.T
                for iu in range(m_uv.shape[0]):
                    row = m_uv[iu]
                    jv = 0
                    while jv < len(row):
                        if not row[jv]:
                            jv += 1
                            continue
                        kv = jv
                        while kv < len(row) and row[kv]:
                            kv += 1
                        u0, u1 = cuts[u][iu], cuts[u][iu + 1]
                        v0, v1 = cuts[v][jv], cuts[v][kv]
                        w = cuts[a][plane]
                        corners = []
                        for uu, vv in ((u0, v0), (u1, v0), (u1, v1), (u0, v1)):
                            p = np.zeros(3)
                            p[a], p[u], p[v] = w, uu, vv
                            corners.append(vid(p))
                        faces.append(tuple(corners) if sign > 0 else tuple(corners[::-1]))
                        jv = kv
    vv = np.zeros((len(verts), 3))
    for i, p in verts.values():
        vv[i] = p
    return Polyhedron(vv, tuple(faces))


@dataclass(frozen=True)
class SharedFace:
    """Face ``fa`` of shape ``a`` touches face ``fb`` of shape ``b`` over ``area`` m²."""

    a: str
    fa: int
    b: str
    fb: int
    area: float


def _plane_key(n, off, angle_q=1e-3, off_q=1e-3):
    return (tuple(np.round(n / angle_q).astype(np.int64)), int(np.round(off / off_q)))


def shared_faces(shapes, tol: float = 1e-3, min_area: float = 1e-4) -> list[SharedFace]:
    """Pairs of faces of different shapes that lie in one plane, face each other and
    overlap.

    Parameters
    ----------
    shapes : iterable of Shape (their ``geometry``).
    tol : plane offset tolerance, metres.
    min_area : smallest overlap that counts, m².

    Faces are bucketed by plane, so the cost is about linear in the number of faces.
    Axis-aligned rectangles are compared by their bounds; other polygons with shapely.
    """
    from shapely.geometry import Polygon

    buckets = defaultdict(list)
    for s in shapes:
        g = s.geometry
        for i in range(len(g.faces)):
            n = g.face_normal(i)
            if not np.any(n):
                continue
            pv = g.face_vertices(i)
            off = float(n @ pv[0])
            # canonical direction: first non-zero component positive
            k = int(np.argmax(np.abs(n) > 1e-9))
            sgn = 1.0 if n[k] > 0 else -1.0
            buckets[_plane_key(sgn * n, sgn * off, off_q=tol)].append((s.id, i, sgn, pv, sgn * n))
    out = []
    for items in buckets.values():
        pos = [it for it in items if it[2] > 0]
        neg = [it for it in items if it[2] < 0]
        if not pos or not neg:
            continue
        n = pos[0][4]
        helper = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        u = np.cross(helper, n)
        u /= np.linalg.norm(u)
        v = np.cross(n, u)

        def proj(pv):
            return np.column_stack([pv @ u, pv @ v])

        P = [proj(it[3]) for it in pos]
        N = [proj(it[3]) for it in neg]
        plo = np.array([p.min(axis=0) for p in P])
        phi = np.array([p.max(axis=0) for p in P])
        nlo = np.array([p.min(axis=0) for p in N])
        nhi = np.array([p.max(axis=0) for p in N])
        ov = np.clip(np.minimum(phi[:, None, :], nhi[None, :, :]) - np.maximum(plo[:, None, :], nlo[None, :, :]),
                     0, None)
        cand = np.argwhere(ov[:, :, 0] * ov[:, :, 1] > min_area)
        for ip, jn in cand:
            a_it, b_it = pos[ip], neg[jn]
            if a_it[0] == b_it[0]:
                continue
            pa, pb = P[ip], N[jn]
            rect = len(pa) == 4 and len(pb) == 4 and _is_rect(pa) and _is_rect(pb)
            area = float(ov[ip, jn, 0] * ov[ip, jn, 1]) if rect else \
                Polygon(pa).buffer(0).intersection(Polygon(pb).buffer(0)).area
            if area > min_area:
                out.append(SharedFace(a_it[0], a_it[1], b_it[0], b_it[1], area))
    return out


def _is_rect(p: np.ndarray) -> bool:
    lo, hi = p.min(axis=0), p.max(axis=0)
    return bool(np.all((np.abs(p - lo) < _EPS) | (np.abs(p - hi) < _EPS)))
