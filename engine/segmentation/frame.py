"""The frame of a scan before preprocessing: its units, its up axis, and clouds that hold no building.

Everything runs on a sample of about ``FrameParams.sample_points`` points — a random
pre-sample thinned on a voxel grid, so it is spatially even (a mobile scanner's dense
horizon band on the walls would otherwise fill whole neighbourhoods with one thin slab) —
with PCA normals over its ``neighbours`` nearest neighbours. Its cost does not grow with
the cloud, and every threshold is relative (to the extent, to the sample's own spacing and
noise) until the units are known. Only the **building** counts (:func:`_building`): rays
through windows and open doors return ground, trees and facades outside in far, sparse
patches that would carry much of the area (a sparse point stands for much of it) and widen
the footprint. The sample's largest connected component on a voxel grid sized from its own
spacing is the building (and any other holding ``building_share`` of its points: a storey
scanned apart); when the rest widened the box that sized the sample's voxel, the building is
sampled anew, as finely as without it.

Up axis (:func:`detect_up`)
---------------------------
Which file axis (±x, ±y, ±z) points up. The *axis* comes from two geometric cues and, when
the cloud says where its scanners stood, from the scanners' blind cone:

* **area**: the share of the surface area (each sample point weighs the area it stands
  for, ∝ r² with r its k-th neighbour distance, so a dense corridor walk does not outvote
  sparse rooms) whose normal is within ``axis_tolerance`` of the axis. Along the up axis
  these are the floors and the ceilings, twice the footprint; along a horizontal axis the
  walls facing one direction, which hold less as long as rooms are wider than tall;
* **extent**: buildings are flatter than they are wide — the robust extent (1st–99th
  percentile) along the up axis is the smallest;
* **blind cone** (``scan_index`` with ``scanner_positions``, or a single position): a
  terrestrial scanner sees nothing within 20–35° of its nadir (the tripod), the operator
  hides the same cone below a mobile scanner, and both see the ceiling at their zenith.
  The signed axis whose ``cone_angle`` cone around the scanners is empty on one side and
  populated on the other is the up direction (horizontal directions see walls on both
  sides); this gives the sign too, and wins over the other cues unless the geometry
  clearly disagrees.

The geometric score of an axis is ``ln(area share) − ln(extent)``. The file's z is kept
unless another axis beats it by ``rotate_margin`` (a clear lead, so that a z-up scan of a
lone narrow corridor keeps z). Without a blind cone the *sign*
comes from **gravity**: furniture stands on the floor, so free-standing horizontal surfaces
inside a storey (tables, desks, cabinets: open air above them, off the floor and ceiling
layers, in patches) lie in its lower half, weighted by their lever from mid-height;
lintels, soffits and lamps are rarer and smaller. Without either cue the sign of a z-up
file is kept (the convention of scanner formats; confidence 0.6) and the sign of another
axis cannot be told (the scan cannot be oriented: pass it). Two other cues are not used,
because neither tells floor from ceiling reliably: the scanner's height (it stands about as
far below the ceiling as above the floor) and the floor's lower completeness (furniture
shadows, the tripod's blind disk: a small difference, of either sign on mobile scans).

Units (:func:`detect_units`, cloud z up)
----------------------------------------
The sample is levelled on its floor/ceiling normals (real scans tilt by a degree), then
horizontal layers are the peaks of the z histogram of the floor/ceiling points, each as
thick as its own measured spread (so in file units); a layer covering
``min_layer_coverage`` of the footprint is dominant. A dominant layer with walls rising
from it is a floor, with walls hanging from it a ceiling (the contrast of steep points in
windows above and below it, as in :mod:`.storeys`). Each floor with the ceilings above it
(before the next floor) gives storey heights in file units. A unit is plausible when it
makes the storey height 2.2–6 m and the horizontal extent 2–500 m; scanner positions add
the scanner's height above the floor (0.8–2.5 m: tripod, trolley, backpack). Metres win
whenever they are plausible. Millimetres, centimetres and inches are then clear (a storey
of 280 m is no building; 2.2–2.36 m in centimetres is also 5.6–6 m in inches: the height
closer to ``typical_storey`` wins). Feet are only chosen on evidence metres cannot explain
— the scanner's height, or two storeys or ceiling heights all implausible in metres, or a
building over 500 m wide — because a single 9.8-unit storey is also a hall in metres.
With no plausible unit the answer is "m" with a low confidence.

Degenerate clouds are refused by :func:`.checks.check_degenerate` (re-exported here), which
also holds the sample and :class:`FrameParams`.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import InputError, ReconstructionError
from ..io import units_warning
from ..pointcloud import PointCloud
from .checks import (FrameParams, FrameSample, area_weights, check_degenerate, check_shape, checked_sample,
                     frame_sample, planar_mask, robust_extent, sample_indices, source_name)

__all__ = ["FrameParams", "UnitGuess", "UpGuess", "UNITS", "UP_AXES", "up_rotation", "detect_units",
           "detect_up", "check_degenerate", "normalize_frame", "apply_frame"]

log = logging.getLogger(__name__)

UNITS = {"m": 1.0, "mm": 0.001, "cm": 0.01, "in": 0.0254, "ft": 0.3048}
"""Unit name → metres per file unit."""
UP_AXES = ("z", "-z", "y", "-y", "x", "-x")
"""The file axis that points up."""


@dataclass(frozen=True)
class UnitGuess:
    """What :func:`detect_units` found.

    Attributes
    ----------
    unit : str — one of :data:`UNITS`
    scale : float — metres per file unit
    evidence : str — what decided, in words
    confidence : float — 0 (a guess) … 1 (certain)
    storey_heights : tuple of float — floor-to-ceiling heights found, file units
    """

    unit: str
    scale: float
    evidence: str
    confidence: float
    storey_heights: tuple = ()


@dataclass(frozen=True)
class UpGuess:
    """What :func:`detect_up` found.

    Attributes
    ----------
    up : str — one of :data:`UP_AXES`: the file axis that points up
    rotation : (3, 3) float64 — proper rotation taking file coordinates to z up
        (``p_up = rotation @ p_file``)
    evidence : str
    confidence : float — 0 … 1; below ``FrameParams.min_up_confidence`` the scan cannot be
        oriented automatically
    scores : dict — the measured cues per axis (for logs and tests)
    """

    up: str
    rotation: np.ndarray
    evidence: str
    confidence: float
    scores: dict


def up_rotation(up: str) -> np.ndarray:
    """(3, 3) proper rotation taking coordinates whose up axis is ``up`` to z up.

    ``rotation @ e_up = e_z``; z is the identity, -z a half turn about x, ±y and ±x quarter
    turns that keep the remaining horizontal axis as it is where possible.
    """
    table = {"z": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "-z": [[1, 0, 0], [0, -1, 0], [0, 0, -1]],
             "y": [[1, 0, 0], [0, 0, -1], [0, 1, 0]], "-y": [[1, 0, 0], [0, 0, 1], [0, -1, 0]],
             "x": [[0, 0, -1], [0, 1, 0], [1, 0, 0]], "-x": [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]}
    if up not in table:
        raise InputError(f"up must be one of {', '.join(UP_AXES)}, not {up!r}")
    return np.array(table[up], dtype=np.float64)


# ----------------------------------------------------------------------------- sample
def _levelled(s: FrameSample, params: FrameParams) -> FrameSample:
    """The z-up sample turned so its horizontal surfaces are level: real scans are often
    tilted by a degree or so, which smears a 12 m floor over 20 cm of height. The vertical
    is the principal direction of the normals within ``axis_tolerance`` of z (those of the
    floors and ceilings)."""
    par = planar_mask(s, params) & (np.abs(s.normals[:, 2]) >= math.cos(params.axis_tolerance))
    if par.sum() < 20:
        return s
    n = s.normals[par]
    w = area_weights(s)[par]
    _, vec = np.linalg.eigh((n * w[:, None]).T @ n)
    up = vec[:, -1] * np.sign(vec[2, -1])
    axis = np.cross(up, [0.0, 0.0, 1.0])
    sin = float(np.linalg.norm(axis))
    if sin < 1e-9:
        return s
    axis /= sin
    ang = math.atan2(sin, float(up[2]))
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + math.sin(ang) * k + (1 - math.cos(ang)) * (k @ k)  # Rodrigues: up -> z
    return s.transformed(rot)


def _building(cloud: PointCloud, s: FrameSample, params: FrameParams, rng) -> FrameSample:
    """The sample of the building alone (module doc): the components of ``s`` on a voxel grid
    of ``building_voxel`` times its median neighbour distance (26-connected); unless all are
    kept (the largest and those with ``building_share`` of its points), the sample is cut to
    them or, when that shrinks the box that sized its voxel (``building_resample``), the
    pre-sample is cut to their voxels (and the empty ones next to them), thinned and measured
    anew: a finer sample of the building alone."""
    ok = s.radius > 0
    v = params.building_voxel * float(np.median(s.radius[ok])) if ok.sum() >= 100 else 0.0
    lo = s.xyz.min(axis=0)
    dims = np.floor((s.xyz.max(axis=0) - lo) / max(v, 1e-300)).astype(np.int64) + 3
    if not v > 0 or float(np.prod(dims.astype(np.float64))) > 2.0 ** 60:
        return s

    def keys(xyz):  # voxel keys (a margin of one voxel around the sample) and whether inside it
        q = np.floor((xyz - lo) / v).astype(np.int64) + 1
        on = np.all((q >= 1) & (q < dims - 1), axis=1)
        q = np.clip(q, 0, dims - 1)
        return (q[:, 0] * dims[1] + q[:, 1]) * dims[2] + q[:, 2], on

    def box_area(xyz):  # of the 0.1-99.9 percentile box, as sample_indices sizes its voxel
        e = np.subtract(*np.percentile(xyz, [99.9, 0.1], axis=0))
        return 2.0 * float(e[0] * e[1] + e[1] * e[2] + e[0] * e[2])

    uk, inv = np.unique(keys(s.xyz)[0], return_inverse=True)
    offs = (np.indices((3, 3, 3)).reshape(3, -1).T - 1) @ np.array([dims[1] * dims[2], dims[2], 1])
    nk = uk[:, None] + offs[None, 14:]  # the 13 forward neighbours (offs[13] is the voxel itself)
    j = np.minimum(np.searchsorted(uk, nk), len(uk) - 1)
    hit = uk[j] == nk
    graph = coo_matrix((np.ones(int(hit.sum())), (np.nonzero(hit)[0], j[hit])), shape=(len(uk),) * 2)
    lab = connected_components(graph, directed=False)[1]
    count = np.bincount(lab[inv])
    keep = (count >= params.building_share * count.max())[lab]
    if keep.all():
        return s
    kp = keep[inv]
    if box_area(s.xyz[kp]) >= params.building_resample * box_area(s.xyz):  # as fine a sample: cut it
        return FrameSample(s.xyz[kp], s.normals[kp], s.curvature[kp], s.spread[kp], s.radius[kp], s.noise[kp],
                           s.rays, s.scanners, s.n_total, s.source)
    near = np.setdiff1d((uk[keep][:, None] + offs[None, :]).ravel(), uk[~keep])
    rng = np.random.default_rng(rng)
    n, k = len(cloud), min(len(cloud), params.presample * params.sample_points)
    raw = np.sort(rng.choice(n, k, replace=False)) if k < n else np.arange(n)
    raw = raw[np.isfinite(cloud.xyz[raw]).all(axis=1)]
    key, on = keys(cloud.xyz[raw])
    j = np.minimum(np.searchsorted(near, key), len(near) - 1)
    raw = raw[on & (near[j] == key)]
    idx, pre = sample_indices(PointCloud(xyz=cloud.xyz[raw]), params, rng)
    return frame_sample(cloud, params, rng, (raw[idx], raw[pre]))


# ----------------------------------------------------------------------------- layers
@dataclass(frozen=True)
class _Layer:
    z: float
    coverage: float  # share of the footprint cells
    weight: float  # horizontal area in the layer (sample units²)
    kind: str  # "floor", "ceiling" or "other"
    contrast: float
    half: float  # half-thickness: points within this of z belong to the layer


class _Layers:
    """Horizontal layers of a z-up sample (see the module docstring)."""

    def __init__(self, s: FrameSample, params: FrameParams):
        planar = planar_mask(s, params)
        nz = np.abs(s.normals[:, 2])
        self.par = planar & (nz >= math.cos(params.axis_tolerance))
        self.steep = nz <= params.steep_normal
        self.z = s.xyz[:, 2]
        self.w = area_weights(s)
        # the layers take every neighbourhood with a vertical normal that is not a scan line,
        # planar or not: in a big building the sample's neighbourhoods (k-th neighbour at
        # 0.3-0.6 m) reach across a 0.3 m slab, and two parallel planes are no plane
        par = (s.spread >= params.min_spread) & (s.radius > 0) & (nz >= math.cos(params.axis_tolerance))
        self.min_coverage = params.min_layer_coverage
        self.min_patch = params.min_patch
        self.layers: list[_Layer] = []
        self.band = 0.0
        self.footprint = 0
        if par.sum() < 20:
            return
        zpar = self.z[par]
        lo, hi = np.percentile(self.z, [0.5, 99.5])
        ext = max(hi - lo, 1e-300)
        noise = float(np.median(s.noise[self.par] if self.par.any() else s.noise[par]))
        band = float(np.clip(3.0 * noise, ext / 1000.0, ext / 30.0))
        self.band = band
        # footprint cells: the sample's own spacing, so about 5 points per cell of a layer
        cell = float(np.median(s.radius[planar])) if planar.any() else ext / 100.0
        self.spacing = cell
        span = np.ptp(s.xyz[:, :2], axis=0)
        cell = max(cell, float(span.max()) / 4000.0, 1e-300)
        q = np.floor((s.xyz[:, :2] - s.xyz[:, :2].min(axis=0)) / cell).astype(np.int64)
        width = int(q[:, 1].max()) + 3
        self.width = width
        self.keys = (q[:, 0] + 1) * width + (q[:, 1] + 1)
        fp = np.unique(self.keys)
        self.footprint = len(fp)
        # sparse histogram of the horizontal points, area-weighted (bins: half the band)
        bw = band / 2.0
        b = np.floor((zpar - zpar.min()) / bw).astype(np.int64)
        ub, inv = np.unique(b, return_inverse=True)
        hw = np.bincount(inv, weights=self.w[par])
        cand = np.unique(np.concatenate([ub - 1, ub, ub + 1]))

        def at(offset):
            j = np.searchsorted(ub, cand + offset)
            jj = np.minimum(j, len(ub) - 1)
            return np.where((j < len(ub)) & (ub[jj] == cand + offset), hw[jj], 0.0)

        smooth = 0.25 * at(-1) + 0.5 * at(0) + 0.25 * at(1)
        order = np.argsort(-smooth, kind="stable")
        gap = max(1, int(round(2.0 * band / bw)))
        peaks = []
        for j in order:
            if smooth[j] < 0.01 * smooth[order[0]] or len(peaks) >= 40:
                break
            if any(abs(cand[j] - p) <= gap for p in peaks):
                continue
            peaks.append(cand[j])
        raw = []
        wpar = self.w[par]
        reach = max(4.0 * band, ext / 30.0)
        for p in peaks:
            zc = zpar.min() + (p + 0.5) * bw
            half = band
            for _ in range(3):  # centre, then the layer's own thickness (noise grows with range)
                sel = np.abs(zpar - zc) <= half
                if not sel.any():
                    break
                zc = float(np.average(zpar[sel], weights=wpar[sel]))
                near = zpar[np.abs(zpar - zc) <= reach]
                mad = float(np.median(np.abs(near - np.median(near))))
                half = float(np.clip(3.0 * 1.4826 * mad, band, reach))
            sel = par & (np.abs(self.z - zc) <= half)
            if sel.sum() < 5:
                continue
            cells = np.unique(self.keys[sel])
            raw.append((zc, len(cells) / self.footprint, float(self.w[sel].sum()), cells, half))
        raw.sort(key=lambda t: t[0])
        # one layer seen as several peaks (a thick, noisy floor): the heaviest stays
        merged = []
        for r in raw:
            if merged and r[0] - merged[-1][0] < max(r[4], merged[-1][4]):
                if r[2] > merged[-1][2]:
                    merged[-1] = r
                continue
            merged.append(r)
        dom = [r for r in merged if r[1] >= params.min_layer_coverage]
        dz = [r[0] for r in dom]
        for r in merged:
            zc, cov, wt, cells, half = r
            kind, contrast = "other", 0.0
            if cov >= params.min_layer_coverage:
                i = dz.index(zc)
                g_above = dz[i + 1] - zc if i + 1 < len(dz) else None
                g_below = zc - dz[i - 1] if i > 0 else None
                if g_above is None and g_below is None:
                    g_above = g_below = ext
                g_above = g_above if g_above is not None else g_below
                g_below = g_below if g_below is not None else g_above
                wa, wb = max(0.3 * g_above, half), max(0.3 * g_below, half)
                near = self._dilated(cells)
                ins = np.isin(self.keys, near) & self.steep
                d = self.z[ins] - zc
                wi = self.w[ins]
                above = wi[(d > half) & (d <= half + wa)].sum() / wa
                below = wi[(d < -half) & (d >= -half - wb)].sum() / wb
                contrast = float((above - below) / max(above + below, 1e-300))
                if contrast >= params.side_contrast:
                    kind = "floor"
                elif contrast <= -params.side_contrast:
                    kind = "ceiling"
            self.layers.append(_Layer(float(zc), float(cov), wt, kind, contrast, half))

    @property
    def _around(self):
        """Key offsets of a cell and its 8 neighbours."""
        w = self.width
        return (0, 1, -1, w, -w, w + 1, w - 1, -w + 1, -w - 1)

    def _dilated(self, cells: np.ndarray) -> np.ndarray:
        return np.unique(np.concatenate([cells + o for o in self._around]))

    def _patch_size(self, i: np.ndarray, zmin: float, step: float, zspan: int, band: float) -> np.ndarray:
        """For each point ``i``: how many of the points ``i`` lie in its cell or the 8 around
        within ``band`` in z (itself included)."""
        if len(i) == 0:
            return np.zeros(0, np.int64)
        zq = np.floor((self.z[i] - zmin) / step).astype(np.int64)
        comp = np.sort(self.keys[i] * zspan + zq)
        r = int(math.ceil(band / step))
        out = np.zeros(len(i), np.int64)
        for o in self._around:
            base = (self.keys[i] + o) * zspan
            out += np.searchsorted(comp, base + zq + r, side="right") - np.searchsorted(comp, base + zq - r)
        return out

    def storeys(self):
        """[(floors z list, ceilings z list, ceiling coverages)] grouped bottom-up: each run of
        floor layers with the ceiling layers above it before the next floor."""
        out = []
        cur = None
        for L in self.layers:
            if L.kind == "floor":
                if cur is None or cur[1]:
                    cur = ([], [], [])
                    out.append(cur)
                cur[0].append(L.z)
            elif L.kind == "ceiling" and cur is not None:
                cur[1].append(L.z)
                cur[2].append(L.coverage)
        return [c for c in out if c[1]]

    def heights(self):
        """Floor-to-ceiling heights (file units) with the ceilings' coverage as weights."""
        hs, ws = [], []
        for floors, ceils, covs in self.storeys():
            f = max(floors)
            for c, w in zip(ceils, covs):
                hs.append(c - f)
                ws.append(w)
        return np.array(hs), np.array(ws)

    def clutter(self):
        """Where the free-standing horizontal surfaces inside the storeys lie: (lower −
        upper)/(lower + upper), (lower + upper) as a share of the horizontal area and the
        number of sample points counted; each surface weighted by its area and its lever
        |1 − 2t| (t: height in the storey, 0 at the floor), so what lies near mid-height (a
        mobile scanner's horizon band on the walls) hardly counts.

        Inside a storey: between its highest floor and its lowest ceiling layer, off every
        dominant layer by twice its half-thickness and by the neighbourhood radius (near a
        wall-ceiling junction the normals lean). Free-standing: no steep point above it up to
        that ceiling in its footprint cell and the 8 around (a table top has open air above
        it; a door head, a cabinet against a wall or a dense band of scan lines on a wall
        has the wall), in a patch of ``min_patch`` points.
        """
        low = upp = 0.0
        count = 0
        if not self.layers:
            return 0.0, 0.0, 0
        dom = [L for L in self.layers if L.kind != "other" or L.coverage >= self.min_coverage]
        dz = np.array([L.z for L in dom])
        dm = np.array([max(2.0 * L.half, self.spacing) for L in dom])  # junction normals lean
        band = self.band
        st = np.nonzero(self.steep)[0]
        zmin = float(self.z.min())
        step = band / 4.0
        zq_st = np.floor((self.z[st] - zmin) / step).astype(np.int64)
        zspan = int(np.floor((float(self.z.max()) - zmin) / step)) + 2
        comp = np.sort(self.keys[st] * zspan + zq_st)
        self.selected = []  # (indices, lever) per storey, for inspection
        for floors, ceils, _ in self.storeys():
            zb, za = max(floors), min(ceils)
            h = za - zb
            sel = self.par & (self.z > zb) & (self.z < za)
            sel &= np.all(np.abs(self.z[:, None] - dz[None, :]) > dm[None, :], axis=1)
            i = np.nonzero(sel)[0]
            if not len(i):
                continue
            lo_q = np.floor((self.z[i] + band - zmin) / step).astype(np.int64)
            hi_q = np.floor((za - band - zmin) / step).astype(np.int64)
            above = np.zeros(len(i), np.int64)
            for o in self._around:
                base = (self.keys[i] + o) * zspan
                above += np.searchsorted(comp, base + hi_q) - np.searchsorted(comp, base + lo_q)
            i = i[above == 0]
            i = i[self._patch_size(i, zmin, step, zspan, band) >= self.min_patch]
            lever = 1.0 - 2.0 * (self.z[i] - zb) / h  # +1 at the floor, -1 at the ceiling
            self.selected.append((i, lever))
            count += len(i)
            wi = self.w[i]
            low += float(np.sum(wi * np.maximum(lever, 0.0)))
            upp += float(np.sum(wi * np.maximum(-lever, 0.0)))
        tot = self.w[self.par].sum()
        share = (low + upp) / tot if tot > 0 else 0.0
        if low + upp <= 0:
            return 0.0, 0.0, 0
        return float((low - upp) / (low + upp)), float(share), count


