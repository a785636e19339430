"""Indoor reconstruction engine: pure Python, never imports Blender.

Scan files → :class:`PointCloud` → reconstruction → :class:`BuildingModel` → IFC,
evaluation, change detection, reports. See README.md for the command line.
"""
from .threads import apply_thread_env

apply_thread_env()  # before NumPy and Open3D start their thread pools

from .errors import (Cancelled, EmptyCloudError, FormatError, IndoorError, InputError,
                     MissingDependencyError, ReconstructionError)
from .model import (BuildingModel, Polyhedron, Provenance, Relation, Scope, Shape, ShapeType,
                    Storey, Surface)
from .io import read_point_cloud, write_ply
from .pointcloud import PointCloud
from .progress import Progress

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "BuildingModel", "Polyhedron", "Provenance", "Relation", "Scope", "Shape", "ShapeType",
    "Storey", "Surface", "PointCloud", "Progress", "read_point_cloud", "write_ply",
    "IndoorError", "InputError", "FormatError", "EmptyCloudError", "ReconstructionError",
    "MissingDependencyError", "Cancelled",
]
