"""Operators: read properties, call one engine function, hand the result to the bridge.

Every operator has one error boundary: any exception (an engine error or a bug) becomes
one line in ``self.report({'ERROR'}, ...)`` naming the file or object and the kind of
error (:func:`engine.errors.error_line`), never a traceback, and ``{'CANCELLED'}``; the
scene is left as it was. Internal errors are logged with their traceback.
"""
from __future__ import annotations

import logging
import os
import time

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       StringProperty)
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ..engine.errors import error_kind, error_line
from . import bridge
from .props import EDIT_TYPE_ITEMS, METHOD_ITEMS, POSITION_ITEMS, UNITS_ITEMS, UP_ITEMS

log = logging.getLogger(__name__)

__all__ = ["INDOOR_OT_import_scan", "INDOOR_OT_reconstruct", "INDOOR_OT_cancel_reconstruct", "ReconstructJob",
           "INDOOR_OT_reclassify", "INDOOR_OT_insert_door", "INDOOR_OT_revert_edit", "INDOOR_OT_show_graph",
           "INDOOR_OT_shortest_path", "INDOOR_OT_detect_changes", "INDOOR_OT_evaluate",
           "INDOOR_OT_export_ifc",
           "SCAN_EXTENSIONS", "CLASSES", "menu_import", "menu_export", "bonsai_available"]

SCAN_EXTENSIONS = (".ply", ".pcd", ".e57", ".las", ".laz", ".pts", ".xyz", ".txt", ".csv")
"""File extensions the Import scan file browser shows (the engine decides what it reads)."""


def _fail(op, exc: BaseException, subject=None):
    """Report ``exc`` on one line (naming ``subject``, a file or an object) and cancel."""
    if error_kind(exc) == "internal":
        log.error("%s", error_line(exc, subject), exc_info=exc)
    op.report({"ERROR"}, error_line(exc, subject))
    return {"CANCELLED"}


def _progress_callback(context):
    """A ``progress(fraction, message)`` callback driving the window manager's progress bar."""
    wm = context.window_manager

    def progress(fraction, message=""):
        wm.progress_update(int(round(1000 * fraction)))
        if message:
            log.debug("%3.0f%% %s", 100 * fraction, message)

    return progress


def _import_frame(cloud, units: str, up: str):
    """``(cloud, frame record)`` in metres with z up (``engine.segmentation.frame``).

    Import shows any file: a cloud the automatic detection cannot judge (no building in it:
    noise, a single wall) is imported as it is and the record says why; Reconstruct refuses
    it later with its own message.
    """
    from ..engine.errors import ReconstructionError
    from ..engine.segmentation.frame import normalize_frame

    try:
        return normalize_frame(cloud, units=units, up=up)
    except ReconstructionError as e:
        if units != "auto" or up != "auto":
            raise
        return cloud, {"units": "m", "scale": 1.0, "up": "z", "checked": False, "note": e.problem}


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
        import json

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
            path = None
            for i, path in enumerate(paths):
                share = (i / len(paths), (i + 1) / len(paths))
                cloud = read_point_cloud(
                    path, progress=lambda f, m="", a=share: progress(a[0] + f * (a[1] - a[0]), m))
                clouds.append(_import_frame(cloud, self.units, self.up_axis))
            t1 = time.perf_counter()
            objects = []
            try:
                for cloud, frame in clouds:
                    obj = bridge.point_cloud_to_object(
                        cloud, display_ratio=self.display_ratio, point_radius=self.point_radius,
                        seed=self.seed, scene=context.scene)
                    objects.append(obj)
                    obj["indoor_frame"] = json.dumps(frame, default=str)  # units and up axis: what was done
            except BaseException:
                bridge.remove_objects(objects)
                raise
        except Exception as e:
            return _fail(self, e, path)
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
        n = sum(len(c) for c, _ in clouds)
        what = os.path.basename(paths[0]) if len(paths) == 1 else f"{len(paths)} files"
        turned = [f"{os.path.basename(c.source or '')}: {f['units']} -> m, {f['up']} up"
                  for c, f in clouds if f.get("units", "m") != "m" or f.get("up", "z") != "z"]
        self.report({"INFO"}, f"Imported {n:,} points from {what} "
                              f"(read {t1 - t0:.2f} s, Blender {t2 - t1:.2f} s)"
                              + (f"; rescaled/turned {'; '.join(turned)}" if turned else ""))
        log.info("imported %d points from %s: read %.2f s, Blender %.2f s", n, what, t1 - t0, t2 - t1)
        return {"FINISHED"}