# ----------------------------------------------------------------------------- up axis
def _cone(s: FrameSample, axis: int, params: FrameParams):
    """(asymmetry (n₊ − n₋)/(n₊ + n₋), n₊ + n₋) of the rays (a plain random sample: the
    scanner's angular sampling, which a spatially even sample would bias by the range)
    within ``cone_angle`` of +axis / −axis, or None without scanners."""
    if s.rays is None:
        return None
    c = s.rays[:, axis]
    ca = math.cos(params.cone_angle)
    up, down = int(np.sum(c > ca)), int(np.sum(c < -ca))
    return (up - down) / max(up + down, 1), up + down


def _axis_scores(s: FrameSample, params: FrameParams) -> dict:
    planar = planar_mask(s, params)
    w = area_weights(s)
    wp = float(w[planar].sum())
    ext = robust_extent(s.xyz)
    big = float(ext.max()) if ext.max() > 0 else 1.0
    out = {}
    for a, name in enumerate("xyz"):
        par = planar & (np.abs(s.normals[:, a]) >= math.cos(params.axis_tolerance))
        share = float(w[par].sum()) / wp if wp > 0 else 0.0
        e = float(ext[a])
        score = math.log(max(share, 1e-6)) - math.log(max(e / big, 1e-6))
        out[name] = {"area_share": share, "extent": e, "score": score, "cone": _cone(s, a, params)}
    return out


