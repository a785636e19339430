"""Change detection between a model and a newer scan (docs/method.md §5).

1. Register the scan to the model (:mod:`.registration`) and check the registration: when
   too few scan points lie on the model, or too few of those on walls on its walls, the
   scan is *unregistered* and the result claims no change (every point ``UNCLASSIFIED``,
   no redundant face, no candidate element) unless ``ChangeParams.force`` is set: a
   failed registration reads as "everything is new, every face is redundant".
2. Classify each scan point: *existing* (0) when some model surface has ``|πᵀp| ≤ r``, its
   outline contains the projection of ``p`` and — when the scan has normals, which are
   estimated when missing — the point's normal agrees with the surface within an angle;
   else *new* (1). The normal test keeps points of a new wall that stand on an old floor
   from being taken for floor points (a departure from the thesis's distance-only test).
   Classification uses every modelled solid surface: room faces, wall and slab faces (so
   the floor strip under a removed wall is not "new").
3. Coverage ``M_cov(π_j) = area(α) / area(π_j)`` of each **room face** by the existing
   points lying on it (2D alpha shape). A removed wall shows up as the faces of the rooms
   it bounded — the faces coplanar with its sides — having almost no coverage; those faces
   (coverage ≤ a threshold) are *redundant*. Occlusion by furniture also lowers coverage,
   so values are reported, not only verdicts.
4. Connected clusters of new points (voxel connectivity) are candidate new elements.
5. Status per model element (:mod:`.elements`: installed, incomplete, not installed, no data,
   from coverage and free-space evidence), the element behind each room face, and new walls
   fitted from the wall candidates (:mod:`.newwalls`) with their doors.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import EmptyCloudError
from ..evaluation.coverage import PatchSupport, alpha_area, patch_support
from ..evaluation.patches import patches_from_model
from ..geometry.normals import knn_pca
from ..geometry.transforms import apply_rotation, apply_transform, frame_transform
from ..model import BuildingModel
from ..pointcloud import PointCloud
from ..progress import Progress
from .elements import StatusParams, element_status, surface_elements
from .newwalls import WallFitParams, fit_new_walls, new_openings
from .registration import REGISTERED, UNREGISTERED, RegistrationParams, RegistrationResult, register

__all__ = ["ChangeParams", "ChangeResult", "detect_changes", "cluster_points", "distance_threshold",
           "EXISTING", "NEW", "UNCLASSIFIED", "OUTSIDE", "REGISTERED", "UNREGISTERED"]

log = logging.getLogger(__name__)

MAD_TO_SIGMA = 1.4826
"""σ of a Gaussian from the median of absolute deviations."""
EXISTING = 0
"""Point type: lies on a model surface."""
NEW = 1
"""Point type: on no model surface."""
UNCLASSIFIED = 2
"""Point type: not classified, because the scan could not be registered to the model."""
OUTSIDE = 3
"""Point type: outside the model's plan (beyond its outer walls: surroundings seen through
windows and doors), neither existing nor new."""


@dataclass(frozen=True)
class ChangeParams:
    """Parameters of :func:`detect_changes` (SI units)."""

    distance_threshold: Optional[float] = None
    """r: a point within this distance of a model surface (inside its outline) exists,
    metres. It should follow the scan noise plus the registration error (thesis: 0.10 m for
    a mobile scan with 3 cm noise). None: automatic, ``max(min_distance_threshold,
    noise_factor · σ̂)`` with σ̂ = 1.4826 × the registration residual (a robust noise
    estimate from the median point-to-plane distance)."""
    min_distance_threshold: float = 0.05
    """Smallest automatic r, metres."""
    noise_factor: float = 8.0
    """Automatic r in units of the estimated noise σ̂."""
    use_normals: bool = True
    """Also require the point normal to agree with the surface (normals are estimated
    when the scan has none)."""
    max_normal_angle: float = float(np.radians(45.0))
    """Largest angle between a point normal and a surface normal, radians."""
    normal_radius: float = 0.1
    """Points on model surfaces within this distance (voxel neighbourhood) of a point the
    distance test found new get the normal test, metres."""
    normal_neighbours: int = 10
    """Nearest neighbours used for estimating missing normals (PCA); raise it for noisy
    (mobile) scans."""
    classify_types: tuple = ("interior", "wall", "slab", "door", "window")
    """Model shape types whose faces make a point existing (door and window boxes hold the
    jambs, lintels and reveals of the openings; points inside a door or window box — glass,
    frames — exist too)."""
    coverage_types: tuple = ("interior",)
    """Model shape types whose faces get a coverage value (the room faces)."""
    alpha_radius: float = 0.2
    """r_α: circumradius limit of the alpha-shape triangles, metres."""
    redundant_threshold: float = 0.25
    """Faces with coverage at most this are redundant (thesis: 0.2–0.3)."""
    search_distance: float = 0.5
    """Per-point distances to the model are reported up to this, metres (inf beyond)."""
    cluster_voxel: float = 0.1
    """New points in touching voxels of this size belong to one cluster, metres."""
    min_cluster_points: int = 200
    """Smaller clusters of new points are noise, not candidate elements."""
    wall_height_share: float = 0.85
    """A candidate element spanning at least this share of its storey's floor-to-ceiling
    height, from floor to ceiling, is a new *wall*; others are objects (furniture)."""
    wall_end_tolerance: float = 0.15
    """A wall candidate must come this close to the floor and to the ceiling, metres."""
    registration: RegistrationParams = field(default_factory=RegistrationParams)
    """How the scan is registered to the model and when the registration has failed
    (``min_fitness``)."""
    status: StatusParams = field(default_factory=StatusParams)
    """How each model element gets its status (:func:`.elements.element_status`)."""
    element_status: bool = True
    """Give each wall, slab, door and window a status."""
    fit_walls: bool = True
    """Fit new walls (and their doors) to the wall candidates."""
    walls: WallFitParams = field(default_factory=WallFitParams)
    force: bool = False
    """Classify the points, flag redundant faces and find new elements even when the
    registration failed (the result stays marked unregistered). Without it an
    unregistered result claims no change."""


@dataclass(frozen=True, eq=False)
class ChangeResult:
    """Outcome of :func:`detect_changes`.

    Attributes
    ----------
    distance_threshold : float
        The r used, metres.
    registration : RegistrationResult
        ``registration.transform`` maps scan coordinates into the model frame.
    point_type : (n,) uint8
        0 existing, 1 new, 3 (:data:`OUTSIDE`) beyond the model's plan, per scan point; 2
        (:data:`UNCLASSIFIED`) everywhere when the registration failed and ``params.force``
        is not set.
    distance : (n,) float64
        Distance to the closest model surface containing the point's projection (normal
        agreeing), metres; inf when none within ``search_distance``.
    surface : (n,) int32
        Index into ``patches`` of that surface (-1 when none).
    cluster : (n,) int32
        Candidate-element index of each new point (-1 for existing points and noise).
    patches : list of PlanarPatch
        The classification surfaces (model frame).
    coverage_keys : list of str
        Keys of the room faces that get a coverage value.
    coverage : (m,) float64
        M_cov of each of those faces, in [0, 1].
    redundant : list of str
        Keys of the redundant faces (none claimed when unregistered without ``force``).
    elements : list of dict
        Candidate new elements (clusters of new points, largest first): id (the
        ``cluster`` value), points, centroid, bounds, normal (PCA), kind "wall" (spans
        floor to ceiling) or "object" (furniture and the like).
    element_status : list of dict
        Status per wall, slab, door and window (:func:`.elements.element_status`: id,
        global_id, name, ifc_class, status, coverage, faces with 3D polygons, ...); empty when
        not classified.
    surface_elements : dict str -> str or None
        Room-face key → id of the element (wall, slab) behind it.
    new_walls : list of dict
        Walls fitted to the new points (:func:`.newwalls.fit_new_walls`; "shape" holds the
        WALL shape, model frame).
    new_openings : list of Shape
        Doors and windows found in the new walls.
    """

    registration: RegistrationResult
    distance_threshold: float
    point_type: np.ndarray
    distance: np.ndarray
    surface: np.ndarray
    cluster: np.ndarray
    patches: list
    coverage_keys: list
    coverage: np.ndarray
    coverage_patches: list
    redundant: list
    elements: list
    params: ChangeParams
    element_status: list = field(default_factory=list)
    surface_elements: dict = field(default_factory=dict)
    new_walls: list = field(default_factory=list)
    new_openings: list = field(default_factory=list)

    @property
    def registered(self) -> bool:
        """Whether the registration check passed (``registration.status``)."""
        return self.registration.registered

    @property
    def classified(self) -> bool:
        """Whether points and faces carry verdicts (registered, or ``params.force``)."""
        return self.registered or bool(self.params.force)

    def new_structure(self) -> np.ndarray:
        """(n,) bool — points of candidate elements of kind "wall" (new structure)."""
        ids = [e["id"] for e in self.elements if e["kind"] == "wall"]
        return np.isin(self.cluster, ids)

    def summary(self) -> dict:
        """JSON-ready counts, registration and verdicts."""
        n = len(self.point_type)
        new = int(np.sum(self.point_type == NEW))
        existing = int(np.sum(self.point_type == EXISTING))
        outside = int(np.sum(self.point_type == OUTSIDE))
        return {
            "points": n,
            "existing": existing,
            "new": new,
            "outside": outside,
            "unclassified": n - new - existing - outside,
            "new_share": new / n if n else 0.0,
            "classified": self.classified,
            "forced": bool(self.params.force and not self.registered),
            "registration": self.registration.to_dict(),
            "distance_threshold_m": float(self.distance_threshold),
            "surfaces": len(self.coverage_keys),
            "redundant": list(self.redundant),
            "new_elements": len(self.elements),
            "new_walls": sum(e["kind"] == "wall" for e in self.elements),
            "new_wall_points": int(self.new_structure().sum()),
            "elements": self.elements,
            "element_status": {st: sum(e["status"] == st for e in self.element_status)
                               for st in ("installed", "incomplete", "not installed", "no data")},
            "not_installed": [e["global_id"] for e in self.element_status if e["status"] == "not installed"],
            "new_walls_fitted": [{k: v for k, v in w.items() if k != "shape"} for w in self.new_walls],
        }

    def element(self, shape_id: str) -> Optional[dict]:
        """The status record of a model element (None when it has none)."""
        return next((e for e in self.element_status if e["id"] == shape_id), None)

    def coverage_table(self, model: Optional[BuildingModel] = None) -> list[dict]:
        """One JSON-ready row per room face: key, shape, kind, area, coverage, redundant, polygon
        (3D rings, model frame) and the element behind it (element_id, element_global_id)."""
        from .elements import element_global_id
        red = set(self.redundant)
        rows = []
        for p, c in zip(self.coverage_patches, self.coverage):
            eid = self.surface_elements.get(p.key)
            gid = None
            if eid is not None:
                rec = self.element(eid)
                gid = rec["global_id"] if rec else (element_global_id(model, model[eid])
                                                     if model is not None and eid in model else None)
            rows.append(dict(p.to_dict(), coverage=float(c), redundant=p.key in red,
                             polygon=[r.tolist() for r in p.outline3d()], element_id=eid,
                             element_global_id=gid))
        return rows


def cluster_points(xyz: np.ndarray, voxel: float) -> np.ndarray:
    """Connected components of points through touching voxels (26-neighbourhood).

    ``xyz`` : (n, 3) float64 metres; returns (n,) int32 labels 0..k-1, largest first.
    """
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if len(xyz) == 0:
        return np.zeros(0, dtype=np.int32)
    ijk = np.floor((xyz - xyz.min(axis=0)) / voxel).astype(np.int64) + 1
    dims = ijk.max(axis=0) + 2
    code = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    vox, inv = np.unique(code, return_inverse=True)
    inv = inv.reshape(-1)
    rows, cols = [], []
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                if (dx, dy, dz) <= (0, 0, 0):
                    continue
                nb = vox + (dx * dims[1] + dy) * dims[2] + dz
                pos = np.searchsorted(vox, nb)
                pos = np.minimum(pos, len(vox) - 1)
                hit = vox[pos] == nb
                rows.append(np.flatnonzero(hit))
                cols.append(pos[hit])
    r = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    c = np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64)
    g = coo_matrix((np.ones(len(r)), (r, c)), shape=(len(vox), len(vox)))
    _, lab = connected_components(g, directed=False)
    point_lab = lab[inv]
    counts = np.bincount(point_lab)
    order = np.argsort(-counts, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[point_lab].astype(np.int32)


def _near_voxels(points: np.ndarray, seeds: np.ndarray, size: float) -> np.ndarray:
    """(n,) bool — which ``points`` fall in a voxel touching (26-neighbourhood) a seed's voxel."""
    lo = np.minimum(points.min(axis=0), seeds.min(axis=0)) - 2 * size
    dims = np.ceil((np.maximum(points.max(axis=0), seeds.max(axis=0)) - lo) / size).astype(np.int64) + 3

    def code(ijk):
        return (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]

    sv = np.floor((seeds - lo) / size).astype(np.int64)
    offs = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)], dtype=np.int64)
    keys = np.unique(code((sv[:, None, :] + offs[None]).reshape(-1, 3)))
    return np.isin(code(np.floor((points - lo) / size).astype(np.int64)), keys)


