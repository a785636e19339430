"""The generic (non-Manhattan) grammar: cells + rjMCMC (SPEC.md §3, thesis Ch. 4).

Pipeline of :func:`reconstruct_generic`:

1. working cloud (voxel thinning), normals, point clusters (wall / floor-ceiling / other),
   storeys — from :mod:`engine.segmentation`; the cloud is taken as levelled (z up) and is
   *not* rotated: walls may run in any direction;
2. wall planes (multi-scale RANSAC, :func:`engine.segmentation.planes.extract_planes`);
3. space partitioning: the wall planes' lines cut the storey's extent into 2-D cells
   (:func:`arrange_cells`; shapely ``polygonize`` of the noded lines), extruded between the
   storey's floor and ceiling — the **place** rule (every cell becomes a non-terminal shape);
   when the segmentation package provides ``decompose_cells`` its cells are used instead;
4. coverage of every cell and face measured once (:mod:`.coverage`);
5. the rjMCMC search for the interior spaces (:mod:`.rjmcmc`) — rules **merge**, **split**,
   **classify**, **declassify** are its moves;
6. walls and exterior (SPEC.md §3.4): an untyped cell next to a space whose vertices all lie
   within the maximum wall thickness of the shared face's line is a **wall**; the other cells
   are **exterior**;
7. adjacency / connectivity with :func:`.rules.derive_topology` (spaces sharing a wall;
   doors put in by hand later through the same editing API as the Manhattan grammar).

Every space is a vertical prism over the union of its cells, from the median height of the
floor points to the median height of the ceiling points over it. Cells stay in the model as
inactive children of their space or wall (``attributes["cell"] = True``) for sub-space
queries.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, dataclass, field
from typing import Optional

import numpy as np

from ..errors import EmptyCloudError, ReconstructionError
from ..model import BuildingModel, Polyhedron, Provenance, Shape, ShapeType, Storey
from ..pointcloud import PointCloud
from ..progress import Progress
from .coverage import CellSet, cellset_from_polygons, measure_coverage
from .rjmcmc import RjmcmcParams, SearchResult, search_spaces

__all__ = ["GenericParams", "reconstruct_generic", "manhattan_score", "choose_method", "arrange_cells", "wall_lines",
           "build_storey_shapes", "StoreyCells"]

log = logging.getLogger(__name__)

_THETA = math.radians(10.0)


def _seg_params():
    from ..segmentation.params import ClassifyParams, NormalParams, PlaneParams, StoreyParams

    return ClassifyParams, NormalParams, PlaneParams, StoreyParams


def _default(name):
    def make():
        return dict(zip(("classify", "normals", "planes", "storeys"), _seg_params()))[name]()
    return field(default_factory=make)


@dataclass(frozen=True)
class GenericParams:
    """Parameters of the generic pipeline (SI units; thesis Table 6.5 defaults)."""

    working_voxel: float = 0.02
    """Voxel of the working cloud used for normals and planes, metres (0: no thinning)."""
    max_working_points: int = 250_000
    """The working voxel grows until the working cloud has about this many points (0: no
    bound) — the scans' density is far above what coverage and planes need."""
    shape_buffer: float = 0.05
    """δ: points within this of a face belong to it, metres (above the noise, below half a
    wall's thickness)."""
    r_alpha: float = 0.2
    """Circumradius bound of the alpha shapes, metres (SPEC.md §5: 0.2 m; above about twice
    the point spacing). The ceiling's alpha shape is kept from bridging walls by the seen
    wall faces (see :func:`~.coverage.measure_coverage`), not by a small r_α."""
    coverage_angle: float = math.radians(45.0)
    """Points enter the coverage measures as floor/ceiling points when their normal is
    within this angle of vertical, as wall points when within it of horizontal, radians.
    Wider than the clustering θ on purpose: far from the scanner, sparse ceilings get noisy
    normals, and losing those points opens holes in the ceiling's alpha shape (the
    coverage is measured near known faces, so the looser test admits little clutter)."""
    min_wall_coverage: float = 0.2
    """A cell face whose wall coverage reaches this share of its area is a seen wall."""
    min_ceiling_area: float = 1.0
    """Horizontal planes at least this large (m²) in a storey's upper half are its ceiling
    levels; ceiling points for the coverage must lie near one (a door head is not a
    ceiling)."""
    ceiling_band: float = 0.1
    """... within this distance, metres."""
    alpha_spacing_factor: float = 5.0
    """r_α is raised to this many median point spacings of the thinned ceiling points when
    that is larger (sparse scans)."""
    r_alpha_max: float = 0.6
    """The ceiling's alpha shape follows the local spacing (``alpha_spacing_factor`` local
    spacings) up to this circumradius, metres: a mobile scan samples a room's ceiling ten
    times more sparsely at its edges than under the path. <= r_α: one r_α everywhere."""
    wall_band: float = 0.6
    """Wall coverage is measured in this band under the ceiling (walls reach the ceiling,
    furniture rarely does), metres; 0: the whole face."""
    coverage_grid: float = 0.04
    """Points are thinned to one per cell of this grid before coverage is measured, metres;
    also the voxel of the inside-area estimate."""
    extent_margin: float = 0.3
    """The storey's extent (box around its points) is grown by this, metres."""
    min_wall_area: float = 0.5
    """Wall planes with a smaller covered area do not cut the floor, m²."""
    line_merge_angle: float = math.radians(2.0)
    """Two wall lines closer than this in angle ..."""
    line_merge_distance: float = 0.015
    """... and this in offset are one line (duplicates would only make slivers), metres."""
    min_cell_area: float = 0.01
    """Cells smaller than this join their neighbour with the longest shared edge, m²."""
    min_cell_width: float = 0.03
    """... and so do cells narrower than this (``2 × area / perimeter``, metres): two wall
    lines crossing at a few degrees, or two faces a centimetre apart, cut wedges and strips
    that are no room and no wall (syn_house at 1M points: one such cell of 175)."""
    min_face_length: float = 0.02
    """Shared edges shorter than this do not make cells adjacent, metres."""
    manhattan_threshold: float = 0.85
    """``--method auto``: Manhattan grammar when :func:`manhattan_score` ≥ this. Measured
    with the 3° tolerance: synthetic Manhattan presets 1.0, the real PCL room scans
    0.92–0.93, syn_house 0.60–0.65, hexagon_hall 0.42."""
    search: RjmcmcParams = field(default_factory=RjmcmcParams)
    """The rjMCMC search (max wall thickness, k1..k3, μ, β, chain length)."""
    classify: object = _default("classify")
    """Point clusters (segmentation ``ClassifyParams``)."""
    theta_spread_factor: float = 4.0
    """θ of the point clusters follows the normals' noise: θ = clip(factor × s, θ of
    ``classify``, ``max_theta``), s the median tilt of the near-vertical normals (|n_z| <
    sin 30°). TLS scans give s ≈ 1° (θ stays 10°); a mobile scan with σ = 2 cm gives
    s ≈ 3.6–4.5° from the same PCA neighbourhoods, and at θ = 10° 40–60 % of the points of
    a sparsely seen wall fall into "other", so no plane is found there and two rooms share
    cells (office_mw mobile seeds 0 and 3: 7 of 8 rooms; at θ ≈ 15°: 8 of 8, completeness
    0.875 → 0.99). Departure from SPEC.md's θ ≤ 10°, for noisy normals only. 0: fixed θ."""
    max_theta: float = math.radians(20.0)
    """Upper bound of the noise-adaptive θ, radians."""
    normals: object = _default("normals")
    """Normals (segmentation ``NormalParams``)."""
    planes: object = _default("planes")
    """RANSAC planes (segmentation ``PlaneParams``)."""
    storeys: object = _default("storeys")
    """Storeys (segmentation ``StoreyParams``)."""


