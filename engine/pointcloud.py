"""The one point-cloud type every reader returns and every algorithm consumes."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Mapping, Optional

import numpy as np

from .errors import EmptyCloudError

__all__ = ["PointCloud", "MIN_POINTS"]

MIN_POINTS = 10
"""Fewer points than this cannot feed any algorithm of the engine (plane fits need 3,
normals need neighbours); readers reject such clouds with :class:`EmptyCloudError`."""


def _opt(a, dtype, shape_tail, n, name):
    if a is None:
        return None
    a = np.ascontiguousarray(a, dtype=dtype)
    if a.shape[0] != n or a.shape[1:] != shape_tail:
        raise ValueError(f"{name} has shape {a.shape}, expected ({n}, {', '.join(map(str, shape_tail))})")
    return a


@dataclass(frozen=True, eq=False)
class PointCloud:
    """Points with optional per-point attributes.

    Attributes
    ----------
    xyz : (n, 3) float64
        Coordinates in metres, z up, **after** removing ``offset``.
    colors : (n, 3) uint8 or None
        sRGB colour, 0–255 (16-bit sources are scaled down).
    intensity : (n,) float32 or None
        Return intensity as the file stores it (no unit).
    normals : (n, 3) float32 or None
        Unit normals.
    scan_index : (n,) int32 or None
        Index into ``scanner_positions`` of the scan each point came from.
    scanner_positions : (k, 3) float64 or None
        Scanner origins in the same frame as ``xyz`` (offset removed), metres.
    offset : (3,) float64
        Removed global offset: original coordinates = ``xyz + offset``. Large offsets
        (georeferenced data) are removed so float32 keeps millimetres in Blender.
    fields : dict of str -> (n, ...) array
        Further per-point scalar fields (e.g. a truth ``label``, ``distance``).
    source : str
        Path of the file the cloud came from ("" when built in memory).
    dropped_nonfinite : int
        Rows dropped by the reader because a coordinate was NaN or infinite.
    warnings : tuple of str
        Reader warnings a user should see (e.g. coordinates that look like millimetres).
    """

    xyz: np.ndarray
    colors: Optional[np.ndarray] = None
    intensity: Optional[np.ndarray] = None
    normals: Optional[np.ndarray] = None
    scan_index: Optional[np.ndarray] = None
    scanner_positions: Optional[np.ndarray] = None
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    fields: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str = ""
    dropped_nonfinite: int = 0
    warnings: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "warnings", tuple(self.warnings))
        xyz = np.ascontiguousarray(self.xyz, dtype=np.float64)
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise ValueError(f"xyz has shape {xyz.shape}, expected (n, 3)")
        n = len(xyz)
        object.__setattr__(self, "xyz", xyz)
        object.__setattr__(self, "colors", _opt(self.colors, np.uint8, (3,), n, "colors"))
        object.__setattr__(self, "intensity", _opt(self.intensity, np.float32, (), n, "intensity"))
        object.__setattr__(self, "normals", _opt(self.normals, np.float32, (3,), n, "normals"))
        object.__setattr__(self, "scan_index", _opt(self.scan_index, np.int32, (), n, "scan_index"))
        if self.scanner_positions is not None:
            sp = np.asarray(self.scanner_positions, dtype=np.float64).reshape(-1, 3)
            object.__setattr__(self, "scanner_positions", sp)
        object.__setattr__(self, "offset", np.asarray(self.offset, dtype=np.float64).reshape(3))
        flds = {}
        for k, v in dict(self.fields).items():
            v = np.asarray(v)
            if v.shape[0] != n:
                raise ValueError(f"field {k!r} has {v.shape[0]} rows, expected {n}")
            flds[k] = v
        object.__setattr__(self, "fields", flds)

    # ------------------------------------------------------------------ basics
    def __len__(self) -> int:
        return len(self.xyz)

    @property
    def n(self) -> int:
        """Number of points."""
        return len(self.xyz)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 — min and max corner in metres (offset removed); zeros if empty."""
        if len(self.xyz) == 0:
            return np.zeros((2, 3))
        return np.stack([self.xyz.min(axis=0), self.xyz.max(axis=0)])

    @property
    def field_names(self) -> list[str]:
        """Names of the attributes present, e.g. ``['xyz', 'colors', 'intensity']``."""
        names = ["xyz"]
        for k in ("colors", "intensity", "normals", "scan_index"):
            if getattr(self, k) is not None:
                names.append(k)
        return names + sorted(self.fields)

    @property
    def scan_count(self) -> int:
        """Number of scans the cloud holds (1 when unknown)."""
        if self.scanner_positions is not None and len(self.scanner_positions):
            return len(self.scanner_positions)
        if self.scan_index is not None and len(self.scan_index):
            return int(self.scan_index.max()) + 1
        return 1

    def with_(self, **changes) -> "PointCloud":
        """A copy with some attributes replaced (``dataclasses.replace``)."""
        return replace(self, **changes)

    def subset(self, index) -> "PointCloud":
        """The points selected by a boolean mask or an index array; scans are kept."""
        def take(a):
            return None if a is None else a[index]

        return PointCloud(
            xyz=self.xyz[index],
            colors=take(self.colors),
            intensity=take(self.intensity),
            normals=take(self.normals),
            scan_index=take(self.scan_index),
            scanner_positions=self.scanner_positions,
            offset=self.offset,
            fields={k: v[index] for k, v in self.fields.items()},
            source=self.source,
            dropped_nonfinite=self.dropped_nonfinite,
            warnings=self.warnings,
        )

    def transformed(self, matrix: np.ndarray) -> "PointCloud":
        """Apply a 4×4 rigid transform to points, normals and scanner positions."""
        m = np.asarray(matrix, dtype=np.float64)
        r, t = m[:3, :3], m[:3, 3]
        sp = None if self.scanner_positions is None else self.scanner_positions @ r.T + t
        nr = None if self.normals is None else (self.normals.astype(np.float64) @ r.T)
        return replace(self, xyz=self.xyz @ r.T + t, normals=nr, scanner_positions=sp)

    @staticmethod
    def concatenate(clouds: "list[PointCloud]") -> "PointCloud":
        """Join clouds (same offset assumed); scan indices are renumbered."""
        if not clouds:
            raise EmptyCloudError("no clouds to join")
        base = clouds[0].offset
        xyz = np.concatenate([c.xyz + (c.offset - base) for c in clouds])

        def cat(name):
            parts = [getattr(c, name) for c in clouds]
            return None if any(p is None for p in parts) else np.concatenate(parts)

        scan_index, positions, k = [], [], 0
        for c in clouds:
            si = c.scan_index if c.scan_index is not None else np.zeros(len(c), np.int32)
            scan_index.append(si + k)
            if c.scanner_positions is not None and len(c.scanner_positions):
                positions.append(c.scanner_positions + (c.offset - base))
                k += len(c.scanner_positions)
            else:
                positions.append(np.full((1, 3), np.nan))
                k += 1
        common = set.intersection(*(set(c.fields) for c in clouds))
        return PointCloud(
            xyz=xyz,
            colors=cat("colors"),
            intensity=cat("intensity"),
            normals=cat("normals"),
            scan_index=np.concatenate(scan_index),
            scanner_positions=np.concatenate(positions),
            offset=base,
            fields={f: np.concatenate([c.fields[f] for c in clouds]) for f in sorted(common)},
            source=clouds[0].source,
        )

    def mean_spacing(self, sample: int = 20000, rng=0) -> float:
        """Mean distance from a point to its nearest *distinct* neighbour, in metres.

        Estimated on a random sample of at most ``sample`` query points against the whole
        cloud (a k-d tree). Exact duplicates are skipped (the PCL room scans hold every
        point twice, which would read as a spacing of 0); a sample point with only
        duplicates among its 8 nearest neighbours does not count. Returns 0.0 for fewer
        than two distinct points.
        """
        if len(self.xyz) < 2:
            return 0.0
        from scipy.spatial import cKDTree

        rng = np.random.default_rng(rng)
        tree = cKDTree(self.xyz)
        q = self.xyz if len(self.xyz) <= sample else self.xyz[rng.choice(len(self.xyz), sample, replace=False)]
        k = min(9, len(self.xyz))
        d, _ = tree.query(q, k=k)
        d = d[:, 1:].reshape(len(q), -1)
        distinct = d > 1e-9
        has = distinct.any(axis=1)
        if not has.any():
            return 0.0
        first = d[has, np.argmax(distinct[has], axis=1)]
        return float(np.mean(first))

    def summary(self) -> dict:
        """JSON-ready facts: count, bounds (original frame), fields, spacing, scans.

        Besides the bounds of every point, ``core_bounds_min``/``core_bounds_max`` are the
        bounds of the bulk of the points (:func:`core_bounds`: percentiles widened through
        gaps no larger than 0.5 m or 2 % of the extent, so a few far strays do not count);
        ``strays`` is the number of points farther than ``max(5 m, 0.5 x the largest core
        extent)`` from the core box and ``stray_max_distance_m`` the distance of the farthest
        of them from the core box in metres (0.0 when there is no stray).
        """
        b = self.bounds + self.offset
        core = core_bounds(self.xyz)
        strays, far = _strays(self.xyz, core)
        core = core + self.offset
        return {
            "source": self.source,
            "points": int(len(self)),
            "bounds_min": [float(v) for v in b[0]],
            "bounds_max": [float(v) for v in b[1]],
            "core_bounds_min": [float(v) for v in core[0]],
            "core_bounds_max": [float(v) for v in core[1]],
            "strays": strays,
            "stray_max_distance_m": far,
            "offset": [float(v) for v in self.offset],
            "fields": self.field_names,
            "mean_spacing_m": self.mean_spacing(),
            "scans": self.scan_count,
            "dropped_nonfinite": int(self.dropped_nonfinite),
            "warnings": list(self.warnings),
        }


