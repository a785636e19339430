"""Overlays: graph and path curves between space centres, and planar patches coloured by a value.

Overlay objects are drawn with one material (:data:`OVERLAY_MATERIAL`) that shows each
object's own colour, so curves and patches of every kind share it.
"""
from __future__ import annotations

import bpy
import numpy as np

from ...engine.topology import space_graph
from .collections import ensure_collection, remove_object
from .shapes import model_matrix

__all__ = ["TOPOLOGY_COLLECTION", "GRAPH_OBJECTS", "PATH_OBJECT", "OVERLAY_COLORS", "CURVE_BEVEL",
           "OVERLAY_MATERIAL", "COVERAGE_RAMP", "FLAG_ALPHA", "PLAIN_ALPHA", "overlay_material",
           "polylines_to_curve", "spline_points", "graph_to_curve", "remove_graph", "graph_shown",
           "path_to_curve", "refresh_overlays", "ramp", "patches_to_objects"]

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
    remove_object(name)
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
    g = space_graph(model, kind, "space")
    edges = sorted(tuple(sorted((a, b))) for a, b in g.edges)
    lines = [np.array([model[a].centroid, model[b].centroid]) for a, b in edges]
    obj = polylines_to_curve(GRAPH_OBJECTS[kind], lines, kind=kind, matrix=model_matrix(model), scene=scene)
    obj["indoor_edges"] = [f"{a}|{b}" for a, b in edges]
    return obj


def remove_graph(kind: str) -> None:
    """Remove the drawn ``kind`` graph (no-op when it is not drawn)."""
    remove_object(GRAPH_OBJECTS[kind])


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
    """After the model changed: redraw the shown graphs and drop the (stale) path curve."""
    scene = scene or bpy.context.scene
    for kind in GRAPH_OBJECTS:
        if graph_shown(kind):
            graph_to_curve(model, kind, scene=scene)
    remove_object(PATH_OBJECT)


# --------------------------------------------------------------------------- surface patches
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
    scene = scene or bpy.context.scene
    coll = ensure_collection(collection, scene)
    flagged = set(flagged)
    values = np.asarray(values, dtype=np.float64).ravel()
    colors = ramp(values)
    mat = overlay_material()
    objs = []
    for p, v, c in zip(patches, values, colors):
        verts, tris = _polygon_triangles(p)
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


def _polygon_triangles(p):
    """engine.evaluation's triangulation, imported when a result is first drawn: the
    evaluation package is not needed to open the add-on (the batch's start-up)."""
    from ...engine.evaluation.patches import polygon_triangles

    return polygon_triangles(p)