# --------------------------------------------------------------------------- Manhattan-ness
def manhattan_score(cloud: PointCloud, params: Optional["GenericParams"] = None, rng=0,
                    angle_tolerance: float = math.radians(3.0), sample: int = 300_000) -> float:
    """How Manhattan a building is: the share of wall area (RANSAC wall planes, weighted by
    their covered area) whose direction lies within ``angle_tolerance`` of two perpendicular
    horizontal directions (the best pair).

    Plane directions are folded modulo 90°; the densest direction (a 0.5° histogram,
    circularly smoothed over the tolerance) is the pair's; the score is the area share
    within the tolerance of it. Plane normals are precise where point normals are noisy
    (mobile scans), so the tolerance can be tight enough to tell a wall 7° off the axes
    (syn_house) from an aligned one; 3° rather than 2° because real walls are not perfectly
    square (the PCL room scan's long walls are 0.7° from parallel: it scored 0.86–0.90 at
    2°, 0.92–0.93 at 3°). Box-room buildings score ≈ 1, the hexagonal hall
    ≈ 0.3–0.5. ``--method auto`` picks the Manhattan grammar when the score reaches
    :attr:`GenericParams.manhattan_threshold`.

    Parameters
    ----------
    cloud : PointCloud — z up, metres; normals estimated when missing.
    params : GenericParams (normals, clusters, storeys, planes).
    rng : seed of the subsample and of RANSAC.
    angle_tolerance : radians.
    sample : at most this many points are used.

    Returns
    -------
    float in [0, 1]; 0 when no wall plane is found.

    Raises
    ------
    EmptyCloudError
        Too few points.
    """
    from ..segmentation import classify_points, estimate_normals, voxel_downsample
    from ..segmentation.planes import extract_planes

    params = params or GenericParams()
    rng = np.random.default_rng(rng)
    if len(cloud) < 100:
        raise EmptyCloudError(f"the cloud has {len(cloud)} points; at least 100 are needed", cloud.source or None)
    work = voxel_downsample(cloud, params.working_voxel)[0] if params.working_voxel > 0 else cloud
    if len(work) > sample:
        work = work.subset(np.sort(rng.choice(len(work), sample, replace=False)))
    if work.normals is None:
        work = estimate_normals(work, params.normals)
    labels = classify_points(work, params.classify)
    try:
        planes = extract_planes(work, params.planes, labels=labels, rng=rng)
    except ReconstructionError:
        return 0.0
    walls = [p for p in planes if p.kind == "wall"]
    if not walls:
        return 0.0
    phi = np.array([math.atan2(p.normal[1], p.normal[0]) for p in walls]) % (math.pi / 2)
    w = np.array([max(p.area, 0.0) for p in walls])
    if w.sum() <= 0:
        return 0.0
    bins = 180
    h = np.bincount(np.floor(phi / (math.pi / 2) * bins).astype(int) % bins, weights=w, minlength=bins)
    k = max(1, int(round(angle_tolerance / (math.pi / 2) * bins)))
    smooth = sum(np.roll(h, j) for j in range(-k, k + 1))
    peak = (np.argmax(smooth) + 0.5) * (math.pi / 2) / bins
    dev = np.abs((phi - peak + math.pi / 4) % (math.pi / 2) - math.pi / 4)
    return float(w[dev <= angle_tolerance].sum() / w.sum())


