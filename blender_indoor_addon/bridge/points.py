"""Point meshes: a scan as mesh vertices with POINT attributes, drawn as points.

Point clouds become *point meshes*: mesh vertices (float32 coordinates, written in bulk
with ``foreach_set``) carrying POINT-domain attributes (``color``, ``intensity``,
``normal``, ``scan_index`` and every ``cloud.fields`` array), drawn as points by a Geometry
Nodes "Mesh to Points" modifier whose material reads the ``color`` attribute. The modifier
has a *Display ratio* input that draws a random subset of the points: the mesh always keeps
every point.
"""
from __future__ import annotations

import logging
import os

import bpy
import numpy as np

from ...engine.errors import printable
from ...engine.pointcloud import PointCloud
from .collections import ensure_collection, undo_on_failure

log = logging.getLogger(__name__)

__all__ = ["SCAN_COLLECTION", "POINTS_NODE_GROUP", "POINTS_MODIFIER", "OFFSET_PROP", "SOURCE_PROP",
           "COUNT_PROP", "IN_RATIO", "IN_RADIUS", "IN_MATERIAL", "IN_SEED", "IN_USE_SECTION", "IN_SECTION_Z",
           "HEIGHT_COLOR", "HEIGHT_RAMP", "points_node_group", "points_material", "write_attribute",
           "point_cloud_to_object", "set_display", "display_settings", "input_identifier", "is_point_mesh",
           "object_points", "add_height_colors", "object_to_cloud"]

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


# --------------------------------------------------------------------------- node group
def _socket(node_group, name, in_out="INPUT"):
    for item in node_group.interface.items_tree:
        if item.item_type == "SOCKET" and item.in_out == in_out and item.name == name:
            return item
    return None


def points_node_group():
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
def points_material(with_color: bool):
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
def write_attribute(mesh, name: str, data_type: str):
    """A new POINT attribute ``name`` of ``data_type`` on ``mesh`` (an old one of that name is replaced)."""
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
        attr = write_attribute(mesh, name, "FLOAT_VECTOR")
        attr.data.foreach_set("vector", np.ascontiguousarray(a, dtype=np.float32).ravel())
        return [name]
    if a.ndim == 1:
        if a.dtype.kind in "iub":
            i32 = np.iinfo(np.int32)
            if a.size and a.dtype.kind in "iu" and (a.max() > i32.max or a.min() < i32.min):
                attr = write_attribute(mesh, name, "FLOAT")  # does not fit an INT attribute
                attr.data.foreach_set("value", a.astype(np.float32))
            else:
                attr = write_attribute(mesh, name, "INT")
                attr.data.foreach_set("value", np.ascontiguousarray(a, dtype=np.int32))
            return [name]
        if a.dtype.kind == "f":
            attr = write_attribute(mesh, name, "FLOAT")
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
        attr = write_attribute(mesh, "color", "BYTE_COLOR")
        attr.data.foreach_set("color_srgb", rgba.ravel())
        mesh.color_attributes.active_color = attr
        mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
        names.append("color")
    if cloud.intensity is not None:
        attr = write_attribute(mesh, "intensity", "FLOAT")
        attr.data.foreach_set("value", cloud.intensity)
        names.append("intensity")
    if cloud.normals is not None:
        attr = write_attribute(mesh, "normal", "FLOAT_VECTOR")
        attr.data.foreach_set("vector", cloud.normals.ravel())
        names.append("normal")
    if cloud.scan_index is not None:
        attr = write_attribute(mesh, "scan_index", "INT")
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
    scene = scene or bpy.context.scene
    if name is None:
        name = os.path.splitext(os.path.basename(cloud.source))[0] if cloud.source else "Scan"
    with undo_on_failure(scene):
        coll = ensure_collection(collection, scene)
        mesh = bpy.data.meshes.new(name)
        names = _fill_mesh(mesh, cloud)
        obj = bpy.data.objects.new(name, mesh)
        obj[OFFSET_PROP] = [float(v) for v in cloud.offset]
        obj[SOURCE_PROP] = printable(cloud.source) if cloud.source else ""  # ID strings are UTF-8
        obj[COUNT_PROP] = int(len(cloud))
        obj["indoor_attributes"] = names
        ng = points_node_group()
        mat = points_material(cloud.colors is not None)
        mesh.materials.append(mat)
        mod = obj.modifiers.new(POINTS_MODIFIER, "NODES")
        mod.node_group = ng
        set_display(obj, display_ratio=display_ratio, point_radius=point_radius, seed=seed, material=mat)
        coll.objects.link(obj)
    return obj



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
    attr = write_attribute(mesh, HEIGHT_COLOR, "BYTE_COLOR")
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
