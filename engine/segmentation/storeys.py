"""Storeys from the z histogram of horizontal points (docs/method.md §1 "Storeys").

Method
------
1. z histogram (``bin_size``) of the floor/ceiling points (normal within θ of vertical)
   of the aligned cloud; local maxima at least ``min_layer_gap`` apart are candidate
   *layers*; each layer's height is the mean z of its points within ``layer_half_width``
   (two passes), so it is not quantised to the bin.
2. A layer's *area* is the area of the occupancy-grid cells (``grid_cell``) its points
   fill; layers covering less than ``min_area_fraction`` of the occupied footprint of the
   storey they bound (all points within ``min_storey_height`` above a floor-like layer,
   below a ceiling-like one) are dropped — a desk, a shelf or a bed is a big histogram peak
   but a small area. The storey's own footprint, not the building's: a scan with one
   position per storey sees a few rooms of each floor, in different places.
3. Floor or ceiling: the non-horizontal points (walls, clutter) inside the layer's
   footprint are counted in a thin window just above it and just below it. Walls rise
   from a floor and hang from a ceiling, and nothing lies inside a slab, so
   contrast = (above − below)/(above + below) is near +1 for a floor, −1 for a ceiling
   and near 0 for furniture tops (legs below, walls above); points within 2 ×
   ``layer_half_width`` of another layer close by (a ceiling just under the floor of the
   storey above, its noisy normals) are not counted. Layers with
   |contrast| < ``min_side_contrast`` are dropped. When scanner positions are known, a
   floor must lie below a scanner and a ceiling above one (a tie-breaker for real scans),
   and a layer without the contrast of a ceiling is a floor when scanner positions stand over
   its cells at an instrument's height above it (``min_standing_scanners``, and half of those
   at that height over any layer).
4. Pairing: floors in ascending order; floors less than ``min_storey_height`` above the
   previous kept floor join its storey (the larger-area one wins); a storey's ceiling is
   the highest ceiling layer at least ``min_storey_height`` above its floor and below the
   next storey's floor (rooms of several heights: the storey reaches the highest; the
   lower ceilings are in :func:`detect_layers` and become cell levels).
5. Sloped tops: a floor without a flat ceiling layer above it (an attic under pitched roof
   slabs) still makes a storey when enough downward-facing points (roof undersides) lie
   above it; its top is their ``sloped_top_quantile`` height (the ridge).

Departure from the thesis: it only says "peaks of the z histogram"; steps 2–5 are what
makes it work on real rooms where furniture tops outnumber the floor.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..errors import ReconstructionError
from ..model import Storey
from ..pointcloud import PointCloud
from ..progress import Progress
from .cleaning import estimate_normals
from .params import NormalParams, StoreyParams

__all__ = ["detect_storeys", "detect_layers", "Layer"]

log = logging.getLogger(__name__)

_PEAK_FLOOR = 0.02
"""Histogram bins below this share of the highest bin are not examined as layers (speed
only: such layers fail ``min_area_fraction`` anyway)."""
_MAX_PEAKS = 40
"""At most this many histogram peaks are examined (speed bound)."""


@dataclass(frozen=True)
class Layer:
    """A dense horizontal layer of points.

    Attributes
    ----------
    z : float — height, metres (aligned frame)
    points : int — horizontal points within ``layer_half_width``
    area : float — occupied area, m² (grid cells)
    contrast : float — (above − below)/(above + below) of non-horizontal points, in [−1, 1]
    kind : str — "floor", "ceiling" or "other"
    """

    z: float
    points: int
    area: float
    contrast: float
    kind: str


def _cells(xy: np.ndarray, origin: np.ndarray, cell: float, dims) -> np.ndarray:
    q = np.floor((xy - origin) / cell).astype(np.int64)
    q[:, 0] = np.clip(q[:, 0], 0, dims[0] - 1)
    q[:, 1] = np.clip(q[:, 1], 0, dims[1] - 1)
    return q[:, 0] * dims[1] + q[:, 1]


def _histogram_peaks(zh: np.ndarray, params: StoreyParams) -> tuple[float, list]:
    """(z0, peak bins) of the z histogram of ``zh`` smoothed by [¼, ½, ¼].

    Sparse: only occupied bins and their neighbours are looked at, so an outlier far away
    costs nothing (a dense histogram grows with the height range, not with the points).
    A histogram of one or two bins (a flat cloud) is handled like any other.
    """
    z0 = float(zh.min())
    nb = int(np.ceil((zh.max() - z0) / params.bin_size)) + 1
    ub, cnt = np.unique(((zh - z0) / params.bin_size).astype(np.int64), return_counts=True)
    cand = np.unique(np.clip(np.concatenate([ub - 1, ub, ub + 1]), 0, nb - 1))

    def at(offset):
        j = np.searchsorted(ub, cand + offset)
        jj = np.minimum(j, len(ub) - 1)
        return np.where((j < len(ub)) & (ub[jj] == cand + offset), cnt[jj], 0).astype(np.float64)

    smooth = 0.25 * at(-1) + 0.5 * at(0) + 0.25 * at(1)
    order = np.argsort(-smooth, kind="stable")
    gap_bins = max(1, int(round(params.min_layer_gap / params.bin_size)))
    peaks: list = []
    floor_count = _PEAK_FLOOR * smooth.max()
    for j in order:
        if smooth[j] < floor_count or len(peaks) >= _MAX_PEAKS:
            break
        b = int(cand[j])
        if any(abs(b - q) <= gap_bins for q in peaks):
            continue
        peaks.append(b)
    return z0, peaks


def detect_layers(cloud: PointCloud, params: StoreyParams = StoreyParams()) -> list[Layer]:
    """Candidate floor/ceiling layers of an aligned cloud with normals (see module doc).

    Returns every histogram layer with enough points, typed "floor", "ceiling" or "other"
    (too small, or no contrast), sorted by z; an empty list when fewer than
    ``min_layer_points`` points are horizontal. A flat cloud gives one layer (no storey:
    :func:`detect_storeys` then raises). Cost follows the number of points: the histogram
    and the occupancy grid are sparse.
    """
    xyz = cloud.xyz
    nz = np.abs(cloud.normals[:, 2].astype(np.float64))
    hor = nz >= np.cos(params.angle_tolerance)
    zh = xyz[hor, 2]
    if len(zh) < params.min_layer_points:
        return []
    z0, peaks = _histogram_peaks(zh, params)
    # footprint of the building: occupied cells only, numbered 0..k-1
    cell = params.grid_cell
    origin = xyz[:, :2].min(axis=0)
    dims = (np.floor((xyz[:, :2].max(axis=0) - origin) / cell).astype(np.int64) + 1)
    all_cells = _cells(xyz[:, :2], origin, cell, dims)
    occupied, cell_of = np.unique(all_cells, return_inverse=True)
    cell_of = cell_of.reshape(-1)
    footprint = len(occupied) * cell * cell
    # the occupied 4-neighbours of every occupied cell (-1: none), for the rim dilation
    cx, cy = np.divmod(occupied, dims[1])
    neighbours = np.full((len(occupied), 4), -1, np.int64)
    for j, (dx, dy) in enumerate(((1, 0), (-1, 0), (0, 1), (0, -1))):
        nx, ny = cx + dx, cy + dy
        ok = (nx >= 0) & (nx < dims[0]) & (ny >= 0) & (ny < dims[1])
        key = nx * dims[1] + ny
        pos = np.minimum(np.searchsorted(occupied, key), len(occupied) - 1)
        hit = ok & (occupied[pos] == key)
        neighbours[hit, j] = pos[hit]
    nonhor = ~hor & (nz <= np.cos(params.angle_tolerance))
    sp = cloud.scanner_positions
    fin = None if sp is None else np.isfinite(sp).all(axis=1)
    scanner_z = None if fin is None or not fin.any() else sp[fin, 2]
    scanner_cell = None  # each scanner's occupied cell (-1: over none)
    if scanner_z is not None:
        sxy = sp[fin, :2]
        inside_grid = np.all((sxy >= origin) & (sxy < origin + dims * cell), axis=1)
        key = _cells(np.where(inside_grid[:, None], sxy, origin), origin, cell, dims)
        pos = np.minimum(np.searchsorted(occupied, key), len(occupied) - 1)
        scanner_cell = np.where(inside_grid & (occupied[pos] == key), pos, -1)
    layers = []
    hw = params.layer_half_width
    peak_z = [z0 + (b + 0.5) * params.bin_size for b in peaks]
    for b in peaks:
        z = z0 + (b + 0.5) * params.bin_size
        for _ in range(2):
            sel = np.abs(zh - z) <= hw
            if sel.sum() == 0:
                break
            z = float(zh[sel].mean())
        in_layer = hor & (np.abs(xyz[:, 2] - z) <= hw)
        cnt = int(in_layer.sum())
        if cnt < params.min_layer_points:
            continue
        occ = np.zeros(len(occupied), bool)
        occ[cell_of[in_layer]] = True
        area = occ.sum() * cell * cell
        dil = occ.copy()  # one-cell dilation so walls on the layer's rim count
        rim = neighbours[occ].reshape(-1)
        dil[rim[rim >= 0]] = True
        inside = dil[cell_of] & nonhor
        others = [q for q in peak_z if abs(q - z) > 2 * hw]  # a layer close by: its noisy normals
        if others:  # are not walls of this one (a ceiling 0.2 m under the floor above)
            zz = xyz[:, 2]
            near = [q for q in others if abs(q - z) <= 2 * hw + params.side_window]
            for q in near:
                inside &= np.abs(zz - q) > 2 * hw
        dz = xyz[inside, 2] - z
        above = int(np.sum((dz > hw) & (dz <= hw + params.side_window)))
        below = int(np.sum((dz < -hw) & (dz >= -hw - params.side_window)))
        contrast = (above - below) / max(above + below, 1)
        # the footprint of the storey the layer bounds: every point within a storey height
        # on the side it faces (a floor: above, a ceiling: below); on a scan with one
        # position per storey each storey sees only some rooms, far fewer than the building
        zz = xyz[:, 2]
        side = (zz > z) & (zz <= z + params.min_storey_height) if contrast >= 0 else \
            (zz < z) & (zz >= z - params.min_storey_height)
        own = min(footprint, np.unique(cell_of[side]).size * cell * cell) if side.any() else footprint
        kind = "other"
        if area >= params.min_area_fraction * own:
            if contrast >= params.min_side_contrast:
                kind = "floor"
            elif contrast <= -params.min_side_contrast:
                kind = "ceiling"
            if scanner_z is not None:
                if kind == "floor" and not np.any(scanner_z > z):
                    kind = "other"
                elif kind == "ceiling" and not np.any(scanner_z < z):
                    kind = "other"
                elif kind == "other" and contrast > -params.min_side_contrast:
                    # scanners stood on it: positions over its cells at an instrument's
                    # height above it (FZK-Haus's attic floor 0.2 m over the ground floor's
                    # ceiling: the slab's edges and the stair's points in the thin window
                    # under it left it a contrast of -0.03 on a mobile walk, 0.39 on the next seed)
                    # (most of those at that height over it: a desk's top holds few of a walk's)
                    h = scanner_z - z
                    at = (h >= params.min_scanner_height) & (h <= params.max_scanner_height)
                    standing = int(np.count_nonzero(occ[scanner_cell[at & (scanner_cell >= 0)]]))
                    if standing >= max(params.min_standing_scanners, 0.5 * int(at.sum())):
                        kind = "floor"
        layers.append(Layer(z=z, points=cnt, area=float(area), contrast=float(contrast), kind=kind))
    layers.sort(key=lambda L: L.z)
    log.debug("layers: %s", layers)
    return layers


def _sloped_top(cloud: PointCloud, floor: Layer, top: float, params: StoreyParams):
    """Top of a storey without a flat ceiling layer (an attic under pitched roof slabs): the
    ``sloped_top_quantile`` of the heights of the points above the floor's footprint and below
    ``top`` that face down or sideways-down (roof undersides); None when they are too few or
    lower than ``min_storey_height`` above the floor."""
    xyz = cloud.xyz
    nz = cloud.normals[:, 2].astype(np.float64)
    sel = (xyz[:, 2] > floor.z + params.min_storey_height * 0.5) & (xyz[:, 2] < top) & (nz < -0.2)
    if int(sel.sum()) < params.min_layer_points:
        return None
    z = float(np.quantile(xyz[sel, 2], params.sloped_top_quantile))
    if z - floor.z < params.min_storey_height:
        return None
    return z


def detect_storeys(cloud: PointCloud, params: StoreyParams = StoreyParams(), *,
                   normal_params: NormalParams = NormalParams(), progress=None,
                   should_stop=None) -> list[Storey]:
    """Floor and ceiling heights of each storey of an aligned cloud (see module doc).

    Parameters
    ----------
    cloud : PointCloud
        Aligned (z up), metres; normals are estimated when missing.
    params : StoreyParams
    progress, should_stop : callables, see :class:`engine.progress.Progress`.

    Returns
    -------
    list of Storey
        Ascending; ``index`` 0, 1, …; ``floor_z``/``ceiling_z`` metres in the aligned frame;
        ``elevation`` = ``floor_z``. For rooms of several ceiling heights in one storey,
        ``ceiling_z`` is the highest ceiling layer (use :func:`detect_layers` for all).

    Raises
    ------
    ReconstructionError
        No floor layer with a ceiling layer at least ``min_storey_height`` above it.
    """

    p = Progress.wrap(progress, should_stop)
    p(0.0, "storeys")
    if cloud.normals is None:
        cloud = estimate_normals(cloud, normal_params, progress=p.sub(0.0, 0.5))
    name = cloud.source or "point cloud"
    layers = detect_layers(cloud, params)
    p(0.9, f"{len(layers)} horizontal layers")
    floors = [L for L in layers if L.kind == "floor"]
    ceilings = [L for L in layers if L.kind == "ceiling"]
    groups: list[list[Layer]] = []
    for f in floors:
        if groups and f.z - groups[-1][0].z < params.min_storey_height:
            groups[-1].append(f)
        else:
            groups.append([f])
    storeys = []
    for i, g in enumerate(groups):
        floor = max(g, key=lambda L: L.area)
        top = groups[i + 1][0].z if i + 1 < len(groups) else np.inf
        cand = [c for c in ceilings if floor.z + params.min_storey_height <= c.z < top]
        if cand:
            ceil_z = max(cand, key=lambda L: L.z).z
        else:
            ceil_z = _sloped_top(cloud, floor, top, params)
            if ceil_z is None:
                log.warning("%s: floor at z = %.3f m has no ceiling layer above it; skipped", name, floor.z)
                continue
            log.info("%s: floor at z = %.3f m has no flat ceiling; its top follows the points above it "
                     "(sloped roof) up to z = %.3f m", name, floor.z, ceil_z)
        k = len(storeys)
        storeys.append(Storey(index=k, floor_z=float(floor.z), ceiling_z=float(ceil_z),
                              name=f"Storey {k}", elevation=float(floor.z)))
    if not storeys:
        desc = ", ".join(f"{L.kind} z={L.z:.2f} area={L.area:.1f}m² contrast={L.contrast:+.2f}"
                         for L in layers)
        raise ReconstructionError(
            f"{name}: no storey found — no floor layer with a ceiling layer at least "
            f"{params.min_storey_height} m above it (layers: {desc or 'none'})")
    p(1.0, f"{len(storeys)} storey(s)")
    log.info("%s: %d storey(s): %s", name, len(storeys),
             ", ".join(f"[{s.floor_z:.3f}, {s.ceiling_z:.3f}]" for s in storeys))
    return storeys