STRAY_MIN_DISTANCE_M = 5.0
"""A point is a stray (in :meth:`PointCloud.summary`) when it lies farther than this, or than
``STRAY_CORE_FRACTION`` x the largest core extent if that is more, from the core box."""
STRAY_CORE_FRACTION = 0.5
_STRAY_BLOCK = 1 << 20


def core_bounds(xyz: np.ndarray, *, tail: float = 1.0, gap_m: float = 0.5, gap_rel: float = 0.02,
                 sample: int = 200_000, rng=0) -> np.ndarray:
    """(2, 3) float64 — min and max corner of the bulk of the points (same frame as ``xyz``).

    Per axis: start from the ``tail`` and ``100 - tail`` percentiles (estimated on a
    random sample of at most ``sample`` points), then widen each side outward through
    the points beyond it, sorted, as long as consecutive values are at most
    ``max(gap_m, gap_rel x percentile range)`` apart. A scan's walls, floor and ceiling
    are far more than 1 % of its points, so the percentiles fall on them and the walk
    reaches the true surface (noise and a sparse view through a window included); a few
    strays hundreds of metres away are cut off by the first large gap. Robust to up to
    ``tail`` % strays on each side of each axis.

    Cost: O(n) per axis (a mask), plus sorting the ``tail`` % of points beyond each
    percentile. Equals the bounds of every point when no gap is larger than the limit.
    """
    n = len(xyz)
    if n == 0:
        return np.zeros((2, 3))
    gen = np.random.default_rng(rng)
    pick = xyz if n <= sample else xyz[gen.choice(n, sample, replace=False)]
    out = np.empty((2, 3))
    for k in range(3):
        col = xyz[:, k]
        lo, hi = np.percentile(pick[:, k], [tail, 100.0 - tail])
        gap = max(gap_m, gap_rel * float(hi - lo))
        out[0, k] = -_walk(-col[col < lo], -lo, gap)
        out[1, k] = _walk(col[col > hi], hi, gap)
    return out


