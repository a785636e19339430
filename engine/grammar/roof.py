"""Attic rooms under pitched roofs (issue 19): roof planes from the scan, and the rooms' bodies
cut by them, so that an IfcSpace under a roof follows the roof instead of being a box up to
the ridge (docs/method.md §2, sloped tops).

:func:`roof_planes` finds the planes of a storey's sloped ceiling points (roof undersides):
the most frequent normal direction, the densest offset along it, a least-squares plane on its
inliers, repeated while a plane covers at least ``min_roof_area``. :func:`slope_spaces` gives
each room of the storey the body of :func:`engine.geometry.sloped.sloped_prism` under the
planes seen over its footprint.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..geometry.sloped import RoofPlane, sloped_prism
from ..model import BuildingModel, ShapeType

__all__ = ["RoofFit", "meets_roof", "roof_planes", "slope_spaces"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RoofFit:
    """One roof plane and the plan positions (m, 2) of the points that support it."""

    plane: RoofPlane
    xy: np.ndarray
    area: float


def _cells(xy: np.ndarray, cell: float) -> int:
    return len(np.unique(np.floor(xy / cell).astype(np.int64), axis=0)) if len(xy) else 0


def roof_planes(xyz: np.ndarray, normals: np.ndarray, *, spacing: float, buffer: float, min_roof_area: float = 2.0,
                angle: float = float(np.radians(15.0)), max_planes: int = 8) -> list[RoofFit]:
    """The planes of sloped ceiling points (``xyz``, ``normals``: (n, 3), the storey's roof
    undersides), largest first; each supported by at least ``min_roof_area`` m² of plan cells
    (twice ``spacing`` wide), its inliers within ``buffer`` of it and their normals within
    ``angle`` of its own."""
    xyz = np.asarray(xyz, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    n = np.where(n[:, 2:3] < 0, -n, n)  # sign-free: up
    cell = max(2.0 * float(spacing), 0.05)  # cells a sparse roof still fills
    cos_a = float(np.cos(angle))
    left = np.ones(len(xyz), dtype=bool)
    out: list[RoofFit] = []
    while len(out) < max_planes and left.sum() >= 10:
        idx = np.flatnonzero(left)
        az = np.arctan2(n[idx, 1], n[idx, 0])
        tilt = np.arccos(np.clip(n[idx, 2], -1, 1))
        key = np.floor((az + np.pi) / np.radians(15.0)).astype(np.int64) * 64 + \
            np.floor(tilt / np.radians(10.0)).astype(np.int64)
        _, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
        fullest = idx[inv == int(np.argmax(counts))]
        seed = n[fullest].mean(axis=0)
        seed /= np.linalg.norm(seed)
        along = idx[n[idx] @ seed >= cos_a]
        if len(along) == 0:  # (a bin's members lie within 18° of each other: not expected)
            left[fullest] = False
            continue
        d = xyz[along] @ seed
        bins = np.floor((d - d.min()) / buffer).astype(np.int64)
        peak = np.argmax(np.bincount(bins))
        d0 = d.min() + (peak + 0.5) * buffer
        inl = along[np.abs(d - d0) <= 1.5 * buffer]
        if len(inl) < 10:
            left[along] = False
            continue
        c = xyz[inl].mean(axis=0)
        _, vec = np.linalg.eigh(np.cov((xyz[inl] - c).T))
        nn = vec[:, 0] * (1 if vec[2, 0] >= 0 else -1)
        if nn[2] < 1e-3 or nn @ seed < cos_a:
            left[inl] = False
            continue
        dd = float(nn @ c)
        inl = idx[(np.abs(xyz[idx] @ nn - dd) <= buffer) & (n[idx] @ nn >= cos_a)]
        area = _cells(xyz[inl, :2], cell) * cell * cell
        left[inl] = False
        left[along[np.abs(d - d0) <= 1.5 * buffer]] = False
        if area < min_roof_area:
            continue
        out.append(RoofFit(RoofPlane(tuple(float(x) for x in nn), dd), xyz[inl, :2].copy(), float(area)))
    out.sort(key=lambda r: -r.area)
    return out


def slope_spaces(model: BuildingModel, storey: int, fits: list, *, spacing: float, min_share: float = 0.1,
                 min_cover: float = 1.0) -> BuildingModel:
    """The model with the rooms of ``storey`` cut by the roof planes seen over them: a plane
    counts for a room when at least ``min_cover`` m² (or ``min_share`` of the room) of its
    inliers' plan cells lie in the room's footprint. Rooms whose body would not change, or
    whose roof would reach their floor, keep their box. The cut rooms get
    ``attributes["sloped_top"] = True``."""
    if not fits:
        return model
    cell = max(2.0 * float(spacing), 0.05)  # cells a sparse roof still fills
    new = {}
    for s in model.spaces:
        if s.storey != storey or s.type != ShapeType.INTERIOR:
            continue
        fp = s.geometry.footprint()
        if fp is None:
            continue
        poly = Polygon(fp)
        shapely.prepare(poly)
        use = []
        for f in fits:
            inside = f.xy[shapely.contains_xy(poly, f.xy[:, 0], f.xy[:, 1])]
            cover = _cells(inside, cell) * cell * cell
            if cover >= min(min_cover, min_share * poly.area):
                use.append(f.plane)
        if not use:
            continue
        z0, z1 = (float(v) for v in s.geometry.bounds[:, 2])
        g = sloped_prism(fp, z0, z1, use)
        if g is None:
            continue
        new[s.id] = s.with_(geometry=g, attributes={**s.attributes, "sloped_top": True})
    if new:
        log.info("storey %d: %d room(s) under %d roof plane(s) follow the roof", storey, len(new), len(fits))
        model = model.with_(shapes=tuple(new.get(s.id, s) for s in model.shapes))
    return model


def meets_roof(wall: np.ndarray, fits: list, axis: int, position: float, *, half_width: float,
               reach: float, band: float, cell: float, min_length: float) -> bool:
    """Does the wall surface at ``position`` along ``axis`` (metres) run up to the roof, as an
    attic's knee wall does where the roof comes down onto it? Its points (``wall``: (n, 3)
    points facing ``axis``; those within ``half_width`` of the position) end, along at least
    ``min_length`` of the wall (counted in ``cell`` bins), within ``band`` of the roof's
    underside over them: the lowest of the roof planes (``fits``, :func:`roof_planes`) whose
    support reaches within ``reach`` of the point in plan (the underside of a pitched roof is
    the lowest of its planes). The roof's points near the eaves are few (seen at a grazing
    angle), so the planes, not the points, say where it meets the wall. Such a wall never
    reaches the storey's top (the ridge), so the grammar's ceiling test does not take it;
    furniture stops well short of the roof."""
    q = wall[np.abs(wall[:, axis] - position) <= half_width]
    if len(q) == 0 or not fits:
        return False
    o = 1 - axis
    k = np.floor(q[:, o] / cell).astype(np.int64)
    order = np.lexsort((q[:, 2], k))
    last = np.r_[k[order][1:] != k[order][:-1], True]
    tops = q[order[last]]  # the highest point of each bin along the wall
    under = np.full(len(tops), np.inf)
    for f in fits:
        lo, hi = f.xy.min(axis=0) - reach, f.xy.max(axis=0) + reach
        near = np.all((tops[:, :2] >= lo) & (tops[:, :2] <= hi), axis=1)
        under[near] = np.minimum(under[near], f.plane.z(tops[near, 0], tops[near, 1]))
    met = np.isfinite(under) & (np.abs(tops[:, 2] - under) <= band)
    return int(met.sum()) * cell >= min_length
