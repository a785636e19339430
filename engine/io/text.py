"""Plain-text point lists: ``.xyz``, ``.pts``, ``.txt``, ``.csv``.

One point per line, 3 or more numbers separated by spaces, tabs, commas or semicolons.
Leading non-numeric lines are header lines; a single integer line before the data is a
point count (Leica PTS writes one) and is checked against the number of rows.

Decimal commas (European software): fields separated by ``;``, tabs or spaces whose numbers
hold one comma, such as ``8,7751;0,1627;1,2500``, are read as 8.7751 0.1627 1.25. The
separator and decimal mark are told from the first data lines
(:func:`engine.io._text.detect_style`); a file that could be read two ways (``1,5, 2,5``)
or mixes ``,`` and ``.`` as decimal marks is refused, never guessed. Ordinary CSV (commas
between numbers with ``.`` decimals) reads as before. UTF-16 text and binary data (NUL
bytes) are refused with a message saying so.

Columns beyond ``x y z``:

* When the last header line names every column, names decide: ``x y z``; ``r g b`` /
  ``red green blue`` -> colour; ``i`` / ``intensity`` / ``reflectance`` -> intensity;
  ``nx ny nz`` / ``normal_x ...`` -> normals; other names -> ``cloud.fields``.
* Otherwise by column count (the common conventions): 3 ``x y z``; 4 ``x y z intensity``;
  6 ``x y z r g b``; 7 ``x y z intensity r g b`` (Leica PTS); 9 ``x y z r g b nx ny nz``
  (CloudCompare's export order); 10 ``x y z intensity r g b nx ny nz``; any other count
  keeps columns 4.. as fields ``column_3``, ``column_4``...

Colours are 0–255 (values above 255 are taken as 16-bit and scaled; fractions in [0, 1] are
scaled by 255). Intensity is kept as written. A PTS file with several blocks (a count line
before each scan's points) gives one scan per block in ``scan_index``; every count is
checked against its block.
"""
from __future__ import annotations

import os
import re
from typing import Optional

import numpy as np

from ..errors import FormatError
from ..pointcloud import PointCloud
from ..progress import Progress
from ._common import DEFAULT_PARAMS, ReadParams, check_file, colors_to_u8, finish_cloud, guard_reader
from ._text import detect_style, iter_text_chunks, parse_rows, split_tokens

__all__ = ["read_text"]

_MAX_HEADER_LINES = 50
_COUNT_LINE = re.compile(r"^[ \t]*(\d+)[ \t]*\r?\n", re.MULTILINE)
_CHUNK_BYTES = 32 << 20
_MAX_LINE_BYTES = 1 << 20
"""A header or first data line longer than this is not a point list."""
_SAMPLE_BYTES = 1 << 16
_SAMPLE_LINES = 200
"""The separator and decimal mark are told from at most this many lines (in 64 KB) of data."""
_NAME_ROLES = {
    "x": ("xyz", 0), "y": ("xyz", 1), "z": ("xyz", 2),
    "r": ("rgb", 0), "g": ("rgb", 1), "b": ("rgb", 2),
    "red": ("rgb", 0), "green": ("rgb", 1), "blue": ("rgb", 2),
    "i": ("intensity", None), "intensity": ("intensity", None), "reflectance": ("intensity", None),
    "nx": ("normals", 0), "ny": ("normals", 1), "nz": ("normals", 2),
    "normal_x": ("normals", 0), "normal_y": ("normals", 1), "normal_z": ("normals", 2),
}
_CONVENTIONS = {
    3: ["x", "y", "z"],
    4: ["x", "y", "z", "intensity"],
    6: ["x", "y", "z", "r", "g", "b"],
    7: ["x", "y", "z", "intensity", "r", "g", "b"],
    9: ["x", "y", "z", "r", "g", "b", "nx", "ny", "nz"],
    10: ["x", "y", "z", "intensity", "r", "g", "b", "nx", "ny", "nz"],
}


def _numbers(tokens):
    try:
        return [float(t) for t in tokens]
    except ValueError:
        return None


def _clean_name(t: str) -> str:
    return t.strip().strip("/#\"'").strip().lower()


