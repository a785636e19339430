"""Operators: read properties, call one engine function, hand the result to the bridge.

Engine errors (:class:`~engine.errors.IndoorError`) become ``self.report({'ERROR'}, ...)``
and ``{'CANCELLED'}``; the scene is left as it was.
"""
from __future__ import annotations

import logging
import os
import time

import bpy
from bpy.props import CollectionProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ..engine.errors import IndoorError
from . import bridge
from .props import METHOD_ITEMS

log = logging.getLogger(__name__)

__all__ = ["INDOOR_OT_import_scan", "INDOOR_OT_reconstruct", "INDOOR_OT_export_ifc", "SCAN_EXTENSIONS",
           "CLASSES", "menu_import", "menu_export"]

SCAN_EXTENSIONS = (".ply", ".pcd", ".e57", ".las", ".laz", ".pts", ".xyz", ".txt", ".csv")
"""File extensions the Import scan file browser shows (the engine decides what it reads)."""


def _progress_callback(context):
    """A ``progress(fraction, message)`` callback driving the window manager's progress bar."""
    wm = context.window_manager

    def progress(fraction, message=""):
        wm.progress_update(int(round(1000 * fraction)))
        if message:
            log.debug("%3.0f%% %s", 100 * fraction, message)

    return progress


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
        from ..engine.io import read_point_cloud  # the engine is imported on first use

        self._defaults_from_scene(context)
        paths = self._paths()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        progress = _progress_callback(context)
        t0 = time.perf_counter()
        try:
            # every file is read before Blender data changes: a bad file leaves the scene as it was
            clouds = []
            for i, path in enumerate(paths):
                share = (i / len(paths), (i + 1) / len(paths))
                clouds.append(read_point_cloud(
                    path, progress=lambda f, m="", a=share: progress(a[0] + f * (a[1] - a[0]), m)))
            t1 = time.perf_counter()
            objects = []
            try:
                for cloud in clouds:
                    objects.append(bridge.point_cloud_to_object(
                        cloud, display_ratio=self.display_ratio, point_radius=self.point_radius,
                        seed=self.seed, scene=context.scene))
            except BaseException:
                bridge.remove_objects(objects)
                raise
        except IndoorError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        finally:
            wm.progress_end()
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
        n = sum(len(c) for c in clouds)
        what = os.path.basename(paths[0]) if len(paths) == 1 else f"{len(paths)} files"
        self.report({"INFO"}, f"Imported {n:,} points from {what} "
                              f"(read {t1 - t0:.2f} s, Blender {t2 - t1:.2f} s)")
        log.info("imported %d points from %s: read %.2f s, Blender %.2f s", n, what, t1 - t0, t2 - t1)
        return {"FINISHED"}


class INDOOR_OT_reconstruct(bpy.types.Operator):
    """Reconstruct spaces, walls and their topology from the active scan"""

    bl_idname = "indoor.reconstruct"
    bl_label = "Reconstruct"
    bl_options = {"REGISTER", "UNDO"}

    method: EnumProperty(name="Method", items=METHOD_ITEMS, default="auto")
    seed: IntProperty(name="Seed", default=0, min=0, description="Same seed, same model")

    @classmethod
    def poll(cls, context):
        return bridge.is_point_mesh(context.active_object)

    def invoke(self, context, event):
        settings = getattr(context.scene, "indoor", None)
        if settings is not None:
            if not self.properties.is_property_set("method"):
                self.method = settings.method
            if not self.properties.is_property_set("seed"):
                self.seed = settings.reconstruct_seed
        return self.execute(context)

    def execute(self, context):
        from ..engine.reconstruct import reconstruct  # the engine is imported on first use

        obj = context.active_object
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        t0 = time.perf_counter()
        try:
            cloud = bridge.object_to_cloud(obj)
            model = reconstruct(cloud, self.method, rng=self.seed, progress=_progress_callback(context))
            by_coll = bridge.model_to_objects(model, scene=context.scene)
        except IndoorError as e:
            self.report({"ERROR"}, f"{obj.name}: {e}")
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        counts = ", ".join(f"{len(v)} {k.lower()}" for k, v in sorted(by_coll.items()) if k != "Cells")
        self.report({"INFO"}, f"Reconstructed {obj.name} ({model.provenance.method or self.method}): "
                              f"{counts} in {time.perf_counter() - t0:.1f} s")
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

    @classmethod
    def poll(cls, context):
        return bpy.data.texts.get(bridge.MODEL_TEXT) is not None

    def execute(self, context):
        from ..engine.ifc import write_ifc  # the engine is imported on first use

        try:
            model = bridge.stored_model()
            if model is None:
                self.report({"ERROR"}, "no reconstructed model in this file: run Reconstruct first")
                return {"CANCELLED"}
            path = write_ifc(model, bpy.path.abspath(self.filepath), schema=self.schema)
        except IndoorError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Wrote {path}")
        return {"FINISHED"}


def menu_import(self, context):
    """File ▸ Import entry."""
    self.layout.operator(INDOOR_OT_import_scan.bl_idname,
                         text="Indoor Scan (" + " ".join(SCAN_EXTENSIONS) + ")")


def menu_export(self, context):
    """File ▸ Export entry."""
    self.layout.operator(INDOOR_OT_export_ifc.bl_idname, text="Indoor Model (.ifc)")


CLASSES = (INDOOR_OT_import_scan, INDOOR_OT_reconstruct, INDOOR_OT_export_ifc)