class INDOOR_OT_reconstruct(bpy.types.Operator):
    """Reconstruct spaces, walls and their topology from the active scan"""

    bl_idname = "indoor.reconstruct"
    bl_label = "Reconstruct"
    bl_options = {"REGISTER", "UNDO"}

    method: EnumProperty(name="Method", items=METHOD_ITEMS, default="auto")
    seed: IntProperty(name="Seed", default=0, min=0, description="Same seed, same model")
    use_custom_params: BoolProperty(name="Set parameters", default=False,
                                    description="Override the key parameters below")
    min_wall_area: FloatProperty(name="Min wall area", default=1.5, min=0.0, unit="AREA")
    max_wall_thickness: FloatProperty(name="Max wall thickness", default=0.5, min=0.05, subtype="DISTANCE",
                                      unit="LENGTH")
    working_voxel: FloatProperty(name="Working voxel", default=0.02, min=0.005, subtype="DISTANCE",
                                 unit="LENGTH")

    _PARAM_KEYS = ("use_custom_params", "min_wall_area", "max_wall_thickness", "working_voxel")

    @classmethod
    def poll(cls, context):
        return bridge.is_point_mesh(context.active_object)

    def invoke(self, context, event):
        """Interactive run: the engine works in a thread (:class:`ReconstructJob`), a timer
        drives the progress bar, Esc (or the panel's Cancel) stops it; the objects are built
        on the main thread when it finishes. Without a window (background): :meth:`execute`."""
        settings = getattr(context.scene, "indoor", None)
        if settings is not None:
            if not self.properties.is_property_set("method"):
                self.method = settings.method
            if not self.properties.is_property_set("seed"):
                self.seed = settings.reconstruct_seed
            for key in self._PARAM_KEYS:
                if not self.properties.is_property_set(key):
                    setattr(self, key, getattr(settings, key))
        if bpy.app.background or context.window is None:
            return self.execute(context)
        if ReconstructJob.current is not None and ReconstructJob.current.running:
            self.report({"WARNING"}, "a reconstruction is already running")
            return {"CANCELLED"}
        obj = context.active_object
        try:
            cloud = bridge.object_to_cloud(obj)
        except Exception as e:
            return _fail(self, e, obj.name)
        self._object_name = obj.name
        self._job = ReconstructJob(cloud, self.method, self.seed, params=self._overrides())
        self._job.start()
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(TIMER_STEP, window=context.window)
        wm.modal_handler_add(self)
        if settings is not None:
            settings.running, settings.progress, settings.progress_text = True, 0.0, "starting"
        return {"RUNNING_MODAL"}

    def _finish(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        settings = getattr(context.scene, "indoor", None)
        if settings is not None:
            settings.running, settings.progress_text = False, ""
        for area in getattr(context.screen, "areas", []):
            area.tag_redraw()

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC":
            job.cancel()
        if event.type != "TIMER" and event.type != "ESC":
            return {"PASS_THROUGH"}
        settings = getattr(context.scene, "indoor", None)
        context.window_manager.progress_update(int(round(1000 * job.fraction)))
        if settings is not None:
            settings.progress, settings.progress_text = job.fraction, job.message
        if job.running:
            return {"RUNNING_MODAL"}
        self._finish(context)
        if job.cancelled:
            self.report({"WARNING"},
                        f"Reconstruction of {self._object_name} cancelled; the scene is unchanged")
            return {"CANCELLED"}
        if job.error is not None:
            return _fail(self, job.error, self._object_name)
        try:
            by_coll = bridge.model_to_objects(job.model, scene=context.scene)
        except Exception as e:
            return _fail(self, e, self._object_name)
        bridge.refresh_overlays(job.model, scene=context.scene)
        self.report({"INFO"}, _summary(self._object_name, job.model, self.method, by_coll, job.seconds))
        return {"FINISHED"}

    def _overrides(self):
        if not self.use_custom_params:
            return None
        return {"min_wall_area": self.min_wall_area, "max_wall_thickness": self.max_wall_thickness,
                "working_voxel": self.working_voxel}

    def execute(self, context):
        from ..engine.reconstruct import reconstruct  # the engine is imported on first use

        obj = context.active_object
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        t0 = time.perf_counter()
        try:
            cloud = bridge.object_to_cloud(obj)
            method, params = engine_params(cloud, self.method, self.seed, self._overrides())
            model = reconstruct(cloud, method, params=params, rng=self.seed,
                                progress=_progress_callback(context))
            by_coll = bridge.model_to_objects(model, scene=context.scene)
        except Exception as e:
            return _fail(self, e, obj.name)
        finally:
            wm.progress_end()
        bridge.refresh_overlays(model, scene=context.scene)
        self.report({"INFO"}, _summary(obj.name, model, self.method, by_coll, time.perf_counter() - t0))
        return {"FINISHED"}


def engine_params(cloud, method: str, seed: int, overrides):
    """``(method, params)`` for ``engine.reconstruct.reconstruct``: ``params`` is None without
    overrides; else the method's parameter dataclass with the overridden fields that it has
    (``min_wall_area`` m², ``max_wall_thickness`` m, ``working_voxel`` m). With overrides,
    "auto" is resolved first (``engine.reconstruct.choose_method``), as the parameters
    depend on the method."""
    import dataclasses

    if not overrides:
        return method, None
    from ..engine.grammar.generic import GenericParams
    from ..engine.grammar.params import ManhattanParams
    from ..engine.reconstruct import choose_method

    if method == "auto":
        method, _ = choose_method(cloud, rng=seed)
    cls = ManhattanParams if method == "manhattan" else GenericParams
    names = {f.name for f in dataclasses.fields(cls)}
    return method, cls(**{k: float(v) for k, v in overrides.items() if k in names})


def _summary(name, model, method, by_coll, seconds) -> str:
    counts = ", ".join(f"{len(v)} {k.lower()}" for k, v in sorted(by_coll.items()) if k != "Cells")
    return f"Reconstructed {name} ({model.provenance.method or method}): {counts} in {seconds:.1f} s"


TIMER_STEP = 0.1
"""Seconds between two progress updates of a modal reconstruction."""


class ReconstructJob:
    """``engine.reconstruct.reconstruct`` in a worker thread, cancellable.

    The thread only runs the engine (numpy, no Blender data); the caller polls
    :attr:`running`, :attr:`fraction` and :attr:`message` and builds the objects from
    :attr:`model` on the main thread. ``params`` are the overrides of :func:`engine_params`
    (a dict or None). :meth:`cancel` makes the engine's ``should_stop``
    return True: the engine raises ``Cancelled`` at its next check and :attr:`cancelled`
    becomes True.
    """

    current = None
    """The job started last (one at a time)."""

    def __init__(self, cloud, method: str = "auto", seed: int = 0, params=None):
        import threading

        self.cloud, self.method, self.seed, self.params = cloud, method, seed, params
        self.fraction, self.message = 0.0, ""
        self.model, self.error, self.cancelled, self.seconds = None, None, False, 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="indoor-reconstruct", daemon=True)

    def _progress(self, fraction, message=""):
        self.fraction = max(self.fraction, float(fraction))
        if message:
            self.message = message

    def _run(self):
        from ..engine.errors import Cancelled
        from ..engine.reconstruct import reconstruct

        t0 = time.perf_counter()
        try:
            method, params = engine_params(self.cloud, self.method, self.seed, self.params)
            self.model = reconstruct(self.cloud, method, params=params, rng=self.seed,
                                     progress=self._progress, should_stop=self._stop.is_set)
        except Cancelled:
            self.cancelled = True
        except Exception as e:  # reported on the main thread; a bug must not kill the loop silently
            self.error = e
        finally:
            self.seconds = time.perf_counter() - t0

    def start(self):
        ReconstructJob.current = self
        self._thread.start()
        return self

    def cancel(self):
        self._stop.set()

    def join(self, timeout=None):
        self._thread.join(timeout)
        return not self._thread.is_alive()

    @property
    def running(self) -> bool:
        return self._thread.is_alive()


