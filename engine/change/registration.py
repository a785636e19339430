"""Registration of a scan to a model: a given coarse transform, then point-to-plane ICP.

The model is turned into points sampled on its surfaces (with the surface normals) and the
scan (voxel-downsampled) is aligned to them by open3d's point-to-plane ICP, coarse to fine
(shrinking correspondence distances). Misregistration reads as change, so the residual is
reported (SPEC.md §5).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..errors import InputError, MissingDependencyError
from ..model import BuildingModel
from ..progress import Progress
from ..evaluation.loading import frame_transform, transform_model
from ..evaluation.patches import patches_from_model, sample_patch_grid

__all__ = ["RegistrationParams", "RegistrationResult", "register", "transform_model", "frame_transform", "model_points"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RegistrationParams:
    """Parameters of :func:`register` (SI units)."""

    enabled: bool = True
    """Run ICP after the initial transform (False: use the initial transform as is)."""
    distances: tuple = (1.0, 0.5, 0.25, 0.15, 0.1)
    """Largest correspondence distance of each ICP stage, coarse to fine, metres (the
    last one should not be below ``model_spacing``: point-to-plane ICP pairs a scan point
    with the nearest model sample, which may be that far away on the same plane)."""
    max_iterations: int = 30
    """ICP iterations per stage."""
    voxel_size: float = 0.1
    """The scan is voxel-downsampled to this cell size for ICP, metres."""
    model_spacing: float = 0.1
    """Grid spacing of the points sampled on the model surfaces, metres."""
    surface_types: tuple = ("interior",)
    """Model shape types whose faces are sampled (the room faces the scanner sees)."""


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
        the changed parts; NaN when ICP did not run). About 0.67 σ for Gaussian noise σ.
    rmse : float
        RMS of the same point-to-plane distances, metres.
    fitness : float
        Share of downsampled scan points with a correspondence in the last stage.
    stages : list of dict
        Per stage: distance, fitness, rmse.
    """

    transform: np.ndarray
    residual: float
    fitness: float
    stages: list = field(default_factory=list)
    rmse: float = float("nan")

    def to_dict(self) -> dict:
        return {"transform": self.transform.tolist(),
                "residual_m": None if not np.isfinite(self.residual) else float(self.residual),
                "rmse_point_to_plane_m": None if not np.isfinite(self.rmse) else float(self.rmse),
                "fitness": float(self.fitness), "stages": list(self.stages)}


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


def register(model: BuildingModel, xyz: np.ndarray, params: Optional[RegistrationParams] = None, *,
             initial: Optional[np.ndarray] = None, progress=None, should_stop=None) -> RegistrationResult:
    """Align scan points to a model.

    Parameters
    ----------
    model : BuildingModel
    xyz : (n, 3) float64
        Scan points, metres.
    initial : (4, 4) float64, optional
        Coarse scan → model transform (default identity).

    Returns
    -------
    RegistrationResult
    """
    params = params or RegistrationParams()
    p = Progress.wrap(progress, should_stop)
    init = np.eye(4) if initial is None else np.asarray(initial, dtype=np.float64).reshape(4, 4)
    if not params.enabled:
        return RegistrationResult(init, float("nan"), float("nan"), [])
    try:
        import open3d as o3d
    except ImportError:
        raise MissingDependencyError("open3d", "ICP registration") from None
    reg = o3d.pipelines.registration
    mp, mn = model_points(model, params.model_spacing, params.surface_types)
    target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(mp))
    target.normals = o3d.utility.Vector3dVector(mn)
    full = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(xyz, dtype=np.float64)))
    source = full.voxel_down_sample(params.voxel_size)
    if len(source.points) < 3:
        raise InputError("too few scan points to register")
    coarse = {}
    t = init
    stages = []
    res = None
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
        stages.append({"distance_m": float(dist), "fitness": float(res.fitness), "rmse_m": float(res.inlier_rmse)})
        log.debug("ICP stage %.2f m: fitness %.3f, rmse %.4f m", dist, res.fitness, res.inlier_rmse)
    p(0.95, "residual")
    from scipy.spatial import cKDTree

    sp = np.asarray(source.points) @ t[:3, :3].T + t[:3, 3]
    dist, idx = cKDTree(mp).query(sp, distance_upper_bound=float(params.distances[-1]))
    ok = np.isfinite(dist)
    d = np.abs(np.einsum("ij,ij->i", sp[ok] - mp[idx[ok]], mn[idx[ok]]))
    residual = float(np.median(d)) if len(d) else float("nan")
    rmse = float(np.sqrt(np.mean(d ** 2))) if len(d) else float("nan")
    p(1.0, "registered")
    log.info("registration: residual %.4f m (median point-to-plane), fitness %.3f", residual, float(ok.mean()))
    return RegistrationResult(t, residual, float(ok.mean()), stages, rmse)
