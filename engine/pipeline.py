"""The one preprocessing stage both reconstruction methods use, and the method choice.

:func:`preprocess` (docs/method.md §1): the working cloud (one point per voxel), normals,
point clusters (wall / floor-ceiling / other), storeys and RANSAC planes, each once.
:func:`align` adds the Manhattan alignment (only the Manhattan method and ``indoor
segment`` need it). :func:`choose_method` decides ``--method auto`` from the planes that
preprocessing found, so ``auto`` costs nothing beyond the method it picks.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from .errors import ReconstructionError
from .geometry.kdtree import kdtree
from .geometry.spacing import estimate_spacing
from .model import Storey
from .pointcloud import PointCloud
from .progress import Progress
from .quantities import Radians, Ratio
from .segmentation.alignment import AlignmentResult, align_manhattan
from .segmentation.classify import CLASS_HORIZONTAL, classify_points
from .segmentation.cleaning import (building_points, clean_voxels, drop_nonfinite, estimate_normals,
                                   voxel_downsample)
from .segmentation.params import CleanParams, PreprocessParams
from .segmentation.planes import extract_planes
from .segmentation.storeys import detect_storeys
from .threads import thread_cap
from .geometry.boxes import column_max, column_min

__all__ = ["ChoiceParams", "Prepared", "Cleaned", "cleaned_clouds", "preprocess", "align", "cap_points",
           "full_cloud_normals", "plausible_scanners", "manhattan_score", "choose_method", "normal_tilt_spread"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ChoiceParams:
    """``--method auto``: the Manhattan grammar when the wall planes are Manhattan enough."""

    manhattan_threshold: Ratio = 0.85
    """Manhattan when :func:`manhattan_score` reaches this share of the wall-plane area."""
    angle_tolerance: Radians = math.radians(3.0)
    """A wall plane within this of the best perpendicular pair of directions counts, radians
    (real walls are not perfectly square; a wall 7° off the axes must not count)."""


@dataclass(frozen=True, eq=False)
class Prepared:
    """What :func:`preprocess` produced, in the input frame (metres, z up).

    Attributes
    ----------
    cloud : PointCloud — the input points that are finite and belong to the building
        (:func:`engine.segmentation.cleaning.building_points`).
    working : PointCloud — one point per voxel, with normals and the fields
        ``segment_class`` (int8, :mod:`engine.segmentation.classify`) and ``plane`` (int32
        plane id, -1 for none).
    working_index : (m,) int64 — index of each working point in ``cloud``.
    voxel : float — the voxel edge used, metres.
    spacing : float or None — point spacing σ of the input's sparsest tenth, metres
        (:func:`engine.geometry.spacing.estimate_spacing`); measured with ``full_normals``
        (the Manhattan grammar's input), else None.
    labels : (m,) int8 — point clusters of the working cloud.
    storeys : list of Storey; ``storeys_found`` False when they are the fallback (one
        storey between the 1st and 99th percentile of the floor/ceiling points).
    planes : list of Plane (empty when planes were not asked for).
    transform : (4, 4) float64 aligned → input, or None before :func:`align`.
    alignment : AlignmentResult or None.
    timings : dict of str → seconds.
    cleaning : dict — input points, and the non-finite and stray points (far clusters) removed.
    tree : a k-d tree of ``cloud.xyz`` (:func:`engine.geometry.kdtree.kdtree`) when a stage
        built one (the spacing, the full cloud's normals), shared with the later ones; or None.
    """

    cloud: PointCloud
    working: PointCloud
    working_index: np.ndarray
    voxel: float
    spacing: Optional[float]
    labels: np.ndarray
    storeys: list
    storeys_found: bool = True
    planes: list = field(default_factory=list)
    transform: Optional[np.ndarray] = None
    alignment: Optional[AlignmentResult] = None
    timings: dict = field(default_factory=dict)
    cleaning: dict = field(default_factory=dict)
    params: PreprocessParams = field(default_factory=PreprocessParams)
    tree: Optional[object] = None

    def cloud_tree(self):
        """The k-d tree of ``cloud.xyz``, built on first use (see ``tree``); return it and
        keep it with ``replace(prep, tree=...)`` to share it."""
        return self.tree if self.tree is not None else kdtree(self.cloud.xyz)

    def representative(self) -> np.ndarray:
        """(n,) int64: for every point of ``cloud``, the index of its working point (its
        voxel's representative; the nearest working point when outliers were removed)."""
        kept, voxel_of = None, None
        if self.voxel > 0:
            _, kept, voxel_of = voxel_downsample(self.cloud, self.voxel)
        if kept is not None and np.array_equal(kept, self.working_index):
            return voxel_of
        if self.voxel <= 0 and len(self.working_index) == len(self.cloud):
            return np.arange(len(self.cloud), dtype=np.int64)
        _, nn = kdtree(self.working.xyz).query(self.cloud.xyz, k=1, workers=thread_cap())
        return nn.astype(np.int64)

    def to_full(self, values: np.ndarray) -> np.ndarray:
        """Carry a per-working-point array (m, ...) onto every point of ``cloud`` (n, ...)."""
        values = np.asarray(values)
        if len(values) != len(self.working):
            raise ValueError(f"expected {len(self.working)} values (one per working point), got {len(values)}")
        return values[self.representative()]


def normal_tilt_spread(normals: np.ndarray) -> float:
    """Median tilt from horizontal of the near-vertical-surface normals (|n_z| < sin 30°),
    radians: how noisy wall normals are (0 when there are none)."""
    nz = np.abs(np.asarray(normals, dtype=np.float64).reshape(-1, 3)[:, 2])
    wall = nz < 0.5
    return float(np.arcsin(np.median(nz[wall]))) if wall.any() else 0.0


def _cluster_params(work: PointCloud, params: PreprocessParams):
    """The point-cluster parameters with θ raised for noisy normals (``theta_spread_factor``)."""
    base = params.classify
    if params.theta_spread_factor <= 0:
        return base
    theta = min(max(base.angle_tolerance, params.theta_spread_factor * normal_tilt_spread(work.normals)),
                max(params.max_theta, base.angle_tolerance))
    if theta > base.angle_tolerance:
        log.info("noisy normals: point clusters with θ = %.1f°", math.degrees(theta))
    return replace(base, angle_tolerance=theta)


def _storeys_of(cloud: PointCloud, labels: np.ndarray, params: PreprocessParams) -> tuple[list, bool]:
    """Storeys of the working cloud, or one storey over the floor/ceiling points (False)."""
    try:
        return list(detect_storeys(cloud, params.storeys)), True
    except ReconstructionError as e:
        z = cloud.xyz[labels == CLASS_HORIZONTAL, 2]
        if len(z) < 10:
            raise ReconstructionError(f"no storey found ({e}) and too few floor/ceiling points",
                                      cloud.source or None) from None
        lo, hi = np.percentile(z, [1, 99])
        log.warning("storey detection failed (%s); one storey from %.2f to %.2f m", e, lo, hi)
        return [Storey(0, float(lo), float(hi), "Storey 0", float(lo))], False


@dataclass(frozen=True, eq=False)
class Cleaned:
    """The first step of :func:`preprocess`, which a second call on the same scan can reuse:
    ``full`` (finite, stray clusters removed, plausible scanner positions), ``work`` (the
    working cloud), ``index`` (each working point's index in ``full``), ``voxel``, the
    ``cleaning`` counts, the ``timings`` and the ``voxels`` of ``full``
    (:func:`engine.segmentation.cleaning.clean_voxels`)."""

    full: PointCloud
    work: PointCloud
    index: np.ndarray
    voxel: float
    cleaning: dict
    timings: dict
    voxels: Optional[tuple] = None


def cleaned_clouds(cloud: PointCloud, params: PreprocessParams = PreprocessParams()) -> Cleaned:
    """The building's points and the working cloud of ``cloud`` (:class:`Cleaned`)."""
    t = {}
    t0 = time.perf_counter()
    full = drop_nonfinite(cloud)
    keep, groups = building_points(full.xyz, params.clean.cluster_voxel, params.clean.min_cluster_share)
    cleaning = {"points": len(cloud), "nonfinite_removed": len(cloud) - len(full),
                "stray_points_removed": int((~keep).sum()), "stray_clusters_removed": groups}
    if not keep.all():
        log.info("%s: %d points in %d far clusters removed", cloud.source or "cloud", (~keep).sum(), groups)
        full = full.subset(keep)
    full, dropped = plausible_scanners(full, params.clean.scanner_margin)
    if dropped:
        cleaning["scanner_positions_dropped"] = dropped
    t["strays"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    work, index, voxel, voxels = clean_voxels(full, params.clean)
    t["working_cloud"] = time.perf_counter() - t1
    return Cleaned(full, work, index, voxel, cleaning, t, voxels)


def preprocess(cloud: PointCloud, params: PreprocessParams = PreprocessParams(), *, rng=0,
               planes: bool = True, full_normals: bool = False, progress=None, should_stop=None,
               cleaned: Optional[Cleaned] = None, plane_kinds=("wall", "horizontal")) -> Prepared:
    """Working cloud, normals, point clusters, storeys and (``planes``) RANSAC planes.

    Parameters
    ----------
    cloud : PointCloud — metres, z up (see :func:`engine.segmentation.frame.normalize_frame`).
    params : PreprocessParams
    rng : seed or numpy Generator — RANSAC draws from it (a Generator is advanced).
    planes : bool — extract planes (the generic method and ``auto`` need them).
    full_normals : bool — estimate the normals of every point first
        (:func:`full_cloud_normals`, what the Manhattan grammar reads); the working cloud then
        takes its points' normals.
    cleaned : :func:`cleaned_clouds` of ``cloud`` with ``params``, from an earlier call, or
        None (computed).
    plane_kinds : the planes to find (:func:`engine.segmentation.planes.extract_planes`'s
        ``kinds``; the method choice reads the walls alone).

    Raises
    ------
    EmptyCloudError
        Fewer usable points than ``params.clean.min_points``.
    ReconstructionError
        No storey and too few floor/ceiling points, or no plane at all.
    """
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    p = Progress.wrap(progress, should_stop)
    p(0.0, "working cloud")
    c = cleaned_clouds(cloud, params) if cleaned is None else cleaned
    full, work, index, voxel, cleaning, t = c.full, c.work, c.index, c.voxel, c.cleaning, dict(c.timings)
    p.check()
    spacing = tree = None  # only the Manhattan grammar reads them
    if full_normals:  # the working cloud then shares them
        t1 = time.perf_counter()
        tree = kdtree(full.xyz)  # shared by the spacing, the normals' fallback and the noise
        spacing = estimate_spacing(full.xyz, tree=tree)
        t["spacing"] = time.perf_counter() - t1
        t1 = time.perf_counter()
        p(0.0, "normals")
        full = full_cloud_normals(full, params, spacing, tree=tree, voxel=voxel, voxels=c.voxels)
        work = work.with_(normals=full.normals[index])
        t["normals_full"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    if work.normals is None:
        p(0.05, "normals")
        npar = params.normals
        # plain PCA: every neighbourhood of the working cloud is wide (>= 3 voxels), so the
        # one-sided estimate would redo most of them (1-1.5 s per 250k mobile points) for the
        # planes and storeys; the Manhattan grammar reads the full cloud's one-sided normals
        work = estimate_normals(work, replace(npar, radius=max(npar.radius, npar.radius_voxels * voxel),
                                              one_sided_planarity=0.0))
    t["normals"] = time.perf_counter() - t1
    p.check()
    t1 = time.perf_counter()
    labels = classify_points(work, _cluster_params(work, params))
    storeys, found = _storeys_of(work, labels, params)
    t["storeys"] = time.perf_counter() - t1
    found_planes = []
    plane_of = np.full(len(work), -1, np.int32)
    if planes:
        t1 = time.perf_counter()
        p(0.2, "planes")
        found_planes = extract_planes(work, params.planes, labels=labels, storeys=storeys, rng=rng,
                                      progress=p.sub(0.2, 1.0), should_stop=should_stop, kinds=plane_kinds)
        for pl in found_planes:
            plane_of[pl.support] = pl.id
        t["planes"] = time.perf_counter() - t1
    work = work.with_(fields={**work.fields, "segment_class": labels, "plane": plane_of})
    log.info("preprocess %s: %d -> %d working points, %d storeys, %d planes (%s)", cloud.source or "cloud",
             len(cloud), len(work), len(storeys), len(found_planes), {k: round(v, 2) for k, v in t.items()})
    return Prepared(cloud=full, working=work, working_index=index, voxel=voxel, spacing=spacing, labels=labels,
                    storeys=storeys, storeys_found=found, planes=found_planes, timings=t, cleaning=cleaning,
                    params=params, tree=tree)


def align(prep: Prepared, *, rng=0, cloud: Optional[PointCloud] = None) -> Prepared:
    """``prep`` with the Manhattan alignment (transform aligned → input) from the normals of
    ``cloud`` (the full cloud with its normals, which becomes ``prep.cloud``), or of the
    working cloud when ``cloud`` is None."""
    if prep.transform is not None:
        return prep
    t0 = time.perf_counter()
    _, transform, res = align_manhattan(prep.working if cloud is None else cloud, prep.params.align, rng=rng,
                                        normal_params=prep.params.normals, return_result=True, apply=False)
    return replace(prep, cloud=prep.cloud if cloud is None else cloud, transform=transform, alignment=res,
                   timings={**prep.timings, "align": time.perf_counter() - t0})


def cap_points(cloud: PointCloud, params: CleanParams = CleanParams()) -> tuple[PointCloud, dict]:
    """``cloud`` thinned to about ``params.max_points`` points, and what was done
    (``{"points", "kept"}``; ``{}`` when nothing was).

    A seeded random sample (each point kept with probability ``max_points / n``): it keeps the
    scan's density pattern (dense near a terrestrial scanner, sparse on far walls), which the
    Manhattan grammar's spacing and IPoF read, where a voxel grid would flatten it; the result
    is a scan of ``max_points`` points of the same building. Every stage after this one
    costs what the thinned cloud costs, so a 10M-point scan costs little more than a 2M-point
    one (this one linear pass excepted).
    """
    limit = int(params.max_points)
    if limit <= 0 or len(cloud) <= limit:
        return cloud, {}
    cloud = drop_nonfinite(cloud)
    n = len(cloud)
    if n <= limit:
        return cloud, {}
    keep = np.random.default_rng(0).random(n) < limit / n
    log.info("%s: %d points thinned to %d at random", cloud.source or "cloud", n, int(keep.sum()))
    return cloud.subset(keep), {"points": n, "kept": int(keep.sum())}


def plausible_scanners(cloud: PointCloud, margin: float, box=None) -> tuple[PointCloud, int]:
    """``cloud`` without the scanner positions that lie more than ``margin`` outside its
    points' box (or ``box``, (lo, hi): the building's), not where it was scanned, and how many
    were dropped. Their points get no scanner (``scan_index`` -1); with none left, the cloud
    has no positions at all (the openings then use stand-ins, :mod:`engine.elements.viewpoints`)."""
    sp = cloud.scanner_positions
    if sp is None or len(sp) == 0 or len(cloud) == 0:
        return cloud, 0
    lo, hi = (column_min(cloud.xyz), column_max(cloud.xyz)) if box is None else box
    lo, hi = np.asarray(lo) - margin, np.asarray(hi) + margin
    ok = np.isfinite(sp).all(axis=1) & (sp >= lo).all(axis=1) & (sp <= hi).all(axis=1)
    bad = int((~ok & np.isfinite(sp).all(axis=1)).sum())
    if bad == 0:
        return cloud, 0
    log.warning("%s: %d of %d scanner positions lie outside the scan's points (by more than %.1f m) and "
                "are ignored", cloud.source or "cloud", bad, len(sp), margin)
    if not ok.any() or len(sp) == 1 or cloud.scan_index is None:
        return cloud.with_(scanner_positions=None, scan_index=None), bad
    si = np.asarray(cloud.scan_index)
    out = np.where((si >= 0) & (si < len(sp)), si, -1)
    out[(out >= 0) & ~ok[np.clip(out, 0, len(sp) - 1)]] = -1
    sp = np.where(ok[:, None], sp, np.nan)
    return cloud.with_(scanner_positions=sp, scan_index=out.astype(np.int32)), bad


def full_cloud_normals(cloud: PointCloud, params: PreprocessParams = PreprocessParams(),
                       spacing: Optional[float] = None, tree=None, voxel: float = 0.0,
                       voxels=None) -> PointCloud:
    """``cloud`` with PCA normals of every point (the Manhattan grammar reads them), over at
    least ``normals.radius_spacings`` point spacings (far walls of a terrestrial scan are
    sparse); unchanged when it has normals. ``tree``: a k-d tree of ``cloud.xyz`` to share.
    ``voxel``: the working cloud's voxel (:func:`engine.segmentation.cleaning.clean`), whose
    points share one normal, estimated over their neighbourhood in the full cloud (0: one
    per point); ``voxels``: that grid's voxels of ``cloud`` when known
    (:class:`Cleaned`)."""
    if cloud.normals is not None:
        return cloud
    npar = params.normals
    spacing = estimate_spacing(cloud.xyz, tree=tree) if spacing is None else spacing
    return estimate_normals(cloud, replace(npar, radius=max(npar.radius, npar.radius_spacings * spacing)),
                            tree=tree, share=voxel, voxels=voxels)


def manhattan_score(planes, angle_tolerance: float = ChoiceParams.angle_tolerance) -> float:
    """Share of wall-plane area (weighted by covered area) within ``angle_tolerance`` of the
    best pair of perpendicular horizontal directions; 0 without wall planes.

    Directions are folded modulo 90°; the pair's direction is the one (among the centres of
    a 0.5° histogram and the walls' own directions) with the most wall area within the
    tolerance. (A peak of the histogram smoothed over the tolerance alone is not enough: when
    every wall falls into one bin the smoothed histogram is a plateau 2·tolerance wide, and
    its first maximum lies a tolerance plus half a bin away from the walls, so that a clean
    scene rotated by 30° scored 0.)
    """
    walls = [p for p in planes if p.kind == "wall"]
    if not walls:
        return 0.0
    phi = np.array([math.atan2(p.normal[1], p.normal[0]) for p in walls]) % (math.pi / 2)
    w = np.array([max(p.area, 0.0) for p in walls])
    if w.sum() <= 0:
        return 0.0
    bins = 180
    cand = np.concatenate([(np.arange(bins) + 0.5) * (math.pi / 2) / bins, phi])
    dev = np.abs((phi[None, :] - cand[:, None] + math.pi / 4) % (math.pi / 2) - math.pi / 4)
    return float(((dev <= angle_tolerance) * w).sum(axis=1).max() / w.sum())


def choose_method(prep: Prepared, params: ChoiceParams = ChoiceParams()) -> tuple[str, float]:
    """("manhattan" or "generic", score) for ``--method auto`` from ``prep.planes``."""
    score = manhattan_score(prep.planes, params.angle_tolerance)
    method = "manhattan" if score >= params.manhattan_threshold else "generic"
    log.info("auto method: Manhattan score %.2f (threshold %.2f) -> %s", score, params.manhattan_threshold, method)
    return method, score
