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

__all__ = ["MODEL_COLLECTION", "TYPE_COLLECTIONS", "CELLS_COLLECTION", "TYPE_COLORS", "STYLE_COLORS",
           "STYLE_MATERIALS", "SHAPE_PROP", "model_objects", "model_to_objects", "apply_edit",
           "restore_previous", "shape_ids_of", "model_matrix", "to_model_frame", "shape_style",
           "element_label"]

MODEL_COLLECTION = "Indoor Model"
"""Parent collection of a reconstructed model's collections."""
TYPE_COLLECTIONS = {"interior": "Spaces", "wall": "Walls", "exterior": "Exterior", "door": "Doors",
                    "window": "Windows", "slab": "Slabs", "none": "Cells"}
"""Collection of each active shape type; inactive shapes (cells, sub-spaces, the method's own
walls and exteriors under the element runs) go to "Cells". All are made for every model, even
empty (a model without an exterior still has its Exterior collection)."""
CELLS_COLLECTION = "Cells"
"""Hidden collection of the inactive shapes (cells and sub-spaces of merged spaces)."""
TYPE_COLORS = {"interior": (0.25, 0.60, 0.95, 0.35), "wall": (0.80, 0.78, 0.74, 1.0),
               "exterior": (0.35, 0.80, 0.40, 0.25), "door": (0.75, 0.45, 0.20, 1.0),
               "window": (0.62, 0.85, 0.97, 0.30), "slab": (0.55, 0.55, 0.58, 1.0),
               "none": (0.6, 0.6, 0.6, 0.2)}
"""Linear RGBA per shape type (viewport object colour and material); spaces and windows
(glass) are see-through."""
STYLE_COLORS = {"wall_external": (0.62, 0.36, 0.26, 1.0), "opening": (0.95, 0.70, 0.25, 0.45)}
"""Linear RGBA of the element styles that differ from their type's: exterior walls (brick
red, interior ones stay light grey) and doorless openings (see-through amber)."""
STYLE_MATERIALS = {"wall_external": "Indoor Exterior Wall", "opening": "Indoor Opening"}
"""Material name of each style of :data:`STYLE_COLORS` (the others: "Indoor <Type>")."""
SHAPE_PROP = "indoor_shape_id"
"""Custom property on a shape object: the id of its :class:`~engine.model.Shape`."""
_RESERVED = {"shape_id", "type", "storey"}
"""Attribute keys not copied to ``indoor_<key>`` (the object's own properties)."""
_LIST_PROPS = ("spaces", "sides")
"""List attributes copied as one comma-separated text (ids; None → "")."""


def model_matrix(model) -> Matrix:
    """``model.transform`` as a mathutils Matrix (model frame → scene frame, offset removed)."""
    return Matrix(np.asarray(model.transform, dtype=np.float64).tolist())


def to_model_frame(model, point) -> np.ndarray:
    """(3,) float64: a scene-frame point (e.g. the 3D cursor, metres) in the model frame."""
    return from_input_frame(np.asarray(point, dtype=np.float64).reshape(1, 3), model.transform)[0]


def shape_style(shape) -> str:
    """How a shape is drawn: its type's value, or "wall_external" (a wall with ``external``
    True) or "opening" (a DOOR of kind "opening")."""
    kind = shape.type.value
    if kind == "wall" and shape.attributes.get("external"):
        return "wall_external"
    if kind == "door" and shape.attributes.get("kind") == "opening":
        return "opening"
    return kind


def _style_color(style: str):
    return STYLE_COLORS.get(style) or TYPE_COLORS.get(style, TYPE_COLORS["none"])


def _type_material(style: str):
    name = STYLE_MATERIALS.get(style, f"Indoor {style.capitalize()}")
    mat = bpy.data.materials.get(name)
    if mat is not None and mat.library is None:
        return mat
    mat = bpy.data.materials.new(name)
    rgba = _style_color(style)
    mat.diffuse_color = rgba
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*rgba[:3], 1.0)
    bsdf.inputs["Alpha"].default_value = rgba[3]
    if style == "window":  # glass: clear, smooth, refracting
        for key, value in (("Transmission Weight", 1.0), ("Transmission", 1.0), ("Roughness", 0.05),
                           ("IOR", 1.45)):
            if key in bsdf.inputs:
                bsdf.inputs[key].default_value = value
    if rgba[3] < 1.0:
        if hasattr(mat, "surface_render_method"):  # 4.2+
            mat.surface_render_method = "BLENDED"
    return mat


