"""Load a source or reference model from a file, whatever its format.

``.json`` → :meth:`BuildingModel.from_json`; ``.ifc`` → ``engine.ifc.read_ifc``;
``.obj``/``.ply``/``.off``/``.stl`` meshes → ``engine.ifc.read_mesh`` when that reader is
installed, else trimesh (each connected component becomes one shape whose triangles are
merged back into planar faces by the evaluation).
"""
from __future__ import annotations

import logging
import os

import numpy as np

from ..errors import FormatError, InputError, MissingDependencyError
from ..model import BuildingModel, Polyhedron, Provenance, Scope, Shape, ShapeType

__all__ = ["load_model", "mesh_to_model", "MODEL_EXTENSIONS", "transform_model", "frame_transform"]

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
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

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


def _read_mesh_trimesh(path: str) -> BuildingModel:
    try:
        import trimesh
    except ImportError:  # pragma: no cover - trimesh is a listed dependency
        raise MissingDependencyError("trimesh", "reading OBJ/PLY meshes") from None
    try:
        mesh = trimesh.load(path, force="mesh", process=True)
    except Exception as e:  # trimesh raises many types on bad files
        raise FormatError(f"not readable as a mesh: {e}", path) from None
    faces = getattr(mesh, "faces", None)
    if faces is None or len(faces) == 0:
        raise FormatError("the file holds no triangles (a point cloud is not a model)", path)
    return mesh_to_model(np.asarray(mesh.vertices), np.asarray(faces), name=os.path.basename(path))


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
        try:
            from ..ifc import read_ifc
        except ImportError:
            raise InputError("reading IFC needs engine.ifc.read_ifc, which this build does not have", path) \
                from None
        return read_ifc(path)
    if ext in MESH_EXTENSIONS:
        try:
            from ..ifc import read_mesh
        except ImportError:
            read_mesh = None
        if read_mesh is not None:
            return read_mesh(path)
        return _read_mesh_trimesh(path)
    raise InputError(f"unsupported model file type {ext or '(none)'!r}; expected one of "
                     f"{', '.join(MODEL_EXTENSIONS)}", path)


def transform_model(model: BuildingModel, matrix: np.ndarray) -> BuildingModel:
    """A copy of ``model`` with every shape's geometry moved by the 4×4 rigid ``matrix``."""
    m = np.asarray(matrix, dtype=np.float64)
    r, t = m[:3, :3], m[:3, 3]
    shapes = []
    for s in model.shapes:
        v = s.geometry.vertices @ r.T + t
        shapes.append(s.with_(geometry=Polyhedron(v, s.geometry.faces), scope=Scope.of_points(v)))
    return model.with_(shapes=tuple(shapes))


def frame_transform(src_transform, src_offset, dst_transform, dst_offset) -> np.ndarray:
    """4×4 float64 mapping model-frame coordinates of one dataset to those of another.

    Each dataset maps its model frame to file coordinates by ``p_file = T @ p + offset``
    (:class:`BuildingModel` ``transform``/``offset``; a point cloud has ``T = I``).
    Returns ``inv(T_dst) ∘ (T_src p + offset_src − offset_dst)``.
    """
    a = np.asarray(src_transform, dtype=np.float64).reshape(4, 4).copy()
    a[:3, 3] += np.asarray(src_offset, dtype=np.float64) - np.asarray(dst_offset, dtype=np.float64)
    return np.linalg.inv(np.asarray(dst_transform, dtype=np.float64).reshape(4, 4)) @ a
