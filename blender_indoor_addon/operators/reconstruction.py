"""Reconstruct (modal with progress and cancel, or at once), and Load / Save parameters.

The parameters of a run are the engine's :class:`~engine.params.Params`: those loaded from
a TOML file (kept on the scene) or the engine's defaults, with the panel's shown values
(:data:`~..props.ENGINE_PARAMS`) applied when "Set parameters" is on.
"""
from __future__ import annotations

import os
import time
import tomllib

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ...engine.background import ReconstructJob
from ...engine.errors import InputError
from ...engine.params import Params, load_params, params_from_dict, params_to_toml, save_params, with_settings
from ...engine.reconstruct import reconstruct
from .. import bridge
from ..props import ENGINE_PARAMS, METHOD_ITEMS, engine_param_properties
from .common import scene_settings, show_model_change
from .engine_call import engine_call

__all__ = ["INDOOR_OT_reconstruct", "INDOOR_OT_cancel_reconstruct", "INDOOR_OT_load_parameters",
           "INDOOR_OT_save_parameters", "running_job", "stop_running_job", "scene_params",
           "reconstruct_params", "TIMER_STEP"]

TIMER_STEP = 0.1
"""Seconds between two progress updates of a modal reconstruction."""

_current_job: list = []
"""The reconstruction job started last (at most one), kept while the add-on is registered."""


def running_job():
    """The :class:`~engine.background.ReconstructJob` of a modal reconstruction still running, or None."""
    return _current_job[0] if _current_job and _current_job[0].running else None


def stop_running_job(timeout: float = 10.0) -> None:
    """Cancel a running modal reconstruction and wait for its worker thread (at most ``timeout`` s)."""
    job = running_job()
    if job is not None:
        job.cancel()
        job.join(timeout)
    _current_job.clear()


def _decimal(value: float) -> str:
    """A float property's value as the decimal it was typed as (Blender keeps float32)."""
    return repr(float(f"{value:.7g}"))


def _param_value(params: Params, key: str):
    obj = params
    for part in key.split("."):
        obj = getattr(obj, part)
    return obj


def scene_params(context) -> Params | None:
    """The parameters Load parameters stored on the scene; None when none were loaded.

    Raises
    ------
    InputError
        The stored text is not a valid parameter file (edited by hand).
    """
    settings = getattr(context.scene, "indoor", None)
    if settings is None or not settings.params_toml.strip():
        return None
    source = settings.params_file or "the loaded parameters"
    try:
        data = tomllib.loads(settings.params_toml)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"not a TOML parameter file: {e}", source) from None
    return params_from_dict(data, source=source)


def reconstruct_params(values, base: Params | None) -> Params | None:
    """``base`` with the shown parameters of ``values`` (the Reconstruct operator or the scene
    settings: :data:`~.props.ENGINE_PARAMS`) when its ``use_custom_params`` is on.

    Returns None (the engine's defaults) when ``base`` is None and nothing is overridden.
    """
    if not values.use_custom_params:
        return base
    return with_settings(base or Params(), [f"{key}={_decimal(getattr(values, prop))}"
                                            for prop, key, _, _ in ENGINE_PARAMS])


def _summary(name, model, method, by_coll, seconds) -> str:
    counts = ", ".join(f"{len(v)} {k.lower()}" for k, v in sorted(by_coll.items()) if k != "Cells")
    return f"Reconstructed {name} ({model.provenance.method or method}): {counts} in {seconds:.1f} s"


_SCENE_SETTINGS = (("method", "method"), ("seed", "reconstruct_seed"),
                   ("use_custom_params", "use_custom_params"),
                   *((prop, prop) for prop, _, _, _ in ENGINE_PARAMS))
"""(operator property, scene setting) pairs Reconstruct takes from the panel."""


