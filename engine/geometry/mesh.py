"""Triangle meshes: outward winding of a closed surface whose triangles disagree."""
from __future__ import annotations

import numpy as np

__all__ = ["orient_outward", "inside"]

_TILTS = np.array([[0.0123, 0.0311, 0.0], [-0.0271, 0.0057, 0.0191], [0.0049, -0.0223, -0.0283]])
"""Small tilts of the test rays off the face normal, so that a ray from one axis-aligned face
does not run along another face or through a triangulation's diagonal."""


_CHUNK = 64
"""Rays tested at once (memory: chunk × triangles × a few (3,) float64 arrays)."""


def _crossings(o: np.ndarray, d: np.ndarray, a: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """(r,) int — how many of the triangles (corners ``a``, edges ``e1``, ``e2``: (m, 3)) each
    ray ``o + t d``, t > 0 (``o``, ``d``: (r, 3)), crosses (Möller–Trumbore, r × m at once)."""
    p = np.cross(d[:, None, :], e2[None, :, :])
    det = np.einsum("mj,rmj->rm", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o[:, None, :] - a[None, :, :]
    u = np.einsum("rmj,rmj->rm", s, p) * inv
    q = np.cross(s, e1[None, :, :])
    v = np.einsum("rmj,rj->rm", q, d) * inv
    t = np.einsum("mj,rmj->rm", e2, q) * inv
    return np.count_nonzero(ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9), axis=1)


def _patches(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge-connected patches of the (welded) triangles ``t`` and, per triangle, whether to flip
    it so that each patch is wound one way: two triangles sharing an edge (met by exactly
    those two) agree when they run along it in opposite directions. Returns (label, flip)."""
    m = len(t)
    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    owner = np.tile(np.arange(m), 3)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    order = np.lexsort((hi, lo))
    lo, hi, owner, fwd = lo[order], hi[order], owner[order], (a < b)[order]
    same = (lo[1:] == lo[:-1]) & (hi[1:] == hi[:-1])
    counts = np.diff(np.flatnonzero(np.r_[True, ~same, True]))
    pair_start = np.flatnonzero(np.r_[True, ~same])[counts == 2]
    nbrs: list[list[tuple[int, bool]]] = [[] for _ in range(m)]
    for i in pair_start:
        k1, k2 = int(owner[i]), int(owner[i + 1])
        if k1 != k2:
            agree = bool(fwd[i] != fwd[i + 1])
            nbrs[k1].append((k2, agree))
            nbrs[k2].append((k1, agree))
    label = np.full(m, -1, dtype=np.int64)
    flip = np.zeros(m, dtype=bool)
    for seed in range(m):
        if label[seed] >= 0:
            continue
        label[seed] = seed
        stack = [seed]
        while stack:
            k = stack.pop()
            for j, agree in nbrs[k]:
                if label[j] < 0:
                    label[j] = seed
                    flip[j] = flip[k] if agree else not flip[k]
                    stack.append(j)
    return label, flip


def orient_outward(v: np.ndarray, tri: np.ndarray, *, eps: float = 1e-4, probes: int = 5) -> np.ndarray:
    """(m, 3) int triangles of a closed surface, each wound so that its normal points outwards.

    IFC tessellations may wind some faces of a solid the other way (faceted breps with
    reversed face bounds, mirroring placements). The triangles are first made to agree across
    the edges they share (each edge-connected patch wound one way); then, per patch, rays
    leave the centroids of its ``probes`` largest triangles (``eps`` metres off the surface)
    along their normals, tilted a little: an odd number of crossings with the surface means
    the normal points inside, and the majority of those votes turns the patch over. A surface
    that already agrees everywhere costs one signed volume. O(m log m) + O(patches · m).
    """
    v = np.asarray(v, dtype=np.float64)
    tri = np.asarray(tri, dtype=np.int64).copy()
    if len(tri) < 4:
        return tri
    _, weld = np.unique(np.round(v / 1e-6).astype(np.int64), axis=0, return_inverse=True)
    label, flip = _patches(weld.reshape(-1)[tri])
    tri[flip] = tri[flip][:, ::-1]
    a, b, c = v[tri[:, 0]], v[tri[:, 1]], v[tri[:, 2]]
    e1, e2 = b - a, c - a
    n = np.cross(e1, e2)
    area2 = np.linalg.norm(n, axis=1)
    patches = np.unique(label)
    if len(patches) == 1 and _closed(weld.reshape(-1)[tri]):
        vol = np.einsum("ij,ij->", a - v.mean(axis=0), n)
        return tri if vol >= 0 else tri[:, ::-1].copy()
    cen = (a + b + c) / 3.0
    for p in patches:
        members = np.flatnonzero(label == p)
        if not np.any(area2[members] > 1e-15):
            continue
        pick = members[np.argsort(-area2[members])[:probes]]
        pick = pick[area2[pick] > 1e-15]
        nn = n[pick] / area2[pick, None]
        votes, total = 0, 0
        for tilt in _TILTS:
            d = nn + tilt
            d /= np.linalg.norm(d, axis=1)[:, None]
            votes += int((_crossings(cen[pick] + eps * nn, d, a, e1, e2) % 2).sum())
            total += len(pick)
        if 2 * votes > total:
            tri[members] = tri[members][:, ::-1]
    return tri


def _closed(t: np.ndarray) -> bool:
    """Every edge of the (welded) triangles met exactly once each way."""
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    e = e[e[:, 0] != e[:, 1]]
    fwd = np.unique(e, axis=0)
    return len(fwd) == len(e) and np.array_equal(fwd, np.unique(e[:, ::-1], axis=0))


def inside(v: np.ndarray, tri: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n,) bool — which (n, 3) points lie inside the closed surface (ray parity, majority of
    three tilted rays; winding does not matter). O(n · m)."""
    v = np.asarray(v, dtype=np.float64)
    tri = np.asarray(tri, dtype=np.int64)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    a = v[tri[:, 0]]
    e1, e2 = v[tri[:, 1]] - a, v[tri[:, 2]] - a
    votes = np.zeros(len(pts), dtype=np.int64)
    for tilt in _TILTS:
        d = np.array([0.0, 0.0, 1.0]) + tilt
        d = np.broadcast_to(d / np.linalg.norm(d), (min(len(pts), _CHUNK), 3))
        for k in range(0, len(pts), _CHUNK):
            o = pts[k:k + _CHUNK]
            votes[k:k + len(o)] += _crossings(o, d[:len(o)], a, e1, e2) % 2
    return votes >= 2