def choose_method(cloud: PointCloud, params: Optional[GenericParams] = None, rng=0) -> tuple[str, float]:
    """``--method auto``: "manhattan" when :func:`manhattan_score` ≥
    ``params.manhattan_threshold``, else "generic". Returns (method, score)."""
    params = params or GenericParams()
    score = manhattan_score(cloud, params, rng=rng)
    method = "manhattan" if score >= params.manhattan_threshold else "generic"
    log.info("auto method: Manhattan score %.2f (threshold %.2f) -> %s", score, params.manhattan_threshold, method)
    return method, score


# --------------------------------------------------------------------------- cells
def wall_lines(planes, storey: int, params: GenericParams) -> np.ndarray:
    """(k, 3) float64 lines ``(nx, ny, ρ)`` (``nx x + ny y = ρ``, metres) of the wall planes of
    one storey, near-duplicates merged (support-weighted)."""
    rows = []
    for pl in planes:
        if pl.kind != "wall" or (pl.storey not in (storey, -1)) or pl.area < params.min_wall_area:
            continue
        n = np.asarray(pl.normal[:2], float)
        nn = np.linalg.norm(n)
        if nn == 0:
            continue
        n, rho = n / nn, pl.offset / nn
        if n[0] < -1e-12 or (abs(n[0]) <= 1e-12 and n[1] < 0):
            n, rho = -n, -rho
        rows.append((n[0], n[1], rho, float(len(pl.support))))
    rows.sort(key=lambda r: -r[3])
    kept: list = []
    for nx, ny, rho, w in rows:
        for k in kept:
            ang = math.acos(min(1.0, abs(nx * k[0] + ny * k[1])))
            if ang < params.line_merge_angle and abs(rho - k[2] * (1 if nx * k[0] + ny * k[1] > 0 else -1)) \
                    < params.line_merge_distance:
                break
        else:
            kept.append((nx, ny, rho))
    return np.array(kept, dtype=np.float64).reshape(-1, 3)


