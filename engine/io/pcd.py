"""PCD (Point Cloud Library) files: ``DATA ascii``, ``binary`` and ``binary_compressed``.

Fields understood (others go to ``cloud.fields``; ``_`` padding fields are skipped):
``x y z`` -> ``xyz``; ``rgb`` / ``rgba`` (a packed 0xAARRGGBB word, stored as F or U) ->
``colors``; ``intensity`` -> ``intensity``; ``normal_x normal_y normal_z`` -> ``normals``.
``VIEWPOINT tx ty tz qw qx qy qz`` is the sensor pose: its translation becomes the cloud's
single scanner position (points are not transformed: PCL stores them in the same frame).

``binary_compressed`` bodies are ``uint32 compressed size, uint32 raw size`` then an LZF
stream of the points laid out field by field (all x, then all y, ...);
:func:`lzf_decompress` decodes it.
"""
from __future__ import annotations

import os
from typing import Optional

import numpy as np

from ..errors import FormatError, IndoorError
from ..pointcloud import PointCloud
from ..progress import Progress
from ._common import DEFAULT_PARAMS, ReadParams, check_file, finish_cloud, guard_reader, parse_count
from ._text import iter_text_chunks, parse_rows

__all__ = ["read_pcd", "lzf_decompress"]

_MAX_HEADER_LINES = 64
_TYPES = {("F", 4): "f4", ("F", 8): "f8", ("I", 1): "i1", ("I", 2): "i2", ("I", 4): "i4", ("I", 8): "i8",
          ("U", 1): "u1", ("U", 2): "u2", ("U", 4): "u4", ("U", 8): "u8"}
_TEXT_CHUNK_BYTES = 32 << 20
_MAX_HEADER_LINE_BYTES = 1 << 16
_LZF_MAX_EXPANSION = 88
"""An LZF token of 3 bytes (control, length, offset) yields at most 264 bytes, a literal
run fewer bytes than it takes: a stream decodes to at most 88 times its size."""


