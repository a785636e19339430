"""The one place that turns engine results into Blender data, and reads them back.

Operators call an engine function and hand its result to a function here; nothing else in
the add-on creates meshes, attributes, collections, node groups or materials. The bridge
builds and reads scene data only: scene settings (``scene.indoor``) are the operators'.

This index re-exports the public names of its modules:

* :mod:`.collections` — collections, removal, :func:`undo_on_failure` (what a failing
  call made is removed);
* :mod:`.points` — point meshes of scans: attributes, the "Indoor Points" display, back to
  a :class:`~engine.pointcloud.PointCloud`;
* :mod:`.shapes` — one object per shape of a model (collections by type, element colours),
  edits, the model ↔ scene frame;
* :mod:`.storage` — the stored model JSON and its edit history (text blocks);
* :mod:`.overlays` — graph and path curves, planar patches coloured by a value;
* :mod:`.results` — change detection and evaluation views.
"""
from __future__ import annotations

from . import collections, overlays, points, results, shapes, storage
from .collections import (DataSnapshot, clear_collection, ensure_collection, remove_object, remove_objects,
                          undo_on_failure)
from .points import (COUNT_PROP, HEIGHT_COLOR, HEIGHT_RAMP, IN_MATERIAL, IN_RADIUS, IN_RATIO, IN_SECTION_Z,
                     IN_SEED, IN_USE_SECTION, OFFSET_PROP, POINTS_MODIFIER, POINTS_NODE_GROUP,
                     SCAN_COLLECTION, SOURCE_PROP, add_height_colors, display_settings, input_identifier,
                     is_point_mesh, object_points, object_to_cloud, point_cloud_to_object, points_material,
                     points_node_group, set_display, write_attribute)
from .shapes import (CELLS_COLLECTION, MODEL_COLLECTION, SHAPE_PROP, STYLE_COLORS, STYLE_MATERIALS,
                     TYPE_COLLECTIONS, TYPE_COLORS, apply_edit, element_label, model_matrix, model_objects,
                     model_to_objects, restore_previous, shape_ids_of, shape_style, to_model_frame)
from .storage import (HISTORY_DEPTH, HISTORY_TEXT, MODEL_TEXT, drop_previous, history_length, previous_model,
                      push_history, stored_model, write_model_text)
from .overlays import (COVERAGE_RAMP, CURVE_BEVEL, FLAG_ALPHA, GRAPH_OBJECTS, OVERLAY_COLORS,
                       OVERLAY_MATERIAL, PATH_OBJECT, PLAIN_ALPHA, TOPOLOGY_COLLECTION, graph_shown,
                       graph_to_curve, overlay_material, patches_to_objects, path_to_curve,
                       polylines_to_curve, ramp, refresh_overlays, remove_graph, spline_points)
from .results import (NEW_ELEMENTS_COLLECTION, STATUS_COLORS, STATUS_PROP, objects_with_status, status_overlay,
                      CHANGES_COLLECTION, CHANGE_DISTANCE, CHANGE_DISTANCE_COLOR, CHANGE_MATERIAL,
                      CHANGE_TYPE, CHANGE_TYPE_COLOR, DISTANCE_RAMP, EVALUATION_COLLECTION, EVALUATION_IMAGE,
                      NO_SURFACE_COLOR, TYPE_COLORS_CHANGE, change_material, change_overlay, changed_scans,
                      evaluation_overlay, set_change_colors)

__all__ = [
    "collections", "overlays", "points", "results", "shapes", "storage", "ensure_collection",
    "NEW_ELEMENTS_COLLECTION", "STATUS_COLORS", "STATUS_PROP", "objects_with_status", "status_overlay",
    "clear_collection", "remove_object", "remove_objects", "DataSnapshot", "undo_on_failure",
    "SCAN_COLLECTION", "POINTS_NODE_GROUP", "POINTS_MODIFIER", "OFFSET_PROP", "SOURCE_PROP", "COUNT_PROP",
    "IN_RATIO", "IN_RADIUS", "IN_MATERIAL", "IN_SEED", "IN_USE_SECTION", "IN_SECTION_Z", "HEIGHT_COLOR",
    "HEIGHT_RAMP", "points_node_group", "points_material", "write_attribute", "point_cloud_to_object",
    "set_display", "display_settings", "input_identifier", "is_point_mesh", "object_points",
    "add_height_colors", "object_to_cloud", "MODEL_COLLECTION", "TYPE_COLLECTIONS", "CELLS_COLLECTION",
    "TYPE_COLORS", "STYLE_COLORS", "STYLE_MATERIALS", "SHAPE_PROP", "shape_style", "element_label",
    "model_objects", "model_to_objects", "apply_edit", "restore_previous",
    "shape_ids_of", "model_matrix", "to_model_frame", "MODEL_TEXT", "HISTORY_TEXT", "HISTORY_DEPTH",
    "write_model_text", "stored_model", "push_history", "history_length", "previous_model",
    "drop_previous", "TOPOLOGY_COLLECTION", "GRAPH_OBJECTS", "PATH_OBJECT", "OVERLAY_COLORS",
    "CURVE_BEVEL", "OVERLAY_MATERIAL", "COVERAGE_RAMP", "FLAG_ALPHA", "PLAIN_ALPHA", "overlay_material",
    "polylines_to_curve", "spline_points", "graph_to_curve", "remove_graph", "graph_shown",
    "path_to_curve", "refresh_overlays", "ramp", "patches_to_objects", "CHANGES_COLLECTION",
    "EVALUATION_COLLECTION", "CHANGE_TYPE", "CHANGE_DISTANCE", "CHANGE_TYPE_COLOR",
    "CHANGE_DISTANCE_COLOR", "CHANGE_MATERIAL", "TYPE_COLORS_CHANGE", "DISTANCE_RAMP", "NO_SURFACE_COLOR",
    "EVALUATION_IMAGE", "change_material", "set_change_colors", "changed_scans", "change_overlay",
    "evaluation_overlay",
]
