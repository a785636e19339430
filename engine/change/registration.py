"""Registration of a scan to a model: a given coarse transform, then point-to-plane ICP, then
a quality check.

The model is turned into points sampled on its surfaces (with the surface normals) and the
scan (voxel-downsampled) is aligned to them by open3d's point-to-plane ICP, coarse to fine
(shrinking correspondence distances). Misregistration reads as change, so the result is
checked (docs/method.md §5): the *fitness* is the share of (voxel-subsampled) scan points
within ``fitness_distance`` of a model surface, the *wall fitness* the same share among the
points on vertical surfaces, and the registration is ``"unregistered"`` when either is below
its threshold (``min_fitness``, ``min_wall_fitness``). When no initial transform was given
and the check fails, a coarse start is tried before giving up: the scan is translated so
that its centroid, or the centre of its bounding box, meets the model's, and ICP runs again
from there (no search over rotations: a scan turned far from the model's frame needs an
initial transform).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError, MissingDependencyError
from ..evaluation.loading import transform_model
from ..evaluation.patches import patches_from_model, sample_patch_grid
from ..geometry.normals import knn_normals
from ..geometry.transforms import apply_rotation, apply_transform
from ..model import BuildingModel
from ..progress import Progress

__all__ = ["RegistrationParams", "RegistrationResult", "register", "transform_model",
           "model_points", "registration_quality", "pca_normals", "voxel_subsample", "REGISTERED",
           "UNREGISTERED"]

log = logging.getLogger(__name__)

REGISTERED = "registered"
"""Registration status: the scan fits the model (fitness at least ``min_fitness``)."""
UNREGISTERED = "unregistered"
"""Registration status: the scan does not fit the model; changes measured against it are void."""


@dataclass(frozen=True)
class RegistrationParams:
    """Parameters of :func:`register` (SI units)."""

    enabled: bool = True
    """Run ICP after the initial transform (False: use the initial transform as is; the
    quality check still runs)."""
    distances: tuple = (1.0, 0.5, 0.25, 0.15, 0.1)
    """Largest correspondence distance of each ICP stage, coarse to fine, metres (the
    last one should not be below ``model_spacing``: point-to-plane ICP pairs a scan point
    with the nearest model sample, which may be that far away on the same plane)."""
    max_iterations: int = 30
    """ICP iterations per stage."""
    voxel_size: float = 0.1
    """The scan is voxel-downsampled to this cell size for ICP and for the quality check,
    metres."""
    model_spacing: float = 0.1
    """Grid spacing of the points sampled on the model surfaces, metres."""
    surface_types: tuple = ("interior",)
    """Model shape types whose faces are sampled (the room faces the scanner sees)."""
    fitness_distance: float = 0.05
    """A scan point within this distance of a model surface is an inlier of the quality
    check, metres (:func:`detect_changes <engine.change.detect_changes>` uses an explicit
    change threshold r instead). Fixed rather than taken from the residual, which means
    nothing when the registration failed; several σ of terrestrial and of mobile scanner
    noise alike."""
    min_fitness: float = 0.5
    """Below this fitness the scan is *unregistered*: about half of a scan may lie off the
    old model (furniture, new or changed parts) before the check fails, while a scan in a
    wrong pose or of another building leaves most of its points off the model's surfaces."""
    min_wall_fitness: float = 0.4
    """Below this *wall fitness* (the fitness of the scan points on vertical surfaces,
    against the model's vertical surfaces) the scan is unregistered too: floors and
    ceilings match wherever two footprints overlap, walls only where the layouts agree.
    Lower than ``min_fitness`` because furniture fronts stand before the walls. Not caught
    by either: buildings that look alike and near-symmetric ones (a scan turned by a half
    turn; ICP from a coarse start can end in that pose)."""
    coarse_start: bool = True
    """When no initial transform is given and the check fails, retry ICP from a
    translation that aligns the scan's centroid / bounding-box centre with the model's."""
    quality_points: int = 100_000
    """At most this many voxel-subsampled scan points are used for the quality check
    (a fixed-seed random subset beyond)."""