def _check_encoding(path: str, start: bytes) -> None:
    """Refuse UTF-16/32 text and binary data (NUL bytes) with a message saying so."""
    if start[:4] in (b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff"):
        raise FormatError("the file is UTF-32 text; save it as UTF-8 or ASCII", path)
    if start[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise FormatError("the file is UTF-16 text; save it as UTF-8 or ASCII", path)
    if b"\x00" in start:
        raise FormatError("the file holds binary data (NUL bytes), not a text point list", path)


def _sample_lines(f, pos: int) -> list:
    """Up to ``_SAMPLE_LINES`` non-blank lines from ``pos`` (the file position is restored)."""
    f.seek(pos)
    block = f.read(_SAMPLE_BYTES)
    f.seek(pos)
    lines = block.decode("utf-8", errors="replace").splitlines()
    if len(block) == _SAMPLE_BYTES and len(lines) > 1:
        lines = lines[:-1]  # possibly cut
    return [ln for ln in lines if ln.strip()][:_SAMPLE_LINES]


@guard_reader("text")
def read_text(path, *, progress=None, should_stop=None, params: Optional[ReadParams] = None) -> PointCloud:
    """Read a text point list (see the module docstring for the column conventions).

    Parameters
    ----------
    path : str or os.PathLike
    progress, should_stop : callables, optional
    params : ReadParams, optional

    Returns
    -------
    PointCloud
        ``xyz`` (n, 3) float64 metres; ``colors`` (n, 3) uint8, ``intensity`` (n,) float32,
        ``normals`` (n, 3) float32 when the columns hold them; other columns in ``fields``
        (float64).

    Raises
    ------
    FormatError
        No numeric data, fewer than 3 columns, a line with a different column count, a value
        that is not a number, a count line that disagrees with the rows, an ambiguous or
        mixed decimal mark, UTF-16 text or binary data.
    EmptyCloudError
        No or too few finite points.
    """
    params = params or DEFAULT_PARAMS
    path = check_file(path)
    p = Progress.wrap(progress, should_stop)
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        _check_encoding(path, f.read(4096))
        f.seek(0)
        header_names = None
        count = None
        line_no = 0
        first = None
        while first is None:
            pos = f.tell()
            raw = f.readline(_MAX_LINE_BYTES)
            if not raw:
                raise FormatError("no numeric point data found", path)
            line_no += 1
            if len(raw) == _MAX_LINE_BYTES and not raw.endswith(b"\n"):
                raise FormatError(f"line {line_no} is longer than {_MAX_LINE_BYTES >> 20} MB: "
                                  "not a text point list", path)
            if raw.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark
                raw, pos = raw[3:], pos + 3
            text = raw.decode("utf-8", errors="replace")
            tokens = split_tokens(text)
            if not tokens:
                continue
            vals = _numbers(tokens)
            if vals is None:
                if count is not None:
                    raise FormatError(f"line {line_no}: not a number in {text.strip()[:60]!r}", path)
                if line_no > _MAX_HEADER_LINES:
                    raise FormatError(f"no numeric point data in the first {_MAX_HEADER_LINES} lines", path)
                header_names = [_clean_name(t) for t in tokens]
                continue
            if len(vals) == 1 and count is None and float(vals[0]).is_integer():
                count = int(vals[0])
                continue
            first = (pos, line_no, text)
        pos, first_line, text = first
        style = detect_style(_sample_lines(f, pos), path)
        ncols = len(style.tokens(text))
        if ncols < 3:
            raise FormatError(f"line {first_line}: {ncols} values; at least 3 (x y z) are needed", path)
        f.seek(pos)
        parts = []
        blocks = [] if count is None else [count]  # declared sizes of PTS blocks
        for text, line, done in iter_text_chunks(f, _CHUNK_BYTES, first_line):
            if count is not None and _COUNT_LINE.search(text):  # a multi-scan PTS: new blocks
                pieces = _COUNT_LINE.split(text)
                # split() alternates text and captured counts: text, count, text, count, ...
                for k in range(0, len(pieces), 2):
                    if k:
                        blocks.append(int(pieces[k - 1]))
                        parts.append(None)  # block boundary
                    if pieces[k].strip():
                        parts.append(parse_rows(pieces[k], ncols, path, line, style=style))
                    line += pieces[k].count("\n") + (1 if k + 1 < len(pieces) else 0)
            else:
                parts.append(parse_rows(text, ncols, path, line, style=style))
            p(done / max(size - pos, 1), "reading text")
    # rows per block (one block unless a PTS file has several count lines)
    sizes, cur = [], 0
    for part in parts:
        if part is None:
            sizes.append(cur)
            cur = 0
        else:
            cur += len(part)
    sizes.append(cur)
    parts = [part for part in parts if part is not None]
    table = np.concatenate(parts) if parts else np.zeros((0, ncols))
    for b, (declared, rows) in enumerate(zip(blocks, sizes)):
        if declared != rows:
            more = "larger than" if declared > rows else "smaller than"
            where = f" of block {b + 1}" if len(blocks) > 1 else ""
            raise FormatError(f"the count line{where} says {declared:,} points, {more} the {rows:,} rows "
                              "that follow it", path)
    scan_index = None
    if len(blocks) > 1:
        scan_index = np.repeat(np.arange(len(blocks), dtype=np.int32), sizes)
    names = None
    if header_names is not None and len(header_names) == ncols and {"x", "y", "z"} <= set(header_names):
        names = header_names
    if names is None:
        names = _CONVENTIONS.get(ncols) or ["x", "y", "z"] + [f"column_{k}" for k in range(3, ncols)]
    arrays = {"xyz": np.empty((len(table), 3)), "rgb": None, "normals": None, "intensity": None}
    fields = {}
    for k, name in enumerate(names):
        role = _NAME_ROLES.get(name)
        if role is None or (role[1] is None and arrays[role[0]] is not None):
            fields[name or f"column_{k}"] = table[:, k]
            continue
        target, col = role
        if col is None:
            arrays[target] = table[:, k]
        else:
            if arrays[target] is None:
                arrays[target] = np.full((len(table), 3), np.nan)
            arrays[target][:, col] = table[:, k]
    for target in ("rgb", "normals"):  # incomplete triples become fields
        a = arrays[target]
        if a is not None and np.isnan(a).all(axis=0).any():
            for k, name in enumerate(names):
                if _NAME_ROLES.get(name, ("",))[0] == target:
                    fields[name] = table[:, k]
            arrays[target] = None
    colors = None if arrays["rgb"] is None else colors_to_u8(arrays["rgb"])
    return finish_cloud(path, arrays["xyz"], colors=colors, intensity=arrays["intensity"],
                        normals=arrays["normals"], scan_index=scan_index, fields=fields, params=params)
