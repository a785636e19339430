"""Status per model element (docs/method.md §5, "Status per element").

Each wall, slab, door and window of the (old) model gets one of four statuses from the
coverage of its faces by the existing scan points **and** from visibility:

* *installed* — a face is covered (coverage ≥ ``installed_coverage``), or partly covered with
  nothing proving the rest absent (occlusion by furniture lowers coverage);
* *incomplete* — partly covered and part of it proven absent;
* *not installed* — (almost) uncovered and proven absent over ``absent_share`` of a face;
* *no data* — (almost) uncovered and nothing proves it absent: the scanner could not see it.

"Proven absent" is free-space evidence. With scan positions (``cloud.scanner_positions`` and
``scan_index``) a ray from the scanner to a point that crosses the face inside its outline and
ends more than r beyond it went through where the face should be. Without them, points inside a
wall's volume (between its two side faces, more than a margin from both) with a near-vertical
normal — the floor or ceiling strip where the wall stood — prove it absent along its axis.
Doors and windows take the status of their wall (they go with it), with their own coverage,
unless the wall goes on across them: both faces of the opening covered by points in the planes
of the wall's faces around it (``walled_up``, "not installed"; a closed leaf stands back).
The faces' outlines leave out the openings of their doors and windows, so a doorway seen
through is not evidence against its wall.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from ..evaluation.coverage import PointBuckets, alpha_area
from ..evaluation.patches import patches_from_model
from ..geometry.boxes import min_area_box
from ..geometry.normals import knn_normals
from ..model import BuildingModel, Shape, ShapeType

__all__ = ["StatusParams", "INSTALLED", "INCOMPLETE", "NOT_INSTALLED", "NO_DATA", "STATUSES",
           "element_status", "element_global_id", "IFC_CLASS", "surface_elements"]

INSTALLED = "installed"
INCOMPLETE = "incomplete"
NOT_INSTALLED = "not installed"
NO_DATA = "no data"
STATUSES = (INSTALLED, INCOMPLETE, NOT_INSTALLED, NO_DATA)

IFC_CLASS = {ShapeType.WALL: "IfcWall", ShapeType.SLAB: "IfcSlab", ShapeType.DOOR: "IfcDoor",
             ShapeType.WINDOW: "IfcWindow", ShapeType.INTERIOR: "IfcSpace"}
"""IFC class of each element type (as the IFC writer writes it)."""

_GUID_CHARS = set("0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$")


@dataclass(frozen=True)
class StatusParams:
    """Parameters of :func:`element_status` (SI units)."""

    installed_coverage: float = 0.5
    """A face covered at least this much is installed."""
    low_coverage: float = 0.25
    """At most this coverage counts as uncovered (the redundant-face threshold)."""
    absent_share: float = 0.5
    """Share of a face (or of a wall's length) proven absent for "not installed"."""
    incomplete_share: float = 0.15
    """Share proven absent that makes a partly covered element "incomplete"."""
    min_face_share: float = 0.3
    """Faces of an element smaller than this share of its largest face are ignored (ends, tops)."""
    ray_points: int = 300_000
    """Rays tested (a fixed-seed subsample of the points), at most."""
    ray_margin: float = 0.05
    """A ray must cross a face this far inside its outline (metres) and end beyond it by r."""
    band_margin: float = 0.3
    """Without scan positions: points deeper than min(r, this × thickness) inside a wall count."""
    band_bin: float = 0.25
    """... in bins of this length along the wall (metres) ..."""
    band_min_points: int = 2
    """... holding at least this many points with a near-vertical normal."""
    vertical_cos: float = float(np.cos(np.radians(30.0)))
    """A normal within 30° of vertical is near-vertical."""
    normal_neighbours: int = 12
    """Neighbours for the normals of the points inside walls."""
    alpha_radius: float = 0.2
    """Alpha-shape radius of the covered and the crossed areas, metres."""
    thin: float = 0.4
    """The points are thinned to a grid of this × ``alpha_radius`` before the alpha shape (speed)."""


def _is_guid(text: str) -> bool:
    return len(text) == 22 and set(text) <= _GUID_CHARS and text[0] in "0123"


def element_global_id(model: BuildingModel, shape: Shape) -> str:
    """The IFC GlobalId of ``shape``: its ``attributes["GlobalId"]``, its id when that is a GlobalId
    (a model read from a foreign IFC file), else the one :func:`engine.ifc.write_ifc` gives it."""
    gid = shape.attributes.get("GlobalId") if shape.attributes else None
    if gid:
        return str(gid)
    if _is_guid(str(shape.id)):
        return str(shape.id)
    try:
        from ..ifc.common import global_id
        return global_id(model.provenance.seed, model.name, ("shape", shape.id))
    except Exception:  # ifcopenshell missing: the shape id stands in
        return str(shape.id)


def _openings_2d(pt, children: list) -> Optional[object]:
    """The openings (door/window boxes) projected on a face, as one 2D geometry in its frame."""
    holes = []
    for c in children:
        d = np.abs(pt.signed_distance(c.geometry.vertices))
        if d.min() > 0.6:  # not in this face's wall
            continue
        xy = pt.to2d(c.geometry.vertices)
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        holes.append(box(lo[0], lo[1], hi[0], hi[1]))
    return shapely.union_all(holes) if holes else None


def _element_faces(model: BuildingModel, shapes: list, opening_children: dict) -> dict:
    """shape id → list of (patch, outline 2D without openings, prepared outline shrunk by margin)."""
    out = {}
    pats = patches_from_model(model, (ShapeType.WALL, ShapeType.SLAB, ShapeType.DOOR, ShapeType.WINDOW))
    by_shape = {}
    for pt in pats:
        by_shape.setdefault(pt.shape_id, []).append(pt)
    for s in shapes:
        faces = by_shape.get(s.id, [])
        if not faces:
            out[s.id] = []
            continue
        if s.type == ShapeType.WALL:
            faces = [f for f in faces if abs(f.normal[2]) < 0.3]
        elif s.type == ShapeType.SLAB:
            faces = [f for f in faces if abs(f.normal[2]) > 0.7]
        if not faces:
            out[s.id] = []
            continue
        big = max(f.area for f in faces)
        rows = []
        for f in faces:
            if f.area < 0.3 * big:
                continue
            geom = f.geom
            holes = _openings_2d(f, opening_children.get(s.id, []))
            if holes is not None:
                geom = geom.difference(holes)
            if geom.area < 1e-3:
                continue
            rows.append((f, geom))
        out[s.id] = rows
    return out


def _inside(geom, xy: np.ndarray) -> np.ndarray:
    if len(xy) == 0 or geom.is_empty:
        return np.zeros(len(xy), dtype=bool)
    return shapely.contains_xy(geom, xy[:, 0], xy[:, 1])


def _wall_frame(s: Shape):
    """(start (2,), direction (2,), across (2,), length, thickness) of a wall."""
    a = s.attributes or {}
    axis = a.get("axis_line")
    if axis is not None:
        axis = np.asarray(axis, dtype=np.float64).reshape(2, 2)
        thick = float(a.get("thickness", 0.0))
        if thick <= 0:
            _, _, size = min_area_box(s.geometry.vertices)
            thick = float(size[1])
    else:
        origin, axes, size = min_area_box(s.geometry.vertices)
        x, y = axes[0, :2], axes[1, :2]
        mid = origin[:2] + y * size[1] / 2
        axis = np.stack([mid, mid + x * size[0]])
        thick = float(a.get("thickness", size[1]))
    length = float(np.hypot(*(axis[1] - axis[0])))
    d = (axis[1] - axis[0]) / max(length, 1e-12)
    return axis[0], d, np.array([-d[1], d[0]]), length, thick


def _band_evidence(s: Shape, children: list, xyz: np.ndarray, buckets: PointBuckets, r: float,
                   p: StatusParams) -> float:
    """Share of a wall's length with near-horizontal surfaces (floor, ceiling) seen inside it."""
    a, d, w, length, thick = _wall_frame(s)
    if length <= 0 or thick <= 0:
        return 0.0
    b = s.geometry.bounds
    cand = buckets.in_box(b[0] - r, b[1] + r)
    if len(cand) == 0:
        return 0.0
    rel = xyz[cand, :2] - a
    u, v = rel @ d, rel @ w
    m = min(r, p.band_margin * thick)
    inb = (np.abs(v) < thick / 2 - m) & (u >= 0) & (u <= length)
    inb &= (xyz[cand, 2] >= b[0, 2] - r) & (xyz[cand, 2] <= b[1, 2] + r)
    idx = cand[inb]
    if len(idx) < p.band_min_points:
        return 0.0
    # normals from the points around (the strip's own neighbours)
    region = buckets.in_box(b[0] - 3 * r - thick, b[1] + 3 * r + thick)
    region = np.union1d(region, idx)
    pos = np.searchsorted(region, idx)
    k = min(p.normal_neighbours, len(region))
    if k < 3:
        return 0.0
    nz = np.abs(knn_normals(xyz[region], k, pos)[:, 2])
    uu = u[inb][nz >= p.vertical_cos]
    nbins = max(int(np.ceil(length / p.band_bin)), 1)
    free = np.ones(nbins, dtype=bool)  # bins outside the openings
    for c in children:
        cu = (c.geometry.vertices[:, :2] - a) @ d
        free[max(int(np.floor(cu.min() / p.band_bin)), 0):int(np.ceil(cu.max() / p.band_bin))] = False
    if not free.any():
        return 0.0
    cnt = np.bincount(np.clip((uu / p.band_bin).astype(np.int64), 0, nbins - 1), minlength=nbins)
    return float(np.sum((cnt >= p.band_min_points) & free) / free.sum())


def _ray_evidence(f, geom, rays, r: float, p: StatusParams) -> float:
    """Share of a face's area that rays from the scanners went through (ending beyond it)."""
    s, q, sd = rays["s"], rays["q"], rays["sd"]
    ds = sd @ f.normal - f.rho
    dq = q @ f.normal - f.rho
    ds_pt = ds[s]
    cross = (ds_pt * dq < 0) & (np.abs(dq) > r) & (np.abs(ds_pt) > r)
    if not cross.any():
        return 0.0
    ii = np.flatnonzero(cross)
    t = ds_pt[ii] / (ds_pt[ii] - dq[ii])
    x = rays["sd"][s[ii]] + t[:, None] * (q[ii] - rays["sd"][s[ii]])
    xy = f.to2d(x)
    shrunk = geom.buffer(-p.ray_margin)
    inside = _inside(shrunk, xy)
    if inside.sum() < 3:
        return 0.0
    return float(min(1.0, alpha_area(xy[inside], p.alpha_radius, thin=p.alpha_radius * p.thin) / geom.area))


def _coverage(geom, xy: np.ndarray, p: StatusParams) -> float:
    """Alpha-shape area of the face points ``xy`` (face frame, inside ``geom``) / its area."""
    if len(xy) < 3:
        return 0.0
    return float(min(1.0, alpha_area(xy, p.alpha_radius, thin=p.alpha_radius * p.thin) / geom.area))


def _verdict(cov: float, absent: float, p: StatusParams) -> str:
    if cov >= p.installed_coverage:
        return INSTALLED
    if cov <= p.low_coverage:
        return NOT_INSTALLED if absent >= p.absent_share else NO_DATA
    return INCOMPLETE if absent >= p.incomplete_share else INSTALLED


def element_status(model: BuildingModel, xyz: np.ndarray, existing: np.ndarray, r: float, *,
                   scanners: Optional[np.ndarray] = None, scan_index: Optional[np.ndarray] = None,
                   params: Optional[StatusParams] = None, seed: int = 0) -> list[dict]:
    """Status per wall, slab, door and window of ``model`` (see the module docstring).

    Parameters
    ----------
    model : BuildingModel
    xyz : (n, 3) float64
        Scan points in the model frame, metres.
    existing : (n,) bool
        Points classified existing (on a model surface).
    r : float
        Distance threshold of the classification, metres.
    scanners : (k, 3) float64, optional
        Scanner positions in the model frame; with ``scan_index`` (n,) int (-1 unknown) the
        free-space evidence comes from rays, else from points inside the walls.

    Returns
    -------
    list of dict, in model order: id, global_id, name, ifc_class, type, status, coverage,
    absent (share proven absent), evidence ("rays"/"points"), parent, center, bbox
    ((x0,y0,z0),(x1,y1,z1)), faces (key, area_m2, coverage, absent, polygon: list of 3D
    rings in model coordinates). Doors and windows take the status of their wall.
    """
    p = params or StatusParams()
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    types = (ShapeType.WALL, ShapeType.SLAB, ShapeType.DOOR, ShapeType.WINDOW)
    shapes = [s for s in model.shapes if s.type in types and s.active]
    children = {}
    for s in shapes:
        if s.type in (ShapeType.DOOR, ShapeType.WINDOW) and s.parent is not None:
            children.setdefault(s.parent, []).append(s)
    faces = _element_faces(model, shapes, children)
    ex = np.flatnonzero(existing)
    ex_buckets = PointBuckets(xyz[ex], 1.0)
    rays = None
    if scanners is not None and scan_index is not None and len(scanners):
        si = np.asarray(scan_index).reshape(-1)
        ok = np.flatnonzero((si >= 0) & (si < len(scanners)))
        if len(ok) > p.ray_points:
            ok = np.sort(np.random.default_rng(seed).choice(ok, p.ray_points, replace=False))
        if len(ok):
            rays = {"s": si[ok].astype(np.int64), "q": xyz[ok], "sd": np.asarray(scanners, dtype=np.float64)}
    all_buckets = PointBuckets(xyz, 1.0) if rays is None else None
    out = []
    by_id = {}
    planes = {}  # face key -> (normal, rho)
    for s in shapes:
        rows = []
        for f, geom in faces.get(s.id, []):
            outline = np.vstack(f.outline3d())
            cand = ex_buckets.in_box(outline.min(axis=0) - r, outline.max(axis=0) + r)
            pts = xyz[ex[cand]]
            dist = pts @ f.normal - f.rho
            near = np.abs(dist) <= r
            xy, dist = f.to2d(pts[near]), dist[near]
            inside = _inside(geom, xy)
            cov = _coverage(geom, xy[inside], p)
            absent = _ray_evidence(f, geom, rays, r, p) if rays is not None else 0.0
            rings = [f.to3d(np.asarray(g.exterior.coords)[:-1]).tolist()
                     for g in getattr(geom, "geoms", [geom]) if isinstance(g, Polygon) and not g.is_empty]
            rows.append({"key": f.key, "area_m2": float(geom.area), "coverage": cov, "absent": absent,
                         "polygon": rings,
                         "offset": float(np.median(dist[inside])) if inside.sum() >= 10 else None})
            planes[f.key] = (f.normal, f.rho)
        cov = max((x["coverage"] for x in rows), default=0.0)
        if rays is not None:
            absent = max((x["absent"] for x in rows), default=0.0)
            evidence = "rays"
        elif s.type == ShapeType.WALL:
            absent = _band_evidence(s, children.get(s.id, []), xyz, all_buckets, r, p)
            evidence = "points"
        else:
            absent, evidence = 0.0, "points"
        b = s.geometry.bounds
        rec = {"id": s.id, "global_id": element_global_id(model, s), "name": s.name, "type": s.type.value,
               "ifc_class": IFC_CLASS.get(s.type, "IfcBuildingElementProxy"), "status": _verdict(cov, absent, p),
               "coverage": cov, "absent": float(absent), "evidence": evidence, "parent": s.parent,
               "center": ((b[0] + b[1]) / 2).tolist(), "bbox": [b[0].tolist(), b[1].tolist()], "faces": rows}
        out.append(rec)
        by_id[s.id] = rec
    for rec in out:  # doors and windows go with their wall, unless the wall is closed across them
        if rec["type"] in ("door", "window") and rec["parent"] in by_id:
            wall = by_id[rec["parent"]]
            rec["status"] = wall["status"]
            rec["walled_up"] = wall["status"] in (INSTALLED, INCOMPLETE) and _walled_up(rec, wall, planes, r, p)
            if rec["walled_up"]:
                rec["status"] = NOT_INSTALLED
    for rec in out:
        for row in rec["faces"]:
            row.pop("offset", None)
    return out


def _walled_up(opening: dict, wall: dict, planes: dict, r: float, p: StatusParams) -> bool:
    """Whether the wall goes on across a door or window: both faces of the opening covered
    (≥ ``installed_coverage``) by points in the plane of the wall's face around it (median
    offsets within max(1 cm, r/4)). A closed door leaf stands back from at least one face, an
    opening seen from one side only proves nothing."""
    faces = opening["faces"]
    if len(faces) < 2:
        return False
    tol = max(0.01, r / 4)
    for row in faces:
        if row["coverage"] < p.installed_coverage or row["offset"] is None:
            return False
        n, rho = planes[row["key"]]
        same = [w for w in wall["faces"] if w["offset"] is not None and float(planes[w["key"]][0] @ n) > 0.99
                and abs(planes[w["key"]][1] - rho) < 0.02]
        if not same or min(abs(w["offset"] - row["offset"]) for w in same) > tol:
            return False
    return True


def surface_elements(model: BuildingModel, room_patches: list, *, gap: float = 0.05) -> dict:
    """Room-face key → id of the element behind it: the wall (or slab) face that is anti-parallel,
    within ``gap`` metres and overlaps it most (None when none)."""
    pats = [pt for pt in patches_from_model(model, (ShapeType.WALL, ShapeType.SLAB))]
    out = {}
    for rp in room_patches:
        best, best_area = None, 1e-4
        for ep in pats:
            if ep.normal @ rp.normal > -0.99 or abs(ep.rho + rp.rho) > gap:
                continue
            ring = np.vstack(rp.outline3d())
            g = Polygon(ep.to2d(ring))
            if not g.is_valid:
                g = g.buffer(0)
            area = g.intersection(ep.geom).area
            if area > best_area:
                best, best_area = ep.shape_id, area
        out[rp.key] = best
    return out
