"""Change-detection outputs.

Files written by :func:`write_change_outputs` into ``out_dir`` (each atomically):

* ``classified_points.ply`` — the scan points in the scan's own frame with scalar fields
  ``type`` (uint8: 0 existing, 1 new, 2 unclassified: the registration failed, 3 outside
  the model's plan),
  ``distance`` (float32 metres to the closest model surface, -1 when none within the
  search distance), ``cluster`` (int32 candidate element, -1 none), ``surface`` (int32
  index into coverage/classification surfaces, -1 none) and colours (existing grey-blue,
  new red, unclassified grey, outside light green);
* ``coverage.json`` — the registration status and one row per room face: key, shape,
  kind, area, coverage, redundant;
* ``surfaces_coverage.ply`` — the room faces (model frame) coloured by coverage;
* ``summary.json`` — counts, registration (status "registered"/"unregistered", fitness,
  rmse, transform, residual), redundant faces, candidate new elements, statuses, new walls;
* ``elements.json`` — the status per model element (GlobalId, name, IFC class, status,
  coverage, share proven absent, face polygons in model coordinates), the redundant room faces
  with the GlobalId of the element behind them and their 3D polygon, and the new walls (axis,
  thickness, heights, GlobalId in changes.ifc);
* with the model given and changes claimed: ``changes.ifc`` (new IfcWall/IfcDoor and the
  removed elements, property set ``Indoor_Change``), ``changes.bcf`` (one topic per change,
  when the BCF writer is available) and, with ``update``, ``as_built.ifc`` (the model as built,
  :func:`.update.as_built_model`).
"""
from __future__ import annotations

import json
import os
from typing import Optional

import numpy as np

from ..fileutil import atomic_write_text
from ..evaluation.report import write_patch_mesh, write_ply_arrays
from .detect import EXISTING, NEW, OUTSIDE, ChangeResult

__all__ = ["write_change_outputs", "bcf_topics", "elements_table"]

EXISTING_RGB = (120, 150, 200)
NEW_RGB = (230, 40, 30)
UNCLASSIFIED_RGB = (160, 160, 160)
OUTSIDE_RGB = (170, 210, 160)


def bcf_topics(model, result: ChangeResult, new_gids: dict) -> list[dict]:
    """One BCF topic per change: each element not installed or incomplete, each new wall."""
    topics = []
    for e in result.element_status:
        # a door or window goes with its wall's topic, unless the wall closes across it
        if e["status"] not in ("not installed", "incomplete") or (e["type"] in ("door", "window")
                                                                  and not e.get("walled_up")):
            continue
        if e.get("walled_up"):
            why = (f"the wall goes on across it: both faces covered by points in the wall's planes "
                   f"(coverage {100 * min(f['coverage'] for f in e['faces']):.0f} % or more).")
        else:
            why = (f"coverage {100 * e['coverage']:.0f} %, proven absent on {100 * e['absent']:.0f} % "
                   f"({e['evidence']}).")
        topics.append({"title": f"{e['ifc_class']} {e['name'] or e['id']}: {e['status']}",
                       "description": f"{e['ifc_class']} {e['name'] or e['id']} ({e['global_id']}) is {e['status']} "
                                      f"in the scan: {why}",
                       "status": e["status"], "guid": e["global_id"], "ifc_class": e["ifc_class"],
                       "center": tuple(e["center"]), "bbox": tuple(tuple(b) for b in e["bbox"])})
    for w in result.new_walls:
        b = w["shape"].geometry.bounds
        topics.append({"title": f"IfcWall {w['name']}: new",
                       "description": f"New wall {w['name']}: {w['length']:.2f} m long, {100 * w['thickness']:.1f} cm "
                                      f"thick, fitted to the new points of the scan (see changes.ifc).",
                       "status": "new", "guid": new_gids.get(w["id"]), "ifc_class": "IfcWall",
                       "center": tuple(((b[0] + b[1]) / 2).tolist()), "bbox": (tuple(b[0].tolist()), tuple(b[1].tolist()))})
    return topics