class INDOOR_OT_cancel_reconstruct(bpy.types.Operator):
    """Stop the running reconstruction (the scene stays as it was)"""

    bl_idname = "indoor.cancel_reconstruct"
    bl_label = "Cancel"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        job = ReconstructJob.current
        return job is not None and job.running

    def execute(self, context):
        ReconstructJob.current.cancel()
        return {"FINISHED"}


# --------------------------------------------------------------------------- Review and fix
def _stored_or_report(op):
    model = bridge.stored_model()
    if model is None:
        op.report({"ERROR"}, "no reconstructed model in this file: run Reconstruct first")
    return model


def _has_model(context) -> bool:
    return bpy.data.texts.get(bridge.MODEL_TEXT) is not None


class INDOOR_OT_reclassify(bpy.types.Operator):
    """Give the selected shapes a new type; merges, walls, doors and topology are re-derived"""

    bl_idname = "indoor.reclassify"
    bl_label = "Reclassify"
    bl_options = {"REGISTER", "UNDO"}

    type: EnumProperty(name="New type", items=EDIT_TYPE_ITEMS, default="interior")
    shape_ids: StringProperty(name="Shape ids", default="", options={"SKIP_SAVE"},
                              description="Comma-separated shape ids (default: the selected objects)")

    @classmethod
    def poll(cls, context):
        return _has_model(context) and any(bridge.SHAPE_PROP in o for o in context.selected_objects)

    def invoke(self, context, event):
        settings = getattr(context.scene, "indoor", None)
        if settings is not None and not self.properties.is_property_set("type"):
            self.type = settings.edit_type
        return self.execute(context)

    def execute(self, context):
        from ..engine.topology import reclassify

        model = _stored_or_report(self)
        if model is None:
            return {"CANCELLED"}
        ids = [i.strip() for i in self.shape_ids.split(",") if i.strip()] or \
            bridge.shape_ids_of(context.selected_objects)
        if not ids:
            self.report({"ERROR"}, "select shapes of the model (spaces, walls, exterior)")
            return {"CANCELLED"}
        try:
            new = reclassify(model, ids, self.type)
            bridge.apply_edit(model, new, scene=context.scene)
        except Exception as e:
            return _fail(self, e)
        self.report({"INFO"}, f"Reclassified {len(ids)} shape(s) as {self.type}: "
                              f"{len(new.spaces)} spaces, {len(new.walls)} walls, {len(new.doors)} doors")
        return {"FINISHED"}


