"""The Blender side of the extension: operators, panels, properties and the bridge."""


def register():
    pass


def unregister():
    pass
