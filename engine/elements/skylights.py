"""Roof windows (skylights): holes in a roof slab, seen from the rooms under it.

From below, a skylight is a hole in the ceiling: the ceiling's plane has no points over it,
while points stand above that plane inside it — the reveals through the roof's thickness, and
the glazing or the sky's frame at its top when the glass returns anything (a recess). A
ceiling's hole with nothing at all seen above it is left alone: from the scan it cannot be told
from ceiling nobody saw. Per roof slab, on a raster of its plan:

1. cells with points above the ceiling (``min_depth`` to ``max_depth`` over it) and none on it;
2. each connected group of them (8-neighbours) of a skylight's size, compact (its share of its
   bounding rectangle) and ringed by ceiling: on three of its four sides at least, most cells
   of a ring ``ring`` wide, past the cells next to it, hold ceiling points (a hole, not the
   edge of the ceiling seen nor ceiling nobody saw; the fourth side may be a wall it stands
   against), and few cells past that ring points above the ceiling (a shaft's walls hide what
   is beyond them; a higher ceiling beyond a room's edge, or the plenum over a missing
   ceiling tile, is seen there);
3. the window is the group's rectangle in the model's frame (its axes: the room's), its top at
   the recess's top (a high quantile of the points above), ``frame`` deep.

Each is a WINDOW shape whose parent is the roof slab over it, ``kind`` "window", ``skylight``
true, width (the longer side) and height (the shorter one) of the hole, the room and the
exterior as its spaces, and a confidence from how fully the ring is seen.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np
import shapely
from scipy import ndimage
from shapely.geometry import Point, Polygon

from ..model import Polyhedron, Shape, ShapeType
from .params import SkylightParams

__all__ = ["roof_windows"]


def _groups(above: np.ndarray, ceiling: np.ndarray, inside: np.ndarray, p: SkylightParams, cell: float):
    """(slices, mask, ring share) of each group of hole cells that qualifies (steps 1-2)."""
    # a clear glass returns nothing: only the reveals stand above, round the hole (their
    # cells share points with the ceiling at its edge)
    hole = ndimage.binary_fill_holes(ndimage.binary_closing(above & inside, np.ones((3, 3))))
    lab, _ = ndimage.label(hole & ~ceiling & inside, structure=np.ones((3, 3)))
    out = []
    k = max(1, int(round(p.ring / cell)))
    for i, sl in enumerate(ndimage.find_objects(lab), start=1):
        m = lab[sl] == i
        h, w = m.shape
        area = m.sum() * cell * cell
        if not (p.min_area <= area <= p.max_area) or min(h, w) * cell < p.min_side:
            continue
        if m.mean() < p.min_fill:
            continue
        a0, b0 = max(0, sl[0].start - k - 2), max(0, sl[1].start - k - 2)
        a1, b1 = min(lab.shape[0], sl[0].stop + k + 2), min(lab.shape[1], sl[1].stop + k + 2)
        grown = np.zeros((a1 - a0, b1 - b0), bool)
        grown[sl[0].start - a0:sl[0].stop - a0, sl[1].start - b0:sl[1].stop - b0] = m
        # the ring past the cells next to the hole (they hold its reveals' bottoms, inside the
        # ceiling's band, and the ceiling's edge); its cells outside the slab have no ceiling
        next_to = ndimage.binary_dilation(grown, np.ones((3, 3)))
        ring = ndimage.binary_dilation(grown, np.ones((2 * k + 3, 2 * k + 3))) & ~next_to
        ceil = ceiling[a0:a1, b0:b1] & inside[a0:a1, b0:b1]
        # per side (a skylight may stand against a wall: three sides of ceiling suffice)
        r, c = np.indices(ring.shape)
        r0, r1, c0, c1 = sl[0].start - a0, sl[0].stop - a0, sl[1].start - b0, sl[1].stop - b0
        sides = [ring & (r < r0), ring & (r >= r1), ring & (c < c0), ring & (c >= c1)]
        shares = sorted(float(ceil[sd].mean()) if sd.any() else 0.0 for sd in sides)
        share = shares[1]  # the worst side but one
        # a shaft's walls bound what is seen above: nothing over the ceiling past the cells of
        # its reveals, the two next to the hole (over a missing ceiling tile the plenum is seen
        # far past it)
        beyond = ndimage.binary_dilation(grown, np.ones((2 * k + 5, 2 * k + 5)))
        beyond &= ~ndimage.binary_dilation(grown, np.ones((5, 5)))
        if beyond.any() and float(above[a0:a1, b0:b1][beyond].mean()) > p.max_beyond:
            continue
        if share >= p.min_ring:
            out.append((sl, m, float(ceil[ring].mean())))
    return out


def _edges(a, b, up, a0: float, a1: float, b0: float, b1: float, cell: float) -> tuple[float, float]:
    """The hole's two edges along ``a`` (raster edges ``a0``, ``a1``): the points above the
    ceiling within two cells of it (the group may stop short of a reveal over a wall's top),
    in the middle three fifths of its other side (``b0``..``b1``), reach the reveals and no
    further (the glazing or the kerb spans the hole) — their 2 % and 98 % quantiles; the
    raster's edges with fewer than ten."""
    mid, half = (b0 + b1) / 2, 0.3 * (b1 - b0)
    m = up & (a >= a0 - 2 * cell) & (a <= a1 + 2 * cell) & (np.abs(b - mid) <= half)
    if m.sum() < 10:
        return a0, a1
    q0, q1 = np.quantile(a[m], [0.02, 0.98])
    return float(q0), float(q1)


def roof_windows(roofs: Sequence[Shape], rooms: Sequence[tuple], xyz: np.ndarray,
                 exterior_ids: dict, p: SkylightParams = SkylightParams()) -> list[Shape]:
    """Skylights in ``roofs`` (roof SLAB shapes, their bottom the ceiling of the rooms under
    them) from the model-frame points ``xyz`` (n, 3); ``rooms``: (room id, storey, footprint
    polygon) each, the window's room the one holding its centre; ``exterior_ids``: storey →
    its exterior's id. The slab's plan is searched, not each room's: a room's edge the model
    misplaces under a hole would cut it."""
    out = []
    if not len(roofs) or xyz is None or not len(xyz):
        return out
    near = xyz[xyz[:, 2] >= min(float(s.bounds[0, 2]) for s in roofs) - p.band]
    cell = p.cell
    for slab in roofs:
        k, ceil, fp = slab.storey, float(slab.bounds[0, 2]), Polygon(slab.footprint()).buffer(0)
        if fp.is_empty:
            continue
        x0, y0, x1, y1 = fp.bounds
        pad = p.ring + 3 * cell  # the rings round a hole by the walls stay on the raster
        x0, y0, x1, y1 = x0 - pad, y0 - pad, x1 + pad, y1 + pad
        sel = near[(near[:, 0] >= x0) & (near[:, 0] <= x1) & (near[:, 1] >= y0) & (near[:, 1] <= y1)
                   & (near[:, 2] >= ceil - p.band) & (near[:, 2] <= ceil + p.max_depth)]
        nx, ny = max(1, int(math.ceil((x1 - x0) / cell))), max(1, int(math.ceil((y1 - y0) / cell)))
        ix = np.clip(((sel[:, 0] - x0) / cell).astype(np.int64), 0, nx - 1)
        iy = np.clip(((sel[:, 1] - y0) / cell).astype(np.int64), 0, ny - 1)
        dz = sel[:, 2] - ceil
        on, up = np.abs(dz) <= p.band, dz >= p.min_depth
        ceiling = np.zeros((nx, ny), bool)
        above = np.zeros((nx, ny), bool)
        ceiling[ix[on], iy[on]] = True
        above[ix[up], iy[up]] = True
        # cells whose centre lies under the slab, a margin inside its outer edge
        cx, cy = np.meshgrid(x0 + (np.arange(nx) + 0.5) * cell, y0 + (np.arange(ny) + 0.5) * cell,
                             indexing="ij")
        inside = shapely.contains_xy(fp.buffer(-p.wall_margin), cx, cy)
        for sl, m, share in _groups(above, ceiling, inside, p, cell):
            u0, u1 = x0 + sl[0].start * cell, x0 + sl[0].stop * cell
            v0, v1 = y0 + sl[1].start * cell, y0 + sl[1].stop * cell
            pts = (ix >= sl[0].start) & (ix < sl[0].stop) & (iy >= sl[1].start) & (iy < sl[1].stop) & up
            u0, u1 = _edges(sel[:, 0], sel[:, 1], up, u0, u1, v0, v1, cell)
            v0, v1 = _edges(sel[:, 1], sel[:, 0], up, v0, v1, u0, u1, cell)
            top = ceil + float(np.quantile(dz[pts], 0.95))
            w, h = u1 - u0, v1 - v0
            centre = Point((u0 + u1) / 2, (v0 + v1) / 2)
            room = min(((r[2].distance(centre), r[0]) for r in rooms if r[1] == k), default=(None, None))[1]
            oid = f"window_roof_s{k}_{len(out)}"
            ring = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
            conf = round(float(min(1.0, share) * min(1.0, m.mean() / max(p.min_fill, 1e-9))), 3)
            out.append(Shape(oid, ShapeType.WINDOW, Polyhedron.prism(ring, top - p.frame, top), storey=k,
                             name=f"Roof window {len(out) + 1}", terminal=True, parent=slab.id,
                             support={"ceiling_ring": share, "fill": float(m.mean()),
                                      "points": float(pts.sum())},
                             attributes={"kind": "window", "skylight": True, "detected": True,
                                         "width": float(max(w, h)), "height": float(min(w, h)),
                                         "sill": float(top - p.frame - ceil), "depth": float(top - ceil),
                                         "spaces": [room, exterior_ids.get(k)], "confidence": conf},
                             log=(f"openings: roof window {max(w, h):.2f} m x {min(w, h):.2f} m, "
                                  f"{top - ceil:.2f} m deep; ceiling around it {share:.0%}",)))
    return out


def host_slab(o: Shape, slabs: Sequence[Shape], tol: float = 0.3) -> Optional[Shape]:
    """The roof slab holding skylight ``o``'s centre in plan, nearest in height (None: none)."""
    c = o.centroid
    best = None
    for s in slabs:
        if s.attributes.get("kind") != "roof" or not Polygon(s.footprint()).contains(Point(c[:2])):
            continue
        d = abs(float(s.bounds[0, 2]) - float(o.bounds[0, 2]))
        if best is None or d < best[0]:
            best = (d, s)
    if best is None or best[0] > max(tol, float(o.attributes.get("depth", 0)) + tol):
        return None
    return best[1]