def _clutter_sign(s: FrameSample, up: str, params: FrameParams):
    """(asymmetry, share, points) of the furniture-top cue when ``up`` is up (module doc)."""
    return _Layers(_levelled(s.transformed(up_rotation(up)), params), params).clutter()


def _decide_up(s: FrameSample, params: FrameParams) -> UpGuess:
    scores = _axis_scores(s, params)
    geo = {a: scores[a]["score"] for a in "xyz"}
    best = max(geo, key=geo.get)
    notes = [f"{a}: area {scores[a]['area_share']:.2f}, extent {scores[a]['extent']:.4g}"
             for a in "xyz"]
    # blind cone of the scanners
    cone_up = None
    cones = {a: scores[a]["cone"] for a in "xyz" if scores[a]["cone"] is not None}
    if cones:
        strong = [a for a, (asym, cnt) in cones.items()
                  if abs(asym) >= params.cone_clear and cnt >= params.min_cone_points]
        weak = [a for a, (asym, cnt) in cones.items() if abs(asym) >= params.cone_other]
        if len(strong) == 1 and weak == strong:
            a = strong[0]
            cone_up = a if cones[a][0] > 0 else "-" + a
        notes.append("blind cone " + ", ".join(f"{a} {asym:+.2f} ({cnt})"
                                               for a, (asym, cnt) in cones.items()))

    def guess(up, conf, why):
        ev = why + " [" + "; ".join(notes) + "]"
        return UpGuess(up, up_rotation(up), ev, float(conf), scores)

    if cone_up is not None:
        axis = cone_up[-1]
        if best != axis and geo[best] - geo[axis] >= params.rotate_margin:
            return guess(cone_up, 0.3, f"the scanners' blind cone says {cone_up} but the floor/wall "
                                       f"geometry says {best}")
        return guess(cone_up, 0.95, f"up is {cone_up}: the scanners see nothing within "
                                    f"{math.degrees(params.cone_angle):.0f}° of that direction's nadir")
    # geometry: the axis
    lead = geo[best] - geo["z"]
    if best != "z" and lead >= params.rotate_margin:
        axis, conf, why = best, 0.9, f"{best} carries the floors and ceilings (score {lead:+.2f} over z)"
    elif best != "z":
        axis, conf, why = "z", 0.5, (f"{best} scores {lead:+.2f} over z, less than the "
                                     f"{params.rotate_margin:g} needed to rotate: the file's z is kept")
    else:
        second = max(v for a, v in geo.items() if a != "z")
        axis, conf = "z", (0.9 if geo["z"] - second >= params.rotate_margin / 2 else 0.7)
        why = f"z carries the floors and ceilings (score {geo['z'] - second:+.2f} over the next axis)"
    # the sign
    asym, share, count = _clutter_sign(s, axis, params)
    scores["clutter"] = {axis: (asym, share, count)}
    clear = (share >= params.min_clutter_share and count >= params.min_clutter_points
             and abs(asym) >= params.clutter_clear)
    cue = (f"furniture tops {asym:+.2f} (lower − upper; {share:.1%} of the horizontal area, "
           f"{count} sample points)")
    if clear:
        up = axis if asym > 0 else "-" + axis
        return guess(up, conf if asym > 0 or axis != "z" else min(conf, 0.8),
                     f"{why}; sign from gravity: {cue}")
    if axis == "z":
        return guess("z", min(conf, 0.6), f"{why}; sign by the file's convention ({cue}: no clear cue)")
    return guess(axis, 0.3, f"{why}; its sign cannot be told ({cue}, no scanner positions)")


