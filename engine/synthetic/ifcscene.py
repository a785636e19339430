"""Synthetic scans of real IFC building models, with the model's doors and windows as truth.

:func:`ifc_geometry` tessellates a file's physical elements with ``ifcopenshell.geom``
(world coordinates, metres, z up): walls, slabs, roofs, coverings, doors, windows, stairs,
railings, beams, members and furniture, plus the IfcSpace footprints. :func:`ifc_scene_mesh`
turns that into the :class:`~engine.synthetic.scan.SceneMesh` the scan simulator casts rays
into:

* walls: every face LABEL_WALL;
* slabs, roofs, coverings: faces looking down (n_z ≤ -``horizontal_nz``) LABEL_CEILING,
  looking up LABEL_FLOOR, the rest (edges, stair-hole sides) LABEL_WALL;
* doors and windows: their frames LABEL_WALL (as the reveals of the presets). Glass
  (a surface style with transparency ≥ ``glass_transparency``) is left out — the simulator
  has no glazing label or partial transparency — so a window is a clear hole in its frame.
  An open door loses its leaf: every connected part of the door that reaches neither side
  of the door's width nor its top (leaf, handles, glazing bars), or that covers the middle
  of the door's elevation (a leaf fitted to its frame), is left out;
* everything else (stairs, railings, beams, members, furniture, ...): LABEL_CLUTTER;
* outside: a ground plane ``ground_offset`` below the lowest floor of a space and four
  vertical screens ``surroundings_distance`` around the building (LABEL_CLUTTER), so that
  rays through windows and open outer doors return points.

``SceneMesh.wall_index`` holds, for wall triangles, the index of the element in
:attr:`IfcGeometry.element_ids`; ``SceneMesh.room_index`` holds that element index for
every triangle (-1 for the ground and the screens).

:func:`ifc_scanner_positions` places terrestrial positions inside each IfcSpace footprint
(about one per ``area_per_scan`` m², at least one per space, ``scanner_height`` above the
space's floor, ``wall_clearance`` from its walls, with floor below, cover above and no
element within ``clutter_clearance``), or a mobile walk through the spaces and their open
doors. :func:`ifc_truth` is :func:`engine.ifc.read_ifc` with each door's ``open`` flag.
:func:`ifc_scene` puts it together: cloud (``fields["label"]``, ``fields["element"]``), truth
and timings, like :func:`engine.synthetic.preset`.
"""
from __future__ import annotations

import logging
import math
import os
import time
from dataclasses import dataclass, field, replace
from typing import Collection, Mapping, Optional, Union

import numpy as np
import shapely
from shapely.geometry import Point, Polygon
from shapely.ops import nearest_points, unary_union

from ..errors import FormatError, InputError
from ..geometry.boxes import box_sides
from ..ifc.common import check_path, require_ifcopenshell
from ..ifc.reader import IfcReadParams, read_ifc
from ..lazy_open3d import open3d
from ..model import BuildingModel, ShapeType
from ..pointcloud import PointCloud
from ..progress import Progress
from .presets import scan_params_for
from .scan import LABEL_CEILING, LABEL_CLUTTER, LABEL_FLOOR, LABEL_WALL, ScanParams, SceneMesh, scan_mesh

__all__ = ["IFC_SCENES", "IfcSceneParams", "IfcElementMesh", "IfcSpaceArea", "IfcGeometry", "IfcScene",
           "ifc_scene_path", "ifc_geometry", "ifc_scene_mesh", "ifc_scanner_positions", "ifc_truth",
           "ifc_door_states", "ifc_scene"]

log = logging.getLogger(__name__)

IFC_SCENES = {"fzk_haus": "AC20-FZK-Haus.ifc", "duplex": "Duplex_A_20110907_architecture.ifc"}
"""Names :func:`ifc_scene` resolves to the sample files in the source tree's ``tests/data``."""

_WALL, _SURFACE, _DOOR, _WINDOW, _CLUTTER = "wall", "surface", "door", "window", "clutter"