@dataclass(frozen=True, eq=False)
class RegistrationResult:
    """Outcome of :func:`register`.

    Attributes
    ----------
    transform : (4, 4) float64
        Maps scan coordinates into the model frame (``p_model = T @ p_scan``).
    residual : float
        Median |point-to-plane distance| of the downsampled scan points to their nearest
        model sample within the last stage's correspondence distance, metres (robust to
        the changed parts; NaN when ICP did not run or no point has a sample that close).
        About 0.67 σ for Gaussian noise σ.
    fitness : float
        Share of the voxel-subsampled scan points within ``fitness_distance`` of a model
        surface, in [0, 1].
    stages : list of dict
        Per ICP stage of the kept attempt: distance, fitness, rmse (open3d's).
    rmse : float
        RMS point-to-plane distance of those inliers, metres (NaN when none).
    status : str
        :data:`REGISTERED`, or :data:`UNREGISTERED` when the fitness is below
        ``min_fitness`` or the wall fitness below ``min_wall_fitness``.
    fitness_distance : float
        Inlier distance of the check, metres.
    min_fitness : float
        The threshold the fitness was compared with.
    start : str
        Where the kept ICP attempt started: "initial" (the given or default transform),
        "centroid" or "bounding-box centre" (coarse starts).
    attempts : list of dict
        Every attempt: start, fitness, wall_fitness, rmse_m.
    wall_fitness : float
        Share of the subsampled scan points on vertical surfaces that lie within
        ``fitness_distance`` of a vertical model surface (NaN when there are none).
    min_wall_fitness : float
        The threshold the wall fitness was compared with.
    """

    transform: np.ndarray
    residual: float
    fitness: float
    stages: list = field(default_factory=list)
    rmse: float = float("nan")
    status: str = REGISTERED
    fitness_distance: float = float("nan")
    min_fitness: float = float("nan")
    start: str = "initial"
    attempts: list = field(default_factory=list)
    wall_fitness: float = float("nan")
    min_wall_fitness: float = float("nan")

    @property
    def registered(self) -> bool:
        """True when the status is :data:`REGISTERED`."""
        return self.status == REGISTERED

    def to_dict(self) -> dict:
        num = _num
        return {"status": self.status, "fitness": num(self.fitness), "rmse_m": num(self.rmse),
                "fitness_distance_m": num(self.fitness_distance), "min_fitness": num(self.min_fitness),
                "wall_fitness": num(self.wall_fitness), "min_wall_fitness": num(self.min_wall_fitness),
                "start": self.start, "transform": self.transform.tolist(),
                "residual_m": num(self.residual),
                "rmse_point_to_plane_m": num(self.rmse),  # same as rmse_m (older key)
                "attempts": list(self.attempts), "stages": list(self.stages)}


def _num(x) -> Optional[float]:
    """A float for JSON (None when missing or not finite)."""
    return None if x is None or not np.isfinite(x) else float(x)


def model_points(model: BuildingModel, spacing: float, types=("interior",)) -> tuple[np.ndarray, np.ndarray]:
    """Points on a grid on the model's faces: ``(points (n, 3) float64, normals (n, 3) float64)``."""
    pts, nrm = [], []
    for p in patches_from_model(model, types):
        xy = sample_patch_grid(p, spacing)
        pts.append(p.to3d(xy))
        nrm.append(np.broadcast_to(p.normal, (len(xy), 3)))
    if not pts:
        raise InputError(f"the model has no surfaces of types {types} to register against")
    return np.vstack(pts), np.vstack(nrm)


