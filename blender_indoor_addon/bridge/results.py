"""Result views: a change detection and an evaluation shown on the scan and the model.

Each view writes the result into Blender data (POINT attributes, colour attributes,
coloured patch objects, a packed image) and returns a JSON-ready summary; the operators
keep that summary in the scene settings for the panels.
"""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ...engine.geometry.transforms import frame_transform
from .collections import clear_collection, ensure_collection
from .overlays import patches_to_objects, ramp
from .points import is_point_mesh, set_display, write_attribute
from .shapes import SHAPE_PROP, _shape_object, model_matrix, model_objects

__all__ = ["CHANGES_COLLECTION", "NEW_ELEMENTS_COLLECTION", "STATUS_PROP", "STATUS_COLORS", "status_overlay",
           "objects_with_status", "EVALUATION_COLLECTION", "CHANGE_TYPE", "CHANGE_DISTANCE",
           "CHANGE_TYPE_COLOR", "CHANGE_DISTANCE_COLOR", "CHANGE_MATERIAL", "TYPE_COLORS_CHANGE",
           "DISTANCE_RAMP", "NO_SURFACE_COLOR", "EVALUATION_IMAGE", "change_material", "set_change_colors",
           "changed_scans", "change_overlay", "evaluation_overlay"]

CHANGES_COLLECTION = "Changes"
"""Collection of the room faces coloured by coverage (change detection)."""
NEW_ELEMENTS_COLLECTION = "New elements"
"""Collection of the walls (and their doors) fitted to a newer scan's new points."""
STATUS_PROP = "indoor_change_status"
"""Object property: the element's status against the newer scan (installed, incomplete, not
installed, no data; "new" for the fitted walls)."""
STATUS_COLORS = {"installed": (0.20, 0.66, 0.30, 1.0), "incomplete": (0.95, 0.65, 0.10, 1.0),
                 "not installed": (0.90, 0.12, 0.10, 1.0), "no data": (0.55, 0.55, 0.58, 1.0),
                 "new": (0.15, 0.45, 0.95, 1.0)}
"""Object colour (RGBA; Workbench "Object" colour) of each status, as the panel's legend lists them."""
EVALUATION_COLLECTION = "Evaluation"
"""Collection of the reference / source surfaces coloured by the evaluation."""
CHANGE_TYPE = "change_type"
"""INT POINT attribute: 0 existing, 1 new (engine.change.EXISTING / NEW)."""
CHANGE_DISTANCE = "change_distance"
"""FLOAT POINT attribute: distance to the closest model surface, metres (inf when none)."""
CHANGE_TYPE_COLOR = "change_type_color"
"""BYTE_COLOR POINT attribute: existing grey / new red."""
CHANGE_DISTANCE_COLOR = "change_distance_color"
"""BYTE_COLOR POINT attribute: distance on :data:`DISTANCE_RAMP` (0 → 2 r), grey when none."""
CHANGE_MATERIAL = "Indoor Changes"
"""Material of a scan showing its change colours (reads one of the two colour attributes)."""
TYPE_COLORS_CHANGE = {0: (0.55, 0.55, 0.58), 1: (0.90, 0.12, 0.10), 2: (0.30, 0.30, 0.30), 3: (0.67, 0.82, 0.63)}
"""sRGB colours of existing (0), new (1), unclassified (2: the scan is unregistered) and outside
(3: beyond the model's plan, seen through windows) points."""
DISTANCE_RAMP = ((0.0, (0.15, 0.35, 0.85)), (0.5, (0.95, 0.85, 0.20)), (1.0, (0.90, 0.12, 0.10)))
"""(position 0–1 of [0, 2 r], sRGB) stops of the distance colours: blue 0 → yellow r → red ≥ 2 r."""
NO_SURFACE_COLOR = (0.35, 0.35, 0.35)
"""sRGB colour of points with no model surface within the search distance."""


def _byte_color(mesh, name, rgb):
    rgba = np.ones((len(rgb), 4), dtype=np.float32)
    rgba[:, :3] = rgb
    attr = write_attribute(mesh, name, "BYTE_COLOR")
    attr.data.foreach_set("color_srgb", rgba.ravel())
    return attr


def change_material(color_attribute: str):
    """The material showing a scan's change colours; its Attribute node reads ``color_attribute``."""
    mat = bpy.data.materials.get(CHANGE_MATERIAL)
    if mat is None or mat.library is not None:
        mat = bpy.data.materials.new(CHANGE_MATERIAL)
        mat.use_nodes = True
        nt = mat.node_tree
        bsdf = nt.nodes.get("Principled BSDF")
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.name = "Change colour"
        attr.attribute_type = "GEOMETRY"
        attr.location = (-300, 200)
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Emission Color"])
        bsdf.inputs["Emission Strength"].default_value = 0.5
        bsdf.inputs["Roughness"].default_value = 1.0
    mat.node_tree.nodes["Change colour"].attribute_name = color_attribute
    return mat


