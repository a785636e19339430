"""The one place that turns engine results into Blender data.

Operators call an engine function and hand its result to a function here; nothing else in
the add-on creates meshes, attributes, collections, node groups or materials.

Point clouds become *point meshes*: mesh vertices (float32 coordinates, written in bulk
with ``foreach_set``) carrying POINT-domain attributes (``color``, ``intensity``,
``normal``, ``scan_index`` and every ``cloud.fields`` array), drawn as points by a Geometry
Nodes "Mesh to Points" modifier whose material reads the ``color`` attribute. The modifier
has a *Display ratio* input that draws a random subset of the points: the mesh always keeps
every point.
"""
from __future__ import annotations

import logging

import bpy
import numpy as np

from ..engine.errors import printable

log = logging.getLogger(__name__)

__all__ = [
    "SCAN_COLLECTION",
    "POINTS_NODE_GROUP",
    "OFFSET_PROP",
    "SOURCE_PROP",
    "ensure_collection",
    "points_node_group",
    "points_material",
    "point_cloud_to_object",
    "object_points",
    "set_display",
    "add_height_colors",
    "remove_objects",
    "object_to_cloud",
    "model_to_objects",
    "model_objects",
    "stored_model",
    "push_history",
    "history_length",
    "restore_previous",
    "apply_edit",
    "shape_ids_of",
    "to_model_frame",
    "graph_to_curve",
    "remove_graph",
    "graph_shown",
    "path_to_curve",
    "spline_points",
    "refresh_overlays",
    "patches_to_objects",
    "change_overlay",
    "set_change_colors",
    "evaluation_overlay",
]

SCAN_COLLECTION = "Scan"
"""Name of the collection that receives imported scans."""
POINTS_NODE_GROUP = "Indoor Points"
"""Name of the Geometry Nodes group that draws a point mesh as points."""
POINTS_MODIFIER = "Indoor Points"
"""Name of the modifier that applies :data:`POINTS_NODE_GROUP` on a scan object."""
MATERIAL_COLOR = "Indoor Scan (colour)"
"""Material for scans with a ``color`` attribute: reads it through an Attribute node."""
MATERIAL_PLAIN = "Indoor Scan"
"""Material for scans without colour: a neutral grey shaded by the point normals."""
OFFSET_PROP = "indoor_offset"
"""Custom property (3 floats, metres) on a scan object: original = vertex + offset."""
SOURCE_PROP = "indoor_source"
"""Custom property on a scan object: the path of the scan file ("" when built in memory)."""
COUNT_PROP = "indoor_points"
"""Custom property on a scan object: the number of points (vertices) of the scan."""

PLAIN_COLOR = (0.62, 0.64, 0.68, 1.0)
"""Linear RGBA of scans without colour (viewport and shader)."""

# Inputs of the node group, by name (their identifiers are looked up at run time).
IN_RATIO = "Display ratio"
IN_RADIUS = "Point radius"
IN_MATERIAL = "Material"
IN_SEED = "Seed"
IN_USE_SECTION = "Section"
IN_SECTION_Z = "Section height"

# Attribute names Blender reserves on meshes; cloud fields with such names get a prefix.
_RESERVED = {"position", "material_index", "sharp_face", "sharp_edge", "crease_vert", "crease_edge",
             "id", "radius", "color"}


# --------------------------------------------------------------------------- collections
def ensure_collection(name: str, scene: bpy.types.Scene | None = None, created: list | None = None):
    """The collection ``name`` linked under the scene's master collection (made when absent).

    Parameters
    ----------
    name : str
        Collection name.
    scene : bpy.types.Scene, optional
        Defaults to the context scene.
    created : list, optional
        Receives ``("collection", coll)`` or ``("link", coll)`` entries for what was made,
        so a failing caller can undo it (see :func:`_undo_created`).
    """
    scene = scene or bpy.context.scene
    coll = scene.collection.children.get(name)
    if coll is not None:
        return coll
    coll = bpy.data.collections.get(name)
    if coll is None or coll.library is not None:
        coll = bpy.data.collections.new(name)
        if created is not None:
            created.append(("collection", coll))
    elif created is not None:
        created.append(("link", coll))
    scene.collection.children.link(coll)
    return coll


def _undo_created(created: list, scene: bpy.types.Scene) -> None:
    """Remove what :func:`point_cloud_to_object` made before it failed (newest first)."""
    for kind, item in reversed(created):
        try:
            if kind == "object":
                bpy.data.objects.remove(item, do_unlink=True)
            elif kind == "mesh":
                bpy.data.meshes.remove(item, do_unlink=True)
            elif kind == "collection":
                bpy.data.collections.remove(item, do_unlink=True)
            elif kind == "link":
                scene.collection.children.unlink(item)
            elif kind == "node_group":
                bpy.data.node_groups.remove(item, do_unlink=True)
            elif kind == "material":
                bpy.data.materials.remove(item, do_unlink=True)
            elif kind == "text":
                bpy.data.texts.remove(item, do_unlink=True)
        except (ReferenceError, RuntimeError):  # already gone
            pass


# --------------------------------------------------------------------------- node group
def _socket(node_group, name, in_out="INPUT"):
    for item in node_group.interface.items_tree:
        if item.item_type == "SOCKET" and item.in_out == in_out and item.name == name:
            return item
    return None


