"""Scan simulation: ray casting against the true geometry of a floor plan.

The scene is a triangle mesh (:mod:`engine.synthetic.mesh`, whose names this module
re-exports) of every surface a scanner inside the building can see: floors, ceilings and
wall faces of each room with the holes of doors and windows and their reveals, window
glazing, closed door leaves, the clutter boxes and, through windows and open exterior
doors, the surroundings. Rays leave each scanner position on a regular spherical grid
(azimuth × elevation, one angular step), so the point density falls off with range as in
a real scan. Glazing is partly transparent: a ray hitting it returns a point with
probability ``ScanParams.glass_return`` and otherwise goes on through the pane. The range
gets Gaussian noise of σ along the ray. Each point carries the label of the surface it hit
(LABEL_*: wall, floor, ceiling, clutter, outside, glass, door).

Terrestrial mode: one or more positions per scanned room (more for big or long rooms),
away from walls and furniture. Mobile mode: positions every ``path_step`` along a walk
through every scanned room and the open doors between them.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
import shapely
from shapely.geometry import Point
from shapely.ops import unary_union

from ..errors import InputError
from ..geometry.boxes import box_sides
from ..lazy_open3d import open3d
from ..pointcloud import PointCloud
from ..progress import Progress
from .mesh import (  # noqa: F401  (re-exported: the scene mesh lives in .mesh)
    DOOR_LEAF_RECESS,
    DOOR_LEAF_THICKNESS,
    LABEL_CEILING,
    LABEL_CLUTTER,
    LABEL_DOOR,
    LABEL_FLOOR,
    LABEL_GLASS,
    LABEL_NAMES,
    LABEL_OUTSIDE,
    LABEL_WALL,
    TABLE_LEG,
    TABLE_LEG_INSET,
    TABLE_TOP,
    SceneMesh,
    _intervals_on_edge,
    _MeshBuilder,
    build_scene_mesh,
)
from .plan import FloorPlan, PlanGeometry, plan_geometry

__all__ = [
    "LABEL_WALL",
    "LABEL_FLOOR",
    "LABEL_CEILING",
    "LABEL_CLUTTER",
    "LABEL_OUTSIDE",
    "LABEL_GLASS",
    "LABEL_DOOR",
    "LABEL_NAMES",
    "DEFAULT_REFLECTANCE",
    "ScanParams",
    "SceneMesh",
    "ScanResult",
    "build_scene_mesh",
    "scanner_positions",
    "simulate_scan",
    "scan_mesh",
]

DEFAULT_REFLECTANCE = (0.6, 0.35, 0.8, 0.45, 0.3, 0.1, 0.5)
"""Reflectance of each label (wall, floor, ceiling, clutter, outside, glass, door), 0–1."""
GLASS_PASSES = 6
"""A ray goes through at most this many panes; one still on glass after that returns nothing."""
GLASS_STEP = 1e-4
"""A ray that goes through a pane is cast again from this far beyond it, metres."""

log = logging.getLogger(__name__)

@dataclass(frozen=True)
class ScanParams:
    """How the simulated scanner works (SI units, radians)."""

    mode: str = "tls"
    """"tls": static positions per room; "mobile": positions along a walk through the doors."""
    sigma: float = 0.005
    """Standard deviation of the range noise along each ray, metres."""
    angular_step: float = math.radians(0.2)
    """Angle between neighbouring rays in azimuth and elevation, radians (ignored when
    ``target_points`` is set)."""
    target_points: Optional[int] = None
    """When set, the angular step is chosen so that the scan has about this many points."""
    min_elevation: float = math.radians(-60.0)
    """Lowest ray elevation (the tripod or the operator hides what is below), radians."""
    max_elevation: float = math.radians(90.0)
    """Highest ray elevation, radians."""
    min_range: float = 0.3
    """Returns closer than this are dropped, metres."""
    max_range: float = 30.0
    """Returns farther than this are dropped, metres."""
    scanner_height: float = 1.5
    """Height of the scanner centre above the floor, metres."""
    area_per_scan: float = 30.0
    """A terrestrial scan per this much floor area (m²), at least one per room."""
    max_scan_spacing: float = 7.0
    """Along a long room, at most this far between terrestrial positions, metres."""
    wall_clearance: float = 0.6
    """Scanner positions keep this far from walls, metres."""
    clutter_clearance: float = 0.4
    """Scanner positions keep this far from furniture, metres."""
    position_grid: float = 0.2
    """Spacing of the candidate grid scanner positions are chosen from, metres."""
    path_step: float = 0.5
    """Mobile mode: distance between successive positions along the walk, metres."""
    door_approach: float = 0.6
    """Mobile mode: the walk passes this far in front of each door, metres."""
    path_wall_clearance: float = 0.2
    """Mobile mode: walk positions closer than this to a wall (outside door openings) are
    dropped, metres."""
    path_clutter_clearance: float = 0.1
    """Mobile mode: walk positions closer than this to furniture are dropped, metres."""
    reflectance: tuple = DEFAULT_REFLECTANCE
    """Simulated reflectance per label (0–1; walls, floors, ceilings, clutter, outside,
    glass, door leaves): a point's ``intensity`` is its surface's reflectance times the
    cosine of the incidence angle. A shorter tuple is completed from
    :data:`DEFAULT_REFLECTANCE`."""
    glass_return: float = 0.07
    """Share of the rays hitting window glazing (LABEL_GLASS triangles) that return a
    point there (0–1); the others pass through the pane."""
    surroundings: bool = True
    """Put the outer wall faces, a ground plane and outdoor boxes around the building
    (:func:`~engine.synthetic.mesh.build_scene_mesh`), seen through windows and open
    exterior doors."""
    pilot_rays: int = 60_000
    """Rays of the pilot scan that measures the hit rate for ``target_points``."""
    batch_rays: int = 1_000_000
    """Rays cast per call to the ray caster (bounds the memory)."""
    positions_per_storey: Optional[int] = None
    """Terrestrial mode: when set, at most this many scanner positions per storey, one in each
    of its biggest scanned rooms, biggest first, at the most central free spot (1: a
    single-position scan of each floor, seeing the other rooms only through doors); None: the
    positions of every scanned room. Not for mobile mode."""

    def __post_init__(self):
        if self.positions_per_storey is not None:
            if int(self.positions_per_storey) < 1:
                raise InputError(f"positions_per_storey must be at least 1, not {self.positions_per_storey!r}")
            if self.mode == "mobile":
                raise InputError("positions_per_storey is for terrestrial scans, not a mobile walk")


@dataclass(frozen=True)
class ScanResult:
    """A simulated scan with per-point provenance.

    ``cloud`` : the points, ``fields["label"]`` int32 per point, ``intensity`` float32
    (reflectance × cos incidence, 0–1).
    ``wall_index`` : (n,) int32 — wall piece hit (-1 when not a wall).
    ``room_index`` : (n,) int32 — room whose face was hit (-1: reveal or clutter).
    ``angular_step`` : radians actually used.
    """

    cloud: PointCloud
    wall_index: np.ndarray
    room_index: np.ndarray
    angular_step: float


# ----------------------------------------------------------------------------- positions
_CLEARANCE_RELAXATION = (1.0, 0.5, 0.25)
"""Factors applied to the wall and clutter clearances when a room has no free spot."""


def _candidates(poly, params, clutter):
    """Grid points (c, 2) where a scanner may stand: inside ``poly``, clear of walls and of
    the clutter footprints (relaxing the clearances when a small room is full); empty
    when there is no such spot at all."""
    s = params.position_grid
    for f in _CLEARANCE_RELAXATION:
        inner = poly.buffer(-params.wall_clearance * f)
        if clutter:
            inner = inner.difference(unary_union([c.buffer(params.clutter_clearance * f) for c in clutter]))
        if inner.is_empty:
            continue
        minx, miny, maxx, maxy = inner.bounds
        xs = np.arange(minx + s / 2, maxx, s)
        ys = np.arange(miny + s / 2, maxy, s)
        gx, gy = np.meshgrid(xs, ys)
        pts = np.column_stack([gx.ravel(), gy.ravel()])
        keep = shapely.contains_xy(inner, pts[:, 0], pts[:, 1]) if len(pts) else np.zeros(0, bool)
        if keep.any():
            return pts[keep]
        c = inner.representative_point()
        return np.array([[c.x, c.y]])
    return np.zeros((0, 2))


def _spread(cands: np.ndarray, k: int, iterations: int = 10) -> np.ndarray:
    """``k`` well-spread points among ``cands`` (farthest-point seeds, then k-means)."""
    k = min(k, len(cands))
    ctr = cands.mean(axis=0)
    sel = [int(np.argmin(np.linalg.norm(cands - ctr, axis=1)))]
    dist = np.linalg.norm(cands - cands[sel[0]], axis=1)
    for _ in range(k - 1):
        j = int(np.argmax(dist))
        sel.append(j)
        dist = np.minimum(dist, np.linalg.norm(cands - cands[j], axis=1))
    centres = cands[sel].copy()
    if k > 1:
        for _ in range(iterations):
            lab = np.argmin(np.linalg.norm(cands[:, None] - centres[None], axis=2), axis=1)
            for c in range(k):
                if np.any(lab == c):
                    centres[c] = cands[lab == c].mean(axis=0)
    snap = np.argmin(np.linalg.norm(cands[:, None] - centres[None], axis=2), axis=0)
    return cands[snap]


def _room_positions(plan, room, params, clutter):
    poly = room.shape
    cands = _candidates(poly, params, clutter)
    if len(cands) == 0:
        log.warning("room %r has no free spot for a scanner; it stays unscanned", room.name)
        return cands
    long_side = box_sides(poly)[1]
    k = max(1, math.ceil(poly.area / params.area_per_scan), math.ceil(long_side / params.max_scan_spacing))
    return _spread(cands, k)


def fps_of(plan: FloorPlan) -> dict:
    """Clutter footprints per room name."""
    fps: dict = {}
    for c in plan.clutter:
        fps.setdefault(c.room, []).append(c.footprint())
    return fps


def _few_positions(plan: FloorPlan, params: ScanParams, fps: dict) -> np.ndarray:
    """``params.positions_per_storey`` positions per storey: the most central free spot of
    each of its biggest scanned rooms."""
    out = []
    for s in range(len(plan.storeys)):
        rooms = sorted((r for r in plan.rooms if r.scanned and r.storey == s), key=lambda r: -r.shape.area)
        k = 0
        for room in rooms:
            if k >= params.positions_per_storey:
                break
            cands = _candidates(room.shape, params, fps.get(room.name, []))
            if len(cands):
                xy = _spread(cands, 1)
                out.append(np.column_stack([xy, np.full(len(xy), plan.floor_z(room) + params.scanner_height)]))
                k += 1
    return np.vstack(out) if out else np.zeros((0, 3))


def scanner_positions(plan: FloorPlan, params: ScanParams = ScanParams(),
                      geometry: Optional[PlanGeometry] = None) -> np.ndarray:
    """Scanner origins for the plan: (k, 3) float64, metres.

    Terrestrial mode: per scanned room, ``max(area / area_per_scan, long side /
    max_scan_spacing, 1)`` positions spread over the free floor (away from walls and
    clutter; with ``positions_per_storey``, only that many per storey, in the biggest
    rooms). Mobile mode: every ``path_step`` along a walk that visits each scanned room
    (through its terrestrial positions) and crosses the open doors between them, per
    storey. Unscanned rooms get none.
    """
    g = plan_geometry(plan) if geometry is None else geometry
    fps = {}
    if params.mode == "tls" and params.positions_per_storey is not None:
        return _few_positions(plan, params, fps_of(plan))
    for c in plan.clutter:
        fps.setdefault(c.room, []).append(c.footprint())
    per_room = {}
    for room in plan.rooms:
        if room.scanned:
            xy = _room_positions(plan, room, params, fps.get(room.name, []))
            if len(xy):
                per_room[room.name] = xy
    if params.mode == "tls":
        out = [np.column_stack([xy, np.full(len(xy), plan.floor_z(plan.room(n)) + params.scanner_height)])
               for n, xy in per_room.items()]
        return np.vstack(out) if out else np.zeros((0, 3))
    if params.mode != "mobile":
        raise InputError(f"scan mode must be 'tls' or 'mobile', not {params.mode!r}")
    # mobile: depth-first walk over rooms joined by open doors
    links = {}
    for door, fp, _ in g.doors:
        if len(door.rooms) != 2:
            continue  # an exterior door leads nowhere the walk goes
        a, b = door.rooms
        if door.open and a in per_room and b in per_room:
            c = np.asarray(fp.centroid.coords[0])
            links.setdefault(a, []).append((b, c))
            links.setdefault(b, []).append((a, c))
    walks = []
    seen = set()
    for room in plan.rooms:
        if room.name not in per_room or room.name in seen:
            continue
        way: list = []

        def approach(name, c):
            poly = plan.room(name).shape
            near = poly.exterior.interpolate(poly.exterior.project(Point(c)))
            v = np.asarray(near.coords[0]) - c
            v = v / max(np.linalg.norm(v), 1e-9)
            return np.asarray(near.coords[0]) + v * params.door_approach

        def visit(name):
            seen.add(name)
            way.extend(per_room[name])
            for other, c in links.get(name, []):
                if other in seen:
                    continue
                way.extend([approach(name, c), c, approach(other, c)])
                visit(other)
                way.extend([approach(other, c), c, approach(name, c), per_room[name][0]])

        visit(room.name)
        walks.append((plan.room(room.name).storey, np.asarray(way)))
    free = {}
    for s in range(len(plan.storeys)):
        rooms = [r.shape.buffer(-params.path_wall_clearance) for r in plan.rooms if r.storey == s]
        doors = [fp.buffer(params.path_wall_clearance / 4) for door, fp, _ in g.doors if door.open
                 and len(door.rooms) == 2 and plan.room(door.rooms[0]).storey == s]
        tall = [c.footprint().buffer(params.path_clutter_clearance) for c in plan.clutter
                if plan.room(c.room).storey == s]
        region = unary_union(rooms + doors)
        if tall:
            region = region.difference(unary_union(tall))
        free[s] = region
    out = []
    for s, way in walks:
        if len(way) == 1:
            pts = way
        else:
            seg = np.linalg.norm(np.diff(way, axis=0), axis=1)
            cum = np.concatenate([[0.0], np.cumsum(seg)])
            ts = np.arange(0.0, cum[-1] + 1e-9, params.path_step)
            pts = np.column_stack([np.interp(ts, cum, way[:, 0]), np.interp(ts, cum, way[:, 1])])
        keep = shapely.contains_xy(free[s], pts[:, 0], pts[:, 1])
        pts = pts[keep]
        out.append(np.column_stack([pts, np.full(len(pts), plan.storeys[s].floor_z + params.scanner_height)]))
    return np.vstack(out) if out else np.zeros((0, 3))


# ----------------------------------------------------------------------------- rays
def _grid_size(step: float, params: ScanParams) -> tuple[int, int]:
    n_az = max(4, int(math.ceil(2 * math.pi / step)))
    n_el = max(2, int(math.ceil((params.max_elevation - params.min_elevation) / step)))
    return n_az, n_el


def _directions(step: float, params: ScanParams, offset: float) -> np.ndarray:
    """(n_el * n_az, 3) float64 unit ray directions of one scan, azimuth rotated by ``offset``.

    Sines and cosines come from :mod:`math` on the few grid angles (numpy's vectorised
    ones may differ in the last bit with memory alignment), so the rays, and the scan,
    are bit-for-bit the same for the same seed.
    """
    n_az, n_el = _grid_size(step, params)
    span = params.max_elevation - params.min_elevation
    el = [params.min_elevation + (k + 0.5) * span / n_el for k in range(n_el)]
    az = [offset + j * 2 * math.pi / n_az for j in range(n_az)]
    ce = np.array([math.cos(a) for a in el])
    se = np.array([math.sin(a) for a in el])
    ca = np.array([math.cos(a) for a in az])
    sa = np.array([math.sin(a) for a in az])
    d = np.empty((n_el, n_az, 3))
    d[..., 0] = ce[:, None] * ca[None]
    d[..., 1] = ce[:, None] * sa[None]
    d[..., 2] = se[:, None]
    return d.reshape(-1, 3)


def _make_scene(mesh: SceneMesh):
    o3d = open3d("the scan simulation")
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                        o3d.core.Tensor(mesh.triangles.astype(np.uint32)))
    return scene, o3d


def _cast(scene, o3d, origin, dirs):
    """Hit distance (inf: none) and triangle of each ray; ``origin`` (3,) or (n, 3)."""
    rays = np.empty((len(dirs), 6), np.float32)
    rays[:, :3] = origin
    rays[:, 3:] = dirs
    ans = scene.cast_rays(o3d.core.Tensor(rays))
    return ans["t_hit"].numpy().astype(np.float64), ans["primitive_ids"].numpy().astype(np.int64)


def _cast_through(scene, o3d, origin, dirs, glass, p_return, rng):
    """Like :func:`_cast`, but a ray that hits a glass triangle (``glass`` (m,) bool, or None
    when the mesh has none) returns there only with probability ``p_return`` (draws from
    ``rng``); otherwise it is cast again from :data:`GLASS_STEP` beyond the pane, for at most
    :data:`GLASS_PASSES` panes."""
    t, prim = _cast(scene, o3d, origin, dirs)
    if glass is None:
        return t, prim
    hit = np.isfinite(t)
    on = np.zeros(len(t), bool)
    on[hit] = glass[prim[hit]]
    for _ in range(GLASS_PASSES):
        idx = np.flatnonzero(on)
        if len(idx) == 0:
            return t, prim
        on[:] = False
        go = idx[rng.random(len(idx)) >= p_return]
        if len(go) == 0:
            return t, prim
        start = t[go] + GLASS_STEP
        t2, p2 = _cast(scene, o3d, origin + dirs[go] * start[:, None], dirs[go])
        t[go] = start + t2
        prim[go] = p2
        h = np.isfinite(t2)
        on[go[h]] = glass[p2[h]]
    t[on] = np.inf  # still on a pane after GLASS_PASSES of them
    return t, prim


def simulate_scan(plan: FloorPlan, params: ScanParams = ScanParams(), *,
                  geometry: Optional[PlanGeometry] = None, clutter: bool = True,
                  positions: Optional[np.ndarray] = None, rng=None,
                  progress=None, should_stop=None) -> ScanResult:
    """Simulate a scan of the plan's building.

    Parameters
    ----------
    plan : FloorPlan
    params : ScanParams
    geometry : PlanGeometry, optional
        :func:`plan_geometry` of the plan when already computed.
    clutter : bool
        Whether furniture is in the scene.
    positions : (k, 3) float64, optional
        Scanner origins (metres); default :func:`scanner_positions`.
    rng : numpy Generator, int or None
        Seed of the azimuth offsets and the range noise.
    progress, should_stop : callbacks (see :class:`engine.progress.Progress`)

    Returns
    -------
    ScanResult
        Points (n, 3) float64 metres with ``scan_index``, ``scanner_positions`` and
        ``fields["label"]`` (int32, LABEL_*).

    Raises
    ------
    InputError
        When there is no scanner position (every room unscanned).
    """
    g = plan_geometry(plan) if geometry is None else geometry
    mesh = build_scene_mesh(plan, g, clutter=clutter, surroundings=params.surroundings)
    pos = scanner_positions(plan, params, g) if positions is None else np.asarray(positions, float).reshape(-1, 3)
    if len(pos) == 0:
        raise InputError(f"plan {plan.name!r}: no scanner position (no room is scanned)")
    return scan_mesh(mesh, pos, params, rng=rng, source=f"synthetic:{plan.name}", progress=progress,
                     should_stop=should_stop)


def scan_mesh(mesh: SceneMesh, positions: np.ndarray, params: ScanParams = ScanParams(), *, rng=None,
              source: str = "synthetic", progress=None, should_stop=None) -> ScanResult:
    """Cast the scanner's rays from every position into a scene mesh (any mesh: a plan's,
    or one tessellated from an IFC model).

    Parameters
    ----------
    mesh : SceneMesh — ``labels`` index ``params.reflectance``; LABEL_GLASS triangles
        return a point for a share ``params.glass_return`` of the rays hitting them and let
        the others through.
    positions : (k, 3) float64 — scanner origins, metres (k ≥ 1).
    params : ScanParams (angular step or target point count, ranges, noise).
    rng : numpy Generator, int or None — azimuth offsets, range noise and which rays
        glazing returns (the pilot scan for ``target_points`` uses its own fixed draws).
    source : text stored as the cloud's source.

    Returns
    -------
    ScanResult (see :func:`simulate_scan`).
    """
    rng = np.random.default_rng(rng)
    prog = Progress.wrap(progress, should_stop)
    pos = np.asarray(positions, float).reshape(-1, 3)
    if len(pos) == 0:
        raise InputError(f"{source}: no scanner position")
    scene, o3d = _make_scene(mesh)
    prog(0.02, "ray casting")
    offsets = rng.uniform(0.0, 2 * math.pi, len(pos))
    step = params.angular_step
    glass = mesh.labels == LABEL_GLASS
    glass = glass if glass.any() else None
    if params.target_points:
        pilot_rng = np.random.default_rng(0)
        span = params.max_elevation - params.min_elevation
        pilot = math.sqrt(len(pos) * 2 * math.pi * span / params.pilot_rays)
        hits = rays = 0
        dirs = _directions(pilot, params, 0.0)
        for o in pos:
            t, _ = _cast_through(scene, o3d, o, dirs, glass, params.glass_return, pilot_rng)
            hits += int(np.count_nonzero((t >= params.min_range) & (t <= params.max_range)))
            rays += len(dirs)
        frac = max(hits / max(rays, 1), 1e-3)
        step = math.sqrt(len(pos) * 2 * math.pi * span * frac / params.target_points)
    tri = mesh.vertices[mesh.triangles]
    tri_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    tri_n /= np.maximum(np.linalg.norm(tri_n, axis=1, keepdims=True), 1e-12)
    refl = tuple(params.reflectance)
    refl = np.asarray(refl + DEFAULT_REFLECTANCE[len(refl):], dtype=np.float64)
    xyz, lab, wall, room, sidx, inten = [], [], [], [], [], []
    for k, o in enumerate(pos):
        dk = _directions(step, params, float(offsets[k]))
        for s0 in range(0, len(dk), params.batch_rays):
            dd = dk[s0:s0 + params.batch_rays]
            t, prim = _cast_through(scene, o3d, o, dd, glass, params.glass_return, rng)
            ok = np.isfinite(t) & (t >= params.min_range) & (t <= params.max_range)
            t, prim, dd = t[ok], prim[ok], dd[ok]
            r = t + rng.normal(0.0, params.sigma, len(t))
            xyz.append(o + dd * r[:, None])
            lab.append(mesh.labels[prim])
            nt = tri_n[prim]
            inten.append(refl[mesh.labels[prim]] * np.abs(dd[:, 0] * nt[:, 0] + dd[:, 1] * nt[:, 1] + dd[:, 2] * nt[:, 2]))
            wall.append(mesh.wall_index[prim])
            room.append(mesh.room_index[prim])
            sidx.append(np.full(len(t), k, np.int32))
        prog(0.02 + 0.98 * (k + 1) / len(pos), f"scan {k + 1}/{len(pos)}")
    cloud = PointCloud(
        xyz=np.vstack(xyz),
        intensity=np.concatenate(inten).astype(np.float32),
        scan_index=np.concatenate(sidx),
        scanner_positions=pos,
        fields={"label": np.concatenate(lab).astype(np.int32)},
        source=source,
    )
    log.info("simulated %d points from %d positions (step %.3f°)", len(cloud), len(pos), math.degrees(step))
    return ScanResult(cloud, np.concatenate(wall), np.concatenate(room), step)