def set_change_colors(obj, mode: str = "TYPE") -> None:
    """Show a scan's change colours: ``mode`` "TYPE" (existing grey / new red) or "DISTANCE"."""
    name = CHANGE_TYPE_COLOR if mode == "TYPE" else CHANGE_DISTANCE_COLOR
    mesh = obj.data
    attr = mesh.color_attributes.get(name)
    if attr is None:
        raise ValueError(f"{obj.name} has no change colours: run Detect changes first")
    mesh.color_attributes.active_color = attr
    mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
    mat = change_material(name)
    if is_point_mesh(obj):
        set_display(obj, material=mat)
    obj.update_tag()


def changed_scans() -> list:
    """Objects whose mesh carries change colours (:func:`change_overlay` ran on them)."""
    return [o for o in bpy.data.objects if o.type == "MESH" and o.data is not None
            and o.data.color_attributes.get(CHANGE_TYPE_COLOR) is not None]


def change_overlay(obj, result, model, *, mode: str = "TYPE", scene=None) -> dict:
    """Show a :class:`~engine.change.ChangeResult` on the scan ``obj`` and the model.

    The scan's point mesh gets POINT attributes :data:`CHANGE_TYPE` (INT 0/1, 2 when the
    scan is unregistered),
    :data:`CHANGE_DISTANCE` (FLOAT metres, inf when no surface) and the two colour
    attributes; its points are drawn with :data:`CHANGE_MATERIAL`. The room faces with a
    coverage value become objects of the "Changes" collection (FACE attribute and
    property ``coverage``, redundant ones flagged, coloured red → green). Returns a
    JSON-ready summary (the panel's ``scene.indoor.change_summary``).
    """
    scene = scene or bpy.context.scene
    mesh = obj.data
    n = len(mesh.vertices)
    if len(result.point_type) != n:
        raise ValueError(f"{obj.name} has {n} points but the change result has {len(result.point_type)}")
    t = write_attribute(mesh, CHANGE_TYPE, "INT")
    t.data.foreach_set("value", result.point_type.astype(np.int32))
    d = write_attribute(mesh, CHANGE_DISTANCE, "FLOAT")
    d.data.foreach_set("value", result.distance.astype(np.float32))
    cols = np.array([TYPE_COLORS_CHANGE[k] for k in sorted(TYPE_COLORS_CHANGE)], dtype=np.float32)
    _byte_color(mesh, CHANGE_TYPE_COLOR, cols[np.clip(result.point_type, 0, len(cols) - 1)])
    r = float(result.distance_threshold)
    dcol = ramp(np.clip(result.distance / (2 * r), 0.0, 1.0), DISTANCE_RAMP)
    dcol[~np.isfinite(result.distance)] = NO_SURFACE_COLOR
    _byte_color(mesh, CHANGE_DISTANCE_COLOR, dcol.astype(np.float32))
    mesh.update()
    set_change_colors(obj, mode)
    clear_collection(CHANGES_COLLECTION, scene)
    patches_to_objects(result.coverage_patches, result.coverage, collection=CHANGES_COLLECTION,
                       attribute="coverage", flagged=result.redundant, matrix=model_matrix(model),
                       prefix="Coverage ", scene=scene)
    statuses, topics = status_overlay(result, model, scene=scene)
    s = result.summary()
    summary = {"statuses": statuses, "topics": topics, "scan": obj.name, "points": s["points"], "existing": s["existing"], "new": s["new"],
               "new_share": s["new_share"], "distance_threshold_m": s["distance_threshold_m"],
               "surfaces": s["surfaces"], "redundant": s["redundant"], "new_elements": s["new_elements"],
               "new_walls": s["new_walls"], "fitness": s["registration"].get("fitness"),
               "rmse_m": s["registration"].get("rmse_point_to_plane_m")}
    return summary