def distance_threshold(params: ChangeParams, registration: RegistrationResult) -> float:
    """The r used: ``params.distance_threshold`` or the automatic one (metres)."""
    if params.distance_threshold is not None:
        return float(params.distance_threshold)
    sigma = MAD_TO_SIGMA * registration.residual
    if not np.isfinite(sigma):
        return float(params.min_distance_threshold)
    return float(max(params.min_distance_threshold, params.noise_factor * sigma))


def _classify(patches, xyz, cloud, t, params: ChangeParams, r: float, should_stop) -> PatchSupport:
    """Points on model surfaces: by distance and boundary; where the distance test leaves new
    points nearby (a new element touching old surfaces), also by normal."""
    search = max(params.search_distance, r)
    if not params.use_normals:
        return patch_support(patches, xyz, r, search_distance=search, should_stop=should_stop)
    if cloud.normals is not None:
        normals = apply_rotation(t, cloud.normals)
        return patch_support(patches, xyz, r, normals=normals, max_normal_angle=params.max_normal_angle,
                             search_distance=search, should_stop=should_stop)
    sup = patch_support(patches, xyz, r, search_distance=search, should_stop=should_stop)
    new0 = ~sup.on_model
    if not new0.any() or new0.all():
        return sup
    amb = np.flatnonzero(sup.on_model)
    amb = amb[_near_voxels(xyz[amb], xyz[new0], params.normal_radius)]
    if len(amb) == 0:
        return sup
    # neighbours come from the points around the new ones only (a smaller k-d tree)
    region = np.flatnonzero(_near_voxels(xyz, xyz[new0], 2 * params.normal_radius))
    pos = np.searchsorted(region, amb)
    _, lam, vec = knn_pca(xyz[region], max(params.normal_neighbours, 3), pos)
    # only a normal that is sure to well within the angle can overrule the distance test: a
    # neighbourhood no wider than the noise (points bunched under a mobile scanner's path), or
    # one across an edge, gives a normal in any direction
    sure = lam[:, 0] <= np.tan(params.max_normal_angle / 2) ** 2 * lam[:, 1]
    amb, normals = amb[sure], vec[sure, :, 0]
    if len(amb) == 0:
        return sup
    sub = patch_support(patches, xyz[amb], r, normals=normals, max_normal_angle=params.max_normal_angle,
                        search_distance=search, should_stop=should_stop)
    on = sup.on_model.copy()
    dist = sup.distance.copy()
    patch = sup.patch.copy()
    on[amb] = sub.on_model
    dist[amb] = sub.distance
    patch[amb] = sub.patch
    is_amb = np.zeros(len(xyz), dtype=bool)
    is_amb[amb] = True
    members = [np.sort(np.concatenate([m[~is_amb[m]], amb[ms]])) for m, ms in zip(sup.members, sub.members)]
    return PatchSupport(on, dist, patch, members)