def points_node_group(created: list | None = None):
    """The Geometry Nodes group "Indoor Points" (made once per file).

    Group inputs: Geometry (the point mesh), Display ratio (0–1, share of points drawn,
    chosen at random by point index; the mesh keeps every point), Point radius (metres),
    Material, Seed, Section (bool) and Section height (metres, object frame: with Section
    on, points above it are not drawn, to look into rooms from above). Output: a point
    cloud with every POINT attribute of the mesh.
    """
    ng = bpy.data.node_groups.get(POINTS_NODE_GROUP)
    if ng is not None and ng.bl_idname == "GeometryNodeTree" and _socket(ng, IN_SECTION_Z) is not None:
        return ng
    ng = bpy.data.node_groups.new(POINTS_NODE_GROUP, "GeometryNodeTree")
    if created is not None:
        created.append(("node_group", ng))
    iface = ng.interface
    iface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    iface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    s = iface.new_socket(IN_RATIO, in_out="INPUT", socket_type="NodeSocketFloat")
    s.subtype, s.default_value, s.min_value, s.max_value = "FACTOR", 1.0, 0.0, 1.0
    s.description = "Share of the points drawn in the viewport and renders; the data keeps every point"
    s = iface.new_socket(IN_RADIUS, in_out="INPUT", socket_type="NodeSocketFloat")
    s.subtype, s.default_value, s.min_value = "DISTANCE", 0.01, 0.0
    s.description = "Radius of each drawn point, metres"
    iface.new_socket(IN_MATERIAL, in_out="INPUT", socket_type="NodeSocketMaterial")
    s = iface.new_socket(IN_SEED, in_out="INPUT", socket_type="NodeSocketInt")
    s.default_value = 0
    s.description = "Seed of the random display subset"
    s = iface.new_socket(IN_USE_SECTION, in_out="INPUT", socket_type="NodeSocketBool")
    s.default_value = False
    s.description = "Hide the points above the section height (look into rooms from above)"
    s = iface.new_socket(IN_SECTION_Z, in_out="INPUT", socket_type="NodeSocketFloat")
    s.subtype, s.default_value = "DISTANCE", 2.0
    s.description = "Height above which points are hidden when Section is on (object frame, metres)"

    nodes, links = ng.nodes, ng.links
    gin = nodes.new("NodeGroupInput")
    gout = nodes.new("NodeGroupOutput")
    rnd = nodes.new("FunctionNodeRandomValue")
    rnd.data_type = "BOOLEAN"
    to_points = nodes.new("GeometryNodeMeshToPoints")
    to_points.mode = "VERTICES"
    set_mat = nodes.new("GeometryNodeSetMaterial")
    for i, node in enumerate((gin, rnd, to_points, set_mat, gout)):
        node.location = (220 * i - 440, 0)

    def out(node, ident):
        return next(s for s in node.outputs if s.identifier == ident)

    def inp(node, ident):
        return next(s for s in node.inputs if s.identifier == ident)

    links.new(gin.outputs["Geometry"], inp(to_points, "Mesh"))
    links.new(gin.outputs[IN_RATIO], inp(rnd, "Probability"))
    links.new(gin.outputs[IN_SEED], inp(rnd, "Seed"))
    # selection = random(ratio) AND (NOT section OR z <= section height)
    pos = nodes.new("GeometryNodeInputPosition")
    sep = nodes.new("ShaderNodeSeparateXYZ")
    below = nodes.new("FunctionNodeCompare")
    below.data_type, below.operation = "FLOAT", "LESS_EQUAL"
    keep = nodes.new("FunctionNodeBooleanMath")
    keep.operation = "IMPLY"  # section -> below
    both = nodes.new("FunctionNodeBooleanMath")
    both.operation = "AND"
    for i, node in enumerate((pos, sep, below, keep, both)):
        node.location = (220 * i - 660, -300)
    links.new(pos.outputs["Position"], sep.inputs[0])
    links.new(sep.outputs["Z"], inp(below, "A"))
    links.new(gin.outputs[IN_SECTION_Z], inp(below, "B"))
    links.new(gin.outputs[IN_USE_SECTION], keep.inputs[0])
    links.new(below.outputs["Result"], keep.inputs[1])
    links.new(out(rnd, "Value_003"), both.inputs[0])
    links.new(keep.outputs[0], both.inputs[1])
    links.new(both.outputs[0], inp(to_points, "Selection"))
    links.new(gin.outputs[IN_RADIUS], inp(to_points, "Radius"))
    links.new(to_points.outputs["Points"], inp(set_mat, "Geometry"))
    links.new(gin.outputs[IN_MATERIAL], inp(set_mat, "Material"))
    links.new(set_mat.outputs["Geometry"], gout.inputs["Geometry"])
    return ng


# --------------------------------------------------------------------------- materials
def points_material(with_color: bool, created: list | None = None):
    """The material of point meshes (made once per file).

    With ``with_color`` its base colour is the ``color`` POINT attribute (an Attribute node
    of type Geometry); otherwise a neutral grey. Both are rough and emit a little so points
    stay readable from any side.
    """
    name = MATERIAL_COLOR if with_color else MATERIAL_PLAIN
    mat = bpy.data.materials.get(name)
    if mat is not None and mat.library is None:
        return mat
    mat = bpy.data.materials.new(name)
    if created is not None:
        created.append(("material", mat))
    mat.use_nodes = True
    mat.diffuse_color = PLAIN_COLOR
    nt = mat.node_tree
    bsdf = nt.nodes.get("Principled BSDF")
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Emission Strength"].default_value = 0.3
    if with_color:
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.attribute_type = "GEOMETRY"
        attr.attribute_name = "color"
        attr.location = (-300, 200)
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Emission Color"])
    else:
        bsdf.inputs["Base Color"].default_value = PLAIN_COLOR
        bsdf.inputs["Emission Color"].default_value = PLAIN_COLOR
    return mat


# --------------------------------------------------------------------------- point meshes
def _attribute(mesh, name, data_type):
    attr = mesh.attributes.get(name)
    if attr is not None:
        mesh.attributes.remove(attr)
    return mesh.attributes.new(name, data_type, "POINT")


def _write_field(mesh, name, values):
    """Write one per-point array as a POINT attribute; returns the attribute names made."""
    a = np.asarray(values)
    n = len(mesh.vertices)
    if name in _RESERVED or name.startswith("."):
        name = "field_" + name
    if a.ndim == 2 and a.shape[1] == 3 and a.dtype.kind == "f":
        attr = _attribute(mesh, name, "FLOAT_VECTOR")
        attr.data.foreach_set("vector", np.ascontiguousarray(a, dtype=np.float32).ravel())
        return [name]
    if a.ndim == 1:
        if a.dtype.kind in "iub":
            i32 = np.iinfo(np.int32)
            if a.size and a.dtype.kind in "iu" and (a.max() > i32.max or a.min() < i32.min):
                attr = _attribute(mesh, name, "FLOAT")  # does not fit an INT attribute
                attr.data.foreach_set("value", a.astype(np.float32))
            else:
                attr = _attribute(mesh, name, "INT")
                attr.data.foreach_set("value", np.ascontiguousarray(a, dtype=np.int32))
            return [name]
        if a.dtype.kind == "f":
            attr = _attribute(mesh, name, "FLOAT")
            attr.data.foreach_set("value", np.ascontiguousarray(a, dtype=np.float32))
            return [name]
    if a.ndim == 2 and a.dtype.kind in "iubf":
        names = []
        for j in range(a.shape[1]):  # a loop over columns, not points
            names += _write_field(mesh, f"{name}_{j}", a[:, j])
        return names
    log.warning("field %r with shape %s and dtype %s cannot become a Blender attribute; skipped",
                name, a.shape, a.dtype)
    assert len(mesh.vertices) == n
    return []


