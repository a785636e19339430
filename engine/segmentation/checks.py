"""The sample the frame stage measures, and the refusal of clouds that hold no building.

Every frame statistic (:mod:`.frame`: units, up axis; and the checks here) runs on a sample
of about ``FrameParams.sample_points`` points — a random pre-sample thinned on a voxel grid,
so it is spatially even — with PCA statistics over its ``neighbours`` nearest neighbours
(:func:`engine.geometry.normals.knn_pca`).

Degenerate clouds (:func:`check_degenerate`)
--------------------------------------------
Too few distinct points, all points identical, collinear or coplanar (robust PCA extents
of the sample against the largest extent, the local noise and, once the units are known,
``min_thickness``), and no structure (fewer than ``min_planar_share`` of the sample's
neighbourhoods are planar: uniform noise). Each raises
:class:`~engine.errors.ReconstructionError` naming the file; the checks read only the sample,
so their cost does not grow with the cloud.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..errors import ReconstructionError
from ..geometry.boxes import column_max
from ..geometry.normals import knn_pca
from ..pointcloud import PointCloud, core_bounds

__all__ = ["FrameParams", "FrameSample", "frame_sample", "sample_indices", "source_name", "planar_mask",
           "area_weights", "robust_extent", "check_shape", "checked_sample", "check_degenerate"]


@dataclass(frozen=True)
class FrameParams:
    """Settings of the frame checks (metres where a unit is given; the rest are relative)."""

    sample_points: int = 50_000
    """Size of the (spatially even) sample the statistics are computed on."""
    presample: int = 4
    """The sample is thinned on a voxel grid from a random sample this many times larger."""
    neighbours: int = 16
    """k of the PCA normals of the sample."""
    planar_curvature: float = 0.1
    """A neighbourhood is planar when its smallest PCA eigenvalue is below this share of the
    sum (a disc of radius r with noise σ: σ²/(r²/2 + σ²), below 0.1 when r > 3σ; 16 uniform
    random points: about 0.2)."""
    min_spread: float = 0.05
    """... and its middle eigenvalue reaches this share of the largest (the neighbours of a
    point far from a mobile scanner's path often lie on one scan line)."""
    axis_tolerance: float = math.radians(15.0)
    """A normal within this of an axis is parallel to it, radians."""
    steep_normal: float = 0.5
    """|n_z| below this is a steep (wall or furniture side) point in the floor/ceiling test."""
    cone_angle: float = math.radians(15.0)
    """Half-angle of the cone around the scanner's nadir and zenith, radians (inside the
    20–35° blind cone of terrestrial scanners)."""
    min_cone_points: int = 30
    """Sample points needed in the two cones of an axis for the blind-cone cue."""
    cone_clear: float = 0.8
    """The blind-cone asymmetry (n₊ − n₋)/(n₊ + n₋) of the up axis must reach this ..."""
    cone_other: float = 0.5
    """... while every other axis stays below this."""
    rotate_margin: float = 1.0
    """Another axis replaces z only when its geometric score beats z's by this (natural
    log of area share / extent): a clear lead, so that a z-up scan of a lone corridor, taller
    than it is wide, keeps z."""
    min_patch: int = 4
    """A furniture top is a patch: at least this many such sample points within its cell
    and the 8 around, at one height (isolated points are sampling artefacts)."""
    min_clutter_share: float = 0.002
    """The furniture-top cue counts when such surfaces hold this share of the horizontal
    area (lever-weighted; an empty room has almost none) ..."""
    min_clutter_points: int = 20
    """... and holds this many sample points (a stray patch under a ceiling holds a few) ..."""
    clutter_clear: float = 0.5
    """... and (lower − upper)/(lower + upper) reaches this in magnitude (furniture tops lie
    almost all in the lower half of a storey)."""
    min_layer_coverage: float = 0.15
    """A horizontal layer covering this share of the footprint is dominant (a floor or a
    ceiling; desks and shelves cover less)."""
    side_contrast: float = 0.3
    """|above − below|/(above + below) of the steep points a dominant layer needs to be a
    floor or a ceiling."""
    storey_height: tuple = (2.2, 6.0)
    """Plausible floor-to-ceiling height of a storey, metres."""
    typical_storey: float = 2.8
    """When two units make the storey plausible, the one closer to this height wins, metres."""
    building_extent: tuple = (2.0, 500.0)
    """Plausible horizontal extent of a scanned building, metres."""
    scanner_height: tuple = (0.8, 2.5)
    """Plausible height of a scanner above the floor it stands on, metres."""
    min_distinct: int = 10
    """Fewer distinct points than this is degenerate."""
    flat_ratio: float = 1e-3
    """A PCA extent below this share of the largest is zero (collinear, coplanar)."""
    flat_noise: float = 10.0
    """... or, for the thinnest axis, below this many times the local noise (one plane)."""
    min_thickness: float = 0.2
    """In metres (units known): a cloud thinner than this along its thinnest PCA axis is
    flat, narrower than this along the second is a line."""
    min_planar_share: float = 0.25
    """Fewer planar neighbourhoods than this share means no structure (a scan is mostly
    planar, uniform noise in a box almost nowhere)."""
    building_voxel: float = 1.5
    """The building is the sample's largest connected component on a voxel grid this many
    times the median ``neighbours``-th neighbour distance (the sample's own spacing): ground,
    trees and facades outside, seen through windows and open doors, lie in far, sparse patches
    apart from it (a gap of over a voxel) ..."""
    building_share: float = 0.1
    """... together with every component holding this share of its sample points (a storey
    scanned apart from the others)."""
    building_resample: float = 0.8
    """... and when the building's box holds less than this share of the surface of the
    sample's box (which sized its voxel), the building is sampled anew, finer."""
    min_up_confidence: float = 0.5
    """:func:`normalize_frame` refuses an automatic up axis below this confidence."""
    min_units_confidence: float = 0.5
    """... and applies a detected unit other than metres only from this confidence."""


# ----------------------------------------------------------------------------- sample
@dataclass(frozen=True, eq=False)
class FrameSample:
    """The sample (:func:`sample_indices`) with its PCA neighbourhood statistics (file units)."""

    xyz: np.ndarray  # (m, 3)
    normals: np.ndarray  # (m, 3) unit
    curvature: np.ndarray  # (m,) smallest eigenvalue / sum, 1 for degenerate neighbourhoods
    spread: np.ndarray  # (m,) middle eigenvalue / largest: near 0 on a line (a scan line)
    radius: np.ndarray  # (m,) distance to the k-th neighbour
    noise: np.ndarray  # (m,) sqrt(smallest eigenvalue / k): plane residual
    rays: Optional[np.ndarray]  # (r, 3) unit scanner → point directions of a random sample, or None
    scanners: Optional[np.ndarray]  # (k, 3) finite scanner positions or None
    n_total: int
    source: str

    def transformed(self, rot: np.ndarray) -> "FrameSample":
        """The sample rotated by ``rot`` (3, 3): p → rot @ p."""
        r = np.asarray(rot, dtype=np.float64)
        return FrameSample(
            xyz=self.xyz @ r.T, normals=self.normals @ r.T, curvature=self.curvature, spread=self.spread,
            radius=self.radius, noise=self.noise,
            rays=None if self.rays is None else self.rays @ r.T,
            scanners=None if self.scanners is None else self.scanners @ r.T,
            n_total=self.n_total, source=self.source)


def source_name(cloud_or_sample) -> str:
    """The cloud's (or sample's) source file for messages; "point cloud" when unknown."""
    return cloud_or_sample.source or "point cloud"


def sample_indices(cloud: PointCloud, params: FrameParams, rng, core: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Indices of a spatially even sample of the cloud's finite, distinct points, and of the
    random pre-sample it was thinned from (for statistics of the rays, which thinning biases).

    A random pre-sample (``presample`` × ``sample_points``) is thinned on a voxel grid to
    about ``sample_points``: a random sample keeps the scan's density, and a mobile
    scanner's horizon band (every position at one height sees the walls' band at that
    height) would otherwise fill the neighbourhoods of wall points with one thin slab
    across the wall. The voxel is sized from the surface count (like :func:`.clean`).
    Exact duplicates go too (some scans hold every point twice).
    """
    rng = np.random.default_rng(rng)
    n = len(cloud)
    m = params.sample_points
    k = min(n, params.presample * m)
    idx = np.sort(rng.choice(n, k, replace=False)) if k < n else np.arange(n)
    xyz = cloud.xyz[idx]
    ok = np.isfinite(xyz).all(axis=1)
    idx, xyz = idx[ok], xyz[ok]
    if core and len(idx) > params.min_distinct:  # without the far strays (pointcloud.core_bounds)
        lo, hi = core_bounds(xyz)
        inside = np.all((xyz >= lo) & (xyz <= hi), axis=1)
        if inside.sum() >= params.min_distinct:
            idx, xyz = idx[inside], xyz[inside]
    if len(idx) > m:
        lo, hi = np.percentile(xyz, [0.1, 99.9], axis=0)
        ext = hi - lo
        if ext.max() > 0:
            area = 2.0 * float(ext[0] * ext[1] + ext[1] * ext[2] + ext[0] * ext[2])
            v = max(math.sqrt(area / m), float(ext.max()) / 1e5)
            for _ in range(6):
                q = np.floor((np.clip(xyz, lo, hi) - lo) / v).astype(np.int64)
                dims = column_max(q) + 1
                key = (q[:, 0] * dims[1] + q[:, 1]) * dims[2] + q[:, 2]
                _, first = np.unique(key, return_index=True)
                if len(first) <= m:
                    break
                v *= math.sqrt(len(first) / m) * 1.02
            if len(first) > m:
                first = rng.choice(first, m, replace=False)
            if len(first) >= params.min_distinct:
                return idx[np.sort(first)], idx
    _, first = np.unique(xyz, axis=0, return_index=True)
    return idx[np.sort(first)], idx


def _rays(cloud: PointCloud, idx: np.ndarray) -> Optional[np.ndarray]:
    """(r, 3) unit directions from each point's scanner to the points ``idx`` (those with a
    known, distinct scanner), or None when the cloud does not say where its scanners were."""
    sp = cloud.scanner_positions
    if sp is None or not len(sp):
        return None
    if cloud.scan_index is not None:
        si = cloud.scan_index[idx]
        good = (si >= 0) & (si < len(sp))
        d = cloud.xyz[idx[good]] - sp[si[good]]
    elif len(sp) == 1:
        d = cloud.xyz[idx] - sp[0]
    else:
        return None
    r = np.linalg.norm(d, axis=1)
    ok = np.isfinite(r) & (r > 0)
    return d[ok] / r[ok, None] if ok.any() else None


def frame_sample(cloud: PointCloud, params: FrameParams, rng, idx: Optional[tuple] = None) -> FrameSample:
    """The sample (:func:`sample_indices`, or ``idx`` as it returns them) with kNN PCA statistics."""
    idx, raw = sample_indices(cloud, params, rng) if idx is None else idx
    xyz = cloud.xyz[idx]
    m = len(xyz)
    n = len(cloud)
    rays = _rays(cloud, raw)
    sp = cloud.scanner_positions
    scanners = None
    if sp is not None and len(sp):
        fin = np.isfinite(sp).all(axis=1)
        scanners = sp[fin] if fin.any() else None
    k = min(params.neighbours, m - 1)
    if k < 3:
        nrm = np.zeros((m, 3))
        nrm[:, 2] = 1.0
        one, zero = np.ones(m), np.zeros(m)
        return FrameSample(xyz, nrm, one, zero, zero, zero, rays, scanners, n, cloud.source)
    centre = xyz.mean(axis=0)  # centred: the covariances of georeferenced data keep their digits
    d, w, v = knn_pca(xyz - centre, k + 1)
    total = w.sum(axis=1)
    curv = np.where(total > 0, np.maximum(w[:, 0], 0.0) / np.where(total > 0, total, 1.0), 1.0)
    spread = np.where(w[:, 2] > 0, np.maximum(w[:, 1], 0.0) / np.where(w[:, 2] > 0, w[:, 2], 1.0), 0.0)
    noise = np.sqrt(np.maximum(w[:, 0], 0.0) / (k + 1))
    return FrameSample(xyz, v[:, :, 0], curv, spread, d[:, -1], noise, rays, scanners, n, cloud.source)


def planar_mask(s: FrameSample, params: FrameParams) -> np.ndarray:
    """Neighbourhoods on a plane: thin, and not a line (a scan line's PCA "normal" is any
    direction across it)."""
    return (s.curvature < params.planar_curvature) & (s.spread >= params.min_spread) & (s.radius > 0)


def area_weights(s: FrameSample) -> np.ndarray:
    """Surface area each sample point stands for (∝ r², file units²)."""
    return s.radius ** 2


def robust_extent(xyz: np.ndarray, lo=1.0, hi=99.0) -> np.ndarray:
    """(3,) extent of (n, 3) points per axis between the ``lo`` and ``hi`` percentiles (units of ``xyz``)."""
    a, b = np.percentile(xyz, [lo, hi], axis=0)
    return b - a


# ----------------------------------------------------------------------------- degenerate
def _pca_extents(xyz: np.ndarray) -> np.ndarray:
    """Robust (0.5–99.5 percentile) extents along the principal axes, largest first."""
    c = xyz - xyz.mean(axis=0)
    _, vec = np.linalg.eigh(c.T @ c)
    p = c @ vec[:, ::-1]
    lo, hi = np.percentile(p, [0.5, 99.5], axis=0)
    return hi - lo


def check_shape(cloud: PointCloud, xyz: np.ndarray, params: FrameParams, scale: Optional[float],
                 e: Optional[np.ndarray] = None) -> np.ndarray:
    """Distinct points, collinear, coplanar from the deduplicated sample ``xyz``; returns the
    PCA extents (file units)."""
    where = cloud.source or None
    n = len(cloud)
    if n < params.min_distinct:
        raise ReconstructionError(f"only {n} points: no building can be reconstructed", where)
    if len(xyz) == 1:
        p = ", ".join(f"{v:.6g}" for v in xyz[0])
        k = params.presample * params.sample_points
        what = f"all {n:,} points" if n <= k else f"all of {k:,} points sampled from the {n:,}"
        raise ReconstructionError(f"{what} are identical ({p}): nothing to reconstruct", where)
    if len(xyz) < params.min_distinct:
        among = f"{n:,}" if n <= params.presample * params.sample_points else \
            f"a random {params.presample * params.sample_points:,} of the {n:,}"
        raise ReconstructionError(f"only {len(xyz)} distinct points among {among}: nothing to reconstruct",
                                  where)
    if e is None:
        e = _pca_extents(xyz)
    unit = "m" if scale is not None else "file units"
    f = 1.0 if scale is None else scale
    if e[0] <= 0:
        raise ReconstructionError(f"almost all of the {n:,} points are at one spot: nothing to reconstruct",
                                  where)
    if e[1] <= params.flat_ratio * e[0] or (scale is not None and e[1] * f < params.min_thickness):
        raise ReconstructionError(
            f"the points lie on a line ({e[0] * f:.4g} {unit} long, {e[1] * f:.3g} {unit} wide): no building "
            f"can be reconstructed", where)
    if e[2] <= params.flat_ratio * e[0] or (scale is not None and e[2] * f < params.min_thickness):
        raise ReconstructionError(
            f"the cloud is flat ({e[0] * f:.4g} × {e[1] * f:.4g} {unit}, {e[2] * f:.3g} {unit} thick): "
            f"a building needs walls, a floor and a ceiling", where)
    return e


def _check_structure(cloud: PointCloud, s: FrameSample, e: np.ndarray, params: FrameParams) -> None:
    """One plane within the noise; no planar neighbourhoods (uniform noise)."""
    where = cloud.source or None
    planar = planar_mask(s, params)
    share = float(planar.mean())
    noise = float(np.median(s.noise[planar])) if planar.any() else float(np.median(s.noise))
    if e[1] <= params.flat_noise * noise:
        raise ReconstructionError(
            f"the points lie on a line: {e[1]:.3g} file units wide, within {params.flat_noise:g} times "
            f"their noise ({noise:.3g}) — no building can be reconstructed", where)
    if e[2] <= params.flat_noise * noise:
        raise ReconstructionError(
            f"the cloud is flat: {e[2]:.3g} file units thick, within {params.flat_noise:g} times its "
            f"noise ({noise:.3g}) of one plane — a building needs walls, a floor and a ceiling", where)
    if share < params.min_planar_share:
        raise ReconstructionError(
            f"no structure: only {share:.0%} of the point neighbourhoods are planar (a scan of walls, "
            f"floors and ceilings has over {params.min_planar_share:.0%}) — noise or a wrong file?", where)


def checked_sample(cloud: PointCloud, params: FrameParams, scale: Optional[float], rng):
    """The sample after the shape checks (before its k-d tree) and the structure checks."""
    if len(cloud) < params.min_distinct:
        check_shape(cloud, cloud.xyz, params, scale)
    try:
        return _checked(cloud, params, scale, rng, core=False)
    except ReconstructionError as first:
        # far strays (1 % of the points spread over kilometres) can size the sample's grid and
        # its PCA extents: judge the core of the cloud before calling it degenerate
        try:
            return _checked(cloud, params, scale, rng, core=True)
        except ReconstructionError:
            raise first from None


def _checked(cloud: PointCloud, params: FrameParams, scale: Optional[float], rng, core: bool):
    idx, raw = sample_indices(cloud, params, rng, core=core)
    if len(idx) == 0:
        raise ReconstructionError("no point has finite coordinates", cloud.source or None)
    e = check_shape(cloud, cloud.xyz[idx], params, scale)
    s = frame_sample(cloud, params, rng, (idx, raw))
    _check_structure(cloud, s, e, params)
    return s, e


def check_degenerate(cloud: PointCloud, params: FrameParams = FrameParams(), *, scale: Optional[float] = None,
                     rng=0) -> None:
    """Raise when the cloud cannot hold a building (see the module docstring).

    Parameters
    ----------
    cloud : PointCloud
    params : FrameParams
    scale : float, optional
        Metres per file unit when known: also refuses clouds thinner than
        ``params.min_thickness`` metres along the thinnest PCA axis (flat) or the second
        (a line). Without it only the relative tests run.
    rng : seed of the sample.

    Raises
    ------
    ReconstructionError
        Naming ``cloud.source``: too few distinct points, identical, collinear, coplanar,
        or no structure. Reads only a sample, so the cost does not grow with the cloud.
    """
    checked_sample(cloud, params, scale, rng)
