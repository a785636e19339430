"""Scan files in and IFC out: Import scan (File ▸ Import) and Export IFC (File ▸ Export)."""
from __future__ import annotations

import json
import logging
import os
import time

import bpy
import numpy as np
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       StringProperty)
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ...engine.errors import ReconstructionError
from ...engine.ifc import IfcWriteParams, write_ifc
from ...engine.io import read_point_cloud
from ...engine.segmentation.frame import apply_frame, normalize_frame
from .. import bridge
from ..props import UNITS_ITEMS, UP_ITEMS
from .engine_call import engine_call

log = logging.getLogger(__name__)

__all__ = ["SCAN_EXTENSIONS", "INDOOR_OT_import_scan", "INDOOR_OT_export_ifc", "bonsai_available",
           "menu_import", "menu_export"]

SCAN_EXTENSIONS = (".ply", ".pcd", ".e57", ".las", ".laz", ".pts", ".xyz", ".txt", ".csv")
"""File extensions the Import scan file browser shows (the engine decides what it reads)."""


def _import_frame(cloud, units: str, up: str):
    """``(cloud, frame record)`` in metres with z up (``engine.segmentation.frame``).

    Import shows any file: a cloud the automatic detection cannot judge (no building in it:
    noise, a single wall) is imported as it is and the record says why; Reconstruct refuses
    it later with its own message.
    """
    try:
        return normalize_frame(cloud, units=units, up=up)
    except ReconstructionError as e:
        if units != "auto" or up != "auto":
            raise
        return cloud, {"units": "m", "scale": 1.0, "up": "z", "checked": False, "note": e.problem}


def _recorded_frame(cloud, record: str):
    """``(cloud, frame record)`` with a frame the engine found for this file before (its checks
    and detections are not run again: 0.16 s of a 1M-point import)."""
    frame = json.loads(record)
    rot = np.asarray(frame.get("rotation", np.eye(3)), dtype=np.float64).reshape(3, 3)
    return apply_frame(cloud, rot, float(frame.get("scale", 1.0))), frame


class INDOOR_OT_import_scan(bpy.types.Operator, ImportHelper):
    """Import a laser scan as a point mesh (points with colour, intensity, normal and other attributes)"""

    bl_idname = "indoor.import_scan"
    bl_label = "Import Scan"
    bl_options = {"REGISTER", "UNDO", "PRESET"}

    filename_ext = ""  # several formats; the engine checks the extension
    filter_glob: StringProperty(
        default=";".join("*" + e for e in SCAN_EXTENSIONS),
        options={"HIDDEN"},
    )
    display_ratio: FloatProperty(
        name="Display ratio",
        description="Share of the points drawn (the mesh keeps every point); "
                    "defaults to the scene's Indoor setting",
        default=1.0, min=0.0, max=1.0, subtype="FACTOR",
    )
    point_radius: FloatProperty(
        name="Point radius",
        description="Radius of each drawn point; defaults to the scene's Indoor setting",
        default=0.01, min=0.0, soft_max=0.1, subtype="DISTANCE", unit="LENGTH", precision=4,
    )
    seed: IntProperty(name="Seed", description="Seed of the random display subset", default=0, min=0)
    units: EnumProperty(name="Units", items=UNITS_ITEMS, default="auto",
                        description="Units of the file's coordinates; the points are rescaled to metres")
    up_axis: EnumProperty(name="Up axis", items=UP_ITEMS, default="auto",
                          description="Which axis of the file points up; the points are turned z up")
    frame_record: StringProperty(
        default="", options={"HIDDEN", "SKIP_SAVE"},
        description="The engine's frame record of this file (JSON: scale, rotation, units, up), "
                    "when it has already checked and framed it (scripts/batch.py): applied as it is")
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"HIDDEN", "SKIP_SAVE"})
    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN", "SKIP_SAVE"})

    def _defaults_from_scene(self, context):
        settings = getattr(context.scene, "indoor", None)
        if settings is None:
            return
        for key in ("display_ratio", "point_radius", "seed"):
            if not self.properties.is_property_set(key):
                setattr(self, key, getattr(settings, key))

    def invoke(self, context, event):
        self._defaults_from_scene(context)
        return ImportHelper.invoke(self, context, event)

    def _paths(self):
        """The chosen files: every file selected in the browser, else ``filepath``."""
        names = [f.name for f in self.files if f.name]
        if names and self.directory:
            return [bpy.path.abspath(os.path.join(self.directory, n)) for n in names]
        return [bpy.path.abspath(self.filepath)]

    def execute(self, context):
        self._defaults_from_scene(context)
        paths = self._paths()
        t0 = t1 = time.perf_counter()
        objects = []
        with engine_call(self, context) as call:
            # every file is read before Blender data changes: a bad file leaves the scene as it was
            clouds = []
            for i, path in enumerate(paths):
                call.subject = path
                cloud = read_point_cloud(path, progress=call.part(i, len(paths)))
                clouds.append(_recorded_frame(cloud, self.frame_record) if self.frame_record
                              else _import_frame(cloud, self.units, self.up_axis))
            t1 = time.perf_counter()
            for cloud, frame in clouds:
                obj = bridge.point_cloud_to_object(
                    cloud, display_ratio=self.display_ratio, point_radius=self.point_radius,
                    seed=self.seed, scene=context.scene)
                objects.append(obj)
                obj["indoor_frame"] = json.dumps(frame, default=str)  # units and up axis: what was done
        if call.failed:
            return {"CANCELLED"}
        t2 = time.perf_counter()
        view_layer = context.view_layer
        if view_layer is not None:
            for o in view_layer.objects.selected:
                o.select_set(False)
            for obj in objects:
                try:
                    obj.select_set(True, view_layer=view_layer)
                    view_layer.objects.active = obj
                except RuntimeError:  # the Scan collection is excluded from this view layer
                    pass
        n = sum(len(c) for c, _ in clouds)
        what = os.path.basename(paths[0]) if len(paths) == 1 else f"{len(paths)} files"
        turned = [f"{os.path.basename(c.source or '')}: {f['units']} -> m, {f['up']} up"
                  for c, f in clouds if f.get("units", "m") != "m" or f.get("up", "z") != "z"]
        self.report({"INFO"}, f"Imported {n:,} points from {what} "
                              f"(read {t1 - t0:.2f} s, Blender {t2 - t1:.2f} s)"
                              + (f"; rescaled/turned {'; '.join(turned)}" if turned else ""))
        log.info("imported %d points from %s: read %.2f s, Blender %.2f s", n, what, t1 - t0, t2 - t1)
        return {"FINISHED"}