def arrange_cells(lines: np.ndarray, extent, min_cell_area: float = 0.01,
                  min_cell_width: float = 0.0) -> list:
    """2-D cells of the arrangement of lines inside a polygonal extent.

    Parameters
    ----------
    lines : (k, 3) float64 — ``(nx, ny, ρ)`` with unit ``(nx, ny)``, metres.
    extent : shapely Polygon — the region to partition (e.g. the storey's box).
    min_cell_area : cells below this area (m²) join the neighbour with the longest shared
        edge.
    min_cell_width : so do cells whose width ``2 × area / perimeter`` is below this, metres.

    Returns
    -------
    list of shapely Polygon — a partition of ``extent``; one polygon (the extent) when there
    are no lines.
    """
    import shapely
    from shapely.ops import polygonize

    minx, miny, maxx, maxy = extent.bounds
    R = 2.0 * math.hypot(maxx - minx, maxy - miny) + 1.0
    c = np.array([(minx + maxx) / 2, (miny + maxy) / 2])
    segs = [extent.exterior]
    for nx, ny, rho in np.asarray(lines, float).reshape(-1, 3):
        n = np.array([nx, ny])
        p0 = c + (rho - n @ c) * n
        d = np.array([-ny, nx])
        ln = shapely.LineString([p0 - R * d, p0 + R * d])
        cl = shapely.intersection(ln, extent)
        if not cl.is_empty:
            segs.append(cl)
    noded = shapely.union_all(segs)
    cells = [p for p in polygonize(noded) if p.area > 0 and extent.contains(p.representative_point())]
    return _merge_small(cells, min_cell_area, min_cell_width)


def _merge_small(cells: list, min_area: float, min_width: float = 0.0) -> list:
    import shapely

    cells = list(cells)
    changed = True
    while changed and len(cells) > 1:
        changed = False
        areas = np.array([p.area for p in cells])
        widths = 2.0 * areas / np.maximum([p.length for p in cells], 1e-12)
        small = (areas < min_area) | (widths < min_width)
        order = np.argsort(np.where(small, areas, np.inf))
        for i in order:
            if not small[i]:
                break
            best, blen = None, 0.0
            for j, q in enumerate(cells):
                if j == i:
                    continue
                inter = shapely.intersection(cells[i].boundary, q.boundary)
                if inter.length > blen:
                    best, blen = j, inter.length
            if best is None:
                continue
            u = shapely.union_all([cells[best], cells[i]])
            if u.geom_type != "Polygon":
                continue
            cells[best] = shapely.simplify(u, 1e-9)
            cells.pop(i)
            changed = True
            break
    return cells


@dataclass(frozen=True, eq=False)
class StoreyCells:
    """The cells of one storey with their search result (for the model builder)."""

    storey: Storey
    cells: CellSet
    coverage: object
    result: SearchResult


# --------------------------------------------------------------------------- model
def _polygon_coords(poly) -> np.ndarray:
    import shapely

    poly = shapely.simplify(shapely.normalize(poly), 1e-7)
    return np.asarray(poly.exterior.coords)[:-1, :2]


