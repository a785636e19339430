"""Plane frames: an orthonormal basis (u, v) of a plane from its unit normal."""
from __future__ import annotations

import numpy as np

__all__ = ["plane_frame"]

_NO_HORIZONTAL = 1e-6
"""Norm of the horizontal part of a unit normal under which the normal is vertical."""


def plane_frame(normal: np.ndarray, flat_cos: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``u, v`` (each (3,) float64) spanning the plane with unit ``normal``.

    ``u`` is horizontal (along z × n) and ``v`` = n × u points up, unless the plane is
    nearly horizontal (``|n_z| >= flat_cos``, or n has no horizontal part): then ``u`` is
    the x axis projected on the plane. ``(u, v, n)`` is right-handed. ``flat_cos = 1``
    keeps ``u`` horizontal on every tilted plane.
    """
    n = np.asarray(normal, dtype=np.float64)
    u = np.array([-n[1], n[0], 0.0])
    if abs(n[2]) >= flat_cos or np.linalg.norm(u) < _NO_HORIZONTAL:
        u = np.array([1.0, 0.0, 0.0]) - n * n[0]
    u /= np.linalg.norm(u)
    # n × u written out: np.cross costs 20 µs a call on (3,) vectors, and the IFC writer and
    # the evaluation frame thousands of faces
    return u, np.array([n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]])
