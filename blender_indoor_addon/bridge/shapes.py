"""Model objects: one mesh object per shape of a building model, in collections by type.

The shapes sit on the scan: each object's matrix is the model's transform (model frame →
scene frame, the scan's offset removed, as for the point mesh).
"""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ...engine.geometry.transforms import from_input_frame
from .collections import ensure_collection, remove_objects, undo_on_failure
from .storage import drop_previous, previous_model, push_history, write_model_text

__all__ = ["MODEL_COLLECTION", "TYPE_COLLECTIONS", "CELLS_COLLECTION", "TYPE_COLORS", "SHAPE_PROP",
           "model_objects", "model_to_objects", "apply_edit", "restore_previous", "shape_ids_of",
           "model_matrix", "to_model_frame"]

MODEL_COLLECTION = "Indoor Model"
"""Parent collection of a reconstructed model's collections."""
TYPE_COLLECTIONS = {"interior": "Spaces", "wall": "Walls", "exterior": "Exterior", "door": "Doors",
                    "slab": "Slabs", "none": "Cells"}
"""Collection of each active shape type; inactive shapes (cells, sub-spaces) go to "Cells"."""
CELLS_COLLECTION = "Cells"
"""Hidden collection of the inactive shapes (cells and sub-spaces of merged spaces)."""
TYPE_COLORS = {"interior": (0.25, 0.60, 0.95, 0.35), "wall": (0.80, 0.78, 0.74, 1.0),
               "exterior": (0.35, 0.80, 0.40, 0.25), "door": (0.75, 0.45, 0.20, 1.0),
               "slab": (0.55, 0.55, 0.58, 1.0), "none": (0.6, 0.6, 0.6, 0.2)}
"""Linear RGBA per shape type (viewport object colour and material); spaces are see-through."""
SHAPE_PROP = "indoor_shape_id"
"""Custom property on a shape object: the id of its :class:`~engine.model.Shape`."""


def model_matrix(model) -> Matrix:
    """``model.transform`` as a mathutils Matrix (model frame → scene frame, offset removed)."""
    return Matrix(np.asarray(model.transform, dtype=np.float64).tolist())


def to_model_frame(model, point) -> np.ndarray:
    """(3,) float64: a scene-frame point (e.g. the 3D cursor, metres) in the model frame."""
    return from_input_frame(np.asarray(point, dtype=np.float64).reshape(1, 3), model.transform)[0]


def _type_material(kind: str):
    name = f"Indoor {kind.capitalize()}"
    mat = bpy.data.materials.get(name)
    if mat is not None and mat.library is None:
        return mat
    mat = bpy.data.materials.new(name)
    rgba = TYPE_COLORS.get(kind, TYPE_COLORS["none"])
    mat.diffuse_color = rgba
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*rgba[:3], 1.0)
    bsdf.inputs["Alpha"].default_value = rgba[3]
    if rgba[3] < 1.0:
        if hasattr(mat, "surface_render_method"):  # 4.2+
            mat.surface_render_method = "BLENDED"
    return mat


def model_objects(scene=None) -> list:
    """The shape objects of the current model (those carrying ``indoor_shape_id``)."""
    scene = scene or bpy.context.scene
    top = scene.collection.children.get(MODEL_COLLECTION)
    if top is None:
        return []
    return [o for o in top.all_objects if SHAPE_PROP in o]


def _shape_object(shape, matrix):
    """One mesh object for ``shape`` (model-frame vertices, placed by ``matrix``), not linked yet."""
    kind = shape.type.value
    geom = shape.geometry
    mesh = bpy.data.meshes.new(shape.name or shape.id)
    mesh.from_pydata(np.asarray(geom.vertices, dtype=np.float64).tolist(), [],
                     [list(map(int, f)) for f in geom.faces])
    mesh.update()
    mesh.materials.append(_type_material(kind))
    obj = bpy.data.objects.new(shape.name or shape.id, mesh)
    obj.matrix_world = matrix
    obj[SHAPE_PROP] = shape.id
    obj["indoor_type"] = kind
    obj["indoor_storey"] = int(shape.storey)
    for k, v in shape.support.items():
        obj["indoor_" + k] = float(v)
    obj.color = TYPE_COLORS.get(kind, TYPE_COLORS["none"])
    if kind in ("interior", "exterior"):
        obj.show_transparent = True
    return obj


def model_to_objects(model, *, scene=None) -> dict:
    """Build one mesh object per shape of a :class:`~engine.model.BuildingModel`.

    Active shapes go to the collections Spaces, Walls, Exterior, Doors, Slabs (by type)
    under "Indoor Model"; inactive ones (cells, sub-spaces) to the hidden "Cells". Each
    object's matrix is ``model.transform`` so shapes sit on the scan (same frame as the
    point mesh: offset removed). Custom properties: ``indoor_shape_id``, ``indoor_type``,
    ``indoor_storey`` and the shape's support figures. The model itself is stored as
    JSON in the text "Indoor Model.json". A previous model is replaced; on failure the
    scene is left as it was.

    Returns
    -------
    dict of str -> list of bpy.types.Object, by collection name.
    """
    scene = scene or bpy.context.scene
    old = model_objects(scene)
    by_coll: dict = {}
    names: list = []
    with undo_on_failure(scene):
        top = ensure_collection(MODEL_COLLECTION, scene)
        matrix = model_matrix(model)
        for shape in model.shapes:
            kind = shape.type.value
            coll_name = TYPE_COLLECTIONS.get(kind, CELLS_COLLECTION) if shape.active else CELLS_COLLECTION
            coll = top.children.get(coll_name)
            if coll is None:
                coll = bpy.data.collections.new(coll_name)
                top.children.link(coll)
                if coll_name == CELLS_COLLECTION:
                    coll.hide_viewport = True
                    coll.hide_render = True
            obj = _shape_object(shape, matrix)
            coll.objects.link(obj)
            by_coll.setdefault(coll_name, []).append(obj)
            names.append((obj, shape.name or shape.id))
        json_text = model.to_json()
        write_model_text(json_text)
    remove_objects(old)
    for obj, wanted in names:  # take back the names the replaced model held
        if obj.name != wanted and bpy.data.objects.get(wanted) is None:
            obj.name = wanted
            obj.data.name = wanted
    return by_coll


def apply_edit(model, new_model, *, scene=None) -> dict:
    """Replace the stored ``model`` by ``new_model`` (an edit's result): the old JSON goes to
    the history and the shape objects are rebuilt (overlays are the caller's:
    :func:`~.overlays.refresh_overlays`). Returns :func:`model_to_objects`'s dict."""
    old_json = model.to_json()
    by_coll = model_to_objects(new_model, scene=scene)
    push_history(old_json)
    return by_coll


def restore_previous(scene=None):
    """Rebuild the objects from the model before the last edit (and drop it from the history).

    Returns the restored :class:`~engine.model.BuildingModel`, or None when there is no
    history. This is the add-on's own "restore" path, independent of Blender's undo.
    """
    model = previous_model()
    if model is None:
        return None
    model_to_objects(model, scene=scene)
    drop_previous()
    return model


def shape_ids_of(objects) -> list[str]:
    """The shape ids (``indoor_shape_id``) of the given objects that carry one, in order."""
    return [str(o[SHAPE_PROP]) for o in objects if o is not None and SHAPE_PROP in o]
