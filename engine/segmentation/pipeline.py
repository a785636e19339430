"""The whole preprocessing and space partitioning in one call (SPEC.md §1, §3.1)."""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from ..pointcloud import PointCloud
from ..progress import Progress
from .alignment import AlignmentResult, align_manhattan
from .cells import CellComplex, decompose_cells
from .classify import classify_points
from .cleaning import clean, drop_nonfinite, estimate_normals
from .params import PreprocessParams
from .planes import extract_planes
from .storeys import detect_storeys

__all__ = ["Preprocessed", "preprocess"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class Preprocessed:
    """Everything :func:`preprocess` produced.

    Attributes
    ----------
    cloud : PointCloud
        The full input cloud (non-finite rows dropped) **in the aligned frame** — keep it for
        evaluation and display.
    working : PointCloud
        The cleaned, downsampled working cloud in the aligned frame, with normals and
        ``fields["segment_class"]`` (int8, see :func:`classify_points`) and
        ``fields["plane"]`` (int32 plane id, -1 for none).
    source_index : (m,) int64
        Index of each working point in ``cloud``.
    transform : (4, 4) float64
        Aligned → input frame (put it in ``BuildingModel.transform``).
    alignment : AlignmentResult
    storeys : list of Storey
    labels : (m,) int8
        Point clusters of the working cloud.
    planes : list of Plane
    cells : CellComplex or None
    timings : dict of str -> float
        Seconds per step.
    """

    cloud: PointCloud
    working: PointCloud
    source_index: np.ndarray
    transform: np.ndarray
    alignment: AlignmentResult
    storeys: list
    labels: np.ndarray
    planes: list = field(default_factory=list)
    cells: Optional[CellComplex] = None
    timings: dict = field(default_factory=dict)

    def to_full(self, values: np.ndarray) -> np.ndarray:
        """Carry a per-working-point array (m, ...) onto every point of ``cloud`` (n, ...)
        through each point's nearest working point (e.g. ``working.fields["plane"]`` to
        colour the full cloud by plane). Costs one k-d tree query of the full cloud."""
        from scipy.spatial import cKDTree

        values = np.asarray(values)
        if len(values) != len(self.working):
            raise ValueError(f"expected {len(self.working)} values (one per working point), got {len(values)}")
        _, nn = cKDTree(self.working.xyz).query(self.cloud.xyz, k=1, workers=-1)
        return values[nn]


def preprocess(cloud: PointCloud, params: PreprocessParams = PreprocessParams(), *, rng=0,
               progress=None, should_stop=None) -> Preprocessed:
    """Clean, normals, alignment, storeys, point clusters, planes and cells.

    Parameters
    ----------
    cloud : PointCloud
        Input cloud, metres, z roughly up.
    params : PreprocessParams
    rng : numpy Generator, int or None
        Seeds the alignment sampling and RANSAC: same seed, same result.
    progress, should_stop : callables, see :class:`engine.progress.Progress`.

    Returns
    -------
    Preprocessed

    Raises
    ------
    EmptyCloudError
        Too few usable points.
    ReconstructionError
        No vertical structure, no storey (floor with a ceiling above), no wall plane.
    """
    rng = np.random.default_rng(rng)
    p = Progress.wrap(progress, should_stop)
    t = {}
    t0 = time.perf_counter()

    def lap(key):
        nonlocal t0
        now = time.perf_counter()
        t[key] = now - t0
        t0 = now

    p(0.0, "cleaning")
    full = drop_nonfinite(cloud)
    work, src, voxel = clean(full, params.clean, progress=p.sub(0.0, 0.1))
    lap("clean")
    p(0.1, "normals")
    nparams = replace(params.normals, radius=max(params.normals.radius, params.normals.radius_voxels * voxel))
    work = estimate_normals(work, nparams, progress=p.sub(0.1, 0.25))
    lap("normals")
    p(0.25, "alignment")
    aligned, transform, res = align_manhattan(work, params.align, rng=rng, normal_params=nparams,
                                              yaw=params.align_manhattan, return_result=True,
                                              progress=p.sub(0.25, 0.3))
    m = np.linalg.inv(transform)
    full_aligned = full.transformed(m)
    lap("align")
    p(0.3, "storeys")
    storeys = detect_storeys(aligned, params.storeys, progress=p.sub(0.3, 0.35))
    labels = classify_points(aligned, params.classify)
    lap("storeys")
    planes, cells = [], None
    plane_of = np.full(len(aligned), -1, np.int32)
    if params.extract_planes:
        planes = extract_planes(aligned, params.planes, labels=labels, storeys=storeys, rng=rng,
                                progress=p.sub(0.35, 0.85))
        for pl in planes:
            plane_of[pl.support] = pl.id
        lap("planes")
        if params.decompose_cells:
            cells = decompose_cells(aligned, planes, storeys, params.cells, labels=labels,
                                    progress=p.sub(0.85, 1.0))
            lap("cells")
    fields = dict(aligned.fields)
    fields["segment_class"] = labels
    fields["plane"] = plane_of
    aligned = aligned.with_(fields=fields)
    p(1.0, "preprocessing done")
    log.info("preprocess %s: %s", cloud.source or "point cloud", {k: round(v, 2) for k, v in t.items()})
    return Preprocessed(cloud=full_aligned, working=aligned, source_index=src, transform=transform,
                        alignment=res, storeys=storeys, labels=labels, planes=planes, cells=cells, timings=t)
