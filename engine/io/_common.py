"""What every reader shares: file checks, reader options, and turning raw arrays into a
:class:`~engine.pointcloud.PointCloud` (non-finite rows, global offset, unit check)."""
from __future__ import annotations

import functools
import logging
import os
import re
import struct
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..errors import EmptyCloudError, FormatError, IndoorError, InputError
from ..pointcloud import MIN_POINTS, PointCloud

__all__ = ["ReadParams", "check_file", "finish_cloud", "colors_to_u8", "suspect_units", "parse_count",
           "guard_reader"]

log = logging.getLogger(__name__)

_WHOLE_NUMBER = re.compile(r"\+?[0-9]+")
_NEGATIVE_NUMBER = re.compile(r"-[0-9]+")

@dataclass(frozen=True)
class ReadParams:
    """Options shared by all readers."""

    chunk_points: int = 2_000_000
    """Points read per chunk when streaming a large file (progress is reported per chunk)."""
    offset_threshold_m: float = 1.0e4
    """Along each axis where some |coordinate| exceeds this (metres), a global offset is
    removed (the other axes keep their values, e.g. heights above sea level)."""
    offset_round_m: float = 100.0
    """The removed offset is the centre of the bounding box rounded to a multiple of this
    (metres), so it reads well and float32 keeps sub-millimetre precision."""
    max_indoor_extent_m: float = 2000.0
    """A cloud whose bounding box is larger than this on any axis is not an indoor scan in
    metres; if its extent divided by 1000 is a plausible building size it is flagged as
    probably being in millimetres."""
    min_building_extent_m: float = 1.0
    """Smallest plausible extent (metres) of a scanned building; used with
    ``max_indoor_extent_m`` by the millimetre check."""


DEFAULT_PARAMS = ReadParams()
_MM_PER_M = 1000.0