def _weighted_median(v: np.ndarray, w: np.ndarray) -> float:
    """Area-weighted median of the cells' heights (a cell under a table does not tilt it)."""
    o = np.argsort(v)
    cw = np.cumsum(w[o])
    return float(v[o][np.searchsorted(cw, cw[-1] / 2)])


def build_storey_shapes(sc: StoreyCells, index: int, max_wall_thickness: float) -> list[Shape]:
    """Shapes of one storey: spaces, walls (SPEC.md §3.4), exterior, and the cells.

    Parameters
    ----------
    sc : StoreyCells
    index : storey index written on the shapes.
    max_wall_thickness : metres.

    Returns
    -------
    list of Shape — active spaces/walls/exterior, inactive cells (children).
    """
    import shapely

    cells, cov, res = sc.cells, sc.coverage, sc.result
    st = sc.storey
    n = len(cells)
    kind = np.full(n, "", dtype=object)
    owner = [None] * n
    shapes = []
    space_of = np.full(n, -1)
    for k, sp in enumerate(res.spaces):
        space_of[list(sp)] = k
    # --- interior spaces
    for k, sp in enumerate(res.spaces):
        sp = list(sp)
        poly = cells.union(sp)
        if poly.geom_type != "Polygon":
            poly = max(poly.geoms, key=lambda g: g.area)
        if len(poly.interiors):
            log.warning("storey %d space %d has a hole (an unselected cell inside); its outline is used",
                        index, k)
            poly = shapely.Polygon(poly.exterior)
        a = cov.area[sp]
        cz, fz = cov.ceiling_z[sp], cov.floor_z[sp]
        okc, okf = np.isfinite(cz), np.isfinite(fz)
        z1 = _weighted_median(cz[okc], a[okc]) if okc.any() else st.ceiling_z
        z0 = _weighted_median(fz[okf], a[okf]) if okf.any() else st.floor_z
        sid = f"s{index}_space{k}"
        top = float(cov.top[sp].sum())
        shapes.append(Shape(
            id=sid, type=ShapeType.INTERIOR, geometry=Polyhedron.prism(_polygon_coords(poly), z0, z1),
            storey=index, terminal=True, children=tuple(f"s{index}_cell{c}" for c in sorted(sp)),
            support={"coverage_top": top / max(float(a.sum()), 1e-12)},
            attributes={"area": float(poly.area), "height": z1 - z0, "floor_z": z0, "ceiling_z": z1,
                        "cells": len(sp), "merged": len(sp) > 1},
            log=(f"rjMCMC: {len(sp)} cell(s) -> interior space (ceiling coverage "
                 f"{top / max(float(a.sum()), 1e-12):.2f})",)))
        for c in sp:
            kind[c], owner[c] = "interior", sid
    # --- walls: untyped cells next to a space, thin w.r.t. the shared face
    nb = cells.neighbours()
    wall_no = 0
    for c in range(n):
        if space_of[c] >= 0:
            continue
        thick = cells.wall_thickness(c, [fi for _, fi in nb[c]], space_of >= 0)
        if thick > max_wall_thickness:
            continue
        wid = f"s{index}_wall{wall_no}"
        wall_no += 1
        shapes.append(Shape(
            id=wid, type=ShapeType.WALL,
            geometry=Polyhedron.prism(_polygon_coords(cells.polygons[c]), *cells.z_range[c]),
            storey=index, terminal=True, children=(f"s{index}_cell{c}",),
            attributes={"thickness": thick, "height": float(cells.z_range[c, 1] - cells.z_range[c, 0])},
            log=(f"walls (SPEC 3.4): untyped cell next to a space, vertices within {thick:.3f} m "
                 f"<= {max_wall_thickness:g} m of the shared face -> wall",)))
        kind[c], owner[c] = "wall", wid
    # --- exterior: connected groups of the remaining cells (hole-free unions), else per cell
    rest = [c for c in range(n) if not kind[c]]
    left = set(rest)
    ext_no = 0
    while left:
        seed = left.pop()
        comp, stack = [seed], [seed]
        while stack:
            c = stack.pop()
            for o, _ in nb[c]:
                if o in left:
                    left.discard(o)
                    comp.append(o)
                    stack.append(o)
        u = cells.union(comp)
        groups = [comp] if (u.geom_type == "Polygon" and not u.interiors) else [[c] for c in comp]
        for g in groups:
            poly = u if len(groups) == 1 else cells.polygons[g[0]]
            eid = f"s{index}_exterior{ext_no}"
            ext_no += 1
            shapes.append(Shape(
                id=eid, type=ShapeType.EXTERIOR,
                geometry=Polyhedron.prism(_polygon_coords(poly), st.floor_z, st.ceiling_z),
                storey=index, terminal=True, children=tuple(f"s{index}_cell{c}" for c in sorted(g)),
                log=("walls/exterior (SPEC 3.4): cell neither interior nor wall -> exterior",)))
            for c in g:
                kind[c], owner[c] = "exterior", eid
    # --- the cells themselves, inactive parts
    types = {"interior": ShapeType.INTERIOR, "wall": ShapeType.WALL, "exterior": ShapeType.EXTERIOR}
    for c in range(n):
        shapes.append(Shape(
            id=f"s{index}_cell{c}", type=types[kind[c]],
            geometry=Polyhedron.prism(_polygon_coords(cells.polygons[c]), *cells.z_range[c]),
            storey=index, terminal=False, active=False, parent=owner[c],
            support={"coverage_top": float(cov.top[c] / max(cov.area[c], 1e-12)),
                     "coverage_inside": float(cov.inside[c])},
            attributes={"cell": True},
            log=(f"place: cell {c} of the arrangement",)))
    return shapes