class INDOOR_OT_reconstruct(bpy.types.Operator):
    """Reconstruct spaces, walls and their topology from the active scan"""

    bl_idname = "indoor.reconstruct"
    bl_label = "Reconstruct"
    bl_options = {"REGISTER", "UNDO"}

    method: EnumProperty(name="Method", items=METHOD_ITEMS, default="auto")
    seed: IntProperty(name="Seed", default=0, min=0, description="Same seed, same model")
    use_custom_params: BoolProperty(name="Set parameters", default=False,
                                    description="Override the key parameters below")
    __annotations__.update(engine_param_properties())

    @classmethod
    def poll(cls, context):
        return bridge.is_point_mesh(context.active_object)

    def _take_scene_settings(self, context):
        """The one place the panel's settings become this run's (those not set by the caller)."""
        settings = getattr(context.scene, "indoor", None)
        if settings is None:
            return
        for mine, theirs in _SCENE_SETTINGS:
            if not self.properties.is_property_set(mine):
                setattr(self, mine, getattr(settings, theirs))

    def invoke(self, context, event):
        """Interactive run: the engine works in a thread (:class:`~engine.background.ReconstructJob`),
        a timer drives the progress bar, Esc (or the panel's Cancel) stops it; the objects are
        built on the main thread when it finishes. Without a window (background): :meth:`execute`."""
        if bpy.app.background or context.window is None:
            return self.execute(context)
        if running_job() is not None:
            self.report({"WARNING"}, "a reconstruction is already running")
            return {"CANCELLED"}
        self._take_scene_settings(context)
        obj = context.active_object
        with engine_call(self, context, obj.name, progress_bar=False) as call:
            cloud = bridge.object_to_cloud(obj)
            params = reconstruct_params(self, scene_params(context))
        if call.failed:
            return {"CANCELLED"}
        self._object_name = obj.name
        self._job = ReconstructJob(cloud, self.method, self.seed, params=params).start()
        _current_job[:] = [self._job]
        wm = context.window_manager
        wm.progress_begin(0, 1000)
        self._timer = wm.event_timer_add(TIMER_STEP, window=context.window)
        wm.modal_handler_add(self)
        settings = getattr(context.scene, "indoor", None)
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
            eta = job.eta  # "~N s left" once enough is done to extrapolate
            settings.progress, settings.progress_text = job.fraction, f"{job.message} ({eta})" if eta else job.message
        if job.running:
            return {"RUNNING_MODAL"}
        self._finish(context)
        if job.cancelled:
            self.report({"WARNING"},
                        f"Reconstruction of {self._object_name} cancelled; the scene is unchanged")
            return {"CANCELLED"}
        with engine_call(self, context, self._object_name, progress_bar=False) as call:
            model = job.outcome()  # the worker's error, raised here
            by_coll = bridge.model_to_objects(model, scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        show_model_change(self, context, model)
        self.report({"INFO"}, _summary(self._object_name, model, self.method, by_coll, job.seconds))
        return {"FINISHED"}

    def execute(self, context):
        self._take_scene_settings(context)
        obj = context.active_object
        t0 = time.perf_counter()
        with engine_call(self, context, obj.name) as call:
            cloud = bridge.object_to_cloud(obj)
            params = reconstruct_params(self, scene_params(context))
            model = reconstruct(cloud, self.method, params=params, rng=self.seed, progress=call.progress)
            by_coll = bridge.model_to_objects(model, scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        show_model_change(self, context, model)
        self.report({"INFO"}, _summary(obj.name, model, self.method, by_coll, time.perf_counter() - t0))
        return {"FINISHED"}


class INDOOR_OT_cancel_reconstruct(bpy.types.Operator):
    """Stop the running reconstruction (the scene stays as it was)"""

    bl_idname = "indoor.cancel_reconstruct"
    bl_label = "Cancel"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return running_job() is not None

    def execute(self, context):
        running_job().cancel()
        return {"FINISHED"}


class INDOOR_OT_load_parameters(bpy.types.Operator, ImportHelper):
    """Load reconstruction parameters from a TOML file (Save parameters' or ``indoor params``' format)"""

    bl_idname = "indoor.load_parameters"
    bl_label = "Load Parameters"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".toml"
    filter_glob: StringProperty(default="*.toml", options={"HIDDEN"})

    def execute(self, context):
        settings = scene_settings(self, context)
        if settings is None:
            return {"CANCELLED"}
        path = bpy.path.abspath(self.filepath)
        with engine_call(self, context, path, progress_bar=False) as call:
            params = load_params(path)
            text = params_to_toml(params)
            shown = {prop: _param_value(params, key) for prop, key, _, _ in ENGINE_PARAMS}
        if call.failed:
            return {"CANCELLED"}
        settings.params_toml, settings.params_file = text, path
        for prop, value in shown.items():  # the panel shows the loaded values
            if value is not None:
                setattr(settings, prop, value)
        self.report({"INFO"}, f"Loaded parameters from {os.path.basename(path)}")
        return {"FINISHED"}


class INDOOR_OT_save_parameters(bpy.types.Operator, ExportHelper):
    """Save the parameters Reconstruct would use (loaded ones and the panel's) as a TOML file"""

    bl_idname = "indoor.save_parameters"
    bl_label = "Save Parameters"
    bl_options = {"REGISTER"}

    filename_ext = ".toml"
    filter_glob: StringProperty(default="*.toml", options={"HIDDEN"})

    def execute(self, context):
        settings = scene_settings(self, context)
        if settings is None:
            return {"CANCELLED"}
        path = bpy.path.abspath(self.filepath)
        with engine_call(self, context, path, progress_bar=False) as call:
            save_params(reconstruct_params(settings, scene_params(context)) or Params(), path)
        if call.failed:
            return {"CANCELLED"}
        self.report({"INFO"}, f"Saved parameters to {path}")
        return {"FINISHED"}