def _fill_mesh(mesh, cloud) -> list[str]:
    n = len(cloud)
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", np.ascontiguousarray(cloud.xyz, dtype=np.float32).ravel())
    names = []
    if cloud.colors is not None:
        rgba = np.empty((n, 4), dtype=np.float32)
        np.multiply(cloud.colors, np.float32(1.0 / 255.0), out=rgba[:, :3], casting="unsafe")
        rgba[:, 3] = 1.0
        attr = _attribute(mesh, "color", "BYTE_COLOR")
        attr.data.foreach_set("color_srgb", rgba.ravel())
        mesh.color_attributes.active_color = attr
        mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
        names.append("color")
    if cloud.intensity is not None:
        attr = _attribute(mesh, "intensity", "FLOAT")
        attr.data.foreach_set("value", cloud.intensity)
        names.append("intensity")
    if cloud.normals is not None:
        attr = _attribute(mesh, "normal", "FLOAT_VECTOR")
        attr.data.foreach_set("vector", cloud.normals.ravel())
        names.append("normal")
    if cloud.scan_index is not None:
        attr = _attribute(mesh, "scan_index", "INT")
        attr.data.foreach_set("value", cloud.scan_index)
        names.append("scan_index")
    for key in sorted(cloud.fields):
        names += _write_field(mesh, key, cloud.fields[key])
    mesh.update()
    return names


def point_cloud_to_object(cloud, name: str | None = None, *, collection: str = SCAN_COLLECTION,
                          display_ratio: float = 1.0, point_radius: float = 0.01, seed: int = 0,
                          scene: bpy.types.Scene | None = None):
    """Create a point-mesh object for a :class:`~engine.pointcloud.PointCloud`.

    Parameters
    ----------
    cloud : PointCloud
        ``xyz`` (n, 3) float64 metres (offset removed) becomes float32 vertex coordinates;
        ``colors`` (n, 3) uint8 → ``color`` BYTE_COLOR (sRGB); ``intensity`` (n,) → FLOAT;
        ``normals`` (n, 3) → ``normal`` FLOAT_VECTOR; ``scan_index`` (n,) → INT; each
        ``fields[k]``: floats → FLOAT, integers/booleans → INT, (n, 3) floats →
        FLOAT_VECTOR, other (n, k) → ``k_0``...; all POINT domain.
    name : str, optional
        Object and mesh name; defaults to the file name of ``cloud.source`` or "Scan".
    collection : str
        Collection (under the scene collection) that receives the object; made if absent.
    display_ratio : float
        Share of the points drawn (0–1); the mesh keeps all points.
    point_radius : float
        Radius of each drawn point, metres.
    seed : int
        Seed of the random display subset.
    scene : bpy.types.Scene, optional
        Defaults to the context scene.

    Returns
    -------
    bpy.types.Object
        The new object; its custom properties hold the offset (``indoor_offset``, metres;
        original coordinates = vertex + offset), the source path and the point count.

    On any failure everything this call created is removed again and the error re-raised.
    """
    import os

    scene = scene or bpy.context.scene
    if name is None:
        name = os.path.splitext(os.path.basename(cloud.source))[0] if cloud.source else "Scan"
    created: list = []
    try:
        coll = ensure_collection(collection, scene, created)
        mesh = bpy.data.meshes.new(name)
        created.append(("mesh", mesh))
        names = _fill_mesh(mesh, cloud)
        obj = bpy.data.objects.new(name, mesh)
        created.append(("object", obj))
        obj[OFFSET_PROP] = [float(v) for v in cloud.offset]
        obj[SOURCE_PROP] = printable(cloud.source) if cloud.source else ""  # ID strings are UTF-8
        obj[COUNT_PROP] = int(len(cloud))
        obj["indoor_attributes"] = names
        ng = points_node_group(created)
        mat = points_material(cloud.colors is not None, created)
        mesh.materials.append(mat)
        mod = obj.modifiers.new(POINTS_MODIFIER, "NODES")
        mod.node_group = ng
        set_display(obj, display_ratio=display_ratio, point_radius=point_radius, seed=seed, material=mat)
        coll.objects.link(obj)
    except BaseException:
        _undo_created(created, scene)
        raise
    return obj


def remove_objects(objects) -> None:
    """Delete point-mesh objects made by :func:`point_cloud_to_object` and their meshes."""
    for obj in objects:
        try:
            mesh = obj.data
            bpy.data.objects.remove(obj, do_unlink=True)
            if mesh is not None and mesh.users == 0:
                bpy.data.meshes.remove(mesh)
        except ReferenceError:  # already gone
            pass


def set_display(obj, *, display_ratio: float | None = None, point_radius: float | None = None,
                seed: int | None = None, material=None, section: bool | None = None,
                section_z: float | None = None) -> None:
    """Change how a point mesh is drawn (its "Indoor Points" modifier inputs).

    ``section_z`` is in metres in the object frame (offset removed); ``section`` turns the
    cut on or off. Arguments left at None keep their current value.
    """
    mod = obj.modifiers.get(POINTS_MODIFIER)
    if mod is None or mod.node_group is None:
        raise ValueError(f"{obj.name} is not a point mesh made by the Indoor add-on")
    ng = mod.node_group
    values = {IN_RATIO: None if display_ratio is None else float(min(max(display_ratio, 0.0), 1.0)),
              IN_RADIUS: None if point_radius is None else float(point_radius),
              IN_SEED: None if seed is None else int(seed),
              IN_MATERIAL: material,
              IN_USE_SECTION: None if section is None else bool(section),
              IN_SECTION_Z: None if section_z is None else float(section_z)}
    for sock_name, value in values.items():
        if value is not None:
            mod[_socket(ng, sock_name).identifier] = value
    obj.update_tag()