def detect_up(cloud: PointCloud, params: FrameParams = FrameParams(), *, rng=0) -> UpGuess:
    """Which file axis points up (see the module docstring for the cues).

    Parameters
    ----------
    cloud : PointCloud
        Any units; scanner positions with ``scan_index`` (or one position) are used when
        present.
    params : FrameParams
    rng : seed of the sample.

    Returns
    -------
    UpGuess
        ``confidence`` below ``params.min_up_confidence`` means the cues disagree or are
        missing: the scan cannot be oriented automatically.
    """
    s = _building(cloud, frame_sample(cloud, params, rng), params, rng)
    g = _decide_up(s, params)
    log.info("%s: up %s (confidence %.2f): %s", source_name(cloud), g.up, g.confidence, g.evidence)
    return g


# ----------------------------------------------------------------------------- units
def _in(v, rng_) -> bool:
    return v is not None and rng_[0] <= v <= rng_[1]


def _weighted_median(v: np.ndarray, w: np.ndarray) -> float:
    o = np.argsort(v)
    c = np.cumsum(w[o])
    return float(v[o][np.searchsorted(c, 0.5 * c[-1])])


def _scanner_height(s: FrameSample, layers: _Layers) -> Optional[float]:
    """Median height of the scanners above the nearest floor layer below them (file units)."""
    if s.scanners is None or not len(s.scanners):
        return None
    floors = np.array([L.z for L in layers.layers if L.kind == "floor"])
    if not len(floors):
        return None
    hs = []
    for z in s.scanners[:, 2]:
        below = floors[floors < z]
        if len(below):
            hs.append(z - below.max())
    return float(np.median(hs)) if hs else None


