"""The sidebar tab View3D ▸ N panel ▸ "Indoor". Panels only draw: no computation here."""
from __future__ import annotations

import json
import os

import bpy

from . import bridge, operators, props


def _model_stored(layout) -> bool:
    """Whether a reconstructed model is stored in the .blend; if not, say so in the panel."""
    if bpy.data.texts.get(bridge.MODEL_TEXT) is None:
        layout.label(text="Reconstruct a scan first", icon="INFO")
        return False
    return True


def _summary(text: str) -> dict:
    """A JSON summary stored by an operator ({} when empty or unreadable)."""
    if not text:
        return {}
    try:
        return json.loads(text)
    except ValueError:
        return {}


def _pct(v) -> str:
    return "n/a" if v is None else f"{100 * v:.1f}%"

__all__ = ["INDOOR_PT_import_scan", "INDOOR_PT_reconstruct", "INDOOR_PT_review", "INDOOR_PT_topology",
           "INDOOR_PT_evaluate", "INDOOR_PT_changes", "INDOOR_PT_export", "CLASSES"]


class _IndoorPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Indoor"


class INDOOR_PT_import_scan(_IndoorPanel, bpy.types.Panel):
    """Import a scan and set how the active scan is drawn."""

    bl_idname = "INDOOR_PT_import_scan"
    bl_label = "Import scan"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = getattr(context.scene, "indoor", None)
        layout.operator("indoor.import_scan", icon="IMPORT")
        if settings is not None:
            col = layout.column(align=True)
            col.prop(settings, "display_ratio")
            col.prop(settings, "point_radius")
        obj = context.active_object
        if not bridge.is_point_mesh(obj):
            return
        box = layout.box()
        box.label(text=obj.name, icon="POINTCLOUD_DATA")
        box.label(text=f"{obj.get(bridge.COUNT_PROP, len(obj.data.vertices)):,} points")
        offset = obj.get(bridge.OFFSET_PROP)
        if offset is not None and any(offset):
            box.label(text="Offset  " + "  ".join(f"{v:.3f}" for v in offset) + " m")
        mod = obj.modifiers.get(bridge.POINTS_MODIFIER)
        for name in (bridge.IN_RATIO, bridge.IN_RADIUS, bridge.IN_USE_SECTION, bridge.IN_SECTION_Z):
            ident = bridge.input_identifier(obj, name)
            if ident is not None:
                box.prop(mod, f'["{ident}"]', text=name)


class INDOOR_PT_reconstruct(_IndoorPanel, bpy.types.Panel):
    """Reconstruct the active scan; the model's collections."""

    bl_idname = "INDOOR_PT_reconstruct"
    bl_label = "Reconstruct"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = getattr(context.scene, "indoor", None)
        if settings is not None:
            layout.prop(settings, "method")
            layout.prop(settings, "reconstruct_seed")
            row = layout.row(align=True)
            row.operator("indoor.load_parameters", icon="FILE_FOLDER")
            row.operator("indoor.save_parameters", icon="FILE_TICK")
            if settings.params_toml:
                layout.label(text=f"Parameters: {os.path.basename(settings.params_file) or 'loaded'}",
                             icon="PRESET")
            layout.prop(settings, "use_custom_params")
            if settings.use_custom_params:
                col = layout.column(align=True)
                for prop, _key, _label, _unit in props.ENGINE_PARAMS:
                    method = props.PARAM_METHOD.get(prop)
                    if method is None or settings.method in ("auto", method):
                        col.prop(settings, prop)
        if settings is not None and settings.running:
            row = layout.row(align=True)
            if hasattr(row, "progress"):  # 4.0+
                row.progress(factor=settings.progress, type="BAR",
                             text=f"{settings.progress_text} {100 * settings.progress:.0f}%")
            else:
                row.label(text=f"{settings.progress_text} {100 * settings.progress:.0f}%")
            row.operator("indoor.cancel_reconstruct", text="", icon="CANCEL")
        else:
            layout.operator("indoor.reconstruct", icon="MOD_BUILD")  # it takes the settings above
        if not bridge.is_point_mesh(context.active_object):
            layout.label(text="Select an imported scan", icon="INFO")
        top = context.scene.collection.children.get(bridge.MODEL_COLLECTION)
        if top is not None:
            col = layout.column(align=True)
            for coll in top.children:
                col.label(text=f"{coll.name}: {len(coll.objects)}", icon="OUTLINER_COLLECTION")


