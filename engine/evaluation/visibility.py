"""Visible / interpreted reference surfaces, annotated from a scan (point-on-face index).

A reference surface is *visible* when the scan covers enough of it: the point-on-face index
of the surface — the area of the 2D alpha shape of the scan points lying on it divided by
its area — reaches a threshold. Other surfaces are *interpreted* (inferred, e.g. the hidden
side of an outer wall) and are left out of the comparison (docs/method.md §4).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..model import BuildingModel
from ..progress import Progress
from .coverage import alpha_area, patch_support
from .patches import patches_from_model

__all__ = ["VisibilityParams", "annotate_visibility"]


@dataclass(frozen=True)
class VisibilityParams:
    """Parameters of :func:`annotate_visibility` (SI units)."""

    max_distance: float = 0.05
    """A point lies on a surface when it is at most this far from its plane, metres."""
    alpha_radius: float = 0.2
    """r_α of the alpha shape measuring the covered area, metres."""
    min_point_on_face: float = 0.1
    """A surface is visible when its point-on-face index reaches this share."""
    surface_types: tuple = ("interior",)
    """Shape types whose faces are annotated."""
    max_normal_angle: Optional[float] = float(np.radians(30.0))
    """When the scan has normals, a point supports only surfaces within this angle,
    radians (None: ignore normals)."""


def annotate_visibility(reference, cloud, params: Optional[VisibilityParams] = None, *,
                        progress=None, should_stop=None) -> dict:
    """Point-on-face index and visibility of each reference surface.

    Parameters
    ----------
    reference : BuildingModel or list of PlanarPatch
        In the frame of the cloud.
    cloud : PointCloud or (n, 3) float64 array, metres.

    Returns
    -------
    dict key → {"point_on_face": float in [0, 1], "visible": bool}; pass it as
    ``visible={k: v["visible"] ...}`` to :func:`engine.evaluation.evaluate`.
    """
    params = params or VisibilityParams()
    p = Progress.wrap(progress, should_stop)
    patches = patches_from_model(reference, params.surface_types) if isinstance(reference, BuildingModel) \
        else list(reference)
    xyz = getattr(cloud, "xyz", cloud)
    normals = getattr(cloud, "normals", None)
    p(0.0, "points on surfaces")
    sup = patch_support(patches, xyz, params.max_distance, normals=normals,
                        max_normal_angle=params.max_normal_angle if normals is not None else None,
                        should_stop=should_stop)
    out = {}
    for j, pt in enumerate(patches):
        p(0.5 + 0.5 * j / max(len(patches), 1), "point-on-face index")
        idx = sup.members[j]
        pof = min(1.0, alpha_area(pt.to2d(np.asarray(xyz)[idx]), params.alpha_radius) / pt.area) if len(idx) else 0.0
        out[pt.key] = {"point_on_face": float(pof), "visible": bool(pof >= params.min_point_on_face)}
    p(1.0, "done")
    return out
