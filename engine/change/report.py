"""Change-detection outputs.

Files written by :func:`write_change_outputs` into ``out_dir`` (each atomically):

* ``classified_points.ply`` — the scan points in the scan's own frame with scalar fields
  ``type`` (uint8: 0 existing, 1 new, 2 unclassified: the registration failed),
  ``distance`` (float32 metres to the closest model surface, -1 when none within the
  search distance), ``cluster`` (int32 candidate element, -1 none), ``surface`` (int32
  index into coverage/classification surfaces, -1 none) and colours (existing grey-blue,
  new red, unclassified grey);
* ``coverage.json`` — the registration status and one row per room face: key, shape,
  kind, area, coverage, redundant;
* ``surfaces_coverage.ply`` — the room faces (model frame) coloured by coverage;
* ``summary.json`` — counts, registration (status "registered"/"unregistered", fitness,
  rmse, transform, residual), redundant faces, candidate new elements.
"""
from __future__ import annotations

import json
import os
from typing import Optional

import numpy as np

from ..fileutil import atomic_write_text
from ..evaluation.report import write_patch_mesh, write_ply_arrays
from .detect import EXISTING, NEW, ChangeResult

__all__ = ["write_change_outputs"]

EXISTING_RGB = (120, 150, 200)
NEW_RGB = (230, 40, 30)
UNCLASSIFIED_RGB = (160, 160, 160)


def write_change_outputs(result: ChangeResult, cloud, out_dir, *, extra: Optional[dict] = None) -> dict:
    """Write the change-detection files; returns name → path.

    ``cloud`` : the scan (PointCloud or (n, 3) array) the result was computed on.
    """
    out_dir = os.fspath(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    paths = {k: os.path.join(out_dir, f) for k, f in (
        ("points_ply", "classified_points.ply"), ("coverage_json", "coverage.json"),
        ("coverage_ply", "surfaces_coverage.ply"), ("summary_json", "summary.json"))}
    xyz = np.asarray(getattr(cloud, "xyz", cloud), dtype=np.float64)
    col = np.empty((len(result.point_type), 3), dtype=np.uint8)
    col[:] = UNCLASSIFIED_RGB
    col[result.point_type == EXISTING] = EXISTING_RGB
    col[result.point_type == NEW] = NEW_RGB
    dist = np.where(np.isfinite(result.distance), result.distance, -1.0).astype(np.float32)
    write_ply_arrays(paths["points_ply"], {
        "x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2],
        "red": col[:, 0], "green": col[:, 1], "blue": col[:, 2],
        "type": result.point_type.astype(np.uint8), "distance": dist,
        "cluster": result.cluster.astype(np.int32), "surface": result.surface.astype(np.int32)})
    rows = result.coverage_table()
    atomic_write_text(paths["coverage_json"], json.dumps({
        "registration_status": result.registration.status, "classified": result.classified,
        "alpha_radius_m": result.params.alpha_radius,
        "redundant_threshold": result.params.redundant_threshold,
        "surfaces": rows}, indent=2))
    write_patch_mesh(paths["coverage_ply"], result.coverage_patches, result.coverage, name="coverage")
    summary = result.summary()
    if extra:
        summary.update(extra)
    atomic_write_text(paths["summary_json"], json.dumps(summary, indent=2))
    return paths
