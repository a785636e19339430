"""PLY point clouds: read ASCII and binary (little/big endian), write binary or ASCII.

Vertex properties understood (other scalar properties go to ``cloud.fields`` by name):

==========================================  ====================================
``x y z`` (float, double or integer)        ``xyz`` (float64 metres)
``red green blue`` (also ``r g b``,         ``colors`` (uint8; 16-bit values are
``diffuse_red``...)                          scaled by 1/257, floats in [0, 1] by 255)
``nx ny nz`` (also ``normal_x``...)         ``normals`` (float32)
``intensity`` (also ``scalar_intensity``,   ``intensity`` (float32)
``reflectance``)
``scan_index``                              ``scan_index`` (int32)
``<name>__0``, ``<name>__1``...             one (n, k) field ``<name>``
==========================================  ====================================

Comments written by :func:`write_ply` and read back: ``comment indoor_offset X Y Z`` (the
cloud's removed offset, metres) and ``comment indoor_scanner I X Y Z`` (scanner position of
scan ``I`` in the file's frame). Elements other than ``vertex`` (faces...) are skipped.

:func:`write_ply_arrays` writes any named vertex arrays and triangles (the coloured meshes
and points of the evaluation and the change detection); :func:`write_ply` is the same
writer with a cloud's attributes.
"""
from __future__ import annotations

import os
import re
from typing import Mapping, Optional, Sequence

import numpy as np

from ..errors import FormatError, IndoorError
from ..fileutil import atomic_path
from ..pointcloud import PointCloud
from ..progress import Progress
from ._common import (DEFAULT_PARAMS, ReadParams, check_file, colors_to_u8, finish_cloud, guard_reader,
                      parse_count)
from ._text import count_lines, iter_text_chunks, parse_rows, take_lines

__all__ = ["read_ply", "write_ply", "write_ply_arrays"]

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_NP_TO_PLY = {"i1": "char", "u1": "uchar", "i2": "short", "u2": "ushort", "i4": "int", "u4": "uint",
              "f4": "float", "f8": "double"}
_MAX_HEADER_BYTES = 1 << 20
_END_HEADER = re.compile(rb"(?:^|\n)end_header[ \t\r]*\n")
"""The line ending the header: ``end_header`` alone on its line (not inside a comment)."""
_ASCII_CHUNK_BYTES = 32 << 20

_ROLE_NAMES = {
    "x": ("xyz", 0), "y": ("xyz", 1), "z": ("xyz", 2),
    "red": ("colors", 0), "green": ("colors", 1), "blue": ("colors", 2),
    "r": ("colors", 0), "g": ("colors", 1), "b": ("colors", 2),
    "diffuse_red": ("colors", 0), "diffuse_green": ("colors", 1), "diffuse_blue": ("colors", 2),
    "nx": ("normals", 0), "ny": ("normals", 1), "nz": ("normals", 2),
    "normal_x": ("normals", 0), "normal_y": ("normals", 1), "normal_z": ("normals", 2),
    "intensity": ("intensity", None), "scalar_intensity": ("intensity", None),
    "reflectance": ("intensity", None),
    "scan_index": ("scan_index", None),
}
_GROUPED = re.compile(r"^(.+)__(\d+)$")


class _Header:
    def __init__(self):
        self.format = None
        self.elements = []  # (name, count, [(prop, type) | (prop, "list", count_t, item_t)])
        self.comments = []
        self.data_start = 0
        self.header_lines = 0


