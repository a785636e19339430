"""Names and small helpers shared by the IFC writer and reader."""
from __future__ import annotations

import json
import os

import numpy as np

from ..errors import InputError, MissingDependencyError

__all__ = [
    "PSET_PROVENANCE", "PSET_SHAPE", "PSET_SUPPORT", "PSET_STOREY", "WRITABLE_SCHEMAS",
    "READABLE_SCHEMAS", "require_ifcopenshell", "dumps", "loads",
]

PSET_PROVENANCE = "Indoor_Provenance"
"""Property set on the IfcProject: method, parameters, seed, timings, frame (transform, offset)."""
PSET_SHAPE = "Indoor_Shape"
"""Property set on each product: the model's shape id, type, flags, attributes and rule log."""
PSET_SUPPORT = "Indoor_Support"
"""Property set on each product: the figures from the data (point-on-face index, coverage, ...)."""
PSET_STOREY = "Indoor_Storey"
"""Property set on each IfcBuildingStorey: index, floor and ceiling heights in the model frame."""

WRITABLE_SCHEMAS = ("IFC4", "IFC4X3")
READABLE_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3")


def require_ifcopenshell(purpose: str):
    """Import ifcopenshell or raise :class:`MissingDependencyError` naming the package."""
    try:
        import ifcopenshell  # noqa: F401
    except ImportError:  # pragma: no cover - the environment ships it
        raise MissingDependencyError("ifcopenshell", purpose) from None
    return ifcopenshell


def dumps(value) -> str:
    """Compact JSON text for property values (numpy arrays and scalars become lists/numbers)."""
    from ..model import _jsonable

    return json.dumps(_jsonable(value), separators=(",", ":"))


def loads(text, default=None):
    """Parse JSON text written by :func:`dumps`; ``default`` when it is missing or malformed."""
    if text is None:
        return default
    try:
        return json.loads(text)
    except (TypeError, ValueError):
        return default


def check_path(path: str | os.PathLike) -> str:
    """The path as a string; :class:`InputError` when the file is missing or is a folder."""
    p = os.fspath(path)
    if not os.path.exists(p):
        raise InputError("file not found", p)
    if os.path.isdir(p):
        raise InputError("is a folder, not a file", p)
    return p


def rigid_part(transform: np.ndarray, tol: float) -> bool:
    """True when the 3×3 part of ``transform`` (4, 4) is a rotation (orthonormal, det +1)."""
    r = np.asarray(transform, dtype=np.float64)[:3, :3]
    return bool(np.allclose(r.T @ r, np.eye(3), atol=tol) and np.linalg.det(r) > 0)