def display_settings(obj) -> dict:
    """The current Display ratio / Point radius / Seed of a point mesh, by input name."""
    mod = obj.modifiers.get(POINTS_MODIFIER)
    if mod is None or mod.node_group is None:
        return {}
    return {n: mod[_socket(mod.node_group, n).identifier]
            for n in (IN_RATIO, IN_RADIUS, IN_SEED, IN_USE_SECTION, IN_SECTION_Z)}


def input_identifier(obj, name: str) -> str | None:
    """Identifier of the node-group input ``name`` on a point mesh (for ``layout.prop``)."""
    mod = obj.modifiers.get(POINTS_MODIFIER)
    if mod is None or mod.node_group is None:
        return None
    s = _socket(mod.node_group, name)
    return None if s is None else s.identifier


def is_point_mesh(obj) -> bool:
    """True for objects made by :func:`point_cloud_to_object`."""
    return obj is not None and obj.type == "MESH" and OFFSET_PROP in obj and \
        obj.modifiers.get(POINTS_MODIFIER) is not None


def object_points(obj) -> tuple[np.ndarray, np.ndarray]:
    """Read a point mesh back: ``(xyz, offset)``.

    Returns
    -------
    xyz : (n, 3) float64
        Vertex coordinates in metres in the object's local frame (offset removed).
    offset : (3,) float64
        The stored offset; original coordinates = ``xyz + offset``.
    """
    mesh = obj.data
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    offset = np.asarray(obj.get(OFFSET_PROP, (0.0, 0.0, 0.0)), dtype=np.float64).reshape(3)
    return co.reshape(-1, 3).astype(np.float64), offset


HEIGHT_COLOR = "height_color"
"""Name of the display colour attribute written by :func:`add_height_colors`."""
HEIGHT_RAMP = ((0.0, (0.18, 0.32, 0.75)), (0.35, (0.20, 0.70, 0.62)), (0.65, (0.95, 0.80, 0.30)),
               (1.0, (0.90, 0.35, 0.25)))
"""(position 0–1, sRGB colour) stops of the height ramp: blue floor → teal → yellow → red ceiling."""


def add_height_colors(obj, *, z_range: tuple[float, float] | None = None, make_active: bool = True) -> str:
    """Add a display colour attribute ``height_color`` that encodes each point's height.

    For scans without colour: Workbench (colour type "Attribute") and the viewport show the
    room's structure instead of a flat colour. The scan's own attributes are not touched.

    Parameters
    ----------
    obj : bpy.types.Object
        A point mesh.
    z_range : (float, float), optional
        Heights (metres, object frame) mapped to the ends of the ramp; default the 1st and
        99th percentile of the vertices' z.
    make_active : bool
        Make it the active and render colour attribute.

    Returns
    -------
    str
        The attribute name.
    """
    xyz, _ = object_points(obj)
    z = xyz[:, 2]
    if z_range is None:
        z_range = (float(np.percentile(z, 1)), float(np.percentile(z, 99))) if len(z) else (0.0, 1.0)
    lo, hi = z_range
    t = np.clip((z - lo) / max(hi - lo, 1e-9), 0.0, 1.0)
    stops = np.array([p for p, _ in HEIGHT_RAMP])
    cols = np.array([c for _, c in HEIGHT_RAMP], dtype=np.float64)
    rgba = np.ones((len(z), 4), dtype=np.float32)
    for k in range(3):  # a loop over channels
        rgba[:, k] = np.interp(t, stops, cols[:, k])
    mesh = obj.data
    attr = _attribute(mesh, HEIGHT_COLOR, "BYTE_COLOR")
    attr.data.foreach_set("color_srgb", rgba.ravel())
    if make_active:
        mesh.color_attributes.active_color = attr
        mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
    mesh.update()
    return HEIGHT_COLOR


# --------------------------------------------------------------------------- scan → engine
def object_to_cloud(obj):
    """A :class:`~engine.pointcloud.PointCloud` from a point mesh (the inverse of
    :func:`point_cloud_to_object` for coordinates, offset, colour, intensity, normals).

    ``xyz`` (n, 3) float64 metres are the float32 vertices (offset removed, object frame);
    the object's own transform is not applied.
    """
    from ..engine.pointcloud import PointCloud

    mesh = obj.data
    n = len(mesh.vertices)
    xyz, offset = object_points(obj)
    kw = {}
    attrs = mesh.attributes
    if "color" in attrs and attrs["color"].domain == "POINT":
        rgba = np.empty(n * 4, dtype=np.float32)
        attrs["color"].data.foreach_get("color_srgb", rgba)
        kw["colors"] = np.clip(np.rint(rgba.reshape(n, 4)[:, :3] * 255), 0, 255).astype(np.uint8)
    if "intensity" in attrs and attrs["intensity"].data_type == "FLOAT":
        v = np.empty(n, dtype=np.float32)
        attrs["intensity"].data.foreach_get("value", v)
        kw["intensity"] = v
    if "normal" in attrs and attrs["normal"].data_type == "FLOAT_VECTOR":
        v = np.empty(n * 3, dtype=np.float32)
        attrs["normal"].data.foreach_get("vector", v)
        kw["normals"] = v.reshape(n, 3)
    return PointCloud(xyz=xyz, offset=offset, source=str(obj.get(SOURCE_PROP, "")), **kw)


# --------------------------------------------------------------------------- model → objects
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
MODEL_TEXT = "Indoor Model.json"
"""Text datablock that keeps the model (``BuildingModel.to_json``) inside the .blend."""