def voxel_subsample(xyz: np.ndarray, size: float, limit: Optional[int] = None, seed: int = 0) -> np.ndarray:
    """One scan point per occupied voxel (the first in the input order), then at most
    ``limit`` of them (a fixed-seed random subset); (m, 3) float64. Cost O(n log n)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if len(xyz) == 0:
        return xyz
    ijk = np.floor((xyz - xyz.min(axis=0)) / size).astype(np.int64)
    dims = ijk.max(axis=0) + 1
    if float(dims[0]) * float(dims[1]) * float(dims[2]) < 2.0 ** 62:  # one int64 key per voxel
        _, first = np.unique((ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2], return_index=True)
    else:
        _, first = np.unique(ijk, axis=0, return_index=True)
    sub = xyz[np.sort(first)]
    if limit is not None and len(sub) > limit:
        sub = sub[np.sort(np.random.default_rng(seed).choice(len(sub), int(limit), replace=False))]
    return sub


WALL_NORMAL_Z = 0.5
"""A unit normal with |z| at most this (within 30° of horizontal) belongs to a vertical surface."""


def pca_normals(xyz: np.ndarray, k: int = 8) -> np.ndarray:
    """(n, 3) unit normals of points from their ``k`` nearest neighbours (at least 3; PCA,
    sign arbitrary): :func:`engine.geometry.normals.knn_normals`."""
    return knn_normals(xyz, max(k, 3))


def registration_quality(tree, mp: np.ndarray, mn: np.ndarray, pts: np.ndarray, distance: float,
                         spacing: float, normals: Optional[np.ndarray] = None,
                         k: int = 8) -> tuple[float, float, float]:
    """Fitness, inlier RMSE and wall fitness of points against model samples.

    Parameters
    ----------
    tree : scipy.spatial.cKDTree
        Built on ``mp``.
    mp, mn : (m, 3) float64
        Model samples (grid of ``spacing`` metres on the surfaces) and their unit normals.
    pts : (n, 3) float64
        Scan points already in the model frame, metres.
    distance : float
        Inlier distance to a surface, metres.
    normals : (n, 3) float64, optional
        Unit normals of ``pts`` (model frame) for the wall fitness.

    Returns
    -------
    fitness : float
        Share of ``pts`` within ``distance`` of the plane of one of their ``k`` nearest
        samples, that sample lying within ``hypot(distance, spacing)`` (so the point is on
        or next to the sampled part of the surface).
    rmse : float
        RMS of the inliers' point-to-plane distances, metres (NaN without inliers).
    wall_fitness : float
        The same share among the points on vertical surfaces (normal |z| ≤
        :data:`WALL_NORMAL_Z`), counting vertical model surfaces only; NaN without normals
        or without such points. Floors and ceilings match wherever two footprints overlap,
        walls only when the layout does.
    """
    if len(pts) == 0:
        return 0.0, float("nan"), float("nan")
    k = int(min(k, len(mp)))
    dist, idx = tree.query(pts, k=k, distance_upper_bound=float(np.hypot(distance, spacing)))
    dist, idx = dist.reshape(len(pts), k), idx.reshape(len(pts), k)
    ok = np.isfinite(dist)
    idc = np.where(ok, idx, 0)
    plane = np.where(ok, np.abs(np.einsum("nkj,nkj->nk", pts[:, None, :] - mp[idc], mn[idc])), np.inf)
    best = plane.min(axis=1)
    inl = best <= distance
    fitness = float(inl.mean())
    rmse = float(np.sqrt(np.mean(best[inl] ** 2))) if inl.any() else float("nan")
    wall_fitness = float("nan")
    if normals is not None:
        wall = np.abs(np.asarray(normals)[:, 2]) <= WALL_NORMAL_Z
        if wall.any():
            vertical = np.abs(mn[idc[wall], 2]) <= WALL_NORMAL_Z
            wall_fitness = float(np.mean(np.where(vertical, plane[wall], np.inf).min(axis=1) <= distance))
    return fitness, rmse, wall_fitness


def _translation(shift) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = shift
    return m


def _icp(reg, source, target, t, params: RegistrationParams, p) -> tuple[np.ndarray, list]:
    """Coarse-to-fine point-to-plane ICP from ``t``; returns the transform and the stages."""
    coarse = {}
    stages = []
    for k, dist in enumerate(params.distances):
        p(k / len(params.distances), f"ICP {dist:.2f} m")
        # coarse stages work on a coarser copy of the scan (a quarter of the distance)
        vs = max(params.voxel_size, float(dist) / 4)
        if vs > params.voxel_size and vs not in coarse:
            coarse[vs] = source.voxel_down_sample(vs)
        src_k = coarse.get(vs, source)
        res = reg.registration_icp(
            src_k, target, float(dist), t, reg.TransformationEstimationPointToPlane(),
            reg.ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6,
                                       max_iteration=int(params.max_iterations)))
        if res.fitness > 0:
            t = np.asarray(res.transformation, dtype=np.float64).copy()
        stages.append({"distance_m": float(dist), "fitness": float(res.fitness),
                       "rmse_m": float(res.inlier_rmse)})
        log.debug("ICP stage %.2f m: fitness %.3f, rmse %.4f m", dist, res.fitness, res.inlier_rmse)
    return t, stages


def register(model: BuildingModel, xyz: np.ndarray, params: Optional[RegistrationParams] = None, *,
             initial: Optional[np.ndarray] = None, coarse_start: Optional[bool] = None,
             fitness_distance: Optional[float] = None, progress=None, should_stop=None) -> RegistrationResult:
    """Align scan points to a model and check the result.

    Parameters
    ----------
    model : BuildingModel
    xyz : (n, 3) float64
        Scan points, metres.
    initial : (4, 4) float64, optional
        Coarse scan → model transform (default identity).
    coarse_start : bool, optional
        Try the coarse starts (centroid, bounding-box centre) when the check fails
        (default: when ``initial`` is None and ``params.coarse_start``; never without ICP).
    fitness_distance : float, optional
        Inlier distance of the check, metres (default ``params.fitness_distance``).

    Returns
    -------
    RegistrationResult
        ``status`` tells whether the scan fits the model.
    """
    params = params or RegistrationParams()
    p = Progress.wrap(progress, should_stop)
    init = np.eye(4) if initial is None else np.asarray(initial, dtype=np.float64).reshape(4, 4)
    if coarse_start is None:
        coarse_start = initial is None and params.coarse_start
    fd = float(params.fitness_distance if fitness_distance is None else fitness_distance)
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    mp, mn = model_points(model, params.model_spacing, params.surface_types)
    tree = cKDTree(mp)
    check = voxel_subsample(xyz, params.voxel_size, params.quality_points)
    if len(check) < 3:
        raise InputError("too few scan points to register")

    check_normals = pca_normals(check)

    def finish(t, stages, start):
        fit, rmse, wall = registration_quality(tree, mp, mn, apply_transform(t, check), fd, params.model_spacing,
                                               apply_rotation(t, check_normals))
        ok = fit >= params.min_fitness and not wall < params.min_wall_fitness  # NaN: no wall points
        attempt = {"start": start, "fitness": fit, "wall_fitness": _num(wall), "rmse_m": _num(rmse)}
        return RegistrationResult(t, float("nan"), fit, stages, rmse, REGISTERED if ok else UNREGISTERED, fd,
                                  float(params.min_fitness), start, [attempt], wall,
                                  float(params.min_wall_fitness))

    if not params.enabled:
        res = finish(init, [], "initial")
        _log_status(res)
        return res
    try:
        import open3d as o3d
    except ImportError:
        raise MissingDependencyError("open3d", "ICP registration") from None
    reg = o3d.pipelines.registration
    target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(mp))
    target.normals = o3d.utility.Vector3dVector(mn)
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz)).voxel_down_sample(params.voxel_size)
    if len(source.points) < 3:
        raise InputError("too few scan points to register")

    t, stages = _icp(reg, source, target, init, params, p.sub(0.0, 0.9 if not coarse_start else 0.5))
    best = finish(t, stages, "initial")
    attempts = list(best.attempts)
    if not best.registered and coarse_start:
        # coarse starts: translations on top of the initial transform
        sub = apply_transform(init, check)
        lo, hi = np.percentile(sub, [1.0, 99.0], axis=0)  # robust to stray points
        starts = (("centroid", mp.mean(axis=0) - sub.mean(axis=0)),
                  ("bounding-box centre", 0.5 * (mp.min(axis=0) + mp.max(axis=0)) - 0.5 * (lo + hi)))
        for j, (name, shift) in enumerate(starts):
            t, stages = _icp(reg, source, target, _translation(shift) @ init, params,
                             p.sub(0.5 + 0.2 * j, 0.7 + 0.2 * j))
            cand = finish(t, stages, name)
            attempts += cand.attempts
            log.info("registration: coarse start from the %s (shift %.1f m): fitness %.3f", name,
                     float(np.linalg.norm(shift)), cand.fitness)
            if _score(cand) > _score(best):
                best = cand
            if best.registered:
                break
    p(0.95, "residual")
    sp = apply_transform(best.transform, np.asarray(source.points))
    dist, idx = tree.query(sp, distance_upper_bound=float(params.distances[-1]))
    ok = np.isfinite(dist)
    d = np.abs(np.einsum("ij,ij->i", sp[ok] - mp[idx[ok]], mn[idx[ok]]))
    residual = float(np.median(d)) if len(d) else float("nan")
    best = replace(best, residual=residual, attempts=attempts)
    p(1.0, "registered")
    _log_status(best)
    return best


def _score(res: RegistrationResult) -> tuple:
    """Order of attempts: registered first, then by the lower of fitness and wall fitness."""
    wall = res.wall_fitness if np.isfinite(res.wall_fitness) else res.fitness
    return res.registered, min(res.fitness, wall), res.fitness


def _log_status(res: RegistrationResult) -> None:
    if res.registered:
        log.info("registration: %s from the %s, fitness %.3f, wall fitness %.3f (within %.3f m), "
                 "rmse %.4f m, residual %.4f m", res.status, res.start, res.fitness, res.wall_fitness,
                 res.fitness_distance, res.rmse, res.residual)
    else:
        log.info("registration failed: fitness %.3f (at least %.2f needed), wall fitness %.3f (at least "
                 "%.2f), within %.3f m of the model", res.fitness, res.min_fitness, res.wall_fitness,
                 res.min_wall_fitness, res.fitness_distance)
