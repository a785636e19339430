"""Operators: read properties, call one engine function, hand the result to the bridge.

Every engine call runs inside :func:`.engine_call.engine_call`: any exception (an engine
error or a bug) becomes one line in ``self.report({'ERROR'}, ...)`` naming the file or
object and the kind of error (:func:`engine.errors.error_line`), never a traceback, and
``{'CANCELLED'}``; what the call created is removed, so the scene is left as it was.
Internal errors are logged with their traceback. Operators, not the bridge, write the
scene settings (``scene.indoor``) that the panels show.

This index re-exports the operators of its modules: :mod:`.scan` (Import scan, Export
IFC), :mod:`.reconstruction` (Reconstruct, Cancel, Load / Save parameters), :mod:`.review`
(Reclassify, Insert door, Revert, graphs, shortest path; their edits of models with building
elements are the engine's :mod:`engine.topology.elements`), :mod:`.analysis` (Detect changes, Evaluate).
"""
from __future__ import annotations

from . import analysis, common, engine_call, reconstruction, review, scan
from .analysis import INDOOR_OT_detect_changes, INDOOR_OT_evaluate, INDOOR_OT_select_by_status
from .engine_call import EngineCall, report_failure
from .reconstruction import (INDOOR_OT_cancel_reconstruct, INDOOR_OT_load_parameters, INDOOR_OT_reconstruct,
                             INDOOR_OT_save_parameters, reconstruct_params, running_job, scene_params,
                             stop_running_job)
from .review import (INDOOR_OT_insert_door, INDOOR_OT_reclassify, INDOOR_OT_revert_edit,
                     INDOOR_OT_shortest_path, INDOOR_OT_show_graph)
from .scan import (SCAN_EXTENSIONS, INDOOR_OT_export_ifc, INDOOR_OT_import_scan, bonsai_available,
                   menu_export, menu_import)

__all__ = ["analysis", "common", "engine_call", "reconstruction", "review", "scan", "EngineCall",
           "report_failure", "INDOOR_OT_import_scan", "INDOOR_OT_reconstruct", "INDOOR_OT_cancel_reconstruct",
           "INDOOR_OT_load_parameters", "INDOOR_OT_save_parameters", "INDOOR_OT_reclassify",
           "INDOOR_OT_insert_door", "INDOOR_OT_revert_edit", "INDOOR_OT_show_graph",
           "INDOOR_OT_shortest_path",
           "INDOOR_OT_detect_changes", "INDOOR_OT_select_by_status", "INDOOR_OT_evaluate", "INDOOR_OT_export_ifc", "SCAN_EXTENSIONS",
           "CLASSES", "menu_import", "menu_export", "bonsai_available", "running_job", "stop_running_job",
           "scene_params", "reconstruct_params"]

CLASSES = (INDOOR_OT_import_scan, INDOOR_OT_reconstruct, INDOOR_OT_cancel_reconstruct,
           INDOOR_OT_load_parameters, INDOOR_OT_save_parameters, INDOOR_OT_reclassify, INDOOR_OT_insert_door,
           INDOOR_OT_revert_edit, INDOOR_OT_show_graph, INDOOR_OT_shortest_path, INDOOR_OT_detect_changes,
           INDOOR_OT_select_by_status, INDOOR_OT_evaluate, INDOOR_OT_export_ifc)
"""Every operator class, in registration order."""