class INDOOR_PT_review(_IndoorPanel, bpy.types.Panel):
    """Reclassify shapes, insert doors, go back to the model before the last edit."""

    bl_idname = "INDOOR_PT_review"
    bl_label = "Review and fix"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = getattr(context.scene, "indoor", None)
        if not _model_stored(layout):
            return
        obj = context.active_object
        if obj is not None and bridge.SHAPE_PROP in obj:
            layout.label(text=f"{obj.name}: {obj.get('indoor_type', '?')} ({obj[bridge.SHAPE_PROP]})",
                         icon="OBJECT_DATA")
            element = bridge.element_label(obj)
            if element:
                layout.label(text=element, icon="MOD_BUILD")
        if settings is None:
            return
        col = layout.column(align=True)
        col.prop(settings, "edit_type")
        op = col.operator("indoor.reclassify", icon="FILE_REFRESH")
        op.type = settings.edit_type
        col = layout.column(align=True)
        col.prop(settings, "door_width")
        col.prop(settings, "door_height")
        col.prop(settings, "door_position_mode")
        if settings.door_position_mode == "VALUE":
            col.prop(settings, "door_position")
        col.prop(settings, "door_snap")
        op = col.operator("indoor.insert_door", icon="MESH_PLANE")
        op.width, op.height = settings.door_width, settings.door_height
        op.position_mode, op.position = settings.door_position_mode, settings.door_position
        op.snap_distance = settings.door_snap
        layout.operator("indoor.revert_edit", icon="LOOP_BACK")


class INDOOR_PT_topology(_IndoorPanel, bpy.types.Panel):
    """Adjacency / connectivity graphs and shortest paths."""

    bl_idname = "INDOOR_PT_topology"
    bl_label = "Topology"

    def draw(self, context):
        layout = self.layout
        if not _model_stored(layout):
            return
        row = layout.row(align=True)
        for kind, label in (("adjacency", "Adjacency"), ("connectivity", "Connectivity")):
            op = row.operator("indoor.show_graph", text=label, depress=bridge.graph_shown(kind),
                              icon="HIDE_OFF" if bridge.graph_shown(kind) else "HIDE_ON")
            op.kind, op.show = kind, "TOGGLE"
        layout.operator("indoor.shortest_path", icon="TRACKING")
        settings = getattr(context.scene, "indoor", None)
        if settings is not None and settings.path_text:
            box = layout.box()
            for part in settings.path_text.split(" → "):
                box.label(text=part, icon="FORWARD")
            if settings.path_length > 0:
                box.label(text=f"{settings.path_length:.1f} m centre to centre")


class INDOOR_PT_evaluate(_IndoorPanel, bpy.types.Panel):
    """Quality against a reference: the curves and coloured surfaces."""

    bl_idname = "INDOOR_PT_evaluate"
    bl_label = "Evaluate"

    def draw(self, context):
        layout = self.layout
        if not _model_stored(layout):
            return
        layout.operator("indoor.evaluate", text="Evaluate against reference…", icon="CHECKMARK")
        settings = getattr(context.scene, "indoor", None)
        s = _summary(settings.eval_summary) if settings is not None else {}
        if not s:
            return
        box = layout.box()
        box.label(text=f"At {100 * s['buffer_m']:.0f} cm buffer:")
        box.label(text=f"Completeness {_pct(s['completeness'])}")
        box.label(text=f"Correctness {_pct(s['correctness'])}")
        if s.get("accuracy_m") is not None:
            box.label(text=f"Accuracy (median) {100 * s['accuracy_m']:.1f} cm")
        box.label(text=f"{len(s['missing'])} missing, {len(s['redundant'])} redundant surfaces")
        box.label(text="Surfaces: red uncovered → green covered")
        img = bpy.data.images.get(bridge.EVALUATION_IMAGE)
        if img is not None and img.preview is not None:
            layout.template_icon(icon_value=img.preview.icon_id, scale=10.0)