def _decide_units(s: FrameSample, params: FrameParams) -> UnitGuess:
    s = _levelled(s, params)
    layers = _Layers(s, params)
    hs, ws = layers.heights()
    ext_h = float(robust_extent(s.xyz)[:2].max())
    h_main = _weighted_median(hs, ws) if len(hs) else None
    h_scan = _scanner_height(s, layers)
    st, ex, sc = params.storey_height, params.building_extent, params.scanner_height
    facts = [f"horizontal extent {ext_h:.4g}"]
    if len(hs):
        facts.append("storey heights " + ", ".join(f"{h:.4g}" for h in hs))
    if h_scan is not None:
        facts.append(f"scanner height {h_scan:.4g}")
    facts = "; ".join(facts) + " (file units)"
    heights = tuple(float(h) for h in hs)

    def guess(u, conf, why):
        return UnitGuess(u, UNITS[u], f"{why} [{facts}]", float(conf), heights)

    def ok(u):
        f = UNITS[u]
        return {"h": _in(None if h_main is None else h_main * f, st), "ext": _in(ext_h * f, ex),
                "scan": None if h_scan is None else _in(h_scan * f, sc)}

    checks = {u: ok(u) for u in UNITS}
    if h_main is not None:
        m = checks["m"]
        if m["h"] and m["ext"]:
            if m["scan"] is False:
                return guess("m", 0.6, f"storey {h_main:.3g} m is plausible in metres, though the scanner "
                                       f"height {h_scan:.3g} m is not")
            return guess("m", 0.9 if m["scan"] is None else 0.95,
                         f"storey {h_main:.3g} m is plausible in metres")
        cands = [u for u in UNITS if u != "m" and checks[u]["h"] and checks[u]["ext"]
                 and checks[u]["scan"] is not False]
        if not cands:
            return guess("m", 0.2, f"no unit makes the storey height {h_main:.4g} plausible; metres assumed")

        def typical(u):
            return abs(math.log(h_main * UNITS[u] / params.typical_storey))

        cands.sort(key=typical)
        u = cands[0]
        conf = 0.9 if len(cands) == 1 else 0.6
        why = f"storey {h_main:.4g} {u} = {h_main * UNITS[u]:.3g} m"
        if u != "ft":
            also = "" if len(cands) == 1 else f" (also possible: {', '.join(cands[1:])})"
            return guess(u, conf, why + also)
        # feet against a hall in metres: only on evidence metres cannot explain
        f = UNITS["ft"]
        all_ft = len(hs) >= 2 and all(_in(h * f, st) and not _in(h, st) for h in hs)
        if checks["ft"]["scan"]:
            return guess("ft", 0.9, why + f"; the scanner stands {h_scan * f:.2g} m above the floor in feet")
        if all_ft:
            return guess("ft", 0.8, why + f"; all {len(hs)} storey/ceiling heights are plausible in "
                                          f"feet only")
        if ext_h > ex[1]:
            return guess("ft", 0.8, why + f"; {ext_h:.4g} m across is no building in metres")
        return guess("m", 0.3, f"storey {h_main:.4g} would be {h_main * f:.3g} m in feet, but a hall that "
                               f"high is possible in metres: metres kept (pass the units if they are feet)")
    if h_scan is not None:
        cands = [u for u in UNITS if checks[u]["scan"] and checks[u]["ext"]]
        if "m" in cands:
            return guess("m", 0.6, f"no storey found; the scanner height {h_scan:.3g} m is plausible "
                                   f"in metres")
        if len(cands) == 1:
            u = cands[0]
            return guess(u, 0.6, f"no storey found; the scanner stands {h_scan * UNITS[u]:.3g} m above "
                                 f"the floor in {u}")
    if checks["m"]["ext"]:
        return guess("m", 0.5, "no storey found; the extent is plausible in metres")
    return guess("m", 0.1, "no storey found and the extent is implausible in metres: the units cannot "
                           "be told")