def _nearest_surface(patches, xyz: np.ndarray, point_type: np.ndarray, cluster: np.ndarray, walls: list,
                     openings: list, r: float) -> None:
    """Give the points near a fitted new wall to the surface they are nearest: the wall's faces
    or the model's (in place).

    Where a new wall stands on an old floor or meets an old ceiling or wall, a point within r
    of both is ambiguous, and the normal test cannot settle it there (estimated normals blur
    at the corner). Within a new wall's extent (not in its new doors and windows), a point
    nearer to a face of the wall than to any model surface is new; one nearer to a model
    surface (within r) exists."""
    from ..evaluation.coverage import PointBuckets
    buckets = PointBuckets(xyz, 1.0)
    parts = []  # (point index, distance to the wall's nearer face, the wall's cluster) per wall
    for w in walls:
        b = w["shape"].geometry.bounds
        idx = buckets.in_box(b[0] - r, b[1] + r)  # the wall's box only, not the whole scan
        a, e = (np.asarray(x, dtype=np.float64) for x in w["axis_line"])
        length = float(np.linalg.norm(e - a))
        if length <= 0 or len(idx) == 0:
            continue
        d = (e - a) / length
        rel = xyz[idx, :2] - a
        u, v = rel @ d, rel @ np.array([-d[1], d[0]])
        inside = ((u >= 0.0) & (u <= length) & (np.abs(v) <= w["thickness"] / 2 + r)
                  & (xyz[idx, 2] >= w["z0"] - r) & (xyz[idx, 2] <= w["z1"] + r))
        parts.append((idx[inside], np.abs(np.abs(v[inside]) - w["thickness"] / 2),
                      np.full(int(inside.sum()), int(w["cluster"]), dtype=np.int32)))
    if not parts:
        return
    cand, dn, own = (np.concatenate(x) for x in zip(*parts))
    order = np.lexsort((dn, cand))  # per point, its nearest new-wall face first
    first = np.r_[True, np.diff(cand[order]) != 0]
    cand, dn, own = cand[order][first], dn[order][first], own[order][first]
    keep = ((dn <= r) & ((point_type[cand] == NEW) | (point_type[cand] == EXISTING))
            & ~_in_boxes(openings, xyz[cand], r))  # a doorway's floor and reveals stay as classified
    cand, dn, own = cand[keep], dn[keep], own[keep]
    if len(cand) == 0:
        return
    d_old = patch_support(patches, xyz[cand], r).distance  # geometric: no normal test here
    to_new = (dn < d_old) & (point_type[cand] == EXISTING)
    to_old = (dn >= d_old) & (d_old <= r) & (point_type[cand] == NEW)
    point_type[cand[to_new]] = NEW
    cluster[cand[to_new]] = own[to_new]  # new points of other clusters keep theirs
    point_type[cand[to_old]] = EXISTING
    cluster[cand[to_old]] = -1


