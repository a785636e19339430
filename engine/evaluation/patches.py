"""Planar patches: the surfaces that evaluation and change detection compare.

A :class:`PlanarPatch` is one planar face of a model (a room face, a wall side, a mesh facet)
with its plane ``nᵀp = ρ``, an orthonormal 2D frame on that plane and its outline as a
shapely geometry in that frame. Every comparison of the evaluation (projection, buffer,
Boolean union) and of the change detection (point-in-boundary, coverage) works in these
frames, so the geometry is derived from a :class:`~engine.model.BuildingModel` once, here.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Iterable, Optional, Sequence

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon

from ..geometry.planes import plane_frame
from ..model import BuildingModel, ShapeType

__all__ = [
    "PlanarPatch",
    "patches_from_model",
    "merge_coplanar",
    "drop_shared_faces",
    "project_to",
    "overlap_on",
    "points_inside",
    "sample_patch_grid",
    "polygon_triangles",
]

log = logging.getLogger(__name__)

COPLANAR_COS = float(np.cos(np.radians(0.5)))
"""Two faces of one shape are merged when their normals are within 0.5° ..."""
COPLANAR_DIST = 1e-3
"""... and their planes within 1 mm (metres)."""
MIN_AREA = 1e-6
"""Patches smaller than this (m²) are degenerate and dropped."""


@dataclass(frozen=True, eq=False)
class PlanarPatch:
    """A planar surface with its own 2D frame.

    Attributes
    ----------
    key : str
        Unique id, ``"<shape_id>:<face>"`` (merged faces: the first face).
    shape_id : str
    face : int
    kind : str
        "wall", "floor" or "ceiling" (by the outward normal, as :meth:`BuildingModel.surfaces`).
    storey : int
    shape_type : ShapeType
    normal : (3,) float64
        Unit normal.
    rho : float
        Plane offset, ``nᵀp = ρ`` (metres).
    origin : (3,) float64
        A point on the plane, origin of the 2D frame (metres).
    u, v : (3,) float64
        Unit axes of the 2D frame.
    geom : shapely Polygon or MultiPolygon
        Outline in the 2D frame (metres).
    name : str
        Name of the shape it came from.
    """

    key: str
    shape_id: str
    face: int
    kind: str
    storey: int
    shape_type: ShapeType
    normal: np.ndarray
    rho: float
    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    geom: object
    name: str = ""

    @property
    def area(self) -> float:
        """Area in m²."""
        return float(self.geom.area)

    def to2d(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) float64 points → (n, 2) float64 coordinates in this frame (metres)."""
        d = np.asarray(points, dtype=np.float64) - self.origin
        return np.column_stack([d @ self.u, d @ self.v])

    def to3d(self, xy: np.ndarray) -> np.ndarray:
        """(n, 2) float64 frame coordinates → (n, 3) float64 points on the plane."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return self.origin + xy[:, :1] * self.u + xy[:, 1:] * self.v

    def signed_distance(self, points: np.ndarray) -> np.ndarray:
        """(n,) float64 signed distances ``nᵀp − ρ`` of (n, 3) points (metres)."""
        return np.asarray(points, dtype=np.float64) @ self.normal - self.rho

    def outline3d(self) -> list[np.ndarray]:
        """The exterior rings in 3D: list of (k, 3) float64 (one per polygon part)."""
        return [self.to3d(np.asarray(p.exterior.coords)[:-1]) for p in _parts(self.geom)]

    def to_dict(self) -> dict:
        return {"key": self.key, "shape_id": self.shape_id, "face": self.face, "name": self.name,
                "kind": self.kind, "storey": self.storey, "area_m2": self.area,
                "normal": [float(x) for x in self.normal], "rho_m": float(self.rho)}


def _parts(geom) -> list:
    if geom is None or geom.is_empty:
        return []
    if geom.geom_type == "Polygon":
        return [geom]
    return [g for g in getattr(geom, "geoms", []) if g.geom_type == "Polygon" and not g.is_empty]


def _make_patch(key, shape, face, kind, polygon3d, normal) -> Optional[PlanarPatch]:
    n = np.asarray(normal, dtype=np.float64)
    if not np.isfinite(n).all() or np.linalg.norm(n) < 0.5:
        return None
    n = n / np.linalg.norm(n)
    poly = np.asarray(polygon3d, dtype=np.float64)
    origin = poly.mean(axis=0)
    rho = float(n @ origin)
    origin = origin - n * (n @ origin - rho)
    u, v = plane_frame(n)
    d = poly - origin
    geom = Polygon(np.column_stack([d @ u, d @ v]))
    if not geom.is_valid:
        geom = geom.buffer(0)
    if geom.area < MIN_AREA:
        return None
    return PlanarPatch(key, shape.id, int(face), kind, int(shape.storey), shape.type, n, rho, origin, u, v,
                       geom, shape.name)


def patches_from_model(model: BuildingModel, types: Iterable = (ShapeType.INTERIOR,), *,
                       kinds: Optional[Sequence[str]] = None, merge: bool = True,
                       active: Optional[bool] = True) -> list[PlanarPatch]:
    """The planar patches of the shapes of ``types`` in ``model``.

    Parameters
    ----------
    model : BuildingModel
    types : shape types (default: interior spaces, i.e. the room faces).
    kinds : keep only these kinds ("wall", "floor", "ceiling"); None keeps all.
    merge : merge coplanar faces of one shape (triangulated meshes, IFC tessellations)
        into one patch per connected planar region.
    active : as :meth:`BuildingModel.surfaces`.

    Returns
    -------
    list of PlanarPatch, in model order. Degenerate faces (area below ``MIN_AREA``) are dropped.
    """
    surfaces = model.surfaces(types=types, active=active)
    out = []
    for s in surfaces:
        if kinds is not None and s.kind not in kinds:
            continue
        p = _make_patch(f"{s.shape_id}:{s.face}", model[s.shape_id], s.face, s.kind, s.polygon, s.normal)
        if p is not None:
            out.append(p)
    if merge:
        out = merge_coplanar(out)
    return out


def project_to(geom, src: PlanarPatch, dst: PlanarPatch):
    """Orthogonal projection of a geometry in ``src``'s frame onto ``dst``'s plane/frame."""
    a = float(src.u @ dst.u)
    b = float(src.v @ dst.u)
    d = float(src.u @ dst.v)
    e = float(src.v @ dst.v)
    off = src.origin - dst.origin
    return affinity.affine_transform(geom, [a, b, d, e, float(off @ dst.u), float(off @ dst.v)])


def merge_coplanar(patches: Sequence[PlanarPatch]) -> list[PlanarPatch]:
    """Merge coplanar patches of the same shape and kind whose outlines touch or overlap.

    Returns one patch per connected planar region (the key of the first member).
    """
    groups: dict = {}
    for p in patches:
        groups.setdefault((p.shape_id, p.kind), []).append(p)
    out = []
    for (_, _), members in groups.items():
        if len(members) == 1:
            out.extend(members)
            continue
        used = [False] * len(members)
        for i, p in enumerate(members):
            if used[i]:
                continue
            used[i] = True
            same = [p]
            for j in range(i + 1, len(members)):
                q = members[j]
                if not used[j] and p.normal @ q.normal >= COPLANAR_COS and abs(q.rho - p.rho) <= COPLANAR_DIST:
                    used[j] = True
                    same.append(q)
            if len(same) == 1:
                out.append(p)
                continue
            geom = safe_union([p.geom] + [project_to(q.geom, q, p) for q in same[1:]]).buffer(0)
            for k, part in enumerate(_parts(geom)):
                key = p.key if k == 0 else f"{p.key}.{k}"
                out.append(PlanarPatch(key, p.shape_id, p.face, p.kind, p.storey, p.shape_type, p.normal, p.rho,
                                       p.origin, p.u, p.v, part, p.name))
    return out


def drop_shared_faces(patches: Sequence[PlanarPatch], gap: float, max_angle: float,
                      walled=None) -> list[PlanarPatch]:
    """The patches without their parts that face another shape's face across at most ``gap``.

    Two spaces of an open plan (a living room and its kitchen, a corridor and its stair)
    meet face to face with no wall between: their shared faces are a virtual boundary that
    no scan can see and no model needs to draw (a wall, however thin, puts its two faces
    further apart than ``gap``). For each pair of patches of different shapes with opposite
    normals (within ``max_angle``, radians) and planes at most ``gap`` metres apart, the part
    of each lying on the other is cut away; a patch left with less than ``MIN_AREA`` is dropped.
    ``walled(point) -> bool`` ((3,) metres): a wall stands there, so the two faces meeting
    there are kept (a model that lost a wall's thickness still claims a wall).
    """
    patches = list(patches)
    if gap <= 0 or len(patches) < 2:
        return patches
    cos_t = float(np.cos(max_angle))
    normals = np.array([p.normal for p in patches])
    boxes = []
    for p in patches:
        pts = np.vstack(p.outline3d()) if not p.geom.is_empty else np.zeros((1, 3))
        boxes.append((pts.min(axis=0) - gap, pts.max(axis=0) + gap))
    lo = np.array([b[0] for b in boxes])
    hi = np.array([b[1] for b in boxes])
    cuts: dict[int, list] = {}
    for i, a in enumerate(patches):
        facing = (normals @ a.normal <= -cos_t) & np.all(lo <= hi[i], axis=1) & np.all(hi >= lo[i], axis=1)
        for j in np.flatnonzero(facing):
            b = patches[j]
            if j <= i or b.shape_id == a.shape_id or b.kind != a.kind:
                continue
            ab = overlap_on(a, b, gap)  # b's part on a's plane, within a
            ab = _open_part(a, ab, walled) if ab is not None and walled is not None else ab
            if ab is None:
                continue
            cuts.setdefault(i, []).append(ab)
            ba = overlap_on(b, a, gap)
            ba = _open_part(b, ba, walled) if ba is not None and walled is not None else ba
            if ba is not None:
                cuts.setdefault(j, []).append(ba)
    out = []
    for i, p in enumerate(patches):
        if i not in cuts:
            out.append(p)
            continue
        rest = safe_difference(p.geom, safe_union(cuts[i]))
        if rest.area >= MIN_AREA:
            out.append(PlanarPatch(p.key, p.shape_id, p.face, p.kind, p.storey, p.shape_type, p.normal, p.rho,
                                   p.origin, p.u, p.v, rest, p.name))
    return out


def _open_part(p: PlanarPatch, region, walled, step: float = 0.1):
    """The part of ``region`` (in ``p``'s frame) where no wall stands (``walled(point)`` false
    at the centres of a ``step`` grid over it), or None."""
    from dataclasses import replace

    xy = sample_patch_grid(replace(p, geom=region), step)
    if len(xy) == 0:
        return region
    free = np.array([not walled(q) for q in p.to3d(xy)])
    if free.all():
        return region
    if not free.any():
        return None
    h = step / 2 + 1e-9
    cells = [shapely.box(x - h, y - h, x + h, y + h) for x, y in xy[free]]
    part = safe_intersection(region, safe_union(cells))
    return None if part.is_empty or part.area < MIN_AREA else part


GRID = 1e-6
"""Precision grid (metres) geometries are snapped to when an overlay fails on round-off."""


def _repair(g):
    try:
        g = shapely.make_valid(g).buffer(0)
    except shapely.errors.GEOSException:
        g = g.buffer(0)
    try:
        return shapely.set_precision(g, GRID)
    except shapely.errors.GEOSException:
        return shapely.set_precision(g, GRID, mode="pointwise").buffer(0)


def _robust(op: str, a, b, fallback, what: str):
    """``shapely.<op>(a, b)``; on a GEOS topology error (nearly degenerate input) retried on
    repaired geometries snapped to a 1 µm grid; if that fails too, ``fallback`` (logged).
    Invalid input is repaired first: GEOS answers wrongly on it without an error (a sliver a
    few µm thick along a face's edge, projected onto a plane 0.02° off, folds over itself:
    FZK-Haus mobile, a whole 10.7 m² wall face then overlapped its model face by 0.001 m²)."""
    if not shapely.is_valid(a):
        a = _repair(a)
    if not shapely.is_valid(b):
        b = _repair(b)
    try:
        return getattr(shapely, op)(a, b)
    except shapely.errors.GEOSException:
        try:
            return getattr(shapely, op)(_repair(a), _repair(b), grid_size=GRID)
        except shapely.errors.GEOSException as e:
            log.warning("%s failed even after repair (%s); %s", op, e, what)
            return fallback


def safe_intersection(a, b):
    """``a ∩ b``, robust (:func:`_robust`): on failure the overlap is counted as empty."""
    return _robust("intersection", a, b, shapely.Polygon(), "counted as no overlap")


def safe_difference(a, b):
    """``a − b``, robust (:func:`_robust`): on failure ``a`` is kept whole."""
    return _robust("difference", a, b, a, "nothing cut")


def safe_union(geoms):
    """Boolean union of a list of geometries, robust like :func:`safe_intersection`."""
    try:
        return shapely.unary_union(geoms)
    except shapely.errors.GEOSException:
        return shapely.unary_union([_repair(g) for g in geoms], grid_size=GRID)


def _strip(patch: PlanarPatch, other: PlanarPatch, b: float):
    """The part of ``patch`` (its frame) within distance ``b`` of ``other``'s plane."""
    g = np.array([other.normal @ patch.u, other.normal @ patch.v])
    c = float(other.normal @ patch.origin - other.rho)
    gn = float(np.linalg.norm(g))
    if gn < 1e-12 or not np.isfinite(b):
        return patch.geom if abs(c) <= b else None
    minx, miny, maxx, maxy = patch.geom.bounds
    big = 2.0 * (abs(minx) + abs(maxx) + abs(miny) + abs(maxy)) + abs(c) / gn + 1.0
    gh = g / gn
    perp = np.array([-gh[1], gh[0]])
    centre = -c / gn * gh  # the points where the distance is 0
    half = b / gn
    corners = [centre + s * half * gh + t * big * perp for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    inter = safe_intersection(patch.geom, Polygon(corners))
    return None if inter.is_empty else inter


def overlap_on(target: PlanarPatch, other: PlanarPatch, b: float):
    """``target ∩ 𝒫_target(other ∩ buffer_b(target))`` in ``target``'s frame (or None).

    The part of ``other`` lying within distance ``b`` (metres) of ``target``'s plane is
    projected orthogonally onto ``target``'s plane and clipped by ``target``'s outline.
    Parallelism is the caller's business.
    """
    part = _strip(other, target, b)
    if part is None:
        return None
    proj = project_to(part, other, target)
    inter = safe_intersection(proj, target.geom)
    return None if inter.is_empty or inter.area <= 0 else inter


def points_inside(patch: PlanarPatch, xy: np.ndarray) -> np.ndarray:
    """(n,) bool — which (n, 2) frame coordinates fall inside the patch outline."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) == 0:
        return np.zeros(0, dtype=bool)
    shapely.prepare(patch.geom)
    return np.asarray(shapely.contains_xy(patch.geom, xy[:, 0], xy[:, 1]), dtype=bool)


def sample_patch_grid(patch: PlanarPatch, spacing: float) -> np.ndarray:
    """Points on a regular grid (cell centres, ``spacing`` metres) inside the patch.

    Returns (n, 2) float64 frame coordinates; a patch narrower than a cell gets its
    representative point so that no patch goes unsampled.
    """
    minx, miny, maxx, maxy = patch.geom.bounds
    xs = np.arange(minx + spacing / 2, maxx, spacing)
    ys = np.arange(miny + spacing / 2, maxy, spacing)
    if len(xs) and len(ys):
        gx, gy = np.meshgrid(xs, ys)
        xy = np.column_stack([gx.ravel(), gy.ravel()])
        xy = xy[points_inside(patch, xy)]
        if len(xy):
            return xy
    rp = patch.geom.representative_point()
    return np.array([[rp.x, rp.y]])


def polygon_triangles(patch: PlanarPatch) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the patch: ``(vertices (n, 3) float64, triangles (m, 3) int64)``."""
    tris = shapely.constrained_delaunay_triangles(patch.geom)
    verts, faces = [], []
    for t in getattr(tris, "geoms", []):
        c = np.asarray(t.exterior.coords)[:3]
        k = len(verts) // 1
        verts.extend(c.tolist())
        faces.append((k, k + 1, k + 2))
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    v3 = patch.to3d(np.asarray(verts))
    f = np.asarray(faces, dtype=np.int64)
    # keep the patch normal's orientation
    e1 = v3[f[:, 1]] - v3[f[:, 0]]
    e2 = v3[f[:, 2]] - v3[f[:, 0]]
    flip = np.cross(e1, e2) @ patch.normal < 0
    f[flip] = f[flip][:, ::-1]
    return v3, f