def _parse_header(path: str, f) -> _Header:
    head = f.read(4)
    if head[:3] != b"ply":
        raise FormatError("not a PLY file (it does not start with 'ply')", path)
    f.seek(0)
    raw = b""
    m = None
    while m is None:
        block = f.read(65536)
        if not block:
            raise FormatError("PLY header has no 'end_header' line", path)
        raw += block
        m = _END_HEADER.search(raw)
        if m is None and len(raw) > _MAX_HEADER_BYTES:
            raise FormatError("PLY header has no 'end_header' line in its first megabyte", path)
    h = _Header()
    h.data_start = m.end()
    h.header_lines = raw[: m.end()].count(b"\n")
    lines = raw[: m.start()].decode("ascii", errors="replace").splitlines()
    for k, line in enumerate(lines[1:], start=2):
        t = line.split()
        if not t:
            continue
        kw = t[0]
        try:
            if kw == "format":
                if t[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                    raise FormatError(f"unknown PLY format {t[1][:40]!r}", path)
                h.format = t[1]
            elif kw in ("comment", "obj_info"):
                h.comments.append(line.split(None, 1)[1] if len(t) > 1 else "")
            elif kw == "element":
                count = parse_count(t[2], f"header line {k}: the count of element {t[1][:40]!r}", path)
                h.elements.append((t[1], count, []))
            elif kw == "property":
                if not h.elements:
                    raise FormatError(f"header line {k}: property before any element", path)
                if t[1] == "list":
                    count_t = _ptype(t[2], path)
                    if np.dtype(count_t).kind not in "iu":
                        raise FormatError(f"header line {k}: the count type of list property {t[4]!r} "
                                          f"must be an integer type, not {t[2]!r}", path)
                    h.elements[-1][2].append((t[4], "list", count_t, _ptype(t[3], path)))
                else:
                    h.elements[-1][2].append((t[2], _ptype(t[1], path)))
            else:
                raise FormatError(f"header line {k}: unknown keyword {kw[:40]!r}", path)
        except IndoorError:
            raise
        except (IndexError, ValueError):
            raise FormatError(f"header line {k}: malformed {line.strip()[:80]!r}", path) from None
    if h.format is None:
        raise FormatError("PLY header has no 'format' line", path)
    return h


def _ptype(name: str, path: str) -> str:
    try:
        return _PLY_TYPES[name]
    except KeyError:
        raise FormatError(f"unknown PLY property type {name[:40]!r}", path) from None


def _record_bytes(props) -> tuple:
    """(bytes of one binary record, whether that size is exact): a list property adds only
    its count (an empty list), so with lists the size is a lower bound."""
    total, exact = 0, True
    for pr in props:
        if len(pr) == 2:
            total += np.dtype(pr[1]).itemsize
        else:
            total += np.dtype(pr[2]).itemsize
            exact = False
    return total, exact


def _binary_layout(path, h, vi, endian, size):
    """Check every element count against the bytes after the header, before anything is
    allocated, and locate the vertices.

    Returns
    -------
    start : int
        File offset of the first vertex.
    dt : numpy.dtype
        The vertex record.
    warnings : list of str
        Data beyond the declared elements, or elements after the vertices that cannot fit.

    Raises
    ------
    FormatError
        An element before the vertices has list properties or does not fit in the file;
        the vertices do not fit ("truncated binary body").
    """
    avail = max(size - h.data_start, 0)
    skip = 0
    for name, count, eprops in h.elements[:vi]:
        if any(len(pr) != 2 for pr in eprops):
            raise FormatError(f"PLY element {name!r} before 'vertex' has list properties; "
                              "cannot locate the vertices", path)
        rec, _ = _record_bytes(eprops)
        if skip + count * rec > avail:
            raise FormatError(f"the header declares {count:,} {name!r} elements before the vertices "
                              f"({count * rec:,} bytes) but only {avail - skip:,} bytes follow the header",
                              path)
        skip += count * rec
    _, n, props = h.elements[vi]
    try:
        dt = np.dtype([(pr[0], endian + pr[1]) for pr in props])
    except (ValueError, TypeError) as e:  # e.g. two properties with one name
        raise FormatError(f"bad PLY vertex properties ({e})", path) from None
    left = avail - skip
    available = left // dt.itemsize if dt.itemsize else 0
    if available < n:
        raise FormatError(
            f"truncated binary body: the header declares {n:,} vertices "
            f"({n * dt.itemsize:,} bytes) but the file holds only {available:,}", path)
    left -= n * dt.itemsize
    warnings = []
    after, exact, smallest = 0, True, dt.itemsize
    for name, count, eprops in h.elements[vi + 1:]:
        rec, ex = _record_bytes(eprops)
        after += count * rec
        exact &= ex
        smallest = min(smallest, rec) if rec else smallest
        if after > left:
            warnings.append(f"the header declares {count:,} {name!r} elements after the vertices, more "
                            f"than the remaining {left:,} bytes can hold; only the vertices are read")
            return h.data_start + skip, dt, warnings
    trailing = left - after
    if exact and smallest and trailing >= smallest:
        warnings.append(f"{trailing:,} bytes follow the elements the header declares (room for "
                        f"{trailing // dt.itemsize:,} more vertices): the header's counts may be too "
                        f"small; only the declared {n:,} vertices were read")
    return h.data_start + skip, dt, warnings


def _ascii_rows_check(path, h, vi, size):
    """Check the ASCII element counts against the bytes after the header before anything
    is allocated: a row needs at least a digit and a separator per property (a list at
    least its count), so ``count * 2 * properties`` bytes (the last row may lack its
    newline). Returns warnings about elements after the vertices that cannot fit.

    Raises
    ------
    FormatError
        An element up to and including the vertices cannot fit.
    """
    avail = max(size - h.data_start, 0) + 1  # + 1: the last row may lack its newline
    used = 0
    warnings = []
    for i, (name, count, eprops) in enumerate(h.elements):
        row = 2 * max(len(eprops), 1)
        if used + count * row > avail:
            most = max(avail - used, 0) // row
            if i > vi:
                warnings.append(f"the header declares {count:,} {name!r} elements after the vertices, "
                                f"more than the file can hold; only the vertices are read")
                break
            raise FormatError(f"the header declares {count:,} {name!r} elements but the "
                              f"{avail - 1:,} bytes after the header can hold at most {most:,} rows of "
                              f"{len(eprops)} values", path)
        used += count * row
    return warnings


def _comment_values(comments, key):
    out = []
    for c in comments:
        t = c.split()
        if t and t[0] == key:
            try:
                out.append([float(v) for v in t[1:]])
            except ValueError:
                pass
    return out


class _Assembler:
    """Preallocated output arrays and the property -> (array, column) copy plan."""

    def __init__(self, names, dtypes, n):
        self.n = n
        self.arrays = {}
        self.plan = []
        self.raw_color_dtype = None
        self.fused = []
        groups = {}
        cols_of = {}
        for name in names:
            role = _ROLE_NAMES.get(name.lower())
            if role is not None and role[1] is not None:
                cols_of.setdefault(role[0], set()).add(role[1])
        for name, dt in zip(names, dtypes):
            role = _ROLE_NAMES.get(name.lower())
            if role is not None and role[0] in self.arrays and role[1] is None:
                role = None  # a second intensity-like property: keep it as a field
            if role is not None and role[1] is not None and cols_of[role[0]] != {0, 1, 2}:
                role = None  # an incomplete colour or normal triple: keep its parts as fields
            if role is not None:
                target, col = role
                if target not in self.arrays:
                    if target == "xyz":
                        self.arrays[target] = np.zeros((n, 3), np.float64)
                    elif target == "colors":
                        self.raw_color_dtype = np.dtype(dt)
                        self.arrays[target] = np.zeros((n, 3), np.dtype(dt))
                    elif target == "normals":
                        self.arrays[target] = np.zeros((n, 3), np.float32)
                    elif target == "intensity":
                        self.arrays[target] = np.zeros(n, np.float32)
                    else:
                        self.arrays[target] = np.zeros(n, np.int32)
                self.plan.append((name, target, col))
                continue
            m = _GROUPED.match(name)
            if m:
                groups.setdefault(m.group(1), []).append((int(m.group(2)), name, dt))
                continue
            key = "field:" + name
            self.arrays[key] = np.zeros(n, np.dtype(dt))
            self.plan.append((name, key, None))
        for base, items in groups.items():
            items.sort()
            if [i for i, _, _ in items] != list(range(len(items))) or ("field:" + base) in self.arrays:
                for _, name, dt in items:  # not a clean 0..k-1 group: keep separate
                    self.arrays["field:" + name] = np.zeros(n, np.dtype(dt))
                    self.plan.append((name, "field:" + name, None))
                continue
            self.arrays["field:" + base] = np.zeros((n, len(items)), np.dtype(items[0][2]))
            for i, name, _ in items:
                self.plan.append((name, "field:" + base, i))

    def fuse(self, dt: np.dtype):
        """Group consecutive same-type properties that fill columns 0, 1, 2 of one target
        (x y z, red green blue, nx ny nz) so a chunk is copied with one strided copy each."""
        plan, fused = [], []
        i = 0
        while i < len(self.plan):
            trio = self.plan[i:i + 3]
            if len(trio) == 3 and all(t[1] == trio[0][1] for t in trio) and [t[2] for t in trio] == [0, 1, 2]:
                f = [dt.fields[t[0]] for t in trio]
                if f[0][0] == f[1][0] == f[2][0] and f[1][1] == f[0][1] + f[0][0].itemsize \
                        and f[2][1] == f[1][1] + f[0][0].itemsize:
                    fused.append((trio[0][1], f[0][0], f[0][1]))
                    i += 3
                    continue
            plan.append(self.plan[i])
            i += 1
        self.plan = plan
        self.fused = [(target, np.dtype({"names": ["v"], "formats": [(base, (3,))], "offsets": [off],
                                         "itemsize": dt.itemsize})) for target, base, off in fused]

    def put_records(self, start, chunk):
        """Copy one chunk of a structured array."""
        for target, view in self.fused:
            self.arrays[target][start:start + len(chunk)] = chunk.view(view)["v"]
        self.put(start, chunk.__getitem__)

    def put(self, start, get):
        """Copy one chunk: ``get(name)`` returns that property's values for the chunk."""
        for name, target, col in self.plan:
            v = get(name)
            a = self.arrays[target]
            if col is None:
                a[start:start + len(v)] = v
            else:
                a[start:start + len(v), col] = v


@guard_reader("PLY")
def read_ply(path, *, progress=None, should_stop=None, params: Optional[ReadParams] = None) -> PointCloud:
    """Read the ``vertex`` element of a PLY file.

    Binary bodies are read with a structured dtype in chunks of ``params.chunk_points``
    (progress reported per chunk); ASCII bodies are parsed in chunks of lines. Every
    element count is checked against the size of the file before anything is allocated.
    When the file holds more data than the header declares (binary: bytes beyond the
    declared elements; ASCII: more lines), the declared vertices are read and a warning
    is added to ``cloud.warnings``.

    Parameters
    ----------
    path : str or os.PathLike
    progress, should_stop : callables, optional
        See :class:`engine.progress.Progress`.
    params : ReadParams, optional

    Returns
    -------
    PointCloud
        ``xyz`` (n, 3) float64 metres (offset removed), optional colours, normals,
        intensity, scan_index and extra properties in ``fields``.

    Raises
    ------
    FormatError
        Not a PLY file, a malformed header (an unknown type, a count that is negative or not
        a whole number), no vertex element or no x/y/z, list properties in the vertex
        element, element counts larger than the file can hold (a truncated body), a bad
        ASCII line.
    EmptyCloudError
        No or too few finite points.
    """
    params = params or DEFAULT_PARAMS
    path = check_file(path)
    p = Progress.wrap(progress, should_stop)
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        h = _parse_header(path, f)
        names = [e[0] for e in h.elements]
        if "vertex" not in names:
            raise FormatError("PLY file has no 'vertex' element", path)
        vi = names.index("vertex")
        _, n, props = h.elements[vi]
        if any(len(pr) != 2 for pr in props):
            raise FormatError("list properties in the PLY vertex element are not supported", path)
        pnames = [pr[0] for pr in props]
        if len(set(pnames)) != len(pnames):
            raise FormatError("the PLY vertex element names a property twice", path)
        if not {"x", "y", "z"} <= set(pnames):
            raise FormatError("PLY vertex element lacks x, y or z", path)
        if h.format == "ascii":
            warnings = _ascii_rows_check(path, h, vi, size)  # before allocating
            asm = _Assembler(pnames, [pr[1] for pr in props], n)
            warnings += _read_ascii_body(path, f, h, vi, n, pnames, asm, p, params)
        else:
            endian = "<" if h.format == "binary_little_endian" else ">"
            start, dt, warnings = _binary_layout(path, h, vi, endian, size)  # before allocating
            asm = _Assembler(pnames, [pr[1] for pr in props], n)
            asm.fuse(dt)
            step = max(int(params.chunk_points), 1)
            try:  # map the body: chunks are copied straight from the page cache
                body = np.memmap(f, dtype=dt, mode="r", offset=start, shape=(n,)) if n else None
            except (OSError, ValueError):  # a file system without mmap: read into a buffer
                body = None
            if body is not None:
                try:
                    for i in range(0, n, step):
                        m = min(step, n - i)
                        asm.put_records(i, body[i:i + m])
                        p((i + m) / n, "reading PLY")
                finally:
                    mm = getattr(body, "_mmap", None)
                    del body
                    if mm is not None:
                        try:  # release the file now (Windows cannot replace a mapped file)
                            mm.close()
                        except BufferError:  # still referenced somewhere: the GC closes it
                            pass
            else:
                f.seek(start)
                buf = np.empty(min(step, n), dtype=dt)  # one reused buffer: no per-chunk allocation
                for i in range(0, n, step):
                    m = min(step, n - i)
                    chunk = buf[:m]
                    got = f.readinto(memoryview(chunk.view(np.uint8)))
                    if got != m * dt.itemsize:
                        raise FormatError(f"truncated binary body at vertex "
                                          f"{i + got // dt.itemsize:,} of {n:,}", path)
                    asm.put_records(i, chunk)
                    p((i + m) / max(n, 1), "reading PLY")
    return _finish(path, h, asm, params, warnings)


def _read_ascii_body(path, f, h, vi, n, pnames, asm, p, params) -> list:
    """Stream the vertex lines of an ASCII body in chunks of about ``_ASCII_CHUNK_BYTES``.

    Blank lines are skipped. Returns warnings: more non-blank lines than the header's
    elements declare.
    """
    f.seek(h.data_start)
    size = max(os.path.getsize(path) - h.data_start, 1)
    skip = sum(e[1] for e in h.elements[:vi])  # rows of the elements before 'vertex'
    line_no = h.header_lines + 1
    skipped = 0
    while skipped < skip:
        line = f.readline()
        if not line:
            raise FormatError(f"the header declares {skip:,} rows of elements before the vertices "
                              f"but the file holds only {skipped:,} lines", path)
        line_no += 1
        skipped += bool(line.strip())
    ncols = len(pnames)
    got = 0
    tail = 0  # non-blank lines after the vertices
    for text, first, done in iter_text_chunks(f, _ASCII_CHUNK_BYTES, line_no):
        need = n - got
        if need <= 0:
            tail += count_lines(text)
            continue
        text, rest = take_lines(text, need)  # the vertex lines may end in this chunk: faces follow
        vals = parse_rows(text, ncols, path, first_line=first)
        cols = {nm: vals[:, k] for k, nm in enumerate(pnames)}
        m = len(vals)
        asm.put(got, lambda nm: cols[nm][:m])
        got += m
        tail += count_lines(rest)
        p(min(done / size, got / max(n, 1)), "reading PLY")
    if got < n:
        raise FormatError(f"the header declares {n:,} vertices but the file holds only "
                          f"{got:,} vertex lines", path)
    declared = sum(e[1] for e in h.elements[vi + 1:])
    if tail > declared:
        what = "vertices" if vi + 1 == len(h.elements) else "elements"
        return [f"the file holds {tail - declared:,} more lines than the header's {what} declare: its "
                f"counts may be too small; only the declared {n:,} vertices were read"]
    return []


def _finish(path, h, asm, params, warnings):
    a = asm.arrays
    colors = None if "colors" not in a else colors_to_u8(a["colors"])
    fields = {k[6:]: v for k, v in a.items() if k.startswith("field:")}
    offs = _comment_values(h.comments, "indoor_offset")
    offset = np.asarray(offs[-1][:3]) if offs and len(offs[-1]) >= 3 else None
    scanners = sorted((int(v[0]), v[1:4])
                      for v in _comment_values(h.comments, "indoor_scanner") if len(v) >= 4)
    sp = np.asarray([s[1] for s in scanners], dtype=np.float64) if scanners else None
    return finish_cloud(path, a["xyz"], colors=colors, intensity=a.get("intensity"), normals=a.get("normals"),
                        scan_index=a.get("scan_index"), scanner_positions=sp, fields=fields, offset=offset,
                        warnings=warnings, params=params)


def write_ply(path, cloud: PointCloud, *, binary: bool = True, dtype: str = "f8") -> None:
    """Write a cloud as a PLY file, atomically (a temporary file moved into place).

    Written vertex properties: ``x y z`` (``dtype`` "f8" double or "f4" float, the cloud's
    offset-removed coordinates), ``red green blue`` (uchar), ``intensity`` (float),
    ``nx ny nz`` (float), ``scan_index`` (int), then every ``cloud.fields`` array (1-D as one
    property, (n, k) as ``name__0..name__{k-1}``; bool is written as uchar; 64-bit integers
    as int/uint, which must fit). The offset and scanner positions go into comments so
    :func:`read_ply` restores them.

    Parameters
    ----------
    path : str or os.PathLike
    cloud : PointCloud
    binary : bool
        Little-endian binary (default) or ASCII.
    dtype : {"f8", "f4"}
        Coordinate precision.
    """
    if dtype not in ("f8", "f4"):
        raise ValueError(f"dtype must be 'f8' or 'f4', not {dtype!r}")
    n = len(cloud)
    cols = []  # (name, np type code, values (n,))
    for k, nm in enumerate("xyz"):
        cols.append((nm, dtype, cloud.xyz[:, k]))
    if cloud.colors is not None:
        for k, nm in enumerate(("red", "green", "blue")):
            cols.append((nm, "u1", cloud.colors[:, k]))
    if cloud.intensity is not None:
        cols.append(("intensity", "f4", cloud.intensity))
    if cloud.normals is not None:
        for k, nm in enumerate(("nx", "ny", "nz")):
            cols.append((nm, "f4", cloud.normals[:, k]))
    if cloud.scan_index is not None:
        cols.append(("scan_index", "i4", cloud.scan_index))
    for name, v in cloud.fields.items():
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise ValueError(f"field name {name!r} cannot be a PLY property name")
        v = np.asarray(v)
        code = _field_code(name, v)
        if v.ndim == 1:
            cols.append((name, code, v))
        else:
            v2 = v.reshape(n, -1)
            for i in range(v2.shape[1]):
                cols.append((f"{name}__{i}", code, v2[:, i]))
    comments = ["written by indoor-reconstruction engine.io.write_ply"]
    if np.any(cloud.offset != 0):
        comments.append("indoor_offset " + " ".join(repr(float(v)) for v in cloud.offset))
    if cloud.scanner_positions is not None:
        for i, s in enumerate(cloud.scanner_positions):
            comments.append(f"indoor_scanner {i} " + " ".join(repr(float(v)) for v in s))
    _write(path, n, cols, None, binary, comments)


_ARRAY_CODES = {"f8", "f4", "u1", "i1", "i2", "u2", "i4", "u4"}
"""numpy types :func:`write_ply_arrays` writes as they are (kind and byte size)."""


def write_ply_arrays(path, vertex: Mapping[str, np.ndarray], faces: Optional[np.ndarray] = None, *,
                     binary: bool = True, comments: Sequence[str] = ("written by indoor engine.io",)) -> None:
    """Write a PLY of the given vertex properties (and triangles), atomically.

    Parameters
    ----------
    path : str or os.PathLike
    vertex : name → (n,) array; ``x``, ``y``, ``z`` first. Types follow the arrays
        (float64 → double, float32 → float, uint8 → uchar, int32 → int, ...; bool → uchar,
        int64 → int, anything else → double).
    faces : (m, 3) int triangles or None.
    binary : little-endian binary (default) or ASCII.
    comments : header comment lines.
    """
    cols = []
    for k, a in vertex.items():
        a = np.asarray(a)
        if a.dtype == np.bool_:
            a = a.astype(np.uint8)
        elif a.dtype == np.int64:
            a = a.astype(np.int32)
        elif not (a.dtype.isnative and f"{a.dtype.kind}{a.dtype.itemsize}" in _ARRAY_CODES):
            a = a.astype(np.float64)
        cols.append((k, f"{a.dtype.kind}{a.dtype.itemsize}", a.reshape(-1)))
    n = len(cols[0][2]) if cols else 0
    f = None if faces is None else np.asarray(faces, dtype=np.int32).reshape(-1, 3)
    _write(path, n, cols, f, binary, comments)


def _write(path, n: int, cols: list, faces: Optional[np.ndarray], binary: bool,
           comments: Sequence[str]) -> None:
    """The PLY writer: ``cols`` is [(name, numpy type code such as "f8", (n,) values)],
    ``faces`` (m, 3) int32 triangles or None; written through a temporary file."""
    lines = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0"]
    lines += [f"comment {c}" for c in comments]
    lines.append(f"element vertex {n}")
    lines += [f"property {_NP_TO_PLY[c]} {nm}" for nm, c, _ in cols]
    if faces is not None:
        lines += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    lines.append("end_header")
    header = ("\n".join(lines) + "\n").encode("ascii")
    with atomic_path(path, suffix=".ply") as tmp:
        with open(tmp, "wb") as f:
            f.write(header)
            if binary:
                rec = np.empty(n, dtype=[(nm, "<" + c) for nm, c, _ in cols])
                for nm, _, v in cols:
                    rec[nm] = v
                rec.tofile(f)
                if faces is not None:
                    fd = np.empty(len(faces), dtype=[("n", "u1"), ("v", "<i4", (3,))])
                    fd["n"] = 3
                    fd["v"] = faces
                    fd.tofile(f)
            else:
                fmts = ["%.17g" if c == "f8" else "%.9g" if c == "f4" else "%d" for _, c, _ in cols]
                table = np.empty((n, len(cols)), dtype=np.float64)
                for k, (_, _, v) in enumerate(cols):
                    table[:, k] = v
                np.savetxt(f, table, fmt=fmts, delimiter=" ")
                if faces is not None:
                    np.savetxt(f, np.column_stack([np.full(len(faces), 3), faces]), fmt="%d", delimiter=" ")


def _field_code(name: str, v: np.ndarray) -> str:
    if v.dtype == np.bool_:
        return "u1"
    if v.dtype.kind == "f":
        return "f8" if v.dtype.itemsize == 8 else "f4"
    if v.dtype.kind in "iu":
        code = f"{v.dtype.kind}{min(v.dtype.itemsize, 4)}"
        if v.dtype.itemsize > 4 and v.size:
            info = np.iinfo(code)
            if v.min() < info.min or v.max() > info.max:
                raise ValueError(f"field {name!r} does not fit a 32-bit PLY integer")
        return code
    raise ValueError(f"field {name!r} has dtype {v.dtype}, which PLY cannot store")
