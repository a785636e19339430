"""Closed doors whose leaf is flush with a wall's face (docs/method.md §7.3).

A closed leaf standing a few centimetres behind a face is a door-sized gap in the face with a
plane behind it (:mod:`.openings`, ``leaf_depth``). A leaf within the face tolerance of the
plaster leaves no gap: FZK-Haus's front door stands 1.2 cm behind the inner face, and a
terrestrial scan's face tolerance is 1.5 cm. What gives it away is a step. Over a rectangle
of a door's size reaching the floor, the face points stand a few millimetres deeper than the
face beside it and above it (the lintel), with sharp edges. The leaf sits in the wall's hole,
so the step is always a recess, never a bulge: furniture, casings and boards stand proud.

The face around it is the reference, not the wall's fitted plane, so a wall that leans or bows
a little does not read as a recess. A recess must be significant against the face's own
noise: its depth at least ``flush_depth`` and ``flush_t`` standard errors (8 by default;
mobile noise of 2 cm still shows a 1 cm recess over a door). Nothing else in a wall makes such a
rectangle: a step between two wall planes has no second edge, a niche to the ceiling no lintel.

Cost: per wall side, a sort of its face points and a few bin counts; linear in the points.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .gaps import mask_runs
from .params import OpeningParams

__all__ = ["flush_leaves"]

_BIN = 0.05  # metres: profile bins along the wall and up it
_SPAN = 2  # bins either side in the profile along the wall
_MED = 1.2533  # a median's standard error over a mean's (normal noise)


def _profile(x: np.ndarray, r: np.ndarray, lo: float, hi: float, span: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Median of ``r`` and point count per ``_BIN`` of ``x`` over [lo, hi) (NaN where empty),
    over the ``span`` bins either side too. Medians: the face's points are cut at the face
    tolerance, which pulls a mean of a recess's points towards the face (by a third on a
    mobile scan)."""
    n = max(1, int(math.ceil((hi - lo) / _BIN)))
    k = np.clip(((x - lo) / _BIN).astype(np.int64), 0, n - 1)
    if span:
        k = np.concatenate([k + j for j in range(-span, span + 1)])
        r = np.tile(r, 2 * span + 1)
        r, k = r[(k >= 0) & (k < n)], k[(k >= 0) & (k < n)]
    cnt = np.bincount(k, minlength=n)
    # one sort of bin + depth (the depths lie within ±0.5 m of the face): by bin, then depth
    key = np.sort(k + (np.clip(r, -0.499, 0.499) + 0.5))
    start = np.r_[0, np.cumsum(cnt)[:-1]]
    a = start + np.maximum(cnt - 1, 0) // 2
    b = start + cnt // 2
    med = np.full(n, np.nan)
    ok = cnt > 0
    med[ok] = 0.5 * (key[a[ok]] + key[np.minimum(b[ok], len(key) - 1)]) - np.flatnonzero(ok) - 0.5
    return med, cnt.astype(np.float64)


def _step(x: np.ndarray, r: np.ndarray, guess: float, reach: float, rising: bool) -> float:
    """Where along ``x`` near ``guess`` (within ``reach``) the mean of ``r`` steps, metres:
    the split with the least squared error of two constant pieces (``rising``: deeper after
    it); ``guess`` when too few points."""
    sel = np.abs(x - guess) <= reach
    if sel.sum() < 10:
        return guess
    o = np.argsort(x[sel])
    xs, rs = x[sel][o], r[sel][o]
    n = len(rs)
    c1, c2 = np.cumsum(rs), np.cumsum(rs * rs)
    k = np.arange(3, n - 2)  # at least three points on each side
    if not len(k):
        return guess
    left = c2[k - 1] - c1[k - 1] ** 2 / k
    right = (c2[-1] - c2[k - 1]) - (c1[-1] - c1[k - 1]) ** 2 / (n - k)
    jump = (c1[-1] - c1[k - 1]) / (n - k) - c1[k - 1] / k
    cost = np.where(jump > 0 if rising else jump < 0, left + right, np.inf)
    j = int(np.argmin(cost))
    if not np.isfinite(cost[j]):
        return guess
    return float(0.5 * (xs[k[j] - 1] + xs[k[j]]))


def _chunks_deep(x: np.ndarray, r: np.ndarray, lo: float, hi: float, depth: float) -> bool:
    """Whether each quarter of [lo, hi) along ``x`` holds points whose median ``r`` is at least
    ``depth``: the recess spans the rectangle, not part of it."""
    edges = np.linspace(lo, hi, 5)
    for a, b in zip(edges[:-1], edges[1:]):
        q = r[(x >= a) & (x < b)]
        if len(q) < 5 or float(np.median(q)) < depth:
            return False
    return True


