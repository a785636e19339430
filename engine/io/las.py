"""LAS / LAZ files through laspy (LAZ needs the ``lazrs`` or ``laszip`` backend).

Coordinates are the scaled values (``X * scale + offset`` per the header); a scale of 0 or a
non-finite scale or offset is refused (it would put every point on one plane or nowhere).
The header's point count is checked against the file size (LAS) before anything is
allocated; a LAZ file's arrays grow with the points actually decoded. Colour (16-bit in
the LAS specification) is scaled to 8 bits; files whose colour never exceeds 255 (a common
writer bug: 8-bit values in the 16-bit fields) are kept as they are. Intensity -> intensity;
``classification`` and extra bytes dimensions -> ``cloud.fields``.
"""
from __future__ import annotations

import os
import struct
from typing import Optional

import numpy as np

from ..errors import FormatError, MissingDependencyError
from ..pointcloud import PointCloud
from ..progress import Progress
from ._common import DEFAULT_PARAMS, ReadParams, check_file, colors_to_u8, finish_cloud, guard_reader

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


_LAZ_FIRST_RATIO = 64
"""A LAZ file's arrays start at this many times the points its compressed bytes would hold
uncompressed (real LAZ files compress 5-20 times) and double when more points decode, up to
the header's count: a corrupt count allocates nothing the data do not fill."""


def _check_transform(hdr, path: str) -> None:
    """Refuse a scale of 0 or a non-finite scale or offset on any axis."""
    scales = np.asarray(hdr.scales, dtype=np.float64).reshape(3)
    offsets = np.asarray(hdr.offsets, dtype=np.float64).reshape(3)
    for k, axis in enumerate("xyz"):
        if not np.isfinite(scales[k]):
            raise FormatError(f"the header's {axis} scale factor is {scales[k]!r}: the coordinates cannot "
                              "be decoded", path)
        if scales[k] == 0:
            raise FormatError(f"the header's {axis} scale factor is 0: every point would have {axis} = "
                              f"{offsets[k]!r} (a corrupt header?)", path)
        if not np.isfinite(offsets[k]):
            raise FormatError(f"the header's {axis} offset is {offsets[k]!r}: the coordinates cannot "
                              "be decoded", path)


_VLR_HEADER = 54
_EVLR_HEADER = 60
_LASZIP_VARIABLE_CHUNKS = 0xFFFFFFFF
_CHUNK_BYTES_LIMIT = 1 << 30
_CHUNK_FILE_RATIO = 64
"""A LAZ chunk size (points per chunk) whose records exceed max(1 GiB, 64 x the file size)
is refused: the decoder allocates a chunk's records at once, and a corrupt size (a random
32-bit value) would abort the process on a failed allocation. Real writers use 50,000."""



def _records(path, f, size: int, pos: int, count: int, head_size: int, length_fmt: str, what: str):
    """Walk ``count`` (extended) variable-length records from byte ``pos``: yield
    ``(header bytes, position, payload length)``; FormatError when one is cut or ends beyond
    the file (``length_fmt`` the payload length's struct format at byte 20 of the header)."""
    for k in range(count):
        f.seek(pos)
        head = f.read(head_size)
        if len(head) < head_size:
            raise FormatError(f"truncated: {what}variable-length record {k + 1} of {count:,} is cut", path)
        length = struct.unpack_from(length_fmt, head, 20)[0]
        if pos + head_size + length > size:
            raise FormatError(f"{what}variable-length record {k + 1} ({length:,} bytes) ends beyond the "
                              "end of the file", path)
        yield head, pos, length
        pos += head_size + length

