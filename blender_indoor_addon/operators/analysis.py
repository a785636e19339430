"""Detect changes (a newer scan against the model) and Evaluate (the model against a reference).

engine.change and engine.evaluation are imported when an operator runs, not with the add-on:
Blender starts (and the batch converts) without them."""
from __future__ import annotations

import json
import os
import tempfile

import bpy
from bpy.props import BoolProperty, EnumProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ...engine.io import read_point_cloud
from .. import bridge
from .common import has_model, stored_or_report
from .engine_call import engine_call
from .scan import SCAN_EXTENSIONS

__all__ = ["INDOOR_OT_detect_changes", "INDOOR_OT_select_by_status", "INDOOR_OT_evaluate"]


class INDOOR_OT_detect_changes(bpy.types.Operator, ImportHelper):
    """Compare a newer scan with the model: new/existing points, distances, coverage of room faces"""

    bl_idname = "indoor.detect_changes"
    bl_label = "Detect Changes"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ""
    filter_glob: StringProperty(default=";".join("*" + e for e in SCAN_EXTENSIONS), options={"HIDDEN"})
    use_active: BoolProperty(name="Active scan", default=False,
                             description="Use the active scan object instead of a file")

    @classmethod
    def poll(cls, context):
        return has_model(context)

    def invoke(self, context, event):
        if self.use_active:
            return self.execute(context)
        return ImportHelper.invoke(self, context, event)

    def execute(self, context):
        from ...engine.change import detect_changes

        model = stored_or_report(self, context)
        if model is None:
            return {"CANCELLED"}
        settings = getattr(context.scene, "indoor", None)
        use_scan = self.use_active or not self.filepath
        obj = context.active_object
        if use_scan and not bridge.is_point_mesh(obj):
            self.report({"ERROR"}, "choose a scan file or make an imported scan active")
            return {"CANCELLED"}
        with engine_call(self, context) as call:
            if use_scan:
                cloud = bridge.object_to_cloud(obj)
            else:
                cloud = read_point_cloud(bpy.path.abspath(self.filepath))
            result = detect_changes(model, cloud, progress=call.progress)
            if not use_scan:  # the scan file becomes a point mesh that shows the result
                obj = bridge.point_cloud_to_object(cloud, scene=context.scene)
            summary = bridge.change_overlay(obj, result, model, scene=context.scene,
                                            mode=settings.change_color_mode if settings else "TYPE")
        if call.failed:
            return {"CANCELLED"}
        if settings is not None:
            settings.change_summary = json.dumps(summary)
        if not result.registered:  # no change is claimed: say why, and what to do
            reg = result.summary()["registration"]
            fit, walls = reg.get("fitness") or 0.0, reg.get("wall_fitness") or 0.0
            self.report({"WARNING"}, f"The scan does not fit the model (registration fitness {fit:.2f}, "
                                     f"walls {walls:.2f}): no change claimed; move the scan near the "
                                     "model and try again")
            return {"FINISHED"}
        self.report({"INFO"}, f"{summary['new']:,} new of {summary['points']:,} points; "
                              f"{len(summary['redundant'])} of {summary['surfaces']} surfaces redundant")
        return {"FINISHED"}


class INDOOR_OT_select_by_status(bpy.types.Operator):
    """Select the elements with this change status (after Detect Changes)"""

    bl_idname = "indoor.select_by_status"
    bl_label = "Select by Status"
    bl_options = {"REGISTER", "UNDO"}

    status: EnumProperty(name="Status", items=[
        ("installed", "Installed", "Seen where the model has it"),
        ("incomplete", "Incomplete", "Partly seen, part of it proven absent"),
        ("not installed", "Not installed", "Proven absent: the scanner saw through where it should be"),
        ("no data", "No data", "Not seen, nothing proves it absent"),
        ("new", "New", "Fitted to the new points of the scan")])
    extend: BoolProperty(name="Extend", default=False, description="Add to the selection")

    def execute(self, context):
        found = bridge.objects_with_status(self.status, context.scene)
        if not found:
            self.report({"WARNING"}, f"No element is '{self.status}': run Detect Changes first")
            return {"CANCELLED"}
        if not self.extend:
            for o in context.selected_objects:
                o.select_set(False)
        for o in found:
            o.hide_set(False)
            o.select_set(True)
        context.view_layer.objects.active = found[0]
        self.report({"INFO"}, f"{len(found)} elements {self.status}")
        return {"FINISHED"}


# --------------------------------------------------------------------------- Evaluate
class INDOOR_OT_evaluate(bpy.types.Operator, ImportHelper):
    """Compare the model with a reference (IFC, OBJ, PLY, JSON): completeness, correctness, accuracy"""

    bl_idname = "indoor.evaluate"
    bl_label = "Evaluate"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ""
    filter_glob: StringProperty(default="*.ifc;*.obj;*.ply;*.json", options={"HIDDEN"})
    out_dir: StringProperty(name="Output folder", default="", subtype="DIR_PATH",
                            description="Where the evaluation files go (default: a temporary folder)")

    @classmethod
    def poll(cls, context):
        return has_model(context)

    def execute(self, context):
        from ...engine.evaluation import evaluate, load_model, write_evaluation_outputs

        model = stored_or_report(self, context)
        if model is None:
            return {"CANCELLED"}
        path = bpy.path.abspath(self.filepath)
        with engine_call(self, context) as call:
            reference = load_model(path)
            result = evaluate(model, reference, progress=call.progress)
            out = bpy.path.abspath(self.out_dir) if self.out_dir else tempfile.mkdtemp(prefix="indoor_eval_")
            files = write_evaluation_outputs(result, out, title=os.path.basename(path))
            summary = bridge.evaluation_overlay(result, reference, model, files["png"], scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        settings = getattr(context.scene, "indoor", None)
        if settings is not None:
            settings.eval_summary = json.dumps(summary)

        def pct(v):
            return "n/a" if v is None else f"{100 * v:.0f}%"

        self.report({"INFO"}, f"completeness {pct(summary['completeness'])}, correctness "
                              f"{pct(summary['correctness'])} at {100 * summary['buffer_m']:.0f} cm; "
                              f"{len(summary['missing'])} missing, {len(summary['redundant'])} redundant")
        return {"FINISHED"}
