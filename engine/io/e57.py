"""E57 files through pye57's libE57 binding: every scan, each with its pose applied.

Each scan is streamed in chunks of ``ReadParams.chunk_points`` records (progress per chunk).
Cartesian or spherical coordinates (range, azimuth, elevation; radians) are turned into
x y z, then transformed by the scan's pose (rotation quaternion + translation) into the
file's common frame; the pose translation is the scanner position. Points flagged invalid
(``cartesianInvalidState``/``sphericalInvalidState`` != 0) are left out. Colour is scaled to
8 bits from the scan's ``colorLimits`` (or the prototype's integer range), so 16-bit colour
works; intensity is kept as stored. Colour/intensity are returned when every scan has them.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import FormatError, IndoorError, MissingDependencyError
from ..pointcloud import PointCloud
from ..progress import Progress
from ._common import DEFAULT_PARAMS, ReadParams, check_file, finish_cloud, guard_reader

__all__ = ["read_e57"]

_CARTESIAN = ("cartesianX", "cartesianY", "cartesianZ")
_SPHERICAL = ("sphericalRange", "sphericalAzimuth", "sphericalElevation")
_COLOURS = ("colorRed", "colorGreen", "colorBlue")
_COLOUR_8BIT_MAX = 255


def _pye57():
    try:
        import pye57
        from pye57 import libe57
    except ImportError:
        raise MissingDependencyError("pye57", "reading E57 files") from None
    return pye57, libe57


def _colour_max(libe57, header, proto) -> float:
    """Largest colour value of a scan: ``colorLimits`` or the prototype's integer range."""
    node = header.node
    try:
        if node.isDefined("colorLimits"):
            return float(max(node["colorLimits"][f"{c}Maximum"].value() for c in _COLOURS))
    except Exception:  # a malformed colorLimits: fall back to the prototype
        pass
    try:
        return float(max(libe57.IntegerNode(proto.get(c)).maximum() for c in _COLOURS))
    except Exception:
        return float(_COLOUR_8BIT_MAX)


def _read_scan(e57, libe57, i, params, p, done, total, path):
    header = e57.get_header(i)
    fields = set(header.point_fields)
    if set(_CARTESIAN) <= fields:
        coords, invalid = _CARTESIAN, "cartesianInvalidState"
    elif set(_SPHERICAL) <= fields:
        coords, invalid = _SPHERICAL, "sphericalInvalidState"
    else:
        raise FormatError(f"scan {i} has neither cartesian nor spherical coordinates", path)
    n = int(header.point_count)
    wanted = [(c, np.float64) for c in coords]
    has_i = "intensity" in fields
    has_c = set(_COLOURS) <= fields
    if has_i:
        wanted.append(("intensity", np.float32))
    if has_c:
        wanted += [(c, np.uint16) for c in _COLOURS]
    if invalid in fields:
        wanted.append((invalid, np.int8))
    out = {name: np.empty(n, dt) for name, dt in wanted}
    cap = max(1, min(n, int(params.chunk_points)))
    bufs = libe57.VectorSourceDestBuffer()
    tmp = {}
    for name, dt in wanted:
        tmp[name] = np.empty(cap, dt)
        bufs.append(libe57.SourceDestBuffer(e57.image_file, name, tmp[name], cap, True, True))
    got = 0
    if n:
        reader = header.points.reader(bufs)
        try:
            while got < n:
                k = reader.read()
                if k == 0:
                    break
                k = min(k, n - got)
                for name in out:
                    out[name][got:got + k] = tmp[name][:k]
                got += k
                p((done + got) / max(total, 1), f"reading scan {i + 1}")
        finally:
            reader.close()
    if got < n:
        raise FormatError(f"scan {i}: {got:,} of its {n:,} points could be read", path)
    keep = None if invalid not in out else out[invalid] == 0
    a = np.stack([out[c] for c in coords], axis=1)
    if coords is _SPHERICAL:
        r, az, el = a[:, 0], a[:, 1], a[:, 2]
        a = np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=1)
    rot = np.asarray(header.rotation_matrix, dtype=np.float64) if header.has_pose() else np.eye(3)
    t = np.asarray(header.translation, dtype=np.float64).reshape(3) if header.has_pose() else np.zeros(3)
    xyz = a @ rot.T + t
    colors = None
    if has_c:
        c = np.stack([out[name] for name in _COLOURS], axis=1).astype(np.float64)
        cmax = _colour_max(libe57, header, libe57.StructureNode(header.points.prototype()))
        if cmax > _COLOUR_8BIT_MAX:
            c *= _COLOUR_8BIT_MAX / cmax
        colors = np.clip(np.round(c), 0, _COLOUR_8BIT_MAX).astype(np.uint8)
    inten = out["intensity"] if has_i else None
    if keep is not None and not keep.all():
        xyz = xyz[keep]
        colors = None if colors is None else colors[keep]
        inten = None if inten is None else inten[keep]
    return xyz, colors, inten, t, n


@guard_reader("E57")
def read_e57(path, *, progress=None, should_stop=None, params: Optional[ReadParams] = None) -> PointCloud:
    """Read all scans of an E57 file.

    Parameters
    ----------
    path : str or os.PathLike
    progress, should_stop : callables, optional
        Progress is reported per chunk of each scan.
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
    pye57, libe57 = _pye57()
    p = Progress.wrap(progress, should_stop)
    try:
        e57 = pye57.E57(path)
    except Exception as e:  # libE57 raises its own exception types
        why = str(e).split("****")[0].strip().splitlines()  # libE57's first line, not its debug trail
        why = why[0].strip() if why else type(e).__name__
        raise FormatError(f"not a readable E57 file ({why})", path) from None
    try:
        k = e57.scan_count
        if k == 0:
            raise FormatError("E57 file holds no scans", path)
        try:
            total = sum(int(e57.get_header(i).point_count) for i in range(k))
        except Exception as e:
            raise FormatError(f"cannot read the scan headers ({e})", path) from None
        xyz, cols, inten, idx, pos = [], [], [], [], []
        done = 0
        for i in range(k):
            try:
                x, c, it, t, n = _read_scan(e57, libe57, i, params, p, done, total, path)
            except IndoorError:  # ours (format, cancelled) pass through
                raise
            except Exception as e:
                raise FormatError(f"scan {i}: cannot read its points ({e})", path) from None
            done += n
            xyz.append(x)
            cols.append(c)
            inten.append(it)
            idx.append(np.full(len(x), i, np.int32))
            pos.append(t)
        p(1.0, "reading E57")
    finally:
        e57.close()
    colors = None if any(c is None for c in cols) else np.concatenate(cols)
    intensity = None if any(v is None for v in inten) else np.concatenate(inten)
    return finish_cloud(path, np.concatenate(xyz), colors=colors, intensity=intensity,
                        scan_index=np.concatenate(idx), scanner_positions=np.stack(pos), params=params)
