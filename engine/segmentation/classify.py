"""Point clusters by normal direction (docs/method.md §1 "Point clustering")."""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..pointcloud import PointCloud
from .params import ClassifyParams

__all__ = ["classify_points", "CLASS_WALL", "CLASS_HORIZONTAL", "CLASS_OTHER"]

CLASS_WALL = 0
"""Wall ("vertical") point: normal within θ of horizontal, |n_z| ≤ sin θ."""
CLASS_HORIZONTAL = 1
"""Floor/ceiling ("horizontal") point: normal within θ of vertical, |n_z| ≥ cos θ."""
CLASS_OTHER = 2
"""Clutter and noise: excluded from surface extraction."""


def classify_points(cloud: PointCloud, params: ClassifyParams = ClassifyParams()) -> np.ndarray:
    """Label each point wall / floor-ceiling / other from its normal.

    Parameters
    ----------
    cloud : PointCloud
        Aligned (z up) with ``normals`` (n, 3) float32.
    params : ClassifyParams

    Returns
    -------
    labels : (n,) int8 — :data:`CLASS_WALL`, :data:`CLASS_HORIZONTAL` or :data:`CLASS_OTHER`.

    Raises
    ------
    InputError
        The cloud has no normals (run :func:`estimate_normals` first).
    """
    if cloud.normals is None:
        raise InputError("classify_points needs normals; run estimate_normals first", cloud.source or None)
    nz = np.abs(cloud.normals[:, 2].astype(np.float64))
    labels = np.full(len(cloud), CLASS_OTHER, dtype=np.int8)
    labels[nz <= np.sin(params.angle_tolerance)] = CLASS_WALL
    labels[nz >= np.cos(params.angle_tolerance)] = CLASS_HORIZONTAL
    return labels
