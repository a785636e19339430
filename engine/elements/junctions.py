"""Where another wall stands against a wall's face (docs/method.md §7.3).

At a T-junction or a crossing the abutting wall covers the face over its own thickness: the
face has no points there, and not because it is open. A hole through a wall cannot open
into the body of a wall standing against it, so such columns take part in no gap (the
Duplex's 0.6–0.7 m walls abutting its party wall on both sides left a door-sized strip
without face points on either face).

Cost: the walls' boxes are compared in one array pass; only pairs whose boxes overlap are
looked at (a few per wall).
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

__all__ = ["clear_of", "hidden_columns"]


def _corners(w, extend: float) -> np.ndarray:
    """(4, 2) corners of a wall frame's footprint, lengthened by ``extend`` at both ends."""
    a = w.p0 - w.d * extend
    b = w.p0 + w.d * (w.length + extend)
    h = w.n * (w.thickness / 2.0)
    return np.array([a + h, b + h, b - h, a - h])


def _span_at(uv: np.ndarray, v: float) -> tuple[float, float]:
    """The u interval where the convex polygon ``uv`` (k, 2) crosses the line at ``v``
    (empty: lo > hi)."""
    us = []
    for i in range(len(uv)):
        (u0, v0), (u1, v1) = uv[i], uv[(i + 1) % len(uv)]
        if (v0 - v) * (v1 - v) <= 0 and v0 != v1:
            us.append(u0 + (v - v0) * (u1 - u0) / (v1 - v0))
    return (min(us), max(us)) if us else (math.inf, -math.inf)


def hidden_columns(walls: Sequence, cell: float, depth: float, extend: float = 0.1,
                   max_cos: float = 0.5) -> list[np.ndarray]:
    """Per wall frame (``engine.elements.openings._Wall``: ``p0``, ``d``, ``n``, ``length``,
    ``thickness``, ``faces``, ``floor_z``, ``ceiling_z``), a ``(2, nu)`` bool array: the
    columns (``cell`` metres) of each face (0 left, 1 right) that another wall, at more than
    ``acos(max_cos)`` to it and overlapping its heights, covers from the face out to
    ``depth`` metres in front of it. The other wall's run is lengthened by ``extend`` at
    its ends (a model's wall may stop short of the face it abuts)."""
    nus = [max(1, int(math.ceil(w.length / cell))) for w in walls]
    out = [np.zeros((2, nu), bool) for nu in nus]
    if len(walls) < 2:
        return out
    corners = [_corners(w, extend) for w in walls]
    lo = np.array([c.min(axis=0) for c in corners])
    hi = np.array([c.max(axis=0) for c in corners])
    reach = np.array([depth + w.thickness for w in walls])  # a face's strip lies within this of the axis box
    r = reach[:, None]
    near = ((lo[:, None, 0] - r <= hi[None, :, 0]) & (hi[:, None, 0] + r >= lo[None, :, 0])
            & (lo[:, None, 1] - r <= hi[None, :, 1]) & (hi[:, None, 1] + r >= lo[None, :, 1]))
    np.fill_diagonal(near, False)
    for i, j in zip(*np.nonzero(near)):
        w, x = walls[i], walls[j]
        if abs(float(w.d @ x.d)) > max_cos or x.floor_z >= w.ceiling_z or x.ceiling_z <= w.floor_z:
            continue
        rel = corners[j] - w.p0
        uv = np.column_stack([rel @ w.d, rel @ w.n])
        for s, sg in ((0, 1.0), (1, -1.0)):
            vf = float(w.faces[s])
            a0, a1 = _span_at(uv, vf + sg * min(0.01, depth))
            b0, b1 = _span_at(uv, vf + sg * depth)
            u0, u1 = max(a0, b0, 0.0), min(a1, b1, w.length)
            if u1 > u0:
                out[i][s, int(u0 // cell):min(nus[i], int(math.ceil(u1 / cell)))] = True
    return out


def clear_of(hidden: np.ndarray, u0: float, u1: float, c0: int, c1: int, cell: float) -> tuple[float, float]:
    """A hole over columns ``c0:c1`` measured from ``u0`` to ``u1`` (metres), its edges moved
    back to the face of a wall standing against the face (``hidden``, (nu,) bool columns)
    that they reach into beside the hole: a hole cannot open into that wall's body. Where the
    face's points end at the abutting wall's far face, the hole's jamb may stand a few
    centimetres on (the Duplex's front door 3.5 cm beside a partition: measured from the
    partition's far face, 0.97 m for 0.81)."""
    left, right = _nearest_ends(hidden, int(math.floor(u0 / cell + 1e-9)), c0, c1,
                                int(math.ceil(u1 / cell - 1e-9)), cell)
    return (u0 if left is None else max(u0, left)), (u1 if right is None else min(u1, right))


def abutting(hidden: Optional[np.ndarray], c0: int, c1: int, cell: float, reach: float) -> tuple:
    """Where the nearest wall standing against the face (``hidden``, (nu,) bool columns)
    ends towards a hole over columns ``c0:c1``, within ``reach`` metres of it on either
    side: (left, right) in metres along the wall, None where there is none."""
    if hidden is None:
        return None, None
    n = int(math.ceil(reach / cell))
    return _nearest_ends(hidden, c0 - n, c0, c1, c1 + n, cell)


def _nearest_ends(hidden: np.ndarray, a: int, c0: int, c1: int, b: int, cell: float) -> tuple:
    """The hidden columns nearest a hole over ``c0:c1``, among ``a:c0`` and ``c1:b``: where
    they end towards the hole (metres), None where there are none."""
    a = max(0, a)
    left = np.flatnonzero(hidden[a:max(a, c0)])
    right = np.flatnonzero(hidden[c1:max(c1, b)])
    return ((a + int(left[-1]) + 1) * cell if len(left) else None,
            (c1 + int(right[0])) * cell if len(right) else None)
