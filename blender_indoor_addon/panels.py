"""The sidebar tab View3D ▸ N panel ▸ "Indoor". Panels only draw: no computation here."""
from __future__ import annotations

import bpy

from . import bridge

__all__ = ["INDOOR_PT_import_scan", "INDOOR_PT_reconstruct", "INDOOR_PT_export", "CLASSES"]


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
        op = layout.operator("indoor.reconstruct", icon="MOD_BUILD")
        if settings is not None:
            op.method = settings.method
            op.seed = settings.reconstruct_seed
        if not bridge.is_point_mesh(context.active_object):
            layout.label(text="Select an imported scan", icon="INFO")
        top = context.scene.collection.children.get(bridge.MODEL_COLLECTION)
        if top is not None:
            col = layout.column(align=True)
            for coll in top.children:
                col.label(text=f"{coll.name}: {len(coll.objects)}", icon="OUTLINER_COLLECTION")


class INDOOR_PT_export(_IndoorPanel, bpy.types.Panel):
    """Export the reconstructed model."""

    bl_idname = "INDOOR_PT_export"
    bl_label = "Export"

    def draw(self, context):
        layout = self.layout
        layout.operator("indoor.export_ifc", icon="EXPORT")
        if bpy.data.texts.get(bridge.MODEL_TEXT) is None:
            layout.label(text="Reconstruct a scan first", icon="INFO")


CLASSES = (INDOOR_PT_import_scan, INDOOR_PT_reconstruct, INDOOR_PT_export)
