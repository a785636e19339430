"""The arrays :func:`engine.elements.openings.detect_openings` takes, validated: a wrong
shape is an :class:`~engine.errors.InputError` naming the array; non-finite points are
dropped, with their normals, scans and view pairs."""
from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["checked"]


def checked(xyz, normals, scan_index, scanner_positions, view_pairs=None):
    """Validated arrays (non-finite points dropped; the ray test needs the scanners and
    ``scan_index`` or ``view_pairs``)."""
    xyz = np.asarray(xyz, dtype=np.float64)
    if xyz.ndim != 2 or xyz.shape[1] != 3:
        raise InputError(f"opening detection: xyz must be (n, 3), not {xyz.shape}")
    n = len(xyz)
    normals = None if normals is None else np.asarray(normals, dtype=np.float64)
    if normals is not None and normals.shape != (n, 3):
        raise InputError(f"opening detection: normals must be ({n}, 3), not {normals.shape}")
    if view_pairs is not None and scanner_positions is not None:
        scan_index = None
        scanner_positions = np.asarray(scanner_positions, dtype=np.float64).reshape(-1, 3)
        view_pairs = tuple(np.asarray(a, np.int64).ravel() for a in view_pairs)
        if len(view_pairs) != 2 or len(view_pairs[0]) != len(view_pairs[1]):
            raise InputError("opening detection: view_pairs must be two arrays of one length")
    elif scan_index is None or scanner_positions is None:
        scan_index = scanner_positions = view_pairs = None
    else:
        view_pairs = None
        scan_index = np.asarray(scan_index).astype(np.int64).ravel()
        scanner_positions = np.asarray(scanner_positions, dtype=np.float64).reshape(-1, 3)
        if len(scan_index) != n:
            raise InputError(f"opening detection: scan_index has {len(scan_index)} entries for {n} points")
    keep = np.all(np.isfinite(xyz), axis=1)
    if not keep.all():
        xyz, normals = xyz[keep], None if normals is None else normals[keep]
        scan_index = None if scan_index is None else scan_index[keep]
        if view_pairs is not None:
            new = np.cumsum(keep) - 1
            ok = keep[view_pairs[0]]
            view_pairs = (new[view_pairs[0][ok]], view_pairs[1][ok])
    return xyz, normals, scan_index, scanner_positions, view_pairs