class INDOOR_OT_insert_door(bpy.types.Operator):
    """Insert a door in the active wall, at the 3D cursor or at a distance along the wall"""

    bl_idname = "indoor.insert_door"
    bl_label = "Insert Door"
    bl_options = {"REGISTER", "UNDO"}

    width: FloatProperty(name="Width", default=0.9, min=0.1, subtype="DISTANCE", unit="LENGTH")
    height: FloatProperty(name="Height", default=2.1, min=0.1, subtype="DISTANCE", unit="LENGTH")
    position_mode: EnumProperty(name="Position", items=POSITION_ITEMS, default="CURSOR")
    position: FloatProperty(name="Along wall", default=1.0, min=0.0, subtype="DISTANCE", unit="LENGTH",
                            description="Door centre from the wall's start, metres (Position = Value)")
    wall_id: StringProperty(name="Wall id", default="", options={"SKIP_SAVE"},
                            description="Id of the wall (default: the active object)")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return _has_model(context) and obj is not None and obj.get("indoor_type") == "wall"

    def invoke(self, context, event):
        settings = getattr(context.scene, "indoor", None)
        if settings is not None:
            for mine, theirs in (("width", "door_width"), ("height", "door_height"),
                                 ("position_mode", "door_position_mode"), ("position", "door_position")):
                if not self.properties.is_property_set(mine):
                    setattr(self, mine, getattr(settings, theirs))
        return self.execute(context)

    def execute(self, context):
        from ..engine.topology import insert_door

        model = _stored_or_report(self)
        if model is None:
            return {"CANCELLED"}
        obj = context.active_object
        wall_id = self.wall_id or (str(obj[bridge.SHAPE_PROP]) if obj is not None and bridge.SHAPE_PROP in obj
                                   else "")
        if not wall_id:
            self.report({"ERROR"}, "select a wall of the model")
            return {"CANCELLED"}
        if self.position_mode == "CURSOR":
            position = bridge.to_model_frame(model, context.scene.cursor.location)
        else:
            position = float(self.position)
        try:
            new = insert_door(model, wall_id, position=position, width=self.width, height=self.height)
            bridge.apply_edit(model, new, scene=context.scene)
        except Exception as e:
            return _fail(self, e)
        door = next(s for s in new.doors if s.id not in model)
        self.report({"INFO"}, f"Inserted {door.name} ({self.width:.2f} x {self.height:.2f} m) in {wall_id} "
                              f"at {door.attributes['position']:.2f} m")
        return {"FINISHED"}