def _in_openings(model: BuildingModel, xyz: np.ndarray, r: float) -> np.ndarray:
    """(n,) bool — points inside (within r of) the box of a door or window of the model."""
    return _in_boxes([s for s in model.shapes if s.active and s.type.value in ("door", "window")], xyz, r)


def _in_boxes(shapes, xyz: np.ndarray, r: float) -> np.ndarray:
    """(n,) bool — points inside (within r of) the oriented box of one of ``shapes``."""
    from ..evaluation.coverage import PointBuckets
    from ..geometry.boxes import min_area_box
    out = np.zeros(len(xyz), dtype=bool)
    if not shapes or len(xyz) == 0:
        return out
    buckets = PointBuckets(xyz, 1.0)
    for s in shapes:
        b = s.geometry.bounds
        cand = buckets.in_box(b[0] - r, b[1] + r)
        if len(cand) == 0:
            continue
        origin, axes, size = min_area_box(s.geometry.vertices)
        rel = xyz[cand] - origin
        u, v, z = rel @ axes[0], rel @ axes[1], xyz[cand, 2]
        inside = ((u >= -r) & (u <= size[0] + r) & (v >= -r) & (v <= size[1] + r)
                  & (z >= b[0, 2] - r) & (z <= b[1, 2] + r))
        out[cand[inside]] = True
    return out