def _type_material(kind: str, created: list):
    name = f"Indoor {kind.capitalize()}"
    mat = bpy.data.materials.get(name)
    if mat is not None and mat.library is None:
        return mat
    mat = bpy.data.materials.new(name)
    created.append(("material", mat))
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
    from mathutils import Matrix

    scene = scene or bpy.context.scene
    old = model_objects(scene)
    created: list = []
    by_coll: dict = {}
    names: list = []
    try:
        top = ensure_collection(MODEL_COLLECTION, scene, created)
        matrix = Matrix(np.asarray(model.transform, dtype=np.float64).tolist())
        for shape in model.shapes:
            kind = shape.type.value
            coll_name = TYPE_COLLECTIONS.get(kind, CELLS_COLLECTION) if shape.active else CELLS_COLLECTION
            coll = top.children.get(coll_name)
            if coll is None:
                coll = bpy.data.collections.new(coll_name)
                created.append(("collection", coll))
                top.children.link(coll)
                if coll_name == CELLS_COLLECTION:
                    coll.hide_viewport = True
                    coll.hide_render = True
            geom = shape.geometry
            mesh = bpy.data.meshes.new(shape.name or shape.id)
            created.append(("mesh", mesh))
            mesh.from_pydata(np.asarray(geom.vertices, dtype=np.float64).tolist(), [],
                             [list(map(int, f)) for f in geom.faces])
            mesh.update()
            mesh.materials.append(_type_material(kind, created))
            obj = bpy.data.objects.new(shape.name or shape.id, mesh)
            created.append(("object", obj))
            obj.matrix_world = matrix
            obj[SHAPE_PROP] = shape.id
            obj["indoor_type"] = kind
            obj["indoor_storey"] = int(shape.storey)
            for k, v in shape.support.items():
                obj["indoor_" + k] = float(v)
            obj.color = TYPE_COLORS.get(kind, TYPE_COLORS["none"])
            if kind in ("interior", "exterior"):
                obj.show_transparent = True
            coll.objects.link(obj)
            by_coll.setdefault(coll_name, []).append(obj)
            names.append((obj, shape.name or shape.id))
        text = bpy.data.texts.get(MODEL_TEXT)
        if text is None:
            text = bpy.data.texts.new(MODEL_TEXT)
            created.append(("text", text))
        json_text = model.to_json()
    except BaseException:
        _undo_created(created, scene)
        raise
    text.clear()
    text.write(json_text)
    remove_objects(old)
    for obj, wanted in names:  # take back the names the replaced model held
        if obj.name != wanted and bpy.data.objects.get(wanted) is None:
            obj.name = wanted
            obj.data.name = wanted
    return by_coll


def stored_model():
    """The model kept in the .blend by :func:`model_to_objects`, or None."""
    from ..engine.model import BuildingModel

    text = bpy.data.texts.get(MODEL_TEXT)
    if text is None or not text.as_string().strip():
        return None
    return BuildingModel.from_json(text.as_string())


# --------------------------------------------------------------------------- edit history
HISTORY_TEXT = "Indoor Model history.json"
"""Text datablock with the models replaced by edits (a JSON list of model JSON strings)."""
HISTORY_DEPTH = 20
"""How many previous models :func:`push_history` keeps."""


def _history() -> list:
    import json

    text = bpy.data.texts.get(HISTORY_TEXT)
    if text is None or not text.as_string().strip():
        return []
    return list(json.loads(text.as_string()))


def _write_history(items: list) -> None:
    import json

    text = bpy.data.texts.get(HISTORY_TEXT) or bpy.data.texts.new(HISTORY_TEXT)
    text.clear()
    text.write(json.dumps(items[-HISTORY_DEPTH:]))


def push_history(model_json: str) -> int:
    """Keep a model's JSON (before an edit) in the .blend; returns the history length."""
    items = _history()
    items.append(model_json)
    _write_history(items)
    return min(len(items), HISTORY_DEPTH)


def history_length() -> int:
    """Number of previous models :func:`restore_previous` can go back to."""
    return len(_history())


def restore_previous(scene=None):
    """Rebuild the objects from the model before the last edit (and drop it from the history).

    Returns the restored :class:`~engine.model.BuildingModel`, or None when there is no
    history. This is the add-on's own "restore" path, independent of Blender's undo.
    """
    from ..engine.model import BuildingModel

    items = _history()
    if not items:
        return None
    model = BuildingModel.from_json(items[-1])
    model_to_objects(model, scene=scene)
    _write_history(items[:-1])
    return model


def apply_edit(model, new_model, *, scene=None) -> dict:
    """Replace the stored ``model`` by ``new_model`` (an edit's result): the old JSON goes to
    the history, the shape objects are rebuilt and shown overlays of the topology refreshed;
    a drawn path (stale now) is removed. Returns :func:`model_to_objects`'s dict."""
    scene = scene or bpy.context.scene
    old_json = model.to_json()
    by_coll = model_to_objects(new_model, scene=scene)
    push_history(old_json)
    refresh_overlays(new_model, scene=scene)
    return by_coll


def shape_ids_of(objects) -> list[str]:
    """The shape ids (``indoor_shape_id``) of the given objects that carry one, in order."""
    return [str(o[SHAPE_PROP]) for o in objects if o is not None and SHAPE_PROP in o]


def model_matrix(model):
    """``model.transform`` as a mathutils Matrix (model frame → scene frame, offset removed)."""
    from mathutils import Matrix

    return Matrix(np.asarray(model.transform, dtype=np.float64).tolist())


def to_model_frame(model, point) -> np.ndarray:
    """(3,) float64: a scene-frame point (e.g. the 3D cursor, metres) in the model frame."""
    t = np.asarray(model.transform, dtype=np.float64)
    p = np.append(np.asarray(point, dtype=np.float64).reshape(3), 1.0)
    return (np.linalg.inv(t) @ p)[:3]


# --------------------------------------------------------------------------- overlays: curves
TOPOLOGY_COLLECTION = "Topology"
"""Collection of the graph and path curves."""
GRAPH_OBJECTS = {"adjacency": "Adjacency graph", "connectivity": "Connectivity graph"}
"""Curve object of each graph kind."""
PATH_OBJECT = "Shortest path"
"""Curve object of the last shortest path."""
OVERLAY_COLORS = {"adjacency": (0.95, 0.75, 0.15, 1.0), "connectivity": (0.15, 0.85, 0.35, 1.0),
                  "path": (0.95, 0.15, 0.15, 1.0)}
"""Linear RGBA of the curves."""
CURVE_BEVEL = {"adjacency": 0.03, "connectivity": 0.05, "path": 0.08}
"""Tube radius of each curve kind, metres."""
OVERLAY_MATERIAL = "Indoor Overlay"
"""Material of overlays: emits the object's colour (Object Info), so one material serves all."""