class INDOOR_OT_revert_edit(bpy.types.Operator):
    """Go back to the model before the last Reclassify / Insert door (kept in the .blend)"""

    bl_idname = "indoor.revert_edit"
    bl_label = "Revert Last Edit"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return bpy.data.texts.get(bridge.HISTORY_TEXT) is not None and bridge.history_length() > 0

    def execute(self, context):
        try:
            model = bridge.restore_previous(scene=context.scene)
        except Exception as e:
            return _fail(self, e)
        if model is None:
            self.report({"ERROR"}, "no earlier model to go back to")
            return {"CANCELLED"}
        bridge.refresh_overlays(model, scene=context.scene)
        self.report({"INFO"}, f"Restored the previous model ({len(model.spaces)} spaces, "
                              f"{len(model.doors)} doors)")
        return {"FINISHED"}


# --------------------------------------------------------------------------- Topology
class INDOOR_OT_show_graph(bpy.types.Operator):
    """Draw or hide the adjacency / connectivity graph: curves between the centres of spaces"""

    bl_idname = "indoor.show_graph"
    bl_label = "Show Graph"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(name="Graph", items=(("adjacency", "Adjacency", "Spaces sharing a wall"),
                                            ("connectivity", "Connectivity", "Spaces joined by a door")))
    show: EnumProperty(name="Show", items=(("TOGGLE", "Toggle", ""), ("ON", "On", ""), ("OFF", "Off", "")),
                       default="TOGGLE")

    @classmethod
    def poll(cls, context):
        return _has_model(context)

    def execute(self, context):
        on = (not bridge.graph_shown(self.kind)) if self.show == "TOGGLE" else self.show == "ON"
        if not on:
            bridge.remove_graph(self.kind)
            return {"FINISHED"}
        model = _stored_or_report(self)
        if model is None:
            return {"CANCELLED"}
        obj = bridge.graph_to_curve(model, self.kind, scene=context.scene)
        self.report({"INFO"}, f"{self.kind.capitalize()} graph: {len(obj['indoor_edges'])} edges")
        return {"FINISHED"}


class INDOOR_OT_shortest_path(bpy.types.Operator):
    """Shortest walk between the two selected spaces (through doors), drawn as a curve"""

    bl_idname = "indoor.shortest_path"
    bl_label = "Shortest Path"
    bl_options = {"REGISTER", "UNDO"}

    start: StringProperty(name="From", default="", options={"SKIP_SAVE"},
                          description="Space id or name (default: the selected space that is not active)")
    end: StringProperty(name="To", default="", options={"SKIP_SAVE"},
                        description="Space id or name (default: the active space)")

    @classmethod
    def poll(cls, context):
        return _has_model(context)

    def _ends(self, context):
        if self.start and self.end:
            return self.start, self.end
        spaces = [o for o in context.selected_objects
                  if o.get("indoor_type") == "interior" and bridge.SHAPE_PROP in o]
        if len(spaces) != 2:
            return None
        active = context.active_object
        spaces.sort(key=lambda o: o == active)  # the active one last
        return tuple(str(o[bridge.SHAPE_PROP]) for o in spaces)

    def execute(self, context):
        from ..engine.topology import describe_path, shortest_path

        model = _stored_or_report(self)
        if model is None:
            return {"CANCELLED"}
        ends = self._ends(context)
        if ends is None:
            self.report({"ERROR"}, "select exactly two spaces")
            return {"CANCELLED"}
        settings = getattr(context.scene, "indoor", None)
        try:
            path = shortest_path(model, *ends)
        except KeyError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if path is None:
            bridge.refresh_overlays(model, scene=context.scene)  # drops a previous path
            text = f"{ends[1]} cannot be reached from {ends[0]}"
            if settings is not None:
                settings.path_text, settings.path_length = text, 0.0
            self.report({"WARNING"}, text)
            return {"FINISHED"}
        text = describe_path(model, path)
        bridge.path_to_curve(model, path, scene=context.scene)
        if settings is not None:
            settings.path_text, settings.path_length = text, path.length
        self.report({"INFO"}, f"{text} ({path.length:.1f} m)")
        return {"FINISHED"}


