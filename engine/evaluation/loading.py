"""Load a source or reference model from a file, whatever its format.

``.json`` → :meth:`BuildingModel.from_json`; ``.ifc`` → ``engine.ifc.read_ifc``;
``.obj``/``.ply``/``.off``/``.stl`` meshes → ``engine.ifc.read_mesh`` (whose triangles are
merged back into planar faces by the evaluation). :func:`mesh_to_model` makes a model of
a triangle mesh in memory, one shape per connected component.
"""
from __future__ import annotations

import logging
import os

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import InputError
from ..geometry.transforms import apply_transform
from ..ifc import read_ifc, read_mesh
from ..model import BuildingModel, Polyhedron, Provenance, Scope, Shape, ShapeType

__all__ = ["load_model", "mesh_to_model", "MODEL_EXTENSIONS", "transform_model"]

log = logging.getLogger(__name__)

MESH_EXTENSIONS = (".obj", ".ply", ".off", ".stl")
MODEL_EXTENSIONS = (".json", ".ifc") + MESH_EXTENSIONS
"""File types :func:`load_model` reads."""


def mesh_to_model(vertices: np.ndarray, triangles: np.ndarray, *, shape_type=ShapeType.INTERIOR,
                  name: str = "", components: bool = True) -> BuildingModel:
    """A BuildingModel from a triangle mesh.

    Parameters
    ----------
    vertices : (n, 3) float64, metres.
    triangles : (m, 3) int.
    shape_type : the type given to every shape (a mesh has no semantics; the default
        treats it as room volumes / visible room surfaces).
    components : one shape per connected component (else one shape for everything).
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        raise InputError("the mesh has no faces")
    labels = np.zeros(len(v), dtype=np.int64)
    if components:
        rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
        cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
        g = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(v), len(v)))
        _, labels = connected_components(g, directed=False)
    tri_label = labels[f[:, 0]]
    shapes = []
    for k, lab in enumerate(np.unique(tri_label)):
        ft = f[tri_label == lab]
        used = np.unique(ft)
        remap = np.full(len(v), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        shapes.append(Shape(id=f"mesh{k}", type=shape_type, geometry=Polyhedron(v[used], remap[ft]),
                            name=f"{name or 'mesh'} {k}", storey=-1))
    return BuildingModel(shapes=tuple(shapes), name=name, provenance=Provenance(method="mesh", source=name))


def load_model(path: str | os.PathLike) -> BuildingModel:
    """Read a model (source or reference) from ``path``, dispatching on the extension.

    Raises
    ------
    InputError
        The file does not exist, is a folder, or its type is not one of ``MODEL_EXTENSIONS``.
    FormatError
        The file cannot be parsed: empty, truncated (an IFC without ``END-ISO-10303-21;``, a
        JSON cut midway), not of its format, or JSON that is not a model.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError("file not found", path)
    if os.path.isdir(path):
        raise InputError("is a folder, not a file", path)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".json":
        return BuildingModel.from_json(path)
    if ext == ".ifc":
        return read_ifc(path)
    if ext in MESH_EXTENSIONS:
        return read_mesh(path)
    raise InputError(f"unsupported model file type {ext or '(none)'!r}; expected one of "
                     f"{', '.join(MODEL_EXTENSIONS)}", path)


def transform_model(model: BuildingModel, matrix: np.ndarray) -> BuildingModel:
    """A copy of ``model`` with every shape's geometry moved by the 4×4 rigid ``matrix``."""
    shapes = []
    for s in model.shapes:
        v = apply_transform(matrix, s.geometry.vertices)
        shapes.append(s.with_(geometry=Polyhedron(v, s.geometry.faces), scope=Scope.of_points(v)))
    return model.with_(shapes=tuple(shapes))