class INDOOR_OT_export_ifc(bpy.types.Operator, ExportHelper):
    """Write the reconstructed model as IFC (spaces, walls, doors, slabs, topology)"""

    bl_idname = "indoor.export_ifc"
    bl_label = "Export IFC"
    bl_options = {"REGISTER"}

    filename_ext = ".ifc"
    filter_glob: StringProperty(default="*.ifc", options={"HIDDEN"})
    schema: EnumProperty(name="Schema", items=(("IFC4", "IFC4", ""), ("IFC2X3", "IFC2X3", "")),
                         default="IFC4")
    parts: BoolProperty(name="Space parts", default=IfcWriteParams().parts,
                        description="Also write the parts of merged spaces (cuboids, cells) as PARTIAL "
                                    "IfcSpace; off: one IfcSpace per room, as area schedules expect")
    open_in_bonsai: BoolProperty(name="Open in Bonsai", default=False,
                                 description="Open the written file with the Bonsai (BlenderBIM) add-on "
                                             "when it is installed and enabled")

    @classmethod
    def poll(cls, context):
        return bpy.data.texts.get(bridge.MODEL_TEXT) is not None

    def execute(self, context):
        with engine_call(self, context, progress_bar=False) as call:
            model = bridge.stored_model()
            if model is not None:
                path = write_ifc(model, bpy.path.abspath(self.filepath), schema=self.schema,
                                 params=IfcWriteParams(parts=self.parts))
        if call.failed:
            return {"CANCELLED"}
        if model is None:
            self.report({"ERROR"}, "no reconstructed model in this file: run Reconstruct first")
            return {"CANCELLED"}
        if self.open_in_bonsai:
            if not bonsai_available():
                self.report({"WARNING"},
                            f"Wrote {path}; Bonsai is not installed or not enabled, so it was not opened")
                return {"FINISHED"}
            try:
                bpy.ops.bim.load_project(filepath=str(path))
            except RuntimeError as e:  # Bonsai's own error: the IFC file is written anyway
                self.report({"WARNING"}, f"Wrote {path}; Bonsai could not open it: {e}")
                return {"FINISHED"}
            self.report({"INFO"}, f"Wrote {path} and opened it in Bonsai")
            return {"FINISHED"}
        self.report({"INFO"}, f"Wrote {path}")
        return {"FINISHED"}


def bonsai_available() -> bool:
    """True when Bonsai's "Load Project" operator (``bim.load_project``) is registered."""
    return hasattr(bpy.types, "BIM_OT_load_project")


def menu_import(self, context):
    """File ▸ Import entry."""
    self.layout.operator(INDOOR_OT_import_scan.bl_idname,
                         text="Indoor Scan (" + " ".join(SCAN_EXTENSIONS) + ")")


def menu_export(self, context):
    """File ▸ Export entry."""
    self.layout.operator(INDOOR_OT_export_ifc.bl_idname, text="Indoor Model (.ifc)")