def check_file(path) -> str:
    """Return ``path`` as str after checking it is an existing, non-empty regular file.

    Raises
    ------
    InputError
        The file is missing, is a directory, or cannot be opened.
    EmptyCloudError
        The file is empty (0 bytes).
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError("file not found", path)
    if os.path.isdir(path):
        raise InputError("is a directory, not a scan file", path)
    if not os.access(path, os.R_OK):
        raise InputError("file is not readable (permission denied)", path)
    if os.path.getsize(path) == 0:
        raise EmptyCloudError("file is empty (0 bytes)", path)
    return path


_COLOUR_BLOCK_ROWS = 1 << 20
"""Rows converted at a time by :func:`colors_to_u8`, bounding its temporary memory."""


def parse_count(token: str, what: str, path: str) -> int:
    """A header count (points, rows, an element size) as a non-negative int.

    ``token`` must be a whole number in decimal digits, optionally with a leading ``+``
    (as C's ``strtol`` accepts); ``what`` names the count in the error ("the count of
    element 'vertex'").

    Raises
    ------
    FormatError
        The count is negative, or not a whole number (``2e1``, ``5.0``, ``1_000``, ``x``).
    """
    t = token.strip()
    if _WHOLE_NUMBER.fullmatch(t):
        return int(t)
    if _NEGATIVE_NUMBER.fullmatch(t):
        raise FormatError(f"{what} is negative ({t})", path)
    raise FormatError(f"{what} is not a whole number ({t[:40]!r})", path)


_PARSE_ERRORS = (struct.error, OverflowError, UnicodeError, ValueError, EOFError)
"""Exceptions a malformed file can still raise deep inside a parser (numpy, struct, codecs)
after every check a reader makes; :func:`guard_reader` turns them into a FormatError."""


def guard_reader(kind: str):
    """Decorate a reader ``reader(path, **kw)`` so that a parsing exception that is not an
    :class:`~engine.errors.IndoorError` (see ``_PARSE_ERRORS``) becomes a
    :class:`~engine.errors.FormatError` naming the file, the format ``kind`` and the
    original exception (chained, and logged at debug level with its traceback).

    The readers check sizes and counts before allocating, so such an exception means a
    corruption no check anticipated; MemoryError and other exceptions pass unchanged.
    """
    def wrap(reader):
        @functools.wraps(reader)
        def guarded(path, *args, **kwargs):
            try:
                return reader(path, *args, **kwargs)
            except IndoorError:
                raise
            except _PARSE_ERRORS as e:
                where = os.fspath(path)
                name = type(e).__name__
                if type(e).__module__ != "builtins":
                    name = f"{type(e).__module__}.{name}"
                log.debug("%s: unexpected %s while reading", where, name, exc_info=True)
                raise FormatError(f"cannot parse this {kind} file ({name}: {str(e)[:200]})", where) from e
        return guarded
    return wrap


def colors_to_u8(c: np.ndarray) -> np.ndarray:
    """Convert colour values to (n, 3) uint8.

    uint8 is kept; integers above 255 anywhere mean 16-bit colour, scaled by 255/65535 and
    rounded (integer arithmetic, in blocks, so 10M points need no float64 copy); floats all
    within [0, 1] with some fraction are scaled by 255; anything else is rounded and clipped
    to 0–255.
    """
    c = np.asarray(c)
    if c.dtype == np.uint8:
        return c
    out = np.empty(c.shape, np.uint8)
    if c.size == 0:
        return out
    if c.dtype.kind in "iu":
        sixteen = c.max() > 255
        for s in range(0, len(c), _COLOUR_BLOCK_ROWS):
            b = np.clip(c[s:s + _COLOUR_BLOCK_ROWS], 0, 65535).astype(np.uint32)
            out[s:s + _COLOUR_BLOCK_ROWS] = (b * 255 + 32767) // 65535 if sixteen else np.minimum(b, 255)
        return out
    v = np.nan_to_num(c.astype(np.float64))
    if v.max() > 255:
        v = v * (255.0 / 65535.0)
    elif v.max() <= 1.0 and np.any(v != np.round(v)):
        v = v * 255.0
    out[...] = np.clip(np.round(v), 0, 255)
    return out


def suspect_units(xyz_extent: np.ndarray, params: ReadParams = DEFAULT_PARAMS) -> Optional[str]:
    """Say whether coordinates look like millimetres rather than metres.

    Parameters
    ----------
    xyz_extent : (3,) float64
        Size of the bounding box along x, y, z in file units (assumed metres).
    params : ReadParams

    Returns
    -------
    str or None
        A human-readable warning when the largest extent exceeds
        ``params.max_indoor_extent_m`` while that extent read as millimetres is a plausible
        building size; None otherwise. The data are **never** rescaled: the caller decides
        (an indoor scan in millimetres must be converted by the user; a wrongly guessed
        rescale would silently corrupt georeferenced data).
    """
    ext = float(np.max(xyz_extent)) if len(xyz_extent) else 0.0
    as_m = ext / _MM_PER_M
    plausible = params.min_building_extent_m <= as_m <= params.max_indoor_extent_m
    if ext > params.max_indoor_extent_m and plausible:
        return (f"bounding box is {ext:,.0f} units across: too large for an indoor scan in metres; "
                f"the coordinates look like millimetres ({as_m:,.1f} m); the reader keeps them as they "
                "are (convert rescales them: --units)")
    return None


def _rounded_centre(lo: np.ndarray, hi: np.ndarray, step: float) -> np.ndarray:
    return np.round((lo + hi) / 2.0 / step) * step


def finish_cloud(
    path: str,
    xyz: np.ndarray,
    *,
    colors=None,
    intensity=None,
    normals=None,
    scan_index=None,
    scanner_positions=None,
    fields=None,
    offset=None,
    warnings=(),
    params: ReadParams = DEFAULT_PARAMS,
) -> PointCloud:
    """Build the reader's result from raw arrays in file coordinates.

    Drops rows whose coordinates are not finite (counted in ``dropped_nonfinite``), removes a
    large global offset (recorded in ``offset``), checks units, and rejects clouds with fewer
    than :data:`~engine.pointcloud.MIN_POINTS` points.

    Parameters
    ----------
    path : str
        The file read (named in errors, stored as ``source``).
    xyz : (n, 3) float64
        Coordinates in file units (metres expected); may be modified in place.
    colors, intensity, normals, scan_index, fields :
        Per-point arrays (see :class:`~engine.pointcloud.PointCloud`) or None.
    scanner_positions : (k, 3) float64 or None
        In the same frame as ``xyz`` (before offset removal).
    offset : (3,) float64 or None
        An offset already removed from ``xyz`` by the file itself (e.g. written by
        :func:`engine.io.write_ply`); any further offset removed here is added to it.
    warnings : sequence of str
        The reader's own warnings (e.g. data beyond the header's counts); each is logged
        and put in ``cloud.warnings`` before the units warning.

    Raises
    ------
    EmptyCloudError
        Nothing or fewer than ``MIN_POINTS`` finite points remain.
    """
    n_total = len(xyz)
    if n_total == 0:
        raise EmptyCloudError("the file holds no points", path)
    # min/max propagate NaN and show inf: finite extremes mean every coordinate is finite
    lo = np.array([xyz[:, k].min() for k in range(3)])  # per column: numpy's axis-0
    hi = np.array([xyz[:, k].max() for k in range(3)])  # reduction of (n, 3) is slower
    if np.isfinite(lo).all() and np.isfinite(hi).all():  # the common case, no row mask
        n_ok, dropped = n_total, 0
    else:
        finite = np.isfinite(xyz[:, 0]) & np.isfinite(xyz[:, 1]) & np.isfinite(xyz[:, 2])
        n_ok = int(np.count_nonzero(finite))
        dropped = n_total - n_ok
    fields = dict(fields or {})
    if dropped:
        if n_ok == 0:
            raise EmptyCloudError(f"all {n_total:,} points have non-finite coordinates (NaN or inf)", path)
        log.warning("%s: dropped %d of %d points with non-finite coordinates", path, dropped, n_total)

        def keep(a):
            return None if a is None else a[finite]

        xyz, colors, intensity, normals, scan_index = (
            keep(a) for a in (xyz, colors, intensity, normals, scan_index))
        fields = {k: v[finite] for k, v in fields.items()}
    if n_ok < MIN_POINTS:
        raise EmptyCloudError(f"only {n_ok} usable points; at least {MIN_POINTS} are needed", path)

    if dropped:
        lo = np.array([xyz[:, k].min() for k in range(3)])
        hi = np.array([xyz[:, k].max() for k in range(3)])
    base = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64).reshape(3)
    extra = np.zeros(3)
    big = np.maximum(np.abs(lo), np.abs(hi)) > params.offset_threshold_m
    if big.any():  # only along the axes that need it: heights above sea level stay as they are
        extra = np.where(big, _rounded_centre(lo, hi, params.offset_round_m), 0.0)
        xyz -= extra
        if scanner_positions is not None:
            scanner_positions = np.asarray(scanner_positions, dtype=np.float64).reshape(-1, 3) - extra
        log.info("%s: removed global offset %s m", path, extra.tolist())
    warning = suspect_units(hi - lo, params)
    notes = tuple(warnings) + ((warning,) if warning else ())
    cloud = PointCloud(
        xyz=xyz, colors=colors, intensity=intensity, normals=normals, scan_index=scan_index,
        scanner_positions=scanner_positions, offset=base + extra, fields=fields, source=path,
        dropped_nonfinite=dropped, warnings=notes,
    )
    for w in notes:
        log.warning("%s: %s", path, w)
    return cloud