_STATUS_COLOUR_NAMES = {"installed": "green", "incomplete": "orange", "not installed": "red", "no data": "grey",
                        "new": "blue"}
"""The colour names of :data:`bridge.STATUS_COLORS` for the legend."""
_MAX_TOPICS = 12


class INDOOR_PT_changes(_IndoorPanel, bpy.types.Panel):
    """Change detection against a newer scan: summary and legend."""

    bl_idname = "INDOOR_PT_changes"
    bl_label = "Changes"

    def draw(self, context):
        layout = self.layout
        if not _model_stored(layout):
            return
        row = layout.row(align=True)
        row.operator("indoor.detect_changes", text="Scan file…", icon="FILE_FOLDER").use_active = False
        op = row.operator("indoor.detect_changes", text="Active scan", icon="POINTCLOUD_DATA")
        op.use_active = True
        settings = getattr(context.scene, "indoor", None)
        if settings is None:
            return
        layout.prop(settings, "change_color_mode", expand=True)
        s = _summary(settings.change_summary)
        if not s:
            return
        box = layout.box()
        box.label(text=f"{s['scan']}: {s['new']:,} new of {s['points']:,} ({_pct(s['new_share'])})")
        box.label(text=f"Threshold r = {100 * s['distance_threshold_m']:.1f} cm")
        box.label(text=f"{len(s['redundant'])} of {s['surfaces']} surfaces redundant")
        box.label(text=f"{s['new_elements']} new elements ({s['new_walls']} walls)")
        legend = layout.box()
        if settings.change_color_mode == "TYPE":
            legend.label(text="grey: existing   red: new", icon="COLOR")
        else:
            r = 100 * s["distance_threshold_m"]
            legend.label(text=f"blue 0 → yellow {r:.0f} cm → red ≥ {2 * r:.0f} cm", icon="COLOR")
            legend.label(text="dark grey: no surface nearby")
        legend.label(text="Surfaces: red uncovered → green covered")
        statuses = s.get("statuses") or {}
        if statuses:  # the model's elements coloured by status: legend, counts, select
            col = layout.box().column(align=True)
            col.label(text="Elements by status", icon="OUTLINER_OB_GROUP_INSTANCE")
            for status, icon in (("installed", "CHECKMARK"), ("incomplete", "ERROR"),
                                 ("not installed", "CANCEL"), ("no data", "QUESTION"), ("new", "ADD")):
                row = col.row(align=True)
                row.label(text=f"{_STATUS_COLOUR_NAMES[status]}: {status}  {statuses.get(status, 0)}", icon=icon)
                if statuses.get(status):
                    row.operator("indoor.select_by_status", text="", icon="RESTRICT_SELECT_OFF").status = status
        topics = s.get("topics") or []
        if topics:  # what changes.bcf holds: one topic per change, with its element
            col = layout.box().column(align=True)
            col.label(text=f"BCF topics ({len(topics)})", icon="TEXT")
            for t in topics[:_MAX_TOPICS]:
                col.label(text=f"{t['title']}" + (f" → {t['object']}" if t.get("object") else ""))
            if len(topics) > _MAX_TOPICS:
                col.label(text=f"… and {len(topics) - _MAX_TOPICS} more (changes.bcf)")


class INDOOR_PT_export(_IndoorPanel, bpy.types.Panel):
    """Export the reconstructed model."""

    bl_idname = "INDOOR_PT_export"
    bl_label = "Export"

    def draw(self, context):
        layout = self.layout
        layout.operator("indoor.export_ifc", icon="EXPORT")
        if operators.bonsai_available():
            op = layout.operator("indoor.export_ifc", text="Export and open in Bonsai", icon="FILE_BLEND")
            op.open_in_bonsai = True
        _model_stored(layout)


CLASSES = (INDOOR_PT_import_scan, INDOOR_PT_reconstruct, INDOOR_PT_review, INDOOR_PT_topology,
           INDOOR_PT_evaluate, INDOOR_PT_changes, INDOOR_PT_export)
"""In the order of the work (registration order is the order in the sidebar)."""
