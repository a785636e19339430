"""The Blender side of the extension: operators, panels, properties and the bridge.

``register()`` and ``unregister()`` are safe to call twice: a second ``register()`` first
undoes the first, a second ``unregister()`` does nothing.
"""
from __future__ import annotations

import bpy

from . import bridge, operators, panels, props

__all__ = ["register", "unregister", "bridge", "operators", "panels", "props", "CLASSES"]

CLASSES = (*props.CLASSES, *operators.CLASSES, *panels.CLASSES)
"""Every registered class, in registration order (property groups first)."""

_registered = False


def register():
    global _registered
    if _registered:
        unregister()
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.indoor = bpy.props.PointerProperty(type=props.INDOOR_PG_settings)
    bpy.types.TOPBAR_MT_file_import.append(operators.menu_import)
    bpy.types.TOPBAR_MT_file_export.append(operators.menu_export)
    _registered = True


def unregister():
    global _registered
    if not _registered:
        return
    operators.stop_running_job(timeout=10.0)  # a modal reconstruction: stop its worker thread
    bpy.types.TOPBAR_MT_file_import.remove(operators.menu_import)
    bpy.types.TOPBAR_MT_file_export.remove(operators.menu_export)
    if hasattr(bpy.types.Scene, "indoor"):
        del bpy.types.Scene.indoor
    for cls in reversed(CLASSES):
        if cls.is_registered:
            bpy.utils.unregister_class(cls)
    _registered = False