@dataclass(frozen=True)
class IfcSceneParams:
    """How an IFC model becomes a scene (SI units)."""

    closed_doors: tuple = ()
    """GlobalIds or names of doors that are closed (their leaf stays); the others are open."""
    close_exterior_doors: bool = False
    """Close every door to the outside too."""
    glass_transparency: float = 0.5
    """Faces with a surface-style transparency at least this (0–1) are glass and left out."""
    frame_tolerance: float = 0.02
    """A door part within this (m) of a side or the top of the door's extent is frame."""
    furniture: bool = True
    """Put the furnishing elements in the scene."""
    skip_classes: tuple = ("IfcFeatureElement", "IfcVirtualElement", "IfcFooting", "IfcPile", "IfcSpace",
                           "IfcOpeningElement", "IfcDistributionPort")
    """IFC classes (with subclasses) never put in the scene."""
    wall_classes: tuple = ("IfcWall", "IfcCurtainWall")
    surface_classes: tuple = ("IfcSlab", "IfcRoof", "IfcCovering")
    furniture_classes: tuple = ("IfcFurnishingElement", "IfcFurniture", "IfcSystemFurnitureElement")
    horizontal_nz: float = 0.3
    """Slab faces with |n_z| at least this are floor (up) or ceiling (down)."""
    ground_offset: float = 0.05
    """The ground plane lies this far below the lowest floor of a space, metres."""
    ground_margin: float = 40.0
    """The ground reaches this far beyond the building's plan extent, metres."""
    surroundings_distance: float = 10.0
    """Vertical screens stand this far outside the building's plan extent, metres."""
    surroundings_height: float = 8.0
    """Height of the screens above the ground, metres."""
    ceiling_clearance: float = 0.3
    """A scanner keeps this far below whatever is above it (and needs something above), metres."""
    floor_tolerance: float = 0.3
    """The floor below a scanner is within this of ``scanner_height``, metres."""
    probe_heights: tuple = (0.2, 1.0)
    """Heights above the floor (m), besides the scanner's, of the horizontal clearance probes."""
    probe_directions: int = 8
    """Horizontal clearance probes per height."""
    threads: int = 1
    """Tessellation threads (ifcopenshell's threaded iterator is slower on a busy machine)."""


@dataclass(frozen=True, eq=False)
class IfcElementMesh:
    """One tessellated IFC element (metres, the geometry's frame).

    ``role``: "wall", "surface" (slab / roof / covering), "door", "window" or "clutter".
    ``glass``: (m,) bool per triangle. ``axis``: (2,) unit plan direction of a door's
    width (its placement's x axis). ``external``: IsExternal of its common property set,
    or None.
    """

    guid: str
    ifc_class: str
    name: str
    role: str
    vertices: np.ndarray
    triangles: np.ndarray
    glass: np.ndarray
    axis: Optional[np.ndarray] = None
    external: Optional[bool] = None


@dataclass(frozen=True, eq=False)
class IfcSpaceArea:
    """An IfcSpace: its plan ``footprint`` (shapely Polygon), ``floor_z`` and ``top_z`` (m)."""

    guid: str
    name: str
    footprint: Polygon
    floor_z: float
    top_z: float


@dataclass(frozen=True, eq=False)
class IfcGeometry:
    """The tessellated file: elements sorted by entity id, spaces, the offset removed (m)."""

    path: str
    elements: tuple
    spaces: tuple
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def element_ids(self) -> tuple:
        """GlobalIds of the elements, in the order the mesh's element indices use."""
        return tuple(e.guid for e in self.elements)


@dataclass(frozen=True, eq=False)
class IfcScene:
    """A scan of a real IFC model with its true model (fields as in ``SyntheticScene``).

    ``cloud.fields``: ``label`` (LABEL_*), ``element`` (int32 index into ``element_ids``, -1
    for the ground and surroundings). ``plan`` is always None (no floor plan behind it).
    """

    name: str
    seed: int
    noise_sigma: float
    cloud: PointCloud
    truth: BuildingModel
    path: str
    positions: np.ndarray
    element_ids: tuple
    scan_params: Optional[ScanParams] = None
    timings: Mapping[str, float] = field(default_factory=dict)
    variants: Mapping[str, BuildingModel] = field(default_factory=dict)
    plan: None = None


def ifc_scene_path(name: str) -> str:
    """The file of a named sample scene ("fzk_haus", "duplex") in the source tree's
    ``tests/data`` (a convenience for tests and benchmarks; pass a path otherwise).

    Raises InputError for an unknown name or when the source tree's data is not there.
    """
    key = str(name).strip().lower()
    if key not in IFC_SCENES:
        raise InputError(f"unknown IFC scene {name!r}; choose one of {', '.join(IFC_SCENES)} or give a path")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    path = os.path.join(root, "tests", "data", IFC_SCENES[key])
    if not os.path.isfile(path):
        raise InputError(f"IFC scene {key!r}: the sample file is missing (only in a source checkout); "
                         "give a path", path)
    return path


# ----------------------------------------------------------------------------- tessellation
def _is(e, classes) -> bool:
    for c in classes:
        try:
            if e.is_a(c):
                return True
        except RuntimeError:  # class not in this schema
            continue
    return False


def _common_external(e, ue) -> Optional[bool]:
    for name, pset in ue.get_psets(e).items():
        if name.startswith("Pset_") and name.endswith("Common") and pset.get("IsExternal") is not None:
            return bool(pset["IsExternal"])
    return None


def _plan_union(v: np.ndarray, tri: np.ndarray):
    polys = [Polygon(v[t, :2]) for t in tri]
    return unary_union([p for p in polys if p.area > 1e-9]).buffer(0)