def _outside(model: BuildingModel, xyz: np.ndarray, r: float) -> np.ndarray:
    """(n,) bool — points whose plan position is more than r outside the model's plan (the
    footprints of its interior spaces, walls and slabs)."""
    import shapely
    from shapely.geometry import Polygon
    fps = [s.footprint() for s in model.shapes if s.active and s.type.value in ("interior", "wall", "slab")]
    polys = [Polygon(f) for f in fps if f is not None and len(f) >= 3]
    polys = [g if g.is_valid else g.buffer(0) for g in polys]
    if not polys:
        return np.zeros(len(xyz), dtype=bool)
    plan = shapely.union_all(polys, grid_size=1e-5).buffer(r)
    shapely.prepare(plan)
    return ~shapely.contains_xy(plan, xyz[:, 0], xyz[:, 1])


def _storey_range(model: BuildingModel, z: float) -> tuple[float, float]:
    """Floor and ceiling heights (metres) of the storey containing height ``z``."""
    for st in model.storeys:
        if st.floor_z - 0.5 <= z <= st.ceiling_z + 0.5:
            return st.floor_z, st.ceiling_z
    spaces = model.spaces
    if spaces:
        b = np.array([s.bounds for s in spaces])
        return float(b[:, 0, 2].min()), float(b[:, 1, 2].max())
    return float("-inf"), float("inf")


