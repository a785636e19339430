"""Surface meshes (OBJ / PLY / STL / OFF / glTF) → BuildingModel: reference surfaces for the
evaluation (:func:`read_mesh`, through trimesh)."""
from __future__ import annotations

import os

import numpy as np

from ..errors import FormatError, MissingDependencyError
from ..model import BuildingModel, Polyhedron, Provenance, Shape, ShapeType
from .common import check_path

__all__ = ["read_mesh", "MESH_EXTENSIONS"]

_MIN_DOUBLE_AREA = 1e-12
"""Triangles whose doubled area (m²) is below this are degenerate and dropped."""

MESH_EXTENSIONS = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
"""Surface-mesh formats :func:`read_mesh` accepts (through trimesh)."""


def read_mesh(path: str | os.PathLike, *, default_type: ShapeType | str = ShapeType.INTERIOR,
              **_ignored) -> BuildingModel:
    """Read a surface mesh (OBJ, PLY, STL, OFF, glTF) as a reference model.

    Each object / group of the file becomes a shape; its type is taken from its name
    ("wall", "slab"/"floor"/"ceiling", "door", "space"/"room") and is ``default_type``
    otherwise, so :meth:`BuildingModel.surfaces` labels its faces wall / floor / ceiling by
    their normals. Faces are the mesh triangles; coordinates are kept (metres, z up);
    ``storey`` is -1 and the model has no storeys.

    Raises
    ------
    InputError — missing file. FormatError — unreadable, or a point cloud without faces.
    """
    p = check_path(path)
    try:
        import trimesh
    except ImportError:  # pragma: no cover
        raise MissingDependencyError("trimesh", "reading meshes") from None
    default_type = ShapeType.parse(default_type)
    kwargs = {"split_objects": True, "group_material": False} if p.lower().endswith(".obj") else {}
    loader = getattr(trimesh, "load_scene", trimesh.load)  # load() merges objects in trimesh >= 4.6
    try:
        loaded = loader(p, process=False, **kwargs)
    except Exception as e:
        raise FormatError(f"cannot read the mesh: {e}", p) from None
    if isinstance(loaded, trimesh.Scene):
        items = []
        for node in loaded.graph.nodes_geometry:
            tf, gname = loaded.graph[node]
            g = loaded.geometry[gname]
            if isinstance(g, trimesh.Trimesh):
                items.append((str(node), g.copy().apply_transform(tf)))
    else:
        items = [(os.path.splitext(os.path.basename(p))[0], loaded)]
    items = [(n, g) for n, g in items if isinstance(g, trimesh.Trimesh) and len(g.faces)]
    if not items:
        raise FormatError("the file holds no triangles (a point cloud, or an empty mesh)", p)
    shapes = []
    for k, (name, g) in enumerate(items):
        v = np.asarray(g.vertices, dtype=np.float64)
        t = np.asarray(g.faces, dtype=np.int64)
        if not np.all(np.isfinite(v)):
            raise FormatError(f"object {name!r} has non-finite vertices", p)
        low = name.lower()
        kind = default_type
        for words, st in ((("wall",), ShapeType.WALL), (("slab", "floor", "ceiling", "roof"), ShapeType.SLAB),
                          (("door",), ShapeType.DOOR), (("space", "room"), ShapeType.INTERIOR)):
            if any(w in low for w in words):
                kind = st
                break
        a = np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
        t = t[a > _MIN_DOUBLE_AREA]
        if len(t) == 0:
            continue
        shapes.append(Shape(f"mesh{k}", kind, Polyhedron(v, [tuple(x) for x in t]), storey=-1, name=name,
                            terminal=True))
    if not shapes:
        raise FormatError("the mesh has only degenerate triangles", p)
    return BuildingModel(shapes=tuple(shapes), provenance=Provenance("mesh", source=p),
                         name=os.path.splitext(os.path.basename(p))[0])