def ifc_geometry(path: Union[str, os.PathLike], params: IfcSceneParams = IfcSceneParams(), *,
                 offset=None, progress=None, should_stop=None) -> IfcGeometry:
    """Tessellate the physical elements and the spaces of an IFC file.

    Parameters
    ----------
    path : the .ifc file.
    params : IfcSceneParams
    offset : (3,) float64, optional
        Removed from every coordinate (metres): pass the truth's ``model.offset`` so the
        scene and :func:`ifc_truth` share one frame. Default zero.

    Returns
    -------
    IfcGeometry

    Raises
    ------
    InputError — missing file. FormatError — not IFC or nothing tessellates.
    """
    import ifcopenshell
    import ifcopenshell.geom
    import ifcopenshell.util.element as ue
    import ifcopenshell.util.placement as up

    prog = Progress.wrap(progress, should_stop)
    path = check_path(path)
    require_ifcopenshell("IFC scenes")
    try:
        f = ifcopenshell.open(path)
    except Exception as e:  # ifcopenshell raises plain errors on bad content
        raise FormatError(f"cannot parse the IFC file: {e}", path) from None
    off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64).reshape(3)
    skip = tuple(params.skip_classes) + (() if params.furniture else tuple(params.furniture_classes))
    chosen = [e for e in f.by_type("IfcElement") if e.Representation is not None and not _is(e, skip)]
    ids = {e.id() for e in chosen}
    # an aggregate drawn by its parts too (a stair and its flights) is drawn once, by its parts
    chosen = [e for e in chosen
              if not any(p.id() in ids for r in e.IsDecomposedBy or () for p in r.RelatedObjects)]
    spaces = list(f.by_type("IfcSpace"))
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    settings.set("weld-vertices", True)
    it = ifcopenshell.geom.iterator(settings, f, max(1, int(params.threads)), include=chosen + spaces)
    raw = {}
    try:
        ok = it.initialize()
    except Exception as e:
        raise FormatError(f"cannot tessellate the IFC geometry: {e}", path) from None
    n = max(len(chosen) + len(spaces), 1)
    while ok:
        sh = it.get()
        g = sh.geometry
        v = np.asarray(g.verts, dtype=np.float64).reshape(-1, 3) - off
        t = np.asarray(g.faces, dtype=np.int64).reshape(-1, 3)
        mids = np.asarray(g.material_ids, dtype=np.int64)
        transp = np.array([float(getattr(m, "transparency", 0.0) or 0.0) for m in g.materials] + [0.0])
        if len(mids) == len(t):
            style = np.where((mids >= 0) & (mids < len(transp) - 1), mids, -1)
            glass = transp[style] >= params.glass_transparency
        else:
            glass = np.zeros(len(t), bool)
        if len(t):
            raw[int(sh.id)] = (v, t, glass)
        if len(raw) % 32 == 0:
            prog(0.9 * len(raw) / n, "tessellating")
        ok = it.next()
    if not raw:
        raise FormatError("no element of the IFC file could be tessellated", path)
    elements = []
    for e in sorted(chosen, key=lambda x: x.id()):
        if e.id() not in raw:
            continue
        v, t, glass = raw[e.id()]
        role = (_WALL if _is(e, params.wall_classes) else _SURFACE if _is(e, params.surface_classes)
                else _DOOR if e.is_a("IfcDoor") else _WINDOW if e.is_a("IfcWindow") else _CLUTTER)
        axis = None
        if role == _DOOR and e.ObjectPlacement is not None:
            x = up.get_local_placement(e.ObjectPlacement)[:2, 0]
            axis = x / max(float(np.linalg.norm(x)), 1e-12)
        elements.append(IfcElementMesh(e.GlobalId, e.is_a(), e.Name or "", role, v, t, glass, axis,
                                       _common_external(e, ue)))
    areas = []
    for s in sorted(spaces, key=lambda x: x.id()):
        if s.id() not in raw:
            log.warning("%s: space %s (%s) has no geometry", path, s.GlobalId, s.LongName or s.Name)
            continue
        v, t, _ = raw[s.id()]
        fp = _plan_union(v, t)
        if fp.geom_type == "MultiPolygon":
            fp = max(fp.geoms, key=lambda p: p.area)
        if fp.is_empty:
            continue
        areas.append(IfcSpaceArea(s.GlobalId, s.LongName or s.Name or "", fp, float(v[:, 2].min()),
                                  float(v[:, 2].max())))
    prog(1.0, "tessellated")
    return IfcGeometry(path, tuple(elements), tuple(areas), off)