# --------------------------------------------------------------------------- Changes
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
        return _has_model(context)

    def invoke(self, context, event):
        if self.use_active:
            return self.execute(context)
        return ImportHelper.invoke(self, context, event)

    def execute(self, context):
        from ..engine.change import detect_changes
        from ..engine.io import read_point_cloud

        model = _stored_or_report(self)
        if model is None:
            return {"CANCELLED"}
        settings = getattr(context.scene, "indoor", None)
        made = None
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        try:
            if self.use_active or not self.filepath:
                obj = context.active_object
                if not bridge.is_point_mesh(obj):
                    self.report({"ERROR"}, "choose a scan file or make an imported scan active")
                    return {"CANCELLED"}
                cloud = bridge.object_to_cloud(obj)
            else:
                cloud = read_point_cloud(bpy.path.abspath(self.filepath))
            result = detect_changes(model, cloud, progress=_progress_callback(context))
            if not (self.use_active or not self.filepath):
                obj = made = bridge.point_cloud_to_object(cloud, scene=context.scene)
            summary = bridge.change_overlay(obj, result, model, scene=context.scene,
                                            mode=settings.change_color_mode if settings else "TYPE")
        except Exception as e:
            if made is not None:
                bridge.remove_objects([made])
            _fail(self, e)
            return {"CANCELLED"}
        finally:
            wm.progress_end()
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
        return _has_model(context)

    def execute(self, context):
        import tempfile

        from ..engine.evaluation import evaluate, load_model, write_evaluation_outputs

        model = _stored_or_report(self)
        if model is None:
            return {"CANCELLED"}
        path = bpy.path.abspath(self.filepath)
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        try:
            reference = load_model(path)
            result = evaluate(model, reference, progress=_progress_callback(context))
            out = bpy.path.abspath(self.out_dir) if self.out_dir else tempfile.mkdtemp(prefix="indoor_eval_")
            files = write_evaluation_outputs(result, out, title=os.path.basename(path))
            summary = bridge.evaluation_overlay(result, reference, model, files["png"], scene=context.scene)
        except Exception as e:
            return _fail(self, e)
        finally:
            wm.progress_end()

        def pct(v):
            return "n/a" if v is None else f"{100 * v:.0f}%"

        self.report({"INFO"}, f"completeness {pct(summary['completeness'])}, correctness "
                              f"{pct(summary['correctness'])} at {100 * summary['buffer_m']:.0f} cm; "
                              f"{len(summary['missing'])} missing, {len(summary['redundant'])} redundant")
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
    open_in_bonsai: BoolProperty(name="Open in Bonsai", default=False,
                                 description="Open the written file with the Bonsai (BlenderBIM) add-on "
                                             "when it is installed and enabled")

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
        except Exception as e:
            return _fail(self, e)
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


CLASSES = (INDOOR_OT_import_scan, INDOOR_OT_reconstruct, INDOOR_OT_cancel_reconstruct, INDOOR_OT_reclassify,
           INDOOR_OT_insert_door, INDOOR_OT_revert_edit, INDOOR_OT_show_graph, INDOOR_OT_shortest_path,
           INDOOR_OT_detect_changes, INDOOR_OT_evaluate, INDOOR_OT_export_ifc)