def elements_table(result: ChangeResult, model=None, new_gids: Optional[dict] = None) -> dict:
    """The JSON of ``elements.json``."""
    new_gids = new_gids or {}
    rows = result.coverage_table(model)
    return {
        "registration_status": result.registration.status, "classified": result.classified,
        "frame": "model coordinates (metres; IFC file coordinates = model transform and offset applied)",
        "elements": result.element_status,
        "redundant_surfaces": [{k: r[k] for k in ("key", "shape_id", "name", "kind", "area_m2", "coverage",
                                                  "polygon", "element_id", "element_global_id")}
                               for r in rows if r["redundant"]],
        "new_walls": [dict({k: v for k, v in w.items() if k != "shape"}, global_id=new_gids.get(w["id"]),
                           status="new") for w in result.new_walls],
        "new_openings": [{"id": d.id, "parent": d.parent, "type": d.type.value, "global_id": new_gids.get(d.id),
                          "width": d.attributes.get("width"), "height": d.attributes.get("height"),
                          "bbox": d.geometry.bounds.tolist()} for d in result.new_openings],
    }


def write_change_outputs(result: ChangeResult, cloud, out_dir, *, extra: Optional[dict] = None, model=None,
                         update: bool = False) -> dict:
    """Write the change-detection files; returns name → path.

    ``cloud`` : the scan (PointCloud or (n, 3) array) the result was computed on.
    ``model`` : the model it was compared with (for changes.ifc, changes.bcf, as_built.ifc and
    the GlobalIds); ``update`` : also write ``as_built.ifc``.
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
    col[result.point_type == OUTSIDE] = OUTSIDE_RGB
    dist = np.where(np.isfinite(result.distance), result.distance, -1.0).astype(np.float32)
    write_ply_arrays(paths["points_ply"], {
        "x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2],
        "red": col[:, 0], "green": col[:, 1], "blue": col[:, 2],
        "type": result.point_type.astype(np.uint8), "distance": dist,
        "cluster": result.cluster.astype(np.int32), "surface": result.surface.astype(np.int32)})
    rows = result.coverage_table(model)
    atomic_write_text(paths["coverage_json"], json.dumps({
        "registration_status": result.registration.status, "classified": result.classified,
        "alpha_radius_m": result.params.alpha_radius,
        "redundant_threshold": result.params.redundant_threshold,
        "surfaces": rows}, indent=2))
    write_patch_mesh(paths["coverage_ply"], result.coverage_patches, result.coverage, name="coverage")
    summary = result.summary()
    if extra:
        summary.update(extra)
    new_gids = {}
    changed = result.classified and (result.new_walls or any(
        e["status"] in ("not installed", "incomplete") for e in result.element_status))
    if model is not None and changed:
        from .update import write_as_built_ifc, write_changes_ifc
        path, new_gids = write_changes_ifc(model, result, os.path.join(out_dir, "changes.ifc"))
        if path:
            paths["changes_ifc"] = path
        try:
            from .bcf import write_bcf
        except ImportError:
            write_bcf = None
        topics = bcf_topics(model, result, new_gids)
        if write_bcf is not None and topics:
            paths["changes_bcf"] = write_bcf(os.path.join(out_dir, "changes.bcf"), topics,
                                             project_name=model.name or "model")
        if update:
            paths["as_built_ifc"] = write_as_built_ifc(model, result, os.path.join(out_dir, "as_built.ifc"))
    elif model is not None and update and result.classified:
        from .update import write_as_built_ifc
        paths["as_built_ifc"] = write_as_built_ifc(model, result, os.path.join(out_dir, "as_built.ifc"))
    paths["elements_json"] = os.path.join(out_dir, "elements.json")
    atomic_write_text(paths["elements_json"], json.dumps(elements_table(result, model, new_gids), indent=2))
    summary["outputs"] = {k: os.path.basename(v) for k, v in paths.items() if k != "summary_json"}
    atomic_write_text(paths["summary_json"], json.dumps(summary, indent=2))
    return paths