def overlay_material():
    """The material of overlay objects: colour = the object's ``color`` (made once per file)."""
    mat = bpy.data.materials.get(OVERLAY_MATERIAL)
    if mat is not None and mat.library is None:
        return mat
    mat = bpy.data.materials.new(OVERLAY_MATERIAL)
    mat.use_nodes = True
    nt = mat.node_tree
    bsdf = nt.nodes.get("Principled BSDF")
    info = nt.nodes.new("ShaderNodeObjectInfo")
    info.location = (-300, 200)
    nt.links.new(info.outputs["Color"], bsdf.inputs["Base Color"])
    nt.links.new(info.outputs["Color"], bsdf.inputs["Emission Color"])
    bsdf.inputs["Emission Strength"].default_value = 0.5
    nt.links.new(info.outputs["Alpha"], bsdf.inputs["Alpha"])
    if hasattr(mat, "surface_render_method"):  # 4.2+
        mat.surface_render_method = "BLENDED"
    return mat


def _remove_object(name: str) -> None:
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


def polylines_to_curve(name: str, lines, *, kind: str, matrix=None, collection: str = TOPOLOGY_COLLECTION,
                       scene=None):
    """One curve object ``name`` holding a POLY spline per polyline (replaces an old one).

    Parameters
    ----------
    lines : list of (k, 3) float64
        Point sequences, metres (model frame when ``matrix`` maps it to the scene).
    kind : str
        Key of :data:`OVERLAY_COLORS` / :data:`CURVE_BEVEL`.
    matrix : mathutils.Matrix, optional
        The object's world matrix.
    """
    scene = scene or bpy.context.scene
    _remove_object(name)
    coll = ensure_collection(collection, scene)
    cu = bpy.data.curves.new(name, "CURVE")
    cu.dimensions = "3D"
    cu.bevel_depth = CURVE_BEVEL.get(kind, 0.03)
    cu.bevel_resolution = 2
    for line in lines:
        pts = np.asarray(line, dtype=np.float64).reshape(-1, 3)
        sp = cu.splines.new("POLY")
        sp.points.add(len(pts) - 1)
        co = np.column_stack([pts, np.ones(len(pts))]).astype(np.float32)
        sp.points.foreach_set("co", co.ravel())
    cu.materials.append(overlay_material())
    obj = bpy.data.objects.new(name, cu)
    if matrix is not None:
        obj.matrix_world = matrix
    obj.color = OVERLAY_COLORS.get(kind, (1.0, 1.0, 1.0, 1.0))
    obj["indoor_overlay"] = kind
    coll.objects.link(obj)
    return obj


def spline_points(obj) -> list[np.ndarray]:
    """The points of each spline of a curve object: list of (k, 3) float64 (object frame)."""
    out = []
    for sp in obj.data.splines:
        co = np.empty(len(sp.points) * 4, dtype=np.float32)
        sp.points.foreach_get("co", co)
        out.append(co.reshape(-1, 4)[:, :3].astype(np.float64))
    return out


def graph_to_curve(model, kind: str, *, scene=None):
    """Draw the space-level ``kind`` graph ("adjacency" or "connectivity") of ``model``: a
    straight segment between the centres of every pair of related spaces (object
    :data:`GRAPH_OBJECTS` ``[kind]`` in the "Topology" collection). The edges are kept as
    the object's ``indoor_edges`` property ("a|b" per spline, in spline order)."""
    from ..engine.topology import space_graph

    g = space_graph(model, kind, "space")
    edges = sorted(tuple(sorted((a, b))) for a, b in g.edges)
    lines = [np.array([model[a].centroid, model[b].centroid]) for a, b in edges]
    obj = polylines_to_curve(GRAPH_OBJECTS[kind], lines, kind=kind, matrix=model_matrix(model), scene=scene)
    obj["indoor_edges"] = [f"{a}|{b}" for a, b in edges]
    return obj


def remove_graph(kind: str) -> None:
    """Remove the drawn ``kind`` graph (no-op when it is not drawn)."""
    _remove_object(GRAPH_OBJECTS[kind])


def graph_shown(kind: str) -> bool:
    """True when the ``kind`` graph is drawn."""
    return bpy.data.objects.get(GRAPH_OBJECTS[kind]) is not None


def path_to_curve(model, path, *, scene=None):
    """Draw a :class:`~engine.topology.PathResult`: a polyline through the centres of its
    spaces, passing through each door (``via``) between them (object :data:`PATH_OBJECT`)."""
    pts = []
    for i, sid in enumerate(path.spaces):
        pts.append(model[sid].centroid)
        if i < len(path.vias) and path.vias[i] is not None and path.vias[i] in model:
            via = model[path.vias[i]]
            c = via.centroid.copy()
            c[2] = pts[-1][2]
            pts.append(c)
    obj = polylines_to_curve(PATH_OBJECT, [np.array(pts)], kind="path", matrix=model_matrix(model),
                             scene=scene)
    obj["indoor_spaces"] = list(path.spaces)
    obj["indoor_length"] = float(path.length)
    return obj


def refresh_overlays(model, *, scene=None) -> None:
    """After the model changed: redraw shown graphs, drop the (stale) path and its text."""
    scene = scene or bpy.context.scene
    for kind in GRAPH_OBJECTS:
        if graph_shown(kind):
            graph_to_curve(model, kind, scene=scene)
    _remove_object(PATH_OBJECT)
    settings = getattr(scene, "indoor", None)
    if settings is not None:
        settings.path_text = ""


# --------------------------------------------------------------------------- overlays: surfaces
CHANGES_COLLECTION = "Changes"
"""Collection of the room faces coloured by coverage (change detection)."""
EVALUATION_COLLECTION = "Evaluation"
"""Collection of the reference / source surfaces coloured by the evaluation."""
COVERAGE_RAMP = ((0.0, (0.85, 0.10, 0.10)), (0.5, (0.95, 0.80, 0.15)), (1.0, (0.15, 0.75, 0.30)))
"""(value 0–1, linear RGB) stops: red (uncovered) → yellow → green (covered)."""
FLAG_ALPHA = 0.9
"""Opacity of flagged surfaces (missing, redundant)."""
PLAIN_ALPHA = 0.45
"""Opacity of the other overlay surfaces."""