def _name_shapes(shapes: list[Shape]) -> list[Shape]:
    counters: dict = {}
    out = []
    order = sorted(range(len(shapes)), key=lambda i: (shapes[i].storey, round(float(shapes[i].centroid[1]), 2),
                                                      round(float(shapes[i].centroid[0]), 2)))
    names = {}
    for i in order:
        s = shapes[i]
        if not s.active:
            continue
        label = {"interior": "Room", "wall": "Wall", "exterior": "Exterior"}.get(s.type.value, "Shape")
        counters[label] = counters.get(label, 0) + 1
        names[i] = f"{label} {counters[label]}"
    for i, s in enumerate(shapes):
        out.append(s.with_(name=names[i]) if i in names else s)
    return out


def assemble_model(storeys: list[StoreyCells], params: GenericParams, *, seed=None,
                   timings=None, source: str = "") -> BuildingModel:
    """A BuildingModel from the searched storeys, with topology (adjacency via walls)."""
    from .rules import derive_topology

    shapes = []
    for i, sc in enumerate(storeys):
        shapes.extend(build_storey_shapes(sc, i, params.search.max_wall_thickness))
    shapes = _name_shapes(shapes)
    trace = {f"storey_{i}": {**sc.result.trace, "log_posterior": sc.result.log_posterior,
                             "acceptance_rate": sc.result.acceptance_rate,
                             "iterations": sc.result.iterations, "spaces": len(sc.result.spaces)}
             for i, sc in enumerate(storeys)}
    prov = Provenance(method="generic", parameters=_params_dict(params), seed=seed,
                      timings=dict(timings or {}), trace=trace, source=source)
    model = BuildingModel(shapes=tuple(shapes), storeys=tuple(sc.storey for sc in storeys), provenance=prov)
    return derive_topology(model)


def _params_dict(params: GenericParams) -> dict:
    out = {}
    for k, v in params.__dict__.items():
        out[k] = asdict(v) if hasattr(v, "__dataclass_fields__") else v
    out["tau"] = 0.3
    return out


# --------------------------------------------------------------------------- pipeline
def _storeys_of(cloud: PointCloud, labels: np.ndarray, params: GenericParams) -> list[Storey]:
    from ..segmentation import detect_storeys

    try:
        return list(detect_storeys(cloud, params.storeys))
    except ReconstructionError as e:
        from ..segmentation import CLASS_HORIZONTAL

        z = cloud.xyz[labels == CLASS_HORIZONTAL, 2]
        if len(z) < 10:
            raise ReconstructionError(f"no storey found ({e}) and too few floor/ceiling points",
                                      cloud.source or None) from None
        lo, hi = np.percentile(z, [1, 99])
        log.warning("storey detection failed (%s); one storey from %.2f to %.2f m", e, lo, hi)
        return [Storey(0, float(lo), float(hi), "Storey 0", float(lo))]