def _check_layout(path: str, size: int) -> None:
    """Check the raw LAS header before laspy reads it: every size laspy or the LAZ decoder
    allocates from (VLR and EVLR counts and lengths, the LAZ chunk size and chunk count)
    must fit in the file. A corrupt count otherwise makes laspy loop for hours creating
    billions of records, or the LAZ decoder abort the whole process (Blender with it) on a
    failed allocation. Files too short or without the ``LASF`` signature are left to laspy.

    Raises
    ------
    FormatError
        A count or length that the file cannot hold.
    """
    with open(path, "rb") as f:
        head = f.read(375)
        if len(head) < 227 or head[:4] != b"LASF":
            return
        minor = head[25]
        header_size, offset, n_vlrs = struct.unpack_from("<HII", head, 94)
        fmt, record = struct.unpack_from("<BH", head, 104)
        if not 227 <= header_size <= size:
            raise FormatError(f"the header size {header_size:,} is impossible (a LAS header has at least "
                              f"227 bytes; the file has {size:,})", path)
        if offset > size:
            raise FormatError(f"truncated: the point data start at byte {offset:,} but the file has "
                              f"{size:,} bytes", path)
        if n_vlrs * _VLR_HEADER > size - header_size:
            raise FormatError(f"the header declares {n_vlrs:,} variable-length records, more than the "
                              f"{size:,}-byte file can hold (a corrupt header)", path)
        chunk_size, laszip = None, None
        for vh, pos, length in _records(path, f, size, header_size, n_vlrs, _VLR_HEADER, "<H", ""):
            if vh[2:16] == b"laszip encoded" and struct.unpack_from("<H", vh, 18)[0] == 22204 \
                    and length >= 16:
                f.seek(pos + _VLR_HEADER)
                laszip = f.read(length)
                chunk_size = struct.unpack_from("<I", laszip, 12)[0]
        limit = max(_CHUNK_BYTES_LIMIT, _CHUNK_FILE_RATIO * size)
        if chunk_size is not None and chunk_size != _LASZIP_VARIABLE_CHUNKS:
            if chunk_size * max(record, 1) > limit:
                raise FormatError(f"the LAZ chunk size {chunk_size:,} points ({chunk_size * record:,} "
                                  "bytes a chunk) is implausible: a corrupt laszip record", path)
        if chunk_size is not None or fmt & 0x80:
            _check_chunk_table(path, f, size, offset, record, laszip, limit)
        if minor >= 4 and header_size >= 247:
            start, n_evlrs = struct.unpack_from("<QI", head, 235)
            if n_evlrs and (start > size or n_evlrs * _EVLR_HEADER > size - start):
                raise FormatError(f"the header declares {n_evlrs:,} extended variable-length records from "
                                  f"byte {start:,}, more than the {size:,}-byte file holds", path)
            for _ in _records(path, f, size, start, n_evlrs, _EVLR_HEADER, "<Q", "extended "):
                pass


def _is_decoder_panic(e: BaseException) -> bool:
    """A panic of the LAZ decoder (lazrs, Rust): pyo3 raises it as ``PanicException``, a
    BaseException, so ``except Exception`` does not catch it."""
    return type(e).__name__ == "PanicException"


def _check_chunk_table(path, f, size, offset, record, laszip, limit) -> None:
    """The LAZ chunk table (its offset is the first 8 bytes of the point data, or the last 8
    bytes of the file when written as -1) cannot list more chunks than there are bytes of
    compressed data; its entries (decoded with lazrs when the laszip record is known) must
    give chunks whose bytes fit in the file and whose records fit in ``limit`` bytes. An
    unreadable offset is left to the decoder (it reports it)."""
    f.seek(offset)
    raw = f.read(8)
    if len(raw) < 8:
        return
    table = struct.unpack("<q", raw)[0]
    if table == -1 and size >= 8:
        f.seek(size - 8)
        table = struct.unpack("<q", f.read(8))[0]
    if not offset + 8 <= table <= size - 8:
        return
    f.seek(table)
    _, chunks = struct.unpack("<II", f.read(8))
    data = table - offset - 8
    if chunks > data:
        raise FormatError(f"the LAZ chunk table lists {chunks:,} chunks but the compressed points take "
                          f"only {data:,} bytes (a corrupt chunk table)", path)
    try:
        import lazrs
    except ImportError:  # laspy reports the missing backend
        return
    if laszip is None:
        return
    try:
        f.seek(table)
        entries = lazrs.read_chunk_table_only(f, lazrs.LazVlr(laszip))
    except BaseException as e:
        if not (_is_decoder_panic(e) or isinstance(e, Exception)):
            raise
        raise FormatError(f"unreadable LAZ chunk table ({e})", path) from None
    total = 0
    for k, (points, nbytes) in enumerate(entries):
        total += nbytes
        if points * max(record, 1) > limit or total > data:
            raise FormatError(f"LAZ chunk {k + 1} of {len(entries):,} ({points:,} points, {nbytes:,} bytes) "
                              f"does not fit in the {data:,} bytes of compressed points (a corrupt chunk "
                              "table)", path)


