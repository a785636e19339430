"""Indoor Reconstruction — Blender extension entry point.

The repository root is the extension. This file stays thin: it imports nothing from
Blender at import time and forwards register/unregister to ``blender_indoor_addon``.
"""


def register():
    from .blender_indoor_addon import register as _register

    _register()


def unregister():
    from .blender_indoor_addon import unregister as _unregister

    _unregister()