def normal_tilt_spread(normals: np.ndarray) -> float:
    """Median tilt from horizontal of the near-vertical-surface normals (|n_z| < sin 30°),
    radians: how noisy the normals of walls are (0 when there are none)."""
    nz = np.abs(np.asarray(normals, dtype=np.float64).reshape(-1, 3)[:, 2])
    wall = nz < 0.5
    return float(np.arcsin(np.median(nz[wall]))) if wall.any() else 0.0


def _cluster_params(work: PointCloud, params: "GenericParams"):
    """The point-cluster parameters with θ raised for noisy normals (``theta_spread_factor``)."""
    from dataclasses import replace

    base = params.classify
    if params.theta_spread_factor <= 0:
        return base
    theta = min(max(base.angle_tolerance, params.theta_spread_factor * normal_tilt_spread(work.normals)),
                max(params.max_theta, base.angle_tolerance))
    if theta > base.angle_tolerance:
        log.info("noisy normals: point clusters with θ = %.1f°", math.degrees(theta))
    return replace(base, angle_tolerance=theta)


def _working_cloud(cloud: PointCloud, params: "GenericParams") -> PointCloud:
    """Voxel-thinned working cloud of at most about ``params.max_working_points`` points:
    the voxel grows with the square root of the excess (the points lie on surfaces)."""
    from ..segmentation import voxel_downsample

    if params.working_voxel <= 0:
        return cloud
    work = voxel_downsample(cloud, params.working_voxel)[0]
    if params.max_working_points and len(work) > params.max_working_points:
        voxel = params.working_voxel * math.sqrt(len(work) / params.max_working_points)
        work = voxel_downsample(cloud, voxel)[0]
        log.info("working cloud: voxel %.3f m -> %d points", voxel, len(work))
    return work


def _near_ceiling_levels(z: np.ndarray, planes, storey: int, z0: float, z1: float,
                         params: "GenericParams") -> np.ndarray:
    """(n,) bool: False for upper-half points that are far from every large horizontal
    plane (door heads, shelf tops seen from below are not ceiling); lower-half points and
    all points when no large plane is known stay True."""
    mid = (z0 + z1) / 2
    levels = [float(p.offset / p.normal[2]) for p in planes
              if p.kind == "horizontal" and p.storey in (storey, -1) and p.area >= params.min_ceiling_area
              and abs(p.normal[2]) > 0.5 and p.offset / p.normal[2] > mid]
    if not levels:
        return np.ones(len(z), bool)
    lv = np.asarray(levels)
    near = np.min(np.abs(z[:, None] - lv[None, :]), axis=1) <= params.ceiling_band
    return near | (z <= mid)