def status_overlay(result, model, *, scene=None) -> tuple[dict, list]:
    """Colour the model's walls, slabs, doors and windows by their status against the newer
    scan (:data:`STATUS_COLORS`, property :data:`STATUS_PROP` and ``indoor_change_coverage``),
    and add the walls fitted to the new points (with their doors) to the "New elements"
    collection, status "new".

    Returns ``(counts per status, topics)``: the topics are the BCF topics ``indoor changes``
    writes (one per change, :func:`engine.change.report.bcf_topics`), each with the name of the
    Blender object it is about (``object``; None when the model has no object for it).
    """
    from ...engine.change.report import bcf_topics

    scene = scene or bpy.context.scene
    by_id = {str(o[SHAPE_PROP]): o for o in model_objects(scene)}
    counts = {k: 0 for k in STATUS_COLORS}
    obj_of_gid = {}
    for e in result.element_status:
        counts[e["status"]] = counts.get(e["status"], 0) + 1
        o = by_id.get(str(e["id"]))
        if o is None:
            continue
        o[STATUS_PROP] = e["status"]
        o["indoor_change_coverage"] = float(e["coverage"])
        o.color = STATUS_COLORS.get(e["status"], STATUS_COLORS["no data"])
        obj_of_gid[e["global_id"]] = o.name
    clear_collection(NEW_ELEMENTS_COLLECTION, scene)
    new_objects = {}
    if result.new_walls or result.new_openings:
        coll = ensure_collection(NEW_ELEMENTS_COLLECTION, scene)
        matrix = model_matrix(model)
        for shape in [w["shape"] for w in result.new_walls] + list(result.new_openings):
            o = _shape_object(shape, matrix)
            o[STATUS_PROP] = "new"
            o.color = STATUS_COLORS["new"]
            coll.objects.link(o)
            new_objects[shape.id] = o.name
        counts["new"] = len(result.new_walls)
    topics = []
    for t in bcf_topics(model, result, {}):
        name = obj_of_gid.get(t["guid"]) if t["guid"] else None
        if t["status"] == "new":
            wid = next((w["id"] for w in result.new_walls if t["title"].startswith(f"IfcWall {w['name']}:")), None)
            name = new_objects.get(wid)
        topics.append({"title": t["title"], "status": t["status"], "guid": t["guid"], "object": name})
    return counts, topics


def objects_with_status(status: str, scene=None) -> list:
    """The model's and the new elements' objects whose change status is ``status``."""
    scene = scene or bpy.context.scene
    return [o for o in scene.objects if o.get(STATUS_PROP) == status]


# --------------------------------------------------------------------------- evaluation
EVALUATION_IMAGE = "Indoor Evaluation Curves"
"""Image datablock of the evaluation curves (packed into the .blend)."""


def evaluation_overlay(result, reference, model, png_path: str, *, scene=None) -> dict:
    """Show an :class:`~engine.evaluation.EvaluationResult` in the scene.

    ``png_path`` (the curves written by ``write_evaluation_outputs``) is loaded and packed
    as the image :data:`EVALUATION_IMAGE`. The "Evaluation" collection gets the visible
    reference surfaces coloured by their covered share (missing ones flagged) and the
    source surfaces coloured by their overlap share (redundant ones flagged), at the
    localisation buffer; both in the reference's frame placed on the scene (offsets
    accounted for). Returns a JSON-ready summary (the panel's ``scene.indoor.eval_summary``).
    """
    scene = scene or bpy.context.scene
    old = bpy.data.images.get(EVALUATION_IMAGE)
    img = bpy.data.images.load(png_path, check_existing=False)
    img.pack()
    if old is not None:
        bpy.data.images.remove(old)
    img.name = EVALUATION_IMAGE
    try:
        img.preview_ensure()
    except (AttributeError, RuntimeError):  # no preview system (headless)
        pass
    li = result.localisation_index
    # the reference's frame → the scene's (the scan's frame, the model's offset removed)
    matrix = Matrix(frame_transform(reference.transform, reference.offset, np.eye(4), model.offset).tolist())
    clear_collection(EVALUATION_COLLECTION, scene)
    ref = [p for p, v in zip(result.reference, result.visible) if v]
    ref_cov = result.reference_covered[np.asarray(result.visible, dtype=bool), li]
    patches_to_objects(ref, ref_cov, collection=EVALUATION_COLLECTION, attribute="covered",
                       flagged=result.missing, matrix=matrix, prefix="Reference ", scene=scene)
    src_cov = result.source_covered[:, li] if len(result.source) else np.zeros(0)
    patches_to_objects(result.source, src_cov, collection=EVALUATION_COLLECTION, attribute="covered",
                       flagged=result.redundant, matrix=matrix, prefix="Source ", scene=scene)
    b = float(result.buffers[li])

    def at(metric):
        v = float(result.curves["all"][metric][li])
        return v if np.isfinite(v) else None

    summary = {"buffer_m": b, "completeness": at("completeness"), "correctness": at("correctness"),
               "accuracy_m": at("accuracy"), "missing": list(result.missing),
               "redundant": list(result.redundant), "reference_surfaces": len(ref),
               "source_surfaces": len(result.source), "image": img.name}
    return summary