def _walk(beyond: np.ndarray, start: float, gap: float) -> float:
    """The largest value reached from ``start`` through the sorted values ``beyond`` (all
    greater than ``start``) without a step larger than ``gap``."""
    if len(beyond) == 0:
        return float(start)
    v = np.sort(beyond)
    steps = np.diff(v, prepend=start)
    big = np.flatnonzero(steps > gap)
    if len(big) == 0:
        return float(v[-1])
    return float(v[big[0] - 1]) if big[0] else float(start)


def _strays(xyz: np.ndarray, core: np.ndarray) -> tuple:
    """(count of points farther than the stray distance from the box ``core`` (2, 3), the
    distance of the farthest of them in metres, 0.0 when there is none); in blocks of
    ``_STRAY_BLOCK`` points, so the temporaries stay small."""
    if len(xyz) == 0:
        return 0, 0.0
    limit = max(STRAY_MIN_DISTANCE_M, STRAY_CORE_FRACTION * float(np.max(core[1] - core[0])))
    count, far = 0, 0.0
    for s in range(0, len(xyz), _STRAY_BLOCK):
        b = xyz[s:s + _STRAY_BLOCK]
        d = np.maximum(np.maximum(core[0] - b, b - core[1]), 0.0)
        d2 = np.einsum("ij,ij->i", d, d)
        count += int(np.count_nonzero(d2 > limit * limit))
        far = max(far, float(np.sqrt(d2.max())))
    return count, (far if count else 0.0)