def element_label(obj) -> str:
    """One line about a building-element object from its custom properties (the Review panel's):
    a wall's kind, thickness and height; an opening's size, sill and wall; a slab's kind and
    thickness. "" for other objects."""
    kind = obj.get("indoor_type")
    if kind == "wall" and "indoor_thickness" in obj:
        text = f"{'Exterior' if obj.get('indoor_external') else 'Interior'} wall, " \
               f"{100 * obj['indoor_thickness']:.0f} cm"
        if "indoor_thickness_measured" in obj:
            text += " (measured)" if obj["indoor_thickness_measured"] else " (assumed)"
        if "indoor_height" in obj:
            text += f", {obj['indoor_height']:.2f} m high"
        return text
    if kind in ("door", "window") and "indoor_width" in obj:
        what = {"opening": "Opening (no door)", "window": "Window"}.get(obj.get("indoor_kind"), "Door")
        text = f"{what} {obj['indoor_width']:.2f} x {obj.get('indoor_height', 0.0):.2f} m"
        if obj.get("indoor_sill"):
            text += f", sill {obj['indoor_sill']:.2f} m"
        if obj.get("indoor_parent"):
            text += f" in {obj['indoor_parent']}"
        return text
    if kind == "slab" and "indoor_kind" in obj:
        return f"{str(obj['indoor_kind']).capitalize()} slab, {100 * obj.get('indoor_thickness', 0.0):.0f} cm"
    return ""


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
    style = shape_style(shape)
    mesh.materials.append(_type_material(style))
    obj = bpy.data.objects.new(shape.name or shape.id, mesh)
    obj.matrix_world = matrix
    obj[SHAPE_PROP] = shape.id
    obj["indoor_type"] = kind
    obj["indoor_storey"] = int(shape.storey)
    for k, v in shape.support.items():
        obj["indoor_" + k] = float(v)
    _element_props(obj, shape)
    obj.color = _style_color(style)
    if obj.color[3] < 1.0:
        obj.show_transparent = True
    return obj


def _element_props(obj, shape) -> None:
    """The shape's scalar attributes as ``indoor_<key>`` properties (a wall's ``external``,
    ``thickness``; an opening's ``width``, ``height``, ``sill``, ``kind``; a slab's ``kind``),
    its ``spaces`` / ``sides`` as comma-separated ids, and ``indoor_parent``."""
    for key, value in shape.attributes.items():
        if key in _RESERVED:
            continue
        if isinstance(value, (bool, str)):
            obj["indoor_" + key] = value
        elif isinstance(value, (int, np.integer)):
            obj["indoor_" + key] = int(value) if abs(int(value)) < 2 ** 31 else float(value)
        elif isinstance(value, (float, np.floating)) and np.isfinite(value):
            obj["indoor_" + key] = float(value)
        elif key in _LIST_PROPS and isinstance(value, (list, tuple)):
            obj["indoor_" + key] = ", ".join("" if v is None else str(v) for v in value)
    if shape.parent is not None:
        obj["indoor_parent"] = str(shape.parent)


def model_to_objects(model, *, scene=None) -> dict:
    """Build one mesh object per shape of a :class:`~engine.model.BuildingModel`.

    Active shapes go to the collections Spaces, Walls, Exterior, Doors, Windows, Slabs (by
    type) under "Indoor Model"; inactive ones (cells, sub-spaces, the method's walls under
    the wall runs) to the hidden "Cells". Every one of these collections is made, empty or
    not. Exterior walls and doorless openings get their own colour and material
    (:func:`shape_style`), windows a glass one. Each object's matrix is ``model.transform``
    so shapes sit on the scan (same frame as the point mesh: offset removed). Custom
    properties: ``indoor_shape_id``, ``indoor_type``, ``indoor_storey``, the shape's support
    figures and scalar attributes (``indoor_external``, ``indoor_width``, ...) and
    ``indoor_parent``. The model itself is stored as JSON in the text "Indoor Model.json".
    A previous model is replaced; on failure the scene is left as it was.

    Returns
    -------
    dict of str -> list of bpy.types.Object, by collection name (every collection, empty
    ones with []).
    """
    scene = scene or bpy.context.scene
    old = model_objects(scene)
    names: list = []
    with undo_on_failure(scene):
        top = ensure_collection(MODEL_COLLECTION, scene)
        colls = {}
        for coll_name in dict.fromkeys(TYPE_COLLECTIONS.values()):
            coll = top.children.get(coll_name)
            if coll is None:
                coll = bpy.data.collections.new(coll_name)
                top.children.link(coll)
                if coll_name == CELLS_COLLECTION:
                    coll.hide_viewport = True
                    coll.hide_render = True
            colls[coll_name] = coll
        by_coll: dict = {name: [] for name in colls}
        matrix = model_matrix(model)
        for shape in model.shapes:
            kind = shape.type.value
            coll_name = TYPE_COLLECTIONS.get(kind, CELLS_COLLECTION) if shape.active else CELLS_COLLECTION
            obj = _shape_object(shape, matrix)
            colls[coll_name].objects.link(obj)
            by_coll[coll_name].append(obj)
            names.append((obj, shape.name or shape.id))
        _cut_openings(model, by_coll)
        json_text = model.to_json()
        write_model_text(json_text)
    remove_objects(old)
    for obj, wanted in names:  # take back the names the replaced model held
        if obj.name != wanted and bpy.data.objects.get(wanted) is None:
            obj.name = wanted
            obj.data.name = wanted
    return by_coll


def _cut_openings(model, by_coll: dict) -> None:
    """Each active wall shows the holes of its doors and windows: a Boolean (difference)
    modifier per opening, the opening's own object as the cutter (it stays visible in the
    hole, drawn as a door or as glass)."""
    walls = {o.get("indoor_shape_id"): o for o in by_coll.get(TYPE_COLLECTIONS["wall"], [])}
    for kind in ("door", "window"):
        for obj in by_coll.get(TYPE_COLLECTIONS[kind], []):
            wall = walls.get(obj.get("indoor_parent"))
            if wall is None:
                continue
            mod = wall.modifiers.new(f"Opening {obj.name}", "BOOLEAN")
            mod.operation = "DIFFERENCE"
            mod.solver = "EXACT"
            mod.object = obj


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