def reconstruct_generic(cloud: PointCloud, params: Optional[GenericParams] = None, *, rng=None,
                        progress=None, should_stop=None) -> BuildingModel:
    """Scan → model with the generic grammar and the rjMCMC search (SPEC.md §3).

    Parameters
    ----------
    cloud : PointCloud
        z up (levelled), metres; (n, 3) float64 ``xyz``; normals are estimated when missing.
        Walls may run in any direction.
    params : GenericParams, optional
    rng : numpy Generator, int or None — seeds RANSAC and the search; same seed, same model.
    progress, should_stop : see :class:`engine.progress.Progress`.

    Returns
    -------
    BuildingModel
        Interior spaces (active prisms over unions of cells), walls, exterior, the cells as
        inactive parts, adjacency relations; provenance method "generic" with the search
        trace of every storey (``provenance.trace["storey_<i>"]``) and timings.

    Raises
    ------
    EmptyCloudError
        Too few points.
    ReconstructionError
        No storey, no wall plane, or no cell.
    """
    import shapely

    from ..segmentation import classify_points, estimate_normals
    from ..segmentation.planes import extract_planes

    params = params or GenericParams()
    seed = int(rng) if isinstance(rng, (int, np.integer)) else None
    rng = np.random.default_rng(rng)
    p = Progress.wrap(progress, should_stop)
    if len(cloud) < 100:
        raise EmptyCloudError(f"the cloud has {len(cloud)} points; at least 100 are needed", cloud.source or None)
    timings = {}
    t0 = time.perf_counter()
    work = _working_cloud(cloud, params)
    if work.normals is None:
        p(0.02, "normals")
        work = estimate_normals(work, params.normals)
    labels = classify_points(work, _cluster_params(work, params))
    timings["preprocess"] = time.perf_counter() - t0
    p.check()
    t1 = time.perf_counter()
    storeys = _storeys_of(work, labels, params)
    timings["storeys"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    p(0.1, "planes")
    planes = extract_planes(work, params.planes, labels=labels, storeys=storeys, rng=rng,
                            progress=p.sub(0.1, 0.5), should_stop=should_stop)
    timings["planes"] = time.perf_counter() - t1
    out = []
    t_cells = t_cov = t_search = 0.0
    for si, st in enumerate(storeys):
        p.check()
        a, b = 0.5 + 0.45 * si / len(storeys), 0.5 + 0.45 * (si + 1) / len(storeys)
        t1 = time.perf_counter()
        # the storey reaches up to the next storey's floor (rooms of several ceiling heights)
        top_z = storeys[si + 1].floor_z - params.shape_buffer if si + 1 < len(storeys) else np.inf
        inz = (work.xyz[:, 2] >= st.floor_z - params.shape_buffer) & (work.xyz[:, 2] <= top_z)
        xyz = work.xyz[inz]
        nz = np.abs(work.normals[inz, 2].astype(np.float64))
        if len(xyz) < 10:
            continue
        z_hi = max(st.ceiling_z, float(np.percentile(xyz[:, 2], 99.9)))
        lo, hi = xyz[:, :2].min(axis=0) - params.extent_margin, xyz[:, :2].max(axis=0) + params.extent_margin
        extent = shapely.box(lo[0], lo[1], hi[0], hi[1])
        lines = wall_lines(planes, si, params)
        polys = arrange_cells(lines, extent, params.min_cell_area, params.min_cell_width)
        cells = cellset_from_polygons(polys, (st.floor_z, z_hi), params.min_face_length)
        t_cells += time.perf_counter() - t1
        t1 = time.perf_counter()
        hmask = nz >= math.cos(params.coverage_angle)
        wmask = nz <= math.sin(params.coverage_angle)
        hmask &= _near_ceiling_levels(xyz[:, 2], planes, si, st.floor_z, z_hi, params)
        cov = measure_coverage(cells, xyz[wmask], xyz[hmask],
                               shape_buffer=params.shape_buffer, r_alpha=params.r_alpha,
                               thin=params.coverage_grid, min_wall_coverage=params.min_wall_coverage,
                               wall_band=params.wall_band, alpha_spacing_factor=params.alpha_spacing_factor,
                               r_alpha_max=params.r_alpha_max,
                               should_check=p.check)
        t_cov += time.perf_counter() - t1
        t1 = time.perf_counter()
        res = search_spaces(cells, cov, params.search, rng=rng, progress=p.sub(a, b), should_stop=should_stop)
        t_search += time.perf_counter() - t1
        log.info("storey %d: %d wall lines, %d cells, %d spaces", si, len(lines), len(cells), len(res.spaces))
        out.append(StoreyCells(st, cells, cov, res))
    if not out:
        raise ReconstructionError("no storey with points to reconstruct", cloud.source or None)
    timings.update(cells=t_cells, coverage=t_cov, rjmcmc=t_search)
    t1 = time.perf_counter()
    model = assemble_model(out, params, seed=seed, timings=timings, source=cloud.source or "")
    timings["model"] = time.perf_counter() - t1
    timings["total"] = time.perf_counter() - t0
    model = model.with_(provenance=Provenance(**{**model.provenance.__dict__, "timings": timings}))
    p(1.0, "generic reconstruction done")
    return model