def ramp(values, stops=COVERAGE_RAMP) -> np.ndarray:
    """(n, 3) float64 colours of (n,) values on a ramp of ``(position, rgb)`` stops (NaN → grey)."""
    v = np.asarray(values, dtype=np.float64).ravel()
    pos = np.array([p for p, _ in stops])
    cols = np.array([c for _, c in stops], dtype=np.float64)
    out = np.column_stack([np.interp(np.nan_to_num(v, nan=0.0), pos, cols[:, k]) for k in range(3)])
    out[~np.isfinite(v)] = 0.5
    return out


def clear_collection(name: str, scene=None) -> None:
    """Remove every object (and its now unused data) of the top-level collection ``name``."""
    scene = scene or bpy.context.scene
    coll = scene.collection.children.get(name)
    if coll is None:
        return
    for obj in list(coll.all_objects):
        _remove_object(obj.name)


def patches_to_objects(patches, values, *, collection: str, attribute: str, flagged=(), matrix=None,
                       prefix: str = "", scene=None) -> list:
    """One mesh object per :class:`~engine.evaluation.PlanarPatch`, coloured by a value.

    Parameters
    ----------
    patches : list of PlanarPatch
        Planar faces (model frame when ``matrix`` maps it to the scene).
    values : (n,) float64
        One value in [0, 1] per patch (e.g. coverage): the FACE attribute ``attribute``,
        the object property of the same name and the colour (:data:`COVERAGE_RAMP`).
    collection : str
        Top-level collection (emptied first).
    flagged : iterable of str
        Patch keys to flag (property ``indoor_flagged`` True, opaque).
    prefix : str
        Object name prefix.

    Returns
    -------
    list of bpy.types.Object (same order as ``patches``).
    """
    from ..engine.evaluation.patches import polygon_triangles

    scene = scene or bpy.context.scene
    coll = ensure_collection(collection, scene)
    flagged = set(flagged)
    values = np.asarray(values, dtype=np.float64).ravel()
    colors = ramp(values)
    mat = overlay_material()
    objs = []
    for p, v, c in zip(patches, values, colors):
        verts, tris = polygon_triangles(p)
        name = f"{prefix}{p.name or p.shape_id} {p.kind} {p.face}"
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(verts.tolist(), [], tris.tolist())
        mesh.update()
        attr = mesh.attributes.new(attribute, "FLOAT", "FACE")
        attr.data.foreach_set("value", np.full(len(mesh.polygons), v, dtype=np.float32))
        mesh.materials.append(mat)
        obj = bpy.data.objects.new(name, mesh)
        if matrix is not None:
            obj.matrix_world = matrix
        flag = p.key in flagged
        obj.color = (*c, FLAG_ALPHA if flag else PLAIN_ALPHA)
        obj.show_transparent = True
        obj["indoor_patch"] = p.key
        obj["indoor_shape_id_of"] = p.shape_id
        obj["indoor_kind"] = p.kind
        obj[attribute] = float(v)
        obj["indoor_flagged"] = flag
        coll.objects.link(obj)
        objs.append(obj)
    return objs


# --------------------------------------------------------------------------- change detection
CHANGE_TYPE = "change_type"
"""INT POINT attribute: 0 existing, 1 new (engine.change.EXISTING / NEW)."""
CHANGE_DISTANCE = "change_distance"
"""FLOAT POINT attribute: distance to the closest model surface, metres (inf when none)."""
CHANGE_TYPE_COLOR = "change_type_color"
"""BYTE_COLOR POINT attribute: existing grey / new red."""
CHANGE_DISTANCE_COLOR = "change_distance_color"
"""BYTE_COLOR POINT attribute: distance on :data:`DISTANCE_RAMP` (0 → 2 r), grey when none."""
CHANGE_MATERIAL = "Indoor Changes"
"""Material of a scan showing its change colours (reads one of the two colour attributes)."""
TYPE_COLORS_CHANGE = {0: (0.55, 0.55, 0.58), 1: (0.90, 0.12, 0.10), 2: (0.30, 0.30, 0.30)}
"""sRGB colours of existing (0), new (1) and unclassified (2: the scan is unregistered) points."""
DISTANCE_RAMP = ((0.0, (0.15, 0.35, 0.85)), (0.5, (0.95, 0.85, 0.20)), (1.0, (0.90, 0.12, 0.10)))
"""(position 0–1 of [0, 2 r], sRGB) stops of the distance colours: blue 0 → yellow r → red ≥ 2 r."""
NO_SURFACE_COLOR = (0.35, 0.35, 0.35)
"""sRGB colour of points with no model surface within the search distance."""


def _byte_color(mesh, name, rgb):
    rgba = np.ones((len(rgb), 4), dtype=np.float32)
    rgba[:, :3] = rgb
    attr = _attribute(mesh, name, "BYTE_COLOR")
    attr.data.foreach_set("color_srgb", rgba.ravel())
    return attr


def change_material(color_attribute: str):
    """The material showing a scan's change colours; its Attribute node reads ``color_attribute``."""
    mat = bpy.data.materials.get(CHANGE_MATERIAL)
    if mat is None or mat.library is not None:
        mat = bpy.data.materials.new(CHANGE_MATERIAL)
        mat.use_nodes = True
        nt = mat.node_tree
        bsdf = nt.nodes.get("Principled BSDF")
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.name = "Change colour"
        attr.attribute_type = "GEOMETRY"
        attr.location = (-300, 200)
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
        nt.links.new(attr.outputs["Color"], bsdf.inputs["Emission Color"])
        bsdf.inputs["Emission Strength"].default_value = 0.5
        bsdf.inputs["Roughness"].default_value = 1.0
    mat.node_tree.nodes["Change colour"].attribute_name = color_attribute
    return mat


def set_change_colors(obj, mode: str = "TYPE") -> None:
    """Show a scan's change colours: ``mode`` "TYPE" (existing grey / new red) or "DISTANCE"."""
    name = CHANGE_TYPE_COLOR if mode == "TYPE" else CHANGE_DISTANCE_COLOR
    mesh = obj.data
    attr = mesh.color_attributes.get(name)
    if attr is None:
        raise ValueError(f"{obj.name} has no change colours: run Detect changes first")
    mesh.color_attributes.active_color = attr
    mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
    mat = change_material(name)
    if is_point_mesh(obj):
        set_display(obj, material=mat)
    obj.update_tag()