def detect_units(cloud: PointCloud, params: FrameParams = FrameParams(), *, rng=0) -> UnitGuess:
    """The unit of the coordinates of a z-up cloud (see the module docstring).

    Parameters
    ----------
    cloud : PointCloud
        z up (orient it first: :func:`detect_up`, :func:`normalize_frame`), any units.
    params : FrameParams
    rng : seed of the sample.

    Returns
    -------
    UnitGuess
        "m" with a low confidence when no unit makes the storey height and the extent
        plausible.
    """
    g = _decide_units(_building(cloud, frame_sample(cloud, params, rng), params, rng), params)
    log.info("%s: units %s (confidence %.2f): %s", source_name(cloud), g.unit, g.confidence, g.evidence)
    return g


# ----------------------------------------------------------------------------- all
def normalize_frame(cloud: PointCloud, units: str = "auto", up: str = "auto",
                    params: FrameParams = FrameParams(), *, rng=0) -> tuple[PointCloud, dict]:
    """Check the cloud, then bring it to metres with z up.

    Parameters
    ----------
    cloud : PointCloud
    units : "auto" or one of :data:`UNITS`
        A given unit skips the detection.
    up : "auto" or one of :data:`UP_AXES` (the file axis that points up)
        A given axis skips the detection.
    params : FrameParams
    rng : seed of the sample.

    Returns
    -------
    cloud : PointCloud
        ``xyz`` and ``scanner_positions`` rotated then scaled to metres, ``normals``
        rotated, ``offset`` scaled and rotated the same way (so ``xyz + offset`` stays the
        original coordinates in the new frame). The input itself when nothing changes and
        nothing needs a warning.
    record : dict
        For provenance: ``units``, ``scale`` (metres per file unit), ``up``, ``rotation``
        (3×3 list, ``p_new = scale · rotation @ p_file``), ``evidence`` (dict with
        ``units`` and ``up``), ``units_confidence``, ``up_confidence`` (1.0 when given),
        ``warnings`` (list of str, also appended to the cloud's ``warnings``: a rescale, a
        rotation, metres assumed with a low confidence).

    Raises
    ------
    InputError
        An unknown unit or axis name.
    ReconstructionError
        A degenerate cloud (:func:`check_degenerate`); ``up="auto"`` and the up axis cannot
        be told (pass ``up``); ``units="auto"`` and the extent is no building in metres
        while no unit can be told (pass ``units``).
    """
    if units != "auto" and units not in UNITS:
        raise InputError(f"units must be auto or one of {', '.join(UNITS)}, not {units!r}")
    if up != "auto" and up not in UP_AXES:
        raise InputError(f"up must be auto or one of {', '.join(UP_AXES)}, not {up!r}")
    name = source_name(cloud)
    notes: list = []  # warnings a user should see
    given_scale = None if units == "auto" else UNITS[units]
    s_all, e = checked_sample(cloud, params, given_scale, rng)
    # the building's sample serves the detections alone: with both given, the checks suffice
    s = _building(cloud, s_all, params, rng) if "auto" in (units, up) else s_all
    if up == "auto":
        ug = _decide_up(s, params)
        if ug.confidence < params.min_up_confidence:
            raise ReconstructionError(
                f"the scan cannot be oriented: {ug.evidence}. Pass the up axis (--up z, -z, y, -y, x or -x)",
                cloud.source or None)
        up_name, rot, up_ev, up_conf = ug.up, ug.rotation, ug.evidence, ug.confidence
    else:
        up_name, rot, up_ev, up_conf = up, up_rotation(up), "given", 1.0
    log.info("%s: up %s (confidence %.2f): %s", name, up_name, up_conf, up_ev)
    if units == "auto":
        s_up = s.transformed(rot)
        g = _decide_units(s_up, params)
        if g.unit == "m" and g.confidence < params.min_units_confidence:
            ext_h = float(robust_extent(s_up.xyz)[:2].max())
            if ext_h > params.building_extent[1]:
                raise ReconstructionError(
                    f"the units cannot be told: {g.evidence}; the cloud is {ext_h:,.0f} units across, too "
                    f"large for a building in metres. Pass the units (--units mm, cm, in, ft or m)",
                    cloud.source or None)
            notes.append(f"units: metres assumed with low confidence — {g.evidence}")
        if g.unit != "m" and g.confidence < params.min_units_confidence:
            raise ReconstructionError(f"the units cannot be told: {g.evidence}. Pass the units (--units)",
                                      cloud.source or None)
        unit, scale, u_ev, u_conf = g.unit, g.scale, g.evidence, g.confidence
        check_shape(cloud, s_all.xyz, params, scale, e)  # now in metres
    else:
        unit, scale, u_ev, u_conf = units, UNITS[units], "given", 1.0
    log.info("%s: units %s (confidence %.2f): %s", name, unit, u_conf, u_ev)
    if unit != "m":
        notes.append(f"coordinates in {unit}, rescaled to metres (× {scale:g})")
    if up_name != "z":
        notes.append(f"the file's {up_name} axis points up: rotated to z up")
    for text in notes:
        log.warning("%s: %s", name, text)
    record = {"units": unit, "scale": scale, "up": up_name, "rotation": rot.tolist(),
              "evidence": {"units": u_ev, "up": up_ev}, "units_confidence": u_conf, "up_confidence": up_conf,
              "warnings": notes}
    out = apply_frame(cloud, rot, scale)
    if notes:
        kept = out.warnings
        if unit != "m":  # the reader's "looks like millimetres" note is answered by the rescale
            kept = tuple(w for w in kept if w != units_warning(out))
        out = out.with_(warnings=tuple(kept) + tuple(notes))
    return out, record


def apply_frame(cloud: PointCloud, rot: np.ndarray, scale: float) -> PointCloud:
    """``cloud`` turned by ``rot`` (3, 3), scaled by ``scale`` (as :func:`normalize_frame` does)."""
    if scale == 1.0 and np.array_equal(rot, np.eye(3)):
        return cloud
    m = scale * rot
    sp = None if cloud.scanner_positions is None else cloud.scanner_positions @ m.T
    nr = None if cloud.normals is None else (cloud.normals.astype(np.float64) @ rot.T)
    return cloud.with_(xyz=cloud.xyz @ m.T, normals=nr, scanner_positions=sp, offset=m @ cloud.offset)
