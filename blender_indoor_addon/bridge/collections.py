"""Collections, removal of bridge-made objects, and undo of what a failing call created.

:func:`undo_on_failure` is the one undo mechanism of the add-on: the bridge's own builders
and the operators' engine calls (``operators.engine_call``) both use it, so a failure leaves
no object, mesh, curve, collection, material, node group, text or image behind.
"""
from __future__ import annotations

import contextlib

import bpy

__all__ = ["ensure_collection", "clear_collection", "remove_object", "remove_objects", "DataSnapshot",
           "undo_on_failure"]

_UNDONE = ("objects", "meshes", "curves", "collections", "materials", "node_groups", "texts", "images")
"""``bpy.data`` collections whose new datablocks a failing call removes (objects first)."""


def ensure_collection(name: str, scene: bpy.types.Scene | None = None):
    """The collection ``name`` linked under the scene's master collection (made when absent).

    Parameters
    ----------
    name : str
        Collection name.
    scene : bpy.types.Scene, optional
        Defaults to the context scene.
    """
    scene = scene or bpy.context.scene
    coll = scene.collection.children.get(name)
    if coll is not None:
        return coll
    coll = bpy.data.collections.get(name)
    if coll is None or coll.library is not None:
        coll = bpy.data.collections.new(name)
    scene.collection.children.link(coll)
    return coll


def remove_object(name: str) -> None:
    """Remove the object ``name`` and its curve or mesh when nothing else uses it (no-op when absent)."""
    obj = bpy.data.objects.get(name)
    if obj is None:
        return
    data = obj.data
    bpy.data.objects.remove(obj, do_unlink=True)
    if data is not None and data.users == 0:
        if isinstance(data, bpy.types.Curve):
            bpy.data.curves.remove(data)
        elif isinstance(data, bpy.types.Mesh):
            bpy.data.meshes.remove(data)


def remove_objects(objects) -> None:
    """Delete mesh objects made by the bridge and their meshes (those already gone are skipped)."""
    for obj in objects:
        try:
            mesh = obj.data
            bpy.data.objects.remove(obj, do_unlink=True)
            if mesh is not None and mesh.users == 0:
                bpy.data.meshes.remove(mesh)
        except ReferenceError:  # already gone
            pass


def clear_collection(name: str, scene=None) -> None:
    """Remove every object (and its now unused data) of the top-level collection ``name``."""
    scene = scene or bpy.context.scene
    coll = scene.collection.children.get(name)
    if coll is None:
        return
    for obj in list(coll.all_objects):
        remove_object(obj.name)


class DataSnapshot:
    """The datablocks of ``bpy.data`` (by pointer) and the scene's top-level collection links.

    :meth:`undo` removes what was made since (newest kinds first: objects before their
    data) and unlinks collections newly linked under the scene. Changes to datablocks that
    existed before are not undone.
    """

    def __init__(self, scene: bpy.types.Scene | None = None):
        self.scene = scene or bpy.context.scene
        self.ids = {kind: {i.as_pointer() for i in getattr(bpy.data, kind)} for kind in _UNDONE}
        self.links = {c.as_pointer() for c in self.scene.collection.children}

    def undo(self) -> None:
        """Remove every datablock made since the snapshot; unlink collections linked since."""
        try:
            for coll in list(self.scene.collection.children):
                if coll.as_pointer() not in self.links:
                    self.scene.collection.children.unlink(coll)
        except ReferenceError:  # the scene itself is gone
            pass
        for kind in _UNDONE:
            data = getattr(bpy.data, kind)
            for item in [i for i in data if i.as_pointer() not in self.ids[kind]]:
                try:
                    data.remove(item, do_unlink=True)
                except (ReferenceError, RuntimeError):  # already gone with its user
                    pass


@contextlib.contextmanager
def undo_on_failure(scene: bpy.types.Scene | None = None):
    """Run a block; when it raises, remove what it created (:class:`DataSnapshot`) and re-raise."""
    snapshot = DataSnapshot(scene)
    try:
        yield snapshot
    except BaseException:
        snapshot.undo()
        raise
