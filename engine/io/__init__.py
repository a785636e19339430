"""Point-cloud readers and writers.

:func:`read_point_cloud` dispatches on the file extension (see :data:`SUPPORTED_EXTENSIONS`)
and returns one :class:`~engine.pointcloud.PointCloud`; :func:`write_ply` writes one.

Every reader

* raises a typed error (:mod:`engine.errors`) naming the file and the problem: missing file,
  a directory, an empty file, unknown extension, truncated body, header counts larger than
  the data, wrong column count, an unreadable LAS/E57;
* checks every count and size a header declares (elements, POINTS, compressed sizes,
  LAS/LAZ records and chunks) against the file size **before** allocating; data beyond
  the declared counts are not read and a warning goes to ``cloud.warnings``; any other
  parsing exception (struct, numpy, codec) becomes a :class:`~engine.errors.FormatError`
  naming the file (``_common.guard_reader``);
* drops rows with non-finite coordinates and counts them in ``cloud.dropped_nonfinite``
  (:class:`~engine.errors.EmptyCloudError` when nothing, or fewer than
  :data:`~engine.pointcloud.MIN_POINTS` points, is left);
* removes a large global offset: along each axis where some |coordinate| exceeds
  ``ReadParams.offset_threshold_m`` (1e4 m) the bounding-box centre rounded to
  ``offset_round_m`` (100 m) is subtracted; the offset is recorded in ``cloud.offset``, so
  float32 in Blender keeps millimetres;
* checks units: a bounding box larger than ``max_indoor_extent_m`` (2 km) that would be a
  plausible building in millimetres logs a warning and adds it to ``cloud.warnings``
  (read it with :func:`units_warning`). Coordinates are **not** rescaled —
  a guessed rescale could silently corrupt a large site; the user converts the file.
* streams large files in chunks and reports progress per chunk; ``should_stop`` cancels
  (:class:`~engine.errors.Cancelled`).
"""
from __future__ import annotations

import os
from typing import Optional

from ..errors import InputError
from ..pointcloud import PointCloud
from ._common import ReadParams, check_file, suspect_units
from .e57 import read_e57
from .las import read_las
from .pcd import lzf_decompress, read_pcd
from .ply import read_ply, write_ply
from .text import read_text

__all__ = [
    "read_point_cloud", "write_ply", "SUPPORTED_EXTENSIONS", "ReadParams", "suspect_units",
    "units_warning", "read_ply", "read_pcd", "read_text", "read_las", "read_e57", "lzf_decompress",
]

_READERS = {
    ".ply": read_ply,
    ".pcd": read_pcd,
    ".xyz": read_text,
    ".pts": read_text,
    ".txt": read_text,
    ".csv": read_text,
    ".las": read_las,
    ".laz": read_las,
    ".e57": read_e57,
}

SUPPORTED_EXTENSIONS = tuple(_READERS)
"""File extensions :func:`read_point_cloud` reads (lower case, with the dot)."""


def units_warning(cloud: PointCloud) -> Optional[str]:
    """The reader's warning that the coordinates look like millimetres, or None."""
    return next((w for w in cloud.warnings if "millimetre" in w), None)


def read_point_cloud(path, *, progress=None, should_stop=None,
                     params: Optional[ReadParams] = None) -> PointCloud:
    """Read a scan file into a :class:`~engine.pointcloud.PointCloud`.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply .pcd .xyz .pts .txt .csv .las .laz .e57`` file (extension case ignored).
    progress : callable or Progress, optional
        ``progress(fraction, message)``, called per chunk read.
    should_stop : callable, optional
        Returns True to cancel (:class:`~engine.errors.Cancelled` is raised).
    params : ReadParams, optional
        Chunk size, offset and unit-check thresholds.

    Returns
    -------
    PointCloud
        ``xyz`` (n, 3) float64 metres with ``offset`` removed, plus whatever attributes the
        file holds; ``source`` is ``path``.

    Raises
    ------
    InputError
        Missing file, a directory, unknown extension.
    FormatError
        Malformed content (see the readers).
    EmptyCloudError
        Empty file, or no / too few finite points.
    MissingDependencyError
        laspy/lazrs or pye57 missing for LAS/LAZ or E57.
    """
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    reader = _READERS.get(ext)
    if reader is None:
        check_file(path)
        known = " ".join(SUPPORTED_EXTENSIONS)
        raise InputError(f"unknown file extension {ext or '(none)'!r}; supported: {known}", path)
    return reader(path, progress=progress, should_stop=should_stop, params=params)
