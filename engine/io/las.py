"""LAS / LAZ files through laspy (LAZ needs the ``lazrs`` or ``laszip`` backend).

Coordinates are the scaled values (``X * scale + offset`` per the header). Colour (16-bit in
the LAS specification) is scaled to 8 bits; files whose colour never exceeds 255 (a common
writer bug: 8-bit values in the 16-bit fields) are kept as they are. Intensity -> intensity;
``classification`` and extra bytes dimensions -> ``cloud.fields``.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import FormatError, MissingDependencyError
from ..pointcloud import PointCloud
from ..progress import Progress
from ._common import DEFAULT_PARAMS, ReadParams, check_file, colors_to_u8, finish_cloud

__all__ = ["read_las"]


def _laspy():
    try:
        import laspy
    except ImportError:
        raise MissingDependencyError("laspy", "reading LAS/LAZ files") from None
    return laspy


def _las_error(e: Exception, path: str, what: str) -> Exception:
    """laspy's error as ours: a missing LAZ backend is a missing dependency."""
    msg = str(e).lower()
    if "lazback" in msg or "backend" in msg or "is not available" in msg:
        return MissingDependencyError("lazrs", f"reading the LAZ file {path}")
    return FormatError(f"{what} ({e})", path)


def read_las(path, *, progress=None, should_stop=None, params: Optional[ReadParams] = None) -> PointCloud:
    """Read a LAS or LAZ file in chunks of ``params.chunk_points`` points.

    Parameters
    ----------
    path : str or os.PathLike
    progress, should_stop : callables, optional
    params : ReadParams, optional

    Returns
    -------
    PointCloud
        ``xyz`` (n, 3) float64 metres (scales and offsets applied, then a large offset
        removed), ``colors`` (n, 3) uint8 when the point format has RGB, ``intensity`` (n,)
        float32, ``fields["classification"]`` (n,) uint8 and extra dimensions.

    Raises
    ------
    FormatError
        Not a LAS file or a corrupt/truncated one.
    MissingDependencyError
        laspy (or, for LAZ, lazrs) is not installed.
    EmptyCloudError
        No or too few finite points.
    """
    params = params or DEFAULT_PARAMS
    path = check_file(path)
    laspy = _laspy()
    p = Progress.wrap(progress, should_stop)
    if path.lower().endswith(".laz") and not laspy.LazBackend.detect_available():
        raise MissingDependencyError("lazrs", f"reading the LAZ file {path}")
    try:
        reader = laspy.open(path)
    except laspy.errors.LaspyException as e:
        raise _las_error(e, path, "not a readable LAS/LAZ file") from None
    except (OSError, ValueError, EOFError) as e:
        raise FormatError(f"not a readable LAS/LAZ file ({e})", path) from None
    with reader:
        hdr = reader.header
        n = int(hdr.point_count)
        dims = set(hdr.point_format.dimension_names)
        has_rgb = {"red", "green", "blue"} <= dims
        extra = list(hdr.point_format.extra_dimension_names)
        xyz = np.empty((n, 3), np.float64)
        rgb = np.empty((n, 3), np.uint16) if has_rgb else None
        inten = np.empty(n, np.float32)
        cls = np.empty(n, np.uint8)
        fields = {}
        got = 0
        step = max(int(params.chunk_points), 1)
        try:
            for chunk in reader.chunk_iterator(step):
                m = len(chunk)
                if got + m > n:
                    raise FormatError(f"holds more points than its header's {n:,}", path)
                sl = slice(got, got + m)
                xyz[sl, 0] = chunk.x
                xyz[sl, 1] = chunk.y
                xyz[sl, 2] = chunk.z
                if has_rgb:
                    rgb[sl, 0] = chunk.red
                    rgb[sl, 1] = chunk.green
                    rgb[sl, 2] = chunk.blue
                inten[sl] = chunk.intensity
                cls[sl] = chunk.classification
                for name in extra:
                    v = np.asarray(chunk[name])
                    if name not in fields:
                        fields[name] = np.empty((n,) + v.shape[1:], v.dtype)
                    fields[name][sl] = v
                got += m
                p(got / max(n, 1), "reading LAS")
        except laspy.errors.LaspyException as e:
            raise _las_error(e, path, "corrupt LAS/LAZ data") from None
        except (ValueError, OSError, EOFError, RuntimeError) as e:
            raise FormatError(f"corrupt or truncated LAS/LAZ data ({e})", path) from None
    if got < n:
        raise FormatError(f"truncated: the header declares {n:,} points but only {got:,} could be read", path)
    fields["classification"] = cls
    colors = None
    if has_rgb:
        colors = colors_to_u8(rgb)  # 16-bit scaled; 8-bit values in 16-bit fields kept
    return finish_cloud(path, xyz, colors=colors, intensity=inten, fields=fields, params=params)