def lzf_decompress(data: bytes, expected_size: int) -> bytes:
    """Decode an LZF stream (liblzf format, as PCL writes it).

    A tight loop over the stream's tokens (one Python step per literal run or back
    reference, never per byte): control byte ``c < 32`` copies ``c + 1`` literal bytes;
    otherwise length ``(c >> 5) + 2`` (``7`` adds the next byte) bytes are copied from
    ``((c & 31) << 8) + next byte + 1`` bytes back, overlapping copies repeating the pattern.

    Parameters
    ----------
    data : bytes
        The compressed stream.
    expected_size : int
        Size of the decoded data in bytes.

    Returns
    -------
    bytes of length ``expected_size``

    Raises
    ------
    ValueError
        The stream is corrupt (a reference before the start, output overrun or underrun, a
        back reference cut at the end), or ``expected_size`` is more than the stream can
        decode to (checked before the output is allocated).
    """
    src = bytes(data)
    n = len(src)
    if expected_size < 0 or expected_size > _LZF_MAX_EXPANSION * n:
        raise ValueError(f"{n:,} LZF bytes cannot decode to {expected_size:,} bytes")
    out = bytearray(expected_size)
    ip = op = 0
    while ip < n:
        ctrl = src[ip]
        ip += 1
        if ctrl < 32:
            ln = ctrl + 1
            if op + ln > expected_size or ip + ln > n:
                raise ValueError("LZF literal run overruns the buffer")
            out[op:op + ln] = src[ip:ip + ln]
            op += ln
            ip += ln
        else:
            ln = ctrl >> 5
            if ip + (ln == 7) >= n:
                raise ValueError("LZF back reference cut at the end of the stream")
            if ln == 7:
                ln += src[ip]
                ip += 1
            ref = op - ((ctrl & 0x1F) << 8) - src[ip] - 1
            ip += 1
            ln += 2
            if ref < 0:
                raise ValueError("LZF back reference before the start of the output")
            if op + ln > expected_size:
                raise ValueError("LZF back reference overruns the buffer")
            dist = op - ref
            if dist >= ln:
                out[op:op + ln] = out[ref:ref + ln]
            else:  # overlapping: the last `dist` bytes repeat
                pat = bytes(out[ref:op])
                reps = -(-ln // dist)
                out[op:op + ln] = (pat * reps)[:ln]
            op += ln
    if op != expected_size:
        raise ValueError(f"LZF stream decodes to {op} bytes, expected {expected_size}")
    return bytes(out)


class _Header:
    pass


def _parse_header(path: str, f) -> _Header:
    h = _Header()
    h.fields = h.sizes = h.types = h.counts = None
    h.width = h.height = h.points = None
    h.viewpoint = None
    h.data = None
    nlines = 0
    while h.data is None:
        line = f.readline(_MAX_HEADER_LINE_BYTES)
        if not line:
            raise FormatError("PCD header has no DATA line", path)
        nlines += 1
        if nlines > _MAX_HEADER_LINES:
            raise FormatError("not a PCD file (no DATA line in the first lines)", path)
        if len(line) == _MAX_HEADER_LINE_BYTES and not line.endswith(b"\n"):
            raise FormatError(f"not a PCD file (header line {nlines} is longer than "
                              f"{_MAX_HEADER_LINE_BYTES >> 10} KB)", path)
        text = line.decode("ascii", errors="replace").strip()
        if not text or text.startswith("#"):
            continue
        t = text.split()
        kw, vals = t[0].upper(), t[1:]
        try:
            if kw == "VERSION":
                pass
            elif kw == "FIELDS" or kw == "COLUMNS":
                h.fields = vals
            elif kw == "SIZE":
                h.sizes = [parse_count(v, f"header line {nlines}: SIZE", path) for v in vals]
            elif kw == "TYPE":
                h.types = [v.upper() for v in vals]
            elif kw == "COUNT":
                h.counts = [parse_count(v, f"header line {nlines}: COUNT", path) for v in vals]
                if 0 in h.counts:
                    raise FormatError(f"header line {nlines}: a field has COUNT 0", path)
            elif kw == "WIDTH":
                h.width = parse_count(vals[0], "WIDTH", path)
            elif kw == "HEIGHT":
                h.height = parse_count(vals[0], "HEIGHT", path)
            elif kw == "POINTS":
                h.points = parse_count(vals[0], "POINTS", path)
            elif kw == "VIEWPOINT":
                h.viewpoint = [float(v) for v in vals[:7]]
            elif kw == "DATA":
                h.data = vals[0].lower()
            else:
                raise FormatError(f"not a PCD file (unknown header keyword {t[0][:20]!r} on line {nlines})",
                                  path)
        except IndoorError:
            raise
        except (IndexError, ValueError):
            raise FormatError(f"PCD header line {nlines} is malformed: {text[:60]!r}", path) from None
    h.header_lines = nlines
    if h.fields is None:
        raise FormatError("PCD header has no FIELDS line", path)
    nf = len(h.fields)
    if h.counts is None:
        h.counts = [1] * nf
    if h.sizes is None or h.types is None:
        if h.data != "ascii":
            raise FormatError("PCD header lacks SIZE or TYPE", path)
        h.sizes = h.sizes or [4] * nf
        h.types = h.types or ["F"] * nf
    if not (len(h.sizes) == len(h.types) == len(h.counts) == nf):
        raise FormatError("PCD header: FIELDS, SIZE, TYPE and COUNT have different lengths", path)
    if h.points is None:
        if h.width is None:
            raise FormatError("PCD header has neither POINTS nor WIDTH", path)
        h.points = h.width * (h.height or 1)
    elif h.width is not None and h.width * (h.height or 1) != h.points:
        raise FormatError(f"PCD header: WIDTH {h.width:,} x HEIGHT {h.height or 1:,} is not POINTS "
                          f"{h.points:,}", path)
    if h.data not in ("ascii", "binary", "binary_compressed"):
        raise FormatError(f"unknown PCD DATA type {h.data!r}", path)
    if not {"x", "y", "z"} <= set(h.fields):
        raise FormatError("PCD file has no x, y or z field", path)
    if any(c != 1 for name, c in zip(h.fields, h.counts) if name in ("x", "y", "z")):
        raise FormatError("PCD fields x, y and z must have COUNT 1", path)
    h.np_types = []
    for name, s, ty in zip(h.fields, h.sizes, h.types):
        code = _TYPES.get((ty, s))
        if code is None:
            raise FormatError(f"PCD field {name!r} has unsupported TYPE {ty} SIZE {s}", path)
        h.np_types.append(code)
    return h


@guard_reader("PCD")
def read_pcd(path, *, progress=None, should_stop=None, params: Optional[ReadParams] = None) -> PointCloud:
    """Read a PCD v0.5–0.7 file.

    Parameters
    ----------
    path : str or os.PathLike
    progress, should_stop : callables, optional
    params : ReadParams, optional

    Returns
    -------
    PointCloud
        ``xyz`` (n, 3) float64 metres; ``colors`` (n, 3) uint8 from ``rgb``/``rgba``;
        ``intensity`` (n,) float32; ``normals`` (n, 3) float32; other fields in ``fields``
        (``COUNT`` > 1 gives an (n, count) field); ``scanner_positions`` (1, 3) from
        ``VIEWPOINT``. NaN points (PCL's organised clouds mark holes so) are dropped and
        counted in ``dropped_nonfinite``.

    Raises
    ------
    FormatError
        Malformed header (a count that is negative or not a whole number, WIDTH x HEIGHT
        other than POINTS), POINTS more than the file can hold (checked before anything is
        allocated), a truncated or corrupt body, compressed sizes that disagree with POINTS,
        wrong column count (ascii).
    EmptyCloudError
        No or too few finite points.
    """
    params = params or DEFAULT_PARAMS
    path = check_file(path)
    p = Progress.wrap(progress, should_stop)
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        h = _parse_header(path, f)
        n = h.points
        start = f.tell()
        warnings = []
        if h.data == "ascii":
            cols = _read_ascii(path, f, h, p, size, start)
        elif h.data == "binary":
            cols = _read_binary(path, f, h, p, size, start, params, warnings)
        else:
            cols = _read_compressed(path, f, h, p, size, start)
    xyz = np.empty((n, 3), np.float64)
    for k, nm in enumerate("xyz"):
        xyz[:, k] = cols[nm]
    colors = None
    col_name = "rgb" if "rgb" in cols else "rgba" if "rgba" in cols else None
    if col_name is not None:
        packed = np.ascontiguousarray(cols[col_name])
        if packed.dtype.itemsize == 4:
            word = packed.view(np.uint32)
        else:
            word = packed.astype(np.uint32)
        colors = np.stack([(word >> 16) & 0xFF, (word >> 8) & 0xFF, word & 0xFF], axis=1).astype(np.uint8)
    intensity = cols.get("intensity")
    normals = None
    if all(("normal_" + c) in cols for c in "xyz"):
        normals = np.stack([cols["normal_" + c] for c in "xyz"], axis=1).astype(np.float32)
    used = {"x", "y", "z", "intensity", col_name, "_"}
    if normals is not None:
        used |= {"normal_x", "normal_y", "normal_z"}
    fields = {k: v for k, v in cols.items() if k not in used}
    sp = None
    if h.viewpoint is not None and len(h.viewpoint) >= 3:
        sp = np.asarray(h.viewpoint[:3], dtype=np.float64).reshape(1, 3)
    return finish_cloud(path, xyz, colors=colors, intensity=intensity, normals=normals, scanner_positions=sp,
                        fields=fields, warnings=warnings, params=params)


def _split_columns(h, table_or_getter, n):
    """Map PCD fields (with COUNT) onto per-field arrays from a getter of flat columns."""
    cols = {}
    k = 0
    for name, c, code in zip(h.fields, h.counts, h.np_types):
        if name == "_":
            k += c
            continue
        vals = [table_or_getter(k + j).astype(code, copy=False) for j in range(c)]
        cols[name] = vals[0] if c == 1 else np.stack(vals, axis=1)
        k += c
    return cols


def _read_ascii(path, f, h, p, size, start):
    ncols = sum(h.counts)
    n = h.points
    avail = max(size - start, 0) + 1  # + 1: the last row may lack its newline
    if n * 2 * ncols > avail:  # a row needs a digit and a separator per value
        raise FormatError(f"the header declares {n:,} points but the {avail - 1:,} bytes after the header "
                          f"can hold at most {avail // (2 * ncols):,} rows of {ncols} values", path)
    parts = []
    got = 0
    for text, line, done in iter_text_chunks(f, _TEXT_CHUNK_BYTES, h.header_lines + 1):
        rows = parse_rows(text, ncols, path, line)
        parts.append(rows)
        got += len(rows)
        p((done) / max(size - start, 1), "reading PCD")
    table = np.concatenate(parts) if parts else np.zeros((0, ncols))
    if len(table) < n:
        raise FormatError(f"the header declares {n:,} points but the file holds only "
                          f"{len(table):,} rows", path)
    if len(table) > n:
        raise FormatError(f"the header declares {n:,} points but the file holds {len(table):,} rows", path)
    # ascii rgb is written as a float whose bits are the packed colour
    cols = _split_columns(h, lambda j: table[:, j], n)
    for name in ("rgb", "rgba"):
        if name in cols and cols[name].dtype.kind == "f":
            cols[name] = cols[name].astype(np.float32)
    return cols


def _read_binary(path, f, h, p, size, start, params, warnings):
    n = h.points
    dt = np.dtype([(f"c{k}", "<" + code, (c,)) if c > 1 else (f"c{k}", "<" + code)
                   for k, (code, c) in enumerate(zip(h.np_types, h.counts))])
    available = (size - start) // dt.itemsize
    if available < n:
        raise FormatError(f"truncated binary body: the header declares {n:,} points "
                          f"({n * dt.itemsize:,} bytes) but the file holds only {available:,}", path)
    if available > n:
        warnings.append(f"{size - start - n * dt.itemsize:,} bytes follow the header's {n:,} points (room "
                        f"for {available - n:,} more): POINTS may be too small; only {n:,} points were read")
    rec = np.empty(n, dt)
    step = max(int(params.chunk_points), 1)
    for i in range(0, n, step):
        m = min(step, n - i)
        rec[i:i + m] = np.fromfile(f, dtype=dt, count=m)
        p((i + m) / max(n, 1), "reading PCD")
    cols = {}
    for k, (name, c) in enumerate(zip(h.fields, h.counts)):
        if name != "_":
            cols[name] = np.ascontiguousarray(rec[f"c{k}"])
    return cols


def _read_compressed(path, f, h, p, size, start):
    n = h.points
    head = f.read(8)
    if len(head) < 8:
        raise FormatError("truncated binary_compressed body: no size words after the header", path)
    csize, usize = (int(v) for v in np.frombuffer(head, "<u4"))
    present = max(size - start - 8, 0)
    if csize > present:  # checked before reading: a corrupt size would allocate up to 4 GB
        raise FormatError(f"truncated binary_compressed body: {csize:,} compressed bytes declared, "
                          f"{present:,} present", path)
    item = [np.dtype(code).itemsize * c for code, c in zip(h.np_types, h.counts)]
    need = n * sum(item)
    if usize < need:
        raise FormatError(f"the header declares {n:,} points ({need:,} bytes) but the compressed body "
                          f"holds only {usize:,} bytes", path)
    if usize > need:
        raise FormatError(f"the compressed body declares {usize:,} uncompressed bytes but the header's "
                          f"{n:,} points of {sum(item)} bytes are {need:,} bytes (corrupt size word?)", path)
    if need > _LZF_MAX_EXPANSION * csize:
        raise FormatError(f"the header declares {n:,} points ({need:,} bytes) but {csize:,} compressed "
                          f"bytes can decode to at most {_LZF_MAX_EXPANSION * csize:,}", path)
    comp = f.read(csize)
    if len(comp) < csize:
        raise FormatError(f"truncated binary_compressed body: {csize:,} compressed bytes declared, "
                          f"{len(comp):,} present", path)
    p(0.05, "decompressing PCD")
    try:
        raw = lzf_decompress(comp, usize)
    except ValueError as e:
        raise FormatError(f"corrupt binary_compressed body: {e}", path) from None
    p(0.9, "decompressing PCD")
    cols = {}
    pos = 0
    for name, code, c, nbytes in zip(h.fields, h.np_types, h.counts, item):
        block = np.frombuffer(raw, dtype="<" + code, count=n * c, offset=pos)
        pos += n * nbytes
        if name == "_":
            continue
        cols[name] = block.copy() if c == 1 else block.reshape(n, c).copy()
    p(1.0, "reading PCD")
    return cols