# ----------------------------------------------------------------------------- mesh
def _components(tri: np.ndarray, nv: int) -> np.ndarray:
    """Connected-component label of each triangle (triangles sharing a vertex connect)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    a = np.concatenate([tri[:, 0], tri[:, 1]])
    b = np.concatenate([tri[:, 1], tri[:, 2]])
    _, lab = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(nv, nv)), directed=False)
    return lab[tri[:, 0]]


def _covers(q: np.ndarray, c: np.ndarray) -> bool:
    """True when one of the triangles ``q`` (m, 3, 2) contains the point ``c`` (2,)."""
    a, b, d = q[:, 0], q[:, 1], q[:, 2]

    def side(p1, p2):
        return (p2[:, 0] - p1[:, 0]) * (c[1] - p1[:, 1]) - (p2[:, 1] - p1[:, 1]) * (c[0] - p1[:, 0])

    s1, s2, s3 = side(a, b), side(b, d), side(d, a)
    return bool((((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))).any())


def _leaf_triangles(el: IfcElementMesh, tol: float) -> np.ndarray:
    """(m,) bool: triangles of a door's parts inside its frame (leaf, handles, bars), and of
    any part that covers the middle of the door's elevation (a leaf that fits its frame
    closer than ``tol``; a frame is a ring and leaves the middle open)."""
    v, t = el.vertices, el.triangles
    u = el.axis if el.axis is not None else np.array([1.0, 0.0])
    pu = v[:, :2] @ u
    lo, hi, top = pu.min(), pu.max(), v[:, 2].max()
    mid = np.array([(lo + hi) / 2, (v[:, 2].min() + top) / 2])
    elev = np.stack([pu, v[:, 2]], axis=1)
    comp = _components(t, len(v))
    leaf = np.zeros(len(t), bool)
    for c in np.unique(comp):
        k = comp == c
        idx = np.unique(t[k])
        inside = pu[idx].min() > lo + tol and pu[idx].max() < hi - tol and v[idx, 2].max() < top - tol
        if inside or _covers(elev[t[k]], mid):
            leaf |= k
    return leaf


def _door_open(el: IfcElementMesh, params: IfcSceneParams) -> bool:
    closed = set(params.closed_doors)
    return not (el.guid in closed or (el.name and el.name in closed)
                or (params.close_exterior_doors and bool(el.external)))


def ifc_scene_mesh(source, params: IfcSceneParams = IfcSceneParams(), *,
                   open_doors: Optional[Collection[str]] = None) -> SceneMesh:
    """The triangle mesh a scanner in the building sees, labelled (see module doc).

    Parameters
    ----------
    source : path of an .ifc file, or its :class:`IfcGeometry`.
    params : IfcSceneParams
    open_doors : GlobalIds of the open doors; default: by ``params`` (``closed_doors``,
        ``close_exterior_doors``).

    Returns
    -------
    SceneMesh — ``wall_index``: element index of wall triangles (-1 otherwise);
    ``room_index``: element index (into ``IfcGeometry.element_ids``) of every triangle,
    -1 for the ground and the surroundings.
    """
    geo = source if isinstance(source, IfcGeometry) else ifc_geometry(source, params)
    vs, ts, labs, walls, elems = [], [], [], [], []
    nv = 0

    def add(v, t, lab, wall, elem):
        nonlocal nv
        vs.append(v)
        ts.append(t + nv)
        nv += len(v)
        labs.append(lab.astype(np.int32))
        walls.append(np.full(len(t), wall, np.int32))
        elems.append(np.full(len(t), elem, np.int32))

    for i, el in enumerate(geo.elements):
        v, t = el.vertices, el.triangles
        keep = ~el.glass
        if el.role == _DOOR:
            is_open = _door_open(el, params) if open_doors is None else el.guid in set(open_doors)
            if is_open:
                keep &= ~_leaf_triangles(el, params.frame_tolerance)
        t = t[keep]
        if len(t) == 0:
            continue
        if el.role == _SURFACE:
            cr = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
            nz = cr[:, 2] / np.maximum(np.linalg.norm(cr, axis=1), 1e-12)
            lab = np.where(nz >= params.horizontal_nz, LABEL_FLOOR,
                           np.where(nz <= -params.horizontal_nz, LABEL_CEILING, LABEL_WALL))
        elif el.role in (_WALL, _DOOR, _WINDOW):
            lab = np.full(len(t), LABEL_WALL)
        else:
            lab = np.full(len(t), LABEL_CLUTTER)
        add(v, t, lab, i if el.role == _WALL else -1, i)
    if not vs:
        raise InputError(f"{geo.path}: no element is left to scan", geo.path)
    allv = np.vstack(vs)
    lo, hi = allv.min(axis=0), allv.max(axis=0)
    floors = [s.floor_z for s in geo.spaces]
    zg = (min(floors) if floors else lo[2]) - params.ground_offset
    m = params.ground_margin
    g = np.array([[lo[0] - m, lo[1] - m, zg], [hi[0] + m, lo[1] - m, zg], [hi[0] + m, hi[1] + m, zg],
                  [lo[0] - m, hi[1] + m, zg]])
    add(g, np.array([[0, 1, 2], [0, 2, 3]]), np.full(2, LABEL_CLUTTER), -1, -1)
    d, zt = params.surroundings_distance, zg + params.surroundings_height
    ring = [(lo[0] - d, lo[1] - d), (hi[0] + d, lo[1] - d), (hi[0] + d, hi[1] + d), (lo[0] - d, hi[1] + d)]
    for (x0, y0), (x1, y1) in zip(ring, ring[1:] + ring[:1]):
        q = np.array([[x0, y0, zg], [x1, y1, zg], [x1, y1, zt], [x0, y0, zt]])
        add(q, np.array([[0, 1, 2], [0, 2, 3]]), np.full(2, LABEL_CLUTTER), -1, -1)
    return SceneMesh(np.vstack(vs), np.vstack(ts).astype(np.int32), np.concatenate(labs),
                     np.concatenate(walls), np.concatenate(elems))


# ----------------------------------------------------------------------------- positions
class _Rays:
    """Ray queries against a scene mesh (open3d): distance and label of the first hit."""

    def __init__(self, mesh: SceneMesh):
        o3d = open3d("IFC scene scanner positions")
        self.o3d = o3d
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                                 o3d.core.Tensor(mesh.triangles.astype(np.uint32)))
        self.labels = mesh.labels

    def cast(self, origins: np.ndarray, direction) -> tuple[np.ndarray, np.ndarray]:
        o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
        rays = np.empty((len(o), 6), np.float32)
        rays[:, :3] = o
        rays[:, 3:] = np.asarray(direction, dtype=np.float64).reshape(-1, 3)
        ans = self.scene.cast_rays(self.o3d.core.Tensor(rays))
        t = ans["t_hit"].numpy().astype(np.float64)
        hit = np.isfinite(t)
        prim = np.where(hit, ans["primitive_ids"].numpy().astype(np.int64), 0)
        return t, np.where(hit, self.labels[prim], -1)

    def free(self, pts: np.ndarray, height: float, params: IfcSceneParams, clearance: float,
             floor_labels=(LABEL_FLOOR,)) -> np.ndarray:
        """(n,) bool: scanner positions ``pts`` (``height`` above their floor) with floor below,
        cover above and nothing within ``clearance`` horizontally at the probe heights."""
        if len(pts) == 0:
            return np.zeros(0, bool)
        td, ld = self.cast(pts, (0.0, 0.0, -1.0))
        ok = np.isin(ld, floor_labels) & (np.abs(td - height) <= params.floor_tolerance)
        tu, _ = self.cast(pts, (0.0, 0.0, 1.0))
        ok &= np.isfinite(tu) & (tu >= params.ceiling_clearance)
        if clearance > 0:
            k = max(int(params.probe_directions), 1)
            for z in tuple(params.probe_heights) + (height,):
                o = pts + np.array([0.0, 0.0, z - height])
                for j in range(k):
                    a = 2 * math.pi * j / k
                    t, _ = self.cast(o, (math.cos(a), math.sin(a), 0.0))
                    ok &= ~(t < clearance)
        return ok


def _spread(cands: np.ndarray, k: int, iterations: int = 10) -> np.ndarray:
    """``k`` well-spread points among ``cands`` (farthest-point seeds, then k-means, snapped)."""
    k = min(k, len(cands))
    sel = [int(np.argmin(np.linalg.norm(cands - cands.mean(axis=0), axis=1)))]
    dist = np.linalg.norm(cands - cands[sel[0]], axis=1)
    for _ in range(k - 1):
        sel.append(int(np.argmax(dist)))
        dist = np.minimum(dist, np.linalg.norm(cands - cands[sel[-1]], axis=1))
    centres = cands[sel].copy()
    for _ in range(iterations if k > 1 else 0):
        lab = np.argmin(np.linalg.norm(cands[:, None] - centres[None], axis=2), axis=1)
        for c in range(k):
            if np.any(lab == c):
                centres[c] = cands[lab == c].mean(axis=0)
    return cands[np.argmin(np.linalg.norm(cands[:, None] - centres[None], axis=2), axis=0)]


def _tour(pts: np.ndarray) -> np.ndarray:
    """The points in nearest-neighbour order from the first (distinct points only)."""
    pts = np.unique(pts, axis=0) if len(pts) > 1 else pts
    order, left = [0], list(range(1, len(pts)))
    while left:
        d = np.linalg.norm(pts[left] - pts[order[-1]], axis=1)
        order.append(left.pop(int(np.argmin(d))))
    return pts[order]


def _grid(poly, step: float) -> np.ndarray:
    if poly.is_empty:
        return np.zeros((0, 2))
    x0, y0, x1, y1 = poly.bounds
    gx, gy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    return pts[shapely.contains_xy(poly, pts[:, 0], pts[:, 1])] if len(pts) else pts


_OPEN_GAP = 0.05
"""Mobile walk: two spaces whose footprints come this close (m) along ``_OPEN_WIDTH`` are one
open space (no wall between them) and the walk goes from one to the other."""
_OPEN_WIDTH = 0.6
"""Mobile walk: the shortest shared stretch (m) of two open spaces."""
_MOBILE_AREA = 10.0
"""Mobile walk: one way point per this much floor area (m², at least two per space)."""
_RELAXATION = (1.0, 0.5, 0.25)
"""Factors on the wall and clutter clearances when a space has no free spot."""


def _space_positions(sp: IfcSpaceArea, rays: _Rays, sparams: ScanParams, params: IfcSceneParams,
                     area_per: Optional[float] = None, least: int = 1) -> np.ndarray:
    """(k, 3) positions in one space, about one per ``area_per`` m² (default the scan's
    ``area_per_scan``, at least ``least``); empty when none is possible. More than one
    come in nearest-neighbour order from the first."""
    h = sparams.scanner_height
    z = sp.floor_z + h
    for f in _RELAXATION:
        xy = _grid(sp.footprint.buffer(-sparams.wall_clearance * f), sparams.position_grid)
        pts = np.column_stack([xy, np.full(len(xy), z)])
        ok = rays.free(pts, h, params, sparams.clutter_clearance * f)
        if ok.any():
            long_side = box_sides(sp.footprint)[1]
            k = max(least, math.ceil(sp.footprint.area / (area_per or sparams.area_per_scan)),
                    math.ceil(long_side / sparams.max_scan_spacing))
            return _tour(_spread(pts[ok], k))
    return np.zeros((0, 3))


def _approach(fp, c: np.ndarray, dist: float) -> np.ndarray:
    """The point of ``fp`` shrunk by ``dist`` (or less) nearest to ``c`` (plan, metres)."""
    for d in (dist, dist / 2, 0.0):
        inner = fp.buffer(-d) if d else fp
        if not inner.is_empty:
            p = inner.exterior.interpolate(inner.exterior.project(Point(c))) if inner.geom_type == "Polygon" \
                else nearest_points(inner, Point(c))[0]
            return np.asarray(p.coords[0])
    return np.asarray(c, dtype=np.float64)


def _walk(spaces: list, per: dict, links: dict, params: ScanParams) -> np.ndarray:
    """Plan way points (n, 2) of a depth-first walk over the spaces of one storey."""
    seen, way = set(), []
    fps = {s.guid: s.footprint for s in spaces}

    def visit(sid):
        seen.add(sid)
        way.extend(per[sid][:, :2])
        for other, c in links.get(sid, []):
            if other in seen:
                continue
            a = _approach(fps[sid], c, params.door_approach)
            b = _approach(fps[other], c, params.door_approach)
            way.extend([a, c, b])
            visit(other)
            way.extend([b, c, a, per[sid][0, :2]])

    walks = []
    for s in spaces:
        if s.guid in per and s.guid not in seen:
            way = []
            visit(s.guid)
            walks.append(np.asarray(way))
    out = []
    for w in walks:
        if len(w) == 1:
            out.append(w)
            continue
        seg = np.linalg.norm(np.diff(w, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        ts = np.arange(0.0, cum[-1] + 1e-9, params.path_step)
        out.append(np.column_stack([np.interp(ts, cum, w[:, 0]), np.interp(ts, cum, w[:, 1])]))
    return np.vstack(out) if out else np.zeros((0, 2))


def _few_positions(geometry: IfcGeometry, rays: _Rays, truth: Optional[BuildingModel], sparams: ScanParams,
                   params: IfcSceneParams) -> np.ndarray:
    """``sparams.positions_per_storey`` positions per storey (the truth's, else spaces with
    floors within 0.5 m): the most central free spot of each of its biggest spaces."""
    def storey(sp):
        if truth is not None and sp.guid in truth:
            return ("s", truth[sp.guid].storey)
        return ("z", round(sp.floor_z / 0.5))

    groups: dict = {}
    for sp in geometry.spaces:
        groups.setdefault(storey(sp), []).append(sp)
    one = replace(sparams, area_per_scan=math.inf, max_scan_spacing=math.inf)
    out = []
    for key in sorted(groups, key=lambda k: min(sp.floor_z for sp in groups[k])):
        k = 0
        for sp in sorted(groups[key], key=lambda sp: -sp.footprint.area):
            if k >= sparams.positions_per_storey:
                break
            xyz = _space_positions(sp, rays, one, params)
            if len(xyz):
                out.append(xyz[:1])
                k += 1
    return np.vstack(out) if out else np.zeros((0, 3))


def ifc_scanner_positions(geometry: IfcGeometry, mesh: SceneMesh, truth: Optional[BuildingModel] = None,
                          scan_params: ScanParams = ScanParams(),
                          params: IfcSceneParams = IfcSceneParams()) -> np.ndarray:
    """Scanner origins (k, 3) float64, metres, in the scene's frame.

    Terrestrial (``scan_params.mode == "tls"``): per IfcSpace, ``max(area / area_per_scan,
    long side / max_scan_spacing, 1)`` positions spread over its footprint shrunk by
    ``wall_clearance``, ``scanner_height`` above its floor, where the floor is below, a
    ceiling at least ``ceiling_clearance`` above and no element within ``clutter_clearance``
    (clearances relaxed to 1/2, 1/4 when nothing fits); with ``positions_per_storey``, only
    that many per storey, at the most central spot of its biggest spaces. A space without any such spot (open
    air above, a stair well) gets none. Mobile: every ``path_step`` along a depth-first walk
    per storey through the spaces' terrestrial positions and the open doors of ``truth``
    (and its doorless connections) between them, kept where ``path_wall_clearance`` from
    walls and ``path_clutter_clearance`` from other elements (``truth`` default:
    :func:`ifc_truth` of the geometry's file, read only for a mobile walk).

    Raises InputError for an unknown scan mode.
    """
    rays = _Rays(mesh)
    h = scan_params.scanner_height
    if scan_params.mode == "tls" and scan_params.positions_per_storey is not None:
        return _few_positions(geometry, rays, truth, scan_params, params)
    per = {}
    for sp in geometry.spaces:
        xyz = _space_positions(sp, rays, scan_params, params)
        if len(xyz):
            per[sp.guid] = xyz
        else:
            log.warning("%s: space %s (%s) has no free spot for a scanner; it stays unscanned",
                        geometry.path, sp.guid, sp.name)
    if scan_params.mode == "tls":
        return np.vstack(list(per.values())) if per else np.zeros((0, 3))
    if scan_params.mode != "mobile":
        raise InputError(f"scan mode must be 'tls' or 'mobile', not {scan_params.mode!r}")
    for sp in geometry.spaces:  # the walk wanders through each space
        if sp.guid in per:
            per[sp.guid] = _space_positions(sp, rays, scan_params, params, _MOBILE_AREA, 2)
    if truth is None:
        truth = ifc_truth(geometry.path, params)
    by_id = {s.guid: s for s in geometry.spaces}
    storey = {s.guid: truth[s.guid].storey if s.guid in truth else -1 for s in geometry.spaces}
    links: dict = {}

    def link(a, b, c):
        if a in per and b in per and storey[a] == storey[b]:
            links.setdefault(a, []).append((b, c))
            links.setdefault(b, []).append((a, c))

    for d in truth.doors:
        sp = [x for x in d.attributes.get("spaces", []) if x in by_id]
        if d.attributes.get("open", True) and len(sp) == 2:
            link(sp[0], sp[1], np.asarray(d.centroid[:2]))
    gap = _OPEN_GAP
    for i, a in enumerate(geometry.spaces):  # spaces that touch without a wall between them
        for b in geometry.spaces[i + 1:]:
            shared = a.footprint.buffer(gap / 2).intersection(b.footprint.buffer(gap / 2))
            if not shared.is_empty and shared.area / gap >= _OPEN_WIDTH:
                link(a.guid, b.guid, np.asarray(shared.centroid.coords[0]))
    out = []
    doors = [d for d in truth.doors if d.attributes.get("open", True)]
    for k in sorted(set(storey.values())):
        spaces = [s for s in geometry.spaces if storey[s.guid] == k]
        xy = _walk(spaces, per, links, scan_params)
        if not len(xy):
            continue
        region = unary_union([s.footprint.buffer(-scan_params.path_wall_clearance) for s in spaces] +
                             [Polygon(d.footprint()).buffer(scan_params.path_wall_clearance / 4)
                              for d in doors if d.footprint() is not None and d.storey == k])
        xy = xy[shapely.contains_xy(region, xy[:, 0], xy[:, 1])]
        floors = np.array([[s.footprint.distance(Point(p)) for s in spaces] for p in xy]).reshape(len(xy), -1)
        z = np.array([s.floor_z for s in spaces])[np.argmin(floors, axis=1)] + h if len(xy) else np.zeros(0)
        pts = np.column_stack([xy, z])
        ok = rays.free(pts, h, params, scan_params.path_clutter_clearance, (LABEL_FLOOR, LABEL_WALL))
        out.append(pts[ok])
    return np.vstack(out) if out else np.zeros((0, 3))


# ----------------------------------------------------------------------------- truth, scene
def ifc_truth(path: Union[str, os.PathLike], params: IfcSceneParams = IfcSceneParams(), *, read_params=None,
              progress=None, should_stop=None) -> BuildingModel:
    """The true model of an IFC file: :func:`engine.ifc.read_ifc` (walls, slabs, spaces,
    doors, windows with their attributes; ``read_params`` default: ``params.threads``
    tessellation threads) with each door's ``open`` flag set by :func:`ifc_door_states`."""
    if read_params is None:
        read_params = IfcReadParams(threads=params.threads)
    m = read_ifc(path, params=read_params, progress=progress, should_stop=should_stop)
    return ifc_door_states(m, params)


def ifc_door_states(model: BuildingModel, params: IfcSceneParams = IfcSceneParams()) -> BuildingModel:
    """The model with ``attributes["open"]`` of every door set by ``params``: closed when its
    id or name is in ``closed_doors``, or it leads outside and ``close_exterior_doors``."""
    closed = set(params.closed_doors)
    upd = []
    for d in model.doors:
        sp = d.attributes.get("spaces") or []
        ext = any(x not in model and str(x).startswith("exterior") or x in model and
                  model[x].type == ShapeType.EXTERIOR for x in sp)
        shut = d.id in closed or (d.name and d.name in closed) or (params.close_exterior_doors and ext)
        is_open = not shut
        upd.append(d.with_(attributes={**d.attributes, "open": bool(is_open)}))
    return model.replace_shapes(*upd)


def _resolve(name_or_path) -> tuple[str, str]:
    s = os.fspath(name_or_path)
    if not os.path.exists(s) and s.strip().lower() in IFC_SCENES:
        return s.strip().lower(), ifc_scene_path(s)
    return os.path.splitext(os.path.basename(s))[0], s


def ifc_scene(name_or_path: Union[str, os.PathLike], *, seed: int = 0, noise: Union[str, float] = "tls",
              target_points: int = 300_000, params: IfcSceneParams = IfcSceneParams(),
              truth: Optional[BuildingModel] = None, geometry: Optional[IfcGeometry] = None,
              positions_per_storey: Optional[int] = None, progress=None, should_stop=None) -> IfcScene:
    """Scan a real IFC building model like the synthetic presets.

    Parameters
    ----------
    name_or_path : an .ifc path, or "fzk_haus" / "duplex" (the sample files in a source
        checkout's ``tests/data``, see :func:`ifc_scene_path`).
    seed : seeds the scan's azimuth offsets and range noise.
    noise : "tls" (σ = 5 mm, positions per space), "mobile" (σ = 2 cm, a walk through the
        doors) or a σ in metres (terrestrial).
    target_points : about how many points the scan has.
    params : IfcSceneParams
    truth, geometry : :func:`ifc_truth` (with the same ``params``) and :func:`ifc_geometry`
        (with ``offset=truth.offset``) of this file, when already made (several scans of
        one building).
    positions_per_storey : terrestrial only: at most this many scanner positions per storey,
        in its biggest spaces (:attr:`ScanParams.positions_per_storey`; 1: single-position scans).

    Returns
    -------
    IfcScene — cloud in metres, z up, in the truth's frame.

    Raises
    ------
    InputError — unknown name, missing file, bad noise, or no space fits a scanner.
    FormatError — the file is not readable IFC.
    """
    prog = Progress.wrap(progress, should_stop)
    name, path = _resolve(name_or_path)
    target = int(target_points)
    if target <= 0:
        raise InputError(f"target_points must be positive, not {target_points!r}")
    sparams = scan_params_for(noise, target)
    if positions_per_storey is not None:
        sparams = replace(sparams, positions_per_storey=int(positions_per_storey))
    timings = {}
    t0 = time.perf_counter()
    if truth is None:
        truth = ifc_truth(path, params, progress=prog.sub(0.0, 0.3))
        timings["truth_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    geo = geometry
    if geo is None:
        geo = ifc_geometry(path, params, offset=truth.offset, progress=prog.sub(0.3, 0.6))
        timings["tessellate_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    mesh = ifc_scene_mesh(geo, params, open_doors={d.id for d in truth.doors if d.attributes.get("open")})
    timings["mesh_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    pos = ifc_scanner_positions(geo, mesh, truth, sparams, params)
    timings["positions_s"] = time.perf_counter() - t0
    if len(pos) == 0:
        raise InputError(f"{path}: no space has room for a scanner", path)
    t0 = time.perf_counter()
    rng = np.random.default_rng(np.random.SeedSequence(int(seed)).spawn(2)[1])
    res = scan_mesh(mesh, pos, sparams, rng=rng, source=f"ifc:{name}", progress=prog.sub(0.65, 1.0))
    timings["scan_s"] = time.perf_counter() - t0
    cloud = res.cloud.with_(fields={**res.cloud.fields, "element": res.room_index.astype(np.int32)},
                            source=f"ifc:{name}:seed={seed}")
    prog(1.0, "done")
    return IfcScene(name=name, seed=int(seed), noise_sigma=sparams.sigma, cloud=cloud, truth=truth, path=path,
                    positions=pos, element_ids=geo.element_ids, scan_params=sparams, timings=timings)
