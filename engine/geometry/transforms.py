"""Frame maths with 4×4 homogeneous matrices (points as (n, 3) float64 rows, metres).

A dataset (a model, a cloud) maps its own frame to file coordinates by
``p_file = T @ p + offset``: ``T`` the (usually rigid) 4×4 ``transform`` — alignment undone —
and ``offset`` the (3,) global offset removed on reading.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

__all__ = ["apply_transform", "apply_rotation", "to_input_frame", "from_input_frame", "frame_transform",
           "is_rigid"]


def apply_transform(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, 3) float64 ``matrix @ p`` of (n, 3) points (the 4×4 ``matrix``'s affine part)."""
    m = np.asarray(matrix, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return p @ m[:3, :3].T + m[:3, 3]


def apply_rotation(matrix: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """(n, 3) float64: (n, 3) direction vectors (normals) turned by the 3×3 part of ``matrix``."""
    m = np.asarray(matrix, dtype=np.float64)
    return np.asarray(vectors, dtype=np.float64).reshape(-1, 3) @ m[:3, :3].T


def to_input_frame(points: np.ndarray, transform: np.ndarray,
                   offset: Optional[np.ndarray] = None) -> np.ndarray:
    """(n, 3) float64 model-frame points in the input frame: ``T @ p`` (+ ``offset`` when given,
    giving file coordinates)."""
    out = apply_transform(transform, points)
    return out if offset is None else out + np.asarray(offset, dtype=np.float64)


def from_input_frame(points: np.ndarray, transform: np.ndarray,
                     offset: Optional[np.ndarray] = None) -> np.ndarray:
    """The inverse of :func:`to_input_frame`: (n, 3) input-frame points (file coordinates when
    ``offset`` is given) → (n, 3) float64 model-frame points, ``T⁻¹ @ (p − offset)``."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if offset is not None:
        p = p - np.asarray(offset, dtype=np.float64)
    return apply_transform(np.linalg.inv(np.asarray(transform, dtype=np.float64)), p)


def frame_transform(src_transform, src_offset, dst_transform, dst_offset) -> np.ndarray:
    """4×4 float64 mapping frame coordinates of one dataset to those of another.

    Each dataset maps its frame to file coordinates by ``p_file = T @ p + offset``
    (a point cloud has ``T = I``). Returns ``inv(T_dst) ∘ (T_src p + offset_src − offset_dst)``.
    """
    a = np.asarray(src_transform, dtype=np.float64).reshape(4, 4).copy()
    a[:3, 3] += np.asarray(src_offset, dtype=np.float64) - np.asarray(dst_offset, dtype=np.float64)
    return np.linalg.inv(np.asarray(dst_transform, dtype=np.float64).reshape(4, 4)) @ a


def is_rigid(transform: np.ndarray, tol: float) -> bool:
    """True when the 3×3 part of ``transform`` (4, 4) is a rotation: ``RᵀR = I`` within
    ``tol`` and det > 0."""
    r = np.asarray(transform, dtype=np.float64)[:3, :3]
    return bool(np.allclose(r.T @ r, np.eye(3), atol=tol) and np.linalg.det(r) > 0)