def changed_scans() -> list:
    """Objects whose mesh carries change colours (:func:`change_overlay` ran on them)."""
    return [o for o in bpy.data.objects if o.type == "MESH" and o.data is not None
            and o.data.color_attributes.get(CHANGE_TYPE_COLOR) is not None]


def change_overlay(obj, result, model, *, mode: str = "TYPE", scene=None) -> dict:
    """Show a :class:`~engine.change.ChangeResult` on the scan ``obj`` and the model.

    The scan's point mesh gets POINT attributes :data:`CHANGE_TYPE` (INT 0/1, 2 when the
    scan is unregistered),
    :data:`CHANGE_DISTANCE` (FLOAT metres, inf when no surface) and the two colour
    attributes; its points are drawn with :data:`CHANGE_MATERIAL`. The room faces with a
    coverage value become objects of the "Changes" collection (FACE attribute and
    property ``coverage``, redundant ones flagged, coloured red → green). Returns the
    summary dict stored in ``scene.indoor.change_summary``.
    """
    import json

    scene = scene or bpy.context.scene
    mesh = obj.data
    n = len(mesh.vertices)
    if len(result.point_type) != n:
        raise ValueError(f"{obj.name} has {n} points but the change result has {len(result.point_type)}")
    t = _attribute(mesh, CHANGE_TYPE, "INT")
    t.data.foreach_set("value", result.point_type.astype(np.int32))
    d = _attribute(mesh, CHANGE_DISTANCE, "FLOAT")
    d.data.foreach_set("value", result.distance.astype(np.float32))
    cols = np.array([TYPE_COLORS_CHANGE[k] for k in sorted(TYPE_COLORS_CHANGE)], dtype=np.float32)
    _byte_color(mesh, CHANGE_TYPE_COLOR, cols[np.clip(result.point_type, 0, len(cols) - 1)])
    r = float(result.distance_threshold)
    dcol = ramp(np.clip(result.distance / (2 * r), 0.0, 1.0), DISTANCE_RAMP)
    dcol[~np.isfinite(result.distance)] = NO_SURFACE_COLOR
    _byte_color(mesh, CHANGE_DISTANCE_COLOR, dcol.astype(np.float32))
    mesh.update()
    set_change_colors(obj, mode)
    clear_collection(CHANGES_COLLECTION, scene)
    patches_to_objects(result.coverage_patches, result.coverage, collection=CHANGES_COLLECTION,
                       attribute="coverage", flagged=result.redundant, matrix=model_matrix(model),
                       prefix="Coverage ", scene=scene)
    s = result.summary()
    summary = {"scan": obj.name, "points": s["points"], "existing": s["existing"], "new": s["new"],
               "new_share": s["new_share"], "distance_threshold_m": s["distance_threshold_m"],
               "surfaces": s["surfaces"], "redundant": s["redundant"], "new_elements": s["new_elements"],
               "new_walls": s["new_walls"], "fitness": s["registration"].get("fitness"),
               "rmse_m": s["registration"].get("rmse_point_to_plane_m")}
    settings = getattr(scene, "indoor", None)
    if settings is not None:
        settings.change_summary = json.dumps(summary)
    return summary


# --------------------------------------------------------------------------- evaluation
EVALUATION_IMAGE = "Indoor Evaluation Curves"
"""Image datablock of the evaluation curves (packed into the .blend)."""


def evaluation_overlay(result, reference, model, png_path: str, *, scene=None) -> dict:
    """Show an :class:`~engine.evaluation.EvaluationResult` in the scene.

    ``png_path`` (the curves written by ``write_evaluation_outputs``) is loaded and packed
    as the image :data:`EVALUATION_IMAGE`. The "Evaluation" collection gets the visible
    reference surfaces coloured by their covered share (missing ones flagged) and the
    source surfaces coloured by their overlap share (redundant ones flagged), at the
    localisation buffer; both in the reference's frame placed on the scene (offsets
    accounted for). Returns the summary stored in ``scene.indoor.eval_summary``.
    """
    import json

    from mathutils import Matrix

    scene = scene or bpy.context.scene
    old = bpy.data.images.get(EVALUATION_IMAGE)
    img = bpy.data.images.load(png_path, check_existing=False)
    img.pack()
    if old is not None:
        bpy.data.images.remove(old)
    img.name = EVALUATION_IMAGE
    try:
        img.preview_ensure()
    except (AttributeError, RuntimeError):  # no preview system (headless)
        pass
    li = result.localisation_index
    m = np.asarray(reference.transform, dtype=np.float64).copy()
    m[:3, 3] += np.asarray(reference.offset, dtype=np.float64) - np.asarray(model.offset, dtype=np.float64)
    matrix = Matrix(m.tolist())
    clear_collection(EVALUATION_COLLECTION, scene)
    ref = [p for p, v in zip(result.reference, result.visible) if v]
    ref_cov = result.reference_covered[np.asarray(result.visible, dtype=bool), li]
    patches_to_objects(ref, ref_cov, collection=EVALUATION_COLLECTION, attribute="covered",
                       flagged=result.missing, matrix=matrix, prefix="Reference ", scene=scene)
    src_cov = result.source_covered[:, li] if len(result.source) else np.zeros(0)
    patches_to_objects(result.source, src_cov, collection=EVALUATION_COLLECTION, attribute="covered",
                       flagged=result.redundant, matrix=matrix, prefix="Source ", scene=scene)
    b = float(result.buffers[li])

    def at(metric):
        v = float(result.curves["all"][metric][li])
        return v if np.isfinite(v) else None

    summary = {"buffer_m": b, "completeness": at("completeness"), "correctness": at("correctness"),
               "accuracy_m": at("accuracy"), "missing": list(result.missing),
               "redundant": list(result.redundant), "reference_surfaces": len(ref),
               "source_surfaces": len(result.source), "image": img.name}
    settings = getattr(scene, "indoor", None)
    if settings is not None:
        settings.eval_summary = json.dumps(summary)
    return summary
