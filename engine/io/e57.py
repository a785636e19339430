"""E57 files through pye57: every scan, each with its pose applied.

Each scan's points (cartesian or spherical) are transformed by its pose (rotation
quaternion + translation) into the file's common frame; the pose translation is the scanner
position. Invalid points (``cartesianInvalidState``) are left out by pye57. Colour and
intensity are read when every scan has them.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import FormatError, MissingDependencyError
from ..pointcloud import PointCloud
from ..progress import Progress
from ._common import DEFAULT_PARAMS, ReadParams, check_file, finish_cloud

__all__ = ["read_e57"]


def _pye57():
    try:
        import pye57
    except ImportError:
        raise MissingDependencyError("pye57", "reading E57 files") from None
    return pye57


def read_e57(path, *, progress=None, should_stop=None, params: Optional[ReadParams] = None) -> PointCloud:
    """Read all scans of an E57 file.

    Parameters
    ----------
    path : str or os.PathLike
    progress, should_stop : callables, optional
        Progress is reported per scan.
    params : ReadParams, optional

    Returns
    -------
    PointCloud
        ``xyz`` (n, 3) float64 metres in the file's common frame; ``scan_index`` (n,) int32;
        ``scanner_positions`` (k, 3) float64, one per scan (its pose translation);
        ``colors`` (n, 3) uint8 and ``intensity`` (n,) float32 when every scan has them.

    Raises
    ------
    FormatError
        Not an E57 file, a corrupt one, or a file without scans.
    MissingDependencyError
        pye57 is not installed.
    """
    params = params or DEFAULT_PARAMS
    path = check_file(path)
    pye57 = _pye57()
    p = Progress.wrap(progress, should_stop)
    try:
        e57 = pye57.E57(path)
    except Exception as e:  # libe57 raises its own exception types
        raise FormatError(f"not a readable E57 file ({e})", path) from None
    try:
        k = e57.scan_count
        if k == 0:
            raise FormatError("E57 file holds no scans", path)
        xyz, cols, inten, idx, pos = [], [], [], [], []
        for i in range(k):
            p(i / k, f"reading scan {i + 1}/{k}")
            try:
                d = e57.read_scan(i, intensity=True, colors=True, transform=True, ignore_missing_fields=True)
                pos.append(np.asarray(e57.scan_position(i), dtype=np.float64).reshape(3))
            except FormatError:
                raise
            except Exception as e:
                raise FormatError(f"scan {i}: cannot read its points ({e})", path) from None
            x = np.stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]], axis=1).astype(np.float64)
            xyz.append(x)
            has_c = all(c in d for c in ("colorRed", "colorGreen", "colorBlue"))
            cols.append(np.stack([d["colorRed"], d["colorGreen"], d["colorBlue"]], axis=1) if has_c else None)
            inten.append(np.asarray(d["intensity"], np.float32) if "intensity" in d else None)
            idx.append(np.full(len(x), i, np.int32))
        p(1.0, "reading E57")
    finally:
        e57.close()
    colors = None if any(c is None for c in cols) else np.concatenate(cols).astype(np.uint8)
    intensity = None if any(v is None for v in inten) else np.concatenate(inten)
    return finish_cloud(path, np.concatenate(xyz), colors=colors, intensity=intensity,
                        scan_index=np.concatenate(idx), scanner_positions=np.stack(pos), params=params)