def _side(u: np.ndarray, z: np.ndarray, r: np.ndarray, length: float, z0: float, z1: float,
          p: OpeningParams) -> list[dict]:
    """Flush leaves on one face: ``u``, ``z`` (metres) and depth ``r`` behind the face (metres,
    < 0 in front) of its points."""
    if len(r) < 100:
        return []
    sigma = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    if not sigma > 0:
        return []
    body = (z > z0 + p.flush_body[0]) & (z < z0 + p.flush_body[1])
    ub_, rb_ = u[body], r[body]
    m, cnt = _profile(ub_, rb_, 0.0, length, span=_SPAN)  # 25 cm windows: a mobile scan's noise
    # candidates only (the rectangle's tests below decide): half the depth, two standard errors
    deep = (cnt >= 5) & (m >= p.flush_depth / 2) & (m * np.sqrt(np.maximum(cnt, 1.0)) >= 2.0 * _MED * sigma)
    out = []
    for a, b in zip(*mask_runs(deep, bridge=1)):
        ua, ub = a * _BIN, b * _BIN
        if not p.min_door_width - 2 * _SPAN * _BIN <= ub - ua <= p.max_door_width + 2 * _SPAN * _BIN:
            continue
        ua = _step(ub_, rb_, ua, (_SPAN + 1) * _BIN, True)
        ub = _step(ub_, rb_, ub, (_SPAN + 1) * _BIN, False)
        if not p.min_door_width <= ub - ua <= p.max_door_width:
            continue
        o = _leaf(u, z, r, body, ua, ub, length, z0, z1, sigma, p)
        if o is not None:
            out.append(o)
    return out


def _leaf(u, z, r, body, ua: float, ub: float, length: float, z0: float, z1: float, sigma: float,
          p: OpeningParams) -> Optional[dict]:
    """The door of a recess between ``ua`` and ``ub`` along the face, or None: flat face
    beside it (the reference depth) and a lintel above, the recess from the floor to a door's
    height, deep and significant over all of it. ``body``: the points at ``flush_body``."""
    flanks = []
    for lo, hi in ((ua - p.flush_flank - _BIN, ua - _BIN), (ub + _BIN, ub + p.flush_flank + _BIN)):
        if lo < 0.0 or hi > length:
            continue  # the run's end (a corner): no face there to compare with
        f = body & (u >= lo) & (u < hi)
        if f.sum() < 10:
            return None  # a face not seen beside it: nothing to measure the recess against
        flanks.append(float(np.median(r[f])))
    if not flanks:
        return None
    ref = float(np.mean(flanks))
    zlo = z0 + p.flush_body[0]
    mid = (u > ua + _BIN) & (u < ub - _BIN) & (z > zlo)
    zm, rm = z[mid], r[mid] - ref
    if len(rm) < 30:
        return None
    zt = _step(zm, rm, 0.5 * (zlo + z1), z1 - zlo, False)  # the head: deep under it, the face above
    height = zt - z0
    if height < p.min_door_height or z1 - zt <= p.ceiling_tolerance:
        return None
    lintel = rm[(zm > zt + _BIN) & (zm < zt + 0.35)]
    if len(lintel) < 10:
        return None  # no face above it: a recess up to the ceiling is no door
    core = (zm < zt - _BIN)
    n = int(core.sum())
    if n < 30:
        return None
    # deeper than the face on either side and above (a step between two planes of a wall is
    # deeper than one side only), by flush_depth and flush_t standard errors
    depth = float(np.median(rm[core])) - max(float(np.median(lintel)), *(f - ref for f in flanks))
    if depth < p.flush_depth or depth * math.sqrt(n) < p.flush_t * _MED * sigma:
        return None
    uc = u[mid][core]
    if not (_chunks_deep(zm[core], rm[core], zlo, zt - _BIN, p.flush_depth / 2)
            and _chunks_deep(uc, rm[core], ua + _BIN, ub - _BIN, p.flush_depth / 2)):
        return None
    t = depth * math.sqrt(n) / (_MED * sigma)
    return {"u0": ua, "u1": ub, "width": ub - ua, "height": height, "sill": 0.0, "kind": "door",
            "open": False, "confidence": float(min(1.0, 0.45 + 0.05 * t / p.flush_t)),
            "support": {"seen_through": 0.0, "occluded": 0.0, "points_beyond": 0, "floor_points": 0.0,
                        "threshold_share": 0.0, "reveal_share": 0.0, "both_faces": 0.0, "leaf_share": 1.0,
                        "flush_depth": depth}}


def flush_leaves(fu: np.ndarray, fz: np.ndarray, fcls: np.ndarray, fdev: np.ndarray, sides: tuple,
                 length: float, floor_z: float, ceiling_z: float, tol: float,
                 p: OpeningParams = OpeningParams()) -> list[dict]:
    """Closed doors flush with a face of one wall run (module doc).

    Parameters
    ----------
    fu, fz : (m,) float — position along the run and height of its face points, metres.
    fcls : (m,) int — 0 / 1: on the left / right face (2: inside the thickness, ignored).
    fdev : (m,) float — depth behind the face, metres (< 0 in front).
    sides : the run's two sides' spaces (None: exterior); only a side with a room is looked at.
    length, floor_z, ceiling_z : the run's length and its storey's floor and ceiling, metres.
    tol : the face tolerance, metres: points deeper than it are not the face.

    Returns
    -------
    list of dict — measured doors as :func:`engine.elements.openings.detect_openings` keeps
    them (``u0``, ``u1``, ``width``, ``height``, ``sill`` 0, kind "door", ``open`` False,
    ``confidence``, ``support``).
    """
    out = []
    for s in (0, 1):
        if sides[s] is None:
            continue
        on = (fcls == s) & (np.abs(fdev) < tol)
        out += _side(fu[on], fz[on], fdev[on], length, floor_z, ceiling_z, p)
    return out