class _Arrays:
    """The output arrays, allocated for ``cap`` points and doubled on demand up to ``n``."""

    def __init__(self, n, cap, has_rgb):
        self.n, self.cap = n, cap
        self.a = {"xyz": np.empty((cap, 3), np.float64), "inten": np.empty(cap, np.float32),
                  "cls": np.empty(cap, np.uint8)}
        if has_rgb:
            self.a["rgb"] = np.empty((cap, 3), np.uint16)

    def reserve(self, need):
        if need <= self.cap:
            return
        cap = min(self.n, max(need, 2 * self.cap))
        for k, v in self.a.items():
            grown = np.empty((cap,) + v.shape[1:], v.dtype)
            grown[:self.cap] = v
            self.a[k] = grown
        self.cap = cap

    def field(self, name, v):
        if name not in self.a:
            self.a[name] = np.empty((self.cap,) + v.shape[1:], v.dtype)
        return self.a[name]

    def trimmed(self, m):
        return {k: v if len(v) == m else v[:m] for k, v in self.a.items()}


@guard_reader("LAS/LAZ")
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
        Not a LAS file, a corrupt/truncated one, more points declared than the file holds, a
        scale of 0 or a non-finite scale/offset.
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
    _check_layout(path, os.path.getsize(path))  # before laspy allocates from the header
    try:
        reader = laspy.open(path)
    except laspy.errors.LaspyException as e:
        raise _las_error(e, path, "not a readable LAS/LAZ file") from None
    except (OSError, ValueError, EOFError, struct.error) as e:
        raise FormatError(f"not a readable LAS/LAZ file ({e})", path) from None
    except BaseException as e:
        if not _is_decoder_panic(e):
            raise
        raise FormatError(f"not a readable LAS/LAZ file (the LAZ decoder failed: {e})", path) from None
    with reader:
        hdr = reader.header
        _check_transform(hdr, path)
        n = int(hdr.point_count)
        record = int(hdr.point_format.size)
        body = max(os.path.getsize(path) - int(hdr.offset_to_point_data), 0)
        if getattr(hdr, "are_points_compressed", False) or path.lower().endswith(".laz"):
            cap = min(n, max(_LAZ_FIRST_RATIO * body // max(record, 1), 1))
        else:
            if n * record > body:  # checked before allocating: a corrupt count is not a 2 PiB array
                raise FormatError(f"truncated: the header declares {n:,} points ({n * record:,} bytes) but "
                                  f"the file holds only {body // max(record, 1):,}", path)
            cap = n
        dims = set(hdr.point_format.dimension_names)
        has_rgb = {"red", "green", "blue"} <= dims
        extra = list(hdr.point_format.extra_dimension_names)
        out = _Arrays(n, cap, has_rgb)
        got = 0
        step = max(int(params.chunk_points), 1)
        try:
            for chunk in reader.chunk_iterator(step):
                m = len(chunk)
                if got + m > n:
                    raise FormatError(f"holds more points than its header's {n:,}", path)
                out.reserve(got + m)
                a = out.a
                sl = slice(got, got + m)
                a["xyz"][sl, 0] = chunk.x
                a["xyz"][sl, 1] = chunk.y
                a["xyz"][sl, 2] = chunk.z
                if has_rgb:
                    a["rgb"][sl, 0] = chunk.red
                    a["rgb"][sl, 1] = chunk.green
                    a["rgb"][sl, 2] = chunk.blue
                a["inten"][sl] = chunk.intensity
                a["cls"][sl] = chunk.classification
                for name in extra:
                    v = np.asarray(chunk[name])
                    out.field("extra:" + name, v)[sl] = v
                got += m
                p(got / max(n, 1), "reading LAS")
        except laspy.errors.LaspyException as e:
            raise _las_error(e, path, f"corrupt LAS/LAZ data after {got:,} of the header's {n:,} points") \
                from None
        except (ValueError, OSError, EOFError, RuntimeError, struct.error) as e:
            raise FormatError(f"corrupt or truncated LAS/LAZ data after {got:,} of the header's {n:,} points "
                              f"({e})", path) from None
        except BaseException as e:
            if not _is_decoder_panic(e):
                raise
            raise FormatError(f"corrupt LAZ data after {got:,} of the header's {n:,} points (the LAZ "
                              f"decoder failed: {e})", path) from None
    if got < n:
        raise FormatError(f"truncated: the header declares {n:,} points but only {got:,} could be read", path)
    a = out.trimmed(got)
    fields = {k[6:]: v for k, v in a.items() if k.startswith("extra:")}
    fields["classification"] = a["cls"]
    colors = None
    if has_rgb:
        colors = colors_to_u8(a["rgb"])  # 16-bit scaled; 8-bit values in 16-bit fields kept
    return finish_cloud(path, a["xyz"], colors=colors, intensity=a["inten"], fields=fields, params=params)