def _element(xyz: np.ndarray, k: int, model: BuildingModel, params: ChangeParams) -> dict:
    c = xyz.mean(axis=0)
    w, v = np.linalg.eigh(np.cov((xyz - c).T))
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    floor, ceiling = _storey_range(model, float(c[2]))
    tol = params.wall_end_tolerance
    wall = (hi[2] - lo[2] >= params.wall_height_share * (ceiling - floor)
            and lo[2] <= floor + tol and hi[2] >= ceiling - tol)
    return {"id": k, "points": int(len(xyz)), "centroid": c.tolist(), "bounds_min": lo.tolist(),
            "bounds_max": hi.tolist(), "normal": v[:, 0].tolist(),
            "kind": "wall" if wall else "object"}


def detect_changes(model: BuildingModel, cloud, params: Optional[ChangeParams] = None, *,
                   initial: Optional[np.ndarray] = None, progress=None, should_stop=None) -> ChangeResult:
    """Detect changes between a model and a scan (docs/method.md §5).

    Parameters
    ----------
    model : BuildingModel
        The (old) model.
    cloud : PointCloud or (n, 3) float64 array
        The (new) scan, metres.
    params : ChangeParams
    initial : (4, 4) float64, optional
        Coarse scan → model transform, refined by ICP unless ``params.registration.enabled``
        is False. Default: from the cloud's offset and the model's transform/offset, and
        when that fails the check, the coarse starts of :func:`.registration.register`.

    Returns
    -------
    ChangeResult
        ``registration.status`` is "registered" or "unregistered"; an unregistered result
        claims no change unless ``params.force``.
    """
    params = params or ChangeParams()
    p = Progress.wrap(progress, should_stop)
    if not isinstance(cloud, PointCloud):
        cloud = PointCloud(np.asarray(cloud, dtype=np.float64).reshape(-1, 3))
    if len(cloud) == 0:
        raise EmptyCloudError("the scan has no points", cloud.source or None)
    given = initial is not None
    if initial is None:
        initial = frame_transform(np.eye(4), cloud.offset, model.transform, model.offset)
    # the check counts points within the change threshold when it is given (an automatic
    # one comes from the residual, meaningless when the registration failed)
    reg = register(model, cloud.xyz, params.registration, initial=initial,
                   coarse_start=params.registration.coarse_start and not given,
                   fitness_distance=params.distance_threshold, progress=p.sub(0.0, 0.35),
                   should_stop=should_stop)
    claim = reg.registered or params.force
    t = reg.transform
    xyz = apply_transform(t, cloud.xyz)
    p(0.4, "classifying points")
    patches = patches_from_model(model, params.classify_types)
    r = distance_threshold(params, reg)
    sup = _classify(patches, xyz, cloud, t, params, r, should_stop)
    point_type = np.where(sup.on_model, EXISTING, NEW).astype(np.uint8)
    point_type[(point_type == NEW) & _in_openings(model, xyz, r)] = EXISTING
    point_type[(point_type == NEW) & _outside(model, xyz, r)] = OUTSIDE

    p(0.7, "surface coverage")
    cov_types = {str(getattr(x, "value", x)).lower() for x in params.coverage_types}
    cov_idx = [j for j, pt in enumerate(patches) if pt.shape_type.value in cov_types]
    coverage = np.zeros(len(cov_idx))
    for k, j in enumerate(cov_idx):
        pt = patches[j]
        m = sup.members[j]
        if len(m):
            coverage[k] = min(1.0, alpha_area(pt.to2d(xyz[m]), params.alpha_radius) / pt.area)
    cov_patches = [patches[j] for j in cov_idx]
    redundant = [pt.key for pt, c in zip(cov_patches, coverage) if c <= params.redundant_threshold]
    if not claim:
        # a failed registration reads as change everywhere: claim none
        point_type[:] = UNCLASSIFIED
        redundant = []

    p(0.85, "clusters of new points")
    cluster = np.full(len(xyz), -1, dtype=np.int32)
    elements = []
    new_idx = np.flatnonzero(point_type == NEW)
    if len(new_idx):
        lab = cluster_points(xyz[new_idx], params.cluster_voxel)
        counts = np.bincount(lab)
        big = np.flatnonzero(counts >= params.min_cluster_points)  # labels are sorted by size
        remap = np.full(len(counts), -1, dtype=np.int32)
        remap[big] = np.arange(len(big), dtype=np.int32)
        cluster[new_idx] = remap[lab]
        for k, lab_k in enumerate(big):
            elements.append(_element(xyz[new_idx[lab == lab_k]], k, model, params))
    status, walls, openings = [], [], []
    surf = surface_elements(model, cov_patches)
    if claim:
        scanners = None
        if cloud.scanner_positions is not None and cloud.scan_index is not None:
            scanners = apply_transform(t, np.asarray(cloud.scanner_positions, dtype=np.float64).reshape(-1, 3))
        if params.fit_walls and any(e["kind"] == "wall" for e in elements):
            p(0.9, "new walls")
            sigma = MAD_TO_SIGMA * reg.residual if np.isfinite(reg.residual) else params.min_distance_threshold
            walls = fit_new_walls(model, xyz, cluster, elements, sigma=sigma, params=params.walls,
                                  new=point_type == NEW)
            normals = apply_rotation(t, cloud.normals) if cloud.normals is not None else None
            openings = new_openings(model, walls, xyz, normals=normals, scan_index=cloud.scan_index,
                                    scanners=scanners)
            if walls:
                _nearest_surface(patches, xyz, point_type, cluster, walls, openings, r)
                counts = np.bincount(cluster[cluster >= 0], minlength=len(elements))
                for e in elements:
                    e["points"] = int(counts[e["id"]])
        if params.element_status:
            p(0.95, "status per element")
            status = element_status(model, xyz, point_type == EXISTING, r, scanners=scanners,
                                    scan_index=cloud.scan_index, params=params.status)
    p(1.0, "done")
    if not claim:
        log.info("change detection: the scan is unregistered: no change claimed")
    elif not reg.registered:
        log.info("change detection: the scan is unregistered: changes reported as forced")
    log.info("change detection: %d of %d points new, %d redundant faces, %d candidate elements, "
             "residual %.4f m", len(new_idx), len(xyz), len(redundant), len(elements), reg.residual)
    return ChangeResult(reg, r, point_type, sup.distance, sup.patch, cluster, patches,
                        [pt.key for pt in cov_patches], coverage, cov_patches, redundant, elements, params,
                        status, surf, walls, openings)
